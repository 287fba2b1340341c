#!/usr/bin/env python3
"""Figure 7.6 of Experiment 2 (thesis 7.4) from a `poolreps data/exp2.ini` folder.

    plot_exp2.py DIR [--error reps|shots]

Reads DIR/exp2_summary.csv and writes DIR/fig7_6.png and .svg: the mean
return of each policy against the training-set size (log axis), with error
bars of two standard errors, one panel for the mean action and one for an
action drawn from the policy, and the ghost-ball expert's own return on the
same test states as a reference line. --error reps (default when there are
at least two repetitions): standard error over the repetitions' means;
--error shots: over all test shots pooled.
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import os

import exp_data
import figstyle as fs
import numpy as np  # noqa: E402  (after figstyle: it picks the Python)

POLICIES = [
    ("single", "single node ($n_{min}$ = n)", fs.PALETTE["grey"], "s"),
    ("s_a", "trees: states → actions", fs.PALETTE["blue"], "o"),
    ("s_rs", "trees: states → reward states", fs.PALETTE["vermillion"], "^"),
]
MODES = [("mean", "(a) mean action"), ("sample", "(b) action drawn from the policy")]
NEED = ("size", "policy", "mode", "mean_return", "two_se", "two_se_shots", "repetitions",
        "shots", "pocketed")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    ap.add_argument("--error", choices=("reps", "shots"), default=None)
    a = ap.parse_args(argv)
    fs.setup()
    rows = exp_data.read_csv(os.path.join(a.dir, "exp2_summary.csv"), need=NEED)
    if not rows:
        raise SystemExit(f"plot_exp2.py: {a.dir}/exp2_summary.csv: no rows")
    reps = max(int(r["repetitions"]) for r in rows)
    err = a.error or ("reps" if reps > 1 else "shots")
    col = "two_se" if err == "reps" else "two_se_shots"
    expert = [r for r in rows if r["policy"] == "expert"]
    fig, axes = fs.figure("full", 0.46, ncols=2, sharey=True)
    for ax, (mode, mtitle) in zip(axes, MODES):
        for i, (pol, label, colour, marker) in enumerate(POLICIES):
            r = sorted((x for x in rows if x["policy"] == pol and x["mode"] == mode),
                       key=lambda x: int(x["size"]))
            if not r:
                continue
            n = np.array([int(x["size"]) for x in r], dtype=float)
            m = np.array([float(x["mean_return"]) for x in r])
            e = np.array([float(x[col]) for x in r])
            # a small horizontal offset keeps overlapping error bars apart
            ax.errorbar(n * 1.04 ** (i - 1), m, yerr=e, fmt=marker + "-", color=colour, ms=4,
                        capsize=3, label=label)
        for x in expert:
            ax.axhline(float(x["mean_return"]), color="black", ls="--", lw=1,
                       label=f"ghost-ball expert ({100 * float(x['pocketed']):.0f} % pocketed)")
        ax.set_xscale("log")
        ax.set_xlabel(fs.label("training samples n"))
        ax.set_title(mtitle)
        ax.grid(True, which="both", alpha=0.25)
    axes[0].set_ylabel(fs.label("mean return on the test shots", "m"))
    handles, labels = axes[0].get_legend_handles_labels()
    fs.legend_below(fig, handles, labels, ncol=2, height=0.16)
    what = (f"two standard errors over {reps} repetitions" if err == "reps"
            else "two standard errors over the pooled test shots")
    shots = int(rows[0]["shots"]) // max(1, int(rows[0]["repetitions"]))
    fig.suptitle(f"Fig. 7.6: tree policies learned from the ghost-ball expert\n"
                 f"({shots} test shots per repetition; bars: {what})")
    fs.finish(a.dir, fs.save(fig, a.dir, "fig7_6"), ["fig7_6"])


if __name__ == "__main__":
    main()
