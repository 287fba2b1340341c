#!/usr/bin/env python3
"""bench_reps.py — `poolreps reps` (a whole process: reading the CSV,
solving, certifying, writing) against scipy.optimize.minimize(method=
'trust-exact') on the same dual (eq. 3.8) in-process, in one run.

Problems (seeded): dense Gaussian features n = 2000, d = 140, eps = 2.4e-5;
dense n = 20000, d = 200, eps = 0.5; one-hot, n = 2000 with 80 features
(4 trees of 20 leaves), eps = 0.5. scipy minimises g over (log eta, theta)
on returns standardised as poolreps does (shift by the max, divide by the
q-weighted standard deviation), with exact gradient and Hessian, gtol 1e-10,
from (0, 0). Each timing is the median of RUNS (default 3). Writes a CSV
row per problem and solver to --csv: problem, n, d, eps, solver, seconds,
status, kl_gap, residual_rel, max |p - p_scipy|; the ratio scipy / poolreps
is printed. When the Python binding loads, poolreps.reps (the same solve
without the CSV round trip) is timed in-process too. --previous ROOT (a
source tree with build/rel built; scripts/bench_reps.sh builds one from
git) adds the same runs of an earlier poolreps: whole process (solver
poolreps-newton-previous) and in-process through its own binding and
library, in a child process (poolreps-newton-inprocess-previous)."""
import argparse
import csv
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from scipy import optimize
from scipy.special import logsumexp

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def problem(name):
    rng = np.random.default_rng({"dense140": 1, "dense200": 2, "onehot80": 3}[name])
    if name == "onehot80":
        n, leaves = 2000, 20
        S = rng.uniform(size=(n, 2))
        cols = []
        for _ in range(4):
            cut = np.sort(rng.uniform(size=leaves - 1))
            cols.append(np.eye(leaves)[np.searchsorted(cut, S[:, int(rng.integers(2))])])
        phi = np.hstack(cols)
        R = np.sin(3 * S[:, 0]) - S[:, 1] + 0.3 * rng.normal(size=n)
        return R, phi, 0.5
    n, d, eps = (2000, 140, 2.4e-5) if name == "dense140" else (20000, 200, 0.5)
    phi = rng.normal(size=(n, d))
    R = phi[:, :3].sum(1) + rng.normal(size=n)
    return R, phi, eps


def scipy_solve(R, phi, eps):
    n = len(R)
    Rs = R - R.max()
    Rs = Rs / Rs.std()
    psi = phi - phi.mean(0)
    lq = np.full(n, -np.log(n))

    def terms(x):
        eta, th = np.exp(x[0]), x[1:]
        A = Rs - psi @ th
        z = lq + A / eta
        lz = logsumexp(z)
        p = np.exp(z - lz)
        u = A / eta
        kl = p @ (z - lz - lq)
        ep = p @ psi
        pw = psi * p[:, None]
        H = np.empty((len(th) + 1,) * 2)
        H[0, 0] = eta * (eps - kl) + eta * (p @ u**2 - (p @ u) ** 2)
        H[0, 1:] = H[1:, 0] = pw.T @ u - ep * (p @ u)
        H[1:, 1:] = (pw.T @ psi - np.outer(ep, ep)) / eta
        return eta * eps + eta * lz, np.r_[eta * (eps - kl), -ep], H, p

    cache = {}

    def get(x):
        k = x.tobytes()
        if k not in cache:
            cache.clear()
            cache[k] = terms(x)
        return cache[k]

    res = optimize.minimize(lambda x: get(x)[0], np.zeros(phi.shape[1] + 1), jac=lambda x: get(x)[1],
                            hess=lambda x: get(x)[2], method="trust-exact",
                            options={"gtol": 1e-10, "maxiter": 1000})
    return get(res.x)[3]


def run_poolreps(binary, path, eps, tmp, extra):
    args = [binary, "reps", "--return", "R", "--features", "phi*", "--epsilon", repr(eps), "-i", path,
            "-o", os.path.join(tmp, "p.csv"), "--summary", os.path.join(tmp, "s.csv"), "-q"] + extra
    t = time.perf_counter()
    r = subprocess.run(args, capture_output=True, text=True)
    dt = time.perf_counter() - t
    if r.returncode:
        return dt, {"status": "exit %d" % r.returncode, "kl_gap": "", "residual_rel": ""}, None
    with open(os.path.join(tmp, "s.csv")) as f:
        s = next(csv.DictReader(f))
    return dt, s, np.loadtxt(os.path.join(tmp, "p.csv"), skiprows=1)


