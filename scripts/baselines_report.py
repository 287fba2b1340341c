#!/usr/bin/env python3
"""Experiment 5's tables, figure and docs/baselines.md, from CSVs only.

    baselines_report.py collect OUT DATA   OUT/runs/*.csv (scripts/baselines.py)
        and OUT/reps/* (poolreps Experiment 3 runs) -> DATA/runs.csv,
        DATA/curve.csv, DATA/timing.csv, DATA/clipped.csv (what the
        repository commits)
    baselines_report.py merge OUT DATA     the (learner, seed) runs found in
        OUT replace theirs in DATA, and so do the poolreps learners' timings;
        the other rows stay (runs done apart: more seeds, a longer budget, or
        jobs of a Slurm array)
    baselines_report.py report DATA DOCS [README] [--check]   -> DOCS/baselines.md,
        DOCS/figures/baselines.png and baselines_profile.png (and README's
        Experiment 5 paragraph); --check writes nothing and fails (exit 1,
        one line) when the page or paragraph differ from what DATA gives

Per budget: IQMs with 95 % stratified-bootstrap intervals and the
probability of improvement over REPS with hand-crafted features (rliable's
estimators, verdict_stats); the verdict: a learner is compared with REPS
with hand-crafted features by the paired difference over the seeds both ran
(seed k of every learner starts its n-th episode from the same state:
Experiment 3's repetition k), tested by the exact paired sign-flip test
(verdict_stats.p_signflip), and the p-values of one budget's comparisons
are Holm-adjusted together. The paired t test's verdicts are computed
beside it: the page names every one that differs.
"""
import ast
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import configparser
import csv
import math
import re
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parent))
import verdict_stats as vs  # noqa: E402  (after the path)

ROOT = Path(__file__).resolve().parent.parent
LAST = 500
LEVEL = 0.95
REFERENCE = "reps_handcrafted"
# learner -> (label, what it is)
LEARNERS = {
    "reps_handcrafted": ("REPS + hand-crafted features", "Experiment 3's `handcrafted` variant (contextual REPS + weighted ML, `exp3.handcrafted_method = creps`)"),
    "reps_tree_nrvr_a": ("REPS + tree features (nrvr_a)", "Experiment 3's best tree variant at 5 repetitions, `nrvr_a`"),
    "ccmaes_handcrafted": ("our contextual CMA-ES", "`exp3.handcrafted_method = ccmaes`: contextual CMA-ES on the hand-crafted linear policy"),
    "cma_linear": ("pycma CMA-ES (linear policy)", "pycma on the 12 weights of a = W φ(s), φ the hand-crafted features, one episode per candidate"),
    "sac": ("SAC (SB3 defaults)", "Stable-Baselines3 SAC, defaults"),
    "ppo": ("PPO (SB3 defaults)", "Stable-Baselines3 PPO, defaults"),
}
CLIPPED_HEADER = ["learner", "seed", "budget", "episodes", "clipped"]
REPS_DIRS = {"creps_handcrafted": "reps_handcrafted", "creps_nrvr_a": "reps_tree_nrvr_a",
             "ccmaes_handcrafted": "ccmaes_handcrafted"}


def write(path, header, rows):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def clipped_flags(folder, episodes):
    """Per repetition, whether each episode's action was clipped onto
    sim.max_speed (exp3.truncation = clip scales it to just below the limit:
    a speed within 1e-9 of it), checked against the count per iteration of
    exp3_reps.csv's redraws column (iterations 1 on; iteration 0 has none)."""
    cfg = configparser.ConfigParser(inline_comment_prefixes=(";",))
    cfg.read(folder / "config.ini")
    vmax = cfg.getfloat("sim", "max_speed")
    flags = defaultdict(list)
    for r in episodes:
        flags[int(r["repetition"])].append(
            (math.hypot(float(r["vx"]), float(r["vy"])) >= vmax * (1 - 1e-9), int(r["iteration"])))
    per_iter = defaultdict(int)
    for k, f in flags.items():
        for c, t in f:
            per_iter[k, t] += c
    for r in read(folder / "exp3_reps.csv"):
        key = (int(r["repetition"]), int(r["iteration"]))
        if per_iter[key] != int(r["redraws"]):
            raise SystemExit(f"baselines_report: {folder}/exp3_reps.csv: repetition {key[0]} "
                             f"iteration {key[1]}: redraws {r['redraws']}, but {per_iter[key]} "
                             "actions at sim.max_speed in exp3_episodes.csv")
    return {k: np.array([c for c, _ in f]) for k, f in flags.items()}


