#!/usr/bin/env python3
"""Every verdict the project prints on the thesis's claims, from the study.

Usage: verdicts.py DATA [--check] [--docs DIR] [--readme FILE]

DATA holds rules.ini (the rules, stated before the numbers) and the compact
results scripts/study_extract.py wrote (`make study`). Writes DIR/verdicts.md
(default docs/), DIR/verdicts_report.html (the report page's claims section),
DIR/figures/study_seeds.png and .svg (scripts/plot_study.py), the README's
table between <!-- verdicts:begin --> and <!-- verdicts:end --> and its
sentence on the sphere benchmark between <!-- sphere:begin --> and
<!-- sphere:end -->;
all or nothing, only once every input has been read and checked. With
--check nothing is written: exit 1 when a file differs from what DATA gives.
Exit codes: 1 usage or a difference (--check), 2 missing or malformed input,
3 partial or mixed-configuration results.
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import configparser
import csv
import html
import math
import os
import sys
import tempfile
from collections import defaultdict

import numpy as np

import exp_data
import verdict_stats as vs
from claim_ids import CLAIM_IDS, EXP3_CLAIMS, EXPERIMENT

MODES = ("event", "stepped", "stepped05")
MODE_LABEL = {"event": "event", "stepped": "stepped, dt 1 ms", "stepped05": "stepped, dt 0.5 ms"}
MODE_SIM = {"event": ("event", None), "stepped": ("stepped", 0.001),
            "stepped05": ("stepped", 0.0005)}
VARYING = {"exp3": ("sim.mode", "sim.dt"), "sphere": ("policy.cov_center", "bench.method"), "exp1": ("experiment.seed", "sim.mode", "sim.dt"),
           "exp2": ("experiment.seed", "sim.mode", "sim.dt")}
TREES = ("nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a")
THESIS = TREES + ("baseline",)
FILES = ("manifest.csv", "exp3_runs.csv", "exp3_curves.csv", "exp1_mse.csv", "exp1_map.csv",
         "exp2_returns.csv", "sphere_curves.csv", "timing.csv")
HOLDOUT_FILES = ("manifest.csv", "exp3_runs.csv", "exp3_curves.csv", "timing.csv")
BEGIN, END = "<!-- verdicts:begin -->", "<!-- verdicts:end -->"
SPHERE_BEGIN, SPHERE_END = "<!-- sphere:begin -->", "<!-- sphere:end -->"
EXP3_BEGIN, EXP3_END = "<!-- exp3-table:begin -->", "<!-- exp3-table:end -->"
# the sphere benchmark's runs: (method, its poolreps settings)
SPHERE = {"creps_old": {"policy.cov_center": "old", "bench.method": "creps"},
          "creps_new": {"policy.cov_center": "new", "bench.method": "creps"},
          "ccmaes": {"bench.method": "ccmaes"}}


# a margin is a constant in one of these units, never computed from the data
MARGIN_UNITS = ("m", "share", "relative")


class Fail(Exception):
    def __init__(self, msg, code):
        super().__init__(msg)
        self.code = code


# ---------------------------------------------------------------- input

def read_rules(path):
    cfg = configparser.ConfigParser(interpolation=None)
    try:
        with open(path, encoding="utf-8") as f:
            cfg.read_file(f)
    except OSError as e:
        raise Fail(f"{path}: {e.strerror}", 2) from e
    except configparser.Error as e:
        raise Fail(f"{path}: not an INI file ({e.__class__.__name__})", 2) from e
    rules = {"margins": {}, "claims": {}}
    try:
        st = cfg["study"]
        rules["alpha"] = st.getfloat("alpha")
        rules["converged_at"] = st.getint("converged_at")
        rules["many"] = st.getint("many")
        rules["power"] = st.getfloat("power")
        m = cfg["margins"]
        for k in m:
            if "." not in k:
                rules["margins"][k] = {"value": m.getfloat(k), "unit": m[f"{k}.unit"],
                                       "why": m[f"{k}.why"]}
                if rules["margins"][k]["unit"] not in MARGIN_UNITS:
                    raise ValueError(f"{k}.unit")
        for cid in CLAIM_IDS:
            s = cfg[f"claim.{cid}"]
            rules["claims"][cid] = {k: s[k] for k in ("section", "short", "words", "reading",
                                                      "test", "margins")}
    except (KeyError, ValueError) as e:
        raise Fail(f"{path}: missing or malformed {e.args[0] if e.args else 'key'}", 2) from e
    extra = [s for s in cfg.sections() if s.startswith("claim.") and s[6:] not in CLAIM_IDS]
    if extra:
        raise Fail(f"{path}: [{extra[0]}] is no claim of the study", 2)
    return rules


def read_csv(path, need):
    try:
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            missing = [c for c in need if c not in (reader.fieldnames or [])]
            if missing:
                raise Fail(f"{path}:1: no column {missing[0]}", 2)
            rows = list(reader)
    except OSError as e:
        raise Fail(f"{path}: {e.strerror or 'unreadable'}", 2) from e
    for line, r in enumerate(rows, start=2):
        if None in r.values() or None in r:
            raise Fail(f"{path}:{line}: wrong number of fields", 2)
    return rows


def number(path, line, row, key, conv=float):
    try:
        v = conv(row[key])
    except ValueError as e:
        raise Fail(f"{path}:{line}: {key}: not a number: {row[key]!r}", 2) from e
    if isinstance(v, float) and not math.isfinite(v):
        raise Fail(f"{path}:{line}: {key}: not finite", 2)
    return v


def read_manifest(path, full=True):
    """{experiment: {unit: {key: value}}}, every unit of an experiment with the
    same configuration but for its VARYING keys. full: the study (every
    experiment), else the holdout (Experiment 3 only)."""
    units = defaultdict(dict)
    for r in read_csv(path, ("experiment", "unit", "key", "value")):
        units[r["experiment"]].setdefault(r["unit"], {})[r["key"]] = r["value"]
    if not full and set(units) != {"exp3"}:
        raise Fail(f"{path}: the holdout holds Experiment 3 only", 3)
    for exp in VARYING if full else ("exp3",):
        if exp not in units:
            raise Fail(f"{path}: no configuration of {exp}", 3)
        ref_unit, ref = next(iter(units[exp].items()))
        for unit, cfg in units[exp].items():
            for k in sorted(set(ref) | set(cfg)):
                if k not in VARYING[exp] and ref.get(k) != cfg.get(k):
                    raise Fail(f"{path}: mixed configurations: {exp} {unit} has {k} = "
                               f"{cfg.get(k, '(none)')}, {exp} {ref_unit} has "
                               f"{ref.get(k, '(none)')}", 3)
    arms = units["exp3"]
    for mode in MODES:
        if mode not in arms:
            raise Fail(f"{path}: no Experiment 3 arm {mode}", 3)
    if set(arms) != set(MODES):
        raise Fail(f"{path}: unknown Experiment 3 arm {sorted(set(arms) - set(MODES))[0]}", 3)
    if not full:
        check_sim(path, units)
        return units
    for exp in ("exp1", "exp2"):
        have = {u.split("/")[0] for u in units[exp]}
        if have != set(MODES):
            raise Fail(f"{path}: {exp} has arms {', '.join(sorted(have))}, not "
                       f"{', '.join(MODES)}", 3)
    for method, want in SPHERE.items():
        cfg = units["sphere"].get(method)
        if cfg is None:
            raise Fail(f"{path}: no sphere benchmark run {method}", 3)
        for k, v in want.items():
            if cfg.get(k) != v:
                raise Fail(f"{path}: sphere {method} has {k} = {cfg.get(k)}, not {v}", 3)
    check_sim(path, units)
    return units


def check_sim(path, units):
    """Every unit's physics is its arm's."""
    for exp, us in units.items():
        if exp == "sphere":
            continue
        for unit, cfg in us.items():
            mode = unit.split("/")[0]
            sim, dt = MODE_SIM.get(mode, (None, None))
            if cfg.get("sim.mode") != sim or (dt and float(cfg.get("sim.dt", "nan")) != dt):
                raise Fail(f"{path}: {exp} {unit} has sim.mode = {cfg.get('sim.mode')}, "
                           f"sim.dt = {cfg.get('sim.dt')}", 3)


def expect_all(path, have, want, what):
    """Refuse a file that lacks a key of want or has one want lacks."""
    missing = sorted(want - have)
    if missing:
        raise Fail(f"{path}: no row for {what(missing[0])}", 3)
    extra = sorted(have - want)
    if extra:
        raise Fail(f"{path}: a row for {what(extra[0])}, which the manifest does not have", 3)


def int_list(cfg, key):
    return [int(x) for x in cfg[key].split(",")]


def load(data):
    for name in FILES:
        if not os.path.isfile(os.path.join(data, name)):
            raise Fail(f"{os.path.join(data, name)}: missing (run make study)", 2)
    p = lambda name: os.path.join(data, name)  # noqa: E731
    d = load_exp3(data, read_manifest(p("manifest.csv")))
    units = d["units"]
    d["exp1"], d["exp1_map"] = read_exp1(p("exp1_mse.csv"), p("exp1_map.csv"), units["exp1"])
    d["exp2"] = read_exp2(p("exp2_returns.csv"), units["exp2"])
    seeds = {e: {(u.split("/")[0], int(u.split("/")[1])) for u in units[e]}
             for e in ("exp1", "exp2")}
    d["seeds"] = sorted({s for _, s in seeds["exp1"]})
    if seeds["exp1"] != seeds["exp2"] or seeds["exp1"] != {(a, s) for a in MODES
                                                             for s in d["seeds"]}:
        raise Fail(f"{p('manifest.csv')}: Experiments 1 and 2 ran different seeds "
                   "(or not the same seeds in every arm)", 3)
    d["per_seed"] = int(next(iter(units["exp1"].values()))["experiment.repetitions"])
    d["sphere"] = read_sphere(p("sphere_curves.csv"), units["sphere"])
    read_timing(d, p("timing.csv"), ("exp3", "exp12", "sphere"))
    return d


def read_timing(d, path, phases):
    d["timing"] = {r["phase"]: r for r in read_csv(path, ("phase", "wall_seconds", "cpu_seconds"))}
    for ph in phases:
        if ph not in d["timing"]:
            raise Fail(f"{path}: no row for phase {ph}", 3)


def load_exp3(data, units):
    """Experiment 3's runs and curves in data, as the manifest's units name them."""
    p = lambda name: os.path.join(data, name)  # noqa: E731
    d = {"units": units}
    c3 = next(iter(units["exp3"].values()))
    policies = c3["exp3.policies"].split(",")
    for q in THESIS + ("handcrafted",):
        if q not in policies:
            raise Fail(f"{p('manifest.csv')}: exp3.policies lacks {q}", 3)
    reps = range(int(c3["experiment.repetitions"]))
    iters = int(c3["exp3.iterations"])
    want = {(a, q, r) for a in MODES for q in policies for r in reps}
    d["exp3"] = read_exp3(p("exp3_runs.csv"), p("exp3_curves.csv"), want, iters)
    d["reps"], d["iterations"] = len(reps), iters
    d["final"] = int(c3["exp3.final_episodes"])
    d["seed"] = c3["experiment.seed"]
    d["version"] = c3.get("version", "?")
    return d


def load_holdout(data):
    """The holdout (DATA/holdout, Experiment 3 with fresh seeds), or None
    when DATA has none."""
    if not os.path.isdir(data):
        return None
    for name in HOLDOUT_FILES:
        if not os.path.isfile(os.path.join(data, name)):
            raise Fail(f"{os.path.join(data, name)}: missing (run make holdout)", 2)
    d = load_exp3(data, read_manifest(os.path.join(data, "manifest.csv"), full=False))
    read_timing(d, os.path.join(data, "timing.csv"), ("exp3",))
    return d


def read_exp3(runs_path, curves_path, want, iters):
    cols = ("mean_return", "sd_return", "target", "pocket2", "pocket5", "median_speed",
            "miss_distance")
    runs = {}
    for line, r in enumerate(read_csv(runs_path, ("arm", "policy", "repetition") + cols), 2):
        key = (r["arm"], r["policy"], number(runs_path, line, r, "repetition", int))
        if key in runs:
            raise Fail(f"{runs_path}:{line}: a second row for {key}", 3)
        runs[key] = {c: number(runs_path, line, r, c) for c in cols}
    what = lambda k: f"arm {k[0]} policy {k[1]} repetition {k[2]}"  # noqa: E731
    expect_all(runs_path, set(runs), want, what)
    icols = [f"i{k}" for k in range(1, iters + 1)]
    curves = {}
    for line, r in enumerate(read_csv(curves_path, ("arm", "policy", "repetition") + tuple(icols)),
                             2):
        key = (r["arm"], r["policy"], number(curves_path, line, r, "repetition", int))
        curves[key] = np.array([number(curves_path, line, r, c) for c in icols])
    expect_all(curves_path, set(curves), want, what)
    for k, v in curves.items():
        runs[k]["curve"] = v
    return runs


def unit_keys(units):
    """{(arm, seed): configuration} of Experiment 1's or 2's manifest units."""
    return {(u.split("/")[0], int(u.split("/")[1])): cfg for u, cfg in units.items()}


def read_exp1(mse_path, map_path, units):
    seeds = unit_keys(units)
    mse = {}
    for line, r in enumerate(read_csv(mse_path, ("arm", "seed", "forest", "sweep", "value",
                                                 "mse")), 2):
        key = (r["arm"], number(mse_path, line, r, "seed", int),
               number(mse_path, line, r, "forest", int), r["sweep"],
               number(mse_path, line, r, "value", int))
        mse[key] = number(mse_path, line, r, "mse")
    want = set()
    for (a, s), cfg in seeds.items():
        for sweep, key in (("n_min", "exp1.n_min_list"), ("trees", "exp1.trees_list"),
                           ("cuts", "exp1.cuts_list")):
            want |= {(a, s, f, sweep, v) for f in range(int(cfg["experiment.repetitions"]))
                     for v in int_list(cfg, key)}
    expect_all(mse_path, set(mse), want,
               lambda k: f"arm {k[0]} seed {k[1]} forest {k[2]} {k[3]} = {k[4]}")
    maps = {}
    for line, r in enumerate(read_csv(map_path, ("arm", "seed", "pred_pocketed", "rms_rest")),
                             2):
        maps[(r["arm"], number(map_path, line, r, "seed", int))] = (
            number(map_path, line, r, "pred_pocketed"), number(map_path, line, r, "rms_rest"))
    expect_all(map_path, set(maps), set(seeds), lambda k: f"arm {k[0]} seed {k[1]}")
    return mse, maps


def read_exp2(path, units):
    seeds = unit_keys(units)
    ret = {}
    for line, r in enumerate(read_csv(path, ("arm", "seed", "repetition", "size", "policy",
                                             "mode", "mean_return")), 2):
        key = (r["arm"], number(path, line, r, "seed", int),
               number(path, line, r, "repetition", int), number(path, line, r, "size", int),
               r["policy"], r["mode"])
        ret[key] = number(path, line, r, "mean_return")
    want = set()
    for (a, s), cfg in seeds.items():
        n = max(int_list(cfg, "exp2.sizes"))
        for rep in range(int(cfg["experiment.repetitions"])):
            want.add((a, s, rep, 0, "expert", "mean"))
            want |= {(a, s, rep, n, q, m) for q in ("single", "s_a", "s_rs")
                     for m in ("mean", "sample")}
    what = lambda k: f"arm {k[0]} seed {k[1]} repetition {k[2]} size {k[3]} {k[4]} {k[5]}"  # noqa: E731,E501
    missing = sorted(want - set(ret))
    if missing:
        raise Fail(f"{path}: no row for {what(missing[0])}", 3)
    extra = sorted({k[:2] for k in ret} - set(seeds))
    if extra:
        raise Fail(f"{path}: rows for arm {extra[0][0]} seed {extra[0][1]}, which the manifest "
                   "does not have", 3)
    return ret


def read_sphere(path, units):
    """{method: [test returns of each repetition, by iteration]}, every
    repetition and iteration the manifest's configuration names."""
    vals = {}
    for line, r in enumerate(read_csv(path, ("method", "repetition", "iteration",
                                             "test_return")), 2):
        key = (r["method"], number(path, line, r, "repetition", int),
               number(path, line, r, "iteration", int))
        vals[key] = number(path, line, r, "test_return")
    want = {(m, rep, it) for m in SPHERE
            for rep in range(int(units[m]["experiment.repetitions"]))
            for it in range(int(units[m]["bench.iterations"]))}
    expect_all(path, set(vals), want,
               lambda k: f"method {k[0]} repetition {k[1]} iteration {k[2]}")
    return {m: [np.array([vals[(m, rep, it)] for it in range(int(units[m]["bench.iterations"]))])
                for rep in range(int(units[m]["experiment.repetitions"]))] for m in SPHERE}


