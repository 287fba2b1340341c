#!/usr/bin/env python3
"""Statistics of the Experiment 3 power study from its merged runs.

Usage: power_stats.py STUDY [--docs DIR] [--boot B] [--seed S]

STUDY holds one merged Experiment 3 run per arm (folders event, stepped,
stepped05, as `poolreps merge` writes them) and timing.csv (scripts/power.sh).
For every claim of the thesis's section 7.5.2 it computes the paired effect
with a 95 % interval and a verdict per arm; also each variant's rank with its
bootstrap probability and the pocket counts with intervals. It writes
STUDY/power_{effects,pairwise,ranks,pockets,runs}.csv; with --docs,
DIR/power.md (from scripts/power_template.md) and DIR/figures/power_effects.png
and .svg. The verdicts on the claims: scripts/verdicts.py (docs/verdicts.md).
Exit codes: 1 usage, 2 missing or malformed input, 3 inconsistent data.
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import configparser
import csv
import math
import os
import re
import shlex
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import verdict_stats as vs  # noqa: E402  (after the path: importable from anywhere)

ARMS = ("event", "stepped", "stepped05")
TREES = ("nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a")
BASELINE = "baseline"
THESIS = TREES + (BASELINE,)
LABEL = {"nrvr_rs": "nrvr, s→rs", "rvr_rs": "rvr, s→rs", "nrvr_a": "nrvr, s→a",
         "rvr_a": "rvr, s→a", "baseline": "baseline (one node)",
         "handcrafted": "hand-crafted (beyond the thesis)"}
POCKETS = (-1, 0, 1, 2, 3, 4, 5)
LEVEL = 0.95
BOOT = 10000
SEED = 20251201
# quantities the claims name (returns are minus a distance in metres, eq. 7.7)
MARGIN = 0.1         # "approximately 0.1 greater than the baseline"
FAR = 0.3            # "balls with a distance greater than 0.3"
CONVERGED_AT = 0.6   # 1400 episodes = iteration 60 of 100 at the thesis's settings
RULES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "study",
                     "rules.ini")


class Fail(Exception):
    """An error for the user: one line, and the exit code."""

    def __init__(self, msg, code):
        super().__init__(msg)
        self.code = code


# ---------------------------------------------------------------- intervals

def paired_t(d, level=LEVEL):
    """Mean of the paired differences d and its t interval:
    mean ± t_{(1+level)/2, n-1} · s / √n. NaN pairs are dropped.
    Returns (mean, lo, hi, n)."""
    d = np.asarray(d, float)
    d = d[np.isfinite(d)]
    n = len(d)
    if n < 2:
        m = float(d[0]) if n else math.nan
        return m, math.nan, math.nan, n
    return (*vs.t_interval(d, level), n)


def resamples(n, boot, seed):
    """Bootstrap resamples of n repetitions: a (boot, n) index array from a
    seeded numpy Generator. Every statistic of an arm uses the same
    resamples, so pairs stay pairs and ranks are joint."""
    return np.random.default_rng(seed).integers(0, n, size=(boot, n))


def percentile_ci(values, level=LEVEL):
    """Percentile interval of bootstrap replicates (NaN replicates ignored)."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if not len(v):
        return math.nan, math.nan
    lo, hi = np.percentile(v, [50 * (1 - level), 50 * (1 + level)])
    return float(lo), float(hi)


def boot_mean_ci(x, idx, level=LEVEL):
    """Percentile interval of the mean of per-repetition values x (the last
    axis indexes repetitions)."""
    return percentile_ci(np.asarray(x, float)[idx].mean(axis=-1), level)


