#!/usr/bin/env python3
"""Experiment 5's tables, figure and docs/baselines.md, from CSVs only.

    baselines_report.py collect OUT DATA   OUT/runs/*.csv (scripts/baselines.py)
        and OUT/reps/* (poolreps Experiment 3 runs) -> DATA/runs.csv,
        DATA/curve.csv, DATA/timing.csv (what the repository commits)
    baselines_report.py merge OUT DATA     the learners found in OUT replace
        theirs in DATA; the other learners' rows stay (runs done apart, e.g.
        one learner at a longer budget, or jobs of a Slurm array)
    baselines_report.py report DATA DOCS [README]   -> DOCS/baselines.md and
        DOCS/figures/baselines.png (and README's Experiment 5 paragraph)

Intervals are 95 % t intervals over seeds; a learner is compared with REPS
with hand-crafted features by the paired difference over the seeds both ran
(seed k of every learner starts its n-th episode from the same state:
Experiment 3's repetition k), and the p-values of one budget's comparisons
are Holm-adjusted together.
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import csv
import math
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parent))
import verdict_stats as vs  # noqa: E402  (after the path)

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
    "sac_tuned": ("SAC (tuned)", "SAC, network 64-64, learning rate 1e-3"),
    "ppo": ("PPO (SB3 defaults)", "Stable-Baselines3 PPO, defaults"),
    "ppo_tuned": ("PPO (tuned)", "PPO, network 64-64, learning rate 1e-3, 200 steps per update, minibatch 50"),
}
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


def reps_rows(folder, learner, budgets, every, timing):
    """Per repetition: the last-500 mean at each budget and every `every`
    episodes, from exp3_episodes.csv in file order."""
    returns = defaultdict(list)
    for r in read(folder / "exp3_episodes.csv"):
        returns[int(r["repetition"])].append(float(r["return"]))
    runs, curve = [], []
    for k, R in sorted(returns.items()):
        R = np.array(R)
        for b in budgets:
            if b <= len(R):
                runs.append([learner, k, b, repr(float(R[max(0, b - LAST):b].mean())), "", "", ""])
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
    runs by (learner, budget, seed), curve by (learner, seed, episodes),
    timing the Python learners by name, then the poolreps learners."""
    reps = list(REPS_DIRS.values())
    if name == "timing.csv":
        return lambda r: (r[0] in reps, reps.index(r[0]) if r[0] in reps else 0, r[0])
    if name == "runs.csv":
        return lambda r: (r[0], int(r[2]), int(r[1]))
    return lambda r: (r[0], int(r[1]), int(r[2]))


def collect(out, data):
    out, data = Path(out), Path(data)
    budgets = [int(b) for b in (out / "budgets.txt").read_text().strip().split(",")]
    runs, curve, timing = [], [], []
    longest = defaultdict(dict)  # learner -> seed -> (episodes, wall, cpu)
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
                old = longest[key[0]].get(key[1])
                if old is None or old[0] < key[2]:
                    longest[key[0]][key[1]] = (key[2], float(r["wall_s"]), float(r["cpu_s"]))
    # a seed run at several budget lists: keep one row per (learner, seed, budget)
    runs = list({(r[0], r[1], r[2]): r for r in runs}.values())
    curve = list({(r[0], r[1], r[2]): r for r in curve}.values())
    for learner, seeds in sorted(longest.items()):
        v = list(seeds.values())
        eps = max(x[0] for x in v)
        at = [x for x in v if x[0] == eps]
        timing.append([learner, len(at), eps, repr(float(np.mean([x[1] for x in at]))),
                       repr(float(np.mean([x[2] for x in at])))])
    for d, learner in REPS_DIRS.items():
        if (out / "reps" / d / "exp3_episodes.csv").exists():
            r, c = reps_rows(out / "reps" / d, learner, budgets, every or 1100, timing)
            runs += r
            curve += c
    runs.sort(key=row_order("runs.csv"))
    curve.sort(key=row_order("curve.csv"))
    write(data / "runs.csv", ["learner", "seed", "budget", "last500_mean", "deterministic_mean",
                              "wall_s", "cpu_s"], runs)
    write(data / "curve.csv", ["learner", "seed", "episodes", "last500_mean"], curve)
    write(data / "timing.csv", ["learner", "runs", "episodes", "wall_s_per_run",
                                "cpu_s_per_run"], timing)
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
        new = {f: read(Path(tmp) / f) for f in ("runs.csv", "curve.csv", "timing.csv")}
    learners = {r["learner"] for r in new["runs.csv"]}
    for f, rows in new.items():
        old = read(data / f)
        header = list(old[0].keys()) if old else list(rows[0].keys())
        kept = [[r[h] for h in header] for r in old if r["learner"] not in learners]
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