# ---------------------------------------------------------------- parts

def make_part(label, e, kind, a, b=None, unit="m"):
    """One claim part: the estimate e and the raw p-values of the support
    (kind 'gt': mean > a, 'lt': mean < a, 'in': a < mean < b) and of its
    complement. Its intervals come once the Holm levels are known (levels)."""
    if kind == "gt":
        p_s, p_r = vs.p_greater(e, a), vs.p_less(e, a)
    elif kind == "lt":
        p_s, p_r = vs.p_less(e, a), vs.p_greater(e, a)
    else:
        p_s, p_r = vs.p_tost(e, a, b), vs.p_outside(e, a, b)
    return {"label": label, "est": e.est, "n": e.n, "kind": kind, "a": a, "b": b,
            "p_s": p_s, "p_r": p_r, "unit": unit, "group": "",
            "ci": lambda level: vs.interval(e, level),
            "dev": lambda c: (e.est - c, e.se * math.sqrt(e.n))}


def share_part(label, num, den, low, high):
    """nrvr_rs's pocket-2 share in (low, high): TOST on mean(num - c den),
    the interval Fieller's. Without a pocketed ball there is no share: the
    part is undecided (p 1)."""
    part = {"label": label, "n": len(num), "kind": "in", "a": low, "b": high,
            "unit": "share", "group": ""}
    if not np.sum(den) > 0:
        return part | {"label": label + " (no ball in a target pocket)", "est": math.nan,
                       "p_s": 1.0, "p_r": 1.0, "ci": lambda level: (math.nan, math.nan),
                       "dev": None}
    est = lambda c: vs.share_estimate(num, den, c)  # noqa: E731
    p_s = max(vs.p_greater(est(low)), vs.p_less(est(high)))
    p_r = min(1.0, 2 * min(vs.p_less(est(low)), vs.p_greater(est(high))))
    return part | {"est": float(np.sum(num) / np.sum(den)), "p_s": p_s, "p_r": p_r,
                   "ci": lambda level: vs.fieller(num, den, level)[1:],
                   "dev": lambda c: (est(c).est, est(c).se * math.sqrt(est(c).n))}


