"""Runs of different poolreps builds (docs/cluster.md, "Merging"): merge
and collect refuse to combine them (exit 1, one line naming two folders and
their versions, nothing written) unless --allow-versions, and then the
merged provenance lists every version. experiment.threads alone never
blocks a merge: threads change no output byte."""
import shutil
import subprocess


from conftest import ROOT
from test_safety import QUICK, USAGE, changed, one_line, run, runs as reps, snapshot  # noqa: F401

Q = ROOT / "data" / "quadratic.ini"


def other_build(folder, version="0.0-another-build"):
    p = folder / "provenance.txt"
    lines = p.read_text().split("\n")
    lines[0] = "version: " + version
    p.write_text("\n".join(lines))


def test_merge_refuses_runs_of_two_builds(reps, tmp_path):
    for n in ("r0", "r1"):
        shutil.copytree(reps / n, tmp_path / n)
    other_build(tmp_path / "r1")
    before = snapshot(tmp_path)
    r = run(["merge", "-q", "-o", "m", "r0", "r1"], tmp_path)
    assert r.returncode == USAGE, r.stderr
    line = one_line(r)
    assert "r1/provenance.txt: poolreps 0.0-another-build" in line and "r0/provenance.txt" in line
    assert "--allow-versions" in line
    assert changed(before, snapshot(tmp_path)) == set()


def test_allow_versions_lists_every_version(reps, tmp_path):
    for n in ("r0", "r1"):
        shutil.copytree(reps / n, tmp_path / n)
    other_build(tmp_path / "r1")
    mine = (tmp_path / "r0" / "provenance.txt").read_text().split("\n")[0][len("version: "):]
    r = run(["merge", "-q", "--allow-versions", "-o", "m", "r0", "r1"], tmp_path)
    assert r.returncode == 0, r.stderr
    first = (tmp_path / "m" / "provenance.txt").read_text().split("\n")[0]
    assert first == f"version: {mine} (runs by {mine}, 0.0-another-build)", first


def test_threads_alone_never_block_a_merge(reps, tmp_path):
    shutil.copytree(reps / "r0", tmp_path / "r0")
    # another thread count than r0's (whose default is the machine's cores)
    threads = 1 if "\nthreads = 1\n" not in (reps / "r0" / "config.ini").read_text() else 2
    r = run([Q, "-o", tmp_path / "r1_t2", "--set", "experiment.repetition=1",
             "--set", f"experiment.threads={threads}"] + QUICK, tmp_path)
    assert r.returncode == 0, r.stderr
    r = run(["merge", "-q", "-o", "m", "r0", "r1_t2"], tmp_path)
    assert r.returncode == 0, r.stderr
    r = run(["merge", "-q", "-o", tmp_path / "m1", "r0", "r1"], reps)
    assert r.returncode == 0, r.stderr
    for f in (tmp_path / "m1").glob("*.csv"):
        assert (tmp_path / "m" / f.name).read_bytes() == f.read_bytes(), f.name


def test_collect_refuses_jobs_of_two_builds(tmp_path):
    sweep = tmp_path / "s"
    r = run(["sweep", Q, "-q", "-o", sweep, "--set", "experiment.repetitions=2",
             "--set", "bench.iterations=3", "--grid", "bench.samples=20,30"], tmp_path)
    assert r.returncode == 0, r.stderr

    for line in (sweep / "jobs.txt").read_text().splitlines():
        subprocess.run(["sh", "-c", line], check=True, capture_output=True)
    jobs = sorted(p for p in sweep.glob("point-*/runs/*") if (p / "provenance.txt").exists())
    assert len(jobs) == 4
    # points 0 and 1 each of one build, but not the same one
    for j in jobs:
        if j.parent.parent.name == "point-1":
            other_build(j)
    before = snapshot(tmp_path)
    r = run(["collect", "-q", sweep], tmp_path)
    assert r.returncode == USAGE, r.stderr
    assert "0.0-another-build" in one_line(r)
    assert changed(before, snapshot(tmp_path)) == set()
    r = run(["collect", "-q", "--allow-versions", sweep], tmp_path)
    assert r.returncode == 0, r.stderr
    first = (sweep / "point-1" / "merged" / "provenance.txt").read_text().split("\n")[0]
    assert "(runs by 0.0-another-build)" in first
