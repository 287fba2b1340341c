#!/usr/bin/env python3
"""Figures 7.7-7.10 of Experiment 3 (thesis 7.5) from a `poolreps data/exp3.ini` folder.

    plot_exp3.py DIR

Reads the derived CSVs of DIR (exp3_curve.csv, exp3_final.csv,
exp3_pockets.csv, exp3_dist.csv) and writes
  fig7_7.png   average return per iteration, panels a-d (value score x policy
               target), each with the baseline and the hand-crafted variant;
               bands: one std over the repetitions;
  fig7_8.png   returns over each run's last episodes (mean +- one std), per
               repetition, panels a-d, with the pooled baseline and hand-crafted;
  fig7_9.png   balls pocketed per pocket (targets and others) per policy;
  fig7_10.png  histograms of the final distance to the nearest target pocket.
Policies missing from the CSVs (exp3.policies) are left out.
"""
import argparse
import csv
import os

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

# panels a-d of Figs. 7.7 and 7.8, in the thesis's order
PANELS = [
    ("nrvr_rs", "(a) nrvr value features, policy s → rs"),
    ("rvr_rs", "(b) rvr value features, policy s → rs"),
    ("nrvr_a", "(c) nrvr value features, policy s → a"),
    ("rvr_a", "(d) rvr value features, policy s → a"),
]
LABEL = {
    "nrvr_rs": "nrvr, s→rs", "rvr_rs": "rvr, s→rs", "nrvr_a": "nrvr, s→a",
    "rvr_a": "rvr, s→a", "baseline": "baseline (1 node)", "handcrafted": "hand-crafted",
}
COLOR = {
    "nrvr_rs": "tab:red", "rvr_rs": "tab:orange", "nrvr_a": "tab:blue", "rvr_a": "tab:cyan",
    "baseline": "tab:gray", "handcrafted": "tab:green",
}
REFS = ("baseline", "handcrafted")


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def ordered(names):
    order = [p for p, _ in PANELS] + list(REFS)
    return [p for p in order if p in names]


def curves(d):
    out = {}
    for r in read(os.path.join(d, "exp3_curve.csv")):
        c = out.setdefault(r["policy"], ([], [], []))
        c[0].append(int(r["episodes"]))
        c[1].append(float(r["mean_return"]))
        c[2].append(float(r["std_return"]))
    return {k: tuple(np.array(x) for x in v) for k, v in out.items()}


def fig7_7(d, cur):
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5), sharex=True, sharey=True)
    lo = min(float(np.min(m - s)) for _, m, s in cur.values())
    for ax, (pol, title) in zip(axes.flat, PANELS):
        for p in [pol] + list(REFS):
            if p not in cur:
                continue
            x, m, s = cur[p]
            main = p == pol
            ax.plot(x, m, color=COLOR[p], lw=2 if main else 1.2, ls="-" if main else "--",
                    label=LABEL[p])
            ax.fill_between(x, m - s, m + s, color=COLOR[p], alpha=0.25 if main else 0.1, lw=0)
        if pol not in cur:
            ax.text(0.5, 0.5, f"{pol}: not run", transform=ax.transAxes, ha="center")
        ax.set_title(title, fontsize=10)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_ylim(max(lo, -4.0), 0.05)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="lower right")
    for ax in axes[1]:
        ax.set_xlabel("episodes")
    for ax in axes[:, 0]:
        ax.set_ylabel("average return per iteration")
    fig.suptitle("Fig. 7.7: average return per iteration (mean ± 1 std over repetitions)",
                 fontsize=11)
    fig.tight_layout()
    fig.savefig(os.path.join(d, "fig7_7.png"), dpi=110)
    plt.close(fig)