def levels(p, lvl_s, lvl_r):
    """The part's two intervals at the levels its support and refutation were
    judged at after Holm: the support's at 1 - 2 lvl_s (two one-sided bounds
    at 1 - lvl_s: the part agrees exactly when it lies in the claim's region),
    the refutation's at 1 - 2 lvl_r, or 1 - lvl_r for the two-sided 'outside'
    refutation of an equivalence band (it disagrees exactly when this interval
    lies outside the claim's region)."""
    two_sided = p["kind"] == "in" and math.isfinite(p["a"])
    p["level_s"] = 1 - 2 * lvl_s
    p["level_r"] = 1 - (lvl_r if two_sided else 2 * lvl_r)
    p["lo"], p["hi"] = p["ci"](p["level_s"])
    p["lo_r"], p["hi_r"] = p["ci"](p["level_r"])


def exp1_parts(d, m, arm):
    """Experiment 1 in one physics arm: per seed the forests' mean MSE of a
    setting relative to a reference setting, minus 1."""
    seeds = d["seeds"]
    cfg = next(iter(d["units"]["exp1"].values()))
    forests = range(int(cfg["experiment.repetitions"]))
    # the margins do not enter the means: once per arm for sensitivity()'s 15 computations
    means = d.setdefault("exp1_means", {})
    if arm not in means:
        means[arm] = {(s, sw, v): np.mean([d["exp1"][(arm, s, f, sw, v)] for f in forests])
                      for (a, s, _, sw, v) in d["exp1"] if a == arm}
    mean = means[arm]

    def rel(sweep, v, ref):
        return vs.one_sample([mean[(s, sweep, v)] / mean[(s, sweep, ref)] - 1 for s in seeds])

    out = defaultdict(list)
    ks = int_list(cfg, "exp1.cuts_list")
    kd = int(cfg["forest.cuts"])
    mse = m["mse"]
    out["cuts"].append(make_part(f"K {min(ks)} − K {kd}", rel("cuts", min(ks), kd), "gt", mse,
                                 unit="rel"))
    out["cuts"].append(make_part(f"K {max(ks)} − K {kd}", rel("cuts", max(ks), kd), "in", -mse,
                                 mse, unit="rel"))
    out["cuts"] += [make_part(f"K {k} − K {kd}", rel("cuts", k, kd), "gt", -mse, unit="rel")
                    for k in ks if k not in (kd, min(ks), max(ks))]
    ms = int_list(cfg, "exp1.trees_list")
    top = max(ms)
    out["trees"].append(make_part(f"M 1 − M {top}", rel("trees", 1, top), "gt", mse, unit="rel"))
    out["trees"].append(make_part(f"M 10 − M {top}", rel("trees", 10, top), "lt", mse,
                                  unit="rel"))
    out["trees"] += [make_part(f"M {k} − M 10", rel("trees", k, 10), "lt", mse, unit="rel")
                     for k in ms if k > 10]
    ns = int_list(cfg, "exp1.n_min_list")
    lo_n, hi_n = min(ns), max(ns)
    out["nmin"].append(make_part(f"n_min {hi_n} − n_min {lo_n}", rel("n_min", hi_n, lo_n), "gt",
                                 0, unit="rel"))
    out["nmin"] += [make_part(f"n_min {n} − n_min {lo_n}", rel("n_min", n, lo_n), "gt", -mse,
                              unit="rel") for n in ns if n not in (lo_n, hi_n)]
    out["nmin"] += [make_part(f"n_min {hi_n} − n_min {n}", rel("n_min", hi_n, n), "gt", 0,
                              unit="rel") for n in ns if n not in (lo_n, hi_n)]
    gap = vs.one_sample([-d["exp1_map"][(arm, s)][0] - d["exp1_map"][(arm, s)][1]
                         for s in seeds])
    out["map"].append(make_part("underestimate at pocketed positions − RMS error elsewhere",
                                gap, "gt", 0))
    return out


def exp2_parts(d, m, arm):
    """Experiment 2 in one physics arm at its largest training set: per seed
    the mean over the run's repetitions."""
    seeds = d["seeds"]
    cfg = next(iter(d["units"]["exp2"].values()))
    n = max(int_list(cfg, "exp2.sizes"))
    reps = range(int(cfg["experiment.repetitions"]))

    def per_seed(size, policy, mode):
        return np.array([np.mean([d["exp2"][(arm, s, r, size, policy, mode)] for r in reps])
                         for s in seeds])

    expert = per_seed(0, "expert", "mean")
    name = {"single": "single node", "s_a": "s→a", "s_rs": "s→rs"}
    out = defaultdict(list)
    out["short"] = [make_part(f"expert − {name[q]} (mean actions)",
                              vs.paired(expert, per_seed(n, q, "mean")), "gt", m["material"])
                    for q in ("single", "s_a", "s_rs")]
    for mode in ("mean", "sample"):
        single = per_seed(n, "single", mode)
        out["single"] += [make_part(f"single node − {name[q]} ({mode} actions)",
                                    vs.paired(single, per_seed(n, q, mode)), "lt", 0)
                          for q in ("s_a", "s_rs")]
        out["rs"].append(make_part(f"s→rs − s→a ({mode} actions)",
                                   vs.paired(per_seed(n, "s_rs", mode), per_seed(n, "s_a", mode)),
                                   "gt", 0))
    return out


def exp3_parts(d, arm, m, rules):
    reps = range(d["reps"])
    x = lambda q, col: np.array([d["exp3"][(arm, q, r)][col] for r in reps])  # noqa: E731
    ret = {q: x(q, "mean_return") for q in THESIS + ("handcrafted",)}
    base = "baseline"
    out = defaultdict(list)
    out["none_better"] = [make_part(f"{q} − baseline", vs.paired(ret[q], ret[base]), "in",
                                    -math.inf, m["considerable"]) for q in TREES]
    out["best"] = [make_part(f"nrvr_rs − {w}", vs.paired(ret["nrvr_rs"], ret[w]), "gt", 0)
                   for w in TREES if w != "nrvr_rs"]
    out["best"].append(make_part("nrvr_rs − baseline, ≈ 0.1", vs.paired(ret["nrvr_rs"], ret[base]),
                                 "in", 0.1 - m["about"], 0.1 + m["about"]))
    out["worst"] = [make_part(f"rvr_a − {w}", vs.paired(ret["rvr_a"], ret[w]), "lt", 0)
                    for w in TREES if w != "rvr_a"]
    for col, what, unit in (("sd_return", "SD of the returns", "m"),
                            ("target", "balls in target pockets", "n"),
                            ("miss_distance", "missed balls' distance", "m"),
                            ("median_speed", "median cue speed", "ms")):
        out["worst"].append(make_part(f"{what}, rvr_a − baseline",
                                      vs.paired(x("rvr_a", col), x(base, col)), "gt", 0, unit=unit))
    n2, n5 = x("nrvr_rs", "pocket2"), x("nrvr_rs", "pocket5")
    out["even"].append(share_part("nrvr_rs's pocket-2 share", n2, n2 + n5, 0.5 - m["even"],
                                  0.5 + m["even"]))
    out["fewest"] = [make_part(f"balls in target pockets, {q} − baseline",
                               vs.paired(x(q, "target"), x(base, "target")), "gt", 0, unit="n")
                     for q in TREES]
    k0 = rules["converged_at"]
    for q in THESIS:
        p = make_part(f"{q}: mean square of the runs' changes after iteration {k0}",
                      drift(d, arm, q, k0), "lt", m["flat"] ** 2, unit="m2")
        p["group"] = "converged"
        out["converged"].append(p)
    for q in THESIS:
        p = make_part(f"hand-crafted − {q}", vs.paired(ret["handcrafted"], ret[q]), "gt",
                      m["considerable"])
        p["group"] = "poor"
        out["converged"].append(p)
    return out


def drift(d, arm, q, k0):
    """The mean over a policy's runs of c^2 - s^2: each run's least-squares
    change c over its curve from iteration k0 on, less the square of its
    standard error s, an estimate of the square of the run's true change
    (E c^2 = change^2 + s^2)."""
    # the trends do not depend on the margins: computed once, not per
    # sensitivity variant
    cache = d.setdefault("drift", {})
    if (arm, q, k0) not in cache:
        es = [vs.trend(d["exp3"][(arm, q, r)]["curve"][k0:]) for r in range(d["reps"])]
        cache[(arm, q, k0)] = vs.one_sample([e.est ** 2 - e.se ** 2 for e in es])
    return cache[(arm, q, k0)]


def task_gap(d, mode):
    """The task's scale in a mode: mean return of the hand-crafted policy minus
    the one-node baseline's, over the repetitions."""
    reps = range(d["reps"])
    h = np.mean([d["exp3"][(mode, "handcrafted", r)]["mean_return"] for r in reps])
    b = np.mean([d["exp3"][(mode, "baseline", r)]["mean_return"] for r in reps])
    return float(h - b)


def margin_values(margins):
    """{name: value} of the rules' margins (constants, the same in every mode)."""
    return {k: v["value"] for k, v in margins.items()}