def rank_probabilities(means, idx):
    """means: (k, n) per-variant run means. Rank 1 = highest mean. Returns
    a (k, k) array P[v, r-1] = share of bootstrap resamples in which variant
    v has rank r, and the ranks of the full sample."""
    boot = means[:, idx].mean(axis=2)                       # (k, B)
    order = np.argsort(-boot, axis=0, kind="stable")
    ranks = np.empty_like(order)
    np.put_along_axis(ranks, order, np.arange(len(means))[:, None], axis=0)
    k = len(means)
    prob = np.stack([(ranks == r).mean(axis=1) for r in range(k)], axis=1)
    point = np.empty(k, int)
    point[np.argsort(-means.mean(axis=1), kind="stable")] = np.arange(k)
    return prob, point + 1


# ---------------------------------------------------------------- input

def read_config(path):
    cfg = configparser.ConfigParser(inline_comment_prefixes=(";",))
    try:
        with open(path, encoding="utf-8") as f:
            cfg.read_file(f)
    except OSError as e:
        raise Fail(f"{path}: {e.strerror}", 2) from e
    except configparser.Error as e:
        raise Fail(f"{path}: not an INI file ({e.__class__.__name__})", 2) from e
    return cfg


def cfg_get(cfg, path, key, conv=str):
    section, name = key.split(".")
    try:
        return conv(cfg.get(section, name))
    except (configparser.Error, ValueError) as e:
        raise Fail(f"{path}: {key}: missing or malformed", 2) from e


EPISODE_COLUMNS = ("repetition", "policy", "iteration", "vx", "vy", "return", "rx", "ry",
                   "pocket", "hit")


def read_episodes(path):
    """{(policy, repetition): columns as float arrays} from exp3_episodes.csv."""
    runs = {}
    try:
        f = open(path, newline="", encoding="utf-8")
    except OSError as e:
        raise Fail(f"{path}: {e.strerror}", 2) from e
    with f:
        reader = csv.reader(f)
        header = next(reader, None)
        if header is None:
            raise Fail(f"{path}: empty file", 2)
        missing = [c for c in EPISODE_COLUMNS if c not in header]
        if missing:
            raise Fail(f"{path}:1: no column {missing[0]}", 2)
        col = [header.index(c) for c in EPISODE_COLUMNS]
        ip = col[1]
        num = [c for i, c in enumerate(col) if i != 1]
        for line, row in enumerate(reader, start=2):
            try:
                values = [float(row[c]) for c in num]
                key = (row[ip], int(values[0]))
            except (IndexError, ValueError) as e:
                raise Fail(f"{path}:{line}: malformed row", 2) from e
            runs.setdefault(key, []).append(values)
    return {k: np.array(v) for k, v in runs.items()}


