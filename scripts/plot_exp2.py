#!/usr/bin/env python3
"""Figure 7.6 of Experiment 2 (thesis 7.4) from a `poolreps data/exp2.ini` folder.

    plot_exp2.py DIR [--error reps|shots]

Reads DIR/exp2_summary.csv (CSV only) and writes DIR/fig7_6.png: the mean
return of each policy against the training-set size (log axis), with error
bars of two standard errors, one panel for the mean action and one for an
action drawn from the policy, and the ghost-ball expert's own return on the
same test states as a reference line. --error reps (default when there are
at least two repetitions): standard error over the repetitions' means;
--error shots: over all test shots pooled.
"""
import argparse
import csv
import os

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

POLICIES = [
    ("single", "single node (n_min = n)", "tab:gray", "s"),
    ("s_a", "trees: states → actions", "tab:blue", "o"),
    ("s_rs", "trees: states → reward states", "tab:red", "^"),
]
MODES = [("mean", "mean action"), ("sample", "sampled action")]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    ap.add_argument("--error", choices=("reps", "shots"), default=None)
    a = ap.parse_args()
    with open(os.path.join(a.dir, "exp2_summary.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    reps = max(int(r["repetitions"]) for r in rows)
    err = a.error or ("reps" if reps > 1 else "shots")
    col = "two_se" if err == "reps" else "two_se_shots"
    expert = [r for r in rows if r["policy"] == "expert"]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    for ax, (mode, mtitle) in zip(axes, MODES):
        for i, (pol, label, color, marker) in enumerate(POLICIES):
            r = sorted((x for x in rows if x["policy"] == pol and x["mode"] == mode),
                       key=lambda x: int(x["size"]))
            if not r:
                continue
            n = np.array([int(x["size"]) for x in r], dtype=float)
            m = np.array([float(x["mean_return"]) for x in r])
            e = np.array([float(x[col]) for x in r])
            # a small horizontal offset keeps overlapping error bars apart
            ax.errorbar(n * 1.04 ** (i - 1), m, yerr=e, fmt=marker + "-", color=color,
                        capsize=3, label=label)
        for x in expert:
            ax.axhline(float(x["mean_return"]), color="k", ls="--", lw=1,
                       label=f"ghost-ball expert ({100 * float(x['pocketed']):.0f}% pocketed)")
        ax.set_xscale("log")
        ax.set_xlabel("training samples")
        ax.set_title(mtitle, fontsize=10)
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("mean return on the test shots")
    axes[0].legend(fontsize=8, loc="lower right")
    what = (f"two standard errors over {reps} repetitions" if err == "reps"
            else "two standard errors over the pooled test shots")
    shots = int(rows[0]["shots"]) // max(1, int(rows[0]["repetitions"]))
    fig.suptitle(f"Fig. 7.6: tree policies learned from the ghost-ball expert\n"
                 f"({shots} test shots per repetition; bars: {what})", fontsize=10)
    fig.tight_layout()
    p = os.path.join(a.dir, "fig7_6.png")
    fig.savefig(p, dpi=120)
    plt.close(fig)
    print(p)


if __name__ == "__main__":
    main()
