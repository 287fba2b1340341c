"""Staging on a shared file system (docs/hardening.md, guarantee 5): a
staging folder or temporary file is named by its owner tag (PID, start
time, PID namespace, boot id) and removed by another process only when that
owner is provably gone; what a process on another node (simulated with
`unshare --pid`: its PIDs do not exist here) or in another namespace left is
never touched. Publishing serialises on a real lock, also where folders
cannot be locked (simulated: flock on a folder fails with EBADF, as on NFS).
Every case checks the folder and its parent before and after."""
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

from conftest import ROOT, owner_tag
from test_commit import shim, shim_env  # noqa: F401  (the fixture)
from test_safety import QUICK, SHOTS, binary, env, snapshot, changed, wait_for

Q = ROOT / "data" / "quadratic.ini"
RUN_FILES = ["bench_curve.csv", "bench_summary.csv", "config.ini", "provenance.txt"]


def need_unshare():
    if os.geteuid() != 0:
        pytest.skip("unshare --pid needs root")
    if shutil.which("unshare") is None:
        pytest.skip("no unshare (util-linux)")
    r = subprocess.run(["unshare", "--pid", "--fork", "--mount-proc", "true"], capture_output=True)
    if r.returncode:
        pytest.skip("unshare --pid does not work here: " + r.stderr.decode()[:100])


def elsewhere(args):
    """args as run by a process of another PID namespace ('another node'),
    under a PID that no process has here (one just gone): the case where
    a PID alone would call its live staging stale."""
    q = subprocess.Popen(["true"])
    q.wait()
    return ["unshare", "--pid", "--fork", "--mount-proc", "sh", "-c",
            'echo "$1" > /proc/sys/kernel/ns_last_pid; shift; "$@"', "sh", str(q.pid - 1)] + args


def start(args, cwd, e):
    return subprocess.Popen([str(a) for a in args], cwd=cwd, env=e, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)


def staged(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.startswith((".partial-", ".poolreps-tmp-")))


@pytest.mark.native
@pytest.mark.parametrize("first_elsewhere", [True, False], ids=["first_in_namespace", "second_in_namespace"])
@pytest.mark.parametrize("second", ["run", "shoot", "sweep_missing"])
def test_live_staging_of_another_node_is_kept(first_elsewhere, second, shim, tmp_path):
    """A run slowed at every rename (its staging folder in place, before
    its commit) while a second command in the other namespace writes into
    the same folder: the second never removes the first's staging, both
    succeed."""
    need_unshare()
    base = tmp_path / "parent"
    out = base / "out"
    out.mkdir(parents=True)
    (base / "s.csv").write_bytes(SHOTS)
    log, mark, go = tmp_path / "renames", tmp_path / "mark", tmp_path / "go"
    slow = [binary(), Q, "-o", out] + QUICK
    if second == "run":
        # the second run takes the folder's publish lock: the first is held
        # in its work (after its first rename inside its staging), unlocked
        e = shim_env(shim, RENAME_LOG=log, RENAME_MARK=mark, RENAME_HOLD=go, RENAME_MARK_FIRST=1)
    else:
        # held at its first move into the folder until the second has finished
        e = shim_env(shim, RENAME_LOG=log, RENAME_MARK=mark, RENAME_HOLD=go)
    p = start(elsewhere(slow) if first_elsewhere else slow, base, e)
    try:
        assert wait_for(lambda: mark.exists(), 60), "the first run never renamed"
        mine = staged(out)
        assert mine, "no staging folder"
        cmd = {"run": [binary(), Q, "-o", out, "--set", "bench.samples=30"] + QUICK,
               "shoot": [binary(), "shoot", "-i", "s.csv", "-o", out / "shots.csv"],
               "sweep_missing": [binary(), "sweep", "--missing", out]}[second]
        r = subprocess.run([str(a) for a in (cmd if first_elsewhere else elsewhere(cmd))], cwd=base,
                           env=env(), capture_output=True, timeout=120)
        # the first's staging is still there: it has not published yet
        assert set(mine) <= set(staged(out)), (mine, staged(out))
        assert "/.partial-" in log.read_text() and str(out) + "/bench" not in log.read_text()
        if second == "sweep_missing":
            assert r.returncode != 0 and r.stderr.count(b"\n") == 1
        else:
            assert r.returncode == 0, r.stderr
        go.touch()
        o, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode == 0, err
    assert not staged(out), staged(out)
    names = sorted(q.name for q in out.iterdir())
    assert [n for n in names if n != "shots.csv"] == RUN_FILES


@pytest.mark.native
def test_live_temporary_file_of_another_node_is_kept(shim, tmp_path):
    """shoot in another namespace, slowed before its rename: its temporary
    file survives a shoot from here into the same folder."""
    need_unshare()
    base = tmp_path / "parent"
    base.mkdir()
    (base / "s.csv").write_bytes(SHOTS)
    (base / "o.csv").write_bytes(b"old\n")
    os.chmod(base / "o.csv", 0o640)
    mark, go = tmp_path / "mark", tmp_path / "go"
    p = start(elsewhere([binary(), "shoot", "-i", "s.csv", "-o", "o.csv"]), base,
              shim_env(shim, RENAME_MARK=mark, RENAME_HOLD=go))
    try:
        assert wait_for(lambda: mark.exists(), 60)
        tmps = staged(base)
        assert len(tmps) == 1
        r = subprocess.run([binary(), "shoot", "-i", "s.csv", "-o", "p.csv"], cwd=base, env=env(),
                           capture_output=True, timeout=60)
        assert r.returncode == 0, r.stderr
        assert staged(base) == tmps
        go.touch()
        o, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode == 0, err
    assert not staged(base)
    assert (base / "o.csv").read_bytes() == (base / "p.csv").read_bytes()
    assert oct(os.stat(base / "o.csv").st_mode & 0o777) == oct(0o640)


