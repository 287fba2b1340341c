#!/usr/bin/env python3
"""The seed spread of Experiments 1 and 2 in the verdict study.

    plot_study.py DATA DIR

Reads DATA/exp1_mse.csv, DATA/exp2_returns.csv and DATA/manifest.csv (what
`make study` commits in data/study/) and writes DIR/study_seeds.png and .svg,
the event-mode runs:
top, Experiment 1's test MSE of each setting relative to its reference (K 10,
M at its largest, the smallest n_min), one grey dot per seed (the mean of its
forests) and the mean over seeds with its 95 % t interval, one y-scale for the
three panels; below, Experiment 2's mean return at the largest training set,
per seed and policy, with mean actions and with sampled actions, on one
y-scale. scripts/verdicts.py calls study_seeds (make verdicts).
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import csv
import os
from collections import defaultdict

import exp_data
import figstyle as fs
import numpy as np  # noqa: E402  (after figstyle: it picks the Python)
from scipy import stats  # noqa: E402

STEM = exp_data.STUDY_SEEDS_STEM
ARM = "event"   # the physics arm drawn (the study runs Experiments 1 and 2 in three)


def rows(data, name):
    with open(os.path.join(data, name), newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def config(data, experiment):
    """The configuration of the experiment's first unit (the generator has
    checked that the units agree)."""
    cfg, unit = {}, None
    for r in rows(data, "manifest.csv"):
        if (r["experiment"] == experiment and r["unit"].startswith(f"{ARM}/")
                and unit in (None, r["unit"])):
            unit = r["unit"]
            cfg[r["key"]] = r["value"]
    return cfg


def spread(ax, x, per_seed, colour):
    """One dot per seed (spread sideways by rank, no random jitter) and the
    mean with its 95 % t interval."""
    v = np.asarray(per_seed, float)
    off = (np.argsort(np.argsort(v)) / max(len(v) - 1, 1) - 0.5) * 0.35
    ax.plot(x + off, v, "o", ms=2.2, color=fs.PALETTE["lightgrey"], mec="none")
    m = v.mean()
    half = stats.t.ppf(0.975, len(v) - 1) * v.std(ddof=1) / np.sqrt(len(v))
    ax.errorbar([x], [m], yerr=[[half], [half]], fmt="o", color=colour, ms=4, capsize=3)


def exp1_panels(axes, data):
    cfg = config(data, "exp1")
    acc = defaultdict(list)
    for r in rows(data, "exp1_mse.csv"):
        if r["arm"] == ARM:
            acc[(int(r["seed"]), r["sweep"], int(r["value"]))].append(float(r["mse"]))
    mse = {k: np.mean(v) for k, v in acc.items()}
    seeds = sorted({k[0] for k in mse})
    lists = {s: [int(x) for x in cfg[f"exp1.{s}_list"].split(",")]
             for s in ("cuts", "trees", "n_min")}
    refs = {"cuts": int(cfg["forest.cuts"]), "trees": max(lists["trees"]),
            "n_min": min(lists["n_min"])}
    names = {"cuts": "K (cuts)", "trees": "M (trees)", "n_min": "n_min"}
    for ax, sweep in zip(axes, ("cuts", "trees", "n_min")):
        ref = refs[sweep]
        for i, v in enumerate(lists[sweep]):
            rel = [100 * (mse[(s, sweep, v)] / mse[(s, sweep, ref)] - 1) for s in seeds]
            spread(ax, i, rel, fs.PALETTE["blue"])
        ax.axhline(0, color="black", lw=0.7)
        ax.set_xticks(range(len(lists[sweep])), [str(v) for v in lists[sweep]], fontsize=6.5,
                      rotation=90 if len(lists[sweep]) > 10 else 0)
        ax.set_xlabel(names[sweep])
        ax.set_title(f"MSE against {names[sweep].split()[0]} = {ref}", fontsize=8.5)
    axes[0].set_ylabel(fs.label("test MSE, relative change", "%"))
    return len(seeds)


def exp2_panels(axes, data):
    cfg = config(data, "exp2")
    top = max(int(x) for x in cfg["exp2.sizes"].split(","))
    acc = defaultdict(list)
    for r in rows(data, "exp2_returns.csv"):
        if r["arm"] == ARM and int(r["size"]) in (0, top):
            acc[(int(r["seed"]), r["policy"], r["mode"])].append(float(r["mean_return"]))
    seeds = sorted({k[0] for k in acc})
    pols = [("single", "single node"), ("s_a", "s→a"), ("s_rs", "s→rs"), ("expert", "expert")]
    for ax, mode in zip(axes, ("mean", "sample")):
        for i, (p, _) in enumerate(pols):
            m = "mean" if p == "expert" else mode
            spread(ax, i, [np.mean(acc[(s, p, m)]) for s in seeds], fs.PALETTE["vermillion"])
        ax.set_xticks(range(len(pols)), [lab for _, lab in pols])
        ax.set_title(f"Exp. 2, {top} samples, {mode} actions", fontsize=8.5)
    axes[0].set_ylabel(fs.label("mean return on the test shots", "m"))


def study_seeds(data, directory):
    """Draw DIR/study_seeds.png and .svg from the study in DATA; return the paths."""
    fs.setup()
    fig = fs.figure("full", 0.85)[0]
    fig.clf()
    gs = fig.add_gridspec(2, 6)
    top = [fig.add_subplot(gs[0, 2 * k:2 * k + 2]) for k in range(3)]
    low = [fig.add_subplot(gs[1, 3 * k:3 * k + 3]) for k in range(2)]
    for ax in top[1:]:
        ax.sharey(top[0])
    low[1].sharey(low[0])
    n = exp1_panels(top, data)
    exp2_panels(low, data)
    fig.suptitle(f"The verdict study: Experiments 1 and 2 over {n} seeds, event mode\n"
                 "(grey: one seed, "
                 "the mean of its run's forests or repetitions; coloured: the mean over the "
                 "seeds with its 95 % t interval)", fontsize=8.5)
    return fs.save(fig, directory, STEM)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data")
    ap.add_argument("dir")
    args = ap.parse_args()
    study_seeds(args.data, args.dir)


if __name__ == "__main__":
    main()
