#!/usr/bin/env python3
"""bench_learner.py — the ask/tell learner's cost from Python (bench_learner.sh).

1. Experiment 3's nrvr_a run (thesis settings, one repetition, one thread)
   through poolreps.Learner: the same start states (Experiment 3's stream),
   actions within sim.max_speed, returns from poolreps.shoot, 200 episodes
   then 100 tells of 20, against `poolreps data/exp3.ini` running that one
   run. Wall seconds per iteration of each and their ratio.
2. ask + tell at 100 episodes (2-D contexts and actions, linear features
   and policy, the cheapest update): the Learner's methods against the bare
   C calls through ctypes on prepared arrays; the difference per call is the
   binding's overhead beyond the update. pycma's es.ask() + es.tell() at
   population 100 in 2-D beside it when `cma` imports (build/venv).
Prints one markdown row per measurement; ROUNDS rounds, medians. With
--csv PATH also writes them (milliseconds, and the load average after the
runs) for scripts/bench_learner_table.py."""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import ctypes
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "python"))
import poolreps  # noqa: E402
from poolreps import _lib  # noqa: E402
from poolreps import learner as _learner  # noqa: E402,F401  (declares the prototypes)

EXP3_SETS = {"learner.value": "nrvr", "learner.policy": "tree", "learner.window": 200,
             "learner.init_std": 0.1, "learner.max_norm": 10, "value.trees": 10, "value.cuts": 10,
             "value.n_min": 60, "value.n_c": 1, "value.replacement": "with", "policy.trees": 10,
             "policy.cuts": 20, "policy.n_min": 75, "policy.n_c": 1, "policy.lambda": 1e-10,
             "reps.epsilon": 0.5}


def exp3_python(poolreps_bin):
    """Wall seconds of Experiment 3's nrvr_a loop through poolreps.Learner."""
    shoot_set = {"start.reward_box": "0.05,0.15,-0.1,0.1", "start.cue_box": "-0.25,-0.25,0,0"}
    cfg = _lib.config(_lib.assignments({"experiment.name": "exp3", **shoot_set}))
    starts = _lib.rng_handle(_lib.lib.pr_bind_exp3_start_rng(1, 0))
    n = 200 + 100 * 20
    S = np.empty((n, 4))
    err = _lib.errbuf()
    _lib.check(_lib.lib.pr_bind_starts(cfg.ptr, starts.ptr, n, _lib.addr(S), err), err)
    t0 = time.perf_counter()
    L = poolreps.Learner(2, 2, seed=1, set=EXP3_SETS)
    lo = 0
    for k in [200] + [20] * 100:
        X = S[lo:lo + k, 2:4]
        A = L.ask(X)
        R = poolreps.shoot(S[lo:lo + k], A, set={"experiment.name": "exp3", **shoot_set})["reward"]
        if lo + k < n:
            L.tell(X, A, R)
        lo += k
    return time.perf_counter() - t0


def exp3_cli(poolreps_bin):
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        subprocess.run([poolreps_bin, "data/exp3.ini", "-q", "-o", d, "--set",
                        "exp3.policies=nrvr_a", "--set", "experiment.repetitions=1", "--set",
                        "experiment.threads=1"], check=True, cwd=ROOT)
        return time.perf_counter() - t0


def overhead(rounds, calls=200):
    """Seconds per ask + tell: through the Learner, through bare ctypes calls."""
    keys = {"learner.value": "linear", "learner.policy": "linear", "learner.window": 100}
    rng = np.random.default_rng(0)
    X = np.ascontiguousarray(rng.uniform(-1, 1, (100, 2)))
    lib, err = _lib.lib, _lib.errbuf()

    def ret(A):
        return -((A - X) ** 2).sum(axis=1)

    py, bare = [], []
    for _ in range(rounds):
        L = poolreps.Learner(2, 2, seed=1, set=keys)
        t0 = time.perf_counter()
        for _ in range(calls):
            A = L.ask(X)
            L.tell(X, A, ret(A))
        py.append((time.perf_counter() - t0) / calls)
        M = poolreps.Learner(2, 2, seed=1, set=keys)
        A = np.empty((100, 2))
        px, pa = _lib.addr(X), _lib.addr(A)
        t0 = time.perf_counter()
        for _ in range(calls):
            lib.pr_learner_ask(M._h.ptr, 100, px, pa, err)
            R = ret(A)
            lib.pr_bind_learner_tell(M._h.ptr, 100, px, pa, _lib.addr(R), None, 0, None, 0, err)
        bare.append((time.perf_counter() - t0) / calls)
    return statistics.median(py), statistics.median(bare)


def pycma(rounds, calls=200):
    try:
        import cma
    except ImportError:
        return None
    out = []
    for _ in range(rounds):
        es = cma.CMAEvolutionStrategy([0.0, 0.0], 1.0, {"popsize": 100, "verbose": -9, "seed": 1})
        t0 = time.perf_counter()
        for _ in range(calls):
            P = es.ask()
            es.tell(P, [float(np.sum(np.square(p))) for p in P])
        out.append((time.perf_counter() - t0) / calls)
    return statistics.median(out)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--poolreps", default=str(ROOT / "build/rel/poolreps"))
    ap.add_argument("--rounds", type=int, default=int(os.environ.get("ROUNDS", 3)))
    ap.add_argument("--csv")
    a = ap.parse_args()
    py, cli = [], []
    for _ in range(a.rounds):  # alternate, so both see the same load
        cli.append(exp3_cli(a.poolreps))
        py.append(exp3_python(a.poolreps))
    mp, mc = statistics.median(py), statistics.median(cli)
    print("| measurement | rounds | median | ratio |")
    print("|---|---:|---:|---:|")
    print(f"| Experiment 3 nrvr_a, 1 repetition: `poolreps data/exp3.ini`, s per iteration | "
          f"{a.rounds} | {mc / 100:.4f} | |")
    print(f"| the same loop through poolreps.Learner + poolreps.shoot, s per iteration | "
          f"{a.rounds} | {mp / 100:.4f} | {mp / mc:.2f} |")
    t_py, t_bare = overhead(a.rounds)
    print(f"| ask + tell at 100 episodes, poolreps.Learner, ms per call pair | {a.rounds} | "
          f"{1e3 * t_py:.3f} | |")
    print(f"| the same C calls through bare ctypes, ms per call pair | {a.rounds} | "
          f"{1e3 * t_bare:.3f} | |")
    print(f"| binding overhead beyond the update, ms per call pair | {a.rounds} | "
          f"{1e3 * (t_py - t_bare):.3f} | |")
    c = pycma(a.rounds)
    print(f"| pycma es.ask() + es.tell(), population 100, 2-D, ms per call pair | {a.rounds} | "
          + (f"{1e3 * c:.3f} | |" if c is not None else "not installed (make venv) | |"))
    if a.csv:
        ms = {"exp3_cli_iteration": 10 * mc, "exp3_python_iteration": 10 * mp,
              "ask_tell_learner": 1e3 * t_py, "ask_tell_bare": 1e3 * t_bare}
        if c is not None:
            ms["pycma_ask_tell"] = 1e3 * c
        with open(a.csv + ".tmp", "w") as f:
            f.write("measurement,rounds,median_ms,load\n")
            for k, v in ms.items():
                f.write(f"{k},{a.rounds},{v:.4f},{os.getloadavg()[0]:.1f}\n")
        os.replace(a.csv + ".tmp", a.csv)


if __name__ == "__main__":
    main()