def adjust(parts, alpha):
    """Holm over one family, the parts' lists given: every support and every
    refutation p-value, a hypothesis two claims share (the same part) counted
    once. Fills each part's adjusted p-values, verdict, family size, the Holm
    levels and its intervals at them."""
    fam = {}
    for ps in parts:
        for p in ps:
            fam.setdefault((p["label"], p["kind"], p["a"], p["b"]), []).append(p)
    keys = list(fam)
    ps_all = [fam[k][0]["p_s"] for k in keys] + [fam[k][0]["p_r"] for k in keys]
    adj, lvl = vs.holm(ps_all), vs.holm_levels(ps_all, alpha)
    n = len(keys)
    for i, k in enumerate(keys):
        for p in fam[k]:
            p["adj_s"], p["adj_r"] = adj[i], adj[n + i]
            p["verdict"] = vs.part_verdict(adj[i], adj[n + i], alpha)
            p["family"] = 2 * n
            p["lvl_s"], p["lvl_r"] = lvl[i], lvl[n + i]
            levels(p, lvl[i], lvl[n + i])


def compute(d, rules, margins, exps=("exp1", "exp2", "exp3")):
    """{(claim, mode): [part]} with Holm-adjusted p-values: one family per
    experiment and mode, every support and refutation of the parts of that
    experiment's claims (the same definition for the study, the holdout and
    the sensitivity points)."""
    parts = defaultdict(list)
    m = margin_values(margins)
    gens = {"exp1": lambda arm: exp1_parts(d, m, arm), "exp2": lambda arm: exp2_parts(d, m, arm),
            "exp3": lambda arm: exp3_parts(d, arm, m, rules)}
    for arm in MODES:
        for e in exps:
            for cid, ps in gens[e](arm).items():
                parts[(cid, arm)] = ps
    for arm in MODES:
        for e in exps:
            adjust([ps for (c, md), ps in parts.items() if md == arm and EXPERIMENT[c] == e],
                   rules["alpha"])
    return parts


def part_need(p, power):
    """(units to agree, units to disagree) of a part at the given power, were
    the true mean its estimate and its SD the study's, each test at the level
    Holm judged it at: the current units for a decided part's verdict,
    math.inf for a direction the estimate does not point to."""
    if p["verdict"] == vs.AGREES:
        return p["n"], math.inf
    if p["verdict"] == vs.DISAGREES:
        return math.inf, p["n"]
    if p["dev"] is None:
        return math.inf, math.inf
    ls, lr, a, b = p["lvl_s"], p["lvl_r"], p["a"], p["b"]
    if p["kind"] in ("gt", "lt"):
        dl, sd = p["dev"](a)
        sign = 1 if p["kind"] == "gt" else -1
        return (vs.units_needed([(sign * dl, sd, ls)], power),
                vs.units_needed([(-sign * dl, sd, lr)], power))
    dh, sh = p["dev"](b)
    if not math.isfinite(a):
        return (vs.units_needed([(-dh, sh, ls)], power), vs.units_needed([(dh, sh, lr)], power))
    da, sa = p["dev"](a)
    # outside the band: twice the smaller one-sided p, so each side at lr / 2
    return (vs.units_needed([(da, sa, ls), (-dh, sh, ls)], power),
            min(vs.units_needed([(-da, sa, lr / 2)], power),
                vs.units_needed([(dh, sh, lr / 2)], power)))


def need_all(needs):
    """(to agree, to disagree) of 'every part': all must agree, one may disagree."""
    return max(n[0] for n in needs), min(n[1] for n in needs)


def claim_need(cid, ps, rules):
    """(units to agree, units to disagree) of a claim in one mode."""
    if cid != "converged":
        return need_all([part_need(p, rules["power"]) for p in ps])
    conv = need_all([part_need(p, rules["power"]) for p in ps if p["group"] == "converged"])
    poor = [part_need(p, rules["power"]) for p in ps if p["group"] == "poor"]
    k = rules["many"]
    poor = (sorted(n[0] for n in poor)[k - 1], sorted(n[1] for n in poor)[len(poor) - k])
    return need_all([conv, poor])


def needed(parts, per, comb, rules):
    """{claim: (units to decide in each mode, over the modes)}: per mode the
    nearer of agreeing and disagreeing, over the modes the nearer of every
    mode agreeing and every mode disagreeing."""
    out = {}
    for cid in comb:
        ns = {m: claim_need(cid, parts[(cid, m)], rules) for m in MODES if (cid, m) in parts}
        out[cid] = ({m: min(n) for m, n in ns.items()},
                    min(max(n[0] for n in ns.values()), max(n[1] for n in ns.values())))
    return out


def claim_verdict(cid, ps, rules):
    if cid == "converged":
        conv = vs.all_of(p["verdict"] for p in ps if p["group"] == "converged")
        poor = vs.at_least([p["verdict"] for p in ps if p["group"] == "poor"], rules["many"])
        return vs.all_of([conv, poor])
    return vs.all_of(p["verdict"] for p in ps)


def verdict_table(parts, rules):
    """{claim: {mode: verdict}} and {claim: combined verdict over its modes}."""
    per = defaultdict(dict)
    for (cid, mode), ps in parts.items():
        per[cid][mode] = claim_verdict(cid, ps, rules)
    return per, {cid: vs.combine_modes(per[cid][md] for md in MODES if md in per[cid])
                 for cid in CLAIM_IDS if cid in per}


def sensitivity(d, rules, base):
    """For each margin halved and doubled: how many (claim, mode) verdicts and
    combined verdicts change."""
    per0, comb0 = base
    rows = []
    for name, mg in rules["margins"].items():
        row = [name, mg]
        for f in (0.5, 2.0):
            scaled = {k: dict(v, value=v["value"] * (f if k == name else 1))
                      for k, v in rules["margins"].items()}
            per, comb = verdict_table(compute(d, rules, scaled), rules)
            changed = [(c, md) for c in per for md in per[c] if per[c][md] != per0[c][md]]
            row.append((changed, [c for c in comb if comb[c] != comb0[c]]))
        rows.append(row)
    return rows


# ---------------------------------------------------------------- text

def num(x, unit, signed=True):
    if math.isnan(x):
        return "n/a"
    if math.isinf(x):
        return "−∞" if x < 0 else "∞"
    if unit == "rel":
        s = f"{100 * x:+.1f}"
    elif unit in ("share", "count"):
        s = f"{x:.{2 if unit == 'count' else 3}f}"
    else:
        s = f"{x:+.{ {'m': 3, 'm2': 4}.get(unit, 2)}f}"
    if not signed:
        s = s.lstrip("+")
    return s.replace("-", "−")


UNIT = {"rel": " % of the MSE", "m": " m", "m2": " m²", "n": " balls", "ms": " m/s",
        "share": ""}


def level(x):
    """A confidence level in per cent, with the digits that tell it apart."""
    return f"{100 * x:.{max(0, min(4, math.ceil(-math.log10(max(1 - x, 1e-9))) - 1))}f} %"


def est(p):
    u = p["unit"]
    return f"{num(p['est'], u)}{UNIT[u]}"


def interval_text(p, side):
    """The interval the part's support (side 's') or refutation ('r') was
    judged by, [lo, hi] (level)."""
    u = p["unit"]
    lo, hi, lvl = ((p["lo"], p["hi"], p["level_s"]) if side == "s" else
                   (p["lo_r"], p["hi_r"], p["level_r"]))
    return f"[{num(lo, u)}, {num(hi, u)}] ({level(lvl)})"


def ci(p, side="s"):
    u = p["unit"]
    lo, hi, lvl = ((p["lo"], p["hi"], p["level_s"]) if side == "s" else
                   (p["lo_r"], p["hi_r"], p["level_r"]))
    head = num(p["est"], u)
    return f"{head} [{num(lo, u)}, {num(hi, u)}]{UNIT[u]} ({level(lvl)})"


def hyp(p):
    u = p["unit"]
    tail = {"rel": " %", "m": " m", "m2": " m²", "n": "", "ms": " m/s", "share": ""}[u]
    if p["kind"] == "gt":
        return f"> {num(p['a'], u, False)}{tail}"
    if p["kind"] == "lt":
        return f"< {num(p['a'], u, False)}{tail}"
    if math.isinf(p["a"]):
        return f"< {num(p['b'], u, False)}{tail}"
    return f"in ({num(p['a'], u, False)}, {num(p['b'], u, False)}){tail}"


def fp(p):
    return f"{p:.4f}" if p >= 1e-3 else f"{p:.1e}"


def md_table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    return "\n".join(out + ["| " + " | ".join(str(c) for c in r) + " |" for r in rows])


def deciding(ps, verdict):
    """The part that decides a claim's verdict: the weakest support of an
    agreeing claim, the strongest refutation of a disagreeing one, else the
    first undecided part."""
    if verdict == vs.AGREES:
        return max((p for p in ps if p["verdict"] == vs.AGREES), key=lambda p: p["adj_s"])
    if verdict == vs.DISAGREES:
        return min((p for p in ps if p["verdict"] == vs.DISAGREES), key=lambda p: p["adj_r"])
    return next(p for p in ps if p["verdict"] == vs.UNDECIDED)


def cell(parts, per, cid, mode, rules):
    if (cid, mode) not in parts:
        return "–"
    v = per[cid][mode]
    p = deciding(parts[(cid, mode)], v)
    return f"**{v}**: {p['label']} {ci(p, 'r' if v == vs.DISAGREES else 's')}"


def units_text(d):
    return (f"Experiment 3: {d['reps']} repetitions per mode; Experiments 1 and 2: "
            f"{len(d['seeds'])} seeds per mode of {d['per_seed']} forests or repetitions "
            "each")


