"""Symbolic links in run folders (docs/hardening.md, guarantee 6): a run
folder is published by renames inside it, so a file there that is a link
would be replaced by a regular file (the link broken, its target stale).
run, merge and collect refuse it instead, exit 2 with one line naming it,
and change nothing: the link, its target, the folder and its parent stay
as they were. Single outputs (-o, --trace, ...) still write through a link
and keep it (test_safety.py)."""
import os
import subprocess

import pytest

from conftest import ROOT
from test_safety import QUICK, binary, env, snapshot, changed, one_line

Q = ROOT / "data" / "quadratic.ini"


def sh(args, cwd):
    r = subprocess.run([str(a) for a in args], cwd=cwd, env=env(), capture_output=True)
    assert r.returncode == 0, r.stderr
    return r


def link_in(folder, name, target_dir, kind):
    """Replace folder/name by a link: to a copy elsewhere, dangling, or to a device."""
    p = folder / name
    if kind == "copy":
        t = target_dir / ("kept-" + name)
        t.write_bytes(p.read_bytes())
        os.chmod(t, 0o640)
    elif kind == "dangling":
        t = target_dir / "nowhere.csv"
    else:
        t = "/dev/null"
    p.unlink()
    p.symlink_to(t)


def setup_run(base):
    sh([binary(), Q, "-o", "out"] + QUICK, base)
    return base / "out", [Q, "-o", "out", "--set", "bench.samples=30"] + QUICK


def setup_merge(base):
    for k in (0, 1):
        sh([binary(), Q, "-o", f"r{k}", "--set", f"experiment.repetition={k}"] + QUICK, base)
    sh([binary(), "merge", "r0", "r1", "-o", "out", "-q"], base)
    return base / "out", ["merge", "r0", "r1", "-o", "out", "-q"]


def setup_collect(base):
    sh([binary(), "sweep", Q, "--grid", "bench.samples=20,30", "-o", "sw"] + QUICK, base)
    for job in (base / "sw" / "jobs.txt").read_text().splitlines():
        assert subprocess.run(job, shell=True, cwd=base, env=env(), capture_output=True).returncode == 0
    sh([binary(), "collect", "sw", "-q"], base)
    return base / "sw" / "point-1" / "merged", ["collect", "sw", "-q"]


SETUPS = {"run": setup_run, "merge": setup_merge, "collect": setup_collect}


@pytest.mark.parametrize("kind", ["copy", "dangling", "device"])
@pytest.mark.parametrize("name", ["bench_curve.csv", "config.ini", "provenance.txt"])
@pytest.mark.parametrize("cmd", list(SETUPS))
def test_symlink_in_a_run_folder_is_refused(cmd, name, kind, tmp_path):
    base = tmp_path / "parent"
    base.mkdir()
    folder, args = SETUPS[cmd](base)
    link_in(folder, name, base, kind)
    before = snapshot(tmp_path)
    r = subprocess.run([str(binary())] + [str(a) for a in args], cwd=base, env=env(), capture_output=True)
    assert r.returncode == 2, r.stderr
    msg = one_line(r)
    assert f"{name}: is a symbolic link" in msg and ".partial-" not in msg, msg
    assert snapshot(tmp_path) == before, changed(before, snapshot(tmp_path))


def test_symlink_the_earlier_run_did_not_list_is_kept(tmp_path):
    """A link of the user's own (not on the earlier run's list) stays as it is."""
    base = tmp_path / "parent"
    base.mkdir()
    folder, args = setup_run(base)
    (base / "notes.txt").write_text("mine\n")
    (folder / "notes").symlink_to(base / "notes.txt")
    r = subprocess.run([str(binary())] + [str(a) for a in args], cwd=base, env=env(), capture_output=True)
    assert r.returncode == 0, r.stderr
    assert os.readlink(folder / "notes") == str(base / "notes.txt")
    assert (base / "notes.txt").read_text() == "mine\n"


def test_listed_symlink_of_another_experiment_is_refused_before_work(tmp_path):
    """The earlier run listed a file that is now a link: refused before any
    work (a run of hours would otherwise be lost at the end)."""
    base = tmp_path / "parent"
    base.mkdir()
    folder, _ = setup_run(base)
    link_in(folder, "bench_summary.csv", base, "copy")
    before = snapshot(tmp_path)
    r = subprocess.run([str(binary()), ROOT / "data" / "figures.ini", "-q", "-o", "out"], cwd=base, env=env(),
                       capture_output=True)
    assert r.returncode == 2 and "bench_summary.csv: is a symbolic link" in one_line(r)
    assert snapshot(tmp_path) == before
