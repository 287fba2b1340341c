"""A full disk (docs/hardening.md, guarantee 8): on a small tmpfs filled to
leave k KiB, for k stepped until the command succeeds, every failure exits 2
with one line that names the file being written at the user's target path
(never a staging folder or temporary file, gone once the command failed),
and the folder and its parent are as they were. Needs root (mount)."""
import os
import re
import shutil
import subprocess

import pytest

from conftest import ROOT
from test_safety import POLICY_TRAIN, QUICK, SHOTS, TRAIN, binary, env, snapshot, changed, one_line

Q = ROOT / "data" / "quadratic.ini"


@pytest.fixture
def tmpfs(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    m = tmp_path / "fs"
    m.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=512k", "tmpfs", str(m)], capture_output=True)
    if r.returncode:
        pytest.skip("cannot mount a tmpfs: " + r.stderr.decode()[:100])
    yield m
    subprocess.run(["umount", "-l", str(m)])


def sh(args, cwd):
    r = subprocess.run([str(a) for a in args], cwd=cwd, env=env(), capture_output=True)
    assert r.returncode == 0, r.stderr
    return r


def free_kib(path):
    st = os.statvfs(path)
    return st.f_bavail * st.f_frsize // 1024


def fill_to(path, slack):
    f = path / "fill"
    if f.exists():
        f.unlink()
    n = max(free_kib(path) - slack, 0)
    with open(f, "wb") as fp:
        fp.write(b"\0" * (n * 1024))


def prepare_sweep(d):
    sh([binary(), "sweep", Q, "--grid", "bench.samples=20,30", "-o", "sw"] + QUICK, d)
    for job in (d / "sw" / "jobs.txt").read_text().splitlines():
        assert subprocess.run(job, shell=True, cwd=d, env=env(), capture_output=True).returncode == 0


def prepare_runs(d):
    for k in (0, 1):
        sh([binary(), Q, "-o", f"r{k}", "--set", f"experiment.repetition={k}"] + QUICK, d)


def prepare_out(d):
    sh([binary(), Q, "-o", "out", "--set", "bench.samples=30"] + QUICK, d)


CASES = {
    # name: (setup, command, the target every message must name a file below, the file names it writes)
    "run_new": (None, [Q, "-o", "out/deep"] + QUICK, "out/deep/", None),
    "run_existing": (prepare_out, [Q, "-o", "out"] + QUICK, "out/", None),
    "merge": (prepare_runs, ["merge", "r0", "r1", "-o", "m", "-q"], "m/", None),
    "collect": (prepare_sweep, ["collect", "sw", "-q"], "sw/", re.compile(r"sw/(point-\d+/merged/)?[^/]+$")),
    "sweep": (None, ["sweep", Q, "--grid", "bench.samples=20,30,40", "-o", "sw2"] + QUICK, "sw2/", None),
    "shoot": (lambda d: (d / "s.csv").write_bytes(SHOTS + SHOTS.split(b"\n", 1)[1] * 10), ["shoot", "-i", "s.csv", "-o", "o.csv",
                                                                   "--trace", "t.csv"], "", re.compile(r"^[ot]\.csv$")),
    "forest": (lambda d: (d / "tr.csv").write_bytes(TRAIN), ["forest", "--train", "tr.csv", "--test", "tr.csv",
                                                           "--target", "y", "-q", "-o", "o.csv", "--leaves", "l.csv"],
               "", re.compile(r"^[ol]\.csv$")),
    # the streamed query states and their draws (3000 rows, about 150 KiB)
    "policy": (lambda d: (d / "p.csv").write_bytes(POLICY_TRAIN), ["policy", "--train", "p.csv", "--state", "s0",
                                                                 "--action", "a0", "--weight", "w", "-i", "p.csv",
                                                                 "--sample", "50", "-q", "-o", "o.csv"],
               "", re.compile(r"^o\.csv$")),
}


@pytest.mark.native
@pytest.mark.parametrize("what", list(CASES))
def test_full_disk_names_the_target(what, tmpfs):
    setup, args, target, names = CASES[what]
    work = tmpfs / "work"
    work.mkdir()
    if setup:
        setup(work)
    failures = 0
    for slack in range(0, 400, 4):
        fill_to(tmpfs, slack)
        before = snapshot(tmpfs)
        r = subprocess.run([str(binary())] + [str(a) for a in args], cwd=work, env=env(), capture_output=True)
        if r.returncode == 0:
            break
        failures += 1
        assert r.returncode == 2, (slack, r.stderr)
        msg = one_line(r)
        assert "No space left on device" in msg, msg
        assert ".partial-" not in msg and ".poolreps-tmp-" not in msg, msg
        path = msg[len("poolreps: "):].split(":")[0]
        assert path.startswith(target), (target, msg)
        if names is not None:
            assert names.search(path), msg
        assert snapshot(tmpfs) == before, (slack, changed(before, snapshot(tmpfs)))
    else:
        pytest.fail("never succeeded")
    assert failures >= 1, "the disk was never full enough"
