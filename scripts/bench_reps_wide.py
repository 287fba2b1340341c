#!/usr/bin/env python3
"""bench_reps_wide.py — REPS with thousands of features: poolreps.reps (the
Python binding, in-process: the span path for d >= n, Newton on LAPACK
above 1024 features, matrix-free from 8192) against scipy's trust-exact on
the same dual (scripts/bench_reps.py's scipy_solve, numpy's BLAS), in the
same run, for n in {200, 2000, 20000} x d in {1000, 5151, 20000} where
they fit, and (--previous) the poolreps before this path (GSL's Cholesky
at every order, no span path): a shape runs when its features take at most --max-cells cells
(default 2e7: 160 MB), scipy only while its d x d Hessian takes at most
--scipy-max-d columns (default 5151).

Problems (seeded per shape): Gaussian features, returns the sum of the
first three plus unit noise, eps = 0.5. Each solver runs in a child
process of its own, which makes the data and times the solve alone; the
peak memory is the child's maximum resident set (data included, the same
for both). A child that runs past --timeout seconds is stopped and its row
says timeout. CSV (--csv) per shape and solver: n, d, solver, seconds,
peak_mib, status, path, max_abs_dp (against scipy when both answered),
load1 (the 1-minute load average when the row was measured: the machine
is shared, numbers under a load above the core count are contended)."""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import csv
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NS = [200, 2000, 20000]
DS = [1000, 5151, 20000]
EPS = 0.5


def data(n, d):
    rng = np.random.default_rng([43, n, d])
    phi = rng.normal(size=(n, d))
    return phi[:, :3].sum(1) + rng.normal(size=n), phi


def child(solver, n, d, out, root):
    """Solve one shape in this process (poolreps: the binding of the tree
    root); p to out (.npy), a summary line to stdout."""
    R, phi = data(n, d)
    if solver.startswith("poolreps"):
        sys.path.insert(0, os.path.join(ROOT, "scripts"))
        from bench_reps import binding
        os.environ["POOLREPS_LIB"] = os.path.join(root, "build", "rel", "libpoolreps.so.0.1.0")
        mod = binding(root)
        t = time.perf_counter()
        r = mod.reps(R, phi, epsilon=EPS)
        dt, p, status, path = time.perf_counter() - t, r["p"], r["status"], r["path"]
    else:
        sys.path.insert(0, os.path.join(ROOT, "scripts"))
        from bench_reps import scipy_solve
        t = time.perf_counter()
        p, _ = scipy_solve(R, phi, EPS)
        dt, status, path = time.perf_counter() - t, "", "trust-exact"
    np.save(out, p)
    print(f"{dt!r},{status},{path}")


def run(solver, n, d, tmp, timeout, root=ROOT):
    """(seconds, peak MiB, status, path, p or None) of one child."""
    out = os.path.join(tmp, f"{solver}.npy")
    proc = subprocess.Popen([sys.executable, __file__, "--child", solver, str(n), str(d), out,
                             root],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    while True:
        pid, st, ru = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        if time.monotonic() - t0 > timeout:
            proc.kill()
            _, st, ru = os.wait4(proc.pid, 0)
            return "", round(ru.ru_maxrss / 1024), "timeout", "", None
        time.sleep(0.05)
    text = proc.stdout.read().strip()
    err = proc.stderr.read().strip()
    peak = round(ru.ru_maxrss / 1024)
    if st != 0 or not text:
        return "", peak, "error: " + (err.splitlines() or ["?"])[-1][:80], "", None
    secs, status, path = text.splitlines()[-1].split(",")
    return float(secs), peak, status, path, np.load(out)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--csv", default=os.path.join(ROOT, "build", "bench", "reps_wide.csv"))
    ap.add_argument("--max-cells", type=float, default=2e7)
    ap.add_argument("--scipy-max-d", type=int, default=5151)
    ap.add_argument("--timeout", type=float, default=600.0)
    ap.add_argument("--previous", help="source tree of an earlier poolreps (build/rel built)")
    ap.add_argument("--child", nargs=5)
    a = ap.parse_args()
    if a.child:
        child(a.child[0], int(a.child[1]), int(a.child[2]), a.child[3], a.child[4])
        return
    import tempfile
    os.makedirs(os.path.dirname(a.csv), exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in NS:
            for d in DS:
                if n * d > a.max_cells:
                    continue
                res = {"poolreps": run("poolreps", n, d, tmp, a.timeout)}
                if a.previous:
                    res["poolreps-previous"] = run("poolreps-previous", n, d, tmp, a.timeout,
                                                   a.previous)
                if d <= a.scipy_max_d:
                    res["scipy-trust-exact"] = run("scipy", n, d, tmp, a.timeout)
                ref = res.get("scipy-trust-exact", (None,) * 5)[4]
                for solver, (secs, peak, status, path, p) in res.items():
                    dp = "" if p is None or ref is None else float(np.abs(p - ref).max())
                    rows.append([n, d, solver, secs, peak, status, path, dp, os.getloadavg()[0]])
                    print(*rows[-1], sep=",", flush=True)
    with open(a.csv, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["n", "d", "solver", "seconds", "peak_mib", "status", "path", "max_abs_dp",
                    "load1"])
        w.writerows(rows)


if __name__ == "__main__":
    main()
