"""The learner's generated blocks: the 20-seed Gymnasium table of
docs/learner.md (scripts/learner_gym_report.py over data/learner/gym_study.csv)
and the learner's rows of docs/benchmarks.md (scripts/bench_learner_table.py
over docs/data/bench_learner.csv) are what their scripts make of the CSVs,
without Gymnasium; a changed number fails the check and changes nothing."""
import subprocess
import sys

import pytest

from conftest import ROOT

TABLES = [("learner_gym_report.py", "data/learner/gym_study.csv", "docs/learner.md",
           "trees,", 3, 300.0),
          ("bench_learner_table.py", "docs/data/bench_learner.csv", "docs/benchmarks.md",
           "exp3_python_iteration,", 2, 1.0)]


def check(script, *args):
    return subprocess.run([sys.executable, str(ROOT / "scripts" / script), "--check", *map(str, args)],
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("script,csv,doc,row,col,delta", TABLES)
def test_the_page_is_what_the_csv_gives(script, csv, doc, row, col, delta):
    r = check(script)
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("script,csv,doc,row,col,delta", TABLES)
def test_a_changed_number_fails_the_check_and_changes_nothing(tmp_path, script, csv, doc, row,
                                                             col, delta):
    lines = (ROOT / csv).read_text().splitlines(keepends=True)
    i = max(k for k, x in enumerate(lines) if x.startswith(row))
    f = lines[i].split(",")
    f[col] = repr(float(f[col]) + delta)
    lines[i] = ",".join(f)
    bad = tmp_path / "runs.csv"
    bad.write_text("".join(lines))
    before = (ROOT / doc).read_bytes()
    r = check(script, bad)
    assert r.returncode == 1 and "differs" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert (ROOT / doc).read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["runs.csv"]