class Arm:
    """One merged arm: per-run quantities over each run's last episodes.
    min_reps: the fewest repetitions accepted (1 for a single job's folder,
    whose runs are pooled with others before any interval)."""

    def __init__(self, name, folder, min_reps=2):
        self.name = name
        self.folder = folder
        cpath = os.path.join(folder, "config.ini")
        cfg = read_config(cpath)
        self.mode = cfg_get(cfg, cpath, "sim.mode")
        self.dt = cfg_get(cfg, cpath, "sim.dt", float)
        self.seed = cfg_get(cfg, cpath, "experiment.seed", int)
        self.final = cfg_get(cfg, cpath, "exp3.final_episodes", int)
        self.iterations = cfg_get(cfg, cpath, "exp3.iterations", int)
        self.samples = cfg_get(cfg, cpath, "exp3.samples", int)
        self.init = cfg_get(cfg, cpath, "exp3.init_samples", int)
        self.policies = cfg_get(cfg, cpath, "exp3.policies").split(",")
        length = cfg_get(cfg, cpath, "table.length", float)
        width = cfg_get(cfg, cpath, "table.width", float)
        self.targets = [int(t) for t in cfg_get(cfg, cpath, "reward.targets").split(",")]
        scratch = cfg_get(cfg, cpath, "reward.scratch_penalty", float)
        self.version = provenance(os.path.join(folder, "provenance.txt")).get("version", "?")
        missing = [p for p in THESIS if p not in self.policies]
        if missing:
            raise Fail(f"{cpath}: exp3.policies lacks {missing[0]}", 2)
        # pocket ids 0..5: (-L/2,-W/2), (0,-W/2), (L/2,-W/2), (-L/2,W/2), (0,W/2), (L/2,W/2)
        centres = {i: ((i % 3 - 1) * length / 2, (1 if i >= 3 else -1) * width / 2)
                   for i in range(6)}
        self.target_xy = np.array([centres[t] for t in self.targets])

        epath = os.path.join(folder, "exp3_episodes.csv")
        runs = read_episodes(epath)
        self.reps = sorted({r for _, r in runs})
        if len(self.reps) < min_reps:
            raise Fail(f"{epath}: {len(self.reps)} repetition(s); intervals need 2 or more", 3)
        length_run = self.init + self.iterations * self.samples
        for p in self.policies:
            for r in self.reps:
                n = len(runs.get((p, r), ()))
                if n != length_run:
                    raise Fail(f"{epath}: policy {p} repetition {r}: {n} episodes, "
                               f"expected {length_run}", 3)
        # (policy, repetition, episode, column) without the repetition column
        data = np.stack([np.stack([runs[(p, r)][:, 1:] for r in self.reps])
                         for p in self.policies])
        it, vx, vy, ret, rx, ry, pocket, hit = np.moveaxis(data, -1, 0)
        dist = np.min(np.hypot(rx[..., None] - self.target_xy[:, 0],
                               ry[..., None] - self.target_xy[:, 1]), axis=-1)
        if scratch == 0:
            # a touched ball's return is minus this distance (eq. 7.7): checks
            # the pocket geometry above against the simulator's
            gap = np.abs(ret + dist)[hit == 1]
            if gap.size and gap.max() > 1e-9:
                raise Fail(f"{epath}: returns of hit shots differ from minus the distance to "
                           f"the nearest target pocket by {gap.max():.3g}", 3)
        last = slice(-self.final, None)
        fr, fp, fd = ret[..., last], pocket[..., last], dist[..., last]
        self.ret = fr.mean(axis=-1)                                   # (P, R)
        self.sd = fr.std(axis=-1, ddof=1)
        self.counts = np.stack([(fp == k).sum(axis=-1) for k in POCKETS], axis=-1)  # (P,R,7)
        tmask = np.isin(fp, self.targets)
        self.target = tmask.sum(axis=-1).astype(float)
        self.speed = np.median(np.hypot(vx, vy)[..., last], axis=-1)
        miss = ~tmask
        with np.errstate(invalid="ignore"):
            self.miss_dist = np.where(miss, fd, 0).sum(axis=-1) / miss.sum(axis=-1)
        self.far = (fd > FAR).mean(axis=-1)
        k0 = round(CONVERGED_AT * self.iterations)
        k1 = k0 + (self.iterations - k0) // 2
        early = (it > k0) & (it <= k1)
        late = it > k1
        self.conv_iters = (k0, k1, self.iterations)
        # mean return per iteration 1..iterations of each run (Fig. 7.7's curve)
        self.curve = np.stack([(ret * (it == k)).sum(-1) / (it == k).sum(-1)
                               for k in range(1, self.iterations + 1)], axis=-1)
        with np.errstate(invalid="ignore"):
            self.change = ((ret * late).sum(-1) / late.sum(-1)
                           - (ret * early).sum(-1) / early.sum(-1))
        self.check_final(os.path.join(folder, "exp3_final.csv"))

    def check_final(self, path):
        """The per-run means must equal poolreps's own exp3_final.csv."""
        try:
            with open(path, newline="", encoding="utf-8") as f:
                rows = list(csv.DictReader(f))
        except OSError as e:
            raise Fail(f"{path}: {e.strerror}", 2) from e
        seen = 0
        for row in rows:
            try:
                r = int(row["repetition"])
                if r < 0:
                    continue
                p = self.policies.index(row["policy"])
                j = self.reps.index(r)
                mean, tgt = float(row["mean_return"]), int(row["pocketed_target"])
            except (KeyError, ValueError) as e:
                raise Fail(f"{path}: malformed row {row}", 2) from e
            if abs(mean - self.ret[p, j]) > 1e-9 * max(1, abs(mean)) or tgt != self.target[p, j]:
                raise Fail(f"{path}: {row['policy']} repetition {r} differs from "
                           "exp3_episodes.csv", 3)
            seen += 1
        if seen != len(self.policies) * len(self.reps):
            raise Fail(f"{path}: {seen} runs, expected {len(self.policies) * len(self.reps)}", 3)

    def row(self, policy):
        return self.policies.index(policy)

    @property
    def label(self):
        if self.mode == "event":
            return "event"
        return f"stepped, dt {self.dt * 1000:g} ms"