def reps_rows(folder, learner, budgets, every, timing, clipped):
    """Per repetition: the last-500 mean at each budget and every `every`
    episodes, from exp3_episodes.csv in file order, the mean action's
    return at each budget (exp3_mean.csv, when the run has one), and the
    actions clipped up to each budget (into clipped)."""
    returns = defaultdict(list)
    episodes = read(folder / "exp3_episodes.csv")
    for r in episodes:
        returns[int(r["repetition"])].append(float(r["return"]))
    flags = clipped_flags(folder, episodes)
    mean = {}
    if (folder / "exp3_mean.csv").exists():
        mean = {(int(r["repetition"]), int(r["episodes"])): r["mean_return"]
                for r in read(folder / "exp3_mean.csv")}
    runs, curve = [], []
    for k, R in sorted(returns.items()):
        R = np.array(R)
        for b in budgets:
            if b <= len(R):
                runs.append([learner, k, b, repr(float(R[max(0, b - LAST):b].mean())),
                             mean.get((k, b), ""), "", ""])
                clipped.append([learner, k, b, b, int(flags[k][:b].sum())])
        for n in range(every, len(R) + 1, every):
            curve.append([learner, k, n, repr(float(R[max(0, n - LAST):n].mean()))])
    t = (folder.parent / (folder.name + ".time")).read_text().split()
    wall, cpu = float(t[1]), float(t[3]) + float(t[4])
    nrun = len(returns)
    timing.append([learner, nrun, max(len(R) for R in returns.values()),
                   repr(wall / nrun), repr(cpu / nrun)])
    return runs, curve


def row_order(name):
    """The order of the rows of a committed CSV (collect's, and merge's):
    runs and clipped by (learner, budget, seed), curve by (learner, seed,
    episodes), timing the poolreps learners in their order."""
    reps = list(REPS_DIRS.values())
    if name == "timing.csv":
        return lambda r: (r[0] in reps, reps.index(r[0]) if r[0] in reps else 0, r[0])
    if name in ("runs.csv", "clipped.csv"):
        return lambda r: (r[0], int(r[2]), int(r[1]))
    return lambda r: (r[0], int(r[1]), int(r[2]))


def collect(out, data):
    out, data = Path(out), Path(data)
    budgets = [int(b) for b in (out / "budgets.txt").read_text().strip().split(",")]
    runs, curve, timing, clipped = [], [], [], []
    every = None
    for f in sorted((out / "runs").glob("*.csv")):
        for r in read(f):
            key = (r["learner"], int(r["seed"]), int(r["episodes"]))
            if r["kind"] == "curve":
                curve.append([r["learner"], key[1], key[2], r["last500_mean"]])
                every = every or key[2]
            else:
                runs.append([r["learner"], key[1], key[2], r["last500_mean"],
                             r["deterministic_mean"], r["wall_s"], r["cpu_s"]])
                if r.get("clipped", ""):   # runs made before the count have none
                    clipped.append([r["learner"], key[1], key[2], key[2], int(r["clipped"])])
    # a seed run at several budget lists: keep one row per (learner, seed, budget)
    runs = list({(r[0], r[1], r[2]): r for r in runs}.values())
    curve = list({(r[0], r[1], r[2]): r for r in curve}.values())
    clipped = list({(r[0], r[1], r[2]): r for r in clipped}.values())
    for d, learner in REPS_DIRS.items():
        if (out / "reps" / d / "exp3_episodes.csv").exists():
            r, c = reps_rows(out / "reps" / d, learner, budgets, every or 1100, timing, clipped)
            runs += r
            curve += c
    runs.sort(key=row_order("runs.csv"))
    curve.sort(key=row_order("curve.csv"))
    clipped.sort(key=row_order("clipped.csv"))
    write(data / "runs.csv", ["learner", "seed", "budget", "last500_mean", "deterministic_mean",
                              "wall_s", "cpu_s"], runs)
    write(data / "curve.csv", ["learner", "seed", "episodes", "last500_mean"], curve)
    write(data / "timing.csv", ["learner", "runs", "episodes", "wall_s_per_run",
                                "cpu_s_per_run"], timing)
    write(data / "clipped.csv", CLIPPED_HEADER, clipped)
    (data / "budgets.txt").write_text(",".join(map(str, budgets)) + "\n")


