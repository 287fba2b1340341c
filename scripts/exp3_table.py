#!/usr/bin/env python3
"""Print the README's Experiment 3 table (markdown) from DIR/exp3_episodes.csv.

Usage: exp3_table.py DIR [--last N]

Per policy, over each run's last N episodes (default: exp3.final_episodes
from DIR/config.ini, else 500): the mean return of all runs pooled, the
sample std of the run means, the paired difference to the baseline's run of
the same repetition (mean +- sample std over repetitions), reward balls
pocketed in pocket 2 / pocket 5 / any other pocket, the hit rate (cue ball
touched the reward ball) and the median cue speed.

As a module (standard library only): load() selects the episodes, summary()
computes these numbers per policy; scripts/plot_exp3.py, scripts/claims.py
and scripts/report.py use them.
"""
import argparse
import math
import os
import statistics
from collections import defaultdict

import exp_data

TARGETS = ("2", "5")
# the thesis's panel order (Figs. 7.7, 7.8 a-d), then the references
ORDER = ("nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a", "baseline", "handcrafted")
TREE_VARIANTS = ORDER[:4]
NEED = ("repetition", "policy", "iteration", "vx", "vy", "return", "rx", "ry", "pocket", "hit")


def final_episodes(directory):
    """exp3.final_episodes of DIR/config.ini (500 when absent)."""
    return exp_data.config(directory).getint("exp3", "final_episodes", fallback=500)


def load(directory, last=None):
    """({(policy, repetition): [episode rows as dicts]}, last): each run's last
    `last` episodes of DIR/exp3_episodes.csv (default exp3.final_episodes)."""
    if last is None:
        last = final_episodes(directory)
    runs = defaultdict(list)
    for row in exp_data.read_csv(os.path.join(directory, "exp3_episodes.csv"), NEED):
        runs[(row["policy"], int(row["repetition"]))].append(row)
    return {key: rows[-last:] for key, rows in runs.items()}, last


def policies(runs):
    """Policies present, in ORDER (unknown names last, as found)."""
    found = list(dict.fromkeys(p for p, _ in runs))
    return [p for p in ORDER if p in found] + [p for p in found if p not in ORDER]


def summary(runs):
    """{policy: stats} with: reps (sorted), episodes (pooled count), mean
    (pooled mean return), run_means {rep: mean}, std_runs (sample std of the
    run means, 0 with one run), paired (run mean minus the baseline's, per
    repetition, [] without a baseline), pockets {pocket id string: count},
    target, other (counts), hit_rate, median_speed (m/s)."""
    out = {}
    for p in policies(runs):
        reps = sorted(r for q, r in runs if q == p)
        eps = [e for r in reps for e in runs[(p, r)]]
        run_means = {r: statistics.fmean(float(e["return"]) for e in runs[(p, r)]) for r in reps}
        pk = defaultdict(int)
        for e in eps:
            pk[e["pocket"]] += 1
        out[p] = {
            "reps": reps,
            "episodes": len(eps),
            "mean": statistics.fmean(float(e["return"]) for e in eps),
            "run_means": run_means,
            "std_runs": statistics.stdev(run_means.values()) if len(reps) > 1 else 0.0,
            "pockets": dict(pk),
            "target": sum(pk[t] for t in TARGETS),
            "other": sum(c for k, c in pk.items() if k not in TARGETS and k != "-1"),
            "hit_rate": sum(int(e["hit"]) for e in eps) / len(eps),
            "median_speed": statistics.median(math.hypot(float(e["vx"]), float(e["vy"]))
                                              for e in eps),
        }
    base = out.get("baseline")
    for s in out.values():
        s["paired"] = ([s["run_means"][r] - base["run_means"][r] for r in s["reps"]
                        if r in base["run_means"]] if base else [])
    return out


def fmt_pm(values):
    """'+0.105 ± 0.181' (mean ± sample std), '+0.105' for one value, '–' for none."""
    if not values:
        return "–"
    if len(values) < 2:
        return f"{values[0]:+.3f}"
    return f"{statistics.mean(values):+.3f} ± {statistics.stdev(values):.3f}"


def table_rows(stats):
    """The table as lists of cell strings, header first."""
    rows = [["policy", "mean return", "std over runs", "paired vs baseline",
             "pocketed 2 / 5 / other", "hit rate", "median speed"]]
    for p, s in stats.items():
        rows.append([p, f"{s['mean']:.3f}", f"{s['std_runs']:.3f}",
                     "0" if p == "baseline" else fmt_pm(s["paired"]),
                     f"{s['pockets'].get('2', 0)} / {s['pockets'].get('5', 0)} / {s['other']}",
                     f"{100 * s['hit_rate']:.0f} %", f"{s['median_speed']:.2f} m/s"])
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    ap.add_argument("--last", type=int, default=None)
    args = ap.parse_args()
    runs, _ = load(args.dir, args.last)
    rows = table_rows(summary(runs))
    print("| " + " | ".join(rows[0]) + " |")
    print("|---|---:|---:|---:|---|---:|---:|")
    for r in rows[1:]:
        print("| " + " | ".join(r) + " |")


if __name__ == "__main__":
    main()
