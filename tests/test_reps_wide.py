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
