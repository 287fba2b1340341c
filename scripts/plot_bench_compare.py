#!/usr/bin/env python3
"""C-REPS (policy.cov_center = new and old) against C-CMA-ES on the
contextual sphere and Rosenbrock functions, from the run folders that
scripts/bench_explore.sh writes.

    plot_bench_compare.py ROOT

ROOT holds one folder per run, named PROBLEM-METHOD (sphere-creps_new,
sphere-creps_old, sphere-ccmaes, rosenbrock-...), each with the
bench_curve.csv of `poolreps`. Writes ROOT/bench_compare.png and .svg (per problem,
the mean over repetitions of the policy mean's test return per generation,
the band from the worst to the best repetition, -return on a log axis, and
the goal lines) and ROOT/bench_compare.csv (per problem and method: final
generation, repetitions, mean, min and max of the final test return, and the
first generation whose mean reaches each goal), and prints the table as
markdown. Reads CSV only; the figures carry no timestamp, so the same CSVs
give the same bytes (scripts/figstyle.py).
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import csv
import os
import sys
from collections import defaultdict

import figstyle as fs
import numpy as np  # noqa: E402  (after figstyle: it picks the Python)

PROBLEMS = ["sphere", "rosenbrock"]
METHODS = [("creps_new", "C-REPS, cov_center = new", fs.PALETTE["vermillion"]),
           ("creps_old", "C-REPS, cov_center = old", fs.PALETTE["blue"]),
           ("ccmaes", "C-CMA-ES", fs.PALETTE["green"])]
# goals on the mean test return (sphere): the reference C-REPS plateau and
# C-CMA-ES's target; the reference C-CMA-ES level for comparison
GOALS = {"sphere": [(-47.0, "reference C-REPS plateau −47", fs.PALETTE["blue"]),
                    (-1e-3, "C-CMA-ES goal −1e-3", fs.PALETTE["green"]),
                    (-10 ** -4.5, "reference C-CMA-ES −10^-4.5", fs.PALETTE["black"])]}
TINY = 1e-300


def read_runs(path):
    """(generations, repetitions) array of test_return, by iteration."""
    rows = defaultdict(dict)
    with open(path, newline="") as fp:
        reader = csv.DictReader(fp)
        missing = {"repetition", "iteration", "test_return"} - set(reader.fieldnames or [])
        if missing:
            raise SystemExit(f"{path}: missing columns {sorted(missing)}")
        for r in reader:
            rows[int(r["repetition"])][int(r["iteration"])] = float(r["test_return"])
    if not rows:
        raise SystemExit(f"{path}: no rows")
    reps = sorted(rows)
    n = min(len(rows[r]) for r in reps)
    return np.array([[rows[r][i] for r in reps] for i in range(n)])


def first_reached(mean, goal):
    hit = np.nonzero(mean >= goal)[0]
    return int(hit[0]) + 1 if hit.size else None


def main():
    if len(sys.argv) != 2:
        raise SystemExit(__doc__.split("\n\n")[1])
    root = sys.argv[1]
    fs.setup()
    fig, axes = fs.figure("full", 0.42, ncols=len(PROBLEMS))
    table = []
    for ax, prob in zip(axes, PROBLEMS):
        for key, label, color in METHODS:
            path = os.path.join(root, f"{prob}-{key}", "bench_curve.csv")
            if not os.path.exists(path):
                continue
            R = read_runs(path)
            gen = np.arange(1, R.shape[0] + 1)
            mean, lo, hi = R.mean(axis=1), R.min(axis=1), R.max(axis=1)
            ax.fill_between(gen, np.maximum(-hi, TINY), np.maximum(-lo, TINY), color=color,
                            alpha=0.18, lw=0)
            ax.plot(gen, np.maximum(-mean, TINY), color=color, lw=1.8,
                    label=f"{label} (mean of {R.shape[1]})")
            row = {"problem": prob, "method": key, "generations": R.shape[0],
                   "repetitions": R.shape[1], "final_mean": mean[-1], "final_min": lo[-1],
                   "final_max": hi[-1]}
            for g, _, _ in GOALS.get(prob, []):
                row[f"gen_mean_ge_{g:g}"] = first_reached(mean, g)
            table.append(row)
        for g, glabel, gcolor in GOALS.get(prob, []):
            ax.axhline(-g, color=gcolor, ls="--", lw=0.9, label=glabel)
        ax.set_yscale("log")
        ax.set_xlabel("generation (50 episodes each)")
        ax.set_ylabel("−(test return of the policy mean)")
        ax.set_title(f"contextual {prob}, 20-D")
        ax.legend(loc="center right" if prob == "sphere" else "lower left", fontsize=6.5)
    fig.suptitle("C-REPS against C-CMA-ES: mean over the repetitions, band from the worst to "
                 "the best")
    written = fs.save(fig, root, "bench_compare")
    goal_cols = sorted({k for r in table for k in r if k.startswith("gen_mean_ge_")})
    cols = ["problem", "method", "generations", "repetitions", "final_mean", "final_min",
            "final_max"] + goal_cols
    with open(os.path.join(root, "bench_compare.csv"), "w", newline="") as fp:
        w = csv.writer(fp, lineterminator="\n")
        w.writerow(cols)
        for r in table:
            w.writerow(["" if r.get(c) is None else (f"{r[c]:.6g}" if isinstance(r.get(c), float)
                                                     else r[c]) for c in cols])
    print("| problem | method | generations | final mean test return | range over repetitions |"
          + "".join(f" first generation, sphere mean ≥ {c[12:]} |" for c in goal_cols))
    print("|---|---|---:|---:|---|" + "---:|" * len(goal_cols))
    for r in table:
        print(f"| {r['problem']} | {r['method']} | {r['generations']} | {r['final_mean']:.3g} | "
              f"{r['final_min']:.3g} … {r['final_max']:.3g} |"
              + "".join(f" {'n/a' if c not in r else '–' if r[c] is None else r[c]} |"
                        for c in goal_cols))
    fs.finish(root, written, ["bench_compare"])


if __name__ == "__main__":
    main()