def provenance(path):
    try:
        with open(path, encoding="utf-8") as f:
            return dict(line.rstrip("\n").split(": ", 1) for line in f if ": " in line)
    except OSError:
        return {}


# ---------------------------------------------------------------- analysis

def share2(counts, idx):
    """Share of the target-pocketed balls in pocket 2 (the lower target
    pocket, y < 0): pooled estimate and its bootstrap interval."""
    n2 = counts[:, POCKETS.index(2)].astype(float)
    n5 = counts[:, POCKETS.index(5)].astype(float)
    tot = n2.sum() + n5.sum()
    est = n2.sum() / tot if tot else math.nan
    with np.errstate(invalid="ignore", divide="ignore"):
        reps = n2[idx].sum(axis=1) / (n2[idx].sum(axis=1) + n5[idx].sum(axis=1))
    return (est,) + percentile_ci(reps), int(tot)


def fmt(x, signed=True, digits=3):
    if not math.isfinite(x):
        return "n/a"
    s = f"{x:+.{digits}f}" if signed else f"{x:.{digits}f}"
    return s.replace("-", "−")


def fmt_ci(est, lo, hi, signed=True, digits=3):
    if not math.isfinite(lo):
        return f"{fmt(est, signed, digits)} (no interval)"
    return f"{fmt(est, signed, digits)} [{fmt(lo, signed, digits)}, {fmt(hi, signed, digits)}]"


class Study:
    """Every statistic of every arm."""

    def __init__(self, arms, boot, seed):
        self.arms = arms
        self.boot = boot
        self.seed = seed
        self.idx = {a.name: resamples(len(a.reps), boot, seed) for a in arms}
        self.considerable = considerable()
        self.effects, self.pairwise, self.ranks, self.pockets, self.perrun = [], [], [], [], []
        for a in arms:
            self.analyse(a)

    def paired(self, a, x, v, w):
        """Paired t interval of x[v] - x[w] over the repetitions."""
        return paired_t(x[a.row(v)] - x[a.row(w)])

    def analyse(self, a):
        idx = self.idx[a.name]
        b = a.row(BASELINE)
        for p in a.policies:
            i = a.row(p)
            d = a.ret[i] - a.ret[b]
            m, lo, hi, n = paired_t(d)
            blo, bhi = boot_mean_ci(d, idx)
            mean, mlo, mhi, _ = paired_t(a.ret[i])
            with np.errstate(invalid="ignore", divide="ignore"):
                corr = float(np.corrcoef(a.ret[i], a.ret[b])[0, 1]) if p != BASELINE else 1.0
            self.effects.append(dict(arm=a.name, policy=p, n=n, mean_return=mean,
                                     mean_lo=mlo, mean_hi=mhi,
                                     std_runs=float(a.ret[i].std(ddof=1)),
                                     effect=m, t_lo=lo, t_hi=hi, boot_lo=blo, boot_hi=bhi,
                                     corr=corr))
            for k, pk in enumerate(POCKETS):
                c = a.counts[i, :, k].astype(float)
                clo, chi = boot_mean_ci(c, idx)
                self.pockets.append(dict(arm=a.name, policy=p, pocket=pk, total=int(c.sum()),
                                         per_run=float(c.mean()), lo=clo, hi=chi))
            (s2, s2lo, s2hi), tot = share2(a.counts[i], idx)
            self.perrun.append(dict(
                arm=a.name, policy=p, sd=float(a.sd[i].mean()),
                target=float(a.target[i].mean()), speed=float(a.speed[i].mean()),
                miss_dist=float(np.nanmean(a.miss_dist[i])), far=float(a.far[i].mean()),
                change=paired_t(a.change[i]), share2=(s2, s2lo, s2hi), target_total=tot))
        for v in TREES:
            for w in TREES:
                if v < w:
                    m, lo, hi, n = self.paired(a, a.ret, v, w)
                    self.pairwise.append(dict(arm=a.name, a=v, b=w, diff=m, lo=lo, hi=hi))
        means = np.stack([a.ret[a.row(p)] for p in THESIS])
        prob, point = rank_probabilities(means, idx)
        for j, p in enumerate(THESIS):
            self.ranks.append(dict(arm=a.name, policy=p, rank=int(point[j]),
                                   prob=[float(x) for x in prob[j]]))


