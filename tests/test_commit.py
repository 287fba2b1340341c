"""The commit point (docs/hardening.md, guarantee 5): a signal that arrives
while a command moves its finished outputs into place never splits the
commit and never lies about it. The renames run with the fatal signals
blocked; if they all succeeded the command exits 0 with its outputs
complete and one line saying that the signal came after; otherwise every
path is as it was and the line says so.

An LD_PRELOAD shim over rename(2) (tests/shims/slowrename.c, built here)
sends the signal before the K-th move into the user's folder, slows every
rename so that a signal from outside lands in the window, or makes the K-th
move fail. Every case snapshots the folder and its parent before and after.
"""
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

from conftest import ROOT
from test_safety import QUICK, SAN, SHOTS, TRAIN, REPS_IN, binary, env, snapshot, changed

SHIM_C = ROOT / "tests" / "shims" / "slowrename.c"


@pytest.fixture(scope="module")
def shim(tmp_path_factory):
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler for the rename shim")
    d = tmp_path_factory.mktemp("shim")
    so = d / "slowrename.so"
    r = subprocess.run([cc, "-shared", "-fPIC", "-O2", "-o", so, SHIM_C, "-ldl"], capture_output=True)
    if r.returncode:
        pytest.skip("cannot build the shim: " + r.stderr.decode()[:200])
    return so


def shim_env(so, **kw):
    e = dict(env(), LD_PRELOAD=str(so))
    # the sanitizer runtime would insist on coming first
    e["ASAN_OPTIONS"] = (e.get("ASAN_OPTIONS", "") + ":verify_asan_link_order=0").lstrip(":")
    e.update({k: str(v) for k, v in kw.items()})
    return e


def run_in(cwd, args, e, timeout=120):
    return subprocess.run([binary()] + [str(a) for a in args], cwd=cwd, capture_output=True,
                          env=e, timeout=timeout)


def dry_log(so, base, setup, args, var):
    """The lines the shim logs through env var in a dry run (a scratch copy)."""
    d = base / "count"
    d.mkdir()
    setup(d)
    log = base / "shim.log"
    r = run_in(d, args, shim_env(so, **{var: log}))
    assert r.returncode == 0, r.stderr
    lines = log.read_text().splitlines() if log.exists() else []
    shutil.rmtree(d)
    if log.exists():
        log.unlink()
    return lines


def moves(so, base, setup, args):
    """How many renames into the user's folders the command makes."""
    lines = dry_log(so, base, setup, args, "RENAME_LOG")
    return sum(1 for ln in lines if "/.partial-" not in ln.split(" ")[1]
               and ".poolreps-tmp-" not in ln.split(" ")[1])


def expected(so, base, setup, args):
    """The folder a run without any signal leaves (provenance's timings vary)."""
    d = base / "expect"
    d.mkdir()
    setup(d)
    r = run_in(d, args, shim_env(so))
    assert r.returncode == 0, r.stderr
    snap = strip(snapshot(d))
    shutil.rmtree(d)
    return snap


# a sweep's job lists hold its folder's absolute path: not compared across folders
PATHFUL = ("jobs.txt", "slurm.sbatch", "parallel.sh")


def strip(snap):
    """Provenance records the wall time: compare its presence, not its bytes."""
    return {k: (v if not k.endswith("provenance.txt") else v[0]) for k, v in snap.items()
            if not k.endswith(PATHFUL)}


def pathful(snap):
    return {k: v for k, v in snap.items() if k.endswith(PATHFUL)}


# ---- the commands with a multi-file commit, each with earlier outputs in place ----

def old_files(*names):
    def f(d):
        for n in names:
            p = d / n
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_bytes(b"old " + n.encode() + b"\n")
            os.chmod(p, 0o640)
    return f


def shoot_setup(d):
    (d / "s.csv").write_bytes(SHOTS)
    old_files("o.csv", "t.csv")(d)


def forest_setup(d):
    (d / "tr.csv").write_bytes(TRAIN)
    old_files("o.csv", "l.csv")(d)


def reps_setup(d):
    (d / "r.csv").write_bytes(REPS_IN)
    old_files("o.csv", "s.csv")(d)


def run_setup(d):
    r = run_in(d, [ROOT / "data" / "quadratic.ini", "-o", "out", "--set", "bench.samples=30"] + QUICK, env())
    assert r.returncode == 0, r.stderr
    (d / "out" / "notes.txt").write_text("mine\n")