def merge(out, data):
    out, data = Path(out), Path(data)
    mine = (data / "budgets.txt").read_text().strip()
    theirs = (out / "budgets.txt").read_text().strip()
    if mine != theirs:
        raise SystemExit(f"baselines_report: {out}/budgets.txt ({theirs}) differs from "
                         f"{data}/budgets.txt ({mine})")
    with tempfile.TemporaryDirectory() as tmp:
        collect(out, tmp)
        new = {f: read(Path(tmp) / f) for f in ("runs.csv", "curve.csv", "timing.csv",
                                                 "clipped.csv")}
    runs = {(r["learner"], r["seed"]) for r in new["runs.csv"]}
    timed = {r["learner"] for r in new["timing.csv"]}
    for f, rows in new.items():
        if f == "clipped.csv" and not (data / f).exists():
            write(data / f, CLIPPED_HEADER, [])
        old = read(data / f)
        with open(data / f, newline="") as fh:
            header = next(csv.reader(fh))
        gone = (lambda r: r["learner"] in timed) if f == "timing.csv" else \
            (lambda r: (r["learner"], r["seed"]) in runs)
        kept = [[r[h] for h in header] for r in old if not gone(r)]
        added = [[r[h] for h in header] for r in rows]
        write(data / f, header, sorted(kept + added, key=row_order(f)))


def t_interval(x):
    """Mean and its 95 % t interval; NaN bounds below 2 values."""
    x = np.asarray(x, float)
    n = len(x)
    if n < 2:
        return (float(x[0]) if n else math.nan), math.nan, math.nan
    m = float(x.mean())
    half = stats.t.ppf(0.5 + LEVEL / 2, n - 1) * float(x.std(ddof=1)) / math.sqrt(n)
    return m, m - half, m + half


def paired_p(d):
    """Two-sided p of the paired t test (NaN below 2 pairs or no spread)."""
    d = np.asarray(d, float)
    if len(d) < 2 or float(d.std(ddof=1)) == 0.0:
        return math.nan
    return float(stats.ttest_1samp(d, 0.0).pvalue)


def holm(ps):
    """Holm-adjusted p-values, in the input order (NaN stays NaN)."""
    idx = [i for i, p in enumerate(ps) if not math.isnan(p)]
    order = sorted(idx, key=lambda i: ps[i])
    out, run = list(ps), 0.0
    for rank, i in enumerate(order):
        run = max(run, min(1.0, (len(order) - rank) * ps[i]))
        out[i] = run
    return out


def fmt(x, digits=3, signed=False):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    return f"{x:+.{digits}f}" if signed else f"{x:.{digits}f}"


def fmt_ci(m, lo, hi, signed=False):
    if math.isnan(lo):
        return fmt(m, signed=signed)
    return f"{fmt(m, signed=signed)} [{fmt(lo, signed=signed)}, {fmt(hi, signed=signed)}]"


def verdict(p, diff, pairs):
    """below / above / no difference shown at 5 % (Holm-adjusted p)."""
    return ("too few pairs" if pairs < 2 else
            "below" if p < 0.05 and diff < 0 else
            "above" if p < 0.05 and diff > 0 else "no difference shown")


def budget_table(rows, b):
    """Rows of one budget's table and the comparisons' verdicts: the sign-flip
    test's (verdict) and the paired t test's (verdict_t)."""
    by = defaultdict(dict)
    det = defaultdict(dict)
    for r in rows:
        if int(r["budget"]) == b:
            by[r["learner"]][int(r["seed"])] = float(r["last500_mean"])
            if r["deterministic_mean"]:
                det[r["learner"]][int(r["seed"])] = float(r["deterministic_mean"])
    ref = by.get(REFERENCE, {})
    learners = [k for k in LEARNERS if k in by]
    diffs, ps, pt = {}, [], []
    for k in learners:
        common = sorted(set(by[k]) & set(ref))
        d = [by[k][s] - ref[s] for s in common] if k != REFERENCE else []
        diffs[k] = (d, t_interval(d) if d else (math.nan,) * 3)
        ps.append(vs.p_signflip(d) if len(d) >= 2 else math.nan)
        pt.append(paired_p(d) if k != REFERENCE else math.nan)
    adj, adj_t = dict(zip(learners, holm(ps))), dict(zip(learners, holm(pt)))
    out = []
    for k in learners:
        m, lo, hi = t_interval(list(by[k].values()))
        dm = t_interval(list(det[k].values())) if det[k] else (math.nan,) * 3
        d, (dd, dlo, dhi) = diffs[k]
        ref_k = k == REFERENCE
        out.append({"learner": k, "seeds": len(by[k]), "mean": (m, lo, hi), "det": dm,
                    "det_seeds": len(det[k]), "diff": (dd, dlo, dhi), "pairs": len(d),
                    "p": adj[k], "p_t": adj_t[k],
                    "verdict": "reference" if ref_k else verdict(adj[k], dd, len(d)),
                    "verdict_t": "reference" if ref_k else verdict(adj_t[k], dd, len(d))})
    return out