def considerable():
    """The "considerably better" margin of the verdict rules (data/study/rules.ini)."""
    cfg = configparser.ConfigParser(interpolation=None)
    if not cfg.read(RULES, encoding="utf-8"):
        raise Fail(f"{RULES}: missing or unreadable", 2)
    try:
        return cfg.getfloat("margins", "considerable")
    except (configparser.Error, ValueError) as e:
        raise Fail(f"{RULES}: margins.considerable: missing or malformed", 2) from e


# ---------------------------------------------------------------- output

def write_csv(path, header, rows):
    tmp = f"{path}.tmp.{os.getpid()}"
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        w.writerows([[f"{v:.17g}" if isinstance(v, float) else v for v in r] for r in rows])
    os.replace(tmp, path)


def write_study_csvs(study, out):
    write_csv(os.path.join(out, "power_effects.csv"),
              ["arm", "policy", "repetitions", "mean_return", "mean_lo", "mean_hi", "std_runs",
               "effect", "t_lo", "t_hi", "boot_lo", "boot_hi", "corr_baseline"],
              [[e["arm"], e["policy"], e["n"], e["mean_return"], e["mean_lo"], e["mean_hi"],
                e["std_runs"], e["effect"], e["t_lo"], e["t_hi"], e["boot_lo"], e["boot_hi"],
                e["corr"]] for e in study.effects])
    write_csv(os.path.join(out, "power_pairwise.csv"), ["arm", "a", "b", "diff", "t_lo", "t_hi"],
              [[p["arm"], p["a"], p["b"], p["diff"], p["lo"], p["hi"]] for p in study.pairwise])
    write_csv(os.path.join(out, "power_ranks.csv"), ["arm", "policy", "rank", "probability"],
              [[r["arm"], r["policy"], k + 1, pr] for r in study.ranks
               for k, pr in enumerate(r["prob"])])
    write_csv(os.path.join(out, "power_pockets.csv"),
              ["arm", "policy", "pocket", "total", "per_run", "lo", "hi"],
              [[p["arm"], p["policy"], p["pocket"], p["total"], p["per_run"], p["lo"], p["hi"]]
               for p in study.pockets])
    write_csv(os.path.join(out, "power_runs.csv"),
              ["arm", "policy", "episode_std", "target_per_run", "median_speed", "miss_distance",
               "far_share", "change", "change_lo", "change_hi", "share2", "share2_lo",
               "share2_hi"],
              [[r["arm"], r["policy"], r["sd"], r["target"], r["speed"], r["miss_dist"], r["far"],
                r["change"][0], r["change"][1], r["change"][2], *r["share2"]]
               for r in study.perrun])



