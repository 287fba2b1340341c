#!/usr/bin/env python3
"""Experiment 4's controls study (docs/exp4.md, "Controls"): compact CSVs,
paired verdicts with 95 % intervals and Holm-adjusted p-values, the tables of
docs/exp4.md and README.md, and the figure exp4_controls.

    exp4_study.py collect OUT --arms "main eps0.1 ..." --out DIR
        per run (arm, repetition, variant): mean return of its last
        exp3.final_episodes episodes, target-pocket rate, the mean-action
        return (exp4_mean.csv), floored iterations (exp4_reps.csv), forest
        n_min and leaves -> DIR/runs.csv; the main arm's learning curves ->
        DIR/curves.csv; OUT/timing.csv -> DIR/timing.csv; the verdicts ->
        DIR/verdicts.csv
    exp4_study.py plot DIR --out FIGDIR      FIGDIR/exp4_controls.{png,svg}
    exp4_study.py docs DIR --doc exp4.md [--readme README.md] [--check]
        rewrite the text between <!-- exp4-study:NAME --> and
        <!-- /exp4-study:NAME --> from DIR's CSVs; --check only compares and
        exits 1 naming the first block that differs

Comparisons are paired over the repetitions (common random numbers: the
same start states, demonstrations and pi_0 in every arm and variant of a
repetition): the mean difference, its 95 % t interval, the two-sided paired
t-test's p-value and the Holm-adjusted p-value over the whole family of one
measure (sampled return, mean-action return). Verdict words: "degrades" or
"improves" when the Holm-adjusted p < 0.05, "no sig. change" otherwise.
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import csv
import math
import os
import re
import sys

import numpy as np
from scipy import stats

import exp_data
import verdict_stats as vs

PROG = "exp4_study"
POLICIES = ["nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a", "baseline", "handcrafted"]
TREES = POLICIES[:4]
FLOOR_ARMS = [("floor0", "1e-6 mm/s (off)"), ("main", "1 mm/s"), ("floor3", "3 mm/s"),
              ("floor10", "10 mm/s")]
ALPHA = 0.05
FLOOR_BIT = 16  # PR_POLICY_FLOOR
# the margin of every Experiment 3 verdict: the smallest return difference
# counted as real (data/study/rules.ini, [margins] material)
RULES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "study",
                     "rules.ini")


def die(msg):
    sys.exit(f"{PROG}: {msg}")


def split(label):
    p, i, c = label.split(".")
    return p, i, c


# ---- collect ----

def arm_runs(arm, d):
    """Per run of arm folder d: the row of runs.csv (without the arm)."""
    fin = exp_data.read_csv(os.path.join(d, "exp4_final.csv"),
                            ("policy", "repetition", "episodes", "mean_return", "pocketed_target"))
    mean = exp_data.read_csv(os.path.join(d, "exp4_mean.csv"),
                             ("repetition", "policy", "mean_return", "pocket_rate", "n_min",
                              "leaves"))
    reps = exp_data.read_csv(os.path.join(d, "exp4_reps.csv"),
                             ("repetition", "policy", "policy_flags", "status"))
    floors, iters, failed = {}, {}, {}
    for r in reps:
        k = (int(r["repetition"]), r["policy"])
        floors[k] = floors.get(k, 0) + (int(r["policy_flags"]) & FLOOR_BIT > 0)
        iters[k] = iters.get(k, 0) + 1
        failed[k] = failed.get(k, 0) + (r["status"] == "failed")
    by = {(int(r["repetition"]), r["policy"]): r for r in mean}
    out = []
    for r in fin:
        k = (int(r["repetition"]), r["policy"])
        if k[0] < 0:
            continue
        if k not in by:
            die(f"{d}/exp4_mean.csv: no row for repetition {k[0]}, {k[1]}")
        m = by[k]
        p, i, c = split(k[1])
        out.append({"arm": arm, "repetition": k[0], "variant": k[1], "policy": p, "init": i,
                    "cov": c, "final_return": float(r["mean_return"]),
                    "final_pocket_rate": int(r["pocketed_target"]) / int(r["episodes"]),
                    "mean_action_return": float(m["mean_return"]),
                    "mean_action_pocket_rate": float(m["pocket_rate"]),
                    "floor_iterations": floors.get(k, 0), "iterations": iters.get(k, 0),
                    "failed_solves": failed.get(k, 0),
                    "n_min": int(m["n_min"]),
                    "leaves": int(m["leaves"])})
    return out


RUN_COLS = ["arm", "repetition", "variant", "policy", "init", "cov", "final_return",
            "final_pocket_rate", "mean_action_return", "mean_action_pocket_rate",
            "floor_iterations", "iterations", "failed_solves", "n_min", "leaves"]


def fmt(x):
    """Nine significant digits: the tables print three decimals."""
    return f"{x:.9g}" if isinstance(x, float) else str(x)


def write_csv(path, cols, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(cols)
        for r in rows:
            w.writerow([fmt(r[c]) for c in cols])


def collect(a):
    os.makedirs(a.out, exist_ok=True)
    runs = []
    for arm in a.arms.split():
        runs += arm_runs(arm, os.path.join(a.dir, arm))
    write_csv(os.path.join(a.out, "runs.csv"), RUN_COLS, runs)
    cur = exp_data.read_csv(os.path.join(a.dir, "main", "exp4_curve.csv"),
                            ("policy", "iteration", "mean_return", "std_return", "repetitions"))
    write_csv(os.path.join(a.out, "curves.csv"),
              ["variant", "iteration", "mean_return", "sd_return", "repetitions"],
              [{"variant": r["policy"], "iteration": int(r["iteration"]),
                "mean_return": float(r["mean_return"]), "sd_return": float(r["std_return"]),
                "repetitions": int(r["repetitions"])} for r in cur])
    tim = os.path.join(a.dir, "timing.csv")
    if os.path.exists(tim):
        with open(tim) as f, open(os.path.join(a.out, "timing.csv"), "w") as g:
            g.write(f.read())
    # from runs.csv as written (nine digits), as read_dir recomputes them
    write_verdicts(a.out, exp_data.read_csv(os.path.join(a.out, "runs.csv"), RUN_COLS))


# ---- statistics ----

def holm(p):
    """Holm step-down adjusted p-values (monotone, capped at 1)."""
    p = np.asarray(p, float)
    order = np.argsort(p, kind="stable")
    adj = np.empty_like(p)
    run = 0.0
    for rank, i in enumerate(order):
        run = max(run, min(1.0, (len(p) - rank) * p[i]))
        adj[i] = run
    return adj


def paired(x, y):
    """Mean of x - y, its 95 % t interval, the paired t-test's p (n >= 2)."""
    d = np.asarray(x, float) - np.asarray(y, float)
    n = len(d)
    m = float(d.mean())
    if n < 2:
        die(f"a paired comparison needs >= 2 repetitions (got {n})")
    se = float(d.std(ddof=1) / math.sqrt(n))
    if se == 0.0:
        # identical differences: the interval is the point, p 0 unless it is 0
        return m, m, m, 0.0 if m != 0.0 else 1.0, n
    h = float(stats.t.ppf(0.975, n - 1)) * se
    p = float(2 * stats.t.sf(abs(m) / se, n - 1))
    return m, m - h, m + h, p, n


