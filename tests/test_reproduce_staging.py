"""`make reproduce` all or nothing (scripts/reproduce.sh): everything is
made in OUT/.reproduce-stage.* and published by renames only when complete,
so an interrupted reproduction leaves the previous results complete; a
second reproduction into an OUT that one is writing is refused; OUT may
hold a blank (quoted everywhere)."""
import fcntl
import os
import signal
import subprocess

import pytest

from conftest import ROOT, poolreps_path, run_cmd, wait_for
from test_safety import changed, snapshot

ENTRIES = ["sim", "exp1", "exp2", "exp3", "exp4", "quadratic", "sphere", "rosenbrock", "figures"]
PY = os.environ.get("PYTHON") or "/usr/bin/python3"


def earlier_results(out):
    """A complete earlier reproduction, as far as the script can tell."""
    for e in ENTRIES:
        (out / e).mkdir(parents=True)
        (out / e / "old.csv").write_text(f"{e}\n")
    (out / "timings.csv").write_text("step,seconds\n")
    (out / "report.html").write_text("<p>earlier</p>\n")
    (out / ".reproduce-files").write_text("".join(f"{p}\n" for p in published(out)))
    (out / "notes.txt").write_text("the user's\n")


def published(out):
    """Every path below OUT that a reproduction publishes, sorted as in C."""
    paths = []
    for e in ENTRIES + ["timings.csv", "report.html"]:
        if (out / e).exists():
            paths += [e] + [str(p.relative_to(out)) for p in (out / e).rglob("*")]
    return sorted(paths)


def reproduce(out, **kw):
    binary = poolreps_path()
    if binary is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    return subprocess.Popen(["sh", "scripts/reproduce.sh", str(out), PY, "1"], cwd=ROOT,
                            env=dict(os.environ, LC_ALL="C", POOLREPS=binary),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, **kw)


def test_second_reproduction_into_one_out_is_refused(tmp_path):
    out = tmp_path / "o u t"
    earlier_results(out)
    fd = os.open(out, os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX)   # what a live reproduction holds
    try:
        before = snapshot(tmp_path)
        p = reproduce(out)
        _, err = p.communicate(timeout=120)
    finally:
        os.close(fd)
    assert p.returncode == 1, err
    assert err.count(b"\n") == 1 and b"another reproduction is writing into it" in err, err
    assert changed(before, snapshot(tmp_path)) == set()


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_interrupted_reproduction_keeps_the_previous_results(sig, tmp_path):
    """Ctrl-C (to the process group, as a terminal sends it) or TERM once
    the first experiments have written into the staging folder."""
    out = tmp_path / "o u t"
    earlier_results(out)
    before = snapshot(tmp_path)
    p = reproduce(out, start_new_session=True)
    staged = lambda: any((s / "sim").is_dir() for s in out.glob(".reproduce-stage.*"))  # noqa: E731
    assert wait_for(staged, 300), "no experiment started"
    os.killpg(p.pid, sig)
    p.communicate(timeout=120)
    assert p.returncode != 0
    assert changed(before, snapshot(tmp_path)) == set()


def test_completed_reproduction_replaced_the_earlier_one_whole(quick_reproduction):
    """The conftest's reproduction ran over a figures folder with a figure
    of an earlier run: it is gone, nothing staged is left."""
    out = quick_reproduction
    assert not (out / "figures" / "fig7_99_old.png").exists()
    assert not list(out.glob(".reproduce-stage.*"))
    assert (out / "report.html").is_file() and (out / "timings.csv").is_file()


def test_completed_reproduction_records_what_it_published(quick_reproduction):
    out = quick_reproduction
    assert (out / ".reproduce-files").read_text().splitlines() == published(out)


@pytest.mark.parametrize("what", ["file", "folder", "symlink"])
def test_a_users_file_in_a_result_folder_is_refused_before_running(what, tmp_path):
    """A result folder is replaced whole: a file (or folder, or link) put
    into it since the last reproduction is named, and nothing runs."""
    out = tmp_path / "o u t"
    earlier_results(out)
    mine = out / "exp3" / "mine"
    if what == "file":
        mine.write_text("the user's notes\n")
    elif what == "folder":
        mine.mkdir()
    else:
        mine.symlink_to(out / "notes.txt")
    before = snapshot(tmp_path)
    p = reproduce(out, start_new_session=True)
    try:
        _, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
            p.wait()
    assert p.returncode == 1, err
    assert err.decode() == (f"reproduce: {out}/exp3/mine: not written by a reproduction; move it "
                            f"out of {out}/exp3, which is replaced whole\n")
    assert changed(before, snapshot(tmp_path)) == set()


@pytest.mark.parametrize("target", ["baselines", "reproduce-run"])
def test_out_with_a_blank_is_one_word(target):
    """make -n: every command that names OUT quotes it."""
    r = run_cmd(["make", "-n", target, "OUT=/tmp/a b", "PYTHON=" + PY], cwd=ROOT,
                capture_output=True, text=True, timeout=120)
    lines = [ln for ln in r.stdout.splitlines() if "/tmp/a b" in ln or "/tmp/a" in ln]
    assert lines, r.stdout
    for ln in lines:
        assert "/tmp/a " not in ln.replace('"/tmp/a b', ""), ln
