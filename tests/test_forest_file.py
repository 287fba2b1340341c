"""Saved forest files (docs/forest.md, "File format") from a hostile hand:
every reader (`forest --load`, Forest.from_text, unpickling) checks the
header's counts against what the file can hold before it allocates, so its
memory is bounded by the file's size; `--load` refuses what is not a
regular file and a file that is no forest after its first bytes; column
names are unique and fit a CSV header. Each refusal: exit 2, one stderr
line naming the file and line, nothing written or removed."""
import os
import pickle
import sys

import pytest

from conftest import ROOT
from test_safety import IO, SAN, TRAIN, binary, changed, one_line, peak_kib, run, snapshot

sys.path.insert(0, str(ROOT / "python"))

FOREST = ["forest", "--train", "tr.csv", "--test", "tr.csv", "--target", "y", "-q"]


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    d = tmp_path_factory.mktemp("saved")
    (d / "tr.csv").write_bytes(TRAIN)
    r = run(FOREST + ["--save", "f.txt", "-o", "p.csv"], d)
    assert r.returncode == 0, r.stderr
    return (d / "f.txt").read_bytes()


def sizes(text, line):
    """text with its sizes line replaced."""
    lines = text.split(b"\n")
    lines[1] = line
    return b"\n".join(lines)


def rename(text, old, new):
    return text.replace(b"\n" + old + b"\n", b"\n" + new + b"\n", 1)


# (id, edit of the saved text, the stderr needles)
BAD = [
    ("dup_input", lambda t: rename(t, b"input s1", b"input s0"), ("f.txt:4:", "'s0' appears twice")),
    ("dup_output_and_input", lambda t: rename(t, b"output y", b"output s1"),
     ("f.txt:5:", "'s1' appears twice")),
    ("control_in_name", lambda t: rename(t, b"input s1", b"input s\t1"), ("f.txt:4:", "control")),
    ("trailing_blank_name", lambda t: rename(t, b"input s1", b"input s1 "), ("f.txt:4:", "blank")),
    ("two_billion_samples", lambda t: sizes(t, b"trees 1 samples 2000000000 inputs 2 outputs 1 "
                                               b"nodes 1 leaves 1"), ("f.txt:2:", "more than the file")),
    ("million_nodes", lambda t: sizes(t, b"trees 30 samples 60 inputs 2 outputs 1 "
                                         b"nodes 3570 leaves 1800"), ("f.txt:2:", "more than the file")),
    ("huge_dims", lambda t: sizes(t, b"trees 30 samples 60 inputs 100000 outputs 100000 "
                                     b"nodes 438 leaves 234"), ("f.txt:2:", "more than the file")),
    # 2 * leaves overflows an int: refused, no signed overflow (SAN=1 checks)
    ("leaves_overflow", lambda t: sizes(t, b"trees 30 samples 60 inputs 2 outputs 1 "
                                           b"nodes 438 leaves 1500000000"), ("f.txt:2:", "inconsistent")),
    ("a_csv_by_mistake", lambda t: TRAIN * 1000, ("f.txt:1:", "not a poolreps forest file")),
]