def comparisons(runs):
    """(family measure, arm_a, variant_a, arm_b, variant_b, name) of the study.
    Every REPS run against imitation, and split at its refit-only control of
    the same resolution (refit at policy.n_min, refit_matched at pi_0's):
    A - imitation = (A - control) + (control - imitation), the reweighting
    and the refitting. The eps arms run no control of their own: a refit runs
    no REPS, so the main arm's is theirs."""
    have = {(r["arm"], r["variant"]) for r in runs}
    out = []
    for p in POLICIES:
        for c in (["none"] if p == "handcrafted" else ["query", "residual"]):
            cand = [("main", "policy", "main", "imitation", "REPS (eps 0.5) vs imitation"),
                    ("main", "refit", "main", "imitation", "refit-only vs imitation"),
                    ("main", "policy", "main", "refit", "REPS vs refit-only"),
                    ("main", "matched", "main", "imitation", "matched REPS (eps 0.5) vs imitation"),
                    ("main", "matched", "main", "policy", "matched REPS vs REPS"),
                    ("main", "refit_matched", "main", "imitation", "refit_matched vs imitation"),
                    ("main", "matched", "main", "refit_matched", "matched REPS vs refit_matched")]
            for eps in ("0.25", "0.1"):
                cand += [(f"eps{eps}", "policy", "main", "imitation",
                          f"REPS (eps {eps}) vs imitation"),
                         (f"eps{eps}", "matched", "main", "imitation",
                          f"matched REPS (eps {eps}) vs imitation"),
                         (f"eps{eps}", "policy", "main", "refit",
                          f"REPS (eps {eps}) vs refit-only"),
                         (f"eps{eps}", "matched", "main", "refit_matched",
                          f"matched REPS (eps {eps}) vs refit_matched")]
            for arm, _ in FLOOR_ARMS:
                if arm != "main":
                    cand += [(arm, "policy", arm, "imitation", f"REPS vs imitation, {arm}"),
                             (arm, "matched", arm, "imitation",
                              f"matched REPS vs imitation, {arm}"),
                             (arm, "refit", arm, "imitation", f"refit-only vs imitation, {arm}"),
                             (arm, "policy", arm, "refit", f"REPS vs refit-only, {arm}"),
                             (arm, "refit_matched", arm, "imitation",
                              f"refit_matched vs imitation, {arm}"),
                             (arm, "matched", arm, "refit_matched",
                              f"matched REPS vs refit_matched, {arm}")]
            for aa, ia, ab, ib, name in cand:
                va, vb = f"{p}.{ia}.{c}", f"{p}.{ib}.{c}"
                if (aa, va) in have and (ab, vb) in have:
                    out.append((aa, va, ab, vb, name, p, c))
    return out


