#!/usr/bin/env python3
"""bench_python.py [--shots N] [--runs K] [--seed S] [--params] — poolreps.shoot throughput.

The workload of tests/bench/bench_sim.c (event mode, "gauss"): 2-ball shots
from Experiment 3's start region, actions N(0, 0.1^2 I), a pool of 65536
shots repeated to N rows. Times one poolreps.shoot call on all N rows per
run (input checks, the C loop, the reward, the output arrays); the inputs
are drawn before the clock starts. Prints one key=value line like bench_sim.
--params: each row with its own table.friction (uniform 0.1..0.5) and
table.restitution (uniform 0.5..1), as domain randomisation draws them.
"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python"))
import poolreps  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("--shots", type=int, default=1000000)
ap.add_argument("--runs", type=int, default=5)
ap.add_argument("--seed", type=int, default=1)
ap.add_argument("--params", action="store_true")
a = ap.parse_args()

POOL = 65536
states, _ = poolreps.PocketEnv().reset_batch(POOL, seed=a.seed)
actions = np.random.default_rng(a.seed).normal(0, 0.1, (POOL, 2))
# at least 16 pool copies whatever --shots, so that the set-up does not grow
# with it (scripts/bench_python.sh counts the instructions per extra shot)
reps = max(16, -(-a.shots // POOL))
balls, acts = np.tile(states, (reps, 1))[:a.shots], np.tile(actions, (reps, 1))[:a.shots]
params = None
if a.params:
    prng = np.random.default_rng(a.seed + 1)
    params = {"table.friction": prng.uniform(0.1, 0.5, a.shots),
              "table.restitution": prng.uniform(0.5, 1.0, a.shots)}
rates = []
for _ in range(a.runs):
    t0 = time.perf_counter()
    r = poolreps.shoot(balls, acts, params=params)
    rates.append(a.shots / (time.perf_counter() - t0))
rates.sort()
print(f"mode=event actions=gauss params={int(a.params)} shots={a.shots} runs={a.runs} "
      f"median_shots_per_s={rates[len(rates) // 2]:.0f} min={rates[0]:.0f} max={rates[-1]:.0f} "
      f"events_per_shot={r['events'].mean():.2f} library={poolreps.library_path()}")