def figure(curve, budgets, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    # each curve over the seeds run to its end, so that its seeds do not change along it
    end = defaultdict(dict)
    for r in curve:
        k, s = r["learner"], r["seed"]
        end[k][s] = max(end[k].get(s, 0), int(r["episodes"]))
    by = defaultdict(lambda: defaultdict(list))
    for r in curve:
        if end[r["learner"]][r["seed"]] == max(end[r["learner"]].values()):
            by[r["learner"]][int(r["episodes"])].append(float(r["last500_mean"]))
    fig, ax = plt.subplots(figsize=(8, 5.6), dpi=90)
    for k in LEARNERS:
        if k not in by:
            continue
        pts = sorted((n, v) for n, v in by[k].items() if len(v) >= 2)
        if not pts:
            continue
        n = np.array([p[0] for p in pts])
        ci = np.array([t_interval(p[1]) for p in pts])
        line, = ax.plot(n, ci[:, 0], label=f"{LEARNERS[k][0]} ({max(len(p[1]) for p in pts)} seeds)")
        ax.fill_between(n, ci[:, 1], ci[:, 2], color=line.get_color(), alpha=0.2, lw=0)
    for b in budgets:
        ax.axvline(b, color="0.6", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_xlabel("training episodes")
    ax.set_ylabel(f"mean return of the last {LAST} episodes")
    ax.set_title("Experiment 3's task: return against episodes (mean over seeds, 95 % t band)")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=3)
    ax.grid(alpha=0.3)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


BOOT, BOOT_SEED = 2000, 1
COLUMNS = {"last500_mean": f"last {LAST}", "deterministic_mean": "mean action"}


def by_learner(runs, b, col="last500_mean"):
    """{learner: array of its seeds' values of col} at budget b, in LEARNERS
    order (learners with fewer than 2 seeds left out)."""
    acc = defaultdict(list)
    for r in runs:
        if int(r["budget"]) == b and r[col]:
            acc[r["learner"]].append(float(r[col]))
    return {k: np.array(acc[k]) for k in LEARNERS if len(acc[k]) >= 2}


def iqm_cell(x, seed):
    """IQM [95 % stratified-bootstrap interval] of one learner's seeds."""
    lo, hi = vs.bootstrap_ci(vs.iqm, [x], BOOT, seed)
    return f"{vs.iqm(x):.3f} [{lo:.3f}, {hi:.3f}]"


def results_table(runs, tables, b):
    """One budget's rows: seeds, IQM of both evaluations, the probability of
    improvement over the reference, the paired mean difference the verdict
    tests (95 % t interval) and the paired test's Holm verdict."""
    cols = {c: by_learner(runs, b, c) for c in COLUMNS}
    ref = cols["last500_mean"].get(REFERENCE)
    test = {r["learner"]: r for r in tables[b]}
    rows = []
    for i, (k, x) in enumerate(cols["last500_mean"].items()):
        seed = BOOT_SEED + 1000 * b + i
        d = cols["deterministic_mean"].get(k)
        pi = "reference" if k == REFERENCE or ref is None else (
            f"{vs.prob_improvement(x, ref):.2f} " + "[{:.2f}, {:.2f}]".format(
                *vs.bootstrap_ci(vs.prob_improvement, [x, ref], BOOT, seed)))
        t = test[k]
        diff = "reference" if k == REFERENCE else fmt_ci(*t["diff"], signed=True)
        rows.append(f"| {LEARNERS[k][0]} | {len(x)} | {iqm_cell(x, seed)} | "
                    f"{iqm_cell(d, seed + 500) if d is not None else '—'} | {pi} | "
                    f"{diff} | {fmt(t['p'])} | {t['verdict']} |")
    return rows


def profile_figure(runs, budgets, path):
    """Performance profiles (rliable): per budget, the share of a learner's
    runs whose return exceeds tau, against tau."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(budgets), figsize=(4 * len(budgets), 5.0), dpi=90,
                             sharey=True, squeeze=False)
    allx = np.concatenate([x for b in budgets for x in by_learner(runs, b).values()])
    taus = np.linspace(allx.min() - 0.05, allx.max() + 0.05, 200)
    for ax, b in zip(axes[0], budgets):
        for k, x in by_learner(runs, b).items():
            ax.step(taus, vs.performance_profile(x, taus), where="post",
                    label=f"{LEARNERS[k][0]} ({len(x)} seeds)")
        ax.set_title(f"{b:,} episodes")
        ax.set_xlabel(f"return τ (mean of the last {LAST} episodes)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16))
    axes[0][0].set_ylabel("share of seeds with return > τ")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def summary(tables, budgets):
    """The paragraph's facts, each from the tables: per budget, how many of
    the learners paired with the reference are below and above it."""
    out = []
    for b in budgets:
        t = [r for r in tables[b] if r["verdict"] not in ("reference", "too few pairs")]
        if not t:
            continue
        s = f"at {b:,} episodes {sum(r['verdict'] == 'below' for r in t)} of {len(t)} below"
        above = [LEARNERS[r["learner"]][0] for r in t if r["verdict"] == "above"]
        out.append(s + (", above: " + "; ".join(above) if above else ", none above"))
    return (f"Against {LEARNERS[REFERENCE][0]}, paired by seed: " + "; ".join(out) + "."
            if out else "")


def readme_text(runs, tables, budgets):
    """The README's sentence and figure, from the tables."""
    parts = []
    for b in sorted({budgets[0], budgets[-1]}):
        t = tables[b]
        if not t:
            continue
        ref = next(r for r in t if r["verdict"] == "reference")
        below = sum(r["verdict"] == "below" for r in t)
        tested = sum(r["verdict"] not in ("reference", "too few pairs") for r in t)
        x = by_learner(runs, b).get(REFERENCE)
        parts.append(f"at {b:,} episodes REPS + hand-crafted features has an IQM of the last "
                     f"{LAST} of {iqm_cell(x, BOOT_SEED + 1000 * b)} ({ref['seeds']} seeds), and "
                     f"{below} of the {tested} learners paired with it "
                     f"{'is' if below == 1 else 'are'} below it")
    return ("Experiment 5 ([docs/baselines.md](docs/baselines.md), `make baselines`) puts "
            "SAC, PPO and CMA-ES on Experiment 3's task beside our REPS learners, none tuned "
            "for it (REPS at the thesis's settings), under one speed-limit rule: "
            + "; ".join(parts) + " (paired sign-flip test by seed, Holm-adjusted, 5 %; seeds per learner "
            "and budget, IQMs and probabilities of improvement in the page).\n\n"
            "![Experiment 5: return against episodes](docs/figures/baselines.png)")


def cpu_rows(runs, timing, budgets):
    """CPU seconds per seed: the Python learners' at each budget (measured
    inside the run, cumulative), the poolreps learners' whole process per
    repetition (its longest run only)."""
    rows = []
    for k in LEARNERS:
        cells = []
        for b in budgets:
            c = [float(r["cpu_s"]) for r in runs
                 if r["learner"] == k and int(r["budget"]) == b and r["cpu_s"]]
            cells.append(f"{np.mean(c):.1f} ({len(c)})" if c else "—")
        t = [r for r in timing if r["learner"] == k]
        if t:
            cells[budgets.index(int(t[0]["episodes"]))] = \
                f"{float(t[0]['cpu_s_per_run']):.1f} ({t[0]['runs']}, whole process)"
        rows.append(f"| {LEARNERS[k][0]} | " + " | ".join(cells) + " |")
    return rows


def clipped_rows(runs, clipped, budgets):
    """The share of training actions clipped onto sim.max_speed up to each
    budget, pooled over the seeds counted; "not recorded" where runs exist
    without a count; and the sentence naming those and what counting them
    would cost (each such seed rerun to its longest budget, runs.csv's CPU)."""
    rows, missing, cost = [], [], 0.0
    for k in LEARNERS:
        cells, gone = [], []
        for b in budgets:
            c = [r for r in clipped if r["learner"] == k and int(r["budget"]) == b]
            ran = {r["seed"] for r in runs if r["learner"] == k and int(r["budget"]) == b}
            if c:
                share = sum(int(r["clipped"]) for r in c) / sum(int(r["episodes"]) for r in c)
                pct = "0" if share == 0 else f"{100 * share:.1f}" if share >= 1e-3 else \
                    f"{100 * share:.2g}"
                cells.append(f"{pct} % ({len(c)})")
            else:
                cells.append("not recorded" if ran else "—")
            lost = len(ran - {r["seed"] for r in c})
            if lost:
                gone.append(f"{b:,}" + ("" if lost == len(ran) else f" ({lost} of {len(ran)} seeds)"))
        if gone:
            counted = {(r["seed"], r["budget"]) for r in clipped if r["learner"] == k}
            seeds = {r["seed"] for r in runs if r["learner"] == k and
                     (r["seed"], r["budget"]) not in counted}
            missing.append(f"{LEARNERS[k][0]} at " + (" and ".join(gone) if len(gone) < 3 else
                                                      ", ".join(gone[:-1]) + " and " + gone[-1]))
            cost += sum(max((float(r["cpu_s"]) for r in runs if r["learner"] == k and
                             r["seed"] == s and r["cpu_s"]), default=0.0) for s in seeds)
        rows.append(f"| {LEARNERS[k][0]} | " + " | ".join(cells) + " |")
    note = "" if not missing else (
        "Not recorded: " + "; ".join(missing) + " episodes (the runs before the count; "
        f"rerunning them costs about {float(f'{cost:.2g}'):,.0f} CPU seconds).")
    return rows, note


def rewrite_readme(path, text):
    """Replace the text between the baselines markers of README.md."""
    s = Path(path).read_text()
    a, b = "<!-- baselines: generated by scripts/baselines_report.py -->", "<!-- /baselines -->"
    i, j = s.index(a) + len(a), s.index(b)
    Path(path).write_text(s[:i] + "\n" + text + "\n" + s[j:])


def num(x):
    """A number as the page prints it: thousands separated, a real minus."""
    return (f"{x:,}" if isinstance(x, int) else f"{x:g}").replace("-", "−")


def setup(root=ROOT):
    """The setup's numbers from where the runs read them: (Python learners'
    value, poolreps learners' value) per item. The Python learners' are
    scripts/baselines.py's constants; the poolreps learners' data/exp3.ini
    and the --set options of scripts/baselines.sh (REPS_SET)."""
    ini = configparser.ConfigParser(inline_comment_prefixes=(";",))
    ini.read(root / "data/exp3.ini")
    py = {}
    for node in ast.parse((root / "scripts/baselines.py").read_text()).body:
        if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Name):
            try:
                py[node.targets[0].id] = ast.literal_eval(node.value)
            except ValueError:
                pass
    sh = re.search(r'^REPS_SET="([^"]*)"', (root / "scripts/baselines.sh").read_text(), re.M)
    sets = dict(re.findall(r"--set exp3\.(\w+)=(\S+)", sh.group(1)))
    box = tuple(float(v) for v in ini["start"]["reward_box"].split(","))
    return {"cue": (None, tuple(float(v) for v in ini["start"]["cue_box"].split(","))),
            "box": (tuple(py["REWARD_BOX"]), box),
            "seed": (py["EXP3_SEED"], ini.getint("experiment", "seed")),
            "truncation": (None, sets["truncation"]),
            "sigma": (py["SIGMA0"], ini.getfloat("exp3", "init_std")),
            "states": (py["EVAL_STARTS"], int(sets["mean_eval"])),
            "eval_seed": (py["EVAL_SEED"], int(sets["mean_eval_seed"])),
            "every": (None, int(re.search(r"^every=(\d+)$", sh.string, re.M).group(1)))}