@pytest.mark.parametrize("edit,needles", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_load_refuses(edit, needles, saved, tmp_path):
    (tmp_path / "tr.csv").write_bytes(TRAIN)
    (tmp_path / "f.txt").write_bytes(edit(saved))
    (tmp_path / "p.csv").write_bytes(b"old\n")
    before = snapshot(tmp_path)
    r = run(["forest", "--load", "f.txt", "--test", "tr.csv", "-o", "p.csv"], tmp_path)
    assert r.returncode == IO, r.stderr
    line = one_line(r)
    for n in needles:
        assert n in line, (n, line)
    assert changed(before, snapshot(tmp_path)) == set()


@pytest.mark.parametrize("edit,needles", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_from_text_and_unpickling_refuse(edit, needles, saved):
    if SAN and "libasan" not in os.environ.get("LD_PRELOAD", ""):
        pytest.skip("the sanitized library loads only with its runtimes preloaded")
    import poolreps
    text = edit(saved)
    with pytest.raises(OSError) as e:
        poolreps.Forest.from_text(text)
    assert needles[-1] in str(e.value)
    good = poolreps.Forest.from_text(saved)
    st = good.__getstate__()
    st["fit"]["text"] = text
    with pytest.raises(OSError):
        pickle.loads(pickle.dumps(good)).__setstate__(st)


def test_saved_forest_still_loads(saved, tmp_path):
    (tmp_path / "tr.csv").write_bytes(TRAIN)
    (tmp_path / "f.txt").write_bytes(saved)
    r = run(["forest", "--load", "f.txt", "--test", "tr.csv", "-o", "p.csv"], tmp_path)
    assert r.returncode == 0, r.stderr
    r2 = run(FOREST + ["-o", "q.csv"], tmp_path)
    assert (tmp_path / "p.csv").read_bytes() == (tmp_path / "q.csv").read_bytes()


@pytest.mark.parametrize("path", ["/dev/zero", "fifo"])
def test_load_refuses_what_is_not_a_regular_file(path, tmp_path):
    """/dev/zero is refused at once, not read until memory runs out; a FIFO
    without a writer does not block."""
    if SAN:
        pytest.skip("AddressSanitizer's shadow memory changes the resident size")
    (tmp_path / "tr.csv").write_bytes(TRAIN)
    if path == "fifo":
        os.mkfifo(tmp_path / "fifo")
    before = snapshot(tmp_path)
    peak, err = peak_kib(["forest", "--load", path, "--test", "tr.csv", "-o", "p.csv"], cwd=tmp_path)
    assert err.count(b"\n") == 1 and b"not a regular file" in err and path.encode() in err, err
    assert peak < 200 * 1024, f"peak {peak} KiB"
    assert changed(before, snapshot(tmp_path)) == set()


def test_wrong_file_is_not_read_whole(tmp_path):
    """A large CSV given to --load by mistake: refused after its first bytes,
    so the peak memory stays far below the file's size."""
    if SAN:
        pytest.skip("AddressSanitizer's shadow memory changes the resident size")
    (tmp_path / "tr.csv").write_bytes(TRAIN)
    with open(tmp_path / "big.csv", "wb") as f:
        f.truncate(300 << 20)   # sparse: no disk space used
    peak, err = peak_kib(["forest", "--load", "big.csv", "--test", "tr.csv", "-o", "p.csv"],
                         cwd=tmp_path)
    assert b"big.csv:1: not a poolreps forest file" in err, err
    assert peak < 100 * 1024, f"peak {peak} KiB"
    assert not (tmp_path / "p.csv").exists()


def test_sparse_terabyte_is_refused_before_any_allocation(tmp_path):
    """A sparse 1 TB file of zeros given to --load: refused by its first
    bytes (exit 2, one line, nothing written), never allocated for (an
    allocation of its size first would fail with "out of memory", exit 4).
    The huge file lies outside the folder snapshotted (hashing it would read
    it all)."""
    (tmp_path / "in").mkdir()
    (tmp_path / "work").mkdir()
    (tmp_path / "in" / "tr.csv").write_bytes(TRAIN)
    huge = tmp_path / "in" / "huge"
    with open(huge, "wb") as f:
        f.truncate(2**40)
    before = snapshot(tmp_path / "work")
    r = run(["forest", "--load", huge, "--test", tmp_path / "in" / "tr.csv", "-o", "p.csv"],
            tmp_path / "work")
    assert r.returncode == IO, r.stderr
    assert one_line(r) == f"poolreps: {huge}:1: not a poolreps forest file\n", r.stderr
    assert changed(before, snapshot(tmp_path / "work")) == set()
    assert os.path.getsize(huge) == 2**40