def merge_setup(d):
    for k in (0, 1):
        r = run_in(d, [ROOT / "data" / "quadratic.ini", "-o", f"r{k}", "--set",
                       f"experiment.repetition={k}"] + QUICK, env())
        assert r.returncode == 0, r.stderr
    run_setup(d)


def sweep_setup(d):
    r = run_in(d, ["sweep", ROOT / "data" / "quadratic.ini", "--grid", "bench.samples=20,30",
                   "-o", "sw"] + QUICK, env())
    assert r.returncode == 0, r.stderr
    for line in (d / "sw" / "jobs.txt").read_text().splitlines():
        r = subprocess.run(line, shell=True, cwd=d, capture_output=True, env=env())
        assert r.returncode == 0, r.stderr


COMMANDS = {
    "shoot": (shoot_setup, ["shoot", "-i", "s.csv", "-o", "o.csv", "--trace", "t.csv"]),
    "forest": (forest_setup, ["forest", "--train", "tr.csv", "--test", "tr.csv", "--target", "y", "-q",
                              "-o", "o.csv", "--leaves", "l.csv"]),
    "reps": (reps_setup, ["reps", "--return", "R", "--features", "phi0", "-i", "r.csv", "-q",
                          "-o", "o.csv", "--summary", "s.csv"]),
    "run": (run_setup, [ROOT / "data" / "quadratic.ini", "-o", "out"] + QUICK),
    "merge": (merge_setup, ["merge", "r0", "r1", "-o", "out", "-q"]),
    "collect": (sweep_setup, ["collect", "sw", "-q"]),
}


def check_one_line(r):
    err = r.stderr
    assert err.startswith(b"poolreps: ") and err.count(b"\n") == 1 and err.endswith(b"\n"), err
    return err.decode()


def case_dirs(tmp_path, setup):
    base = tmp_path / "parent"
    d = base / "work"
    d.mkdir(parents=True)
    setup(d)
    return base, d


@pytest.mark.native
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGHUP], ids=["TERM", "INT", "HUP"])
@pytest.mark.parametrize("cmd", list(COMMANDS))
def test_signal_inside_the_commit_completes_it(cmd, sig, shim, tmp_path):
    """A signal before the K-th move, for every K: exit 0, every output the
    new one, nothing left over, and one line that says so."""
    setup, args = COMMANDS[cmd]
    n = moves(shim, tmp_path, setup, args)
    assert n >= 2, "a multi-file commit"
    want = expected(shim, tmp_path, setup, args)
    for k in range(1, n + 1):
        base, d = case_dirs(tmp_path / f"k{k}", setup)
        before_parent, before = set(os.listdir(base)), snapshot(d)
        r = run_in(d, args, shim_env(shim, RENAME_KILL_AT=k, RENAME_KILL_SIG=int(sig)))
        assert r.returncode == 0, (k, r.stderr)
        line = check_one_line(r)
        assert "after the outputs were complete" in line and signal.Signals(sig).name in line, line
        assert strip(snapshot(d)) == want, k
        assert pathful(snapshot(d)) == pathful(before)
        assert set(os.listdir(base)) == before_parent


@pytest.mark.native
@pytest.mark.parametrize("cmd", list(COMMANDS))
def test_failed_move_with_a_pending_signal_leaves_everything(cmd, shim, tmp_path):
    """The last move fails while a signal waits: every path as it was (modes,
    contents), the signal's exit code, and the line says nothing changed."""
    setup, args = COMMANDS[cmd]
    n = moves(shim, tmp_path, setup, args)
    for k in sorted({1, n}):
        base, d = case_dirs(tmp_path / f"k{k}", setup)
        before, before_parent = snapshot(d), snapshot(base)
        r = run_in(d, args, shim_env(shim, RENAME_KILL_AT=1, RENAME_FAIL_AT=k))
        assert r.returncode == 128 + signal.SIGTERM, (k, r.stderr)
        line = check_one_line(r)
        assert "left as" in line and "complete" not in line, line
        assert snapshot(d) == before, (k, changed(before, snapshot(d)))
        assert snapshot(base) == before_parent


@pytest.mark.native
@pytest.mark.parametrize("cmd", ["shoot", "run", "merge", "collect"])
def test_failed_move_alone_leaves_everything(cmd, shim, tmp_path):
    setup, args = COMMANDS[cmd]
    n = moves(shim, tmp_path, setup, args)
    base, d = case_dirs(tmp_path / "x", setup)
    before = snapshot(base)
    r = run_in(d, args, shim_env(shim, RENAME_FAIL_AT=n))
    assert r.returncode == 2, r.stderr
    line = check_one_line(r)
    assert "Input/output error" in line and ".partial-" not in line, line
    assert snapshot(base) == before, changed(before, snapshot(base))


