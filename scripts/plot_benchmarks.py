#!/usr/bin/env python3
"""Learning curves of the REPS validation problems (quadratic, sphere,
rosenbrock) from a `poolreps data/<problem>.ini` folder.

    plot_benchmarks.py DIR [--title TEXT]

Reads DIR/bench_curve.csv (CSV only) and writes DIR/bench_curve.png with
three log-scale panels against the number of episodes: the negated mean
return of each iteration's samples, the negated return of the policy mean
on the fixed test contexts, and the RMS distance of the policy mean to the
optimum x*(s), plus the policy's root mean variance. Thin lines are single
repetitions, the thick line their median.
"""
import argparse
import csv
import os
from collections import defaultdict

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

PANELS = [
    ("mean_return", "−(mean return of the samples)", True),
    ("test_return", "−(return of the policy mean)", True),
    ("test_error", "RMS distance of the mean to x*(s)", False),
]
TINY = 1e-300


def read_curves(path):
    """{repetition: {column: np.array}} ordered by iteration."""
    rows = defaultdict(list)
    with open(path, newline="") as fp:
        reader = csv.DictReader(fp)
        need = {"repetition", "iteration", "samples", "mean_return", "test_return",
                "test_error", "mean_std"}
        missing = need - set(reader.fieldnames or [])
        if missing:
            raise SystemExit(f"{path}: missing columns {sorted(missing)}")
        for r in reader:
            rows[int(r["repetition"])].append(r)
    curves = {}
    for rep, rs in rows.items():
        rs.sort(key=lambda r: int(r["iteration"]))
        curves[rep] = {k: np.array([float(r[k]) for r in rs]) for k in rs[0]}
    return curves


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dir")
    ap.add_argument("--title", default=None)
    args = ap.parse_args()
    curves = read_curves(os.path.join(args.dir, "bench_curve.csv"))
    if not curves:
        raise SystemExit(f"{args.dir}/bench_curve.csv: no rows")
    title = args.title or os.path.basename(os.path.normpath(args.dir))

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for ax, (col, label, negate) in zip(axes, PANELS):
        stack = []
        for rep in sorted(curves):
            c = curves[rep]
            y = -c[col] if negate else c[col]
            y = np.maximum(y, TINY)
            ax.plot(c["samples"], y, color="tab:blue", alpha=0.25, lw=0.8)
            stack.append(y)
        n = min(len(y) for y in stack)
        med = np.median(np.array([y[:n] for y in stack]), axis=0)
        x = curves[sorted(curves)[0]]["samples"][:n]
        ax.plot(x, med, color="tab:blue", lw=2, label=f"median of {len(stack)}")
        if col == "test_error":
            std = np.median(np.array([curves[r]["mean_std"][:n] for r in sorted(curves)]), axis=0)
            ax.plot(x, np.maximum(std, TINY), color="tab:red", lw=1.5, ls="--",
                    label="policy std (median)")
        ax.set_yscale("log")
        ax.set_xlabel("episodes")
        ax.set_ylabel(label)
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    fig.suptitle(f"REPS on {title}")
    fig.tight_layout()
    out = os.path.join(args.dir, "bench_curve.png")
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
