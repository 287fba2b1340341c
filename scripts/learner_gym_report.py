#!/usr/bin/env python3
"""The 20-seed table of docs/learner.md from data/learner/gym_study.csv
(scripts/learner_gym_study.py writes it).

    scripts/learner_gym_report.py [CSV]            print the block
    scripts/learner_gym_report.py --write          put it between the
                                                   learner_gym markers
    scripts/learner_gym_report.py --check [CSV]    exit 1 if the page differs

The rule, stated before computing: per method and budget, the IQM of the
runs' test returns with its 95 % stratified-bootstrap interval (the
estimators of scripts/verdict_stats.py). At the largest budget, tree
features are called higher (lower) than another method when the bootstrap
interval of the IQM difference lies above (below) 0, with Holm's correction
for the two comparisons: the comparison whose 97.5 % interval excludes 0
is decided first, the other then at 95 %; otherwise "no difference shown".
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import os
import sys

import numpy as np

import doc_block
import verdict_stats as vs

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NAMES = {"trees": "tree features", "linear": "linear features", "ccmaes": "C-CMA-ES"}
REPS, SEED = 10000, 0


def load(rows):
    """{(method, episodes): test returns in seed order}, CPU seconds per run, seeds."""
    runs, cpu, seeds = {}, {}, {}
    for i, row in enumerate(rows, start=2):
        try:
            key, seed = (row["method"], int(row["episodes"])), int(row["seed"])
            runs.setdefault(key, []).append(float(row["test_return"]))
            seeds.setdefault(key, []).append(seed)
            run = (row["method"], seed)
            cpu[run] = max(cpu.get(run, 0.0), float(row["cpu_s"]))
        except (KeyError, ValueError, TypeError) as e:
            sys.exit(f"learner_gym_report.py: row {i}: {e}")
    first = sorted(next(iter(seeds.values())))
    for key, s in seeds.items():
        if sorted(s) != first or key[0] not in NAMES:
            sys.exit(f"learner_gym_report.py: {key}: not the seeds of the other methods")
    return {k: np.array(v) for k, v in runs.items()}, cpu, len(first)


def interval(stat, samples, level):
    return vs.bootstrap_ci(stat, samples, REPS, SEED, level)


def verdicts(runs, top):
    """Holm over the two comparisons of tree features at the largest budget."""
    diff = lambda a, b: vs.iqm(a) - vs.iqm(b)  # noqa: E731
    others = [m for m in NAMES if m != "trees"]
    ci = {m: interval(diff, [runs["trees", top], runs[m, top]], 1 - vs.ALPHA / 2) for m in others}
    first = [m for m in others if ci[m][0] > 0 or ci[m][1] < 0]
    out = {}
    for m in others:
        level = 1 - vs.ALPHA / 2 if not first or m in first else 1 - vs.ALPHA
        lo, hi = interval(diff, [runs["trees", top], runs[m, top]], level)
        out[m] = ("higher than" if lo > 0 else "lower than" if hi < 0 else
                  "not shown different from", lo, hi)
    return out


def render(rows):
    runs, cpu, nseeds = load(rows)
    budgets = sorted({e for _, e in runs})
    top = budgets[-1]
    lines = ["| method | " + " | ".join(f"{b} episodes" for b in budgets) + " |",
             "|---|" + "---|" * len(budgets)]
    for m in NAMES:
        cells = []
        for b in budgets:
            lo, hi = interval(vs.iqm, [runs[m, b]], vs.LEVEL)
            cells.append(f"{vs.iqm(runs[m, b]):.0f} [{lo:.0f}, {hi:.0f}]")
        lines.append(f"| {NAMES[m]} | " + " | ".join(cells) + " |")
    said = " and ".join(f"{w} {NAMES[m]} (IQM difference [{lo:.0f}, {hi:.0f}])"
                        for m, (w, lo, hi) in verdicts(runs, top).items())
    lines += ["", f"IQM of the test return over {nseeds} seeds [95 % stratified-bootstrap "
              f"interval, {REPS} resamples]. At {top} episodes tree features are {said}, "
              f"Holm-corrected (difference intervals at Holm's levels, 97.5 % or 95 %). The study used {sum(cpu.values()) / 60:.1f} CPU minutes "
              f"({len(cpu)} runs)."]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(doc_block.table_main(render, "learner_gym", "learner_gym_report.py",
                                  os.path.join(ROOT, "data", "learner", "gym_study.csv"),
                                  [os.path.join(ROOT, "docs", "learner.md")]))
