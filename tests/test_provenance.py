"""provenance.txt cannot be forged (docs/hardening.md, guarantee 6): an
argument with a line break is recorded with it escaped, so it never starts
a line of its own; the record is read back strictly; a later run removes
only plain names poolreps itself writes. Every case snapshots the folder
and its parent before and after."""
import os
import re

import pytest

from conftest import ROOT
from test_safety import QUICK, run, snapshot, changed, one_line

Q = ROOT / "data" / "quadratic.ini"
RUN_FILES = ["bench_curve.csv", "bench_summary.csv", "config.ini", "provenance.txt"]
KEYS = ["version", "command", "experiment", "seed", "repetition", "parameter_file", "host",
        "finished", "wall_seconds", "cpu_seconds", "peak_memory_mib", "files"]
FORGE = "\nfiles: victim.txt notes.csv\n"


def record_lines(folder):
    text = (folder / "provenance.txt").read_text()
    assert text.endswith("\n")
    lines = text[:-1].split("\n")
    assert [ln.split(":")[0] for ln in lines] == KEYS, lines
    return lines


def prepare(tmp_path):
    """A run folder with files poolreps did not write, inside and beside it."""
    base = tmp_path / "parent"
    (base / "r").mkdir(parents=True)
    for name in ("victim.txt", "notes.csv"):
        (base / "r" / name).write_text("mine\n")
        os.chmod(base / "r" / name, 0o600)
    (base / "outside.csv").write_text("mine too\n")
    return base


@pytest.mark.parametrize("where", ["config_name", "output_name", "merge_input"])
def test_line_break_in_an_argument_is_escaped(where, tmp_path):
    base = prepare(tmp_path)
    args = [Q, "-o", "r"] + QUICK
    if where == "config_name":
        forged = base / ("q" + FORGE + ".ini")
        forged.write_bytes(Q.read_bytes())
        args = [forged, "-o", "r"] + QUICK
    elif where == "output_name":
        r0 = run([Q, "-o", "r" + FORGE] + QUICK, base)
        assert r0.returncode == 0, r0.stderr
        folder = base / ("r" + FORGE)
        assert len(record_lines(folder)) == 12 and "\\x0afiles: victim.txt" in record_lines(folder)[1]
    else:
        for k in (0, 1):
            r0 = run([Q, "-o", f"in{k}" + FORGE, "--set", f"experiment.repetition={k}"] + QUICK, base)
            assert r0.returncode == 0, r0.stderr
        args = ["merge", "in0" + FORGE, "in1" + FORGE, "-o", "r", "-q"]
    keep = {k: v for k, v in snapshot(base).items() if k in ("r/victim.txt", "r/notes.csv", "outside.csv")}
    r = run(args, base)
    assert r.returncode == 0, r.stderr
    lines = record_lines(base / "r")
    assert lines[-1] == "files: " + " ".join(RUN_FILES)
    assert where == "output_name" or "\\x0afiles: victim.txt notes.csv\\x0a" in lines[1]
    # a second run into the folder: the files poolreps did not write stay
    r = run([Q, "-o", "r", "--set", "bench.samples=30"] + QUICK, base)
    assert r.returncode == 0, r.stderr
    after = snapshot(base)
    assert {k: after.get(k) for k in keep} == keep
    assert sorted(os.listdir(base / "r")) == sorted(RUN_FILES + ["notes.csv", "victim.txt"])


def test_sweep_records_its_parameter_file_escaped(tmp_path):
    base = prepare(tmp_path)
    forged = base / ("q" + FORGE + ".ini")
    forged.write_bytes(Q.read_bytes())
    r = run(["sweep", forged, "--grid", "bench.samples=20,30", "-o", "sw"] + QUICK, base)
    assert r.returncode == 0, r.stderr
    lines = record_lines(base / "sw")
    assert lines[5] == "parameter_file: " + str(base / "q\\x0afiles: victim.txt notes.csv\\x0a.ini")


def test_escaped_record_holds_the_argument(tmp_path):
    base = prepare(tmp_path)
    forged = base / "a\x01b\x7fc\rd.ini"
    forged.write_bytes(Q.read_bytes())
    r = run([forged, "-o", "r"] + QUICK, base)
    assert r.returncode == 0, r.stderr
    lines = record_lines(base / "r")
    assert "a\\x01b\\x7fc\\x0dd.ini" in lines[1] and lines[5].endswith("a\\x01b\\x7fc\\x0dd.ini")


def valid_record(tmp_path):
    base = prepare(tmp_path)
    r = run([Q, "-o", "r"] + QUICK, base)
    assert r.returncode == 0, r.stderr
    return base, (base / "r" / "provenance.txt").read_text()