CI_LEGEND = ("[lo, hi] is the interval of the test that decides, at the level (in "
             "parentheses) Holm's procedure judged that test at, not a fixed 95 %: an agreeing "
             "part's interval lies inside the claim's region (beyond its bound, or inside its "
             "equivalence band), a disagreeing part's refutation interval outside it, an "
             "undecided part's interval reaches both. t intervals for means, Fieller's for "
             "the pocket share.")


def not_reproduced(d, per, comb):
    """Sentences on the claims that do not reproduce, from the verdicts."""
    rules_short = d["rules"]["claims"]
    dis = [c for c in CLAIM_IDS if comb[c] == vs.DISAGREES]
    some = [c for c in CLAIM_IDS if comb[c] != vs.DISAGREES
            and vs.DISAGREES in per[c].values()]
    und = [c for c in CLAIM_IDS if comb[c] == vs.UNDECIDED and c not in some]
    lines = []
    name = lambda c: f"{rules_short[c]['section']} “{rules_short[c]['short']}”"  # noqa: E731
    if dis:
        lines.append("**Do not reproduce** (disagree in every mode): " +
                     "; ".join(name(c) for c in dis) + ".")
    if some:
        lines.append("**Disagree in some modes**: " + "; ".join(
            f"{name(c)} ({', '.join(MODE_LABEL[m] for m in MODES if per[c].get(m) == vs.DISAGREES)})"
            for c in some) + ".")
    if und:
        lines.append("**Undecided** (the study cannot tell, or the modes differ): " +
                     "; ".join(name(c) for c in und) + ".")
    lines.append(ranking(d))
    agree = [c for c in CLAIM_IDS if comb[c] == vs.AGREES]
    lines.append(f"**Reproduce** (agree in every mode): {len(agree)} of {len(CLAIM_IDS)}" +
                 (": " + "; ".join(name(c) for c in agree) if agree else "") + ".")
    return lines


def ranking(d):
    """Experiment 3's ranking per mode: the tree variant with the highest mean
    return, and those whose paired 95 % interval against the baseline lies
    above 0 (unadjusted: a description, not a verdict)."""
    bits = []
    for mode in MODES:
        reps = range(d["reps"])
        ret = {q: np.array([d["exp3"][(mode, q, r)]["mean_return"] for r in reps])
               for q in THESIS}
        top = max(TREES, key=lambda q: ret[q].mean())
        above = [q for q in TREES if vs.interval(vs.paired(ret[q], ret["baseline"]))[0] > 0]
        bits.append(f"{MODE_LABEL[mode]}: highest {top}; above the baseline "
                    f"{', '.join(above) or 'none'}")
    return ("**Ranking of Experiment 3** (a description, not a tested part: mean return of "
            "the last episodes; above the baseline: the paired 95 % t interval, unadjusted, "
            "above 0): " + "; ".join(bits) + ". The thesis "
            "has nrvr_rs best, about 0.1 above the baseline.")


def margin_rows(d, margins):
    """The margins table: value and the value against the task's scale (or,
    for a share of it, in metres) per mode."""
    gap = {m: task_gap(d, m) for m in MODES}
    rows = []
    for k, mg in margins.items():
        if mg["unit"] == "m":
            scale = "; ".join(f"{mg['value'] / gap[m]:.0%} in {MODE_LABEL[m]}" for m in MODES)
        else:
            scale = "–"
        value = f"{mg['value']:g} {mg['unit']}"
        rows.append([f"`{k}`", value, scale])
    return rows, gap


def render_md(d, parts, per, comb, sens):
    rules = d["rules"]
    mrows, gap = margin_rows(d, rules["margins"])
    fams = {e: next(p["family"] for (c, _), ps in parts.items() for p in ps if EXPERIMENT[c] == e)
            for e in ("exp1", "exp2", "exp3")}
    srows = []
    for cid in CLAIM_IDS:
        c = rules["claims"][cid]
        srows.append([f"{c['section']} {c['short']}"] + [per[cid].get(m, "–") for m in MODES] +
                     [f"**{comb[cid]}**", need_cell(d["need"][cid], cid, comb[cid], d)])
    out = [HEAD_MD.format(units=units_text(d), alpha=rules["alpha"], f1=fams["exp1"],
                          f2=fams["exp2"], f3=fams["exp3"], power=power_text(rules),
                          k0=rules["converged_at"])]
    out.append(md_table(["margin", "value", "against the task's scale, hand-crafted − "
                         f"baseline ({', '.join(num(gap[m], 'm') for m in MODES)} m)"], mrows))
    out.append("\n## Verdicts\n\nEach cell: the mode's verdict. The part that decides it (the "
               "weakest support of an agreeing claim, the strongest refutation of a disagreeing "
               "one, else the first undecided part), with its estimate and interval at its Holm "
               f"level, is a row of [`{PARTS_CSV}`]({PARTS_CSV[5:]}) (and in the README's table "
               "for two modes). The verdict column is the verdict common to the modes, undecided "
               f"where they differ; the last column, for an undecided claim, the units (per mode) "
               f"needed to decide it at {power_text(rules)}.\n")
    out.append(md_table(["claim"] + [MODE_LABEL[m] for m in MODES] +
                        ["verdict", f"to decide ({power_text(rules)})"], srows))
    # the lists by verdict are the README's; the page keeps the ranking
    out.append("\n" + "\n\n".join(x for x in not_reproduced(d, per, comb)
                                     if x.startswith("**Ranking")))
    out.append(holdout_md(d))
    if d.get("added"):
        out.append(added_md(d))
    out.append(f"\n![seed spread](figures/{exp_data.STUDY_SEEDS_STEM}.png)\n\n*Figure: the seed spread "
               "behind the Experiment 1 and 2 verdicts (event mode). Top: the test MSE of each "
               "setting relative to its reference, one grey dot per seed (the mean of its run's "
               "forests), the mean over the seeds with its 95 % t interval (a description, not "
               "the Holm-level interval of the tables), one y-scale for the three sweeps; the "
               "thesis's Fig. 7.4 shows one run's forests instead (our Fig. 7.4a–c do too). "
               "Below: Experiment 2's mean return at the largest training set per seed (the "
               "mean of its repetitions), with mean and sampled actions on one y-scale; the "
               "thesis's Fig. 7.6 shows one run over the training-set sizes.*")
    out.append("\n## The claims one by one\n\nEach claim's test, and the thesis's words it "
               "judges, are in `data/study/rules.ini`. Every part of every claim and mode is a "
               f"row of [`{PARTS_CSV}`]({PARTS_CSV[5:]}): H1, estimate, both tests' intervals "
               f"and p-values, verdict, units needed at {power_text(rules)}.")
    for cid in CLAIM_IDS:
        out.append(claim_section(cid, rules, per, comb, d))
    out.append(sens_md(sens, rules))
    out.append(time_md(d))
    return "\n".join(out) + "\n"


POWER_CSV = "docs/data/power/summary.csv"


def power_rows(d, study):
    """Per mode and policy of one study (d): the mean over the repetitions of
    the run's mean return, its paired effect against the baseline (95 % t
    intervals), balls in the target pockets, the SD of its returns and its
    median cue speed."""
    rows = []
    for m in MODES:
        pol = sorted({q for (a, q, _) in d["exp3"] if a == m}, key=POWER_ORDER.index)
        get = lambda q, k: np.array([d["exp3"][(m, q, r)][k] for r in range(d["reps"])])  # noqa: E731
        base = get("baseline", "mean_return")
        for q in pol:
            x = get(q, "mean_return")
            mu, lo, hi = vs.t_interval(x)
            e = vs.t_interval(x - base) if q != "baseline" else (math.nan,) * 3
            rows.append([study, m, q, d["reps"]] + [f"{v:.6g}" for v in (
                mu, lo, hi, *e, get(q, "target").mean(), get(q, "sd_return").mean(),
                get(q, "median_speed").mean())])
    return rows


POWER_HEAD = ["study", "mode", "policy", "repetitions", "mean_return", "lo", "hi",
              "effect_vs_baseline", "effect_lo", "effect_hi", "target_balls", "sd_return",
              "median_speed"]
POWER_ORDER = ["nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a", "baseline", "handcrafted"]


def power_csv(rows):
    import io
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(POWER_HEAD)
    w.writerows(rows)
    return buf.getvalue()