def margin():
    """The material margin [m] of data/study/rules.ini."""
    import configparser
    cfg = configparser.ConfigParser(interpolation=None)
    if not cfg.read(RULES) or not cfg.has_option("margins", "material"):
        die(f"{RULES}: no [margins] material")
    return float(cfg.get("margins", "material"))


def margin_verdicts(fam, m):
    """Each comparison against the margin m, three tests of its paired
    differences: worse by more than m (H1: d < -m), better by more than m
    (H1: d > m), within it (TOST, H1: -m < d < m); Holm over all three tests
    of every comparison in the family. 'degrades' / 'improves' / 'within'
    when that test holds at Holm's 0.05, else 'undecided'."""
    ps = []
    for r in fam:
        e = vs.paired(r["x"], r["y"])
        ps.append([vs.p_less(e, -m), vs.p_greater(e, m), vs.p_tost(e, -m, m)])
    adj = vs.holm([p for t in ps for p in t]) if ps else []
    for i, r in enumerate(fam):
        below, above, within = adj[3 * i: 3 * i + 3]
        r["p_below_holm"], r["p_above_holm"], r["p_within_holm"] = below, above, within
        r["margin_verdict"] = ("degrades" if below < ALPHA else "improves" if above < ALPHA
                               else "within" if within < ALPHA else "undecided")


VERDICT_COLS = ["measure", "comparison", "policy", "cov", "arm_a", "variant_a", "arm_b",
                "variant_b", "n", "mean_a", "mean_b", "diff", "ci_lo", "ci_hi", "p", "p_holm",
                "verdict", "p_below_holm", "p_above_holm", "p_within_holm", "margin_verdict"]


def verdict_rows(runs):
    """The rows of verdicts.csv that runs gives."""
    idx = {(r["arm"], r["variant"], int(r["repetition"])): r for r in runs}
    rows, band = [], margin()
    for measure, col in (("sampled", "final_return"), ("mean_action", "mean_action_return")):
        fam = []
        for aa, va, ab, vb, name, p, c in comparisons(runs):
            ks = sorted(k for (a, v, k) in idx if (a, v) == (aa, va) and (ab, vb, k) in idx)
            x = [float(idx[(aa, va, k)][col]) for k in ks]
            y = [float(idx[(ab, vb, k)][col]) for k in ks]
            m, lo, hi, pv, n = paired(x, y)
            fam.append({"measure": measure, "comparison": name, "policy": p, "cov": c,
                        "arm_a": aa, "variant_a": va, "arm_b": ab, "variant_b": vb, "n": n,
                        "mean_a": float(np.mean(x)), "mean_b": float(np.mean(y)), "diff": m,
                        "ci_lo": lo, "ci_hi": hi, "p": pv, "x": x, "y": y})
        for r, ph in zip(fam, holm([r["p"] for r in fam])):
            r["p_holm"] = float(ph)
            r["verdict"] = ("no sig. change" if ph >= ALPHA else
                            "improves" if r["diff"] > 0 else "degrades")
        margin_verdicts(fam, band)
        rows += fam
    return rows


def write_verdicts(out, runs):
    write_csv(os.path.join(out, "verdicts.csv"), VERDICT_COLS, verdict_rows(runs))


def same_field(want, have):
    """A recomputed field against its CSV text: numbers to the CSV's nine
    significant digits (runs.csv is rounded too), words exactly."""
    if isinstance(want, float):
        h = float(have)
        return math.isclose(want, h, rel_tol=1e-6, abs_tol=1e-12)
    return str(want) == have