def budget_table(rows, b):
    """Rows of one budget's table and the comparisons' verdicts."""
    by = defaultdict(dict)
    det = defaultdict(dict)
    for r in rows:
        if int(r["budget"]) == b:
            by[r["learner"]][int(r["seed"])] = float(r["last500_mean"])
            if r["deterministic_mean"]:
                det[r["learner"]][int(r["seed"])] = float(r["deterministic_mean"])
    ref = by.get(REFERENCE, {})
    learners = [k for k in LEARNERS if k in by]
    diffs, ps = {}, []
    for k in learners:
        common = sorted(set(by[k]) & set(ref))
        d = [by[k][s] - ref[s] for s in common] if k != REFERENCE else []
        diffs[k] = (d, t_interval(d) if d else (math.nan,) * 3)
        ps.append(paired_p(d) if k != REFERENCE else math.nan)
    adj = dict(zip(learners, holm(ps)))
    out = []
    for k in learners:
        m, lo, hi = t_interval(list(by[k].values()))
        dm = t_interval(list(det[k].values())) if det[k] else (math.nan,) * 3
        d, (dd, dlo, dhi) = diffs[k]
        verdict = "reference" if k == REFERENCE else (
            "too few pairs" if len(d) < 2 else
            "below" if adj[k] < 0.05 and dd < 0 else
            "above" if adj[k] < 0.05 and dd > 0 else "no difference shown")
        out.append({"learner": k, "seeds": len(by[k]), "mean": (m, lo, hi), "det": dm,
                    "det_seeds": len(det[k]), "diff": (dd, dlo, dhi), "pairs": len(d),
                    "p": adj[k], "verdict": verdict})
    return out