def power_md(d, rows):
    """docs/power.md: Experiment 3's study and holdout at power, described
    (the verdicts are verdicts.md's); the numbers in POWER_CSV."""
    h = d.get("holdout")
    studies = [("study", d)] + ([("holdout", h[0])] if h else [])
    by = {(r[0], r[1], r[2]): r for r in rows}
    head = ["policy"] + [f"{st}: {MODE_LABEL[m]}" for st, _ in studies for m in MODES]
    body = []
    for q in POWER_ORDER[:4] + POWER_ORDER[5:]:
        body.append([q] + [f"{float(by[(st, m, q)][7]):+.3f} [{float(by[(st, m, q)][8]):+.3f}, "
                           f"{float(by[(st, m, q)][9]):+.3f}]" for st, _ in studies for m in MODES])
    t = d["timing"]["exp3"]
    out = [
        "# Experiment 3 at power: the verdict study and its holdout", "",
        "<!-- Generated by scripts/verdicts.py (make verdicts) from data/study/; do not edit. -->",
        "",
        "The thesis judges Experiment 3 (section 7.5) on 5 repetitions per variant, and so does "
        "`make reproduce`; at 5 the run-to-run spread of a variant's mean return is as large "
        "as the differences 7.5.2 reads into them. The verdict study reruns Experiment 3 "
        "unchanged (`data/exp3.ini`, seed " + d["seed"] + f") at {d['reps']} repetitions of "
        "every variant in each physics mode: the exact event-driven simulator and the thesis's "
        "time-stepped scheme at dt 1 ms and 0.5 ms." + (
            f" The holdout reruns it at {h[0]['reps']} repetitions with seed {h[0]['seed']}, "
            "which no study had used, after the rules were committed." if h else "") +
        " The verdicts on the claims, their rules and their tests are in "
        "[verdicts.md](verdicts.md); this page gives the runs they are computed from.", "",
        "**Pairing.** Within a repetition every variant sees the same start states and the "
        "same 200 initial episodes (common random numbers), so variants are compared per "
        "repetition; the repetitions are the independent samples. **Per run** "
        "(`data/study/exp3_runs.csv`, over its last "
        f"{d['final']} episodes): the mean and SD of the returns, the reward balls in pockets "
        "2 and 5, the median cue speed, the mean distance of the balls not in a target "
        "pocket; `exp3_curves.csv` holds each run's mean return per iteration.", "",
        "Paired effect of each policy against the baseline [m], mean over the repetitions with "
        "its 95 % t interval (unadjusted: a description; the tests are verdicts.md's). Every "
        f"policy's mean return, balls in the targets, SD of returns and cue speed: "
        f"[`{POWER_CSV}`]({POWER_CSV[5:]}).", "",
        md_table(head, body), "",
        f"**Runs and time.** `make study POWER_REPS={d['reps']}` reruns the study whole, "
        "`make holdout` the holdout (batches and commands: "
        "[verdicts.md](verdicts.md#data-and-time)). Experiment 3 took "
        f"{float(t['cpu_seconds']):.0f} s CPU in the study's timing.csv"
        + (f", {float(h[0]['timing']['exp3']['cpu_seconds']):.0f} s in the holdout's" if h
           else "") + " (shared machine). `make power` runs a standalone study of its own size "
        "(`POWER_REPS`, default 50) and reports into `OUT/power`, never here.", ""]
    return "\n".join(out)


PARTS_CSV = "docs/data/verdicts/parts.csv"
HOLDOUT_CSV = "docs/data/verdicts/holdout_parts.csv"


def judge_added(d, rules, path):
    """The last extension of the study (extensions.csv: from, to, version,
    cpu_seconds; absent: None) judged on its repetitions alone: (from, to,
    parts, per-mode verdicts, combined verdicts). Its size was chosen after
    a look at the repetitions before it, its data were not: a test on them
    alone is not a second look."""
    if not os.path.exists(path):
        return None
    rows = read_csv(path, ("from", "to", "version", "cpu_seconds"))
    if not rows:
        raise Fail(f"{path}: no extension", 3)
    lo = number(path, len(rows) + 1, rows[-1], "from", int)
    hi = number(path, len(rows) + 1, rows[-1], "to", int)
    if not 0 <= lo < hi == d["reps"]:
        raise Fail(f"{path}:{len(rows) + 1}: repetitions {lo}..{hi - 1} are not the last of the "
                   f"study's {d['reps']}", 3)
    if hi - lo < 2:  # one repetition allows no paired test
        return None
    da = dict(d, reps=hi - lo, exp3={(a, q, r - lo): v for (a, q, r), v in d["exp3"].items()
                                     if r >= lo})
    parts = compute(da, rules, rules["margins"], ("exp3",))
    per, comb = verdict_table(parts, rules)
    return lo, hi, parts, per, comb


def added_md(d):
    """The last extension's repetitions alone, beside the study's verdicts."""
    lo, hi, _, per, comb = d["added"]
    rules = d["rules"]
    rows = [[f"`{c}`"] + [per[c][m] for m in MODES] + [f"**{comb[c]}** ({d['comb'][c]})"]
            for c in EXP3_CLAIMS]
    return ("\n## The added repetitions alone\n\nRepetitions "
            f"{lo}–{hi - 1} were added after the first {lo} had been judged, their number "
            "chosen from those results (`data/study/extensions.csv`). The whole study's "
            "verdicts had two chances (error up to about 2α). Judged alone (same rules), "
            "the added ones are a sample whose size, not whose data, that look chose, run after "
            "the rules were committed:\n\n" +
            md_table(["claim", f"repetitions {lo}–{hi - 1}: " + MODE_LABEL["event"]] +
                     [MODE_LABEL[m] for m in MODES[1:]] + ["verdict (all repetitions)"], rows))


def holdout_md(d):
    """The holdout's verdicts beside the study's (Experiment 3's claims)."""
    h = d.get("holdout")
    if h is None:
        return "\n## Holdout\n\nNo holdout in the study's folder (`data/study/holdout/`)."
    dh, hparts, hper, hcomb = h
    rules = d["rules"]
    rows = []
    for cid in EXP3_CLAIMS:
        c = rules["claims"][cid]
        rows.append([f"{c['section']} {c['short']}", d["comb"][cid]] +
                     [hper[cid][m] for m in MODES] +
                     [f"**{hcomb[cid]}**", need_cell(dh["need"][cid], cid, hcomb[cid])])
    return ("\n## Holdout: the rules stated in advance\n\nThe rules above were revised after "
            "the study's results had been seen. `data/study/rules.ini` was then committed, and "
            f"only then was the holdout run: Experiment 3 at {dh['reps']} repetitions per mode "
            f"with seed {dh['seed']}, unused by any study (the study's is {d['seed']}). Its "
            "verdicts are the only ones judged by rules fixed before their data (same parts, "
            f"margins, families and tests; every part: [`{HOLDOUT_CSV}`]({HOLDOUT_CSV[5:]})).\n\n" +
            md_table(["claim", "study", "holdout: " + MODE_LABEL["event"]] +
                     [MODE_LABEL[m] for m in MODES[1:]] +
                     ["holdout verdict", f"holdout: to decide ({power_text(rules)})"], rows))


HEAD_MD = """# The thesis's claims, judged: rules, tests and verdicts

<!-- Generated by scripts/verdicts.py from data/study/ (rules: data/study/rules.ini,
     results: `make study`, holdout: `make holdout`). Do not edit: run `make verdicts`. -->

Every verdict this project prints on the thirteen claims of the thesis's discussions
(sections 7.3.2, 7.4.2 and 7.5.2) comes from this page's generator, over the committed
results of one study: {units}. The rules are in `data/study/rules.ini`, apart from the
numbers; `make verdicts` applies them, `make verdicts CHECK=1` (part of `make check`) fails
when this page, its CSVs, the README's table or the report page's claims section differ
from what the results give. The rules were revised after the study's results had been seen;
the holdout and the added repetitions judged alone (below) are the data judged by rules
committed before the data existed.

## How a claim is judged

- **Parts.** A claim is split into parts, each a statement about one quantity measured per
  independent unit: a repetition of Experiment 3 (all variants of a repetition share start
  states and initial episodes, so differences are paired by repetition), a seed of
  Experiments 1 and 2 (each seed draws its own data; a seed's value is the mean over its
  run's forests or repetitions).
- **Tests.** Each part has a support (the claim's statement as an alternative hypothesis)
  and a refutation (its complement at the same bound). Superiority and ordering: one-sided
  t tests; "no considerable difference", "almost as good", "≈ 0.1 above", "almost evenly":
  equivalence by two one-sided tests (TOST) with a stated margin; their refutation: the
  value lies outside the band (twice the smaller one-sided p). "Converged" is judged per
  run: each run's least-squares change after iteration {k0}, squared, less its noise
  variance, averaged over the runs, below `flat`² by a one-sided t test (the root mean
  square of the runs' true changes below `flat`). Every margin is a constant of the rules,
  none is computed from the data. SD: standard deviation.
- **Multiplicity.** Holm's step-down adjustment over one family per experiment and mode:
  every support and every refutation p-value of the parts of that experiment's claims
  (Experiment 1: {f1} tests, Experiment 2: {f2}, Experiment 3: {f3} tests per mode; a part
  two claims share counts once). The same definition for the study, the holdout and the
  sensitivity study (docs/sensitivity.md), so an Experiment 3 verdict means the same
  wherever it is printed. A part **agrees** when its support's adjusted p is below α =
  {alpha}, **disagrees** when its refutation's is, and is **undecided** when neither is.
- **Intervals.** Every interval printed with a verdict is the one that decides it: at the
  level Holm's procedure judged the test at (the k-th smallest p of the family against α
  / (m − k + 1), until the first that fails; the later ones at that failing level), two
  one-sided bounds at 1 − that level for a one-sided test or TOST, so the interval lies
  in the claim's region exactly when the adjusted p is below α. The level is printed
  beside each interval.
- **Claims.** A claim agrees when every part agrees, disagrees when any part disagrees,
  else is undecided ("many": at least the stated number of parts). The verdict column is
  the verdict all modes share; where they differ it is undecided.
- **Units to decide.** For an undecided part: the smallest number of repetitions (or
  seeds) at which its test has {power}, were the true mean its estimate and the SD of
  its units the study's, at the level Holm judged it at (noncentral t; an equivalence
  band needs both one-sided tests, their misses added). A claim needs its slowest part to
  agree, or its fastest part to disagree; over the modes, every mode the same way. An
  estimate on a bound needs more than 10⁶.

## Margins

Returns are minus the reward ball's final distance to the nearest target pocket (eq. 7.7),
so return margins are distances in metres. The last column puts each against the task's
scale, the distance between the one-node baseline and the hand-crafted policy (beyond the
thesis) in the same mode: a description, no margin is derived from it. Why each margin has
its value is stated beside it in `data/study/rules.ini` (`KEY.why`). The sensitivity table
below halves and doubles each margin.
"""


