"""Wide REPS problems beyond memory: a problem whose solve would need more
memory than the process may use fails before the solver allocates it, with
the size in its one-line message (PR_ENOMEM: MemoryError in Python, exit 4
on the command line). The limit is the address-space limit (ulimit -v) set
in a child process, so that the test does not depend on the machine's
memory."""
import os
import subprocess
import sys

import pytest

from conftest import ROOT

CHILD = r"""
import resource, sys, time
resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
sys.path.insert(0, sys.argv[1])
import numpy as np, scipy.sparse as sp, poolreps
n = 20000
# one leaf of its own per sample: 19999 free one-hot features, a Hessian
# of 3 GiB
F = sp.csr_matrix((np.ones(n), (np.arange(n), np.arange(n))), shape=(n, n))
t = time.time()
try:
    poolreps.reps(np.arange(n, dtype=float), features=F)
    print("solved")
except MemoryError as e:
    print("MemoryError", e, "%.3f" % (time.time() - t))
"""


@pytest.mark.skipif(os.environ.get("SAN") == "1", reason="ASan reserves more address space")
def test_too_large_for_memory_fails_before_allocating():
    r = subprocess.run([sys.executable, "-c", CHILD, str(ROOT / "python")], capture_output=True,
                       text=True, timeout=120, env=dict(os.environ, LC_ALL="C"))
    assert r.returncode == 0, r.stderr
    out = r.stdout.strip().splitlines()
    assert len(out) == 1 and out[0].startswith("MemoryError reps: 20000 samples x 19999 free "
                                               "features need about 2.98 GiB, more than the "
                                               "2 GiB of memory"), out
    # refused up front, not after building a 3 GiB matrix
    assert float(out[0].split()[-1]) < 1.0


@pytest.mark.native  # a latency of the bare process (valgrind is slower)
def test_interrupted_wide_solve_exits_within_half_a_second(tmp_path):
    """SIGINT during a wide solve (n = 1200, d = 3000: the span's LAPACK
    calls, which do not poll for signals, take seconds): exit 130 within
    0.5 s of the signal, one stderr line, no output file."""
    import signal
    import time

    import numpy as np

    from test_ref_reps import BIN
    rng = np.random.default_rng(43)
    phi = rng.normal(size=(1200, 3000))
    np.savetxt(tmp_path / "in.csv", np.c_[phi[:, :3].sum(1), phi], fmt="%.6g", delimiter=",",
               header=",".join(["R"] + [f"phi{j}" for j in range(3000)]), comments="")
    out = tmp_path / "p.csv"
    p = subprocess.Popen([BIN, "reps", "--return", "R", "--features", "phi*", "-i",
                          str(tmp_path / "in.csv"), "-o", str(out), "-q"],
                         stderr=subprocess.PIPE, text=True, env=dict(os.environ, LC_ALL="C"))
    time.sleep(1.0)
    assert p.poll() is None, "the solve ended within 1 s: make the problem larger"
    t = time.monotonic()
    p.send_signal(signal.SIGINT)
    p.wait(timeout=10)
    assert time.monotonic() - t <= 0.5
    err = p.stderr.read().splitlines()
    assert p.returncode == 130 and len(err) == 1 and "interrupted by SIGINT" in err[0], err
    assert not out.exists() and sorted(x.name for x in tmp_path.iterdir()) == ["in.csv"]
