#!/usr/bin/env python3
"""What one reproduction run measures on each of the thesis's claims
(chapter 7 discussions): a sample of a few repetitions, without verdicts.

Usage: claims.py OUT     (OUT holds exp1/, exp2/ and exp3/ as `make reproduce` writes them)

Prints a markdown table: section, the thesis's claim, what this run measured.
Every number comes from the run's CSVs (standard library only); intervals are
95 % Student-t intervals of a paired difference over the repetitions (forests
or runs), written [lo, hi] (scripts/figstats.py). A run that lacks the
settings or repetitions a measurement needs says so. The verdicts are judged
on the verdict study (and the repetitions it would need): scripts/verdicts.py,
docs/verdicts.md.
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import math
import os
import statistics

import exp3_table
import exp_data
from figstats import fmt_ci, mean_ci, paired

class Untested(Exception):
    """The run lacks what a rule needs; the message says what."""


def ci(values):
    """mean_ci, or Untested with fewer than two repetitions."""
    m, lo, hi = mean_ci(values)
    if lo is None:
        raise Untested("needs at least two repetitions")
    return m, lo, hi


def have(d, *names):
    """Untested unless the run folder d holds every CSV in names."""
    for n in names:
        if not os.path.isfile(os.path.join(d, n)):
            raise Untested(f"the run has no {os.path.join(os.path.basename(d), n)}")


def need(mapping, key, what):
    if key not in mapping:
        raise Untested(f"the run has no {what}")
    return mapping[key]


# ---- Experiment 1 (thesis 7.3.2) ----

def exp1_sweep(d, sweep):
    have(d, "exp1_mse.csv")
    by_sweep, _ = exp_data.exp1_mse(d)
    values = by_sweep.get(sweep)
    if not values:
        raise Untested(f"the run has no {sweep} sweep")
    return values


def claim_cuts(d):
    v = exp1_sweep(d, "cuts")
    kd = exp_data.exp1_default(exp_data.config(d))[2]
    ref = need(v, kd, f"K = {kd}")
    lo_k, hi_k = min(v), max(v)
    if lo_k >= kd or hi_k <= kd:
        raise Untested(f"the K sweep must hold values below and above {kd}")
    more = paired(v[hi_k], ref)
    one = paired(v[lo_k], ref)
    worse_all = sum(x > 0 for x in one)
    here = (f"K {kd}: MSE {statistics.fmean(ref.values()):.4f} m²; K {hi_k} − K {kd}: "
            f"{fmt_ci(more, 4)}; K {lo_k} − K {kd}: {fmt_ci(one, 4)}, worse in {worse_all} of "
            f"{len(one)} forests")
    return here


def claim_trees(d):
    v = exp1_sweep(d, "trees")
    mx = max(v)
    one, ten = need(v, 1, "M = 1"), need(v, 10, "M = 10")
    if mx <= 10:
        raise Untested("the M sweep must go beyond 10")
    d1 = paired(one, v[mx])
    d10 = paired(ten, v[mx])
    over = [paired(v[m], ten) for m in v if m > 10]
    here = (f"M 1 − M {mx}: {fmt_ci(d1, 4)} m²; M 10 − M {mx}: {fmt_ci(d10, 4)} m²; "
            f"{sum(ci(x)[1] > 0 for x in over)} of {len(over)} settings with M > 10 significantly "
            "worse than M 10")
    return here


def claim_nmin(d):
    v = exp1_sweep(d, "n_min")
    xs = sorted(v)
    if len(xs) < 3:
        raise Untested("the n_min sweep needs three values")
    mean = {x: statistics.fmean(v[x].values()) for x in xs}
    best = min(xs, key=mean.get)
    worst = max(xs, key=mean.get)
    span = paired(v[xs[-1]], v[xs[0]])
    here = (f"lowest mean MSE at n_min {best} ({mean[best]:.4f} m²), highest at {worst} "
            f"({mean[worst]:.4f}); n_min {xs[-1]} − n_min {xs[0]}: {fmt_ci(span, 4)} m²")
    return here


def claim_map(d):
    have(d, "exp1_map.csv")
    rows = exp_data.exp1_map(d)
    if not rows:
        raise Untested("the run has no reward map")
    pred = {}
    reward = {}
    for r in rows:
        key = (r["x1"], r["y1"])
        pred.setdefault(key, []).append(float(r["pred"]))
        reward[key] = float(r["reward"])
    mean = {k: statistics.fmean(p) for k, p in pred.items()}
    pocketed = [k for k in mean if reward[k] == 0]
    rest = [k for k in mean if reward[k] != 0]
    if not pocketed or not rest:
        raise Untested("the map has no pocketed (or no other) positions")
    under = statistics.fmean(mean[k] for k in pocketed)
    rms = math.sqrt(statistics.fmean((mean[k] - reward[k]) ** 2 for k in rest))
    n = len({r["repetition"] for r in rows})
    here = (f"{len(pocketed)} of {len(mean)} grid positions pocket the ball (return 0); there "
            f"the mean of {n} forests predicts {under:.2f} m; RMS error elsewhere {rms:.3f} m")
    return here


# ---- Experiment 2 (thesis 7.4.2) ----

def exp2_at_largest(d):
    have(d, "exp2_returns.csv")
    ret = exp_data.exp2_returns(d)
    sizes = sorted({s for s, p, _ in ret if p != "expert"})
    if not sizes:
        raise Untested("the run has no learned policies")
    return ret, sizes[-1]


def series(ret, size, policy, mode, k=0):
    """{repetition: value} of (size, policy, mode); k 0 = return, 1 = pocketed share."""
    s = need(ret, (size, policy, mode), f"{policy} ({mode}) at size {size}")
    return {r: v[k] for r, v in s.items()}


def claim_short_of_expert(d):
    ret, n = exp2_at_largest(d)
    expert = series(ret, 0, "expert", "mean")
    diffs = {p: paired(series(ret, n, p, "mean"), expert) for p in ("single", "s_a", "s_rs")}
    best = max(diffs, key=lambda p: statistics.fmean(diffs[p]))
    pk = statistics.fmean(series(ret, n, best, "mean", 1).values())
    here = (f"expert {statistics.fmean(expert.values()):.3f} m "
            f"({100 * statistics.fmean(series(ret, 0, 'expert', 'mean', 1).values()):.0f} % "
            f"pocketed); best learned ({best}, n = {n}) {fmt_ci(diffs[best])} m below it "
            f"({100 * pk:.0f} % pocketed)")
    return here


def claim_single_worst(d):
    ret, n = exp2_at_largest(d)
    bits = []
    for mode in ("mean", "sample"):
        single = series(ret, n, "single", mode)
        da = paired(single, series(ret, n, "s_a", mode))
        drs = paired(single, series(ret, n, "s_rs", mode))
        bits.append(f"{mode} actions: single {statistics.fmean(single.values()):.3f} m, − s→a "
                    f"{fmt_ci(da)}, − s→rs {fmt_ci(drs)}")
    return "; ".join(bits)


def claim_rs_beats_a(d):
    ret, n = exp2_at_largest(d)
    dm = paired(series(ret, n, "s_rs", "mean"), series(ret, n, "s_a", "mean"))
    dp = paired(series(ret, n, "s_rs", "mean", 1), series(ret, n, "s_a", "mean", 1))
    ds = paired(series(ret, n, "s_rs", "sample"), series(ret, n, "s_a", "sample"))
    here = (f"s→rs − s→a at n = {n}: mean actions {fmt_ci(dm)} m; pocketed share "
            f"{fmt_ci([100 * x for x in dp], 1)} points; sampled actions {fmt_ci(ds)} m")
    return here


# ---- Experiment 3 (thesis 7.5.2) ----

def exp3_stats(d):
    have(d, "exp3_episodes.csv", "exp3_curve.csv")
    runs, last = exp3_table.load(d)
    st = exp3_table.summary(runs)
    for p in exp3_table.TREE_VARIANTS + ("baseline",):
        need(st, p, f"{p} policy")
    return st, last


def claim_none_better(d):
    st, last = exp3_stats(d)
    tree = exp3_table.TREE_VARIANTS
    best = max(tree, key=lambda p: statistics.fmean(st[p]["paired"]))
    n_sig = sum(ci(st[p]["paired"])[1] > 0 for p in tree)
    here = (f"best tree variant {best}: {fmt_ci(st[best]['paired'])} m over the baseline "
            f"(paired, {len(st[best]['paired'])} runs); {n_sig} of 4 significantly better")
    return here


def claim_best_nrvr_rs(d):
    st, _ = exp3_stats(d)
    tree = exp3_table.TREE_VARIANTS
    best = max(tree, key=lambda p: st[p]["mean"])
    m = statistics.fmean(st["nrvr_rs"]["paired"])
    here = (f"highest mean return: {best} ({st[best]['mean']:.3f} m); nrvr_rs − baseline "
            f"{fmt_ci(st['nrvr_rs']['paired'])} m")
    return here


def claim_worst_rvr_a(d):
    st, _ = exp3_stats(d)
    tree = exp3_table.TREE_VARIANTS
    worst = min(tree, key=lambda p: st[p]["mean"])
    widest = max(tree + ("baseline",), key=lambda p: st[p]["std_runs"])
    fastest = max(tree, key=lambda p: st[p]["median_speed"])
    r, b = st["rvr_a"], st["baseline"]
    here = (f"lowest mean: {worst}; widest spread of run means: {widest} (rvr_a "
            f"{r['std_runs']:.3f}, baseline {b['std_runs']:.3f} m); target pocketed rvr_a "
            f"{r['target']} vs baseline {b['target']}; fastest median shot: {fastest} "
            f"({st[fastest]['median_speed']:.2f} m/s; rvr_a {r['median_speed']:.2f})")
    return here


def claim_even_split(d):
    st, _ = exp3_stats(d)
    pk = st["nrvr_rs"]["pockets"]
    a, b = pk.get("2", 0), pk.get("5", 0)
    if a + b < 10:
        raise Untested("fewer than 10 balls in the target pockets")
    share = min(a, b) / (a + b)
    here = f"pocket 2 / pocket 5: {a} / {b} (smaller share {100 * share:.0f} %)"
    return here


def claim_baseline_fewest(d):
    st, _ = exp3_stats(d)
    tree = exp3_table.TREE_VARIANTS
    counts = ", ".join(f"{p} {st[p]['target']}" for p in tree)
    here = f"balls in the target pockets: baseline {st['baseline']['target']}; {counts}"
    return here


def settle_episode(curve, level, tol=0.1, window=5):
    """First episode count from which the moving average (window
    iterations) of the curve stays within tol of level; None when it never
    does (the last point alone is no settling)."""
    eps = [e for e, _ in curve]
    ys = [y for _, y in curve]
    avg = [statistics.fmean(ys[max(0, i - window + 1):i + 1]) for i in range(len(ys))]
    for i in range(len(avg)):
        if i < len(avg) - 1 and all(abs(a - level) <= tol for a in avg[i:]):
            return eps[i]
    return None


def claim_converge(d):
    st, last = exp3_stats(d)
    rows = exp_data.read_csv(os.path.join(d, "exp3_curve.csv"),
                             ("policy", "episodes", "mean_return"))
    settle, pocketed = {}, {}
    for p in exp3_table.TREE_VARIANTS:
        curve = sorted((int(r["episodes"]), float(r["mean_return"])) for r in rows
                       if r["policy"] == p)
        if len(curve) < 10:
            raise Untested("needs at least 10 iterations")
        settle[p] = settle_episode(curve, st[p]["mean"])
        pocketed[p] = st[p]["target"] / st[p]["episodes"]
    here = ("settled (5-iteration average within 0.1 m of the final level) after "
            + ", ".join(f"{p} {'never' if e is None else e}" for p, e in settle.items())
            + f" episodes; in the last episodes at most {100 * max(pocketed.values()):.1f} % "
            "pocketed in a target")
    return here


# (thesis section, result folder, the claim in short, the function that measures it)
CLAIMS = [
    ("7.3.2", "exp1", "best with K = 10; slightly worse with more cuts (not significant); "
     "worse as K → 1", claim_cuts),
    ("7.3.2", "exp1", "one tree is poor; 10 trees almost as good as 50; no overfitting with "
     "more trees", claim_trees),
    ("7.3.2", "exp1", "smaller n_min is best, no overfitting; worst at n_min 200 (no structure)",
     claim_nmin),
    ("7.3.2", "exp1", "forests do not represent the discontinuities; pocketed regions "
     "underestimated", claim_map),
    ("7.4.2", "exp2", "all three policies fall well short of the optimal training data",
     claim_short_of_expert),
    ("7.4.2", "exp2", "the single-node policy drops most (it averages the two solutions)",
     claim_single_worst),
    ("7.4.2", "exp2", "states → reward states beats states → actions", claim_rs_beats_a),
    ("7.5.2", "exp3", "no tree policy considerably better than the baseline", claim_none_better),
    ("7.5.2", "exp3", "best is nrvr with s→rs, ≈ 0.1 above the baseline", claim_best_nrvr_rs),
    ("7.5.2", "exp3", "worst is rvr with s→a: high variance, more balls pocketed than the "
     "baseline, excessive velocities", claim_worst_rvr_a),
    ("7.5.2", "exp3", "nrvr with s→rs splits its pocketed balls evenly between the two pockets",
     claim_even_split),
    ("7.5.2", "exp3", "the baseline pockets the fewest balls", claim_baseline_fewest),
    ("7.5.2", "exp3", "all converge after ≈ 1400 episodes, many to poor local optima",
     claim_converge),
]


def evaluate(out):
    """[{section, claim, here}] for the run in folder out."""
    rows = []
    for section, sub, claim, fn in CLAIMS:
        try:
            here = fn(os.path.join(out, sub))
        except Untested as e:
            here = f"not measured: {e}"
        rows.append({"section": section, "claim": claim, "here": here})
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", help="folder with exp1/, exp2/, exp3/")
    rows = evaluate(ap.parse_args().out)
    print("| thesis | claim | this run |")
    print("|---|---|---|")
    for r in rows:
        print(f"| {r['section']} | {r['claim']} | {r['here']} |")


if __name__ == "__main__":
    main()
