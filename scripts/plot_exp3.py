#!/usr/bin/env python3
"""Figures 7.7-7.10 of Experiment 3 (thesis 7.5) from a `poolreps data/exp3.ini` folder.

    plot_exp3.py DIR

Reads DIR/exp3_episodes.csv and DIR/config.ini, and writes as PNG and SVG:
  fig7_7   average return per iteration, panels a-d (value score x policy
           target), each with the baseline and the hand-crafted variant; the
           mean over the repetitions, bands -+ one SD over the repetitions;
  fig7_8   the returns of each run's last episodes (exp3.final_episodes): top,
           as the thesis draws it, each run's mean with one SD of its returns;
           below, a box per run (quartiles, whiskers at the 5th and 95th
           percentiles, diamond: the run's mean); every policy once;
  fig7_9   reward balls pocketed in each pocket group (numbered as in
           Fig. 7.1), as a share of the N last episodes of all runs (bars) and
           of each run (dots);
  fig7_10  the outcome of those episodes (pocketed in a target, pocketed
           elsewhere, reward ball never hit, on the table after a hit), with
           each run's share, and the final distance of the reward ball to the
           nearest target pocket: over every ball (the thesis's histogram) and
           for the balls left on the table after a hit, on one scale.
Policies missing from the CSVs (exp3.policies) are left out.
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import math
from collections import defaultdict

import exp3_table
import exp_data
import figstyle as fs
import numpy as np  # noqa: E402  (after figstyle: it picks the Python)
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

STEMS = ["fig7_7", "fig7_8", "fig7_9", "fig7_10"]
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
COLOUR = {
    "nrvr_rs": fs.PALETTE["vermillion"], "rvr_rs": fs.PALETTE["orange"],
    "nrvr_a": fs.PALETTE["blue"], "rvr_a": fs.PALETTE["skyblue"],
    "baseline": fs.PALETTE["grey"], "handcrafted": fs.PALETTE["green"],
}
REFS = ("baseline", "handcrafted")
RETURN = fs.label("return", "m")
# outcome of an episode (Fig. 7.10), in the order they are decided
# (colours apart from the policies' own)
OUTCOMES = [
    ("target", "pocketed in a target", fs.PALETTE["black"]),
    ("elsewhere", "pocketed elsewhere", fs.PALETTE["purple"]),
    ("missed", "reward ball never hit", fs.PALETTE["lightgrey"]),
    ("table", "hit, left on the table", fs.PALETTE["yellow"]),
]
BIN = 0.05  # m, Fig. 7.10's histogram bins


def label_of(p):
    return LABEL.get(p, p)


def colour_of(p):
    return COLOUR.get(p, "black")


def curves(all_runs):
    """{policy: (episodes, mean, low, high)}: per iteration, the episodes run so
    far, the mean over the repetitions of the iteration's average return and
    that mean -+ one SD of those averages over the repetitions (the band of
    Experiment 4's curves too)."""
    out = {}
    for p in exp3_table.policies(all_runs):
        per_rep = []
        for (q, r), eps in sorted(all_runs.items()):
            if q != p:
                continue
            its = defaultdict(list)
            for e in eps:
                its[int(e["iteration"])].append(float(e["return"]))
            per_rep.append(its)
        iters = sorted(set.intersection(*(set(i) for i in per_rep)))
        count = np.cumsum([len(per_rep[0][i]) for i in iters])
        avg = np.array([[np.mean(its[i]) for i in iters] for its in per_rep])
        m = avg.mean(axis=0)
        sd = avg.std(axis=0, ddof=1) if len(avg) > 1 else np.zeros_like(m)
        out[p] = (count, m, m - sd, m + sd)
    return out


def outcome(e, targets):
    """Category of one episode row: target, elsewhere, missed or table."""
    if e["pocket"] in targets:
        return "target"
    if e["pocket"] != "-1":
        return "elsewhere"
    return "missed" if e["hit"] == "0" else "table"


def target_distance(e, geo):
    """Final distance of the reward ball to the nearest target pocket [m]."""
    x, y = float(e["rx"]), float(e["ry"])
    return min(math.hypot(x - geo["pockets"][t][0], y - geo["pockets"][t][1])
               for t in geo["targets"])


def shares(runs, policy, key):
    """{category: (pooled share, [share of each run])} of policy's episodes,
    key(episode) giving the category."""
    reps = sorted(r for p, r in runs if p == policy)
    per_run = []
    pooled = defaultdict(int)
    total = 0
    for r in reps:
        c = defaultdict(int)
        for e in runs[(policy, r)]:
            c[key(e)] += 1
        per_run.append((c, len(runs[(policy, r)])))
        for k, v in c.items():
            pooled[k] += v
        total += len(runs[(policy, r)])
    cats = set(pooled) | {k for c, _ in per_run for k in c}
    return {k: (pooled[k] / total, [c[k] / n for c, n in per_run]) for k in cats}, total


def iterations(runs):
    """'iterations 76-100': the iterations the selected episodes come from."""
    its = {int(e["iteration"]) for eps in runs.values() for e in eps}
    return f"iterations {min(its)}–{max(its)}" if len(its) > 1 else f"iteration {min(its)}"


def fig7_7(d, cur, nreps):
    fig, axes = fs.figure("full", 0.72, nrows=2, ncols=2, sharex=True, sharey=True)
    lo = min(float(np.min(low)) for _, _, low, _ in cur.values())
    for ax, (pol, title) in zip(axes.flat, PANELS):
        for p in list(REFS) + [pol]:
            if p not in cur:
                continue
            x, m, low, high = cur[p]
            if p == pol:
                ax.fill_between(x, low, high, color=colour_of(p), alpha=0.3, lw=0)
                ax.plot(x, m, color=colour_of(p), lw=1.8)
            elif p == "baseline":
                # the reference the thesis compares against: a hatched, outlined band
                ax.fill_between(x, low, high, facecolor="0.85", edgecolor="0.45",
                                hatch="////", lw=0.6, alpha=0.8)
                ax.plot(x, m, color="black", lw=1.2, ls="--")
            else:
                ax.fill_between(x, low, high, color=colour_of(p), alpha=0.15, lw=0)
                ax.plot(x, m, color=colour_of(p), lw=1.2, ls=":")
        if pol not in cur:
            ax.text(0.5, 0.5, f"{pol}: not run", transform=ax.transAxes, ha="center")
        ax.set_title(title, fontsize=8.5)
        ax.axhline(0, color="black", lw=0.5)
        ax.set_ylim(max(lo, -4.0) - 0.05, 0.15)
    for ax in axes[1]:
        ax.set_xlabel(fs.label("episodes"))
    for ax in axes[:, 0]:
        ax.set_ylabel(fs.label("average return per iteration", "m"), fontsize=8)
    handles = [Line2D([], [], color="0.2", lw=1.8, label="the panel's tree policy (its colour)")]
    if "baseline" in cur:
        handles.append(Patch(facecolor="0.85", edgecolor="0.45", hatch="////",
                             label="baseline (1 node), dashed: mean"))
    if "handcrafted" in cur:
        handles.append(Line2D([], [], color=colour_of("handcrafted"), ls=":", lw=1.2,
                              label="hand-crafted features (beyond the thesis)"))
    fs.legend_below(fig, handles, ncol=3, height=0.07)
    fig.suptitle(f"Fig. 7.7: average return per iteration, mean over {nreps} repetitions "
                 "(bands: ± 1 SD)")
    return fs.save(fig, d, "fig7_7")


def run_returns(runs, p):
    """[returns of each of policy p's runs], in repetition order."""
    return [[float(e["return"]) for e in runs[(p, r)]] for r in sorted(r for q, r in runs if q == p)]


def fig7_8(d, runs, last):
    """Top, as the thesis draws it: each run's mean return with one SD of its
    returns as the error bar. Bottom: the same runs as boxes."""
    pols = exp3_table.policies(runs)
    fig, (top, ax) = fs.figure("full", 0.8, nrows=2, sharex=True,
                               gridspec_kw={"height_ratios": [1, 1.15]})
    pos, ticks, lows, sd_lo, sd_hi = 0.0, [], [], [], []
    for p in pols:
        data = run_returns(runs, p)
        x = pos + np.arange(len(data))
        means = np.array([np.mean(v) for v in data])
        sds = np.array([np.std(v, ddof=1) if len(v) > 1 else 0.0 for v in data])
        top.errorbar(x, means, yerr=sds, fmt="o", color=colour_of(p), ms=4, capsize=3, lw=1)
        sd_lo.append(float(np.min(means - sds)))
        sd_hi.append(float(np.max(means + sds)))
        ax.boxplot(data, positions=x, widths=0.7, whis=(5, 95), showfliers=False,
                   showmeans=True, patch_artist=True,
                   boxprops={"facecolor": colour_of(p), "alpha": 0.55, "lw": 0.8},
                   medianprops={"color": "black", "lw": 1},
                   meanprops={"marker": "D", "mfc": "white", "mec": "black", "ms": 3.5},
                   whiskerprops={"lw": 0.8}, capprops={"lw": 0.8})
        lows.extend(np.percentile(v, 5) for v in data)
        ticks.append((pos + (len(data) - 1) / 2, label_of(p)))
        pos += len(data) + 1.0
    for a in (top, ax):
        a.axhline(0, color="black", lw=0.8)
        a.set_ylabel(RETURN)
        a.grid(axis="x", visible=False)
    top.set_ylim(min(sd_lo) * 1.05, max(0.08, max(sd_hi) + 0.05))
    top.set_title("as in the thesis: each run's mean return ± 1 SD of its returns "
                  "(the bar may pass 0, which no return exceeds)", fontsize=8.5)
    ax.set_ylim(min(lows) * 1.05, 0.08)
    ax.set_title("the same runs as boxes: quartiles, whiskers 5–95 %, diamond: the run's mean",
                 fontsize=8.5)
    ax.set_xticks([t for t, _ in ticks], [lab for _, lab in ticks])
    ax.tick_params(axis="x", length=0)
    fig.suptitle(f"Fig. 7.8: returns of the last {last} episodes of each run ({iterations(runs)}); "
                 "one mark per run\n0 m: pocketed in a target, the best possible")
    return fs.save(fig, d, "fig7_8")


# pockets numbered as in Fig. 7.1: 0-2 along the lower cushion (y < 0), 3-5
# along the upper; the targets are the corners at x = +L/2
POCKET_GROUPS = [("2", "pocket 2 (target, lower)", ("2",)),
                 ("5", "pocket 5 (target, upper)", ("5",)),
                 ("middle", "middle pockets 1, 4", ("1", "4")),
                 ("far", "far corners 0, 3", ("0", "3"))]


def fig7_9(d, runs, last):
    pols = exp3_table.policies(runs)
    group_of = {pk: g for g, _, ids in POCKET_GROUPS for pk in ids}
    colours = [fs.PALETTE["blue"], fs.PALETTE["orange"], fs.PALETTE["purple"], fs.PALETTE["grey"]]
    fig, ax = fs.figure("full", 0.48)
    w = 0.8 / len(POCKET_GROUPS)
    n_eps, top = {}, 0.0
    for i, p in enumerate(pols):
        sh, n_eps[p] = shares(runs, p, lambda e: group_of.get(e["pocket"], "none"))
        for j, ((g, lab, _), col) in enumerate(zip(POCKET_GROUPS, colours)):
            pooled, per_run = sh.get(g, (0.0, []))
            x = i + (j - (len(POCKET_GROUPS) - 1) / 2) * w
            b = ax.bar([x], [100 * pooled], w, color=col, label=lab if i == 0 else None)
            ax.bar_label(b, [f"{round(pooled * n_eps[p])}"], fontsize=6, padding=1)
            # the runs' dots beside the bar's right edge, clear of its count
            ax.plot([x + 0.3 * w] * len(per_run), [100 * v for v in per_run], "o", mfc="white",
                    mec="black", mew=0.5, ms=2.2, label="one run" if i == 0 and j == 0 else None)
            top = max(top, 100 * pooled, *(100 * v for v in per_run))
    ax.set_xticks(range(len(pols)), [label_of(p) for p in pols])
    ax.set_ylabel(fs.label("reward balls pocketed", "% of N"))
    ax.grid(axis="x", visible=False)
    ax.set_ylim(0, top * 1.25)
    ax.legend(loc="upper right", ncol=2)
    runs_n = len({r for _, r in runs})
    n = sorted(set(n_eps.values()))
    ax.set_title(f"Fig. 7.9: where the reward ball was pocketed in the last {last} episodes of "
                 f"each of the {runs_n} runs ({iterations(runs)})\n(N = "
                 f"{', '.join(map(str, n))} episodes per policy; bars: share of the N episodes, "
                 "numbers: balls; dots: each run's share)", fontsize=8.5)
    return fs.save(fig, d, "fig7_9")


def fig7_10(d, runs, last, geo):
    pols = exp3_table.policies(runs)
    targets = {str(t) for t in geo["targets"]}
    ncol = 3
    nrow = (len(pols) + ncol - 1) // ncol
    fig = fs.figure("full", 0.42 + 0.3 * nrow)[0]
    fig.clf()
    gs = fig.add_gridspec(1 + nrow, ncol, height_ratios=[1.25] + [1] * nrow)
    top = fig.add_subplot(gs[0, :])
    w = 0.8 / len(OUTCOMES)
    dist_all, every = {}, {}
    for i, p in enumerate(pols):
        sh, _ = shares(runs, p, lambda e: outcome(e, targets))
        for j, (k, lab, col) in enumerate(OUTCOMES):
            pooled, per_run = sh.get(k, (0.0, []))
            x = i + (j - (len(OUTCOMES) - 1) / 2) * w
            top.bar([x], [100 * pooled], w, color=col, edgecolor="black", lw=0.4,
                    label=lab if i == 0 else None)
            top.plot([x] * len(per_run), [100 * s for s in per_run], "o", mfc="white", mec="black",
                     mew=0.6, ms=2.8, label="one run" if i == 0 and j == 0 else None)
        dist_all[p] = {r: [target_distance(e, geo) for e in runs[(p, r)]
                           if outcome(e, targets) == "table"]
                       for q, r in runs if q == p}
        # the thesis's histogram: every ball, 0 when in a target pocket, a
        # pocket's centre when pocketed elsewhere, where it stopped otherwise
        every[p] = [0.0 if outcome(e, targets) == "target" else target_distance(e, geo)
                    for q, r in runs if q == p for e in runs[(p, r)]]
    top.set_xticks(range(len(pols)), [label_of(p) for p in pols])
    top.set_ylabel(fs.label("share of the episodes", "%"))
    top.grid(axis="x", visible=False)
    top.legend(loc="upper left", ncol=3, fontsize=7)
    top.set_ylim(0, 130)
    top.set_title("outcome of each episode (bars: all runs, dots: each run)", fontsize=8.5)
    dmax = max((max(v) for v in every.values() if v), default=BIN)
    edges = np.arange(0, dmax + BIN, BIN)
    if len(edges) < 2:
        edges = np.array([0, BIN])
    axes = [fig.add_subplot(gs[1 + k // ncol, k % ncol]) for k in range(len(pols))]
    for ax in axes[1:]:
        ax.sharex(axes[0])
        ax.sharey(axes[0])
    for ax, p in zip(axes, pols):
        per_run = []
        for r, dist in sorted(dist_all[p].items()):
            n = len(runs[(p, r)])
            per_run.append(100 * np.histogram(dist, edges)[0] / n)
        per_run = np.array(per_run)
        pooled = 100 * np.histogram([x for v in dist_all[p].values() for x in v], edges)[0] / \
            sum(len(runs[(p, r)]) for r in dist_all[p])
        centres = (edges[:-1] + edges[1:]) / 2
        ax.stairs(100 * np.histogram(every[p], edges)[0] / len(every[p]), edges,
                  color="black", lw=1.0, label="every ball (the thesis's histogram)")
        ax.bar(edges[:-1], pooled, BIN, align="edge", color=colour_of(p), alpha=0.8,
               edgecolor="black", lw=0.3, label="hit, left on the table")
        if len(per_run) > 1:
            ax.vlines(centres, per_run.min(axis=0), per_run.max(axis=0), color="black", lw=0.8)
        ax.set_title(label_of(p), fontsize=8.5)
        ax.set_xlim(0, edges[-1])
    for k, ax in enumerate(axes):
        if k % ncol == 0:
            ax.set_ylabel(fs.label("share of the episodes", "%"), fontsize=8)
    axes[0].legend(loc="upper right", fontsize=6)
    fig.supxlabel(fs.label("final distance of the reward ball to the nearest target pocket", "m"),
                  fontsize=8.5)
    fig.suptitle(f"Fig. 7.10: the last {last} episodes of each run ({iterations(runs)})\n"
                 "top: their outcome; below: the final distance of the reward ball to the "
                 "nearest target pocket\nline: every ball, as the thesis counts it (0 in a "
                 "target); bars: the balls left on the table after a hit\n(share of all the "
                 f"policy's episodes per {BIN:g} m bin, range over the runs; one scale for "
                 "every policy)", fontsize=9)
    return fs.save(fig, d, "fig7_10")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    d = ap.parse_args(argv).dir
    fs.setup()
    runs, last = exp3_table.load(d)
    if not runs:
        raise SystemExit(f"plot_exp3.py: {d}/exp3_episodes.csv: no episodes")
    geo = exp_data.table_geometry(exp_data.config(d))
    nreps = len({r for _, r in runs})
    written = fig7_7(d, curves(exp3_table.load(d, 10**12)[0]), nreps) + fig7_8(d, runs, last) + \
        fig7_9(d, runs, last) + \
        fig7_10(d, runs, last, geo)
    fs.finish(d, written, STEMS)


if __name__ == "__main__":
    main()
