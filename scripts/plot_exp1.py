#!/usr/bin/env python3
"""Figures of Experiment 1 (thesis 7.3) from a `poolreps data/exp1.ini` folder.

    plot_exp1.py DIR [--repetition K]

Reads DIR/exp1_summary.csv and DIR/exp1_map.csv (CSV only) and writes into DIR:
  fig7_4a_nmin.png, fig7_4b_trees.png, fig7_4c_cuts.png  test MSE per setting,
      mean over the forests with error bars of one standard deviation;
  exp1_map.png  simulated return against the forest's prediction over the
      reward-ball region (forest of repetition K, default the first present).
"""
import argparse
import configparser
import csv
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def table_geometry(d):
    """Table size, pocket radius, target pockets and cue box from config.ini."""
    geo = {"length": 1.0, "width": 0.5, "pocket_radius": 0.03, "targets": [2, 5],
           "cue": (-0.25, 0.0)}
    path = os.path.join(d, "config.ini")
    if os.path.exists(path):
        c = configparser.ConfigParser(inline_comment_prefixes=(";",))
        c.read(path)
        geo["length"] = c.getfloat("table", "length", fallback=1.0)
        geo["width"] = c.getfloat("table", "width", fallback=0.5)
        geo["pocket_radius"] = c.getfloat("table", "pocket_radius", fallback=0.03)
        t = c.get("reward", "targets", fallback="2,5")
        geo["targets"] = [int(x) for x in t.split(",")]
        box = [float(x) for x in c.get("start", "cue_box", fallback="-0.25,-0.25,0,0").split(",")]
        geo["cue"] = ((box[0] + box[1]) / 2, (box[2] + box[3]) / 2)
    return geo


def pockets(geo):
    """Pocket centres by id (SPEC.md §1)."""
    L, W = geo["length"], geo["width"]
    return {i: ((i % 3 - 1) * L / 2, (-1 if i < 3 else 1) * W / 2) for i in range(6)}


SWEEPS = [
    ("n_min", "fig7_4a_nmin.png", r"$n_{min}$", "Fig. 7.4a: varying $n_{min}$"),
    ("trees", "fig7_4b_trees.png", "trees $M$", "Fig. 7.4b: varying $M$"),
    ("cuts", "fig7_4c_cuts.png", "cuts $K$", "Fig. 7.4c: varying $K$"),
]


def plot_sweeps(d, rows, cfg_defaults):
    out = []
    for sweep, name, xlabel, title in SWEEPS:
        r = [x for x in rows if x["sweep"] == sweep]
        if not r:
            continue
        v = np.array([float(x["value"]) for x in r])
        m = np.array([float(x["mean_mse"]) for x in r])
        s = np.array([float(x["std_mse"]) for x in r])
        n = int(r[0]["forests"])
        fig, ax = plt.subplots(figsize=(5, 3.6))
        ax.errorbar(v, m, yerr=s, fmt="o-", capsize=3, color="tab:blue")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("test MSE of the return")
        others = ", ".join(f"{k} = {val}" for k, val in cfg_defaults.items() if k != sweep)
        ax.set_title(f"{title}\n({others}; {n} forests, bars: ±1 std)", fontsize=9)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        p = os.path.join(d, name)
        fig.savefig(p, dpi=120)
        plt.close(fig)
        out.append(p)
    return out


def plot_map(d, rows, rep, geo):
    reps = sorted({int(x["repetition"]) for x in rows})
    if not reps:
        return None
    if rep is None:
        rep = reps[0]
    r = [x for x in rows if int(x["repetition"]) == rep]
    if not r:
        sys.exit(f"plot_exp1.py: repetition {rep} not in exp1_map.csv (have {reps})")
    x = np.array([float(a["x1"]) for a in r])
    y = np.array([float(a["y1"]) for a in r])
    xs, ys = np.unique(x), np.unique(y)
    grids = []
    for col in ("reward", "pred"):
        g = np.full((len(ys), len(xs)), np.nan)
        ix = np.searchsorted(xs, x)
        iy = np.searchsorted(ys, y)
        g[iy, ix] = [float(a[col]) for a in r]
        grids.append(g)
    lo = min(np.nanmin(g) for g in grids)
    dx = (xs[1] - xs[0]) / 2 if len(xs) > 1 else 0.01
    dy = (ys[1] - ys[0]) / 2 if len(ys) > 1 else 0.01
    extent = (xs[0] - dx, xs[-1] + dx, ys[0] - dy, ys[-1] + dy)
    L, W = geo["length"], geo["width"]
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    for ax, g, title in zip(axes, grids, ("simulated return", f"forest prediction (repetition {rep})")):
        im = ax.imshow(g, origin="lower", extent=extent, vmin=lo, vmax=0, cmap="viridis",
                       aspect="equal", interpolation="nearest")
        ax.add_patch(plt.Rectangle((-L / 2, -W / 2), L, W, fill=False, color="k", lw=1))
        for pid, (px, py) in pockets(geo).items():
            target = pid in geo["targets"]
            ax.add_patch(plt.Circle((px, py), geo["pocket_radius"], color="tab:red" if target else "0.3",
                                    fill=True, zorder=3))
        ax.plot(*geo["cue"], "o", ms=6, mfc="white", mec="k", zorder=3)
        ax.annotate("cue ball", geo["cue"], xytext=(0, 8), textcoords="offset points",
                    ha="center", fontsize=8)
        ax.set_xlim(geo["cue"][0] - 0.1, L / 2 + 0.05)
        ax.set_ylim(-W / 2 - 0.05, W / 2 + 0.05)
        ax.set_xlabel("reward ball x1 (m)")
        ax.set_title(title, fontsize=10)
    axes[0].set_ylabel("reward ball y1 (m)")
    fig.colorbar(im, ax=axes, label="return (0 = pocketed in a target, red pockets)")
    fig.suptitle("Experiment 1: return of the aimed shot against the reward-ball position", fontsize=10)
    p = os.path.join(d, "exp1_map.png")
    fig.savefig(p, dpi=120)
    plt.close(fig)
    return p


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    ap.add_argument("--repetition", type=int, default=None, help="map of this forest")
    a = ap.parse_args()
    summary = read_csv(os.path.join(a.dir, "exp1_summary.csv"))
    defaults = {}
    path = os.path.join(a.dir, "config.ini")
    if os.path.exists(path):
        c = configparser.ConfigParser(inline_comment_prefixes=(";",))
        c.read(path)
        defaults = {"n_min": c.get("forest", "n_min", fallback="20"),
                    "trees": c.get("forest", "trees", fallback="30"),
                    "cuts": c.get("forest", "cuts", fallback="10")}
    made = plot_sweeps(a.dir, summary, defaults)
    m = plot_map(a.dir, read_csv(os.path.join(a.dir, "exp1_map.csv")), a.repetition,
                 table_geometry(a.dir))
    if m:
        made.append(m)
    for p in made:
        print(p)


if __name__ == "__main__":
    main()
