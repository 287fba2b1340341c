#!/usr/bin/env python3
"""Figures of Experiment 1 (thesis 7.3) from a `poolreps data/exp1.ini` folder.

    plot_exp1.py DIR

Reads DIR/exp1_mse.csv, DIR/exp1_map.csv and DIR/config.ini and writes into
DIR, as PNG and SVG:
  fig7_4a_nmin, fig7_4b_trees, fig7_4c_cuts  test MSE against n_min, M and K:
      top, the mean over the forests with bars of one standard deviation (the
      thesis's figure); bottom, each setting's paired difference to the default
      setting (forest.n_min, forest.trees, forest.cuts) on the same training
      and test subsets, its mean with a 95 % t interval, and every forest's
      difference as a dot;
  exp1_map  simulated return of the aimed shot over the reward-ball region,
      the mean prediction of all the forests, and their difference.
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import sys

import exp_data
import figstats
import figstyle as fs
import matplotlib.pyplot as plt  # noqa: E402  (after figstyle: it picks the Python)
import numpy as np  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

# sweep name, file stem, axis label, thesis panel
SWEEPS = [
    ("n_min", "fig7_4a_nmin", "$n_{min}$ (samples a node needs to be split)", "7.4a"),
    ("trees", "fig7_4b_trees", "trees $M$", "7.4b"),
    ("cuts", "fig7_4c_cuts", "cuts $K$ (random tests per node)", "7.4c"),
]
STEMS = [s[1] for s in SWEEPS] + ["exp1_map"]
MSE_UNIT = "m²"  # the return is a distance in metres (eq. 7.7)


def plot_sweep(d, sweep, stem, xlabel, panel, values, by_setting, default):
    xs = sorted(values)
    reps = sorted({k for v in values.values() for k in v})
    mse = np.array([[values[x].get(k, np.nan) for k in reps] for x in xs])
    ref, src = exp_data.exp1_reference(sweep, values, by_setting, default)
    fig, (top, bot) = fs.figure("half", 1.25, nrows=2, sharex=True,
                                gridspec_kw={"height_ratios": [3, 2]})
    mean, std = np.nanmean(mse, axis=1), np.nanstd(mse, axis=1, ddof=1) if len(reps) > 1 else 0
    top.errorbar(xs, mean, yerr=std, fmt="o-", ms=4, capsize=3, color=fs.PALETTE["blue"])
    top.set_ylabel(fs.label("test MSE of the return", MSE_UNIT))
    names = {"n_min": "$n_{min}$", "trees": "$M$", "cuts": "$K$"}
    fixed = ", ".join(f"{names[s]} = {v}" for s, v in zip(("n_min", "trees", "cuts"), default)
                      if s != sweep)
    top.set_title(f"Fig. {panel}: varying {names[sweep]} ({fixed})\n"
                  f"mean ± 1 std over {len(reps)} forests", fontsize=9)
    if ref is not None:
        dv = {"n_min": default[0], "trees": default[1], "cuts": default[2]}[sweep]
        for x in xs:
            diffs = figstats.paired(values[x], ref)
            if not diffs:
                continue
            m, lo, hi = figstats.mean_ci(diffs)
            bot.plot([x] * len(diffs), diffs, ".", color=fs.PALETTE["grey"], ms=3, alpha=0.7)
            if x == dv and src == sweep:
                bot.plot([x], [0], "o", ms=5, mfc="white", mec="black", zorder=3)
            elif lo is not None:
                bot.errorbar([x], [m], yerr=[[m - lo], [hi - m]], fmt="o", ms=4, capsize=3,
                             color=fs.PALETTE["vermillion"])
            else:
                bot.plot([x], [m], "o", ms=4, color=fs.PALETTE["vermillion"])
        bot.axhline(0, color="black", lw=0.8)
        bot.set_ylabel(fs.label("paired difference", MSE_UNIT), fontsize=8)
        other = "" if src == sweep else f"\n(the default's forests from the {src} sweep)"
        bot.set_title(f"minus the default ({names[sweep]} = {dv}) on the same subsets:\n"
                      f"mean and 95 % interval (orange), each forest (grey){other}", fontsize=7.5)
    else:
        bot.text(0.5, 0.5, "default setting not run: no paired difference",
                 transform=bot.transAxes, ha="center", va="center")
    bot.set_xlabel(xlabel)
    bot.xaxis.set_major_locator(MaxNLocator(integer=True))
    return fs.save(fig, d, stem)


def plot_map(d, rows, geo):
    """Simulated return, the forests' mean prediction and their difference."""
    reps = sorted({int(r["repetition"]) for r in rows})
    x = np.array([float(r["x1"]) for r in rows])
    y = np.array([float(r["y1"]) for r in rows])
    xs, ys = np.unique(x), np.unique(y)
    ix, iy = np.searchsorted(xs, x), np.searchsorted(ys, y)
    reward = np.full((len(ys), len(xs)), np.nan)
    pred = np.zeros((len(reps), len(ys), len(xs)))
    for r, i, j in zip(rows, iy, ix):
        reward[i, j] = float(r["reward"])
        pred[reps.index(int(r["repetition"])), i, j] = float(r["pred"])
    mean = pred.mean(axis=0)
    diff = mean - reward
    dx = (xs[1] - xs[0]) / 2 if len(xs) > 1 else 0.01
    dy = (ys[1] - ys[0]) / 2 if len(ys) > 1 else 0.01
    extent = (xs[0] - dx, xs[-1] + dx, ys[0] - dy, ys[-1] + dy)
    lo = min(np.nanmin(reward), np.nanmin(mean))
    big = np.nanmax(np.abs(diff))
    L, W = geo["length"], geo["width"]
    fig, axes = fs.figure("full", 0.4, ncols=3, sharey=True)
    panels = [(reward, "simulated return", fs.CMAP, lo, 0, fs.label("return", "m")),
              (mean, f"mean prediction of {len(reps)} forests", fs.CMAP, lo, 0,
               fs.label("return", "m")),
              (diff, "prediction − simulation", fs.CMAP_DIVERGING, -big, big,
               fs.label("difference", "m"))]
    for k, (ax, (g, title, cmap, vmin, vmax, clabel)) in enumerate(zip(axes, panels)):
        im = ax.imshow(g, origin="lower", extent=extent, vmin=vmin, vmax=vmax, cmap=cmap,
                       aspect="equal", interpolation="nearest")
        ax.add_patch(plt.Rectangle((-L / 2, -W / 2), L, W, fill=False, color="black", lw=1))
        for pid, (px, py) in geo["pockets"].items():
            target = pid in geo["targets"]
            ax.add_patch(plt.Circle((px, py), geo["pocket_radius"], zorder=3,
                                    color=fs.PALETTE["vermillion"] if target else "0.35"))
        ax.set_xlim(-0.04, L / 2 + 0.04)
        ax.set_ylim(-W / 2 - 0.04, W / 2 + 0.04)
        ax.set_xlabel(fs.label("reward ball $x_1$", "m"))
        ax.set_title(title, fontsize=8.5)
        ax.grid(False)
        if k != 0:
            fig.colorbar(im, ax=axes[:2] if k == 1 else ax, label=clabel, shrink=0.8)
    axes[0].set_ylabel(fs.label("reward ball $y_1$", "m"))
    cx, cy = geo["cue"]
    fig.suptitle(f"Experiment 1: return of the shot from the cue ball at ({cx:g}, {cy:g}) aimed "
                 "at the reward ball, by the reward ball's position\n(grey: pockets, "
                 "red: target pockets; blue in the right panel: the forests underestimate)",
                 fontsize=8.5)
    return fs.save(fig, d, "exp1_map")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    d = ap.parse_args(argv).dir
    fs.setup()
    cfg = exp_data.config(d)
    default = exp_data.exp1_default(cfg)
    by_sweep, by_setting = exp_data.exp1_mse(d)
    written = []
    for sweep, stem, xlabel, panel in SWEEPS:
        if by_sweep.get(sweep):
            written += plot_sweep(d, sweep, stem, xlabel, panel, by_sweep[sweep], by_setting,
                                  default)
    map_rows = exp_data.exp1_map(d)
    if map_rows:
        written += plot_map(d, map_rows, exp_data.table_geometry(cfg))
    if not written:
        sys.exit(f"plot_exp1.py: {d}: no sweep rows and no map rows")
    fs.finish(d, written, STEMS)


if __name__ == "__main__":
    main()
