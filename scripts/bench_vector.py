#!/usr/bin/env python3
"""bench_vector.py [--envs N ...] [--rounds K] [--seconds S] — environment
steps per second of the native vector env (PocketVectorEnv, one batch call
per step, its shots split over one thread per CPU by default; kind native1:
threads=1, at the --sync-envs sizes) against Gymnasium's SyncVectorEnv of
PocketEnvs (a Python loop over the sub-envs), both with same-step
autoreset, on two action workloads:

  gauss    velocities N(0, 0.1^2 I) m/s (tests/bench/bench_sim.c's shots)
  uniform  normalize_actions=True, actions uniform in [-1, 1]^2 (a fresh
           policy's; faster shots, more cushion events per shot)

and per-row physics: poolreps.shoot on --rows rows of the gauss workload,
plain and with table.friction and table.restitution per row (workload
shoot, kind plain or params, envs = rows, steps_per_s = shots/s).

Rounds alternate the kinds so that all see the same machine load; each
round steps for S seconds. Writes CSV rows workload,envs,kind,round,
steps_per_s,load1 (the 1-minute load average as the round ended),threads
(the threads the kind's batch calls use) to stdout."""
import os
import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python"))
import gymnasium  # noqa: E402
from gymnasium.vector import AutoresetMode  # noqa: E402

import poolreps  # noqa: E402,F401  (registers the environment)

ap = argparse.ArgumentParser()
ap.add_argument("--envs", type=int, nargs="+", default=[256, 4096])
ap.add_argument("--sync-envs", type=int, nargs="+", default=[256])
ap.add_argument("--rounds", type=int, default=5)
ap.add_argument("--seconds", type=float, default=1.0)
ap.add_argument("--rows", type=int, default=262144)
a = ap.parse_args()

WORKLOADS = {"gauss": {}, "uniform": {"normalize_actions": True}}


def make(kind, n, kwargs):
    if kind in ("native", "native1"):
        threads = {"threads": 1} if kind == "native1" else {}
        return gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=n,
                                  vectorization_mode="vector_entry_point", **threads, **kwargs)
    return gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=n, vectorization_mode="sync",
                              vector_kwargs={"autoreset_mode": AutoresetMode.SAME_STEP}, **kwargs)


def actions(workload, n, rng):
    if workload == "gauss":
        return rng.normal(0, 0.1, (n, 2))
    return rng.uniform(-1, 1, (n, 2)).astype(np.float32)


def rate(env, acts, seconds):
    """Steps of all sub-envs per second, over whole calls for at least seconds."""
    k, steps, t0 = 0, 0, time.perf_counter()
    while True:
        env.step(acts[k % len(acts)])
        k, steps = k + 1, steps + env.num_envs
        dt = time.perf_counter() - t0
        if dt >= seconds:
            return steps / dt


def shoot_rate(states, acts, params, seconds):
    k, t0 = 0, time.perf_counter()
    while True:
        poolreps.shoot(states, acts, params=params)
        k += 1
        dt = time.perf_counter() - t0
        if dt >= seconds:
            return k * len(states) / dt


CPUS = min(len(os.sched_getaffinity(0)), 64)  # what threads=0 means (the library's cap)


def row(w, n, kind, r, rate):
    threads = CPUS if kind == "native" else 1
    print(f"{w},{n},{kind},{r},{rate:.0f},{os.getloadavg()[0]:.2f},{threads}", flush=True)


print("workload,envs,kind,round,steps_per_s,load1,threads")
rng = np.random.default_rng(1)
states, _ = poolreps.PocketEnv().reset_batch(a.rows, seed=1)
acts = rng.normal(0, 0.1, (a.rows, 2))
params = {"table.friction": rng.uniform(0.1, 0.5, a.rows),
          "table.restitution": rng.uniform(0.5, 1.0, a.rows)}
for r in range(a.rounds):
    for kind, p in (("plain", None), ("params", params)):
        row("shoot", a.rows, kind, r, shoot_rate(states, acts, p, a.seconds))
for w, kwargs in WORKLOADS.items():
    sizes = sorted(set(a.envs) | set(a.sync_envs))
    envs = {(kind, n): make(kind, n, kwargs) for n in sizes
            for kind in ("native", "native1", "sync")
            if kind == "native" and n in a.envs or kind != "native" and n in a.sync_envs}
    for e in envs.values():
        e.reset(seed=1)
    acts = {n: [actions(w, n, rng) for _ in range(16)] for n in sizes}
    for r in range(a.rounds):
        for (kind, n), e in envs.items():
            row(w, n, kind, r, rate(e, acts[n], a.seconds))
