#!/usr/bin/env python3
"""Figures of Experiment 4 (imitation, then REPS) from a `poolreps data/exp4.ini` folder.

    plot_exp4.py DIR

Reads DIR/exp4_curve.csv, DIR/exp4_final.csv, DIR/exp4_verdict.csv and
DIR/config.ini (derived files only, so it stays fast whatever the number of
episodes) and writes, as PNG and SVG:
  exp4_curves_query, exp4_curves_residual
           average return per iteration, in the style of Fig. 7.7, one panel
           per policy, for each covariance of exp4.covs: the run from scratch
           (Experiment 3, hatched band and dashed mean), imitation only, and
           imitation followed by REPS with the window started from the
           demonstrations or from episodes of the fitted policy; mean over
           the repetitions, bands: mean +- one standard deviation;
  exp4_final
           the returns of each run's last exp3.final_episodes episodes per
           variant: a box of all runs pooled (quartiles, whiskers at the 5th
           and 95th percentiles, diamond: the mean) and each run's mean;
  exp4_rates
           per variant, the share of those episodes that pocketed the reward
           ball in a target pocket and the share in which the cue ball hit it
           (bars: all runs pooled; dots: each run's pocket rate).
Variants missing from the CSVs are left out.
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import os
from collections import defaultdict

import exp_data
import figstyle as fs
import numpy as np  # noqa: E402  (after figstyle: it picks the Python)
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

POLICIES = ["nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a", "baseline", "handcrafted"]
POLICY_LABEL = {
    "nrvr_rs": "nrvr, s→rs", "rvr_rs": "rvr, s→rs", "nrvr_a": "nrvr, s→a",
    "rvr_a": "rvr, s→a", "baseline": "baseline (1 node)", "handcrafted": "hand-crafted",
}
INITS = ["scratch", "imitation", "demo", "policy"]
INIT_LABEL = {
    "scratch": "from scratch (Experiment 3's loop)",
    "imitation": "imitation only, no REPS",
    "demo": "imitation + REPS, window: demonstrations",
    "policy": "imitation + REPS, window: fitted policy's episodes",
}
INIT_SHORT = {"scratch": "scratch", "imitation": "imitation", "demo": "+REPS (demo)",
              "policy": "+REPS (policy)"}
INIT_COLOUR = {
    "scratch": "0.55", "imitation": fs.PALETTE["black"], "demo": fs.PALETTE["blue"],
    "policy": fs.PALETTE["vermillion"],
}
COV_LABEL = {"query": "policy.cov = query (eq. 6.8 as printed)",
             "residual": "policy.cov = residual", "none": "linear-Gaussian covariance"}
RETURN = fs.label("return", "m")
CURVE_NEED = ("policy", "iteration", "episodes", "mean_return", "std_return", "repetitions")
FINAL_NEED = ("policy", "repetition", "episodes", "mean_return", "pocketed_target")
VERDICT_NEED = ("policy", "init", "cov", "mean_return", "q05_return", "q25_return",
                "median_return", "q75_return", "q95_return", "pocket_rate", "hit_rate")


def split_label(rows):
    """Rows whose policy column is a run label policy.init.cov, with the
    three parts as columns of their own."""
    for r in rows:
        r["policy"], r["init"], r["cov"] = r["policy"].split(".")
    return rows


def covs_of(rows):
    """The covariances of the tree policies and the baseline, in file order
    (the hand-crafted variant's "none" is drawn in every figure)."""
    return [c for c in dict.fromkeys(r["cov"] for r in rows) if c != "none"] or ["none"]


def variant_cov(policy, cov):
    return "none" if policy == "handcrafted" else cov


def load_curves(d):
    """{(policy, init, cov): (episodes, mean, mean - std, mean + std)} from
    exp4_curve.csv."""
    cur = defaultdict(list)
    for r in split_label(exp_data.read_csv(os.path.join(d, "exp4_curve.csv"), CURVE_NEED)):
        m, sd = float(r["mean_return"]), float(r["std_return"])
        cur[(r["policy"], r["init"], r["cov"])].append((int(r["episodes"]), m, m - sd, m + sd))
    return {k: tuple(np.array(c) for c in zip(*sorted(v))) for k, v in cur.items()}


def fig_curves(d, cur, cov, nreps, final):
    pols = [p for p in POLICIES if any(k[0] == p for k in cur)]
    ncol = 3
    nrow = (len(pols) + ncol - 1) // ncol
    fig, axes = fs.figure("full", 0.36 * nrow + 0.12, nrows=nrow, ncols=ncol, sharex=True,
                          sharey=True, squeeze=False)
    lows = [float(np.min(v[2])) for k, v in cur.items() if k[2] in (cov, "none")]
    bottom = max(min(lows), -4.0) - 0.05
    for ax, p in zip(axes.flat, pols):
        c = variant_cov(p, cov)
        for init in INITS:
            key = (p, init, c)
            if key not in cur:
                continue
            x, m, lo, hi = cur[key]
            if init == "scratch":
                ax.fill_between(x, lo, hi, facecolor="0.88", edgecolor="0.5", hatch="////",
                                lw=0.5, alpha=0.8)
                ax.plot(x, m, color="black", lw=1.1, ls="--")
            elif init == "imitation":
                ax.fill_between(x, lo, hi, color=INIT_COLOUR[init], alpha=0.12, lw=0)
                ax.plot(x, m, color=INIT_COLOUR[init], lw=1.0, ls=":")
            else:
                ax.fill_between(x, lo, hi, color=INIT_COLOUR[init], alpha=0.22, lw=0)
                ax.plot(x, m, color=INIT_COLOUR[init], lw=1.5)
        ax.axhline(0, color="black", lw=0.5)
        ax.set_ylim(bottom, 0.05)
        ax.set_title(POLICY_LABEL.get(p, p) + ("" if c == cov else " (no policy.cov)"),
                     fontsize=8.5)
    for ax in axes.flat[len(pols):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel(fs.label("episodes"))
    for ax in axes[:, 0]:
        ax.set_ylabel(fs.label("average return per iteration", "m"), fontsize=8)
    handles = [Patch(facecolor="0.88", edgecolor="0.5", hatch="////",
                     label=INIT_LABEL["scratch"] + ", dashed: mean"),
               Line2D([], [], color=INIT_COLOUR["imitation"], ls=":", lw=1.0,
                      label=INIT_LABEL["imitation"]),
               Line2D([], [], color=INIT_COLOUR["demo"], lw=1.5, label=INIT_LABEL["demo"]),
               Line2D([], [], color=INIT_COLOUR["policy"], lw=1.5, label=INIT_LABEL["policy"])]
    fs.legend_below(fig, handles, ncol=2, height=0.1)
    fig.suptitle(f"Experiment 4: average return per iteration, {COV_LABEL.get(cov, cov)}\n"
                 f"(mean of {nreps} repetitions ± one standard deviation; runs are scored on "
                 f"their last {final} episodes)")
    return fs.save(fig, d, f"exp4_curves_{cov}")


def variants(final, cov):
    """[(policy, init, cov)] of the figure for one covariance, in drawing order."""
    keys = {(r["policy"], r["init"], r["cov"]) for r in final}
    return [(p, i, variant_cov(p, cov)) for p in POLICIES for i in INITS
            if (p, i, variant_cov(p, cov)) in keys]


def group_positions(vs):
    """x position of each variant (groups of inits per policy) and the tick
    of each policy."""
    pos, ticks, x, last = {}, [], 0.0, None
    for v in vs:
        if last is not None and v[0] != last:
            x += 0.8
        pos[v] = x
        last = v[0]
        x += 1.0
    for p in dict.fromkeys(v[0] for v in vs):
        xs = [pos[v] for v in vs if v[0] == p]
        ticks.append(((min(xs) + max(xs)) / 2, POLICY_LABEL.get(p, p)))
    return pos, ticks


def fig_final(d, final, verdict, covs, last):
    fig, axes = fs.figure("full", 0.3 * len(covs) + 0.1, nrows=len(covs), ncols=1, sharey=True,
                          squeeze=False)
    lows = []
    for ax, cov in zip(axes[:, 0], covs):
        vs = variants(verdict, cov)
        pos, ticks = group_positions(vs)
        stats = []
        for v in vs:
            pooled = [r for r in verdict if (r["policy"], r["init"], r["cov"]) == v][0]
            stats.append({"med": float(pooled["median_return"]),
                          "q1": float(pooled["q25_return"]), "q3": float(pooled["q75_return"]),
                          "whislo": float(pooled["q05_return"]),
                          "whishi": float(pooled["q95_return"]),
                          "mean": float(pooled["mean_return"]), "fliers": []})
            lows.append(float(pooled["q05_return"]))
        bp = ax.bxp(stats, positions=[pos[v] for v in vs], widths=0.7, showmeans=True,
                    patch_artist=True, medianprops={"color": "black", "lw": 1},
                    meanprops={"marker": "D", "mfc": "white", "mec": "black", "ms": 3.2},
                    whiskerprops={"lw": 0.8}, capprops={"lw": 0.8})
        for box, v in zip(bp["boxes"], vs):
            box.set(facecolor=INIT_COLOUR[v[1]], alpha=0.55 if v[1] != "imitation" else 0.35,
                    lw=0.8)
            if v[1] == "scratch":
                box.set(hatch="////", edgecolor="0.35")
        for v in vs:
            runs = [float(r["mean_return"]) for r in final
                    if (r["policy"], r["init"], r["cov"]) == v and r["repetition"] != "-1"]
            ax.plot([pos[v] + 0.42] * len(runs), runs, "o", ms=2.4, mfc="white", mec="black",
                    mew=0.6)
        ax.set_xticks([t for t, _ in ticks], [lab for _, lab in ticks])
        ax.tick_params(axis="x", length=0)
        ax.grid(axis="x", visible=False)
        ax.axhline(0, color="black", lw=0.6)
        ax.set_ylabel(RETURN)
        ax.set_title(COV_LABEL.get(cov, cov), fontsize=8.5)
    axes[0, 0].set_ylim(min(lows) * 1.08 - 0.02, 0.06)
    handles = [Patch(facecolor=INIT_COLOUR[i], alpha=0.55, label=INIT_LABEL[i],
                     hatch="////" if i == "scratch" else None, edgecolor="0.35")
               for i in INITS] + [
        Line2D([], [], ls="", marker="D", mfc="white", mec="black", ms=3.2,
               label="mean of all runs' episodes"),
        Line2D([], [], ls="", marker="o", mfc="white", mec="black", ms=2.6,
               label="one run's mean")]
    fs.legend_below(fig, handles, ncol=3, height=0.12 / len(covs) + 0.06)
    fig.suptitle(f"Experiment 4: returns of the last {last} episodes of each run, all runs "
                 "pooled\n(boxes: quartiles, whiskers: 5th to 95th percentile; 0 m: pocketed "
                 "in a target)")
    return fs.save(fig, d, "exp4_final")


def fig_rates(d, final, verdict, covs, last):
    # a fixed layout: the constrained one comes out with positions that differ
    # in the last bits from run to run here, and so would the SVG's clip ids
    fig, axes = fs.figure("full", 0.3 * 2 * len(covs) + 0.1, nrows=2 * len(covs), ncols=1,
                          squeeze=False, layout=None)
    fig.subplots_adjust(left=0.08, right=0.99, top=1 - 0.85 / fig.get_figheight(),
                        bottom=0.95 / fig.get_figheight(), hspace=0.45)
    for j, cov in enumerate(covs):
        vs = variants(verdict, cov)
        pos, ticks = group_positions(vs)
        for k, (col, what) in enumerate((("pocket_rate", "pocketed in a target"),
                                         ("hit_rate", "cue ball hit the reward ball"))):
            ax = axes[2 * j + k, 0]
            top = 0.0
            for v in vs:
                pooled = [r for r in verdict if (r["policy"], r["init"], r["cov"]) == v][0]
                top = max(top, 100 * float(pooled[col]))
                ax.bar([pos[v]], [100 * float(pooled[col])], 0.8, color=INIT_COLOUR[v[1]],
                       alpha=0.7 if v[1] != "imitation" else 0.45,
                       hatch="////" if v[1] == "scratch" else None, edgecolor="0.3", lw=0.4)
                if k == 0:
                    runs = [100 * int(r["pocketed_target"]) / int(r["episodes"]) for r in final
                            if (r["policy"], r["init"], r["cov"]) == v and
                            r["repetition"] != "-1"]
                    top = max([top] + runs)
                    ax.plot([pos[v]] * len(runs), runs, "o", ms=2.2, mfc="white", mec="black",
                            mew=0.5)
            ax.set_xticks([t for t, _ in ticks], [lab for _, lab in ticks])
            ax.tick_params(axis="x", length=0)
            ax.grid(axis="x", visible=False)
            # pocket rates are small: their own scale
            ax.set_ylim(0, 105 if k else min(105.0, 1.15 * top + 2))
            ax.set_ylabel(fs.label(what.split()[0] if k == 0 else "hit", "%"), fontsize=8)
            ax.set_title(f"{what}, {COV_LABEL.get(cov, cov)}", fontsize=8.5)
    handles = [Patch(facecolor=INIT_COLOUR[i], alpha=0.7, label=INIT_LABEL[i],
                     hatch="////" if i == "scratch" else None, edgecolor="0.3") for i in INITS]
    handles.append(Line2D([], [], ls="", marker="o", mfc="white", mec="black", ms=2.4,
                          label="one run's pocket rate"))
    fig.legend(handles, [h.get_label() for h in handles], loc="lower center",
               bbox_to_anchor=(0.5, 0.005), ncol=3)
    fig.suptitle(f"Experiment 4: pocket and hit rates, last {last} episodes of each run\n"
                 "(bars: all runs pooled)")
    return fs.save(fig, d, "exp4_rates")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    d = ap.parse_args(argv).dir
    fs.setup()
    final = split_label(exp_data.read_csv(os.path.join(d, "exp4_final.csv"), FINAL_NEED))
    verdict = exp_data.read_csv(os.path.join(d, "exp4_verdict.csv"), VERDICT_NEED)
    if not final or not verdict:
        raise SystemExit(f"plot_exp4.py: {d}: exp4_final.csv or exp4_verdict.csv has no rows")
    cur = load_curves(d)
    cfg = exp_data.config(d)
    last = cfg.getint("exp3", "final_episodes", fallback=500)
    nreps = len({r["repetition"] for r in final if r["repetition"] != "-1"})
    covs = covs_of(verdict)
    written = []
    for cov in covs:
        written += fig_curves(d, cur, cov, nreps, last)
    written += (fig_final(d, final, verdict, covs, last) +
                fig_rates(d, final, verdict, covs, last))
    fs.finish(d, written, [f"exp4_curves_{c}" for c in ("query", "residual", "none")] +
              ["exp4_final", "exp4_rates"])


if __name__ == "__main__":
    main()
