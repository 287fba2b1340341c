#!/usr/bin/env python3
"""bench_reps.py — `poolreps reps` (a whole process: reading the CSV,
solving, certifying, writing) against scipy.optimize.minimize(method=
'trust-exact') on the same dual (eq. 3.8) in-process, in one run.

Problems (seeded): dense Gaussian features n = 2000, d = 140, eps = 2.4e-5;
dense n = 20000, d = 200, eps = 0.5; one-hot, n = 2000 with 80 features
(4 trees of 20 leaves), eps = 0.5. scipy minimises g over (log eta, theta)
on returns standardised as poolreps does (shift by the max, divide by the
q-weighted standard deviation), with exact gradient and Hessian, gtol 1e-10,
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
from (0, 0). Each timing is the median of RUNS (default 3) rounds, every
solver once per round. Writes a CSV row per problem and solver to --csv:
problem, n, d, eps, solver, seconds, status, kl_gap, residual_rel,
max |p - p_scipy|, evaluations (points at which the dual was evaluated:
scipy's nfev, poolreps' summary `iterations`), blas; the ratio scipy / poolreps
is printed. scipy runs twice: in this process on the BLAS numpy finds
(scipy-trust-exact; OpenBLAS once Debian's libopenblas0 is installed, which
runs on every core) and in a child process on Debian's reference BLAS
(scipy-trust-exact-refblas: libblas3, what python3-numpy pulls in on a
fresh machine), chosen through LD_LIBRARY_PATH and checked in the child's
memory map; the CSV's blas column names the BLAS each one loaded.
When the Python binding loads, poolreps.reps (the same solve
without the CSV round trip) is timed in-process too, in a child process
per round, after one untimed call that loads the library. --previous ROOT (a
source tree with build/rel built; scripts/bench_reps.sh builds one from
git) adds the same runs of an earlier poolreps: whole process (solver
poolreps-newton-previous) and in-process through its own binding and
library, in a child process (poolreps-newton-inprocess-previous).
poolreps runs on every CPU by default (the same bits on any number of
threads); poolreps-newton-threads1 is the whole process with `--threads 1`."""
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
    return get(res.x)[3], res.nfev


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


def binding(root=ROOT):
    """The poolreps module (the Python binding) of the tree root, or None."""
    sys.path.insert(0, os.path.join(root, "python"))
    os.environ.setdefault("POOLREPS_LIB", os.path.join(root, "build", "rel", "libpoolreps.so.0.1.0"))
    try:
        import poolreps
    except (ImportError, OSError):
        return None
    return poolreps


def in_process(mod, R, phi, eps):
    """One poolreps.reps call (the solve without the CSV): seconds, summary, p."""
    t = time.perf_counter()
    out = mod.reps(R, phi, epsilon=eps)
    return time.perf_counter() - t, out, out["p"]


def in_process_child(root, name):
    """in_process for the tree root in a child process (its own binding and
    library; this tree's and the previous one's alike, so that both are
    timed in the same state of a process), or None."""
    env = dict(os.environ, POOLREPS_LIB=os.path.join(root, "build", "rel", "libpoolreps.so.0.1.0"))
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out.npz")
        r = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", root, "--problems", name,
                            "--csv", out], env=env)
        if r.returncode or not os.path.exists(out):
            return None
        z = np.load(out)
        return float(z["seconds"]), {k: str(z[k]) for k in ("status", "kl_gap", "residual_rel",
                                                            "iterations")}, z["p"]


def child(a):
    """--child ROOT: in_process of ROOT on one problem, saved to --csv (npz)."""
    mod = binding(a.child)
    if mod is None:
        return 1
    R, phi, eps = problem(a.problems)
    # the first call loads the library (and whatever it loads): not timed,
    # as in the parent, whose first call falls in the median's tails
    in_process(mod, R, phi, eps)
    t, s, p = in_process(mod, R, phi, eps)
    np.savez(a.csv, seconds=t, p=p, **{k: s[k] for k in ("status", "kl_gap", "residual_rel", "iterations")})
    return 0


def scipy_run(R, phi, eps):
    t = time.perf_counter()
    p, nfev = scipy_solve(R, phi, eps)
    return time.perf_counter() - t, {"status": "", "kl_gap": "", "residual_rel": "", "iterations": nfev}, p


# Debian's reference BLAS and LAPACK (libblas3, liblapack3), ahead of the
# alternatives' choice when they lead LD_LIBRARY_PATH
REF_BLAS = ["/usr/lib/x86_64-linux-gnu/blas", "/usr/lib/x86_64-linux-gnu/lapack"]


def loaded_blas():
    """The BLAS library this process mapped (numpy's), by its path."""
    with open("/proc/self/maps") as f:
        paths = {line.split()[-1] for line in f if "blas" in line.split()[-1]}
    if any("openblas" in p for p in paths):
        return "OpenBLAS"
    if any(os.path.dirname(p) == REF_BLAS[0] for p in paths):
        return "reference BLAS"
    return ", ".join(sorted(paths)) or "unknown"


