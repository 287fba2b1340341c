#!/usr/bin/env python3
"""Learning curves of the REPS validation problems (quadratic, sphere,
rosenbrock) from a `poolreps data/<problem>.ini` folder.

    plot_benchmarks.py DIR [--title TEXT]

Reads DIR/bench_curve.csv and writes DIR/bench_curve.png and .svg with three
log-scale panels against the number of episodes: the negated mean return of
each iteration's samples, the negated return of the policy mean on the fixed
test contexts, and the RMS distance of the policy mean to the optimum x*(s),
plus the policy's root mean variance. Thin lines are single repetitions (every
one the folder holds), the thick line their median, the dotted line its
plateau (the median over the last tenth of the iterations). Every method in METHODS whose CSV is in DIR is
drawn (same columns as bench_curve.csv), each in its own colour.
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import os
from collections import defaultdict

import exp_data
import figstyle as fs
import numpy as np  # noqa: E402  (after figstyle: it picks the Python)

PANELS = [
    ("mean_return", "−(mean return of the samples)", True),
    ("test_return", "−(return of the policy mean)", True),
    ("test_error", "RMS distance of the mean to x*(s)", False),
]
# (CSV in DIR, legend name, colour); add a method by adding its CSV here
METHODS = [
    ("bench_curve.csv", "REPS", fs.PALETTE["blue"]),
]
NEED = ("repetition", "iteration", "samples", "mean_return", "test_return", "test_error",
        "mean_std")
TINY = exp_data.TINY


def read_curves(path):
    """{repetition: {column: np.array}} ordered by iteration."""
    rows = defaultdict(list)
    for r in exp_data.read_csv(path, need=NEED):
        rows[int(r["repetition"])].append(r)
    curves = {}
    for rep, rs in rows.items():
        rs.sort(key=lambda r: int(r["iteration"]))
        curves[rep] = {k: np.array([float(r[k]) for r in rs]) for k in NEED}
    return curves


def draw(axes, curves, name, colour):
    for ax, (col, _, negate) in zip(axes, PANELS):
        stack = []
        for rep in sorted(curves):
            c = curves[rep]
            y = np.maximum(-c[col] if negate else c[col], TINY)
            ax.plot(c["samples"], y, color=colour, alpha=0.25, lw=0.7)
            stack.append(y)
        level, med = exp_data.plateau(stack)
        n = len(med)
        x = curves[sorted(curves)[0]]["samples"][:n]
        ax.plot(x, med, color=colour, lw=1.8, label=f"{name}: median of {len(stack)} runs")
        ax.axhline(level, color=colour, lw=0.8, ls=":",
                   label=f"{name}: plateau {level:.3g} (median, last tenth)")
        if col == "test_error":
            std = np.median(np.array([curves[r]["mean_std"][:n] for r in sorted(curves)]), axis=0)
            ax.plot(x, np.maximum(std, TINY), color=colour, lw=1.2, ls="--",
                    label=f"{name}: policy std (median)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dir")
    ap.add_argument("--title", default=None)
    args = ap.parse_args(argv)
    fs.setup()
    title = args.title or os.path.basename(os.path.normpath(args.dir))
    fig, axes = fs.figure("full", 0.36, ncols=3)
    drawn = 0
    for csv_name, name, colour in METHODS:
        path = os.path.join(args.dir, csv_name)
        if csv_name != METHODS[0][0] and not os.path.exists(path):
            continue
        curves = read_curves(path)
        if not curves:
            raise SystemExit(f"plot_benchmarks.py: {path}: no rows")
        draw(axes, curves, name, colour)
        drawn += 1
    for ax, (col, label, _) in zip(axes, PANELS):
        ax.set_yscale("log")
        ax.set_xlabel(fs.label("episodes"))
        ax.set_ylabel(label, fontsize=8)
        # the median std falls to the bottom right: keep the legend off it
        ax.legend(loc="center right" if col == "test_error" else "upper right", fontsize=6)
    fig.suptitle(f"Episodic contextual REPS on the {title} problem (log scale; thin lines: "
                 "single runs)")
    fs.finish(args.dir, fs.save(fig, args.dir, "bench_curve"), ["bench_curve"])


if __name__ == "__main__":
    main()
