#!/usr/bin/env python3
"""Print the README's Experiment 3 table (markdown) from DIR/exp3_episodes.csv.

Usage: exp3_table.py DIR [--last N]

Per policy, over each run's last N episodes (default: exp3.final_episodes
from DIR/config.ini, else 500): the mean return of all runs pooled, the
sample std of the run means, the paired difference to the baseline's run of
the same repetition (mean +- sample std over repetitions), reward balls
pocketed in pocket 2 / pocket 5 / any other pocket, the hit rate (cue ball
touched the reward ball) and the median cue speed.
"""
import argparse
import configparser
import csv
import math
import os
import statistics
from collections import defaultdict

TARGETS = ("2", "5")


def last_episodes(path, n):
    runs = defaultdict(list)
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            runs[(row["policy"], int(row["repetition"]))].append(row)
    return {key: rows[-n:] for key, rows in runs.items()}


def fmt_pm(values):
    if len(values) < 2:
        return f"{values[0]:+.3f}"
    return f"{statistics.mean(values):+.3f} ± {statistics.stdev(values):.3f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    ap.add_argument("--last", type=int, default=None)
    args = ap.parse_args()
    n = args.last
    if n is None:
        cfg = configparser.ConfigParser()
        cfg.read(os.path.join(args.dir, "config.ini"))
        n = cfg.getint("exp3", "final_episodes", fallback=500)
    runs = last_episodes(os.path.join(args.dir, "exp3_episodes.csv"), n)
    policies = list(dict.fromkeys(p for p, _ in runs))
    reps = sorted({r for _, r in runs})
    run_mean = {k: statistics.mean(float(e["return"]) for e in v) for k, v in runs.items()}
    print("| policy | mean return | std over runs | paired vs baseline "
          "| pocketed 2 / 5 / other | hit rate | median speed |")
    print("|---|---:|---:|---:|---|---:|---:|")
    for p in policies:
        eps = [e for r in reps for e in runs[(p, r)]]
        means = [run_mean[(p, r)] for r in reps]
        pooled = statistics.mean(float(e["return"]) for e in eps)
        std = statistics.stdev(means) if len(means) > 1 else 0.0
        if ("baseline", reps[0]) in runs:
            diff = fmt_pm([run_mean[(p, r)] - run_mean[("baseline", r)] for r in reps])
        else:
            diff = "–"
        pk = [e["pocket"] for e in eps]
        other = sum(1 for x in pk if x not in TARGETS and x != "-1")
        hit = sum(int(e["hit"]) for e in eps) / len(eps)
        speed = statistics.median(math.hypot(float(e["vx"]), float(e["vy"])) for e in eps)
        print(f"| {p} | {pooled:.3f} | {std:.3f} | {diff} | {pk.count('2')} / {pk.count('5')} / "
              f"{other} | {100 * hit:.0f} % | {speed:.2f} m/s |")


if __name__ == "__main__":
    main()