def figure(curve, budgets, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    by = defaultdict(lambda: defaultdict(list))
    for r in curve:
        by[r["learner"]][int(r["episodes"])].append(float(r["last500_mean"]))
    fig, ax = plt.subplots(figsize=(8, 5.6), dpi=110)
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


def by_learner(runs, b):
    """{learner: array of its seeds' last-500 means} at budget b, in LEARNERS order."""
    acc = defaultdict(list)
    for r in runs:
        if int(r["budget"]) == b:
            acc[r["learner"]].append(float(r["last500_mean"]))
    return {k: np.array(acc[k]) for k in LEARNERS if len(acc[k]) >= 2}


def aggregate_table(runs, b):
    """rliable's summary of one budget: per learner its seeds, IQM with the
    95 % stratified-bootstrap interval, and the probability of improvement
    over REPS + hand-crafted features with its interval."""
    by = by_learner(runs, b)
    ref = by.get(REFERENCE)
    rows = []
    for i, (k, x) in enumerate(by.items()):
        seed = BOOT_SEED + 1000 * b + i
        lo, hi = vs.bootstrap_ci(vs.iqm, [x], BOOT, seed)
        pi = "reference" if k == REFERENCE or ref is None else (
            f"{vs.prob_improvement(x, ref):.2f} " + "[{:.2f}, {:.2f}]".format(
                *vs.bootstrap_ci(vs.prob_improvement, [x, ref], BOOT, seed)))
        rows.append(f"| {LEARNERS[k][0]} | {len(x)} | {vs.iqm(x):.3f} [{lo:.3f}, {hi:.3f}] "
                    f"| {pi} |")
    return rows


def profile_figure(runs, budgets, path):
    """Performance profiles (rliable): per budget, the share of a learner's
    runs whose return exceeds tau, against tau."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(budgets), figsize=(4 * len(budgets), 4.2), dpi=110,
                             sharey=True, squeeze=False)
    allx = np.concatenate([x for b in budgets for x in by_learner(runs, b).values()])
    taus = np.linspace(allx.min() - 0.05, allx.max() + 0.05, 200)
    for ax, b in zip(axes[0], budgets):
        for k, x in by_learner(runs, b).items():
            ax.step(taus, vs.performance_profile(x, taus), where="post",
                    label=f"{LEARNERS[k][0]} ({len(x)} seeds)")
        ax.set_title(f"{b:,} episodes")
        ax.set_xlabel("return τ (last 500 episodes)")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("share of runs with return > τ")
    axes[0][0].legend(fontsize=6, loc="lower left")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def summary(tables, budgets):
    """The paragraph's facts, each from the tables."""
    out = []
    for b in budgets:
        t = tables[b]
        if not t:
            continue
        best = max(t, key=lambda r: r["mean"][0])
        below = [LEARNERS[r["learner"]][0] for r in t if r["verdict"] == "below"]
        above = [LEARNERS[r["learner"]][0] for r in t if r["verdict"] == "above"]
        same = [LEARNERS[r["learner"]][0] for r in t if r["verdict"] == "no difference shown"]
        s = (f"At {b:,} episodes the highest mean return is that of "
             f"{LEARNERS[best['learner']][0]} ({fmt(best['mean'][0])}, {best['seeds']} seeds).")
        if below:
            s += " Below REPS + hand-crafted features (Holm-adjusted paired t test, 5 %): " \
                 + "; ".join(below) + "."
        if above:
            s += " Above it: " + "; ".join(above) + "."
        if same:
            s += " No difference shown: " + "; ".join(same) + "."
        out.append(s)
    return out


def readme_text(tables, budgets):
    """The README's sentence and figure, from the tables."""
    parts = []
    for b in sorted({budgets[0], budgets[-1]}):
        t = tables[b]
        if not t:
            continue
        best = max(t, key=lambda r: r["mean"][0])
        below = sum(r["verdict"] == "below" for r in t)
        tested = sum(r["verdict"] not in ("reference", "too few pairs") for r in t)
        parts.append(f"at {b:,} episodes the best mean return of the last {LAST} is that of "
                     f"{LEARNERS[best['learner']][0]} ({fmt(best['mean'][0])}, "
                     f"{best['seeds']} seeds), and {below} of the {tested} learners paired "
                     f"with REPS + hand-crafted features {'is' if below == 1 else 'are'} below it")
    return ("Experiment 5 ([docs/baselines.md](docs/baselines.md), `make baselines`) puts "
            "SAC, PPO and CMA-ES on Experiment 3's task beside our REPS learners: "
            + "; ".join(parts) + " (paired by seed, Holm-adjusted, 5 %; seed counts per "
            "learner and budget in the tables).\n\n"
            "![Experiment 5: return against episodes](docs/figures/baselines.png)")


def reached(runs):
    """'SAC (SB3 defaults) 2,200, …, and PPO (tuned) 55,000': the largest
    budget each SB3 learner has a row at."""
    top = defaultdict(int)
    for r in runs:
        top[r["learner"]] = max(top[r["learner"]], int(r["budget"]))
    parts = [f"{LEARNERS[k][0]} {top[k]:,}" for k in ("sac", "sac_tuned", "ppo", "ppo_tuned")
             if top[k]]
    return ", ".join(parts[:-1]) + " and " + parts[-1] if len(parts) > 1 else "".join(parts)


def rewrite_readme(path, text):
    """Replace the text between the baselines markers of README.md."""
    s = Path(path).read_text()
    a, b = "<!-- baselines: generated by scripts/baselines_report.py -->", "<!-- /baselines -->"
    i, j = s.index(a) + len(a), s.index(b)
    Path(path).write_text(s[:i] + "\n" + text + "\n" + s[j:])


def report(data, docs, readme=None):
    data, docs = Path(data), Path(docs)
    runs, curve, timing = read(data / "runs.csv"), read(data / "curve.csv"), read(data / "timing.csv")
    budgets = [int(b) for b in (data / "budgets.txt").read_text().strip().split(",")]
    figure(curve, budgets, docs / "figures" / "baselines.png")
    profile_figure(runs, budgets, docs / "figures" / "baselines_profile.png")
    tables = {b: budget_table(runs, b) for b in budgets}
    L = ["# Experiment 5: standard learners on the thesis's task", "",
         "<!-- Generated by scripts/baselines_report.py from data/baselines/*.csv "
         "(make baselines). Do not edit. -->", ""]
    L.append(TEXT_SETUP.replace("{reached}", reached(runs)))
    L += ["", "## Learners", "", "| learner | what |", "|---|---|"]
    L += [f"| {LEARNERS[k][0]} | {LEARNERS[k][1]} |" for k in LEARNERS]
    L += ["", "## Sample efficiency", "", "![return against episodes](figures/baselines.png)", "",
          f"Each curve: the mean over seeds of the mean return of the last {LAST} training "
          "episodes, every " + f"{int(curve[0]['episodes']) if curve else 0:,}" +
          " episodes, with its 95 % t band; dotted lines mark the budgets. A curve stops "
          "where its runs stop.", ""]
    for b in budgets:
        t = tables[b]
        L += [f"## Budget {b:,} episodes", "",
              f"| learner | seeds | mean return, last {LAST} [95 % CI] | deterministic, 2000 "
              "fresh starts [95 % CI] | paired difference vs REPS hand-crafted [95 % CI] | "
              "pairs | Holm p | verdict |", "|---|---:|---|---|---|---:|---:|---|"]
        for r in t:
            L.append(f"| {LEARNERS[r['learner']][0]} | {r['seeds']} | {fmt_ci(*r['mean'])} | "
                     f"{fmt_ci(*r['det']) if r['det_seeds'] else '— (not measured)'} | "
                     f"{fmt_ci(*r['diff'], signed=True) if r['pairs'] else '—'} | "
                     f"{r['pairs'] or '—'} | {fmt(r['p'])} | {r['verdict']} |")
        if not t:
            L.append("| (no runs at this budget) | | | | | | | |")
        L.append("")
    few = sorted({LEARNERS[k][0] for b in budgets for k, x in by_learner(runs, b).items()
                  if len(x) < 20}, key=list(v[0] for v in LEARNERS.values()).index)
    L += ["## Aggregate, the rliable way", "",
          "As deep-RL results are now reported (Agarwal et al., NeurIPS 2021, the estimators of "
          "the `rliable` library, written in scripts/verdict_stats.py and tested against "
          "scipy): per budget the interquartile mean (IQM) of the seeds' mean returns of the "
          f"last {LAST} training episodes, with its 95 % stratified-bootstrap interval "
          f"({BOOT} resamples, each learner's seeds resampled on their own), and the "
          "probability of improvement over REPS + hand-crafted features, P(X > Y) + P(X = Y) "
          "/ 2 of a run of the learner against one of REPS, with its interval. Seeds per "
          "learner as run (the tables' second column); " + (
              f"fewer than the 20 such comparisons call for: {', '.join(few)}, whose intervals "
              "are wide accordingly" if few else "every learner has 20 or more") +
          ". Profiles: "
          "[figures/baselines_profile.png](figures/baselines_profile.png).", ""]
    for b in budgets:
        L += [f"**{b:,} episodes**", "",
              "| learner | seeds | IQM [95 % CI] | P(improvement over REPS hand-crafted) "
              "[95 % CI] |", "|---|---:|---|---|"] + aggregate_table(runs, b) + [""]
    L += ["![performance profiles](figures/baselines_profile.png)", "",
          "*Figure: performance profiles per budget: the share of a learner's runs (seeds) whose "
          f"mean return of the last {LAST} episodes exceeds τ; a curve further right is "
          "better. Step curves over the seeds as run (the legend gives their number).*", ""]
    L += ["## Time per run", "",
          "| learner | runs | episodes per run | wall s per run | CPU s per run |",
          "|---|---:|---:|---:|---:|"]
    for r in timing:
        L.append(f"| {LEARNERS.get(r['learner'], (r['learner'],))[0]} | {r['runs']} | "
                 f"{int(r['episodes']):,} | {float(r['wall_s_per_run']):.1f} | "
                 f"{float(r['cpu_s_per_run']):.1f} |")
    L += ["", TEXT_TIMING, "", "## What it means", ""]
    L += [" ".join(summary(tables, budgets)), "", TEXT_MEANING, ""]
    docs.mkdir(parents=True, exist_ok=True)
    (docs / "baselines.md").write_text("\n".join(L))
    if readme:
        rewrite_readme(readme, readme_text(tables, budgets))


TEXT_SETUP = """The thesis compares its tree features only with REPS on other features. This
experiment asks how today's standard learners do on the same task: Experiment 3's
(docs/exp3.md) cue ball at (−0.25, 0), the reward ball uniform in
[0.05, 0.15] × [−0.1, 0.1], one shot per episode, the reward of eq. 7.7.

```sh
make baselines        # venv with SB3 + pycma (PyPI), every run, data/baselines/*.csv, this file
```

The venv's packages are pinned by version and sha256 in
`scripts/baselines-requirements.txt` (`pip install --require-hashes`), so that two
installs train with the same code; torch's CPU path is used (one thread per run).

- **Start states**: seed k of every learner draws its n-th episode's start state from
  Experiment 3's stream of repetition k (`PocketEnv.reset(seed=1, options={'repetition':
  k})`, `experiment.seed` 1), so every learner of a seed meets the same states, and the
  comparisons are paired by seed.
- **Evaluation** as Experiment 3's: the mean return of the last 500 training episodes, at
  each budget of one long run per seed (a run is not restarted per budget; the value at
  2,200 episodes is what a 2,200-episode run gives, since nothing in a learner depends on
  the total). Also the return of the learner's deterministic action (SB3's
  `deterministic=True`, the CMA-ES mean) on 2,000 fresh start states (seed 1,000,000 + k,
  apart from every training stream). Experiment 3's learners keep no policy, so their
  deterministic evaluation is not measured.
- **Max speed**: Experiment 3 draws an action faster than `sim.max_speed` again from its
  Gaussian; SB3 and pycma hand the environment one action, which it scales down to
  `sim.max_speed` (`info['clipped']`, docs/python.md). SB3 acts in [−1, 1]² ×
  `sim.max_speed` (`normalize_actions=True`).
- **Budgets**: Experiment 3's 2,200 episodes, 10× and 25× that. On a shared 2-core
  machine the SB3 learners, whose SAC takes a gradient step at every step, ran up to
  {reached} episodes (`BASELINES_SAC_BUDGETS`, `BASELINES_SAC_TUNED_BUDGETS` and
  `BASELINES_PPO_BUDGETS` set them); the tables give each learner's seed count as run.
- **Tuned settings** (one per SB3 learner, chosen before any run, not searched): a smaller
  network (64-64) and learning rate 1e-3; PPO also updates every 200 episodes
  (Experiment 3's window) with minibatches of 50.
- **Slurm**: the poolreps learners are Experiment 3 runs and go through
  `poolreps sweep`/`collect` like any other (docs/cluster.md); the Python learners are not
  poolreps experiments, so `sweep` cannot schedule them: `scripts/baselines.sh one OUT
  LEARNER SEED BUDGETS` is one job, which a Slurm array can run, and
  `scripts/baselines_report.py collect` gathers the folder; `merge` puts the runs of
  some learners, made apart, in place of theirs in the committed CSVs."""

TEXT_TIMING = """Wall and CPU seconds of one run of the length shown (Python learners: at their
largest budget, measured inside the run, CPU of the process; poolreps learners: the whole
process for all its repetitions, divided by their number). The machine was shared with
other work at the time, so wall time is mostly waiting; CPU time is the cost."""

TEXT_MEANING = """For the thesis's question, whether tree features let REPS learn this task
well, the comparison that matters is against learners that need no features at all:
SAC and PPO learn their own from the state, CMA-ES searches the hand-crafted policy's
weights directly. The verdicts above are per budget; a learner with fewer than 10
seeds at a budget is reported with the seeds it has, and with fewer than 2 it has no
interval."""


def main(argv):
    if len(argv) == 4 and argv[1] == "collect":
        collect(argv[2], argv[3])
    elif len(argv) == 4 and argv[1] == "merge":
        merge(argv[2], argv[3])
    elif len(argv) in (4, 5) and argv[1] == "report":
        report(*argv[2:])
    else:
        print(__doc__, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