def in_process(R, phi, eps, runs, root=ROOT):
    """poolreps.reps (the Python binding: the solve without the CSV) of the
    tree root, or None."""
    sys.path.insert(0, os.path.join(root, "python"))
    os.environ.setdefault("POOLREPS_LIB", os.path.join(root, "build", "rel", "libpoolreps.so.0.1.0"))
    try:
        import poolreps
    except (ImportError, OSError):
        return None
    ts = []
    for _ in range(runs):
        t = time.perf_counter()
        out = poolreps.reps(R, phi, epsilon=eps)
        ts.append(time.perf_counter() - t)
    return float(np.median(ts)), out["p"], out


def in_process_previous(root, name, runs):
    """in_process for the tree root, in a child process (its own binding and
    library): (seconds, p, summary) or None."""
    env = dict(os.environ, POOLREPS_LIB=os.path.join(root, "build", "rel", "libpoolreps.so.0.1.0"))
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out.npz")
        r = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", root, "--problems", name,
                            "--runs", str(runs), "--csv", out], env=env)
        if r.returncode or not os.path.exists(out):
            return None
        z = np.load(out)
        return float(z["seconds"]), z["p"], {k: str(z[k]) for k in ("status", "kl_gap", "residual_rel")}


def child(a):
    """--child ROOT: in_process of ROOT on one problem, saved to --csv (npz)."""
    R, phi, eps = problem(a.problems)
    res = in_process(R, phi, eps, a.runs, a.child)
    if res is None:
        return 1
    np.savez(a.csv, seconds=res[0], p=res[1], status=res[2]["status"], kl_gap=res[2]["kl_gap"],
             residual_rel=res[2]["residual_rel"])
    return 0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--poolreps", default=os.path.join(ROOT, "build", "rel", "poolreps"))
    ap.add_argument("--csv", default=os.path.join(ROOT, "build", "bench", "reps.csv"))
    ap.add_argument("--runs", type=int, default=int(os.environ.get("RUNS", "3")))
    ap.add_argument("--problems", default="dense140,dense200,onehot80")
    ap.add_argument("--solvers", default="newton,nlopt")
    ap.add_argument("--previous", help="an earlier poolreps tree (build/rel built), timed the same way")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        return child(a)
    os.makedirs(os.path.dirname(a.csv), exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.problems.split(","):
            R, phi, eps = problem(name)
            path = os.path.join(tmp, "in.csv")
            np.savetxt(path, np.c_[R, phi], delimiter=",", fmt="%.17g", comments="",
                       header=",".join(["R"] + [f"phi{j}" for j in range(phi.shape[1])]))
            ts = []
            for _ in range(a.runs):
                t = time.perf_counter()
                p_ref = scipy_solve(R, phi, eps)
                ts.append(time.perf_counter() - t)
            t_sc = float(np.median(ts))
            rows.append([name, len(R), phi.shape[1], eps, "scipy-trust-exact", t_sc, "", "", "", ""])
            inprocs = [("newton-inprocess", in_process(R, phi, eps, a.runs))]
            if a.previous:
                inprocs.append(("newton-inprocess-previous", in_process_previous(a.previous, name, a.runs)))
            for label, inproc in inprocs:
                if inproc is None:
                    continue
                t_b, p_b, s_b = inproc
                rows.append([name, len(R), phi.shape[1], eps, "poolreps-" + label, t_b,
                             s_b["status"], s_b["kl_gap"], s_b["residual_rel"],
                             "%.3g" % np.abs(p_b - p_ref).max()])
                print(f"{name}: poolreps.reps {label} {t_b:.3f} s, ratio scipy/poolreps "
                      f"{t_sc / t_b:.2f}", flush=True)
            runs = [(s, a.poolreps, s) for s in a.solvers.split(",")]
            if a.previous:
                runs.append(("newton-previous", os.path.join(a.previous, "build", "rel", "poolreps"), "newton"))
            for label, binary, solver in runs:
                extra = ["--set", f"reps.solver={solver}"] if solver != "newton" else []
                res = [run_poolreps(binary, path, eps, tmp, extra) for _ in range(a.runs)]
                t_c = float(np.median([r[0] for r in res]))
                s, p = res[-1][1], res[-1][2]
                diff = "" if p is None else "%.3g" % np.abs(p - p_ref).max()
                rows.append([name, len(R), phi.shape[1], eps, "poolreps-" + label, t_c, s["status"],
                             s["kl_gap"], s["residual_rel"], diff])
                print(f"{name}: poolreps {label} {t_c:.3f} s, scipy trust-exact {t_sc:.3f} s, "
                      f"ratio scipy/poolreps {t_sc / t_c:.2f}, status {s['status']}, "
                      f"max|p - p_scipy| {diff}", flush=True)
    with open(a.csv, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["problem", "n", "d", "eps", "solver", "seconds", "status", "kl_gap",
                    "residual_rel", "max_abs_p_diff"])
        w.writerows(rows)


if __name__ == "__main__":
    sys.exit(main())