def setup_text(values):
    """TEXT_SETUP filled in: one value where both kinds of learner read the
    same, else both, named, and a sentence listing the differences."""
    def show(k, v):
        if k == "cue":
            return f"({num(v[0])}, {num(v[2])})" if v[0] == v[1] and v[2] == v[3] else \
                f"[{num(v[0])}, {num(v[1])}] × [{num(v[2])}, {num(v[3])}]"
        return f"[{num(v[0])}, {num(v[1])}] × [{num(v[2])}, {num(v[3])}]" if k == "box" \
            else v if isinstance(v, str) else num(v)
    out, differ = {"last": LAST}, []
    for k, (py, reps) in values.items():
        if k == "every":
            continue
        if py is None or py == reps:
            out[k] = show(k, reps)
        else:
            out[k] = f"{show(k, py)} (Python learners; poolreps learners {show(k, reps)})"
            differ.append(k)
    note = ("" if not differ else "\n- **Differences** between the Python and the poolreps "
            "learners' settings: " + ", ".join(differ) + ".")
    return TEXT_SETUP.format(differ=note, **out)


def t_changes(tables, budgets):
    """The sentence naming every verdict the paired t test would change."""
    ch = [f"{LEARNERS[r['learner']][0]} at {b:,} episodes would be *{r['verdict_t']}* "
          f"(Holm p {fmt(r['p_t'])})" for b in budgets for r in tables[b]
          if r["verdict_t"] != r["verdict"]]
    return ("Under the paired t test no verdict differs." if not ch else
            "Under the paired t test " + ("one verdict differs: " if len(ch) == 1 else
                                          f"{len(ch)} verdicts differ: ") + "; ".join(ch) + ".")


