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

MODES = ("event", "stepped", "stepped05")
MODE_LABEL = {"event": "event", "stepped": "stepped, dt 1 ms", "stepped05": "stepped, dt 0.5 ms"}
MODE_SIM = {"event": ("event", None), "stepped": ("stepped", 0.001),
            "stepped05": ("stepped", 0.0005)}
VARYING = {"exp3": ("sim.mode", "sim.dt"), "sphere": ("policy.cov_center", "bench.method"), "exp1": ("experiment.seed", "sim.mode", "sim.dt"),
           "exp2": ("experiment.seed", "sim.mode", "sim.dt")}
CLAIM_IDS = ("cuts", "trees", "nmin", "map", "short", "single", "rs", "none_better", "best",
             "worst", "even", "fewest", "converged")
TREES = ("nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a")
THESIS = TREES + ("baseline",)
FILES = ("manifest.csv", "exp3_runs.csv", "exp3_curves.csv", "exp1_mse.csv", "exp1_map.csv",
         "exp2_returns.csv", "sphere_curves.csv", "timing.csv")
BEGIN, END = "<!-- verdicts:begin -->", "<!-- verdicts:end -->"
SPHERE_BEGIN, SPHERE_END = "<!-- sphere:begin -->", "<!-- sphere:end -->"
# the sphere benchmark's runs: (method, its poolreps settings)
SPHERE = {"creps_old": {"policy.cov_center": "old", "bench.method": "creps"},
          "creps_new": {"policy.cov_center": "new", "bench.method": "creps"},
          "ccmaes": {"bench.method": "ccmaes"}}


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
        rules["run_alpha"] = st.getfloat("run_alpha")
        rules["many"] = st.getint("many")
        m = cfg["margins"]
        for k in m:
            if "." not in k:
                rules["margins"][k] = {"value": m.getfloat(k), "unit": m[f"{k}.unit"],
                                       "why": m[f"{k}.why"]}
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


def read_manifest(path):
    """{experiment: {unit: {key: value}}}, every unit of an experiment with the
    same configuration but for its VARYING keys."""
    units = defaultdict(dict)
    for r in read_csv(path, ("experiment", "unit", "key", "value")):
        units[r["experiment"]].setdefault(r["unit"], {})[r["key"]] = r["value"]
    for exp in VARYING:
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
    for exp, us in units.items():
        if exp == "sphere":
            continue
        for unit, cfg in us.items():
            mode = unit.split("/")[0]
            sim, dt = MODE_SIM.get(mode, (None, None))
            if cfg.get("sim.mode") != sim or (dt and float(cfg.get("sim.dt", "nan")) != dt):
                raise Fail(f"{path}: {exp} {unit} has sim.mode = {cfg.get('sim.mode')}, "
                           f"sim.dt = {cfg.get('sim.dt')}", 3)
    return units


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
    units = read_manifest(p("manifest.csv"))
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
    d["timing"] = {r["phase"]: r for r in read_csv(p("timing.csv"),
                                                   ("phase", "wall_seconds", "cpu_seconds"))}
    for ph in ("exp3", "exp12", "sphere"):
        if ph not in d["timing"]:
            raise Fail(f"{p('timing.csv')}: no row for phase {ph}", 3)
    d["version"] = c3.get("version", "?")
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
            "ci": lambda level: vs.interval(e, level)}


def share_part(label, num, den, low, high):
    """nrvr_rs's pocket-2 share in (low, high): TOST on mean(num - c den),
    the interval Fieller's. Without a pocketed ball there is no share: the
    part is undecided (p 1)."""
    part = {"label": label, "n": len(num), "kind": "in", "a": low, "b": high,
            "unit": "share", "group": ""}
    if not np.sum(den) > 0:
        return part | {"label": label + " (no ball in a target pocket)", "est": math.nan,
                       "p_s": 1.0, "p_r": 1.0, "ci": lambda level: (math.nan, math.nan)}
    est = lambda c: vs.share_estimate(num, den, c)  # noqa: E731
    p_s = max(vs.p_greater(est(low)), vs.p_less(est(high)))
    p_r = min(1.0, 2 * min(vs.p_less(est(low)), vs.p_greater(est(high))))
    return part | {"est": float(np.sum(num) / np.sum(den)), "p_s": p_s, "p_r": p_r,
                   "ci": lambda level: vs.fieller(num, den, level)[1:]}


