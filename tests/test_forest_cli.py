"""End-to-end tests of `poolreps forest` (the `forest` command of docs/forest.md).

The binary is $POOLREPS (default ./poolreps at the repository root); run
with LC_ALL=C.
"""
import csv
import os
import random
import sys
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


@pytest.mark.parametrize("multi", [False, True])
def test_weight_scale_changes_no_byte(tmp_path, multi):
    """Weights times 1e-170, 1e160, 1e-300, 1e300 or 2^-500 (one weight
    in eight 1e-3 of the others) give the same predictions, byte for byte:
    a weighted score squares weighted sums, which underflowed or overflowed
    at those scales and grew other trees (predictions 0.7 apart)."""
    rnd = random.Random(11)
    rows = []
    for _ in range(300):
        x = [rnd.random() for _ in range(3)]
        y = [x[0] ** 2 + x[1] + rnd.gauss(0, 0.1), x[2] - x[0] + rnd.gauss(0, 0.1)]
        rows.append((x, y, rnd.expovariate(1.0) * (1e-3 if rnd.random() < 0.125 else 1.0)))
    test = "x0,x1,x2\n" + "".join(",".join(repr(rnd.random()) for _ in range(3)) + "\n"
                                   for _ in range(60))
    target = "y0,y1" if multi else "y0"
    preds = set()
    for scale in (1.0, 1e-170, 1e160, 1e-300, 1e300, 2.0 ** -500):
        train = f"x0,x1,x2,{target},w\n" + "".join(
            ",".join(repr(v) for v in [*x, *y[:1 + multi], w * scale]) + "\n" for x, y, w in rows)
        forest(tmp_path, train, test, target, "--weight", "w", "-q")
        preds.add((tmp_path / "pred.csv").read_bytes())
    assert len(preds) == 1


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


def test_constant_columns_block_matches_its_csv():
    """docs/forest.md's table of K = d without replacement against
    scikit-learn on inputs constant in many nodes is what
    scripts/bench_forest_constant.py makes of its committed CSV."""
    r = run_cmd([sys.executable, str(ROOT / "scripts" / "bench_forest_constant.py"), "--check"],
                capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