def control_text(d, rules):
    """The convergence rule applied to the hand-crafted policy, which no claim
    is about: evidence that the rule can be met."""
    k0, flat, bits = rules["converged_at"], rules["margins"]["flat"]["value"], []
    for mode in MODES:
        e = drift(d, mode, "handcrafted", k0)
        bits.append(f"{MODE_LABEL[mode]} {num(e.est, 'm2')} m², one-sided p "
                    f"{fp(vs.p_less(e, flat ** 2))} (raw)")
    return ("**Control** (not a part): the same statistic for the hand-crafted policy, which no "
            f"claim is about, against flat² = {num(flat ** 2, 'm2', False)} m²: " +
            "; ".join(bits) + ".")


def claim_section(cid, rules, per, comb, d):
    """A claim's rule (the thesis's words: rules.ini), its verdict over the
    modes and, undecided, the units to decide it."""
    c = rules["claims"][cid]
    return (f"\n**{c['section']} {c['short']} (`{cid}`)**: {c['reading']} "
            f"Verdict: **{comb[cid]}**. "
            f"{need_sentence(d['need'][cid], cid, comb[cid], rules)}" +
            (f"\n\n{control_text(d, rules)}" if cid == "converged" else ""))


def unit_word(cid):
    return "repetitions" if EXPERIMENT[cid] == "exp3" else "seeds"


def need_num(n):
    return "more than 10⁶" if not math.isfinite(n) else f"{n:,}".replace(",", " ")


def need_cell(need, cid, verdict, d=None):
    """The units needed to decide an undecided claim over the modes (per mode
    when the modes point different ways), '–' for a decided one. With the
    study d, an Experiment 3 claim also gets the repetitions still to run per
    mode and their CPU time at the holdout's cost per repetition and mode."""
    if verdict != vs.UNDECIDED:
        return "–"
    if math.isfinite(need[1]):
        more = ""
        if d is not None and d.get("rep_cpu") and EXPERIMENT[cid] == "exp3":
            k = need[1] - d["reps"]
            cpu = int(round(k * len(MODES) * d["rep_cpu"], -2))
            more = (f": {need_num(k)} more per mode, about {need_num(cpu)} s CPU at the "
                    f"holdout's {d['rep_cpu']:.2f} s per repetition and mode")
        return f"{need_num(need[1])} {unit_word(cid)}{more}"
    return (f"per mode: " + ", ".join(f"{MODE_LABEL[m]} {need_num(n)}" for m, n in need[0].items())
            + f" {unit_word(cid)} (the modes point different ways)")


def power_text(rules):
    return f"{100 * rules['power']:g} % power"


def need_sentence(need, cid, verdict, rules):
    per_mode = "; ".join(f"{MODE_LABEL[m]} {need_num(n)}" for m, n in need[0].items())
    return (f"{unit_word(cid).capitalize()} to decide at {power_text(rules)} "
            f"(per mode: {per_mode}; "
            f"the same verdict in every mode: {need_num(need[1])})." if verdict == vs.UNDECIDED
            else "")


def parts_csv(parts, rules):
    """Every part of every claim and mode, as the page's tables had them."""
    import io
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["claim", "mode", "part", "H1", "estimate", "support interval (level)",
                "p (Holm)", "refutation interval (level)", "p refute (Holm)", "verdict",
                "units to agree", "units to disagree"])
    for cid in CLAIM_IDS:
        for mode in MODES:
            for p in parts.get((cid, mode), []):
                na, nd = part_need(p, rules["power"])
                w.writerow([cid, MODE_LABEL[mode], p["label"], hyp(p), est(p),
                            interval_text(p, "s"), f"{fp(p['p_s'])} ({fp(p['adj_s'])})",
                            interval_text(p, "r"), f"{fp(p['p_r'])} ({fp(p['adj_r'])})",
                            p["verdict"], need_num(na), need_num(nd)])
    return buf.getvalue()


def sens_md(sens, rules):
    rows = []
    for name, mg, (h_chg, h_comb), (d_chg, d_comb) in sens:
        fmt = lambda chg, cmb: (f"{len(chg)} ({len(cmb)} combined)" +  # noqa: E731
                                (": " + ", ".join(sorted({c for c, _ in chg})) if chg else ""))
        rows.append([f"`{name}` = {mg['value']:g} {mg['unit']}", fmt(h_chg, h_comb),
                     fmt(d_chg, d_comb)])
    return ("\n## Sensitivity to the margins\n\nHow many of the claim × mode verdicts (and of "
            "the combined verdicts) change when one margin is halved or doubled, the others "
            "kept; the claims that change are named. A margin can change a claim that does not use "
            "it: its tests move in the Holm ranking of its experiment's family in the mode.\n\n" +
            md_table(["margin", "halved", "doubled"], rows))


def time_md(d):
    t = d["timing"]
    f = lambda ph: (f"{float(t[ph]['wall_seconds']):.0f} s wall, "  # noqa: E731
                    f"{float(t[ph]['cpu_seconds']):.0f} s CPU")
    return ("\n## Data and time\n\n`make study` (not in `make reproduce`) writes the study's "
            "compact results to `data/study/` (its manifest: every unit's configuration, mixed "
            "ones refused). "
            "Measured on this shared machine: "
            f"Experiment 3 ({d['reps']} repetitions × 6 variants × 3 modes) {f('exp3')}; "
            f"Experiments 1 and 2 ({len(d['seeds'])} seeds in each mode) "
            f"{f('exp12')}; the sphere benchmark (3 methods) {f('sphere')}. "
            f"Version of the runs: `{d['version']}`" + (
                " (Experiment 3 ran in batches, the first before the rules were revised, the "
                "later ones after; each later batch reran repetition 0 of every mode and "
                "matched)" if ";" in d["version"] else "") +
            f". To rerun: `make study POWER_REPS={d['reps']} STUDY_SEEDS={len(d['seeds'])}` "
            "(then `make verdicts`); to add repetitions FROM..TO−1 to the committed study: "
            "`sh scripts/study_extend.sh OUT FROM TO data/study python3`." + holdout_time(d))


def holdout_time(d):
    h = d.get("holdout")
    if h is None:
        return ""
    t = h[0]["timing"]["exp3"]
    return (f" The holdout (`data/study/holdout/`): Experiment 3, {h[0]['reps']} repetitions × 6 "
            f"variants × 3 modes, {float(t['wall_seconds']):.0f} s wall, "
            f"{float(t['cpu_seconds']):.0f} s CPU, run niced beside other jobs; to rerun: "
            f"`make holdout HOLDOUT_REPS={h[0]['reps']} HOLDOUT_SEED={h[0]['seed']}`.")


def readme_block(d, parts, per, comb):
    rules = d["rules"]
    rows = []
    for cid in CLAIM_IDS:
        c = rules["claims"][cid]
        step = cell(parts, per, cid, "stepped", rules)
        if (cid, "stepped05") in parts and per[cid]["stepped05"] != per[cid]["stepped"]:
            step += f" (dt 0.5 ms: {per[cid]['stepped05']})"
        rows.append([f"{c['section']} {c['short']}", cell(parts, per, cid, "event", rules), step,
                     f"**{comb[cid]}**", need_cell(d["need"][cid], cid, comb[cid], d),
                     holdout_cell(d, cid)])
    legend = (f"Generated by `make verdicts` from the committed study ({units_text(d)}; "
              "rules, tests and every part: [docs/verdicts.md](docs/verdicts.md)). Each cell: "
              "the mode's verdict, then the part that decides it: estimate [lo, hi] (level), "
              f"Holm-adjusted over every test of the experiment in the mode ({FAMILY_TEXT}). " +
              CI_LEGEND + " Verdict: common to the three modes (event, stepped at dt 1 ms and "
              "0.5 ms), else undecided; where dt 0.5 ms differs from dt 1 ms its verdict is "
              f"named. To decide: for an undecided claim, the units needed at "
              f"{power_text(rules)} were the estimates true. Holdout: the verdict on fresh "
              "seeds, judged by the rules committed before they were run (the study's rules "
              "were revised after its results had been seen)." + (
                  f" Repetitions {d['added'][0]}–{d['added'][1] - 1}, run after a look at the "
                  "first ones, judged alone: [docs/verdicts.md](docs/verdicts.md"
                  "#the-added-repetitions-alone)." if d.get("added") else ""))
    return "\n".join([BEGIN, legend, "", md_table(
        ["thesis claim", f"event, {d['reps']} reps", f"stepped (dt 1 ms), {d['reps']} reps",
         "verdict", f"to decide ({power_text(rules)})", holdout_head(d)], rows), "",
        "\n\n".join(not_reproduced(d, per, comb)), END])


FAMILY_TEXT = "one family per experiment and mode, as everywhere"


def holdout_head(d):
    h = d.get("holdout")
    return "holdout" if h is None else f"holdout ({h[0]['reps']} reps, seed {h[0]['seed']})"


def holdout_cell(d, cid):
    h = d.get("holdout")
    if h is None or cid not in h[3]:
        return "–"
    return f"**{h[3][cid]}**"


