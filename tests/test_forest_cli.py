"""End-to-end tests of `poolreps forest` (SPEC.md §6, issue 3 items 3 and 5).

The binary is $POOLREPS (default ./poolreps at the repository root); run
with LC_ALL=C.
"""
import csv
import os
import random
from pathlib import Path

import pytest
from conftest import run_cmd

ROOT = Path(__file__).resolve().parent.parent
BIN = os.environ.get("POOLREPS", str(ROOT / "poolreps"))

# x = 0..9, y = [x >= 5], z = 2 y - 1; a zero-weight outlier at x = 2.5
STEP = "x,y,z\n" + "".join(f"{i},{int(i >= 5)},{2 * int(i >= 5) - 1}\n" for i in range(10))
STEP1 = "x,y\n" + "".join(f"{i},{int(i >= 5)}\n" for i in range(10))
OUTLIER = "x,y,w\n" + "".join(f"{i},{int(i >= 5)},{1 + i % 3}\n" for i in range(10)) \
    + "2.5,100,0\n"
EXACT = ["--set", "forest.cuts=200", "--set", "forest.n_min=5", "--set", "forest.trees=3"]


def run(args, cwd):
    env = dict(os.environ, LC_ALL="C")
    return run_cmd([BIN, "forest"] + args, capture_output=True, text=True, cwd=cwd,
                          env=env, timeout=60)


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def forest(tmp_path, train, test, target, *extra):
    tr = write(tmp_path, "train.csv", train)
    te = write(tmp_path, "test.csv", test)
    out = tmp_path / "pred.csv"
    r = run(["--train", tr, "--test", te, "--target", target, "-o", str(out), *extra], tmp_path)
    assert r.returncode == 0, r.stderr
    return read_csv(out), r


def test_known_split(tmp_path):
    rows, r = forest(tmp_path, STEP, "x,y,z\n3.5,0,-1\n5,1,1\n8,1,1\n", "y,z", *EXACT)
    assert list(rows[0]) == ["pred_y", "pred_z"]
    assert [float(row["pred_y"]) for row in rows] == [0.0, 1.0, 1.0]
    assert [float(row["pred_z"]) for row in rows] == [-1.0, 1.0, 1.0]
    line = r.stderr.strip()
    assert line.startswith("poolreps: forest: 3 trees, 6 leaves, fit ")
    assert "predict" in line and line.endswith("test MSE 0")


def test_prefix_target_quiet_and_no_mse(tmp_path):
    rows, r = forest(tmp_path, STEP.replace("x,y,z", "x,ya,yb"), "x\n3.5\n8\n", "y*", *EXACT)
    assert list(rows[0]) == ["pred_ya", "pred_yb"]
    assert [float(row["pred_yb"]) for row in rows] == [-1.0, 1.0]
    assert "test MSE" not in r.stderr and "fit" in r.stderr
    _, r = forest(tmp_path, STEP1, "x,y\n3.5,0\n", "y", "-q", *EXACT)
    assert r.stderr == ""


def test_leaves_file(tmp_path):
    tr = write(tmp_path, "train.csv", STEP1)
    te = write(tmp_path, "test.csv", "x\n1\n9\n")
    r = run(["--train", tr, "--test", te, "--target", "y", "--leaves", "leaves.csv",
             "-o", "pred.csv", *EXACT], tmp_path)
    assert r.returncode == 0, r.stderr
    # every tree splits once in (4, 5]: leaf 0 holds x < 5, leaf 1 the others
    leaves = read_csv(tmp_path / "leaves.csv")
    assert list(leaves[0]) == ["tree0", "tree1", "tree2"]
    assert [list(map(int, row.values())) for row in leaves] == [[0, 0, 0], [1, 1, 1]]


def test_weight_column(tmp_path):
    rows, _ = forest(tmp_path, OUTLIER, "x\n2.5\n8\n", "y", "--weight", "w",
                     "--set", "forest.cuts=200", "--set", "forest.n_min=6")
    # the zero-weight outlier neither moves the split nor the leaf means
    assert [float(row["pred_y"]) for row in rows] == [0.0, 1.0]


def test_seed(tmp_path):
    rnd = random.Random(5)
    train = "a,b,y\n" + "".join(f"{rnd.random()},{rnd.random()},{rnd.random()}\n"
                                for _ in range(200))
    test = "a,b\n" + "".join(f"{rnd.random()},{rnd.random()}\n" for _ in range(20))
    one, _ = forest(tmp_path, train, test, "y", "--seed", "3", "--set", "forest.cuts=1")
    two, _ = forest(tmp_path, train, test, "y", "--seed", "3", "--set", "forest.cuts=1")
    other, _ = forest(tmp_path, train, test, "y", "--seed", "4", "--set", "forest.cuts=1")
    assert one == two
    assert one != other


BAD = [
    # (train, test, extra args, words the one-line message must contain)
    ("x,y\n1,2\n3\n", "x\n1\n", [], ["train.csv:3", "fields"]),
    ("x,y\n1,2\n3,abc\n", "x\n1\n", [], ["train.csv:3", "'y'", "abc"]),
    ("x,y\n1,2\n3,4\n", "x\n1\nzz\n", [], ["test.csv:3", "'x'"]),
    ("x,y\n1,2\n3,4\n", "q\n1\n", [], ["test.csv", "'x'"]),
    ("x,v\n1,2\n3,4\n", "x\n1\n", [], ["train.csv", "'y'"]),
    ("x,y\n1,2\n3,4\n", "x\n1\n", ["--set", "forest.n_c=3"], ["train.csv", "forest.n_c"]),
    ("x,y\n1,2\n3,4\n", "x\n1\n", ["--set", "forest.cuts=0"], ["forest.cuts"]),
    ("x,y\n1,2\n3,4\n", "x\n1\n", ["--set", "forest.n_min=0"], ["forest.n_min"]),
    ("x,y,w\n1,2,1\n3,4,-1\n", "x\n1\n", ["--weight", "w"], ["train.csv:3", "'w'", ">= 0"]),
    ("x,y,w\n1,2,1\n3,4,inf\n", "x\n1\n", ["--weight", "w"], ["train.csv:3", "'w'"]),
    ("x,y,w\n1,2,0\n3,4,0\n", "x\n1\n", ["--weight", "w"], ["train.csv", "'w'", "zero"]),
    ("x,y\n1,2\n3,4\n", "x\n1\n", ["--weight", "nope"], ["train.csv", "'nope'"]),
    ("y\n1\n2\n", "x\n1\n", [], ["train.csv", "no input"]),
    ("x,y\n", "x\n1\n", [], ["train.csv", "no data"]),
]


@pytest.mark.parametrize("train,test,extra,words", BAD)
def test_bad_input(tmp_path, train, test, extra, words):
    tr = write(tmp_path, "train.csv", train)
    te = write(tmp_path, "test.csv", test)
    r = run(["--train", tr, "--test", te, "--target", "y", "-o", "pred.csv",
             "--leaves", "leaves.csv", *extra], tmp_path)
    assert r.returncode != 0
    lines = r.stderr.strip().split("\n")
    assert len(lines) == 1 and lines[0].startswith("poolreps: "), r.stderr
    for w in words:
        assert w in lines[0], lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["test.csv", "train.csv"]
