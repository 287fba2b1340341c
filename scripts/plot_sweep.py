#!/usr/bin/env python3
"""Plot a sweep's summary against its grid, from `poolreps collect`'s table.

    plot_sweep.py SWEEP_DIR [-y COLUMN] [--x KEY] [--panel COLUMN]
                  [--where COLUMN=VALUE]... [--exclude COLUMN=VALUE]... [--logx] [-o FILE]

Reads SWEEP_DIR/sweep_summary.csv (the grid keys, then the experiment's
summary columns) and SWEEP_DIR/manifest.csv (which columns are grid keys).
The y column goes against the grid key --x (default: the first), one line per
combination of the other grid keys, one panel per value of --panel. Rows
are kept by --where and dropped by --exclude. When several rows fall on one
point (e.g. one per repetition), the point is their mean and the bar +-2
standard errors (2 sd / sqrt(n)); the title says n.

Defaults for Experiment 3's exp3_final.csv: -y mean_return --panel policy
--exclude repetition=-1 (each repetition's mean return over its last
episodes; bars over repetitions). Experiment 1 (exp1_summary.csv): -y
mean_mse --panel sweep. Writes SWEEP_DIR/sweep_summary.png by default.
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import csv
import math
import os
import statistics

import figstyle as fs
import matplotlib.pyplot as plt  # noqa: E402  (after figstyle: it picks the Python)

# units of the summary columns the shipped experiments write (others: none shown)
UNITS = {"mean_return": "m", "std_return": "m", "mean_distance": "m", "mean_mse": "m²",
         "std_mse": "m²"}

DEFAULTS = [  # (columns that identify a summary, its defaults)
    ({"policy", "repetition", "mean_return"},
     {"y": "mean_return", "panel": "policy", "exclude": ["repetition=-1"]}),
    ({"sweep", "value", "mean_mse"}, {"y": "mean_mse", "panel": "sweep"}),
]


def read_csv(path):
    with open(path, newline="") as f:
        r = csv.reader(f)
        header = next(r)
        return header, [dict(zip(header, row)) for row in r]


def grid_keys(sweep):
    header, _ = read_csv(os.path.join(sweep, "manifest.csv"))
    return header[2:header.index("repetition")]


def condition(text):
    col, sep, value = text.partition("=")
    if not sep:
        raise argparse.ArgumentTypeError(f"expected COLUMN=VALUE, got {text!r}")
    return col, value


def number(s):
    try:
        return float(s)
    except ValueError:
        return None


def in_order(values):
    """Distinct values (strings or tuples of them), numbers ascending,
    otherwise in order of appearance."""
    seen = list(dict.fromkeys(values))
    as_tuples = [v if isinstance(v, tuple) else (v,) for v in seen]
    if all(number(s) is not None for t in as_tuples for s in t):
        order = sorted(range(len(seen)), key=lambda i: tuple(float(s) for s in as_tuples[i]))
        seen = [seen[i] for i in order]
    return seen


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("sweep", help="a sweep folder after `poolreps collect`")
    ap.add_argument("-y", help="summary column to plot")
    ap.add_argument("--x", help="grid key on the x axis (default: the first)")
    ap.add_argument("--panel", help="one panel per value of this column")
    ap.add_argument("--where", type=condition, action="append", default=None)
    ap.add_argument("--exclude", type=condition, action="append", default=None)
    ap.add_argument("--logx", action="store_true", help="logarithmic x axis")
    ap.add_argument("-o", "--out", help="PNG to write")
    a = ap.parse_args()

    header, rows = read_csv(os.path.join(a.sweep, "sweep_summary.csv"))
    keys = grid_keys(a.sweep)
    if not keys:
        ap.error("the sweep has no grid keys: nothing to plot against")
    for cols, d in DEFAULTS:
        if cols <= set(header):
            a.y = a.y or d["y"]
            a.panel = a.panel or d["panel"]
            if a.exclude is None:
                a.exclude = [condition(c) for c in d.get("exclude", [])]
    x = a.x or keys[0]
    for name, col in (("-y", a.y), ("--x", x), ("--panel", a.panel)):
        if col is not None and col not in header:
            ap.error(f"{name} {col}: no such column in sweep_summary.csv ({', '.join(header)})")
    if a.y is None:
        ap.error("give -y COLUMN (one of: " + ", ".join(h for h in header if h not in keys) + ")")
    for col, _ in (a.where or []) + (a.exclude or []):
        if col not in header:
            ap.error(f"{col}: no such column in sweep_summary.csv")
    rows = [r for r in rows if all(r[c] == v for c, v in a.where or [])
            and not any(r[c] == v for c, v in a.exclude or [])]
    if not rows:
        ap.error("no rows left after --where/--exclude")

    fs.setup()
    lines = [k for k in keys if k != x]
    panels = in_order(r[a.panel] for r in rows) if a.panel else [None]
    xs = in_order(r[x] for r in rows)
    numeric = all(number(v) is not None for v in xs)
    combos = in_order(tuple(r[k] for k in lines) for r in rows) if lines else [()]
    ncol = min(3, len(panels))
    nrow = math.ceil(len(panels) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(max(6.5, 4.2 * ncol), 3.4 * nrow + 0.3),
                             sharex=True, sharey=True, squeeze=False)
    counts = set()
    for ax, panel in zip(axes.flat, panels):
        for i, combo in enumerate(combos):
            px, py, pe = [], [], []
            for xv in xs:
                ys = [float(r[a.y]) for r in rows
                      if r[x] == xv and tuple(r[k] for k in lines) == combo
                      and (panel is None or r[a.panel] == panel)]
                if not ys:
                    continue
                counts.add(len(ys))
                px.append(float(xv) if numeric else xs.index(xv))
                py.append(statistics.fmean(ys))
                pe.append(2 * statistics.stdev(ys) / math.sqrt(len(ys)) if len(ys) > 1 else 0.0)
            label = ", ".join(f"{k} = {v}" for k, v in zip(lines, combo)) or None
            ax.errorbar(px, py, yerr=pe if any(pe) else None, marker="o", capsize=3,
                        color=fs.CYCLE[i % len(fs.CYCLE)], label=label)
        if panel is not None:
            ax.set_title(f"{a.panel} = {panel}", fontsize=10)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel(x)
        if a.logx:
            ax.set_xscale("log")
        if numeric:
            ax.set_xticks([float(v) for v in xs])
            ax.set_xticklabels(xs)
            ax.minorticks_off()
        else:
            ax.set_xticks(range(len(xs)))
            ax.set_xticklabels(xs)
    for ax in axes[:, 0]:
        ax.set_ylabel(fs.label(a.y, UNITS.get(a.y)))
    if lines:
        axes.flat[0].legend(fontsize=8)
    n = sorted(counts)
    what = (f"mean of {n[0]} rows per point, bars ±2 s.e." if n == [n[0]] and n[0] > 1 else
            "one row per point" if n == [1] else f"mean of {n[0]}–{n[-1]} rows per point, "
            "bars ±2 s.e.")
    fig.suptitle(f"{a.y} against {x} ({what})", fontsize=11)
    fig.tight_layout()
    out = a.out or os.path.join(a.sweep, "sweep_summary.png")
    for p in fs.save(fig, os.path.dirname(out) or ".", os.path.splitext(os.path.basename(out))[0]):
        print(p)


if __name__ == "__main__":
    main()
