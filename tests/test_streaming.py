"""shoot and forest --test stream: the first result row appears while the
input is still open, memory does not grow with the row count, output bytes
are those of the previous all-in-memory version (hashes recorded from it on
the same seeded inputs), and a bad row late in the input changes no file."""
import hashlib
import os
import random
import select
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BIN = os.environ.get("POOLREPS", str(ROOT / "build" / "rel" / "poolreps"))
PY = os.environ.get("PYTHON", sys.executable)
ROWS = ROOT / "scripts" / "shoot_rows.py"


def run(args, cwd, **kw):
    return subprocess.run([BIN] + [str(a) for a in args], cwd=cwd, capture_output=True,
                          env=dict(os.environ, LC_ALL="C"), timeout=600, **kw)


def rows(tmp, n, seed, name="in.csv"):
    with open(tmp / name, "wb") as f:
        subprocess.run([PY, str(ROWS), str(n), str(seed)], stdout=f, check=True)
    return tmp / name


def snapshot(d):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in Path(d).iterdir()}


def forest_inputs(tmp):
    r = random.Random(3)
    tr = ["s0,s1,a0,a1,w"] + ["%.4f,%.4f,%.4f,%.4f,%.3f" % (r.random(), r.random(), r.random(),
                                                         r.random(), 1 + r.random()) for _ in range(300)]
    te = ["s0,s1,a0"] + ["%.4f,%.4f,%.4f" % (r.random(), r.random(), r.random()) for _ in range(20000)]
    (tmp / "tr.csv").write_text("\n".join(tr) + "\n")
    (tmp / "te.csv").write_text("\n".join(te) + "\n")


# sha256 of the previous (all-in-memory) version's output on these inputs
PREV = {
    "shoot_keep": "c742a33f2f769ac3d29f6946045232828a4be5c7304887cc577d688b5d150539",
    "forest_pred": "162e15a95126859630b3323ab97ff0f23a975a0e5439c72ab0a371b7573a7fb0",
    "forest_leaves": "1b2a5ee323c5a220e90bbb6023327afa25a9bc254f760d8e3360faa271ee5440",
}


def test_shoot_bytes_are_the_previous_versions(tmp_path):
    rows(tmp_path, 20000, 7)
    r = run(["shoot", "-i", "in.csv", "--keep", "-q"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert hashlib.sha256(r.stdout).hexdigest() == PREV["shoot_keep"]
    # the same bytes through a file, a pipe as input, and with a trace
    r2 = run(["shoot", "--keep", "-q", "-o", "o.csv", "--trace", "t.csv"], tmp_path,
             stdin=open(tmp_path / "in.csv", "rb"))
    assert r2.returncode == 0, r2.stderr
    assert (tmp_path / "o.csv").read_bytes() == r.stdout


def test_forest_test_bytes_are_the_previous_versions(tmp_path):
    forest_inputs(tmp_path)
    base = ["forest", "--train", "tr.csv", "--test", "te.csv", "--target", "a0,a1", "--weight", "w",
            "--set", "forest.trees=20", "-q"]
    r = run(base, tmp_path)
    assert r.returncode == 0, r.stderr
    assert hashlib.sha256(r.stdout).hexdigest() == PREV["forest_pred"]
    r = run(base + ["--leaves", "/dev/stdout", "-o", "/dev/null"], tmp_path)
    assert hashlib.sha256(r.stdout).hexdigest() == PREV["forest_leaves"]


@pytest.mark.parametrize("cmd", ["shoot", "forest"])
def test_first_row_before_the_input_ends(cmd, tmp_path):
    if cmd == "shoot":
        args, head, line = ["shoot", "-q"], b"x0,y0,x1,y1,vx,vy\n", b"-0.25,0,0.1,0,0.6,0.03\n"
    else:
        forest_inputs(tmp_path)
        args, head, line = (["forest", "--train", "tr.csv", "--test", "-", "--target", "a0,a1", "-q",
                             "--set", "forest.trees=5"], b"s0,s1,w\n", b"0.5,0.5,1\n")
    p = subprocess.Popen([BIN] + args, cwd=tmp_path, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE)
    p.stdin.write(head + line)
    p.stdin.flush()
    got = b""
    while got.count(b"\n") < 2:
        ready, _, _ = select.select([p.stdout], [], [], 30)
        assert ready, "no result row while the input stays open"
        got += os.read(p.stdout.fileno(), 65536)
    assert p.poll() is None  # still reading
    p.stdin.write(line)
    p.stdin.close()
    rest = p.stdout.read()
    assert p.wait() == 0, p.stderr.read()
    assert (got + rest).count(b"\n") == 3


@pytest.mark.parametrize("out", ["file", "pipe"])
def test_bad_row_late_in_the_input(out, tmp_path):
    src = rows(tmp_path, 50000, 2).read_bytes()
    bad = src + b"9,9,0.1,0,0.2,0,0.3,0,0.5,0\n" + src.split(b"\n", 1)[1]
    (tmp_path / "in.csv").write_bytes(bad)
    (tmp_path / "o.csv").write_bytes(b"keep\n")
    before = snapshot(tmp_path)
    if out == "file":
        r = run(["shoot", "-i", "in.csv", "-o", "o.csv", "--trace", "t.csv"], tmp_path)
    else:
        r = run(["shoot", "-i", "in.csv"], tmp_path)
    assert r.returncode == 1
    assert r.stderr.decode().count("\n") == 1 and "in.csv:50002:" in r.stderr.decode()
    assert snapshot(tmp_path) == before  # no output changed, no temporary file left
    if out == "pipe":
        # exactly the rows before the bad one: the header and 50000 results
        assert r.stdout.count(b"\n") == 50001 and r.stdout.endswith(b"\n")


def peak_kib(tmp, n):
    rows(tmp, n, 1)
    r = subprocess.run(["/usr/bin/time", "-f", "%M", BIN, "shoot", "-i", "in.csv", "-o", "/dev/null"],
                       cwd=tmp, capture_output=True, timeout=900)
    assert r.returncode == 0, r.stderr
    (tmp / "in.csv").unlink()
    return int(r.stderr.decode().split()[-1])


@pytest.mark.native
@pytest.mark.slow
def test_peak_memory_does_not_grow_with_rows(tmp_path):
    if not shutil.which("/usr/bin/time") or os.environ.get("POOLREPS_WRAPPER"):
        pytest.skip("needs /usr/bin/time and the bare binary")
    small, big = peak_kib(tmp_path, 100000), peak_kib(tmp_path, 2000000)
    assert big <= 1.5 * small, (small, big)