def count_part(label, k, n, bound):
    """The share k / n of units with a property is below bound: exact binomial
    tests, Clopper-Pearson intervals."""
    return {"label": label, "est": k / n, "n": n, "k": k, "kind": "lt", "a": bound,
            "b": None, "p_s": vs.p_binom_less(k, n, bound),
            "p_r": vs.p_binom_greater(k, n, bound), "unit": "count", "group": "",
            "ci": lambda level: vs.clopper_pearson(k, n, level)}


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
        moving = [run_moving(d, (arm, q, r), k0, m["flat"], rules["run_alpha"]) for r in reps]
        p = count_part(f"{q}: share of runs still moving after iteration {k0}", sum(moving),
                       len(moving), m["unsettled"])
        p["group"] = "converged"
        out["converged"].append(p)
    for q in THESIS:
        p = make_part(f"hand-crafted − {q}", vs.paired(ret["handcrafted"], ret[q]), "gt",
                      m["considerable"])
        p["group"] = "poor"
        out["converged"].append(p)
    return out


def run_moving(d, key, k0, flat, alpha):
    """A run is still moving when its own trend over its curve from iteration
    k0 on lies beyond +flat or beyond -flat by a one-sided t test at alpha."""
    # the trend does not depend on the margins: computed once, not per
    # sensitivity variant
    cache = d.setdefault("trends", {})
    if (key, k0) not in cache:
        cache[(key, k0)] = vs.trend(d["exp3"][key]["curve"][k0:])
    e = cache[(key, k0)]
    return vs.p_greater(e, flat) < alpha or vs.p_less(e, -flat) < alpha


def task_gap(d, mode):
    """The task's scale in a mode: mean return of the hand-crafted policy minus
    the one-node baseline's, over the repetitions."""
    reps = range(d["reps"])
    h = np.mean([d["exp3"][(mode, "handcrafted", r)]["mean_return"] for r in reps])
    b = np.mean([d["exp3"][(mode, "baseline", r)]["mean_return"] for r in reps])
    return float(h - b)


def mode_margins(d, margins, mode):
    """The margins' values in a mode: those given as a share of the task's
    scale ('gap') in metres of that mode."""
    return {k: v["value"] * (task_gap(d, mode) if v["unit"] == "gap" else 1)
            for k, v in margins.items()}


def compute(d, rules, margins):
    """{(claim, mode): [part]} with Holm-adjusted p-values per mode. The family
    is the same in every mode: every support and refutation of every part of
    the 13 claims (Experiments 1 to 3 all ran in each mode)."""
    parts = defaultdict(list)
    for arm in MODES:
        m = mode_margins(d, margins, arm)
        for gen in (exp1_parts(d, m, arm), exp2_parts(d, m, arm), exp3_parts(d, arm, m, rules)):
            for cid, ps in gen.items():
                parts[(cid, arm)] = ps
    sizes = set()
    for mode in MODES:
        # a hypothesis two claims share (the same part) counts once
        fam = {}
        for (c, md), ps in parts.items():
            if md == mode:
                for p in ps:
                    fam.setdefault((p["label"], p["kind"], p["a"], p["b"]), []).append(p)
        keys = list(fam)
        ps_all = [fam[k][0]["p_s"] for k in keys] + [fam[k][0]["p_r"] for k in keys]
        adj, lvl = vs.holm(ps_all), vs.holm_levels(ps_all, rules["alpha"])
        n = len(keys)
        for i, k in enumerate(keys):
            for p in fam[k]:
                p["adj_s"], p["adj_r"] = adj[i], adj[n + i]
                p["verdict"] = vs.part_verdict(adj[i], adj[n + i], rules["alpha"])
                p["family"] = 2 * n
                levels(p, lvl[i], lvl[n + i])
        sizes.add((2 * n, tuple(sorted((c for c, md in parts if md == mode)))))
    if len(sizes) != 1:
        raise ValueError("the modes' families differ")
    return parts


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
                 for cid in CLAIM_IDS}


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
        s = f"{x:+.{3 if unit == 'm' else 2}f}"
    if not signed:
        s = s.lstrip("+")
    return s.replace("-", "−")


UNIT = {"rel": " % of the MSE", "m": " m", "n": " balls", "ms": " m/s", "share": "",
        "count": ""}


def level(x):
    """A confidence level in per cent, with the digits that tell it apart."""
    return f"{100 * x:.{max(0, min(4, math.ceil(-math.log10(max(1 - x, 1e-9))) - 1))}f} %"