def replace_files(text, names):
    return re.sub(r"(?m)^files: .*$", "files: " + names, text)


FORGED = [
    ("name_with_slash", lambda t: replace_files(t, "bench_curve.csv ../outside.csv provenance.txt"), 12),
    ("absolute_name", lambda t: replace_files(t, "/etc/passwd provenance.txt"), 12),
    ("dot_name", lambda t: replace_files(t, ".. provenance.txt"), 12),
    ("hidden_name", lambda t: replace_files(t, ".bashrc provenance.txt"), 12),
    ("foreign_name", lambda t: replace_files(t, "victim.txt provenance.txt"), 12),
    ("foreign_csv", lambda t: replace_files(t, "notes.csv provenance.txt"), 12),
    ("second_files_line", lambda t: t + "files: victim.txt\n", 13),
    ("unknown_key", lambda t: t.replace("seed:", "sneed:"), 4),
    ("repeated_key", lambda t: t.replace("seed: 1\n", "seed: 1\nseed: 2\n"), 5),
    ("misplaced_files", lambda t: t.replace("experiment:", "files: victim.txt\nexperiment:"), 3),
    ("no_files_line", lambda t: re.sub(r"(?m)^files: .*\n", "", t), 12),
    ("carriage_return", lambda t: t.replace("seed: 1", "seed: 1\r"), 4),
    ("unfinished_line", lambda t: t[:-1], 12),
]


@pytest.mark.parametrize("name,edit,line", FORGED, ids=[f[0] for f in FORGED])
def test_forged_record_is_refused_and_nothing_changes(name, edit, line, tmp_path):
    base, text = valid_record(tmp_path)
    (base / "r" / "provenance.txt").write_text(edit(text))
    before = snapshot(tmp_path)
    r = run([Q, "-o", "r", "--set", "bench.samples=30"] + QUICK, base)
    assert r.returncode == 2, r.stderr
    msg = one_line(r)
    assert msg.startswith(f"poolreps: r/provenance.txt:{line}: not a provenance record poolreps writes"), msg
    assert snapshot(tmp_path) == before, changed(before, snapshot(tmp_path))


def test_forged_record_of_a_collected_point_is_refused(tmp_path):
    base = tmp_path / "parent"
    base.mkdir()
    r = run(["sweep", Q, "--grid", "bench.samples=20,30", "-o", "sw"] + QUICK, base)
    assert r.returncode == 0, r.stderr
    import subprocess
    from test_safety import env
    for job in (base / "sw" / "jobs.txt").read_text().splitlines():
        assert subprocess.run(job, shell=True, cwd=base, env=env(), capture_output=True).returncode == 0
    assert run(["collect", "sw", "-q"], base).returncode == 0
    prov = base / "sw" / "point-1" / "merged" / "provenance.txt"
    prov.write_text(replace_files(prov.read_text(), "../../jobs.txt provenance.txt"))
    before = snapshot(tmp_path)
    r = run(["collect", "sw", "-q"], base)
    assert r.returncode == 2, r.stderr
    assert "point-1/merged/provenance.txt:12: not a provenance record" in one_line(r)
    assert snapshot(tmp_path) == before, changed(before, snapshot(tmp_path))


@pytest.mark.parametrize("other", ["exp1_mse.csv", "fig7_table.csv", "exp3_episodes.csv"])
def test_a_plain_poolreps_name_of_another_experiment_is_removed(other, tmp_path):
    """The other side: what an earlier run listed and could have written goes."""
    base, text = valid_record(tmp_path)
    (base / "r" / other).write_text("x\n")
    (base / "r" / "provenance.txt").write_text(replace_files(text, " ".join([other] + RUN_FILES)))
    r = run([Q, "-o", "r", "--set", "bench.samples=30"] + QUICK, base)
    assert r.returncode == 0, r.stderr
    assert sorted(os.listdir(base / "r")) == sorted(RUN_FILES + ["notes.csv", "victim.txt"])


@pytest.mark.parametrize("content", [b"", b"not a record\nfiles: victim.txt\n", b"\x00\x01"])
def test_a_file_that_is_no_record_is_never_replaced(content, tmp_path):
    """No poolreps record: poolreps wrote nothing there, so the run replaces
    nothing (refused before its work, exit 2), removes nothing."""
    base = prepare(tmp_path)
    (base / "r" / "provenance.txt").write_bytes(content)
    (base / "r" / "bench_curve.csv").write_text("kept\n")
    before = snapshot(tmp_path)
    r = run([Q, "-o", "r"] + QUICK, base)
    assert r.returncode == 2, r.stderr
    assert "r/provenance.txt: exists, and no earlier poolreps run" in one_line(r)
    assert snapshot(tmp_path) == before, changed(before, snapshot(tmp_path))