def fewer_seeds(runs, budgets):
    """The sentence naming the learners run on fewer seeds than the most at a budget."""
    out = []
    for b in budgets:
        n = {k: len(x) for k, x in by_learner(runs, b).items()}
        few = defaultdict(list)
        for k, c in n.items():
            if n and c < max(n.values()):
                few[c].append(LEARNERS[k][0])
        out += [f"{', '.join(ks)} {'has' if len(ks) == 1 else 'have'} {c} seeds at {b:,} "
                "episodes." for c, ks in sorted(few.items())]
    return " ".join(out)


def page(runs, timing, clipped, budgets, tables):
    """docs/baselines.md's text."""
    L = ["# Experiment 5: standard learners on the thesis's task", "",
         "<!-- Generated by scripts/baselines_report.py from data/baselines/*.csv "
         "(make baselines). Do not edit. -->", "", setup_text(setup()), "",
         "| learner | what |", "|---|---|"]
    L += [f"| {LEARNERS[k][0]} | {LEARNERS[k][1]} |" for k in LEARNERS]
    most = max((r["pairs"] for t in tables.values() for r in t), default=0)
    enum = "all 2^n sign vectors" if most <= vs.SIGNFLIP_EXACT_MAX else (
        f"all 2^n sign vectors up to {vs.SIGNFLIP_EXACT_MAX} pairs, "
        f"{vs.SIGNFLIP_DRAWS:,} seeded random ones beyond")
    L += ["", TEXT_STATS.format(enum=enum) + " " + t_changes(tables, budgets) + " " +
          fewer_seeds(runs, budgets), ""]
    for b in budgets:
        L += [f"**{b:,} episodes**", "",
              f"| learner | seeds | IQM, last {LAST} [95 % CI] | IQM, mean action [95 % CI] | "
              "P(better than reference) [95 % CI] | "
              "mean paired difference [95 % t, unadjusted] | Holm p, sign flip | verdict |",
              "|---|---:|---|---|---|---|---:|---|"] + results_table(runs, tables, b) + [""]
    crows, cnote = clipped_rows(runs, clipped, budgets)
    L += ["![performance profiles](figures/baselines_profile.png)", "",
          "*Performance profiles: per budget, the share of a learner's seeds whose mean "
          f"return of the last {LAST} episodes exceeds τ; further right is better.*", "",
          "![return against episodes](figures/baselines.png)", "",
          f"*Mean over seeds (those run to the curve's end: the legend's count) of the "
          f"mean return of the last {LAST} episodes, 95 % t band; dotted: the budgets.*", "",
          "## Clipped actions", "",
          "Share of the training actions up to each budget clipped onto `sim.max_speed` "
          "(seeds counted):", "",
          "| learner | " + " | ".join(f"{b:,}" for b in budgets) + " |",
          "|---|" + "---:|" * len(budgets)] + crows + ["", cnote, "",
          "## CPU time", "", "CPU seconds per seed (seeds measured) at each budget:", "",
          "| learner | " + " | ".join(f"{b:,}" for b in budgets) + " |",
          "|---|" + "---:|" * len(budgets)] + cpu_rows(runs, timing, budgets)
    L += ["", TEXT_TIMING.format(every=num(setup()["every"][1])), "", "## What it means", "",
          summary(tables, budgets) + " " + TEXT_MEANING, ""]
    return "\n".join(L)


