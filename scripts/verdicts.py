#!/usr/bin/env python3
"""Every verdict the project prints on the thesis's claims, from the study.

Usage: verdicts.py DATA [--check] [--docs DIR] [--readme FILE]

DATA holds rules.ini (the rules, stated before the numbers) and the compact
results scripts/study_extract.py wrote (`make study`). Writes DIR/verdicts.md
(default docs/), DIR/verdicts_report.html (the report page's claims section)
and the README's table between <!-- verdicts:begin --> and <!-- verdicts:end -->;
all or nothing, only once every input has been read and checked. With
--check nothing is written: exit 1 when a file differs from what DATA gives.
Exit codes: 1 usage or a difference (--check), 2 missing or malformed input,
3 partial or mixed-configuration results.
"""
import argparse
import configparser
import csv
import html
import math
import os
import sys
from collections import defaultdict

import numpy as np

import verdict_stats as vs

MODES = ("event", "stepped", "stepped05")
MODE_LABEL = {"event": "event", "stepped": "stepped, dt 1 ms", "stepped05": "stepped, dt 0.5 ms"}
MODE_SIM = {"event": ("event", None), "stepped": ("stepped", 0.001),
            "stepped05": ("stepped", 0.0005)}
VARYING = {"exp3": ("sim.mode", "sim.dt"), "exp1": ("experiment.seed",),
           "exp2": ("experiment.seed",)}
CLAIM_IDS = ("cuts", "trees", "nmin", "map", "short", "single", "rs", "none_better", "best",
             "worst", "even", "fewest", "converged")
TREES = ("nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a")
THESIS = TREES + ("baseline",)
FILES = ("manifest.csv", "exp3_runs.csv", "exp3_curves.csv", "exp1_mse.csv", "exp1_map.csv",
         "exp2_returns.csv", "timing.csv")
BEGIN, END = "<!-- verdicts:begin -->", "<!-- verdicts:end -->"


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
        rules["settle_block"] = st.getint("settle_block")
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
        sim, dt = MODE_SIM[mode]
        if arms[mode].get("sim.mode") != sim or (dt and float(arms[mode]["sim.dt"]) != dt):
            raise Fail(f"{path}: arm {mode} has sim.mode = {arms[mode].get('sim.mode')}, "
                       f"sim.dt = {arms[mode].get('sim.dt')}", 3)
    if set(arms) != set(MODES):
        raise Fail(f"{path}: unknown Experiment 3 arm {sorted(set(arms) - set(MODES))[0]}", 3)
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
    d["seeds"] = sorted(int(s) for s in units["exp1"])
    if sorted(int(s) for s in units["exp2"]) != d["seeds"]:
        raise Fail(f"{p('manifest.csv')}: Experiments 1 and 2 ran different seeds", 3)
    d["per_seed"] = int(next(iter(units["exp1"].values()))["experiment.repetitions"])
    d["timing"] = {r["phase"]: r for r in read_csv(p("timing.csv"),
                                                   ("phase", "wall_seconds", "cpu_seconds"))}
    for ph in ("exp3", "exp12"):
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


def read_exp1(mse_path, map_path, units):
    seeds = {int(s): cfg for s, cfg in units.items()}
    mse = {}
    for line, r in enumerate(read_csv(mse_path, ("seed", "forest", "sweep", "value", "mse")), 2):
        key = (number(mse_path, line, r, "seed", int), number(mse_path, line, r, "forest", int),
               r["sweep"], number(mse_path, line, r, "value", int))
        mse[key] = number(mse_path, line, r, "mse")
    want = set()
    for s, cfg in seeds.items():
        for sweep, key in (("n_min", "exp1.n_min_list"), ("trees", "exp1.trees_list"),
                           ("cuts", "exp1.cuts_list")):
            want |= {(s, f, sweep, v) for f in range(int(cfg["experiment.repetitions"]))
                     for v in int_list(cfg, key)}
    expect_all(mse_path, set(mse), want,
               lambda k: f"seed {k[0]} forest {k[1]} {k[2]} = {k[3]}")
    maps = {}
    for line, r in enumerate(read_csv(map_path, ("seed", "pred_pocketed", "rms_rest")), 2):
        maps[number(map_path, line, r, "seed", int)] = (number(map_path, line, r, "pred_pocketed"),
                                                        number(map_path, line, r, "rms_rest"))
    expect_all(map_path, set(maps), set(seeds), lambda k: f"seed {k}")
    return mse, maps