def report_html(d, parts, per, comb):
    rules = d["rules"]
    esc = html.escape
    strip = lambda s: s.replace("**", "")  # noqa: E731
    rows = []
    for cid in CLAIM_IDS:
        c = rules["claims"][cid]
        cells = "".join(f"<td>{esc(strip(cell(parts, per, cid, m, rules)))}</td>" for m in MODES)
        rows.append(f"<tr><td>{esc(c['section'])}</td><td>{esc(c['short'])}</td>{cells}"
                    f"<td class=\"{comb[cid]}\">{esc(comb[cid])}</td></tr>")
    head = "".join(f"<th>{esc(MODE_LABEL[m])}</th>" for m in MODES)
    notes = "".join(f"<p>{esc(strip(s))}</p>" for s in not_reproduced(d, per, comb))
    return (f"<!-- generated by scripts/verdicts.py (make verdicts); do not edit -->\n"
            f"<p>The verdicts of the committed study ({esc(units_text(d))}), each with the part "
            "that decides it: estimate [lo, hi] (level), Holm-adjusted over every test of the "
            f"experiment in the mode ({FAMILY_TEXT}). {esc(CI_LEGEND)} Rules and every part: "
            "docs/verdicts.md.</p>\n"
            f"<table><tr><th>thesis</th><th>claim</th>{head}<th>verdict</th></tr>\n" +
            "\n".join(rows) + f"\n</table>\n{notes}\n")


# ---------------------------------------------------------------- output

def sphere_block(d):
    """The README's sentence on the contextual sphere benchmark: each method's
    plateau of the policy mean's test return, the statistic the bench_sphere
    figure marks (exp_data.plateau, on the figure's values)."""
    lv = {m: -exp_data.plateau([np.maximum(-y, exp_data.TINY)
                                 for y in d["sphere"][m]])[0] for m in SPHERE}
    n = len(d["sphere"]["creps_old"])
    g = lambda x: f"{x:.3g}".replace("-", "−")  # noqa: E731
    return (f"{SPHERE_BEGIN}\nREPS benchmarks ([docs/reps_policy.md](docs/reps_policy.md)), "
            f"contextual sphere of Abdolmaleki et al. (IJCAI 2017, §6.1), {n} seeds, generated "
            "by `make verdicts` from `data/study/sphere_curves.csv`: the test return (of the "
            "policy mean on fixed test contexts) plateaus at "
            f"{g(lv['creps_old'])} with C-REPS's covariance around the sampling mean "
            "(`policy.cov_center = old`, the benchmarks' default, drawn in the bench_sphere "
            f"figure), at {g(lv['creps_new'])} around the new mean; contextual CMA-ES "
            f"(`bench.method = ccmaes`) at {g(lv['ccmaes'])}. Plateau: the median over the "
            "seeds per iteration, then its median over the last tenth of the iterations, as the "
            "figure marks it; the final means and the peers' numbers are in "
            f"docs/policies.md.\n{SPHERE_END}")


def exp3_block(d, mode="event"):
    """The README's Experiment 3 table: the study's runs in one mode."""
    reps = range(d["reps"])
    x = lambda q, c: np.array([d["exp3"][(mode, q, r)][c] for r in reps])  # noqa: E731
    name = {"nrvr_rs": "nrvr, s→rs", "rvr_rs": "rvr, s→rs", "nrvr_a": "nrvr, s→a",
            "rvr_a": "rvr, s→a", "baseline": "baseline (one node)",
            "handcrafted": "hand-crafted (beyond the thesis)"}
    base = x("baseline", "mean_return")
    rows = []
    for q in THESIS + ("handcrafted",):
        r = x(q, "mean_return")
        if q == "baseline":
            diff = "0"
        else:
            e = vs.paired(r, base)
            lo, hi = vs.interval(e)
            diff = f"{num(e.est, 'm')} [{num(lo, 'm')}, {num(hi, 'm')}]"
        rows.append([name[q], num(r.mean(), "m"), num(r.std(ddof=1), "m", False), diff,
                     f"{x(q, 'pocket2').mean():.1f} / {x(q, 'pocket5').mean():.1f}",
                     f"{x(q, 'median_speed').mean():.2f} m/s"])
    return "\n".join([
        EXP3_BEGIN,
        f"Experiment 3 in the study ({MODE_LABEL[mode]} mode, {d['reps']} repetitions; "
        "generated by `make verdicts` from `data/study/exp3_runs.csv`): each run's mean "
        f"return over its last {d['final']} episodes, its mean and SD over the runs, the "
        "paired difference to the baseline with its 95 % t interval (unadjusted: a "
        "description, the verdicts above are the tests), balls per run in the target pockets "
        "2 and 5, and the run's median cue speed, averaged over the runs.", "",
        md_table(["policy", "mean return", "SD over runs", "paired vs baseline [95 %]",
                  "balls in pocket 2 / 5 per run", "median speed"], rows),
        EXP3_END])


def splice_readme(path, blocks):
    """README's text with each (begin, end, block) put between its markers."""
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError as e:
        raise Fail(f"{path}: {e.strerror}", 2) from e
    for begin, end, block in blocks:
        if (text.count(begin) != 1 or text.count(end) != 1
                or text.index(begin) > text.index(end)):
            raise Fail(f"{path}: needs one {begin} and one {end} after it", 2)
        text = text[:text.index(begin)] + block + text[text.index(end) + len(end):]
    return text


def outputs(data, docs, readme, figures=True):
    """{path: text} of every file the verdicts go into (without the figure
    unless figures); raises Fail before anything is written."""
    rules = read_rules(os.path.join(data, "rules.ini"))
    d = load(data)
    d["rules"] = rules
    if not 1 <= rules["converged_at"] <= d["iterations"] - 3:
        raise Fail(f"{os.path.join(data, 'rules.ini')}: converged_at must leave 3 iterations "
                   f"after it in the {d['iterations']} iterations", 3)
    dh = load_holdout(os.path.join(data, "holdout"))
    try:
        parts = compute(d, rules, rules["margins"])
        per, comb = verdict_table(parts, rules)
        sens = sensitivity(d, rules, (per, comb))
        d["need"], d["comb"] = needed(parts, per, comb, rules), comb
        if dh is not None:
            dh["rules"] = rules
            hparts = compute(dh, rules, rules["margins"], ("exp3",))
            hper, hcomb = verdict_table(hparts, rules)
            dh["need"] = needed(hparts, hper, hcomb, rules)
            d["holdout"] = (dh, hparts, hper, hcomb)
            d["rep_cpu"] = float(dh["timing"]["exp3"]["cpu_seconds"]) / (dh["reps"] * len(MODES))
        d["added"] = judge_added(d, rules, os.path.join(data, "extensions.csv"))
    except ValueError as e:
        raise Fail(f"{data}: the results allow no test: {e}", 3) from e
    figs = {}
    if figures:
        import plot_study  # here: matplotlib's import is a second per run
    with tempfile.TemporaryDirectory() as tmp:
        for path in plot_study.study_seeds(data, tmp) if figures else ():
            with open(path, "rb") as f:
                figs[os.path.join(docs, "figures", os.path.basename(path))] = f.read()
    prows = power_rows(d, "study") + (power_rows(dh, "holdout") if dh is not None else [])
    csvs = {os.path.join(docs, PARTS_CSV[5:]): parts_csv(parts, rules),
            os.path.join(docs, POWER_CSV[5:]): power_csv(prows),
            os.path.join(docs, "power.md"): power_md(d, prows)}
    if dh is not None:
        csvs[os.path.join(docs, HOLDOUT_CSV[5:])] = parts_csv(d["holdout"][1], rules)
    return figs | csvs | {
        os.path.join(docs, "verdicts.md"): render_md(d, parts, per, comb, sens),
        os.path.join(docs, "verdicts_report.html"): report_html(d, parts, per, comb),
        readme: splice_readme(readme, [(BEGIN, END, readme_block(d, parts, per, comb)),
                                       (SPHERE_BEGIN, SPHERE_END, sphere_block(d)),
                                       (EXP3_BEGIN, EXP3_END, exp3_block(d))]),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    ap.add_argument("data", help="the study's folder (data/study)")
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 on a difference")
    ap.add_argument("--docs", default=os.path.join(here, "docs"))
    ap.add_argument("--readme", default=os.path.join(here, "README.md"))
    ap.add_argument("--no-figures", action="store_true",
                    help="the text files only: the study figure is neither drawn nor checked")
    args = ap.parse_args()
    try:
        out = outputs(args.data, args.docs, args.readme, not args.no_figures)
    except Fail as e:
        print(f"verdicts: {e}", file=sys.stderr)
        return e.code
    if args.check:
        for path, text in out.items():
            try:
                with open(path, "rb") as f:
                    same = f.read() == (text if isinstance(text, bytes) else text.encode())
            except OSError:
                same = False
            if not same:
                print(f"verdicts: {path} differs from what {args.data} gives; run make verdicts",
                      file=sys.stderr)
                return 1
        return 0
    staged = []
    try:
        for path, text in out.items():
            tmp = f"{path}.tmp.{os.getpid()}"
            os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
            with open(tmp, "wb") as f:
                f.write(text if isinstance(text, bytes) else text.encode())
            staged.append((tmp, path))
    except OSError as e:
        for tmp, _ in staged:
            os.remove(tmp)
        print(f"verdicts: {e.filename}: {e.strerror}", file=sys.stderr)
        return 2
    for tmp, path in staged:
        os.replace(tmp, path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
