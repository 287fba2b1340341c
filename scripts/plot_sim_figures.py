#!/usr/bin/env python3
"""Draw the simulator figures (thesis Fig. 7.1, 7.2, 7.3, 7.5) from the CSVs
that `poolreps data/figures.ini -o DIR` writes (see src/private/poolreps/figures.h).

Usage: plot_sim_figures.py DIR

Reads DIR/fig7_*.csv and DIR/config.ini (ghost.aim) and writes, as PNG and
SVG: fig7_1_table (the table, its pockets and a start state with obstacles),
fig7_2_reward (the return over a grid of actions for a fixed state),
fig7_3_shots (two zero-return shots of that grid), fig7_5_ghost (the
ghost-ball expert's geometry and shot).
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import os
import sys

import exp_data
import figstyle as fs
import numpy as np  # noqa: E402  (after figstyle: it picks the Python)
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Circle, Patch, Rectangle  # noqa: E402

STEMS = ["fig7_1_table", "fig7_2_reward", "fig7_3_shots", "fig7_5_ghost"]
FELT, RAIL = "#2f7d4f", "#6b4a2f"
BALL = {"cue": "white", "reward": fs.PALETTE["blue"], "obstacle": fs.PALETTE["vermillion"]}


def read(d, name):
    rows = exp_data.read_csv(os.path.join(d, name))
    if not rows:
        sys.exit(f"plot_sim_figures.py: {os.path.join(d, name)}: no rows")
    return rows


def num(row, key):
    return float(row[key])


def draw_table(ax, table, pockets, margin=0.07):
    """Felt, cushions, pockets with their ids outside the table."""
    L, W = num(table, "length"), num(table, "width")
    rp = num(table, "pocket_radius")
    ax.add_patch(Rectangle((-L / 2, -W / 2), L, W, facecolor=FELT, edgecolor=RAIL,
                           linewidth=5, zorder=0))
    for p in pockets:
        x, y = num(p, "x"), num(p, "y")
        ax.add_patch(Circle((x, y), rp, facecolor="black", zorder=1))
        # the id sits outside the table, away from anything drawn on it
        ox = np.sign(x) * (rp + 0.018)
        oy = np.sign(y) * (rp + 0.018)
        ax.text(x + ox, y + oy, p["pocket"], ha="center", va="center", fontsize=8, zorder=2,
                clip_on=True)
    ax.set_xlim(-L / 2 - margin, L / 2 + margin)
    ax.set_ylim(-W / 2 - margin, W / 2 + margin)
    ax.set_aspect("equal")
    ax.grid(False)
    ax.set_xlabel(fs.label("x", "m"))
    ax.set_ylabel(fs.label("y", "m"))


def draw_ball(ax, x, y, r, colour, **kw):
    ax.add_patch(Circle((x, y), r, facecolor=colour, edgecolor="black", linewidth=0.8,
                        zorder=kw.pop("zorder", 5), **kw))


def ball_handle(colour, label):
    return Line2D([], [], ls="", marker="o", ms=7, mfc=colour, mec="black", label=label)


def paths(rows, shot=None):
    """{ball: ([x...], [y...])} in time order, optionally of one shot."""
    out = {}
    for r in rows:
        if shot is not None and int(float(r["shot"])) != shot:
            continue
        xs, ys = out.setdefault(int(float(r["ball"])), ([], []))
        xs.append(num(r, "x"))
        ys.append(num(r, "y"))
    return out


def fig_table(d, table, pockets):
    balls = read(d, "fig7_1_balls.csv")
    r = num(table, "ball_radius")
    fig, ax = fs.figure("full", 0.56)
    draw_table(ax, table, pockets)
    for b in balls:
        draw_ball(ax, num(b, "x"), num(b, "y"), r, BALL[b["role"]])
    n = {k: sum(b["role"] == k for b in balls) for k in BALL}
    ax.legend(handles=[ball_handle(BALL["cue"], "cue ball"),
                       ball_handle(BALL["reward"], f"reward ball ({n['reward']})"),
                       ball_handle(BALL["obstacle"], f"obstacles ({n['obstacle']})")],
              loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3)
    ax.set_title(f"Fig. 7.1: table with pockets 0–5 and a start state of {len(balls)} balls")
    return fs.save(fig, d, "fig7_1_table")


def fig_reward(d):
    rows = read(d, "fig7_2_reward.csv")
    shots = read(d, "fig7_3_shots.csv")
    vx = np.array([num(r, "vx") for r in rows])
    vy = np.array([num(r, "vy") for r in rows])
    xs, ys = np.unique(vx), np.unique(vy)
    grid = np.full((len(ys), len(xs)), np.nan)
    grid[np.searchsorted(ys, vy), np.searchsorted(xs, vx)] = [num(r, "reward") for r in rows]
    missed = np.zeros(grid.shape, bool)
    missed[np.searchsorted(ys, vy), np.searchsorted(xs, vx)] = [num(r, "hit") == 0 for r in rows]
    dx, dy = (xs[1] - xs[0]) / 2, (ys[1] - ys[0]) / 2
    extent = (xs[0] - dx, xs[-1] + dx, ys[0] - dy, ys[-1] + dy)
    # a miss pays the miss penalty, far below every hit: its own colour, so that
    # the colour scale spans the hits and the zero-return set stands out
    hits = np.ma.masked_where(missed | np.isnan(grid), grid)
    cmap = plt.get_cmap(fs.CMAP).copy()
    cmap.set_bad(fs.PALETTE["lightgrey"])
    fig, ax = fs.figure(4.8, 0.9)
    im = ax.imshow(hits, origin="lower", extent=extent, cmap=cmap, vmax=0,
                   vmin=float(np.floor(hits.min() * 10) / 10), interpolation="nearest")
    zero = np.ma.masked_where(grid != 0, np.ones_like(grid))
    ax.imshow(zero, origin="lower", extent=extent, cmap=ListedColormap(["white"]),
              interpolation="nearest")
    ax.contour(xs, ys, (grid == 0).astype(float), levels=[0.5], colors="black",
               linewidths=0.9)
    fig.colorbar(im, ax=ax, label=fs.label("return of a shot that hits the reward ball", "m"),
                 shrink=0.9)
    fs.legend_below(fig, [Patch(facecolor="white", edgecolor="black",
                                label="return 0: pocketed in a target"),
                          Patch(facecolor=fs.PALETTE["lightgrey"],
                                label="reward ball missed (miss penalty)")], ncol=2, height=0.08)
    for s in shots:
        ax.plot(num(s, "vx"), num(s, "vy"), "o", mfc="none", mec=fs.PALETTE["vermillion"],
                ms=8, mew=1.5)
        up = num(s, "vy") >= 0
        ax.annotate(f"Fig. 7.3, pocket {int(float(s['pocket']))}", (num(s, "vx"), num(s, "vy")),
                    xytext=(6, 12 if up else -12), textcoords="offset points", ha="left",
                    va="bottom" if up else "top", color="white", fontsize=7.5,
                    bbox={"boxstyle": "round,pad=0.2", "fc": "black", "alpha": 0.6, "lw": 0})
    ax.set_xlabel(fs.label("action $v_x$", "m/s"))
    ax.set_ylabel(fs.label("action $v_y$", "m/s"))
    ax.grid(False)
    ax.set_title("Fig. 7.2: return over the actions\n"
                 "cue ball at (−0.25, 0), reward ball at (0.1, 0)")
    return fs.save(fig, d, "fig7_2_reward")


def fig_shots(d, table, pockets):
    shots = read(d, "fig7_3_shots.csv")
    trace = read(d, "fig7_3_trace.csv")
    r = num(table, "ball_radius")
    fig, ax = fs.figure("full", 0.58)
    draw_table(ax, table, pockets)
    start = paths(trace, int(float(shots[0]["shot"])))
    draw_ball(ax, start[0][0][0], start[0][1][0], r, BALL["cue"])
    draw_ball(ax, start[1][0][0], start[1][1][0], r, BALL["reward"])
    # the thesis's colours: red into the lower pocket, yellow into the upper one
    for s in shots:
        q = int(float(s["shot"]))
        pocket = int(float(s["pocket"]))
        colour = fs.PALETTE["vermillion"] if pocket < 3 else fs.PALETTE["yellow"]
        for ball, (xs, ys) in sorted(paths(trace, q).items()):
            ax.plot(xs, ys, "-" if ball == 1 else "--", color=colour, lw=1.6, zorder=4,
                    label=(f"a = ({num(s, 'vx'):.3f}, {num(s, 'vy'):.3f}) m/s → pocket {pocket}"
                           if ball == 1 else None))
    handles, _ = ax.get_legend_handles_labels()
    handles += [Line2D([], [], color="0.3", ls="-", label="reward ball"),
                Line2D([], [], color="0.3", ls="--", label="cue ball")]
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2)
    ax.set_title("Fig. 7.3: two actions with return 0 from the grid of Fig. 7.2")
    return fs.save(fig, d, "fig7_3_shots")


def fig_ghost(d, table, pockets, aim_mode):
    g = read(d, "fig7_5_ghost.csv")[0]
    trace = read(d, "fig7_5_trace.csv")
    r = num(table, "ball_radius")
    rp = num(table, "pocket_radius")
    cx, cy = num(g, "cue_x"), num(g, "cue_y")
    bx, by = num(g, "ball_x"), num(g, "ball_y")
    gx, gy = num(g, "ghost_x"), num(g, "ghost_y")
    ax_, ay_ = num(g, "aim_x"), num(g, "aim_y")
    ex, ey = num(g, "entry_x"), num(g, "entry_y")
    target = int(float(g["target"]))
    px, py = next((num(p, "x"), num(p, "y")) for p in pockets if int(p["pocket"]) == target)
    fig, axes = fs.figure("full", 0.56, ncols=2, gridspec_kw={"width_ratios": [1.75, 1]})
    for k, ax in enumerate(axes):
        draw_table(ax, table, pockets)
        tr = paths(trace)
        ax.plot(*tr[0], lw=1.0, zorder=3, label="cue ball path", **fs.outlined())
        # wide, under the aim line it follows
        ax.plot(*tr[1], color=fs.PALETTE["skyblue"], lw=3.5, zorder=3, solid_capstyle="butt",
                label="reward ball path")
        ax.plot([cx, gx], [cy, gy], ":", color="black", lw=1.2, zorder=4,
                label="cue line (to the ghost-ball centre)")
        ax.plot([gx, ax_], [gy, ay_], "-", color=fs.PALETTE["yellow"], lw=1.0, zorder=4,
                label="ghost centre → reward ball → aim point")
        draw_ball(ax, cx, cy, r, BALL["cue"])
        draw_ball(ax, bx, by, r, BALL["reward"])
        ax.add_patch(Circle((gx, gy), r, facecolor="none", edgecolor="white", linestyle=":",
                            linewidth=1.5, zorder=6))
        ax.plot(px, py, "+", ms=8, mew=1.2, zorder=6, label="pocket centre",
                **fs.outlined(width=2.6))
        ax.plot(ex, ey, "o", mfc="none", mec=fs.PALETTE["orange"], ms=6, mew=1.5, zorder=6,
                label="centre of the entry arc")
        ax.plot(ax_, ay_, "x", color=fs.PALETTE["yellow"], ms=9, mew=2, zorder=7,
                label=f"aim point (ghost.aim = {aim_mode})")
        if k == 1:
            # the corridor: the capture disc clipped to where a ball centre fits
            L, W = num(table, "length"), num(table, "width")
            ax.plot([-L / 2 + r, L / 2 - r, L / 2 - r, -L / 2 + r, -L / 2 + r],
                    [-W / 2 + r, -W / 2 + r, W / 2 - r, W / 2 - r, -W / 2 + r],
                    lw=0.7, ls="--", zorder=2, label="reach of a ball centre (R from the cushions)",
                    **fs.outlined(width=1.6))
            phi = np.linspace(0, 2 * np.pi, 721)
            arc_x, arc_y = px + rp * np.cos(phi), py + rp * np.sin(phi)
            inside = (np.abs(arc_x) <= L / 2 - r) & (np.abs(arc_y) <= W / 2 - r)
            ax.plot(np.where(inside, arc_x, np.nan), np.where(inside, arc_y, np.nan),
                    color=fs.PALETTE["orange"], lw=2, zorder=5, label="corridor entry arc")
            half = max(0.06, 0.6 * max(abs(px - gx), abs(py - gy)))
            mx, my = (gx + px) / 2, (gy + py) / 2
            ax.set_xlim(mx - half, mx + half)
            ax.set_ylim(my - half, my + half)
            ax.annotate("ghost ball", (gx + r, gy - r), xytext=(22, -22),
                        textcoords="offset points", color="white", fontsize=8,
                        arrowprops={"arrowstyle": "->", "color": "white"})
            ax.set_title(f"zoom: pocket {target}, radius {rp:g} m")
    handles, labels = axes[1].get_legend_handles_labels()
    fs.legend_below(fig, handles, labels, ncol=3, height=0.17, fontsize=7)
    aim = ("its centre (ghost.aim = centre, the default)" if aim_mode == "centre"
           else "the centre of its corridor entry (ghost.aim = corridor)")
    fig.suptitle(f"Fig. 7.5: ghost-ball expert, target pocket {target}, aimed at {aim}\n"
                 f"cut {num(g, 'cut_deg'):.1f}°, $v_0$ = {num(g, 'v0'):.3f} m/s, "
                 f"return {num(g, 'reward'):.3g} m", fontsize=9)
    return fs.save(fig, d, "fig7_5_ghost")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    d = ap.parse_args(argv).dir
    fs.setup()
    table = read(d, "fig7_table.csv")[0]
    pockets = read(d, "fig7_1_pockets.csv")
    aim = exp_data.config(d).get("ghost", "aim", fallback="centre")
    written = fig_table(d, table, pockets) + fig_reward(d) + fig_shots(d, table, pockets) + \
        fig_ghost(d, table, pockets, aim)
    fs.finish(d, written, STEMS)


if __name__ == "__main__":
    main()
