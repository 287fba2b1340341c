"""The contextual sphere and Rosenbrock benchmarks through poolreps.Learner
give the numbers of `poolreps data/NAME.ini` (quick settings) bit for bit.

The command line's C-REPS loop is the learner with learner.window = 0
(each tell's episodes alone, uniform base weights), value = given (the
context itself), a linear policy drawing with its fit's decomposition
(learner.draw = fit) and pi_0 = N(mu0, I). Here the same loop runs in
Python: G, mu0, the test contexts and each episode's context are drawn from
the learner's own stream in the command line's order (context, action,
context, ...), and the objective is evaluated in plain Python."""
import ctypes
import math
import sys

import numpy as np
import pytest

from conftest import ROOT, csv_rows, quick_sets, run_poolreps

sys.path.insert(0, str(ROOT / "python"))
import poolreps  # noqa: E402
from poolreps import _lib  # noqa: E402

lib = _lib.lib
lib.pr_policy_gaussian_new.restype = ctypes.c_void_p
lib.pr_policy_gaussian_new.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_void_p,
                                       ctypes.c_void_p, ctypes.c_char_p]
STREAM = 0xbe4c4  # the benchmarks' stream id (src/streams.h)
M64 = (1 << 64) - 1


def mix(z):
    """The splitmix64 finaliser, from its published constants."""
    z = (z + 0x9e3779b97f4a7c15) & M64
    z = ((z ^ (z >> 30)) * 0xbf58476d1ce4e5b9) & M64
    z = ((z ^ (z >> 27)) * 0x94d049bb133111eb) & M64
    return z ^ (z >> 31)


def stream_seed(seed, rep):
    """The mt19937 seed of repetition rep's stream."""
    h = mix(mix(mix(seed) ^ STREAM) ^ rep) & 0xffffffff
    return h or 1


def uniforms(rng, k):
    u = np.empty(k)
    lib.pr_bind_uniforms_each((ctypes.c_void_p * 1)(rng), 1, k, u.ctypes.data)
    return u


def gaussians(rng, m):
    """m draws of N(0, 1) from rng (a one-dimensional unit Gaussian policy)."""
    zero, one, err = np.zeros(1), np.ones(1), _lib.errbuf()
    p = lib.pr_policy_gaussian_new(1, 1, zero.ctypes.data, one.ctypes.data, err)
    out, st = np.empty(m), np.empty(1, dtype=np.intc)
    try:
        _lib.check(lib.pr_bind_policy_sample_rng(p, 1, zero.ctypes.data, m, rng, out.ctypes.data,
                                                 st.ctypes.data, err), err)
    finally:
        lib.pr_policy_free(p)
    return out


def objective(problem, G, x, s):
    """The command line's return, term by term in its order."""
    y = list(x)
    for i in range(len(x)):
        for j in range(len(s)):
            y[i] += G[i * len(s) + j] * s[j]
    if problem == "sphere":
        f = 0.0
        for v in y:
            f += v * v
        return -f
    f = 0.0
    for i in range(len(y) - 1):
        f += 100.0 * (y[i + 1] - y[i] * y[i]) * (y[i + 1] - y[i] * y[i]) + (1.0 - y[i]) * (1.0 - y[i])
    return -f


def optimum(problem, G, s, da):
    out = []
    for i in range(da):
        v = 1.0 if problem == "rosenbrock" else 0.0
        for j in range(len(s)):
            v -= G[i * len(s) + j] * s[j]
        out.append(v)
    return out


def python_run(problem, keys, seed, rep):
    """Rows of bench_curve.csv's columns (all but samples, mean_std and
    policy_flags) per iteration of repetition rep, through poolreps.Learner."""
    n, da, k = int(keys["bench.samples"]), int(keys["bench.dims"]), int(keys["bench.context_dims"])
    T, iters = int(keys["bench.test_contexts"]), int(keys["bench.iterations"])
    scratch = _lib.rng_handle(lib.pr_bind_rng_new(stream_seed(seed, rep)))
    G = gaussians(scratch.ptr, da * k)
    mu0 = gaussians(scratch.ptr, da)
    tc = (1.0 + uniforms(scratch.ptr, T * k)).reshape(T, k)
    L = poolreps.Learner(k, da, value="given", policy="linear", init_mean=mu0, set={
        "learner.window": 0, "learner.draw": "fit", "learner.init_std": keys["bench.init_std"],
        "policy.min_std": keys["bench.min_std"], "policy.lambda": keys["policy.lambda"],
        "policy.cov_center": "old", "reps.epsilon": keys["reps.epsilon"]})
    # the learner's stream goes on where the problem's draws left it
    ctypes.memmove(lib.pr_bind_rng_state(L._rng.ptr), _lib.rng_state(scratch), len(_lib.rng_state(scratch)))
    rows = []
    for _ in range(iters):
        S, A, R = np.empty((n, k)), np.empty((n, da)), np.empty(n)
        ret = 0.0
        for i in range(n):
            S[i] = 1.0 + uniforms(L._rng.ptr, k)
            A[i] = L.ask(S[i:i + 1])[0]
            R[i] = objective(problem, G, A[i], S[i])
            ret += R[i] / n
        M = L.mean(tc)
        tr, e2 = 0.0, 0.0
        for t in range(T):
            tr += objective(problem, G, M[t], tc[t])
            for mj, xj in zip(M[t], optimum(problem, G, tc[t], da)):
                e2 += (mj - xj) * (mj - xj)
        L.tell(S, A, R, features=S)
        s = L.summary
        rows.append((ret, tr / T, math.sqrt(e2 / T), s["eta"], s["kl"], s["ess"], s["bound"],
                     s["kl_gap"], s["residual_rel"], s["status"] == "unreachable",
                     s["status"] == "failed"))
    return rows


@pytest.mark.parametrize("problem", ["sphere", "rosenbrock"])
def test_the_python_learner_gives_the_command_lines_numbers(tmp_path, problem):
    import configparser
    ini = configparser.ConfigParser(inline_comment_prefixes=None, comment_prefixes=(";", "#"))
    ini.read(ROOT / "data" / f"{problem}.ini")
    keys = {f"{s}.{k}": v for s in ini.sections() for k, v in ini[s].items()}
    sets = quick_sets(problem) + ["bench.iterations=4"]
    keys.update(a.split("=", 1) for a in sets)
    r = run_poolreps([ROOT / "data" / f"{problem}.ini", "-o", tmp_path / "out"]
                     + [x for a in sets for x in ("--set", a)])
    assert r.returncode == 0, r.stderr
    _, cli = csv_rows(tmp_path / "out" / "bench_curve.csv")
    cols = ("mean_return", "test_return", "test_error", "eta", "kl", "ess", "bound", "kl_gap",
            "residual_rel", "unreachable", "failed")
    for rep in range(int(keys["experiment.repetitions"])):
        got = python_run(problem, keys, int(keys["experiment.seed"]), rep)
        want = [tuple(float(row[c]) for c in cols) for row in cli if int(row["repetition"]) == rep]
        assert got == want, (rep, got[0], want[0])