@pytest.mark.native
@pytest.mark.parametrize("cmd", ["shoot", "run", "collect"])
def test_signal_from_outside_during_the_moves(cmd, shim, tmp_path):
    """SIGTERM sent while the command is held at its first move into place
    (the shim waits there until the test lets it go; kill(2) has queued the
    signal before it returns): the command still ends complete, exit 0."""
    setup, args = COMMANDS[cmd]
    want = expected(shim, tmp_path, setup, args)
    base, d = case_dirs(tmp_path / "x", setup)
    mark, go = tmp_path / "mark", tmp_path / "go"
    p = subprocess.Popen([binary()] + [str(a) for a in args], cwd=d, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, env=shim_env(shim, RENAME_MARK=mark, RENAME_HOLD=go))
    t0 = time.monotonic()
    while not mark.exists():
        assert p.poll() is None and time.monotonic() - t0 < 60, "no move into place"
        time.sleep(0.01)
    p.send_signal(signal.SIGTERM)
    go.touch()
    out, err = p.communicate(timeout=60)
    assert p.returncode == 0, err
    assert err.count(b"\n") == 1 and b"SIGTERM arrived after the outputs were complete" in err, err
    assert strip(snapshot(d)) == want


@pytest.mark.native
def test_signal_before_the_commit_still_changes_nothing(shim, tmp_path):
    """The other side of the commit point: a signal while a run writes into
    its staging folder (config.ini's rename there) leaves the folder as it was."""
    setup, args = COMMANDS["run"]
    base, d = case_dirs(tmp_path / "x", setup)
    before = snapshot(base)
    log = tmp_path / "l"
    e = shim_env(shim, RENAME_DELAY_MS=400, RENAME_LOG=log)
    p = subprocess.Popen([binary()] + [str(a) for a in args], cwd=d, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, env=e)
    t0 = time.monotonic()
    while not log.exists():
        assert p.poll() is None and time.monotonic() - t0 < 60
        time.sleep(0.005)
    p.send_signal(signal.SIGTERM)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 128 + signal.SIGTERM, err
    assert err.count(b"\n") == 1 and b"left as" in err, err
    assert snapshot(base) == before, changed(before, snapshot(base))


# ---- a signal right after a folder is made, before the command has told its handler ----

def run_new_setup(d):
    pass


MKDIR_COMMANDS = {
    "run_new": (run_new_setup, [ROOT / "data" / "quadratic.ini", "-o", "new/a/out"] + QUICK),
    "run_old": (run_setup, [ROOT / "data" / "quadratic.ini", "-o", "out"] + QUICK),
    "merge_new": (merge_setup, ["merge", "r0", "r1", "-o", "new/m", "-q"]),
    "sweep_new": (run_new_setup, ["sweep", ROOT / "data" / "quadratic.ini", "--grid", "bench.samples=20,30",
                                  "-o", "new/sw"] + QUICK),
    "collect": (sweep_setup, ["collect", "sw", "-q"]),
}


@pytest.mark.native
@pytest.mark.parametrize("sigs", [(signal.SIGTERM,), (signal.SIGTERM, signal.SIGINT)], ids=["TERM", "TERM_INT"])
@pytest.mark.parametrize("cmd", list(MKDIR_COMMANDS))
def test_signal_after_each_mkdir(cmd, sigs, shim, tmp_path):
    """One signal, or a second one back to back (the handler then cleans up
    at once), right after the K-th folder the command makes, for every K:
    either the command completed (exit 0, the outputs of a run without a
    signal) or it exits 128+N with one line and every path is as it was."""
    setup, args = MKDIR_COMMANDS[cmd]
    n = len(dry_log(shim, tmp_path, setup, args, "MKDIR_LOG"))
    assert n >= 1
    want = expected(shim, tmp_path, setup, args)
    for k in range(1, n + 1):
        base, d = case_dirs(tmp_path / f"k{k}", setup)
        before, before_parent = snapshot(d), snapshot(base)
        r = run_in(d, args, shim_env(shim, MKDIR_KILL_AT=k, MKDIR_KILL_SIGS=",".join(str(int(s)) for s in sigs)))
        check_one_line(r)
        if r.returncode == 0:
            assert strip(snapshot(d)) == want, k
            continue
        assert r.returncode in [128 + s for s in sigs], (k, r.stderr)
        assert snapshot(d) == before, (k, changed(before, snapshot(d)))
        assert snapshot(base) == before_parent, k
