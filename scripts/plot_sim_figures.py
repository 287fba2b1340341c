#!/usr/bin/env python3
"""Draw the simulator figures (thesis Fig. 7.1, 7.2, 7.3, 7.5) from the CSVs
that `poolreps` writes for experiment `figures` (see include/poolreps/figures.h).

Usage: plot_sim_figures.py DIR   -> DIR/fig7_1_table.png, fig7_2_reward.png,
                                    fig7_3_shots.png, fig7_5_ghost.png
Reads only DIR/fig7_*.csv.
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Circle, Rectangle  # noqa: E402

BALL_COLOURS = {"cue": "white", "reward": "tab:blue", "obstacle": "tab:red"}


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"plot_sim_figures.py: {path}: no rows")
    return rows


def num(row, key):
    return float(row[key])


def draw_table(ax, table, pockets):
    length, width = num(table, "length"), num(table, "width")
    rp = num(table, "pocket_radius")
    ax.add_patch(Rectangle((-length / 2, -width / 2), length, width, facecolor="#2e7d32",
                           edgecolor="#5d4037", linewidth=6, zorder=0))
    for p in pockets:
        ax.add_patch(Circle((num(p, "x"), num(p, "y")), rp, facecolor="black", zorder=1))
        ax.annotate(p["pocket"], (num(p, "x"), num(p, "y")), color="white", ha="center",
                    va="center", fontsize=8, zorder=2)
    margin = 0.06
    ax.set_xlim(-length / 2 - margin, length / 2 + margin)
    ax.set_ylim(-width / 2 - margin, width / 2 + margin)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def draw_ball(ax, x, y, r, colour, **kw):
    ax.add_patch(Circle((x, y), r, facecolor=colour, edgecolor="black", linewidth=0.8,
                        zorder=kw.pop("zorder", 3), **kw))


def paths(rows, shot=None):
    """{ball: ([x...], [y...])} in time order, optionally for one shot."""
    out = {}
    for r in rows:
        if shot is not None and int(float(r["shot"])) != shot:
            continue
        xs, ys = out.setdefault(int(float(r["ball"])), ([], []))
        xs.append(num(r, "x"))
        ys.append(num(r, "y"))
    return out


def fig_table(d, table, pockets):
    balls = read(os.path.join(d, "fig7_1_balls.csv"))
    r = num(table, "ball_radius")
    fig, ax = plt.subplots(figsize=(8, 4.6))
    draw_table(ax, table, pockets)
    for b in balls:
        draw_ball(ax, num(b, "x"), num(b, "y"), r, BALL_COLOURS[b["role"]])
    ax.set_title("Fig. 7.1: table, pockets 0-5 and a start state\n"
                 "(white cue ball, blue reward ball, red obstacles)")
    fig.tight_layout()
    fig.savefig(os.path.join(d, "fig7_1_table.png"), dpi=120)
    plt.close(fig)


def fig_reward(d):
    rows = read(os.path.join(d, "fig7_2_reward.csv"))
    shots = read(os.path.join(d, "fig7_3_shots.csv"))
    vxs = sorted({num(r, "vx") for r in rows})
    vys = sorted({num(r, "vy") for r in rows})
    ix = {v: i for i, v in enumerate(vxs)}
    iy = {v: i for i, v in enumerate(vys)}
    grid = [[0.0] * len(vxs) for _ in vys]
    for r in rows:
        grid[iy[num(r, "vy")]][ix[num(r, "vx")]] = num(r, "reward")
    fig, ax = plt.subplots(figsize=(6.4, 5.4))
    im = ax.imshow(grid, origin="lower", cmap="jet", aspect="equal",
                   extent=(vxs[0], vxs[-1], vys[0], vys[-1]), interpolation="nearest")
    fig.colorbar(im, ax=ax, label="reward")
    for s in shots:
        ax.plot(num(s, "vx"), num(s, "vy"), "o", markerfacecolor="none", markeredgecolor="white",
                markersize=7, markeredgewidth=1.5)
        ax.annotate(f"Fig. 7.3: pocket {int(float(s['pocket']))}", (num(s, "vx"), num(s, "vy")),
                    xytext=(10, 12 if num(s, "vy") >= 0 else -20), textcoords="offset points",
                    color="white", fontsize=9)
    ax.set_xlabel("action vx [m/s]")
    ax.set_ylabel("action vy [m/s]")
    ax.set_title("Fig. 7.2: reward over actions\ncue (-0.25, 0), reward ball (0.1, 0)")
    fig.tight_layout()
    fig.savefig(os.path.join(d, "fig7_2_reward.png"), dpi=120)
    plt.close(fig)


def fig_shots(d, table, pockets):
    shots = read(os.path.join(d, "fig7_3_shots.csv"))
    trace = read(os.path.join(d, "fig7_3_trace.csv"))
    r = num(table, "ball_radius")
    fig, ax = plt.subplots(figsize=(8, 4.6))
    draw_table(ax, table, pockets)
    draw_ball(ax, -0.25, 0.0, r, "white")
    draw_ball(ax, 0.1, 0.0, r, "tab:blue")
    for s, colour in zip(shots, ("red", "gold")):
        q = int(float(s["shot"]))
        for ball, (xs, ys) in sorted(paths(trace, q).items()):
            ax.plot(xs, ys, "-" if ball == 1 else "--", color=colour, linewidth=1.6, zorder=4,
                    label=(f"a = ({num(s, 'vx'):.3f}, {num(s, 'vy'):.3f}) m/s -> pocket "
                           f"{int(float(s['pocket']))}" if ball == 1 else None))
    fig.legend(loc="lower center", ncol=2, fontsize=8)
    ax.set_title("Fig. 7.3: two zero-reward shots (solid: reward ball, dashed: cue ball)")
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    fig.savefig(os.path.join(d, "fig7_3_shots.png"), dpi=120)
    plt.close(fig)


def fig_ghost(d, table, pockets):
    g = read(os.path.join(d, "fig7_5_ghost.csv"))[0]
    trace = read(os.path.join(d, "fig7_5_trace.csv"))
    r = num(table, "ball_radius")
    cx, cy = num(g, "cue_x"), num(g, "cue_y")
    bx, by = num(g, "ball_x"), num(g, "ball_y")
    gx, gy = num(g, "ghost_x"), num(g, "ghost_y")
    px, py = num(g, "aim_x"), num(g, "aim_y")
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), gridspec_kw={"width_ratios": [1.7, 1]})
    for k, ax in enumerate(axes):
        draw_table(ax, table, pockets)
        for ball, (xs, ys) in sorted(paths(trace).items()):
            ax.plot(xs, ys, color="white" if ball == 0 else "tab:cyan", linewidth=0.9, alpha=0.7,
                    zorder=2, label="trajectories" if ball == 0 else None)
        ax.plot([cx, gx], [cy, gy], ":", color="white", linewidth=1.4, zorder=4,
                label="cue line (to the ghost centre)")
        ax.plot([gx, px], [gy, py], "-", color="yellow", linewidth=1.0, zorder=4,
                label="ghost centre -> reward ball -> aim point")
        draw_ball(ax, cx, cy, r, "white")
        draw_ball(ax, bx, by, r, "tab:blue")
        ax.add_patch(Circle((gx, gy), r, facecolor="none", edgecolor="white", linestyle=":",
                            linewidth=1.5, zorder=5))
        ax.plot(px, py, "x", color="yellow", markersize=9, zorder=6,
                label="aim point (target pocket centre)")
        if k == 1:
            half = max(0.06, 0.6 * max(abs(px - gx), abs(py - gy)))
            mx, my = (gx + px) / 2, (gy + py) / 2
            ax.set_xlim(mx - half, mx + half)
            ax.set_ylim(my - half, my + half)
            ax.annotate("ghost ball", (gx, gy - r), xytext=(10, -45), textcoords="offset points",
                        color="white", arrowprops={"arrowstyle": "->", "color": "white"})
            ax.set_title("zoom")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8, facecolor="0.35",
               labelcolor="white")
    axes[0].set_title(f"Fig. 7.5: ghost ball, target pocket {int(float(g['target']))}, "
                      f"cut {num(g, 'cut_deg'):.1f} deg, v0 = {num(g, 'v0'):.3f} m/s, "
                      f"reward {num(g, 'reward'):.3g}", fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(os.path.join(d, "fig7_5_ghost.png"), dpi=120)
    plt.close(fig)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__.strip())
    d = sys.argv[1]
    table = read(os.path.join(d, "fig7_table.csv"))[0]
    pockets = read(os.path.join(d, "fig7_1_pockets.csv"))
    fig_table(d, table, pockets)
    fig_reward(d)
    fig_shots(d, table, pockets)
    fig_ghost(d, table, pockets)


if __name__ == "__main__":
    main()