def fig7_8(d, fin):
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5), sharey=True)
    pooled = {r["policy"]: r for r in fin if r["repetition"] == "-1"}
    for ax, (pol, title) in zip(axes.flat, PANELS):
        reps = [r for r in fin if r["policy"] == pol and r["repetition"] != "-1"]
        labels, m, s, colors = [], [], [], []
        for r in reps:
            labels.append(f"rep {r['repetition']}")
            m.append(float(r["mean_return"]))
            s.append(float(r["std_return"]))
            colors.append(COLOR[pol])
        for p in [pol] + list(REFS):
            if p in pooled:
                labels.append("all: " + LABEL[p])
                m.append(float(pooled[p]["mean_return"]))
                s.append(float(pooled[p]["std_return"]))
                colors.append(COLOR[p])
        if not reps:
            ax.text(0.5, 0.5, f"{pol}: not run", transform=ax.transAxes, ha="center")
        x = np.arange(len(m))
        ax.bar(x, m, yerr=s, color=colors, capsize=3, alpha=0.85)
        ax.set_xticks(x)
        ax.set_xticklabels(labels, rotation=35, ha="right", fontsize=8)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_title(title, fontsize=10)
        ax.grid(axis="y", alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel("return (mean ± 1 std)")
    n = fin[0]["episodes"] if fin else "?"
    fig.suptitle(f"Fig. 7.8: returns over the last {n} episodes of each run", fontsize=11)
    fig.tight_layout()
    fig.savefig(os.path.join(d, "fig7_8.png"), dpi=110)
    plt.close(fig)


def fig7_9(d, pk):
    pols = ordered({r["policy"] for r in pk})
    pockets = sorted({int(r["pocket"]) for r in pk if r["target"] == "1"})
    fig, ax = plt.subplots(figsize=(9, 4.5))
    x = np.arange(len(pols))
    cols = [(f"pocket {p} (target)", [p]) for p in pockets]
    cols.append(("other pockets", [p for p in range(6) if p not in pockets]))
    w = 0.8 / len(cols)
    for j, (lab, ids) in enumerate(cols):
        h = [sum(int(r["count"]) for r in pk if r["policy"] == p and int(r["pocket"]) in ids)
             for p in pols]
        b = ax.bar(x + (j - (len(cols) - 1) / 2) * w, h, w, label=lab)
        ax.bar_label(b, fontsize=7)
    ax.set_xticks(x)
    ax.set_xticklabels([LABEL[p] for p in pols])
    ax.set_ylabel("balls pocketed (all repetitions)")
    ax.set_title("Fig. 7.9: pocketed reward balls per pocket, last episodes of each run",
                 fontsize=11)
    ax.legend(fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(d, "fig7_9.png"), dpi=110)
    plt.close(fig)


def fig7_10(d, dist):
    pols = ordered({r["policy"] for r in dist})
    ncol = 3
    nrow = max(1, (len(pols) + ncol - 1) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(12, 3.4 * nrow), sharex=True, sharey=True,
                             squeeze=False)
    for ax, p in zip(axes.flat, pols):
        r = [x for x in dist if x["policy"] == p]
        lo = np.array([float(x["bin_lo"]) for x in r])
        hi = np.array([float(x["bin_hi"]) for x in r])
        c = np.array([int(x["count"]) for x in r])
        ax.bar(lo, c, hi - lo, align="edge", color=COLOR[p], edgecolor="k", lw=0.3)
        ax.set_title(LABEL[p], fontsize=10)
        ax.grid(axis="y", alpha=0.3)
    for ax in axes.flat[len(pols):]:
        ax.axis("off")
    for ax in axes[:, 0]:
        ax.set_ylabel("episodes")
    fig.supxlabel("final distance of the reward ball to the nearest target pocket [m] "
                  "(0: pocketed there)", fontsize=10)
    fig.suptitle("Fig. 7.10: final distance of the reward ball, last episodes of each run",
                 fontsize=11)
    fig.tight_layout()
    fig.savefig(os.path.join(d, "fig7_10.png"), dpi=110)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    a = ap.parse_args()
    fig7_7(a.dir, curves(a.dir))
    fig7_8(a.dir, read(os.path.join(a.dir, "exp3_final.csv")))
    fig7_9(a.dir, read(os.path.join(a.dir, "exp3_pockets.csv")))
    fig7_10(a.dir, read(os.path.join(a.dir, "exp3_dist.csv")))


if __name__ == "__main__":
    main()