# ---- tables ----

def read_dir(d):
    runs = exp_data.read_csv(os.path.join(d, "runs.csv"), RUN_COLS)
    path = os.path.join(d, "verdicts.csv")
    ver = exp_data.read_csv(path, VERDICT_COLS)
    want = verdict_rows(runs)
    if len(want) != len(ver):
        die(f"{path}: {len(ver)} rows, runs.csv gives {len(want)}; run exp4_study.py collect")
    for line, (w, h) in enumerate(zip(want, ver), start=2):
        for c in VERDICT_COLS:
            if not same_field(w[c], h[c]):
                die(f"{path}:{line}: {c} is {h[c]}, runs.csv gives {fmt(w[c])}; "
                    "run exp4_study.py collect")
    return runs, ver


def label_pc(p, c):
    return p if c == "none" else f"{p}, {c}"


def pcs():
    return [(p, c) for p in POLICIES for c in (["none"] if p == "handcrafted"
                                                else ["query", "residual"])]


def pick(ver, measure, names):
    """The tree policies' rows of verdicts.csv of one measure whose
    comparison is in names."""
    return [r for r in ver if r["measure"] == measure and r["comparison"] in names and
            r["policy"] in TREES]


def say(rows):
    """Margin verdicts of rows: worse, better, within, undecided of n, and the
    range of the differences."""
    n, d = len(rows), [float(r["diff"]) for r in rows]
    k = [(sum(r["margin_verdict"] == w for r in rows), name) for w, name in
         (("degrades", "worse"), ("improves", "better"), ("within", "within"),
          ("undecided", "undecided"))]
    return (", ".join(f"{c} {name}" for c, name in k if c) +
            f" of {n} ({min(d):+.3f} to {max(d):+.3f} m)")


def split_effect(ver, total, control, reweight):
    """One headline effect and its split, sampled [mean actions]: the total
    (A vs imitation), the refitting (the control vs imitation) and the
    reweighting (A vs the control)."""
    out = []
    for what, names in (("total", total), ("refitting", control), ("reweighting", reweight)):
        if names:
            out.append(f"{what} {say(pick(ver, 'sampled', names))} "
                       f"[{say(pick(ver, 'mean_action', names))}]")
    return "; ".join(out)


def cell_pairs(runs, names, col):
    """(x, y) over the repetitions of each tree policy x covariance cell of
    the comparisons in names."""
    idx = {(r["arm"], r["variant"], int(r["repetition"])): float(r[col]) for r in runs}
    reps = sorted({k for (_, _, k) in idx})
    return [([idx[(aa, va, k)] for k in reps], [idx[(ab, vb, k)] for k in reps])
            for aa, va, ab, vb, name, p, _ in comparisons(runs) if name in names and p in TREES]


def mean_diff_ci(runs, names, col="final_return"):
    """The mean over the cells of the comparisons in names, with its 95 % t
    interval over the repetitions: per repetition the cells' differences are
    averaged, so the interval keeps their pairing."""
    d = [np.subtract(x, y) for x, y in cell_pairs(runs, names, col)]
    return vs.t_interval([np.mean([c[k] for c in d]) for k in range(len(d[0]))])


def own_family(runs, names, col, m):
    """(degrades, improves) of the comparisons in names over the tree cells,
    their margin tests Holm-adjusted among themselves alone."""
    fam = [{"x": x, "y": y} for x, y in cell_pairs(runs, names, col)]
    margin_verdicts(fam, m)
    return tuple(sum(r["margin_verdict"] == w for r in fam) for w in ("degrades", "improves"))


def fmt_ci(m, lo, hi):
    return f"{m:+.3f} m [{lo:+.3f}, {hi:+.3f}]"


MATCHED = (["matched REPS (eps 0.5) vs imitation"], ["refit_matched vs imitation"],
           ["matched REPS vs refit_matched"])