def est(p):
    u = p["unit"]
    if u == "count":
        return f"{p['k']}/{p['n']} = {num(p['est'], u)}"
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
    head = (f"{p['k']}/{p['n']} = {num(p['est'], u)}" if u == "count" else num(p["est"], u))
    return f"{head} [{num(lo, u)}, {num(hi, u)}]{UNIT[u]} ({level(lvl)})"


def hyp(p):
    u = p["unit"]
    tail = {"rel": " %", "m": " m", "n": "", "ms": " m/s", "share": "", "count": ""}[u]
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
             "the pocket share, Clopper-Pearson for the share of moving runs.")


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
    """The margins table: value, why, and the value against the task's scale
    (or, for a share of it, in metres) per mode."""
    gap = {m: task_gap(d, m) for m in MODES}
    rows = []
    for k, mg in margins.items():
        if mg["unit"] == "m":
            scale = "; ".join(f"{mg['value'] / gap[m]:.0%} in {MODE_LABEL[m]}" for m in MODES)
        elif mg["unit"] == "gap":
            scale = "; ".join(f"{mg['value'] * gap[m]:.3f} m in {MODE_LABEL[m]}" for m in MODES)
        else:
            scale = "–"
        value = (f"{mg['value']:g} of hand-crafted − baseline" if mg["unit"] == "gap"
                 else f"{mg['value']:g} {mg['unit']}")
        rows.append([f"`{k}`", value, mg["why"], scale])
    return rows, gap


def render_md(d, parts, per, comb, sens):
    rules = d["rules"]
    mrows, gap = margin_rows(d, rules["margins"])
    fam = next(p["family"] for ps in parts.values() for p in ps)
    srows = []
    for cid in CLAIM_IDS:
        c = rules["claims"][cid]
        srows.append([f"{c['section']} {c['short']}"] +
                     [cell(parts, per, cid, m, rules) for m in MODES] + [f"**{comb[cid]}**"])
    out = [HEAD_MD.format(units=units_text(d), alpha=rules["alpha"], fam=fam,
                          run_alpha=rules["run_alpha"])]
    out.append(md_table(["margin", "value", "why", "against the task's scale, hand-crafted − "
                         f"baseline ({', '.join(num(gap[m], 'm') for m in MODES)} m)"], mrows))
    out.append("\n## Verdicts\n\nEach cell: the mode's verdict, then the part that decides "
               "it (the weakest support of an agreeing claim, the strongest refutation of a "
               "disagreeing one, else the first undecided part): estimate [lo, hi] (level). "
               + CI_LEGEND + " The last column is the verdict common to the modes, undecided "
               "where they differ.\n")
    out.append(md_table(["claim"] + [MODE_LABEL[m] for m in MODES] + ["verdict"], srows))
    out.append("\n" + "\n\n".join(not_reproduced(d, per, comb)))
    out.append(f"\n![seed spread](figures/{exp_data.STUDY_SEEDS_STEM}.png)\n\n*Figure: the seed spread "
               "behind the Experiment 1 and 2 verdicts (event mode). Top: the test MSE of each "
               "setting relative to its reference, one grey dot per seed (the mean of its run's "
               "forests), the mean over the seeds with its 95 % t interval (a description, not "
               "the Holm-level interval of the tables), one y-scale for the three sweeps; the "
               "thesis's Fig. 7.4 shows one run's forests instead (our Fig. 7.4a–c do too). "
               "Below: Experiment 2's mean return at the largest training set per seed (the "
               "mean of its repetitions), with mean and sampled actions on one y-scale; the "
               "thesis's Fig. 7.6 shows one run over the training-set sizes.*")
    out.append("\n## The claims one by one\n\nColumns: the part; its alternative hypothesis "
               "(what the claim says); the mode; the estimate; the support's interval at the "
               "level Holm's procedure judged the support at (it lies inside the H1 region "
               "exactly when the support's Holm-adjusted p is below α); the support's p-value "
               "raw and Holm-adjusted; the refutation's interval at its own Holm level (it lies "
               "outside the H1 region exactly when the refutation's adjusted p is below α) and "
               "p-values (the refutation is the complement: the other side of the same bound, "
               "or outside the band); the part's verdict. " + CI_LEGEND)
    for cid in CLAIM_IDS:
        out.append(claim_section(cid, rules, parts, per, comb, d))
    out.append(sens_md(sens, rules))
    out.append(time_md(d))
    return "\n".join(out) + "\n"


