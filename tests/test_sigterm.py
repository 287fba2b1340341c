"""SIGTERM is honoured promptly (docs/hardening.md, guarantee 5): whatever
long numerical step a run is in (a REPS solve with 5151 features whose
factorisation takes minutes, CMA-ES, forest and policy fits, simulation
batches), it exits with 128 + N, one stderr line and the folder and its
parent as they were, within 1 s of the signal (a batch system sends SIGKILL
30 s after SIGTERM)."""
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

from conftest import ROOT, timeout_scale
from test_safety import QUICK, binary, env, snapshot, changed, wait_for

BOUND = 1.0  # seconds from the signal to the exit
BUSY = 0.5  # CPU seconds of work after the staging folder appeared

# Rosenbrock with 100 context dimensions and quadratic context features:
# 5151 features, one factorisation of their covariance per Newton step
ROSENBROCK = [ROOT / "data" / "rosenbrock.ini", "--set", "bench.context_dims=100", "--set",
              "bench.value_degree=2", "--set", "experiment.repetitions=2"]
RUNS = {
    "rosenbrock_100_contexts": ROSENBROCK,
    "rosenbrock_one_thread": ROSENBROCK + ["--set", "experiment.threads=1"],
    "exp3_forest_policy_reps": [ROOT / "data" / "exp3.ini", "--set", "experiment.threads=1"],
    "exp1_forests": [ROOT / "data" / "exp1.ini", "--set", "exp1.subset=100000", "--set", "exp1.train=500000",
                     "--set", "exp1.trees_list=5000"],
    "exp2_policy_fits": [ROOT / "data" / "exp2.ini", "--set", "exp2.sizes=100000", "--set", "exp2.test=100000"],
    "exp4_simulation": [ROOT / "data" / "exp4.ini"],
    "sphere_cmaes": [ROOT / "data" / "sphere.ini", "--set", "bench.dims=200", "--set", "bench.samples=2000"],
}


def cpu_seconds(pid):
    """User + system CPU time of process pid, all its threads (/proc/PID/stat)."""
    f = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")


def in_its_work(p, out):
    """Wait until run p is past its set-up (its staging folder is in out)
    and then BUSY CPU seconds into its numerical work (CPU, not wall time:
    a loaded machine delays it, it does not cut it short); False when p
    ended first."""
    def staged():
        return out.is_dir() and any(q.name.startswith(".partial-") for q in out.iterdir())
    if not wait_for(lambda: p.poll() is not None or staged(), 60 * timeout_scale()) or p.poll() is not None:
        return False
    start = cpu_seconds(p.pid)
    return wait_for(lambda: p.poll() is not None or cpu_seconds(p.pid) - start >= BUSY,
                    60 * timeout_scale()) and p.poll() is None


def earlier_run(base):
    r = subprocess.run([str(binary()), ROOT / "data" / "quadratic.ini", "-o", "out"] + QUICK, cwd=base,
                       env=env(), capture_output=True)
    assert r.returncode == 0, r.stderr


CASES = ([(w, signal.SIGTERM, e) for w in RUNS for e in (False, True)] +
         [("rosenbrock_100_contexts", s, False) for s in (signal.SIGINT, signal.SIGHUP)] +
         [("exp3_forest_policy_reps", signal.SIGINT, True)])


@pytest.mark.native
@pytest.mark.slow
@pytest.mark.parametrize("what,sig,existing", CASES,
                         ids=[f"{w}-{signal.Signals(s).name}-{'existing' if e else 'new'}" for w, s, e in CASES])
def test_signal_is_honoured_within_a_second(what, sig, existing, tmp_path):
    base = tmp_path / "parent"
    base.mkdir()
    if existing:
        earlier_run(base)
    before = snapshot(tmp_path)
    p = subprocess.Popen([str(binary())] + [str(a) for a in RUNS[what]] + ["-q", "-o", "out"], cwd=base,
                         env=env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if not in_its_work(p, base / "out"):
        p.kill()
        pytest.fail("the run ended or stalled before the signal: " + p.communicate()[1].decode())
    t0 = time.monotonic()
    p.send_signal(sig)
    out, err = p.communicate(timeout=60)
    took = time.monotonic() - t0
    assert p.returncode == 128 + sig, err
    assert err.count(b"\n") == 1 and err.startswith(b"poolreps: interrupted"), err
    assert took < BOUND, f"{took:.2f} s"
    assert snapshot(tmp_path) == before, changed(before, snapshot(tmp_path))