def read_exp2(path, units):
    seeds = {int(s): cfg for s, cfg in units.items()}
    ret = {}
    for line, r in enumerate(read_csv(path, ("seed", "repetition", "size", "policy", "mode",
                                             "mean_return")), 2):
        key = (number(path, line, r, "seed", int), number(path, line, r, "repetition", int),
               number(path, line, r, "size", int), r["policy"], r["mode"])
        ret[key] = number(path, line, r, "mean_return")
    want = set()
    for s, cfg in seeds.items():
        n = max(int_list(cfg, "exp2.sizes"))
        for rep in range(int(cfg["experiment.repetitions"])):
            want.add((s, rep, 0, "expert", "mean"))
            want |= {(s, rep, n, q, m) for q in ("single", "s_a", "s_rs")
                     for m in ("mean", "sample")}
    what = lambda k: f"seed {k[0]} repetition {k[1]} size {k[2]} {k[3]} {k[4]}"  # noqa: E731
    missing = sorted(want - set(ret))
    if missing:
        raise Fail(f"{path}: no row for {what(missing[0])}", 3)
    extra = sorted({k[0] for k in ret} - set(seeds))
    if extra:
        raise Fail(f"{path}: rows for seed {extra[0]}, which the manifest does not have", 3)
    return ret


# ---------------------------------------------------------------- parts

def make_part(label, e, kind, a, b=None, unit="m"):
    """One claim part: the estimate e, its 95 % interval and the raw p-values
    of the support (kind 'gt': mean > a, 'lt': mean < a, 'in': a < mean < b)
    and of its complement."""
    lo, hi = vs.interval(e)
    if kind == "gt":
        p_s, p_r = vs.p_greater(e, a), vs.p_less(e, a)
    elif kind == "lt":
        p_s, p_r = vs.p_less(e, a), vs.p_greater(e, a)
    else:
        p_s, p_r = vs.p_tost(e, a, b), vs.p_outside(e, a, b)
    return {"label": label, "est": e.est, "lo": lo, "hi": hi, "n": e.n, "kind": kind,
            "a": a, "b": b, "p_s": p_s, "p_r": p_r, "unit": unit, "group": ""}


def share_part(label, num, den, low, high):
    """nrvr_rs's pocket-2 share in (low, high): TOST on mean(num - c den).
    Without a pocketed ball there is no share: the part is undecided (p 1)."""
    if not np.sum(den) > 0:
        return {"label": label + " (no ball in a target pocket)", "est": math.nan,
                "lo": math.nan, "hi": math.nan, "n": len(num), "kind": "in", "a": low,
                "b": high, "p_s": 1.0, "p_r": 1.0, "unit": "share", "group": ""}
    r, lo, hi = vs.fieller(num, den)
    est = lambda c: vs.share_estimate(num, den, c)  # noqa: E731
    p_s = max(vs.p_greater(est(low)), vs.p_less(est(high)))
    p_r = min(1.0, 2 * min(vs.p_less(est(low)), vs.p_greater(est(high))))
    return {"label": label, "est": r, "lo": lo, "hi": hi, "n": len(num), "kind": "in",
            "a": low, "b": high, "p_s": p_s, "p_r": p_r, "unit": "share", "group": ""}


def exp1_parts(d, m):
    """Experiment 1: per seed the forests' mean MSE of a setting relative to a
    reference setting, minus 1."""
    seeds = d["seeds"]
    cfg = next(iter(d["units"]["exp1"].values()))
    forests = range(int(cfg["experiment.repetitions"]))
    mean = {(s, sw, v): np.mean([d["exp1"][(s, f, sw, v)] for f in forests])
            for (s, _, sw, v) in d["exp1"]}

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
    gap = vs.one_sample([-d["exp1_map"][s][0] - d["exp1_map"][s][1] for s in seeds])
    out["map"].append(make_part("underestimate at pocketed positions − RMS error elsewhere",
                                gap, "gt", 0))
    return out