HEAD_MD = """# The thesis's claims, judged: rules, tests and verdicts

<!-- Generated by scripts/verdicts.py from data/study/ (rules: data/study/rules.ini,
     results: `make study`). Do not edit: run `make verdicts`. -->

Every verdict this project prints on the thirteen claims of the thesis's discussions
(sections 7.3.2, 7.4.2 and 7.5.2) comes from this page's generator, over the committed
results of one study: {units}. The rules are stated in `data/study/rules.ini`, apart from
the numbers; `make verdicts` applies them, `make verdicts CHECK=1`
(part of `make check`) fails when this page, the README's table or the report page's
claims section differ from what the results give.

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
  run: a run is still moving when its own trend after the convergence point lies beyond the
  `flat` margin by a one-sided t test at {run_alpha}; the part is the share of a policy's
  runs still moving, below the `unsettled` margin by an exact binomial test. SD always
  means standard deviation.
- **Multiplicity.** Holm's step-down adjustment over one family per mode, the same in
  every mode: every support and every refutation p-value of every part of the 13 claims
  ({fam} tests per mode; a part two claims share counts once). Experiments 1 and 2 ran
  in every mode, so each mode's family holds the same claims and parts, and a piece of
  evidence meets the same bar in every mode. A part **agrees** when its support's adjusted p
  is below α = {alpha}, **disagrees** when its refutation's is, and is **undecided** (not
  enough power to tell) when neither is.
- **Intervals.** Every interval printed with a verdict is the one that decides it: at the
  level Holm's procedure judged the test at (the k-th smallest p of the family against α
  / (m − k + 1), until the first that fails; the later ones at that failing level), two
  one-sided bounds at 1 − that level for a one-sided test or TOST, so the interval lies
  in the claim's region exactly when the adjusted p is below α. The level is printed
  beside each interval.
- **Claims.** A claim agrees when every part agrees, disagrees when any part disagrees,
  else is undecided ("many": at least the stated number of parts). The verdict column is
  the verdict all modes share; where they differ it is undecided.

## Margins

Returns are minus the reward ball's final distance to the nearest target pocket (eq. 7.7),
so return margins are distances in metres. The last column puts each against the task's
scale: the distance between the one-node baseline and the hand-crafted policy (beyond the
thesis) in the same mode; a margin given as a share of that distance (`flat`) is converted
to metres per mode from the baseline and hand-crafted runs, which no part it serves tests.
The sensitivity table below halves and doubles each margin.
"""


def control_text(d, rules):
    """The convergence rule applied to the hand-crafted policy, which no claim
    is about: evidence that the rule can be met."""
    k0, bits = rules["converged_at"], []
    for mode in MODES:
        flat = mode_margins(d, rules["margins"], mode)["flat"]
        moving = [run_moving(d, (mode, "handcrafted", r), k0, flat, rules["run_alpha"])
                  for r in range(d["reps"])]
        bits.append(f"{MODE_LABEL[mode]} {sum(moving)}/{len(moving)}")
    return ("**Control** (not a part): the same rule on the hand-crafted policy, which no "
            "claim is about, counts as still moving: " + "; ".join(bits) + ".")


def claim_section(cid, rules, parts, per, comb, d):
    c = rules["claims"][cid]
    rows = []
    for mode in MODES:
        for p in parts.get((cid, mode), []):
            rows.append([p["label"], hyp(p), MODE_LABEL[mode], est(p), interval_text(p, "s"),
                         f"{fp(p['p_s'])} ({fp(p['adj_s'])})", interval_text(p, "r"),
                         f"{fp(p['p_r'])} ({fp(p['adj_r'])})", p["verdict"]])
    verdicts = "; ".join(f"{MODE_LABEL[m]}: **{per[cid][m]}**" for m in MODES if m in per[cid])
    return (f"\n### {c['section']} {c['short']} (`{cid}`)\n\n> {c['words']}\n\n"
            f"**Reading.** {c['reading']}\n\n**Test.** {c['test']}\n\n" +
            md_table(["part", "H1", "mode", "estimate", "support's interval (level)",
                      "p (Holm)", "refutation's interval (level)", "p refute (Holm)", "part"],
                     rows) +
            f"\n\n**Verdict**: {verdicts}; over the modes: **{comb[cid]}**." +
            (f"\n\n{control_text(d, rules)}" if cid == "converged" else ""))