def scipy_child(name, out):
    """--scipy-child NAME: scipy_run on one problem (untimed once first, as
    in the parent, whose first round falls in the median's tails), saved to
    out (npz) with the BLAS it ran on."""
    R, phi, eps = problem(name)
    scipy_run(R, phi, eps)
    t, s, p = scipy_run(R, phi, eps)
    np.savez(out, seconds=t, p=p, iterations=s["iterations"], blas=loaded_blas())
    return 0


def scipy_refblas(name):
    """scipy_run in a child process on Debian's reference BLAS, or None
    when it is not installed or the child loaded another BLAS."""
    if not os.path.exists(os.path.join(REF_BLAS[0], "libblas.so.3")):
        return None
    env = dict(os.environ, LD_LIBRARY_PATH=":".join(REF_BLAS + [os.environ.get("LD_LIBRARY_PATH", "")]))
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out.npz")
        r = subprocess.run([sys.executable, os.path.abspath(__file__), "--scipy-child", name, "--csv", out],
                           env=env)
        if r.returncode or not os.path.exists(out):
            return None
        z = np.load(out)
        if str(z["blas"]) != "reference BLAS":
            return None
        return float(z["seconds"]), {"status": "", "kl_gap": "", "residual_rel": "",
                                     "iterations": int(z["iterations"])}, z["p"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--poolreps", default=os.path.join(ROOT, "build", "rel", "poolreps"))
    ap.add_argument("--csv", default=os.path.join(ROOT, "build", "bench", "reps.csv"))
    ap.add_argument("--runs", type=int, default=int(os.environ.get("RUNS", "3")))
    ap.add_argument("--problems", default="dense140,dense200,onehot80")
    ap.add_argument("--solvers", default="newton,nlopt")
    ap.add_argument("--previous", help="an earlier poolreps tree (build/rel built), timed the same way")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--scipy-child", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        return child(a)
    if a.scipy_child:
        return scipy_child(a.scipy_child, a.csv)
    os.makedirs(os.path.dirname(a.csv), exist_ok=True)
    rows = []
    # the binding is timed in child processes; here it only has to load
    mod = binding()
    # the BLAS of each scipy peer: this process's (numpy is loaded), the child's
    blas = {"scipy-trust-exact": loaded_blas(), "scipy-trust-exact-refblas": "reference BLAS"}
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.problems.split(","):
            R, phi, eps = problem(name)
            path = os.path.join(tmp, "in.csv")
            np.savetxt(path, np.c_[R, phi], delimiter=",", fmt="%.17g", comments="",
                       header=",".join(["R"] + [f"phi{j}" for j in range(phi.shape[1])]))
            # every solver once per round, rounds interleaved: a change of
            # the machine's load falls on all of them
            runners = [("scipy-trust-exact", lambda: scipy_run(R, phi, eps)),
                       ("scipy-trust-exact-refblas", lambda: scipy_refblas(name))]
            if mod is not None:
                runners.append(("poolreps-newton-inprocess", lambda: in_process_child(ROOT, name)))
            if a.previous:
                runners.append(("poolreps-newton-inprocess-previous",
                                lambda: in_process_child(a.previous, name)))
            for solver in a.solvers.split(","):
                extra = ["--set", f"reps.solver={solver}"] if solver != "newton" else []
                runners.append(("poolreps-" + solver,
                                lambda extra=extra: run_poolreps(a.poolreps, path, eps, tmp, extra)))
                if solver == "newton":
                    # the dense Hessian's rank-k update on one thread
                    runners.append(("poolreps-newton-threads1",
                                    lambda: run_poolreps(a.poolreps, path, eps, tmp, ["--threads", "1"])))
            if a.previous:
                runners.append(("poolreps-newton-previous",
                                lambda: run_poolreps(os.path.join(a.previous, "build", "rel", "poolreps"),
                                                     path, eps, tmp, [])))
            res = {label: [] for label, _ in runners}
            for _ in range(a.runs):
                for label, run in runners:
                    out = run()
                    if out is not None:
                        res[label].append(out)
            p_ref = res["scipy-trust-exact"][-1][2]
            t_sc = float(np.median([r[0] for r in res["scipy-trust-exact"]]))
            for label, _ in runners:
                if not res[label]:
                    continue
                t_c = float(np.median([r[0] for r in res[label]]))
                s, p = res[label][-1][1], res[label][-1][2]
                diff = "" if p is None or label.startswith("scipy") else "%.3g" % np.abs(p - p_ref).max()
                rows.append([name, len(R), phi.shape[1], eps, label, t_c, s["status"], s["kl_gap"],
                             s["residual_rel"], diff, s.get("iterations", ""), blas.get(label, "")])
                print(f"{name}: {label} {t_c:.3f} s, ratio scipy/it {t_sc / t_c:.2f}, "
                      f"status {s['status'] or '-'}, max|p - p_scipy| {diff or '-'}", flush=True)
    print(f"scipy-trust-exact ran on {blas['scipy-trust-exact']}", flush=True)
    with open(a.csv, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["problem", "n", "d", "eps", "solver", "seconds", "status", "kl_gap",
                    "residual_rel", "max_abs_p_diff", "evaluations", "blas"])
        w.writerows(rows)


if __name__ == "__main__":
    sys.exit(main())