def draw_effects(study, png, svg):
    """Paired effect on the mean return against the baseline, with 95 % t
    intervals, per variant: event mode left, stepped mode (1 and 0.5 ms)
    right. Self-contained so that a shared plot style can replace it."""
    import figstyle as fs
    import matplotlib.pyplot as plt
    fs.setup()
    panels = [("event", ["event"]), ("stepped", ["stepped", "stepped05"])]
    present = {a.name: a for a in study.arms}
    variants = [p for p in study.arms[0].policies if p != BASELINE]
    style = {"event": ("o", fs.PALETTE["blue"]), "stepped": ("s", fs.PALETTE["vermillion"]),
             "stepped05": ("^", fs.PALETTE["orange"])}
    eff = {(e["arm"], e["policy"]): e for e in study.effects}
    fig, axes = plt.subplots(1, 2, figsize=(fs.WIDTH["full"], 3.6), sharey=True, sharex=True)
    handles = []
    for ax, (title, arms) in zip(axes, panels):
        arms = [x for x in arms if x in present]
        for k, arm in enumerate(arms):
            off = (k - (len(arms) - 1) / 2) * 0.22
            ys = [len(variants) - 1 - j - off for j in range(len(variants))]
            e = [eff[(arm, p)] for p in variants]
            x = np.array([v["effect"] for v in e])
            err = np.array([[v["effect"] - v["t_lo"] for v in e],
                            [v["t_hi"] - v["effect"] for v in e]])
            m, c = style[arm]
            handles.append(ax.errorbar(x, ys, xerr=err, fmt=m, color=c, capsize=3, ms=5,
                                       label=present[arm].label))
        zero = ax.axvline(0, color=fs.PALETTE["black"], lw=0.8, label="no difference")
        thesis = ax.axvline(MARGIN, color=fs.PALETTE["grey"], lw=0.8, ls=":",
                            label=f"{MARGIN}: thesis's nrvr, s→rs")
        big = ax.axvline(study.considerable, color=fs.PALETTE["grey"], lw=0.8, ls="--",
                         label=f"{study.considerable:g}: \"considerably better\"")
        ax.set_title(f"{title} mode")
        ax.set_xlabel(fs.label("return − baseline's (paired)", "m"))
        ax.grid(axis="y", visible=False)
    axes[0].set_yticks(range(len(variants)))
    axes[0].set_yticklabels([LABEL.get(p, p) for p in reversed(variants)])
    fig.legend(handles=handles + [zero, thesis, big], loc="lower center", ncol=3, frameon=False)
    fig.suptitle(f"Experiment 3, {len(study.arms[0].reps)} repetitions, each run's last "
                 f"{study.arms[0].final} episodes: 95 % paired t intervals")
    fig.tight_layout(rect=(0, 0.13, 1, 1))
    stem = os.path.splitext(os.path.basename(png))[0]
    assert svg == os.path.join(os.path.dirname(png), stem + ".svg")
    fs.save(fig, os.path.dirname(png) or ".", stem)


