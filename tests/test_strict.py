"""Parsers keep their documented limits exactly and drop nothing silently
(docs/hardening.md, "Limits refused up front" and guarantee 7), and the
duplicate-name check of a CSV header is linear. Every refused case: exit
code, one stderr line, and the folder and its parent unchanged."""
import time

import pytest

from conftest import ROOT
from test_safety import QUICK, run, snapshot, changed, one_line


@pytest.fixture
def cwd(tmp_path):
    """The command's folder, inside the test's own: the snapshot of its
    parent sees anything the command leaves beside it, and nothing of the
    other tests' folders."""
    d = tmp_path / "cwd"
    d.mkdir()
    return d

LIMIT = 4094  # docs/hardening.md: a parameter-file line


def ini_line(n, end):
    """A [table] file whose second line holds exactly n bytes before its end."""
    head = "balls = 3"
    return b"[table]\n" + (head + " " * (n - len(head))).encode() + end


@pytest.mark.parametrize("end", [b"\n", b"\r\n", b""], ids=["lf", "crlf", "no_end"])
@pytest.mark.parametrize("n,ok", [(LIMIT - 1, True), (LIMIT, True), (LIMIT + 1, False), (LIMIT + 2, False)])
def test_ini_line_limit_is_exact(n, ok, end, cwd):
    (cwd / "l.ini").write_bytes(ini_line(n, end))
    before = snapshot(cwd.parent)
    r = run(["config", "-c", "l.ini"], cwd)
    if ok:
        assert r.returncode == 0, r.stderr
        assert b"balls = 3\n" in r.stdout
    else:
        assert r.returncode == 1
        assert one_line(r) == f"poolreps: l.ini:2: line longer than {LIMIT} bytes\n"
    assert snapshot(cwd.parent) == before


def test_ini_comment_line_at_the_limit(tmp_path):
    (tmp_path / "l.ini").write_bytes(b"[table]\n;" + b"x" * (LIMIT - 1) + b"\nballs = 3\n")
    r = run(["config", "-c", "l.ini"], tmp_path)
    assert r.returncode == 0, r.stderr


SECTION_JUNK = [b"[table] junk", b"[table]junk", b"[table] ]", b"[ table ] x = 1", b"[table]\t#"]


@pytest.mark.parametrize("line", SECTION_JUNK, ids=range(len(SECTION_JUNK)))
def test_section_with_trailing_text_is_refused(line, cwd):
    (cwd / "j.ini").write_bytes(line + b"\nballs = 3\n")
    before = snapshot(cwd.parent)
    r = run(["config", "-c", "j.ini"], cwd)
    assert r.returncode == 1, r.stderr
    assert one_line(r).startswith("poolreps: j.ini:1: [table]: unexpected text after the ']'")
    assert snapshot(cwd.parent) == before


@pytest.mark.parametrize("line", [b"[table]", b"[table]   ", b"[table] ; a comment", b"[ table ];c"])
def test_section_with_blanks_or_a_comment_is_accepted(line, tmp_path):
    (tmp_path / "j.ini").write_bytes(line + b"\nballs = 3\n")
    r = run(["config", "-c", "j.ini"], tmp_path)
    assert r.returncode == 0, r.stderr


GRID_TWICE = [
    (["--grid", "bench.samples=20,30", "--grid", "bench.samples =40"], "key given twice"),
    (["--grid", "bench.samples=20", "--grid", " bench . samples=40"], "key given twice"),
    (["--grid", "bench.samples\t=20", "--grid", "bench.samples=40"], "key given twice"),
    (["--grid", "bench.samples=10,010"], "value '010' listed twice (as '10')"),
    (["--grid", "bench.samples=10,1e1"], "value '1e1' listed twice"),
    (["--grid", "bench.samples=20, 20"], "listed twice"),
    (["--grid", "bench.samples=20,30,20.0"], "listed twice"),
    (["--grid", "bench.init_std=0.5,5e-1"], "listed twice"),
]


@pytest.mark.parametrize("grid,needle", GRID_TWICE, ids=range(len(GRID_TWICE)))
def test_sweep_grid_refuses_the_same_key_or_value_twice(grid, needle, cwd):
    before = snapshot(cwd.parent)
    r = run(["sweep", ROOT / "data" / "quadratic.ini", "-o", "sw"] + grid + QUICK, cwd)
    assert r.returncode == 1, r.stderr
    msg = one_line(r)
    assert needle in msg and msg.startswith("poolreps: --grid bench."), msg
    assert snapshot(cwd.parent) == before, changed(before, snapshot(cwd.parent))


def test_sweep_grid_blank_spelling_names_the_key_plainly(tmp_path):
    r = run(["sweep", ROOT / "data" / "quadratic.ini", "-o", "sw", "--grid", " bench.samples =20,30"]
            + QUICK, tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "sw" / "manifest.csv").read_text().split("\n")[0].split(",")[2] == "bench.samples"


# ---- a header at the documented column limit ----

NCOLS = 100000


def wide(path, names):
    # two rows: REPS needs at least two samples
    row = ",".join("1" for _ in names) + "\n"
    path.write_text(",".join(names) + "\n" + row + row.replace("1", "2", 1))


@pytest.mark.parametrize("dup", [None, 1, NCOLS // 2, NCOLS - 1])
def test_wide_header_duplicate_check_is_fast(dup, tmp_path):
    """100 000 columns: the duplicate check used to compare every pair (25 s);
    a hash set makes it linear. The bound is generous (a loaded machine)."""
    names = ["R"] + [f"phi{i}" for i in range(NCOLS - 1)]
    if dup is not None:
        names[dup] = names[dup - 1] if dup > 1 else "R"
    wide(tmp_path / "w.csv", names)
    before = snapshot(tmp_path)
    t0 = time.monotonic()
    r = run(["reps", "--return", "R", "--features", "phi0", "-i", "w.csv", "-q", "-o", "o.csv"], tmp_path)
    took = time.monotonic() - t0
    assert took < 5, took
    if dup is None:
        assert r.returncode == 0, r.stderr
    else:
        assert r.returncode == 2
        assert one_line(r) == f"poolreps: w.csv:1: header column '{names[dup]}' appears twice\n"
        assert snapshot(tmp_path) == before


def test_wide_prefix_selection_is_fast(tmp_path):
    names = ["R"] + [f"phi{i}" for i in range(NCOLS - 1)]
    wide(tmp_path / "w.csv", names)
    t0 = time.monotonic()
    r = run(["reps", "--return", "R", "--features", "phi*,phi7", "-i", "w.csv", "-q", "-o", "o.csv"], tmp_path)
    assert time.monotonic() - t0 < 5
    assert r.returncode == 2 and "column 'phi7' selected twice by 'phi*,phi7'" in one_line(r), r.stderr