@pytest.mark.native
def test_leftover_of_a_killed_run_in_another_namespace_is_kept(shim, tmp_path):
    """SIGKILL inside a namespace leaves a staging folder whose owner cannot
    be proven dead from here (or from a new namespace): kept, and the runs
    into the folder still succeed."""
    need_unshare()
    base = tmp_path / "parent"
    out = base / "out"
    out.mkdir(parents=True)
    mark = tmp_path / "mark"
    p = start(elsewhere([binary(), Q, "-o", out] + QUICK), base,
              shim_env(shim, RENAME_MARK=mark, RENAME_HOLD=tmp_path / "never"))
    assert wait_for(lambda: mark.exists(), 60)
    # unshare's child is the shell, PID 1 of its namespace: the run dies with it
    for child in Path(f"/proc/{p.pid}/task/{p.pid}/children").read_text().split():
        os.kill(int(child), signal.SIGKILL)
    p.kill()
    p.wait()
    time.sleep(0.2)
    left = staged(out)
    assert left, "SIGKILL left nothing"
    for cmd in ([binary(), Q, "-o", out] + QUICK, elsewhere([binary(), Q, "-o", out] + QUICK)):
        r = subprocess.run([str(a) for a in cmd], cwd=base, env=env(), capture_output=True, timeout=120)
        assert r.returncode == 0, r.stderr
        assert staged(out) == left


def fabricate(folder, name):
    p = folder / name
    p.mkdir()
    (p / "x.csv").write_text("x\n")
    return p


def dead():
    q = subprocess.Popen(["true"])
    q.wait()
    return q.pid


TAGS = [
    # (name, removed?)
    ("same_node_dead", lambda: owner_tag(dead()), True),
    ("same_node_pid_reused", lambda: f"{os.getpid()}-1-" + owner_tag(os.getpid()).split("-", 2)[2], True),
    ("same_node_alive", lambda: owner_tag(os.getpid()), False),
    ("other_boot", lambda: owner_tag(dead())[:-12] + "0123456789ab", False),
    ("other_namespace", lambda: "-".join(owner_tag(dead()).split("-")[:2] + ["1"] + owner_tag(1).split("-")[3:]), False),
    ("old_format_pid_only", lambda: str(dead()), False),
    ("garbage", lambda: "x-y-z", False),
]


@pytest.mark.native
@pytest.mark.parametrize("what,tag,removed", TAGS, ids=[t[0] for t in TAGS])
@pytest.mark.parametrize("kind", ["partial", "tmp"])
def test_only_provably_dead_leftovers_go(what, tag, removed, kind, tmp_path):
    base = tmp_path / "parent"
    out = base / "out"
    out.mkdir(parents=True)
    t = tag()
    if kind == "partial":
        left = fabricate(out, f".partial-{t}")
    else:
        left = out / f".poolreps-tmp-{t}-0"
        left.write_text("x\n")
    r = subprocess.run([binary(), Q, "-o", out] + QUICK, cwd=base, env=env(), capture_output=True)
    assert r.returncode == 0, r.stderr
    assert left.exists() != removed, (t, os.listdir(out))
    assert sorted(q.name for q in out.iterdir() if not q.name.startswith(".")) == RUN_FILES


@pytest.mark.native
def test_publish_lock_where_folders_cannot_be_locked(shim, tmp_path):
    """flock on a folder fails (NFS): the lock falls back to an fcntl lock
    on OUT/.poolreps.lock, kept; three concurrent runs still publish one
    complete run."""
    base = tmp_path / "parent"
    base.mkdir()
    out = base / "out"
    e = shim_env(shim, FLOCK_DIR_EBADF=1, RENAME_DELAY_MS=50)
    procs = [start([binary(), Q, "-o", out, "--seed", s, "--set", "bench.iterations=20",
                    "--set", "experiment.repetitions=2", "-q"], base, e) for s in (1, 2, 3)]
    errs = [p.communicate(timeout=300)[1] for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0], errs
    assert sorted(q.name for q in out.iterdir()) == [".poolreps.lock"] + RUN_FILES
    assert os.listdir(base) == ["out"]
    seed = [x for x in (out / "provenance.txt").read_text().splitlines() if x.startswith("seed: ")][0]
    ref = base / "ref"
    r = subprocess.run([binary(), Q, "-o", ref, "--seed", seed.split()[1], "--set", "bench.iterations=20",
                        "--set", "experiment.repetitions=2", "-q"], cwd=base, env=env(), capture_output=True)
    assert r.returncode == 0, r.stderr
    for n in RUN_FILES[:-1]:
        assert (out / n).read_bytes() == (ref / n).read_bytes(), n