def closing(ver, runs, m):
    """The bold headline, and the answer: it and the split of every effect."""
    nrep = len({r["repetition"] for r in runs})
    tot = pick(ver, "sampled", MATCHED[0])
    tot_m = pick(ver, "mean_action", MATCHED[0])
    cnt = lambda rows, w: sum(r["margin_verdict"] == w for r in rows)  # noqa: E731
    parts = [fmt_ci(*mean_diff_ci(runs, names)) for names in MATCHED]
    parts_m = [fmt_ci(*mean_diff_ci(runs, names, "mean_action_return")) for names in MATCHED]
    own = [own_family(runs, MATCHED[0], c, m) for c in ("final_return", "mean_action_return")]
    ntest = 3 * sum(r["measure"] == "sampled" for r in ver)
    fl = ["floor3", "floor10"]
    eps = ["0.25", "0.1"]
    off = (["matched REPS vs imitation, floor0"], ["refit_matched vs imitation, floor0"],
           ["matched REPS vs refit_matched, floor0"])
    nmin = (["REPS (eps 0.5) vs imitation"], ["refit-only vs imitation"], ["REPS vs refit-only"])
    small = ([f"matched REPS (eps {e}) vs imitation" for e in eps], [],
             [f"matched REPS (eps {e}) vs refit_matched" for e in eps])
    high = ([f"REPS vs imitation, {a}" for a in fl], [f"refit-only vs imitation, {a}" for a in fl],
            [f"REPS vs refit-only, {a}" for a in fl])
    head = (
        f"**Against Experiment 3's {m:g} m margin, REPS at π₀'s resolution (ε 0.5, 1 mm/s "
        f"floor) degrades {cnt(tot, 'degrades')} and improves {cnt(tot, 'improves')} of the "
        f"{len(tot)} imitated tree policy × covariance cells ({cnt(tot_m, 'degrades')} and "
        f"{cnt(tot_m, 'improves')} by their mean actions; {own[0][0]} and {own[0][1]} "
        f"[{own[1][0]} and {own[1][1]}] Holm over these {len(tot)} cells alone); "
        f"of its mean change, {parts[0]}, refitting at π₀'s resolution without REPS accounts "
        f"for {parts[1]} and REPS's reweighting for {parts[2]}, along the refit-only path**")
    return head, [
        head + f" ({nrep} paired repetitions; mean changes over the {len(tot)} cells, 95 % t "
        f"intervals; each difference tested for < −{m:g} m, > +{m:g} m "
        f"and within ±{m:g} m, Holm over the {ntest} tests of its measure (3 × {ntest // 3} "
        f"comparisons); "
        f"counts for the sampled actions, [mean actions]). By mean actions the change is "
        f"{parts_m[0]}: refitting {parts_m[1]}, reweighting {parts_m[2]}. "
        f"At π₀'s resolution: {split_effect(ver, *MATCHED)}. "
        f"With the floor practically off: {split_effect(ver, *off)}. "
        f"At `policy.n_min` (REPS as first run): {split_effect(ver, *nmin)}. "
        f"Smaller steps at π₀'s resolution (ε 0.25, 0.1): {split_effect(ver, *small)}. "
        f"A 3 or 10 mm/s floor, at `policy.n_min`: {split_effect(ver, *high)}."]