def exp2_parts(d, m):
    """Experiment 2 at its largest training set: per seed the mean over the
    run's repetitions."""
    seeds = d["seeds"]
    cfg = next(iter(d["units"]["exp2"].values()))
    n = max(int_list(cfg, "exp2.sizes"))
    reps = range(int(cfg["experiment.repetitions"]))

    def per_seed(size, policy, mode):
        return np.array([np.mean([d["exp2"][(s, r, size, policy, mode)] for r in reps])
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
    return out, n


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
    k0, blk = rules["converged_at"], rules["settle_block"]
    for q in THESIS:
        curves = np.stack([d["exp3"][(arm, q, r)]["curve"] for r in reps])
        its = np.arange(k0 + 1, d["iterations"] + 1)
        win = curves[:, k0:]
        slope = np.polyfit(its, win.T, 1)[0] * (its[-1] - its[0])
        settle = win.mean(axis=1) - curves[:, k0 - blk:k0].mean(axis=1)
        p = make_part(f"{q}: trend over iterations {its[0]}–{its[-1]}", vs.one_sample(slope),
                      "in", -m["flat"], m["flat"])
        s = make_part(f"{q}: window − iterations {k0 - blk + 1}–{k0}", vs.one_sample(settle),
                      "lt", m["flat"])
        p["group"] = s["group"] = "converged"
        out["converged"] += [p, s]
    for q in THESIS:
        p = make_part(f"hand-crafted − {q}", vs.paired(ret["handcrafted"], ret[q]), "gt",
                      m["considerable"])
        p["group"] = "poor"
        out["converged"].append(p)
    return out


def mode_of(cfg):
    for mode, (sim, dt) in MODE_SIM.items():
        if cfg["sim.mode"] == sim and (dt is None or float(cfg["sim.dt"]) == dt):
            return mode
    raise Fail(f"manifest.csv: sim.mode {cfg['sim.mode']}, dt {cfg['sim.dt']} is no mode", 3)


def compute(d, rules, margins):
    """{(claim, mode): [part]} with Holm-adjusted p-values per mode (the family:
    every part of every claim judged in that mode, support and refutation)."""
    m = {k: v["value"] for k, v in margins.items()}
    parts = defaultdict(list)
    m1 = mode_of(next(iter(d["units"]["exp1"].values())))
    m2 = mode_of(next(iter(d["units"]["exp2"].values())))
    for cid, ps in exp1_parts(d, m).items():
        parts[(cid, m1)] = ps
    e2, _ = exp2_parts(d, m)
    for cid, ps in e2.items():
        parts[(cid, m2)] = ps
    for arm in MODES:
        for cid, ps in exp3_parts(d, arm, m, rules).items():
            parts[(cid, arm)] = ps
    for mode in MODES:
        # a hypothesis two claims share (the same part) counts once
        fam = {}
        for (c, md), ps in parts.items():
            if md == mode:
                for p in ps:
                    fam.setdefault((p["label"], p["kind"], p["a"], p["b"]), []).append(p)
        keys = list(fam)
        adj = vs.holm([fam[k][0]["p_s"] for k in keys] + [fam[k][0]["p_r"] for k in keys])
        for k, a_s, a_r in zip(keys, adj[:len(keys)], adj[len(keys):]):
            for p in fam[k]:
                p["adj_s"], p["adj_r"] = a_s, a_r
                p["verdict"] = vs.part_verdict(a_s, a_r, rules["alpha"])
                p["family"] = 2 * len(keys)
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
    elif unit == "share":
        s = f"{x:.3f}"
    else:
        s = f"{x:+.{3 if unit == 'm' else 2}f}"
    if not signed:
        s = s.lstrip("+")
    return s.replace("-", "−")


UNIT = {"rel": " % of the MSE", "m": " m", "n": " balls", "ms": " m/s", "share": ""}


def ci(p):
    u = p["unit"]
    return f"{num(p['est'], u)} [{num(p['lo'], u)}, {num(p['hi'], u)}]{UNIT[u]}"


def hyp(p):
    u = p["unit"]
    tail = {"rel": " %", "m": " m", "n": "", "ms": " m/s", "share": ""}[u]
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
        return max(ps, key=lambda p: p["adj_s"])
    if verdict == vs.DISAGREES:
        return min((p for p in ps if p["verdict"] == vs.DISAGREES), key=lambda p: p["adj_r"])
    return next(p for p in ps if p["verdict"] == vs.UNDECIDED)


def cell(parts, per, cid, mode, rules):
    if (cid, mode) not in parts:
        return "–"
    v = per[cid][mode]
    p = deciding(parts[(cid, mode)], v)
    return f"**{v}**: {p['label']} {ci(p)}"


def units_text(d):
    return (f"Experiment 3: {d['reps']} repetitions per mode; Experiments 1 and 2: "
            f"{len(d['seeds'])} seeds (event mode) of {d['per_seed']} forests or repetitions "
            "each")


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
    return ("**Ranking of Experiment 3** (mean return of the last episodes; above the "
            "baseline: paired 95 % interval above 0): " + "; ".join(bits) + ". The thesis "
            "has nrvr_rs best, about 0.1 above the baseline.")


def scale_ratios(d, parts, margins):
    """Each return margin as a fraction of the hand-crafted − baseline distance per mode."""
    gap = {}
    for mode in MODES:
        reps = range(d["reps"])
        h = np.mean([d["exp3"][(mode, "handcrafted", r)]["mean_return"] for r in reps])
        b = np.mean([d["exp3"][(mode, "baseline", r)]["mean_return"] for r in reps])
        gap[mode] = h - b
    return gap


def render_md(d, parts, per, comb, sens):
    rules = d["rules"]
    gap = scale_ratios(d, parts, rules["margins"])
    fams = {m: next(p["family"] for (c, md), ps in parts.items() if md == m for p in ps)
            for m in MODES}
    mrows = []
    for k, mg in rules["margins"].items():
        ratio = ("; ".join(f"{mg['value'] / gap[m]:.0%} in {MODE_LABEL[m]}" for m in MODES)
                 if mg["unit"] == "m" else "–")
        mrows.append([f"`{k}`", f"{mg['value']:g} {mg['unit']}", mg["why"], ratio])
    srows = []
    for cid in CLAIM_IDS:
        c = rules["claims"][cid]
        srows.append([f"{c['section']} {c['short']}"] +
                     [cell(parts, per, cid, m, rules) for m in MODES] + [f"**{comb[cid]}**"])
    out = [HEAD_MD.format(units=units_text(d), alpha=rules["alpha"],
                          fams=", ".join(f"{MODE_LABEL[m]} {fams[m]}" for m in MODES))]
    out.append(md_table(["margin", "value", "why", "as a share of hand-crafted − baseline "
                         f"({', '.join(num(gap[m], 'm') for m in MODES)} m)"], mrows))
    out.append("\n## Verdicts\n\nEach cell: the mode's verdict, then the part that decides "
               "it (the weakest support of an agreeing claim, the strongest refutation of a "
               "disagreeing one, else the first undecided part): estimate [95 % t interval]. "
               "The last column is the verdict common to the modes, undecided where they "
               "differ.\n")
    out.append(md_table(["claim"] + [MODE_LABEL[m] for m in MODES] + ["verdict"], srows))
    out.append("\n" + "\n\n".join(not_reproduced(d, per, comb)))
    out.append("\n## The claims one by one\n\nColumns: the part; its alternative hypothesis "
               "(what the claim says); the mode; the estimate with its 95 % t interval; the "
               "support's p-value raw and Holm-adjusted; the refutation's (the complement: "
               "the other side of the same bound) raw and Holm-adjusted; the part's verdict.")
    for cid in CLAIM_IDS:
        out.append(claim_section(cid, rules, parts, per, comb))
    out.append(sens_md(sens, rules))
    out.append(time_md(d))
    return "\n".join(out) + "\n"


HEAD_MD = """# The thesis's claims, judged: rules, tests and verdicts

<!-- Generated by scripts/verdicts.py from data/study/ (rules: data/study/rules.ini,
     results: `make study`). Do not edit: run `make verdicts`. -->

Every verdict this project prints on the thirteen claims of the thesis's discussions
(sections 7.3.2, 7.4.2 and 7.5.2) comes from this page's generator, over the committed
results of one study: {units}. The rules were written into `data/study/rules.ini` before
the study's numbers were read; `make verdicts` applies them, `make verdicts CHECK=1`
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
  t tests; "no considerable difference", "almost as good", "≈ 0.1 above", "almost evenly",
  "converged": equivalence by two one-sided tests (TOST) with a stated margin; their
  refutation: the value lies outside the band (twice the smaller one-sided p). Intervals
  are 95 % Student-t intervals, written [lo, hi]; SD always means standard deviation.
- **Multiplicity.** Holm's step-down adjustment over the whole family of a mode: every
  support and every refutation p-value of every claim judged in that mode ({fams}
  tests; a part two claims share counts once). A part **agrees** when its support's adjusted p is below α = {alpha},
  **disagrees** when its refutation's is, and is **undecided** (not enough power to tell)
  when neither is.
- **Claims.** A claim agrees when every part agrees, disagrees when any part disagrees,
  else is undecided ("many": at least the stated number of parts). The verdict column is
  the verdict all modes share; where they differ it is undecided.

## Margins

Returns are minus the reward ball's final distance to the nearest target pocket (eq. 7.7),
so return margins are distances in metres. The last column puts each against the task's
scale: the distance between the one-node baseline and the hand-crafted policy (beyond the
thesis) in the same mode; the sensitivity table below halves and doubles each margin.
"""


def claim_section(cid, rules, parts, per, comb):
    c = rules["claims"][cid]
    rows = []
    for mode in MODES:
        for p in parts.get((cid, mode), []):
            rows.append([p["label"], hyp(p), MODE_LABEL[mode], ci(p), fp(p["p_s"]),
                         fp(p["adj_s"]), fp(p["p_r"]), fp(p["adj_r"]), p["verdict"]])
    verdicts = "; ".join(f"{MODE_LABEL[m]}: **{per[cid][m]}**" for m in MODES if m in per[cid])
    return (f"\n### {c['section']} {c['short']} (`{cid}`)\n\n> {c['words']}\n\n"
            f"**Reading.** {c['reading']}\n\n**Test.** {c['test']}\n\n" +
            md_table(["part", "H1", "mode", "estimate [95 %]", "p", "p Holm", "p refute",
                      "p refute Holm", "part"], rows) +
            f"\n\n**Verdict**: {verdicts}; over the modes: **{comb[cid]}**.")


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
            "`exp2_returns.csv` and `manifest.csv` (every unit's configuration; mixed "
            "configurations are refused). Measured on this machine, shared with other jobs: "
            f"Experiment 3 ({d['reps']} repetitions × 6 variants × 3 modes) {f('exp3')}; "
            f"Experiments 1 and 2 ({len(d['seeds'])} seeds each) {f('exp12')}. "
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
              "the mode's verdict, then the part that decides it, estimate [95 % t interval]; "
              "Holm-adjusted over every test of the mode. Verdict: common to the three modes "
              "(event, stepped at dt 1 ms and 0.5 ms), else undecided; –: Experiments 1 and 2 "
              "ran in event mode only.")
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
            "that decides it: estimate [95 % t interval], Holm-adjusted over every test of the "
            "mode. Rules and every part: docs/verdicts.md.</p>\n"
            f"<table><tr><th>thesis</th><th>claim</th>{head}<th>verdict</th></tr>\n" +
            "\n".join(rows) + f"\n</table>\n{notes}\n")