def sens_md(sens, rules):
    rows = []
    for name, mg, (h_chg, h_comb), (d_chg, d_comb) in sens:
        fmt = lambda chg, cmb: (f"{len(chg)} ({len(cmb)} combined)" +  # noqa: E731
                                (": " + ", ".join(sorted({c for c, _ in chg})) if chg else ""))
        unit = "of hand-crafted − baseline" if mg["unit"] == "gap" else mg["unit"]
        rows.append([f"`{name}` = {mg['value']:g} {unit}", fmt(h_chg, h_comb),
                     fmt(d_chg, d_comb)])
    return ("\n## Sensitivity to the margins\n\nHow many of the claim × mode verdicts (and of "
            "the combined verdicts) change when one margin is halved or doubled, the others "
            "kept; the claims that change are named. A margin can change a claim that does not use "
            "it: its tests move in the Holm ranking of the mode's family.\n\n" +
            md_table(["margin", "halved", "doubled"], rows))


def time_md(d):
    t = d["timing"]
    f = lambda ph: (f"{float(t[ph]['wall_seconds']):.0f} s wall, "  # noqa: E731
                    f"{float(t[ph]['cpu_seconds']):.0f} s CPU")
    return ("\n## Data and time\n\n`make study` (not part of `make reproduce`) runs the study "
            "on the sweep and collect machinery (docs/cluster.md) and writes the compact "
            "results to `data/study/`: `exp3_runs.csv` (one row per run), `exp3_curves.csv` "
            "(each run's mean return per iteration), `exp1_mse.csv`, `exp1_map.csv`, "
            "`exp2_returns.csv`, `sphere_curves.csv` (the contextual sphere benchmark behind "
            "the README's sentence on it) and `manifest.csv` (every unit's configuration; "
            "mixed configurations are refused). Measured on this machine, shared with other "
            f"jobs: Experiment 3 ({d['reps']} repetitions × 6 variants × 3 modes) {f('exp3')}; "
            f"Experiments 1 and 2 ({len(d['seeds'])} seeds each in each of the three modes) "
            f"{f('exp12')}; the sphere benchmark (3 methods) {f('sphere')}. "
            f"Version of the runs: `{d['version']}`.")


def readme_block(d, parts, per, comb):
    rules = d["rules"]
    rows = []
    for cid in CLAIM_IDS:
        c = rules["claims"][cid]
        step = cell(parts, per, cid, "stepped", rules)
        if (cid, "stepped05") in parts and per[cid]["stepped05"] != per[cid]["stepped"]:
            step += f" (dt 0.5 ms: {per[cid]['stepped05']})"
        rows.append([f"{c['section']} {c['short']}", cell(parts, per, cid, "event", rules), step,
                     f"**{comb[cid]}**"])
    legend = (f"Generated by `make verdicts` from the committed study ({units_text(d)}; "
              "rules, tests and every part: [docs/verdicts.md](docs/verdicts.md)). Each cell: "
              "the mode's verdict, then the part that decides it: estimate [lo, hi] (level), "
              "Holm-adjusted over every test of the mode (the same family in every mode). " +
              CI_LEGEND + " Verdict: common to the three modes (event, stepped at dt 1 ms and "
              "0.5 ms), else undecided; where dt 0.5 ms differs from dt 1 ms its verdict is "
              "named.")
    return "\n".join([BEGIN, legend, "", md_table(
        ["thesis claim", f"event, {d['reps']} reps", f"stepped (dt 1 ms), {d['reps']} reps",
         "verdict"], rows), "", "\n\n".join(not_reproduced(d, per, comb)), END])


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
            f"mode (the same family in every mode). {esc(CI_LEGEND)} Rules and every part: "
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
            f"docs/reps_policy.md.\n{SPHERE_END}")


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
    try:
        parts = compute(d, rules, rules["margins"])
        per, comb = verdict_table(parts, rules)
        sens = sensitivity(d, rules, (per, comb))
    except ValueError as e:
        raise Fail(f"{data}: the results allow no test: {e}", 3) from e
    figs = {}
    if figures:
        import plot_study  # here: matplotlib's import is a second per run
    with tempfile.TemporaryDirectory() as tmp:
        for path in plot_study.study_seeds(data, tmp) if figures else ():
            with open(path, "rb") as f:
                figs[os.path.join(docs, "figures", os.path.basename(path))] = f.read()
    return figs | {
        os.path.join(docs, "verdicts.md"): render_md(d, parts, per, comb, sens),
        os.path.join(docs, "verdicts_report.html"): report_html(d, parts, per, comb),
        readme: splice_readme(readme, [(BEGIN, END, readme_block(d, parts, per, comb)),
                                       (SPHERE_BEGIN, SPHERE_END, sphere_block(d))]),
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