def md_table(header, rows, align=None):
    align = align or ["---"] + ["---:"] * (len(header) - 1)
    out = ["| " + " | ".join(header) + " |", "|" + "|".join(align) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def render(study, timing, template):
    arms = study.arms
    names = [a.name for a in arms]
    head = [a.label for a in arms]
    first = arms[0]
    eff = {(e["arm"], e["policy"]): e for e in study.effects}
    effect_tables = []
    for a in arms:
        rows = []
        for p in a.policies:
            e = eff[(a.name, p)]
            diff = "0" if p == BASELINE else fmt_ci(e["effect"], e["t_lo"], e["t_hi"])
            boot = "–" if p == BASELINE else f"[{fmt(e['boot_lo'])}, {fmt(e['boot_hi'])}]"
            corr = "–" if p == BASELINE else fmt(e["corr"], digits=2)
            rows.append([LABEL.get(p, p), fmt_ci(e["mean_return"], e["mean_lo"], e["mean_hi"]),
                         fmt(e["std_runs"], False), diff, boot, corr])
        effect_tables.append(f"**{a.label}**\n\n" + md_table(
            ["policy", "mean return [95 % t]", "SD over runs",
             "paired vs baseline [95 % t]", "bootstrap 95 %", "corr. with baseline"], rows))
    pair_rows = []
    pw = {(p["arm"], p["a"], p["b"]): p for p in study.pairwise}
    for v in TREES:
        for w in TREES:
            if v < w:
                pair_rows.append([f"{v} − {w}"] + [fmt_ci(pw[(n, v, w)]["diff"],
                                                          pw[(n, v, w)]["lo"],
                                                          pw[(n, v, w)]["hi"]) for n in names])
    rank_tables = []
    for a in arms:
        rows = []
        for r in (r for r in study.ranks if r["arm"] == a.name):
            rows.append([LABEL[r["policy"]], r["rank"]] + [f"{x:.3f}" for x in r["prob"]])
        rank_tables.append(f"**{a.label}**\n\n" + md_table(
            ["policy", "rank"] + [f"P(rank {k})" for k in range(1, len(THESIS) + 1)], rows))
    pocket_tables = []
    pk = {(p["arm"], p["policy"], p["pocket"]): p for p in study.pockets}
    for a in arms:
        rows = []
        for p in a.policies:
            cells = []
            for k in POCKETS:
                c = pk[(a.name, p, k)]
                cells.append(f"{c['per_run']:.2f} [{c['lo']:.2f}, {c['hi']:.2f}] ({c['total']})")
            rows.append([LABEL.get(p, p)] + cells)
        pocket_tables.append(f"**{a.label}**\n\n" + md_table(
            ["policy", "none"] + [f"pocket {k}{' (target)' if k in a.targets else ''}"
                                  for k in POCKETS[1:]], rows))
    run_tables = []
    for a in arms:
        rows = []
        for r in (r for r in study.perrun if r["arm"] == a.name):
            s2 = r["share2"]
            rows.append([LABEL.get(r["policy"], r["policy"]), f"{r['sd']:.3f}",
                         f"{r['target']:.2f}", f"{r['speed']:.2f}", f"{r['miss_dist']:.3f}",
                         f"{100 * r['far']:.1f} %", fmt_ci(*r["change"][:3]),
                         f"{fmt_ci(*s2, signed=False, digits=2)} of {r['target_total']}"])
        run_tables.append(f"**{a.label}**\n\n" + md_table(
            ["policy", "episode SD", "target balls per run", "median speed m/s",
             "missed-ball distance m", f"beyond {FAR} m", "late − early [95 % t]",
             "pocket-2 share [95 % bootstrap]"], rows))
    trow = [[t["phase"], f"{float(t['wall_seconds']):.0f}", t["jobs"], t["cores"],
             t["load_before"], t["load_after"]] for t in timing]
    wall = sum(float(t["wall_seconds"]) for t in timing)
    cpu = sum(cpu_seconds(a) for a in arms)
    cpu_text = f"{cpu:.0f} s ({cpu / 60:.1f} min)" if math.isfinite(cpu) else "not recorded"
    k0, k1, kn = first.conv_iters
    values = {
        "reps": str(len(first.reps)), "boot": str(study.boot), "seed": str(study.seed),
        "final": str(first.final), "version": first.version, "exp_seed": str(first.seed),
        "episodes": str(first.init + first.iterations * first.samples),
        "arms": "; ".join(f"`{a.name}`: {a.label}" for a in arms),
        "conv": f"iterations {span(k0 + 1, k1)} against {span(k1 + 1, kn)}",
        "init": str(first.init),
        "policies": ", ".join(first.policies),
        "overrides": overrides(first),
        "effects": "\n\n".join(effect_tables),
        "pairwise": md_table(["tree variants"] + head, pair_rows),
        "ranks": "\n\n".join(rank_tables),
        "pockets": "\n\n".join(pocket_tables),
        "perrun": "\n\n".join(run_tables),
        "timing": md_table(["phase", "wall s", "jobs at once", "cores", "load before",
                            "load after"], trow),
        "wall": f"{wall:.0f} s ({wall / 60:.1f} min)",
        "cpu": cpu_text,
        "considerable": f"{study.considerable:g}", "far": str(FAR),
    }
    used = set(re.findall(r"\{\{(\w+)\}\}", template))
    if used - values.keys():
        raise Fail(f"template: unknown placeholder {sorted(used - values.keys())[0]}", 2)
    return re.sub(r"\{\{(\w+)\}\}", lambda m: values[m.group(1)], template)


def span(a, b):
    return str(a) if a == b else f"{a}–{b}"


def overrides(arm):
    """The study-wide --set options of the arm's runs (their provenance),
    less what power.sh sets per arm and per job."""
    prov = provenance(os.path.join(os.path.dirname(arm.folder), "runs", arm.name, "point-0",
                                   "runs", "rep-0", "provenance.txt"))
    words = shlex.split(prov.get("command", ""))
    own = ("sim.mode=", "sim.dt=", "experiment.repetitions=", "experiment.repetition=",
           "experiment.threads=")
    sets = [v for k, v in zip(words, words[1:]) if k == "--set" and not v.startswith(own)]
    return ("no other overrides" if not sets else
            "these overrides: " + ", ".join(f"`{v}`" for v in sets))


def cpu_seconds(arm):
    """CPU seconds of an arm's runs, from each repetition's provenance."""
    runs = os.path.join(os.path.dirname(arm.folder), "runs", arm.name, "point-0", "runs")
    return sum(float(provenance(os.path.join(runs, f"rep-{r}", "provenance.txt"))
                     .get("cpu_seconds", "nan")) for r in arm.reps)


def read_timing(path):
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        raise Fail(f"{path}: {e.strerror}", 2) from e
    need = ("phase", "wall_seconds", "jobs", "cores", "load_before", "load_after")
    for line, r in enumerate(rows, start=2):
        if any(r.get(k) in (None, "") for k in need):
            raise Fail(f"{path}:{line}: missing a column of {','.join(need)}", 2)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("study")
    ap.add_argument("--docs", help="write DOCS/power.md and DOCS/figures/power_effects.*")
    ap.add_argument("--boot", type=int, default=BOOT, help=f"bootstrap resamples ({BOOT})")
    ap.add_argument("--seed", type=int, default=SEED, help=f"bootstrap seed ({SEED})")
    args = ap.parse_args()
    if args.boot < 100:
        ap.error("--boot must be at least 100")
    try:
        arms = [Arm(n, os.path.join(args.study, n)) for n in ARMS
                if os.path.isdir(os.path.join(args.study, n))]
        if not arms or arms[0].name != "event" or "stepped" not in [a.name for a in arms]:
            raise Fail(f"{args.study}: needs the merged arms event and stepped", 2)
        for a in arms[1:]:
            if a.reps != arms[0].reps or a.policies != arms[0].policies:
                raise Fail(f"{a.folder}: repetitions or policies differ from "
                           f"{arms[0].folder}", 3)
        study = Study(arms, args.boot, args.seed)
        write_study_csvs(study, args.study)
        if args.docs:
            timing = read_timing(os.path.join(args.study, "timing.csv"))
            here = os.path.dirname(os.path.abspath(__file__))
            with open(os.path.join(here, "power_template.md"), encoding="utf-8") as f:
                template = f.read()
            text = render(study, timing, template)
            figs = os.path.join(args.docs, "figures")
            os.makedirs(figs, exist_ok=True)
            draw_effects(study, os.path.join(figs, "power_effects.png"),
                         os.path.join(figs, "power_effects.svg"))
            tmp = os.path.join(args.docs, f"power.md.tmp.{os.getpid()}")
            with open(tmp, "w", encoding="utf-8") as f:
                f.write(text)
            os.replace(tmp, os.path.join(args.docs, "power.md"))
    except Fail as e:
        print(f"power_stats: {e}", file=sys.stderr)
        return e.code
    except OSError as e:
        print(f"power_stats: {e.filename}: {e.strerror}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