def report(data, docs, readme=None, check=False):
    """docs/baselines.md, its figures and the README paragraph; check: write
    nothing and fail on a difference from the committed text."""
    data, docs = Path(data), Path(docs)
    runs, curve, timing = read(data / "runs.csv"), read(data / "curve.csv"), read(data / "timing.csv")
    budgets = [int(b) for b in (data / "budgets.txt").read_text().strip().split(",")]
    clipped = read(data / "clipped.csv") if (data / "clipped.csv").exists() else []
    tables = {b: budget_table(runs, b) for b in budgets}
    text = page(runs, timing, clipped, budgets, tables)
    if check:
        bad = [] if (docs / "baselines.md").read_text() == text else [docs / "baselines.md"]
        if readme:
            s = Path(readme).read_text()
            if "\n" + readme_text(runs, tables, budgets) + "\n<!-- /baselines -->" not in s:
                bad.append(readme)
        if bad:
            raise SystemExit("baselines_report: " + ", ".join(map(str, bad)) +
                             " differ from what data/baselines gives (make baselines-report)")
        return
    figure(curve, budgets, docs / "figures" / "baselines.png")
    profile_figure(runs, budgets, docs / "figures" / "baselines_profile.png")
    docs.mkdir(parents=True, exist_ok=True)
    (docs / "baselines.md").write_text(text)
    if readme:
        rewrite_readme(readme, readme_text(runs, tables, budgets))