def table_split(ver):
    """The headline effect per tree policy: total, refitting, reweighting,
    difference [m] and margin verdict, sampled and mean actions."""
    by = {(r["measure"], r["comparison"], r["policy"], r["cov"]): r for r in ver}
    lines = ["| policy, covariance | total | refitting | reweighting | total, mean actions "
             "| refitting, mean actions | reweighting, mean actions |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for p, c in pcs():
        if p not in TREES:
            continue
        cells = [by[(meas, names[0], p, c)] for meas in ("sampled", "mean_action")
                 for names in MATCHED]
        lines.append(f"| {label_pc(p, c)} | " + " | ".join(
            f"{float(r['diff']):+.3f} {r['margin_verdict']}" for r in cells) + " |")
    return lines


def blocks(d):
    runs, ver = read_dir(d)
    m = margin()
    nrep = len({r["repetition"] for r in runs})
    t = exp_data.read_csv(os.path.join(d, "timing.csv")) if os.path.exists(
        os.path.join(d, "timing.csv")) else []
    cpu = sum(float(r["cpu_seconds"]) for r in t)
    wall = sum(float(r["wall_seconds"]) for r in t)
    nruns = len(runs)
    nfail = sum(int(r["failed_solves"]) for r in runs)
    nfrun = sum(int(r["failed_solves"]) > 0 for r in runs)
    b = {
        "setup": [f"{nrep} paired repetitions, {nruns} runs in six arms; the runs and their "
                  f"merges took {cpu:.0f} s of CPU ({wall:.0f} s wall on "
                  f"{t[0]['cores'] if t else '?'} cores, load "
                  f"{t[0]['load_before'] if t else '?'} at the start; "
                  f"`{os.path.basename(os.path.normpath(d))}/timing.csv`). "
                  f"{nfail} REPS solves in {nfrun} runs could not be certified and were "
                  f"recorded (`reps.allow_failed`)."],
        "split": table_split(ver),
    }
    head, b["closing"] = closing(ver, runs, m)
    b["readme"] = [head + f" ({nrep} paired repetitions; per policy, both evaluations and the "
                   "split of every other effect: [docs/exp4.md](docs/exp4.md#answer))."]
    return b


MARK = re.compile(r"(<!-- exp4-study:(\w+) -->\n)(.*?)(<!-- /exp4-study:\2 -->)", re.S)


def rewrite(path, b, check):
    text = open(path).read()
    seen = []

    def repl(m):
        name = m.group(2)
        if name not in b:
            die(f"{path}: unknown block {name!r}")
        seen.append(name)
        return m.group(1) + "\n".join(b[name]) + "\n" + m.group(4)
    new = MARK.sub(repl, text)
    if not seen:
        die(f"{path}: no <!-- exp4-study:NAME --> block")
    if check:
        if new != text:
            for m in MARK.finditer(text):
                if m.group(3) != "\n".join(b[m.group(2)]) + "\n":
                    print(f"{PROG}: {path}: block {m.group(2)} differs from the CSVs; run "
                          f"scripts/exp4_study.py docs", file=sys.stderr)
                    sys.exit(1)
        return
    if new != text:
        with open(path, "w") as f:
            f.write(new)


def docs(a):
    b = blocks(a.dir)
    rewrite(a.doc, b, a.check)
    if a.readme:
        rewrite(a.readme, b, a.check)


# ---- figure ----

def plot(a):
    import figstyle
    plt = figstyle.setup()
    rows = exp_data.read_csv(os.path.join(a.dir, "curves.csv"),
                             ("variant", "iteration", "mean_return", "sd_return", "repetitions"))
    cur = {}
    for r in rows:
        cur.setdefault(r["variant"], []).append(
            (int(r["iteration"]), float(r["mean_return"]), float(r["sd_return"]),
             int(r["repetitions"])))
    nrep = max(int(r["repetitions"]) for r in rows)
    fig, axes = figstyle.figure("full", aspect=0.55, nrows=2, ncols=6, sharex=True, sharey="row")
    style = [("imitation", "imitation only", "0.45", "--"),
             ("policy", "imitation + REPS", "C0", "-"),
             ("refit", "refit-only (no REPS)", "C1", "-"),
             ("matched", "REPS at π₀'s resolution", "C2", "-"),
             ("refit_matched", "refit-only at π₀'s resolution", "C3", ":")]
    handles = {}
    for row, c in enumerate(("query", "residual")):
        for col, p in enumerate(POLICIES):
            ax = axes[row][col]
            cc = "none" if p == "handcrafted" else c
            if p == "handcrafted" and row == 1:
                ax.set_visible(False)
                continue
            for init, lab, colour, ls in style:
                v = cur.get(f"{p}.{init}.{cc}")
                if not v:
                    continue
                v.sort()
                it = np.array([x[0] for x in v])
                m = np.array([x[1] for x in v])
                s = np.array([x[2] for x in v])
                ax.fill_between(it, m - s, m + s, color=colour, alpha=0.18, lw=0)
                handles[lab], = ax.plot(it, m, color=colour, ls=ls, lw=1.0)
            ax.set_title(p if cc == "none" else f"{p}, {cc}", fontsize=7)
            if col == 0 or (p == "handcrafted"):
                ax.set_ylabel(figstyle.label("return", "m"))
            if row == 1 or p == "handcrafted":
                ax.set_xlabel("iteration")
                ax.tick_params(labelbottom=True)
    figstyle.legend_below(fig, list(handles.values()), list(handles.keys()), ncol=4)
    fig.suptitle(f"mean ± 1 SD across {nrep} repetitions", fontsize=7)
    os.makedirs(a.out, exist_ok=True)
    figstyle.save(fig, a.out, "exp4_controls")


def main():
    ap = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("collect")
    c.add_argument("dir")
    c.add_argument("--arms", required=True)
    c.add_argument("--out", required=True)
    p = sub.add_parser("plot")
    p.add_argument("dir")
    p.add_argument("--out", required=True)
    d = sub.add_parser("docs")
    d.add_argument("dir")
    d.add_argument("--doc", required=True)
    d.add_argument("--readme")
    d.add_argument("--check", action="store_true")
    a = ap.parse_args()
    {"collect": collect, "plot": plot, "docs": docs}[a.cmd](a)


if __name__ == "__main__":
    main()
