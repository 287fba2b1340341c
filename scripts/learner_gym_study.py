#!/usr/bin/env python3
"""The learner on Gymnasium's Pendulum-v1 (examples/learn_gym.py) over 20
seeds: tree value features, linear value features (both with the tree-LWR
policy) and contextual CMA-ES (the library's pr_cmaes, as `bench.method =
ccmaes`), at equal episode budgets.

    PYTHONPATH=python build/venv/bin/python scripts/learner_gym_study.py OUT.csv [SEEDS]

Each run draws its training start states from reset(seed) with seeds of its
own (the same for every method: common random numbers) and scores the mean
action of its policy after 200, 400 and 1000 episodes on 30 fixed test
starts (their mean return). One row per (method, seed, episodes), with the
run's CPU seconds so far. scripts/learner_gym_report.py writes the table of
docs/learner.md from it.
"""
import ctypes
import os
import sys
import time
from ctypes import POINTER, Structure, c_char_p, c_double, c_int, c_void_p

import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import gymnasium as gym
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples"))
import poolreps  # noqa: E402
from poolreps._lib import errbuf, lib  # noqa: E402
from learn_gym import BATCH, play, start  # noqa: E402

INIT_STD = 5.0           # pi_0 = N(0, 5^2 I) over the gains, as the example
CHECKPOINTS = (5, 10, 25)  # iterations of BATCH episodes: 200, 400, 1000
TEST = range(10**9, 10**9 + 30)
METHODS = ("trees", "linear", "ccmaes")
AFFINE = 1               # PR_FEATURES_AFFINE: the C-CMA-ES mean is W [1, s]


class Batch(Structure):
    _fields_ = [("n", c_int), ("nb", c_int), ("S", c_void_p), ("X", c_void_p),
                ("R", c_void_p), ("B", c_void_p)]


class Info(Structure):
    _fields_ = [("mueff", c_double), ("sigma", c_double), ("ps_norm", c_double),
                ("hsig", c_int), ("flags", c_int)]


for _name, (_res, _args) in {
    "pr_cmaes_new": (c_void_p, [c_int, c_int, c_int, c_void_p, c_double, c_double, c_char_p]),
    "pr_cmaes_update": (c_int, [c_void_p, POINTER(Batch), POINTER(Info), c_char_p]),
    "pr_cmaes_state": (None, [c_void_p, c_void_p, c_void_p]),
    "pr_cmaes_sigma": (c_double, [c_void_p]),
    "pr_cmaes_free": (None, [c_void_p]),
}.items():
    getattr(lib, _name).restype = _res
    getattr(lib, _name).argtypes = _args


def quadratic(S):
    """[1, s, s_j s_k (j <= k)]: the bench's C-CMA-ES baseline features."""
    k = S.shape[1]
    prods = [S[:, j] * S[:, m] for j in range(k) for m in range(j, k)]
    return np.column_stack([np.ones(len(S)), S, *prods])


class CCMAES:
    """Contextual CMA-ES with the learner's ask/tell/mean, drawing with numpy."""

    def __init__(self, seed, dx=2, da=2):
        self.rng = np.random.default_rng(seed)
        self.da = da
        W0 = np.zeros((da, dx + 1))
        err = errbuf()
        self.c = lib.pr_cmaes_new(AFFINE, dx, da, W0.ctypes.data, INIT_STD, 1e-10, err)
        if not self.c:
            raise RuntimeError(err.value.decode())

    def _state(self):
        nf = 3
        W, C = np.empty((self.da, nf)), np.empty((self.da, self.da))
        lib.pr_cmaes_state(self.c, W.ctypes.data, C.ctypes.data)
        return W, C, lib.pr_cmaes_sigma(self.c)

    def mean(self, S):
        W, _, _ = self._state()
        return np.column_stack([np.ones(len(S)), S]) @ W.T

    def ask(self, S):
        _, C, sigma = self._state()
        z = self.rng.standard_normal((len(S), self.da))
        return self.mean(S) + sigma * z @ np.linalg.cholesky(C).T

    def tell(self, S, X, R):
        S, X, R = (np.ascontiguousarray(v, dtype=float) for v in (S, X, R))
        B = np.ascontiguousarray(quadratic(S))
        b = Batch(len(S), B.shape[1], S.ctypes.data, X.ctypes.data, R.ctypes.data, B.ctypes.data)
        err = errbuf()
        if lib.pr_cmaes_update(self.c, ctypes.byref(b), ctypes.byref(Info()), err):
            raise RuntimeError(err.value.decode())

    def __del__(self):
        lib.pr_cmaes_free(self.c)


def make(method, seed):
    if method == "ccmaes":
        return CCMAES(seed)
    return poolreps.Learner(2, 2, value=method, seed=seed, set={"learner.init_std": INIT_STD})


def run(env, method, seed):
    """[(episodes, test return, CPU seconds)] at the checkpoints."""
    t0 = time.process_time()
    L = make(method, seed)
    tests = [(s, start(env, s)) for s in TEST]
    out = []
    for it in range(1, CHECKPOINTS[-1] + 1):
        seeds = [seed * 10**6 + it * BATCH + i for i in range(BATCH)]
        S = np.array([start(env, s) for s in seeds])
        A = L.ask(S)
        L.tell(S, A, np.array([play(env, s, a) for s, a in zip(seeds, A)]))
        if it in CHECKPOINTS:
            M = L.mean(np.array([x for _, x in tests]))
            score = np.mean([play(env, s, a) for (s, _), a in zip(tests, M)])
            out.append((it * BATCH, score, time.process_time() - t0))
    return out


def main(path, seeds):
    env = gym.make("Pendulum-v1")
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write("method,seed,episodes,test_return,cpu_s\n")
        for seed in range(seeds):
            for method in METHODS:
                for episodes, score, cpu in run(env, method, seed):
                    f.write(f"{method},{seed},{episodes},{score!r},{cpu:.2f}\n")
                f.flush()
            print(f"seed {seed} done", file=sys.stderr)
    os.replace(tmp, path)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 20)