TEXT_SETUP = """Today's standard learners on Experiment 3's task (docs/exp3.md): the cue ball
at {cue}, the reward ball uniform in {box}, one shot per episode, the reward of eq. 7.7.

```sh
make baselines         # venv (pinned SB3, pycma), all runs, CSVs, this page
sh scripts/baselines.sh one OUT sac 10 2200,22000   # one run (a Slurm array job)
python3 scripts/baselines_report.py merge OUT data/baselines   # add runs made apart
make baselines-report  # this page; make verdicts CHECK=1 checks it
```

- **Same start states**: seed k of every learner plays Experiment 3's start states of
  repetition k (`experiment.seed` {seed}), so the comparisons are paired by seed.
- **One speed-limit rule**: an action faster than `sim.max_speed` is scaled onto the
  limit for every learner (`exp3.truncation = {truncation}`; PocketEnv does it for the
  Python learners; how often: below). SB3 acts in [−1, 1]² × `sim.max_speed`.
- **Equal tuning budget: none.** SB3's defaults; pycma's defaults with σ₀ = {sigma} m/s
  (Experiment 3's `init_std`); REPS and our CMA-ES with data/exp3.ini's settings.
  Two hand-tuned SB3 variants were dropped for this rule after their results were
  known.
- **Two evaluations** at each budget, of one long run per seed (torch on one thread):
  the mean return of the last {last} training episodes, and the return of the
  learner's mean action (SB3's `deterministic=True`, the CMA-ES mean, REPS's
  policy mean, `exp3.mean_eval`) on {states} fresh start states (seed {eval_seed} + k), the
  same states for every learner of a seed.{differ}"""

TEXT_STATS = f"""## Results

Per budget: the interquartile mean (IQM) of the seeds' values with its 95 %
stratified-bootstrap interval ({BOOT} resamples), and the probability of improvement
P(X > Y) + P(X = Y)/2 of a seed of the learner over one of REPS + hand-crafted features
(Agarwal et al., NeurIPS 2021; `rliable`'s estimators in scripts/verdict_stats.py). The
verdict: the exact two-sided paired sign-flip test of the mean difference of the
last-{LAST} means from REPS + hand-crafted features over the seeds both ran ({{enum}};
sums within {vs.SIGNFLIP_RTOL:g} × Σ|d| of the observed one are ties),
Holm-adjusted over one budget's learners, 5 %; the mean difference has its 95 % t
interval, unadjusted, not the test's. This test replaced the paired t test after the data
were seen: a reviewer found the reference's seeds bimodal; it assumes differences symmetric
about 0 under the null, not normal. P(improvement) pairs no seeds."""


TEXT_TIMING = """Python learners: the process's CPU up to that budget; poolreps learners:
the whole process (mean-action evaluations every {every} episodes included) per
repetition. Measured on a shared 2-core machine."""

TEXT_MEANING = """SAC and PPO learn their own features from the state; CMA-ES searches the
hand-crafted policy's weights. *No difference shown* is a failure to reject at the
seeds run, not a finding of equality."""


def main(argv):
    if len(argv) == 4 and argv[1] == "collect":
        collect(argv[2], argv[3])
    elif len(argv) == 4 and argv[1] == "merge":
        merge(argv[2], argv[3])
    elif len(argv) in (4, 5, 6) and argv[1] == "report":
        args = [a for a in argv[2:] if a != "--check"]
        if len(args) not in (2, 3) or argv[2:].count("--check") > 1:
            print(__doc__, file=sys.stderr)
            return 1
        report(*args, check="--check" in argv)
    else:
        print(__doc__, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
