"""Learner state files (`poolreps learner ... STATE`) from a hostile hand,
like saved forests (test_forest_file.py): the state is read whole only from
a regular file (a FIFO, a device or a folder is refused at once, a file of
another kind after its first bytes), and every count in it is checked
against the bytes the file has left before anything is allocated for it.
Each refusal: exit 2, one stderr line naming the file, nothing written."""
import os
import struct

import numpy as np
import pytest

from test_safety import IO, SAN, changed, one_line, peak_kib, run, snapshot

# the counters after the options: dx, da, dy, dg, iteration, oldest policy, policies
COUNTS = 17 + 4 + 28 * 4 + 7 * 8  # magic line, version, 28 int32 options, 7 doubles


def state(tmp_path):
    r = run(["learner", "new", "st", "--context", "x,y", "--action", "a,b", "--seed", "3"], tmp_path)
    assert r.returncode == 0, r.stderr
    good = (tmp_path / "st").read_bytes()
    assert struct.unpack_from("<7i", good, COUNTS) == (2, 2, 0, 0, 0, 0, 1)
    return good


def ask(tmp_path, path):
    np.savetxt(tmp_path / "c.csv", np.zeros((3, 2)), delimiter=",", header="x,y", comments="")
    before = snapshot(tmp_path)
    r = run(["learner", "ask", path, "-i", "c.csv", "-o", "o.csv"], tmp_path, timeout=30)
    assert changed(before, snapshot(tmp_path)) == set()
    return r


@pytest.mark.parametrize("path", ["fifo", "/dev/zero", "folder"])
def test_state_that_is_not_a_regular_file_is_refused(path, tmp_path):
    """A FIFO without a writer does not block; /dev/zero is not read."""
    if path == "fifo":
        os.mkfifo(tmp_path / "fifo")
    elif path == "folder":
        (tmp_path / "folder").mkdir()
    r = ask(tmp_path, path)
    assert r.returncode == IO, r.stderr
    assert one_line(r) == f"poolreps: {path}: not a regular file\n", r.stderr


def test_counts_beyond_the_file_are_refused_before_allocating(tmp_path):
    """Two billion policies in a 5 kB state: refused as truncated, not an
    allocation of hundreds of GB (exit 4, "out of memory")."""
    good = state(tmp_path)
    bad = bytearray(good)
    struct.pack_into("<3i", bad, COUNTS + 16, 2000000000, 0, 2000000001)
    (tmp_path / "bad").write_bytes(bytes(bad))
    r = ask(tmp_path, "bad")
    assert r.returncode == IO, r.stderr
    line = one_line(r)
    assert line == (f"poolreps: bad: not a valid learner state: truncated (2000000001 policies, "
                    f"more than its {len(good)} bytes hold)\n"), line


def test_another_file_is_not_read_whole(tmp_path):
    """A large file given as STATE by mistake: refused after its first
    bytes, so the peak memory stays far below the file's size."""
    if SAN:
        pytest.skip("AddressSanitizer's shadow memory changes the resident size")
    with open(tmp_path / "big.csv", "wb") as f:
        f.write(b"x,y\n")
        f.truncate(300 << 20)
    np.savetxt(tmp_path / "c.csv", np.zeros((3, 2)), delimiter=",", header="x,y", comments="")
    peak, err = peak_kib(["learner", "ask", "big.csv", "-i", "c.csv", "-o", "o.csv"], cwd=tmp_path)
    assert err.decode() == "poolreps: big.csv: not a poolreps learner state\n", err
    assert peak < 100 * 1024, f"peak {peak} KiB"
    assert not (tmp_path / "o.csv").exists()


@pytest.mark.parametrize("value", [float("nan"), float("inf")])
def test_a_log_density_that_no_policy_gives_is_refused(value, tmp_path):
    """A stored log pi_m(a|s) is finite or -inf (zero density); NaN or +inf
    (a forged or damaged state) is refused when the state is read, naming
    it, not by a later tell as a bad parameter (exit 1) without the file."""
    state(tmp_path)
    np.savetxt(tmp_path / "c.csv", np.linspace(-1, 1, 40).reshape(20, 2), delimiter=",",
               header="x,y", comments="")
    assert run(["learner", "ask", "st", "-i", "c.csv", "-o", "a.csv"], tmp_path).returncode == 0
    a = np.loadtxt(tmp_path / "a.csv", delimiter=",", skiprows=1)
    ret = -np.arange(20) / 7.0
    np.savetxt(tmp_path / "e.csv", np.c_[a, ret], delimiter=",", header="x,y,a,b,ret",
               comments="", fmt="%.17g")
    assert run(["learner", "tell", "st", "--return", "ret", "-i", "e.csv"], tmp_path).returncode == 0
    good = (tmp_path / "st").read_bytes()
    # the window: contexts, actions, returns, then each episode's log-densities
    at = good.index(struct.pack("<20d", *ret)) + 20 * 8
    bad = bytearray(good)
    struct.pack_into("<d", bad, at, value)
    (tmp_path / "bad").write_bytes(bytes(bad))
    for verb in (["mean", "bad", "-i", "c.csv"], ["tell", "bad", "--return", "ret", "-i", "e.csv"]):
        before = snapshot(tmp_path)
        r = run(["learner"] + verb, tmp_path)
        assert r.returncode == IO, r.stderr
        assert one_line(r) == "poolreps: bad: not a valid learner state: a log-density is NaN or +inf\n"
        assert changed(before, snapshot(tmp_path)) == set()