# ---------------------------------------------------------------- output

def splice_readme(path, block):
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError as e:
        raise Fail(f"{path}: {e.strerror}", 2) from e
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        raise Fail(f"{path}: needs one {BEGIN} and one {END} after it", 2)
    return text[:text.index(BEGIN)] + block + text[text.index(END) + len(END):]


def outputs(data, docs, readme):
    """{path: text} of every file the verdicts go into; raises Fail before
    anything is written."""
    rules = read_rules(os.path.join(data, "rules.ini"))
    d = load(data)
    d["rules"] = rules
    if not rules["settle_block"] <= rules["converged_at"] <= d["iterations"] - 3:
        raise Fail(f"{os.path.join(data, 'rules.ini')}: converged_at must leave settle_block "
                   f"iterations before it and 3 after it in the {d['iterations']} iterations", 3)
    try:
        parts = compute(d, rules, rules["margins"])
        per, comb = verdict_table(parts, rules)
        sens = sensitivity(d, rules, (per, comb))
    except ValueError as e:
        raise Fail(f"{data}: the results allow no test: {e}", 3) from e
    return {
        os.path.join(docs, "verdicts.md"): render_md(d, parts, per, comb, sens),
        os.path.join(docs, "verdicts_report.html"): report_html(d, parts, per, comb),
        readme: splice_readme(readme, readme_block(d, parts, per, comb)),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    ap.add_argument("data", help="the study's folder (data/study)")
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 on a difference")
    ap.add_argument("--docs", default=os.path.join(here, "docs"))
    ap.add_argument("--readme", default=os.path.join(here, "README.md"))
    args = ap.parse_args()
    try:
        out = outputs(args.data, args.docs, args.readme)
    except Fail as e:
        print(f"verdicts: {e}", file=sys.stderr)
        return e.code
    if args.check:
        for path, text in out.items():
            try:
                with open(path, encoding="utf-8") as f:
                    same = f.read() == text
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
            with open(tmp, "w", encoding="utf-8") as f:
                f.write(text)
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
