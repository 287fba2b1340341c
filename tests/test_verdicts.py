"""docs/verdicts.md against an oracle: every part's estimate, 95 % interval,
raw and Holm-adjusted p-values and verdict recomputed with scipy.stats from
the committed results in data/study/, written from the rules' text
(data/study/rules.ini), sharing no code with scripts/verdicts.py. Also: the
generator refuses missing, partial and mixed-configuration results with one
line and changes no file, and --check sees a difference."""
import configparser
import csv
import hashlib
import math
import os
import re
import shutil
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "data" / "study"
PY = os.environ.get("PYTHON", sys.executable)
MODES = {"event": "event", "stepped": "stepped, dt 1 ms", "stepped05": "stepped, dt 0.5 ms"}
TREES = ["nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a"]
THESIS = TREES + ["baseline"]


def rows(name, data=DATA):
    with open(data / name, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def rules():
    c = configparser.ConfigParser(interpolation=None)
    c.read(DATA / "rules.ini", encoding="utf-8")
    return c


def manifest_of(data=DATA):
    m = defaultdict(dict)
    for r in rows("manifest.csv", data):
        m[(r["experiment"], r["unit"])][r["key"]] = r["value"]
    return m




# ---------------------------------------------------------------- oracle
# Each part is [est, p_s, p_r, interval(level), group] here; the intervals are
# drawn at the Holm levels once the family's p-values are known.

def one_sided(x, bound, alt):
    return stats.ttest_1samp(x, bound, alternative=alt).pvalue


def part(x, kind, a, b=None):
    """(est, p_support, p_refute, interval at a level, two-sided refutation?)"""
    x = np.asarray(x, float)
    ci = lambda L: tuple(stats.ttest_1samp(x, 0.0).confidence_interval(L))  # noqa: E731
    if kind == "gt":
        ps, pr = one_sided(x, a, "greater"), one_sided(x, a, "less")
    elif kind == "lt":
        ps, pr = one_sided(x, a, "less"), one_sided(x, a, "greater")
    elif a == -math.inf:
        ps, pr = one_sided(x, b, "less"), one_sided(x, b, "greater")
    else:
        ps = max(one_sided(x, a, "greater"), one_sided(x, b, "less"))
        pr = min(1.0, 2 * min(one_sided(x, a, "less"), one_sided(x, b, "greater")))
    return [x.mean(), ps, pr, ci, kind == "in" and a != -math.inf, ""]


def share(n2, tot, low, high):
    """Pooled share, its interval from inverting the t test of n2 - c tot, TOST."""
    from scipy.optimize import brentq
    n2, tot = np.asarray(n2, float), np.asarray(tot, float)
    r = n2.sum() / tot.sum()
    t = lambda c: stats.ttest_1samp(n2 - c * tot, 0).statistic  # noqa: E731

    def ci(L):
        q = stats.t.ppf(0.5 + L / 2, len(n2) - 1)
        return brentq(lambda c: t(c) - q, -1, r), brentq(lambda c: t(c) + q, r, 2)
    ps = max(one_sided(n2 - low * tot, 0, "greater"), one_sided(n2 - high * tot, 0, "less"))
    pr = min(1.0, 2 * min(one_sided(n2 - low * tot, 0, "less"),
                          one_sided(n2 - high * tot, 0, "greater")))
    return [r, ps, pr, ci, True, ""]


def drift(cv, k0, flat):
    """The mean over runs of c^2 - se^2, c the least-squares change of a run's
    curve after iteration k0 (slope x (window - 1), scipy's linregress) and se
    its standard error: one-sided t test against flat^2."""
    d = []
    for c in cv:
        y = c[k0:]
        fit = stats.linregress(np.arange(len(y)), y)
        w = len(y) - 1
        d.append((fit.slope * w) ** 2 - (fit.stderr * w) ** 2)
    return part(d, "lt", flat ** 2)


def exp12_oracle(arm, mg, c1, c2):
    """Experiments 1 and 2 in one arm: ({label: part} of 1, of 2)."""
    ev = {}
    seeds = sorted({int(r["seed"]) for r in rows("exp1_mse.csv") if r["arm"] == arm})
    acc = defaultdict(list)
    for r in rows("exp1_mse.csv"):
        if r["arm"] == arm:
            acc[(int(r["seed"]), r["sweep"], int(r["value"]))].append(float(r["mse"]))
    mse = {k: np.mean(v) for k, v in acc.items()}
    rel = lambda sw, v, ref: [mse[(s, sw, v)] / mse[(s, sw, ref)] - 1 for s in seeds]  # noqa
    ks = [int(x) for x in c1["exp1.cuts_list"].split(",")]
    kd, e = int(c1["forest.cuts"]), mg["mse"]
    ev[f"K {min(ks)} − K {kd}"] = part(rel("cuts", min(ks), kd), "gt", e)
    ev[f"K {max(ks)} − K {kd}"] = part(rel("cuts", max(ks), kd), "in", -e, e)
    for k in ks:
        if k not in (kd, min(ks), max(ks)):
            ev[f"K {k} − K {kd}"] = part(rel("cuts", k, kd), "gt", -e)
    ms = [int(x) for x in c1["exp1.trees_list"].split(",")]
    ev[f"M 1 − M {max(ms)}"] = part(rel("trees", 1, max(ms)), "gt", e)
    ev[f"M 10 − M {max(ms)}"] = part(rel("trees", 10, max(ms)), "lt", e)
    for k in ms:
        if k > 10:
            ev[f"M {k} − M 10"] = part(rel("trees", k, 10), "lt", e)
    ns = [int(x) for x in c1["exp1.n_min_list"].split(",")]
    a, b = min(ns), max(ns)
    ev[f"n_min {b} − n_min {a}"] = part(rel("n_min", b, a), "gt", 0)
    for n in ns[1:-1]:
        ev[f"n_min {n} − n_min {a}"] = part(rel("n_min", n, a), "gt", -e)
        ev[f"n_min {b} − n_min {n}"] = part(rel("n_min", b, n), "gt", 0)
    mp = {int(r["seed"]): -float(r["pred_pocketed"]) - float(r["rms_rest"])
          for r in rows("exp1_map.csv") if r["arm"] == arm}
    ev["underestimate at pocketed positions − RMS error elsewhere"] = part(
        [mp[s] for s in seeds], "gt", 0)
    ev1, ev = ev, {}
    top = max(int(x) for x in c2["exp2.sizes"].split(","))
    acc = defaultdict(list)
    for r in rows("exp2_returns.csv"):
        if r["arm"] == arm and int(r["size"]) in (0, top):
            acc[(int(r["seed"]), r["policy"], r["mode"])].append(float(r["mean_return"]))
    v2 = lambda q, m: np.array([np.mean(acc[(s, q, m)]) for s in seeds])  # noqa: E731
    name = {"single": "single node", "s_a": "s→a", "s_rs": "s→rs"}
    for q in ("single", "s_a", "s_rs"):
        ev[f"expert − {name[q]} (mean actions)"] = part(
            v2("expert", "mean") - v2(q, "mean"), "gt", mg["material"])
    for m in ("mean", "sample"):
        for q in ("s_a", "s_rs"):
            ev[f"single node − {name[q]} ({m} actions)"] = part(
                v2("single", m) - v2(q, m), "lt", 0)
        ev[f"s→rs − s→a ({m} actions)"] = part(v2("s_rs", m) - v2("s_a", m), "gt", 0)
    return ev1, ev


def exp3_oracle(arm, mg, R, data=DATA):
    o = {}
    runs = defaultdict(dict)
    for r in rows("exp3_runs.csv", data):
        if r["arm"] == arm:
            runs[r["policy"]][int(r["repetition"])] = r
    curves = defaultdict(dict)
    for r in rows("exp3_curves.csv", data):
        if r["arm"] == arm:
            its = sorted((int(k[1:]), float(v)) for k, v in r.items() if k.startswith("i"))
            curves[r["policy"]][int(r["repetition"])] = np.array([v for _, v in its])
    col = lambda q, c: np.array([float(runs[q][k][c]) for k in sorted(runs[q])])  # noqa: E731
    ret = {q: col(q, "mean_return") for q in THESIS + ["handcrafted"]}
    flat = mg["flat"]
    for q in TREES:
        o[f"{q} − baseline"] = part(ret[q] - ret["baseline"], "in", -math.inf,
                                    mg["considerable"])
        if q != "nrvr_rs":
            o[f"nrvr_rs − {q}"] = part(ret["nrvr_rs"] - ret[q], "gt", 0)
        if q != "rvr_a":
            o[f"rvr_a − {q}"] = part(ret["rvr_a"] - ret[q], "lt", 0)
        o[f"balls in target pockets, {q} − baseline"] = part(
            col(q, "target") - col("baseline", "target"), "gt", 0)
    o["nrvr_rs − baseline, ≈ 0.1"] = part(ret["nrvr_rs"] - ret["baseline"], "in",
                                          0.1 - mg["about"], 0.1 + mg["about"])
    for c, what in (("sd_return", "SD of the returns"), ("target", "balls in target pockets"),
                    ("miss_distance", "missed balls' distance"),
                    ("median_speed", "median cue speed")):
        o[f"{what}, rvr_a − baseline"] = part(col("rvr_a", c) - col("baseline", c), "gt", 0)
    n2, n5 = col("nrvr_rs", "pocket2"), col("nrvr_rs", "pocket5")
    o["nrvr_rs's pocket-2 share"] = share(n2, n2 + n5, 0.5 - mg["even"], 0.5 + mg["even"])
    k0 = int(R["study"]["converged_at"])
    for q in THESIS:
        cv = [curves[q][k] for k in sorted(curves[q])]
        o[f"{q}: mean square of the runs' changes after iteration {k0}"] = \
            drift(cv, k0, flat)[:5] + ["converged"]
        o[f"hand-crafted − {q}"] = part(ret["handcrafted"] - ret[q], "gt",
                                        mg["considerable"])[:5] + ["poor"]
    return o


def holm_oracle(ps, alpha):
    """Adjusted p-values and the level each p was judged at (step-down)."""
    m = len(ps)
    order = sorted(range(m), key=lambda i: ps[i])
    adj, lvl, run, stop = [0.0] * m, [0.0] * m, 0.0, None
    tie = {}
    for j, i in enumerate(order):
        run = max(run, min(1.0, (m - j) * ps[i]))
        adj[i] = run
        if stop is None and ps[i] >= alpha / (m - j):
            stop = alpha / (m - j)
        # tied p-values: the level of the first of them
        lvl[i] = tie.setdefault(ps[i], stop if stop is not None else alpha / (m - j))
    return adj, lvl


def oracle():
    """{mode: {label: [est, p_s, p_r, adj_s, adj_r, verdict, group, (lo, hi, level)
    of the support, (lo, hi, level) of the refutation]}} from the rules' text."""
    R = rules()
    mg = {k: float(v) for k, v in R["margins"].items() if "." not in k}
    man = manifest_of()
    out = {}
    alpha = float(R["study"]["alpha"])
    for arm in MODES:
        out[arm] = {}
        # one Holm family per experiment and mode
        for o in (*exp12_oracle(arm, mg, man[("exp1", f"{arm}/1")], man[("exp2", f"{arm}/1")]),
                  exp3_oracle(arm, mg, R)):
            out[arm] |= adjusted(o, alpha)
    return out


def adjusted(o, alpha):
    """One family's parts with their Holm-adjusted p-values, verdicts and
    intervals at the Holm levels."""
    labels = list(o)
    ps = [o[k][1] for k in labels] + [o[k][2] for k in labels]
    adj, lvl = holm_oracle(ps, alpha)
    for j, k in enumerate(labels):
        est, p_s, p_r, ci, two_sided, group = o[k]
        a_s, a_r = adj[j], adj[j + len(labels)]
        l_s, l_r = 1 - 2 * lvl[j], 1 - (1 if two_sided else 2) * lvl[j + len(labels)]
        v = "agrees" if a_s < alpha else "disagrees" if a_r < alpha else "undecided"
        o[k] = [est, p_s, p_r, a_s, a_r, v, group, (*ci(l_s), l_s), (*ci(l_r), l_r)]
    return o


# ---------------------------------------------------------------- the page

PARTS = ROOT / "docs" / "data" / "verdicts" / "parts.csv"


def csv_parts(path=PARTS):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def page_parts():
    """{mode: {label: (estimate, support interval, p (Holm), refutation interval,
    p refute (Holm), verdict)}} of the parts' CSV, and the page's text."""
    text = (ROOT / "docs" / "verdicts.md").read_text(encoding="utf-8")
    label_of = {v: k for k, v in MODES.items()}
    got = defaultdict(dict)
    for r in csv_parts():
        got[label_of[r["mode"]]][r["part"]] = [r[c] for c in (
            "estimate", "support interval (level)", "p (Holm)", "refutation interval (level)",
            "p refute (Holm)", "verdict")]
    return got, text


def close(printed, value, scale=1.0):
    """A printed number equals value to its printed precision."""
    s = printed.replace("−", "-").replace("+", "")
    if s in ("∞", "-∞"):
        return math.isinf(value) and (value < 0) == s.startswith("-")
    x = float(s)
    if "e" in s:
        mant, ex = s.split("e")
        dec = len(mant.split(".")[1]) if "." in mant else 0
        tol = 0.5 * 10 ** (int(ex) - dec)
    else:
        dec = len(s.split(".")[1]) if "." in s else 0
        tol = 0.5 * 10 ** -dec
    return abs(x - value * scale) <= tol * 1.001 + 1e-12


NUM = r"[−+]?(?:\d+\.?\d*(?:e[−+-]?\d+)?|∞)"


def check_interval(cell, want, scale, where):
    """'[lo, hi] (level %)' against the oracle's (lo, hi, level)."""
    m = re.fullmatch(rf"\[({NUM}), ({NUM})\] \(({NUM}) %\)", cell)
    assert m, (where, cell)
    lo, hi, lvl = want
    assert close(m.group(3), 100 * lvl), (where, cell, lvl)
    assert close(m.group(1), lo, scale) and close(m.group(2), hi, scale), (where, cell, want)


@pytest.fixture(scope="module")
def want():
    """The oracle, computed once for the tests that read it (none changes it)."""
    return oracle()


def test_holdout_recomputed():
    """The holdout's parts (Experiment 3 on fresh seeds) against the oracle,
    its own family per mode."""
    R = rules()
    mg = {k: float(v) for k, v in R["margins"].items() if "." not in k}
    label_of = {v: k for k, v in MODES.items()}
    got = defaultdict(dict)
    for r in csv_parts(ROOT / "docs" / "data" / "verdicts" / "holdout_parts.csv"):
        got[label_of[r["mode"]]][r["part"]] = r
    for arm in MODES:
        want = adjusted(exp3_oracle(arm, mg, R, DATA / "holdout"), float(R["study"]["alpha"]))
        assert set(got[arm]) == set(want), arm
        for label, w in want.items():
            g = got[arm][label]
            assert close(re.findall(NUM, g["estimate"])[-1], w[0]), (arm, label)
            check_interval(g["support interval (level)"], w[7], 1, (arm, label))
            assert g["verdict"] == w[5], (arm, label)


def test_every_part_recomputed(want):
    got, _ = page_parts()
    assert set(got) == set(want)
    for mode in want:
        assert set(got[mode]) == set(want[mode]), mode
        for label, (est, ps, pr, a_s, a_r, v, _g, ci_s, ci_r) in want[mode].items():
            e_cell, i_s, p_s, i_r, p_r, verdict = got[mode][label]
            scale = 100 if "% of the MSE" in e_cell else 1
            e_num = re.findall(NUM, e_cell)[-1]
            assert close(e_num, est, scale), (mode, label, e_cell, est)
            check_interval(i_s, ci_s, scale, (mode, label, "support"))
            check_interval(i_r, ci_r, scale, (mode, label, "refutation"))
            for cell, (raw, adj) in ((p_s, (ps, a_s)), (p_r, (pr, a_r))):
                m = re.fullmatch(rf"({NUM}) \(({NUM})\)", cell)
                assert m and close(m.group(1), raw) and close(m.group(2), adj), (mode, label, cell)
            assert verdict == v, (mode, label)


def region(h1):
    """The H1 cell ('> a', '< a', 'in (a, b)', with a unit) as (low, high)."""
    nums = [float(x.replace("−", "-")) for x in re.findall(r"[−+]?\d+\.?\d*", h1)]
    scale = 0.01 if h1.endswith("%") else 1.0
    if h1.startswith(">"):
        return nums[0] * scale, math.inf
    if h1.startswith("<"):
        return -math.inf, nums[0] * scale
    return nums[0] * scale, nums[1] * scale


def test_decision_matches_interval(want):
    """The printed interval gives the part's verdict: the support's lies in
    the H1 region exactly when the part agrees, the refutation's lies outside
    it exactly when the part disagrees (oracle intervals at Holm's levels)."""
    h1 = page_h1()
    seen = set()
    for mode in want:
        for label, w in want[mode].items():
            lo_h, hi_h = region(h1[(mode, label)])
            v, (lo, hi, _), (rlo, rhi, _) = w[5], w[7], w[8]
            if math.isnan(lo):
                continue
            inside = lo_h < lo and hi < hi_h
            outside = rhi < lo_h or rlo > hi_h
            assert inside == (v == "agrees"), (mode, label, v, (lo, hi), (lo_h, hi_h))
            assert outside == (v == "disagrees"), (mode, label, v, (rlo, rhi), (lo_h, hi_h))
            seen.add(v)
    assert seen == {"agrees", "disagrees", "undecided"}


def page_h1():
    """{(mode, label): the H1 cell} of the parts' CSV."""
    label_of = {v: k for k, v in MODES.items()}
    return {(label_of[r["mode"]], r["part"]): r["H1"] for r in csv_parts()}


def test_family_sizes_stated(want):
    """One family per experiment and mode: the page states each one's size."""
    _, text = page_parts()
    m = re.search(r"Experiment 1: (\d+) tests, Experiment 2: (\d+), Experiment 3: (\d+) tests "
                  r"per mode", text)
    assert m, "the families' sizes are not stated"
    R = rules()
    mg = {k: float(v) for k, v in R["margins"].items() if "." not in k}
    man = manifest_of()
    o1, o2 = exp12_oracle("event", mg, man[("exp1", "event/1")], man[("exp2", "event/1")])
    sizes = (2 * len(o1), 2 * len(o2), 2 * len(exp3_oracle("event", mg, R)))
    assert tuple(int(x) for x in m.groups()) == sizes


def test_claim_verdicts_follow_their_parts(want):
    _, text = page_parts()
    R = rules()
    many = int(R["study"]["many"])
    per_claim = {}
    labels_of = defaultdict(set)
    for r in csv_parts():
        labels_of[r["claim"]].add(r["part"])
    # each claim's row of the verdicts table: its verdict per mode
    table = text[text.index("\n## Verdicts"):text.index("\n## Holdout")]
    for cid in re.findall(r"^\*\*[^*]* \(`(\w+)`\)\*\*:", text, re.M):
        c = R[f"claim.{cid}"]
        row = re.search(r"^\| " + re.escape(f"{c['section']} {c['short']}") + r" \| (.*)$",
                        table, re.M).group(1).split(" | ")
        per_claim[cid] = (labels_of[cid], "; ".join(
            f"{name}: **{v}**" for name, v in zip(MODES.values(), row)))
    assert len(per_claim) == 13
    for cid, (labels, line) in per_claim.items():
        for mode, name in MODES.items():
            parts = [want[mode][k] for k in labels if k in want[mode]]
            assert parts, (cid, mode)
            vs = [p[5] for p in parts]

            def all_of(v):
                return "agrees" if all(x == "agrees" for x in v) else \
                    "disagrees" if "disagrees" in v else "undecided"
            if cid == "converged":
                conv = all_of([p[5] for p in parts if p[6] == "converged"])
                poor = [p[5] for p in parts if p[6] == "poor"]
                assert len(poor) == 5 and len(parts) == 10, (cid, mode)
                n_a, n_ok = poor.count("agrees"), len(poor) - poor.count("disagrees")
                pv = "agrees" if n_a >= many else "disagrees" if n_ok < many else "undecided"
                expect = all_of([conv, pv])
            else:
                expect = all_of(vs)
            assert f"{name}: **{expect}**" in line, (cid, mode, line)


def test_readme_and_report_come_from_the_generator():
    p = subprocess.run([PY, ROOT / "scripts" / "verdicts.py", DATA, "--check"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    block = readme[readme.index("<!-- verdicts:begin -->"):readme.index("<!-- verdicts:end -->")]
    assert block.count("\n| ") == 14   # header and 13 claims
    outside = readme.replace(block, "")
    # the other generated blocks (the sensitivity study's sentence, ...) come
    # from their own generators, each checked by its own test
    outside = re.sub(r"<!-- (sensitivity|exp4-study):(\w+) -->.*?<!-- /(sensitivity|exp4-study)(:\w+)? -->",
                     "", outside, flags=re.S)
    for word in ("agrees", "disagrees", "undecided", "does not agree", "partly"):
        assert word not in outside, word


def test_sphere_sentence_is_the_figures_plateau():
    """The README's sphere numbers: per method, the median over the seeds of
    the policy mean's test return per iteration, then the median of its last
    tenth of iterations (what the bench_sphere figure marks), recomputed here."""
    acc = defaultdict(lambda: defaultdict(list))
    for r in rows("sphere_curves.csv"):
        acc[r["method"]][int(r["iteration"])].append(float(r["test_return"]))
    level = {}
    for method, its in acc.items():
        med = [float(np.median(its[i])) for i in sorted(its)]
        assert len({len(v) for v in its.values()}) == 1
        level[method] = float(np.median(med[-max(1, len(med) // 10):]))
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    block = readme[readme.index("<!-- sphere:begin -->"):readme.index("<!-- sphere:end -->")]
    got = re.findall(r"(?:plateaus at|, at| at) (−[\d.]+(?:e−\d+)?)(?=[ .;])", block)
    assert len(got) == 3, block
    for printed, method in zip(got, ("creps_old", "creps_new", "ccmaes")):
        x = float(printed.replace("−", "-"))
        assert abs(x - level[method]) <= 5e-3 * abs(level[method]), (method, printed, level)
    assert f"{len(acc['creps_old'][0])} seeds" in block


# ---------------------------------------------------------------- bad input

def snapshot(*dirs):
    out = {}
    for d in dirs:
        for p in sorted(Path(d).rglob("*")):
            if p.is_file():
                out[str(p)] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


@pytest.fixture
def study(tmp_path):
    data = tmp_path / "data"
    shutil.copytree(DATA, data)
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "verdicts.md").write_text("old\n")
    readme = tmp_path / "README.md"
    readme.write_text("a\n<!-- verdicts:begin -->\nold\n<!-- verdicts:end -->\nb\n"
                      "<!-- sphere:begin -->\nold\n<!-- sphere:end -->\nc\n"
                      "<!-- exp3-table:begin -->\n<!-- exp3-table:end -->\n")
    return data, docs, readme


def generate(data, docs, readme, *extra):
    return subprocess.run([PY, ROOT / "scripts" / "verdicts.py", data, "--docs", docs,
                           "--readme", readme, *extra], capture_output=True, text=True)


def edit_csv(path, fn):
    with open(path, newline="", encoding="utf-8") as f:
        rs = list(csv.reader(f))
    rs = fn(rs)
    with open(path, "w", newline="", encoding="utf-8") as f:
        csv.writer(f, lineterminator="\n").writerows(rs)


def drop_run(rs):
    return [r for r in rs if r[:3] != ["stepped", "rvr_a", "17"]]


def mix_config(rs):
    return [r[:3] + ["99"] if r[:3] == ["exp3", "stepped05", "exp3.iterations"] else r for r in rs]


def sphere_centre(rs):
    return [r[:3] + ["old"] if r[:3] == ["sphere", "creps_new", "policy.cov_center"] else r
            for r in rs]


def shift_seed(rs):
    return [r if r[:2] != ["event", "20"] else ["event", "21"] + r[2:] for r in rs]


@pytest.mark.parametrize("case,code,words", [
    ("missing", 2, ["exp1_map.csv", "missing"]),
    ("partial", 3, ["exp3_runs.csv", "arm stepped policy rvr_a repetition 17"]),
    ("curves", 3, ["exp3_curves.csv", "arm stepped policy rvr_a repetition 17"]),
    ("mixed", 3, ["manifest.csv", "exp3.iterations"]),
    ("seed", 3, ["exp1_map.csv", "arm event seed 20"]),
    ("malformed", 2, ["exp3_runs.csv", "mean_return"]),
    ("sphere", 3, ["manifest.csv", "sphere creps_new has policy.cov_center = old"]),
    ("sphere_rows", 3, ["sphere_curves.csv", "method ccmaes repetition 3"]),
    ("holdout_missing", 2, ["holdout/exp3_curves.csv", "missing"]),
    ("holdout_other", 3, ["holdout/manifest.csv", "Experiment 3 only"]),
    ("holdout_partial", 3, ["holdout/exp3_runs.csv", "arm stepped policy rvr_a repetition 17"]),
])
def test_bad_study_refused_and_nothing_written(study, case, code, words):
    data, docs, readme = study
    if case == "missing":
        (data / "exp1_map.csv").unlink()
    elif case == "partial":
        edit_csv(data / "exp3_runs.csv", drop_run)
    elif case == "curves":
        edit_csv(data / "exp3_curves.csv", drop_run)
    elif case == "mixed":
        edit_csv(data / "manifest.csv", mix_config)
    elif case == "seed":
        edit_csv(data / "exp1_map.csv", shift_seed)
    elif case == "sphere":
        edit_csv(data / "manifest.csv", sphere_centre)
    elif case == "holdout_missing":
        (data / "holdout" / "exp3_curves.csv").unlink()
    elif case == "holdout_other":
        edit_csv(data / "holdout" / "manifest.csv",
                 lambda rs: rs + [["exp1", "event/1", "experiment.seed", "1"]])
    elif case == "holdout_partial":
        edit_csv(data / "holdout" / "exp3_runs.csv", drop_run)
    elif case == "sphere_rows":
        edit_csv(data / "sphere_curves.csv", lambda rs: [r for r in rs
                                                          if r[:2] != ["ccmaes", "3"]])
    else:
        edit_csv(data / "exp3_runs.csv", lambda rs: rs[:5] + [rs[5][:3] + ["nan"] + rs[5][4:]]
                 + rs[6:])
    before = snapshot(docs, data) | {str(readme): readme.read_text()}
    p = generate(data, docs, readme)
    assert p.returncode == code, p.stderr
    assert p.stderr.count("\n") == 1 and p.stderr.startswith("verdicts: "), p.stderr
    for w in words:
        assert w in p.stderr, p.stderr
    assert snapshot(docs, data) | {str(readme): readme.read_text()} == before


def test_check_sees_a_difference(study):
    """The text outputs (--no-figures: the figure's check is that of
    test_readme_and_report_come_from_the_generator, over the committed one)."""
    data, docs, readme = study
    p = generate(data, docs, readme, "--check", "--no-figures")
    assert p.returncode == 1 and "differs" in p.stderr
    assert generate(data, docs, readme, "--no-figures").returncode == 0
    assert not (docs / "figures").exists()
    assert generate(data, docs, readme, "--check", "--no-figures").returncode == 0
    # without --no-figures the check misses the figure never drawn here
    p = generate(data, docs, readme, "--check")
    assert p.returncode == 1 and "study_seeds" in p.stderr, p.stderr
    text = readme.read_text()
    assert text.startswith("a\n<!-- verdicts:begin -->")
    assert "<!-- sphere:end -->\nc\n<!-- exp3-table:begin -->\nExperiment 3 in the study" in text
    assert text.endswith("<!-- exp3-table:end -->\n")
    assert "<!-- verdicts:end -->\nb\n<!-- sphere:begin -->\nREPS benchmarks" in text
    (docs / "verdicts.md").write_text((docs / "verdicts.md").read_text() + " ")
    p = generate(data, docs, readme, "--check", "--no-figures")
    assert p.returncode == 1 and "verdicts.md" in p.stderr


# ---------------------------------------------------------------- the study target

def tiny(*sets):
    return " ".join(f"--set {s}" for s in sets)


@pytest.mark.slow
def test_tiny_study_end_to_end(tmp_path):
    """scripts/study.sh on tiny settings (real binary, sweep, GNU Parallel,
    collect), then the generator with rules whose convergence point fits."""
    binary = os.environ.get("POOLREPS")
    if not binary or shutil.which("parallel") is None:
        pytest.skip("needs POOLREPS and GNU parallel")
    env = dict(os.environ, POOLREPS=binary, POWER_JOBS="2", LC_ALL="C",
               STUDY_EXP3=tiny("exp3.iterations=6", "exp3.init_samples=40", "exp3.window=40",
                               "exp3.samples=10", "exp3.final_episodes=20",
                               "exp3.baseline_n_min=60", "policy.n_min=15", "value.n_min=12",
                               "value.trees=3", "policy.trees=3"),
               STUDY_EXP1=tiny("exp1.train=200", "exp1.test=200", "exp1.subset=100",
                               "exp1.test_subset=100", "exp1.n_min_list=5,20,100",
                               "exp1.trees_list=1,10,20", "exp1.cuts_list=1,10,20",
                               "exp1.map_grid=11", "experiment.repetitions=2"),
               STUDY_EXP2=tiny("exp2.sizes=10,50", "exp2.test=100", "experiment.repetitions=2"),
               STUDY_SPHERE=tiny("bench.iterations=10", "experiment.repetitions=2"))
    data, docs = tmp_path / "data", tmp_path / "docs"
    docs.mkdir()
    p = subprocess.run(["sh", ROOT / "scripts" / "study.sh", tmp_path / "out", "3", "3", data,
                        PY], capture_output=True, text=True, env=env, cwd=tmp_path,
                       timeout=600)
    assert p.returncode == 0, p.stdout + p.stderr
    assert sorted(x.name for x in data.iterdir()) == sorted(
        ["manifest.csv", "exp3_runs.csv", "exp3_curves.csv", "exp1_mse.csv", "exp1_map.csv",
         "exp2_returns.csv", "sphere_curves.csv", "timing.csv"])
    assert len(list(csv.DictReader(open(data / "exp3_runs.csv")))) == 3 * 6 * 3
    # the power report stays in OUT: docs/power.md is make verdicts's
    assert (tmp_path / "out" / "power" / "power.md").is_file() and not (docs / "power.md").exists()
    rules_text = (DATA / "rules.ini").read_text(encoding="utf-8")
    (data / "rules.ini").write_text(rules_text.replace("converged_at = 60", "converged_at = 3"))
    readme = tmp_path / "README.md"
    readme.write_text("<!-- verdicts:begin -->\n<!-- verdicts:end -->\n"
                      "<!-- sphere:begin -->\n<!-- sphere:end -->\n"
                      "<!-- exp3-table:begin -->\n<!-- exp3-table:end -->\n")
    p = generate(data, docs, readme)
    assert p.returncode == 0, p.stderr
    md = (docs / "verdicts.md").read_text(encoding="utf-8")
    assert "3 repetitions per mode" in md and "3 seeds" in md and "nan" not in md.lower()
    # two more repetitions (3 and 4), and repetition 0 again, which must match
    runs_before = (data / "exp3_runs.csv").read_text()
    p = subprocess.run(["sh", ROOT / "scripts" / "study_extend.sh", tmp_path / "ext", "3", "5",
                        data, PY, *env["STUDY_EXP3"].split()], capture_output=True, text=True,
                       env=env, cwd=tmp_path, timeout=600)
    assert p.returncode == 0, p.stdout + p.stderr
    ext = list(csv.DictReader(open(data / "exp3_runs.csv")))
    assert len(ext) == 5 * 6 * 3 and (data / "exp3_runs.csv").read_text().startswith(runs_before)
    assert {r["repetition"] for r in ext} == {"0", "1", "2", "3", "4"}
    assert manifest_of(data)[("exp3", "event")]["experiment.repetitions"] == "5"
    assert "nan" not in (data / "timing.csv").read_text()
    assert (data / "extensions.csv").read_text().splitlines()[1].startswith("3,5,")
    p = generate(data, docs, readme)
    assert p.returncode == 0, p.stderr
    md = (docs / "verdicts.md").read_text(encoding="utf-8")
    assert "5 repetitions per mode" in md and "| repetitions 3–4: event |" in md
    # the added repetitions must be the study's last: refused, nothing written
    good = (data / "extensions.csv").read_text()
    (data / "extensions.csv").write_text(good.replace("3,5,", "2,4,"))
    before = snapshot(docs) | {str(readme): readme.read_text()}
    p = generate(data, docs, readme)
    assert p.returncode == 3 and "extensions.csv:2" in p.stderr and p.stderr.count("\n") == 1
    assert snapshot(docs) | {str(readme): readme.read_text()} == before
    (data / "extensions.csv").write_text(good)
    # a key poolreps gained after the study ran (here: one dropped from the
    # manifest) is taken at the new runs' value once repetition 0 comes out
    # the same, and recorded; without repetition 0 it is refused, nothing changed
    lines = (data / "manifest.csv").read_text().splitlines(keepends=True)
    gone = [ln for ln in lines if ln.startswith("exp3,") and ",exp3.mean_eval_seed," in ln]
    assert len(gone) == 3
    (data / "manifest.csv").write_text("".join(ln for ln in lines if ln not in gone))
    ext = [PY, str(ROOT / "scripts" / "study_extract.py"), "--extend",
           str(tmp_path / "ext"), str(data)]
    shutil.rmtree(tmp_path / "ext" / "event" / "point-0" / "runs" / "rep-0")
    before = snapshot(data)
    p = subprocess.run(ext, capture_output=True, text=True, cwd=tmp_path)
    assert p.returncode == 2 and "exp3.mean_eval_seed" in p.stderr and "repetition 0" in p.stderr
    assert p.stderr.count("\n") == 1 and snapshot(data) == before
    p = subprocess.run(["sh", ROOT / "scripts" / "study_extend.sh", tmp_path / "ext", "5", "6",
                        data, PY, *env["STUDY_EXP3"].split()], capture_output=True, text=True,
                       env=env, cwd=tmp_path, timeout=600)
    assert p.returncode == 0, p.stdout + p.stderr
    assert sorted(ln for ln in (data / "manifest.csv").read_text().splitlines(keepends=True)
                  if ln.startswith("exp3,") and ",exp3.mean_eval_seed," in ln) == sorted(gone)
    assert manifest_of(data)[("exp3", "event")]["experiment.repetitions"] == "6"
    assert (data / "extensions.csv").read_text().splitlines()[2].startswith("5,6,")
    # the repository's rules do not fit 6 iterations: refused, nothing written
    (data / "rules.ini").write_text(rules_text)
    before = snapshot(docs) | {str(readme): readme.read_text()}
    p = generate(data, docs, readme)
    assert p.returncode == 3 and "converged_at" in p.stderr and p.stderr.count("\n") == 1
    assert snapshot(docs) | {str(readme): readme.read_text()} == before


def test_readme_exp3_table_recomputed():
    """The README's Experiment 3 table (event mode of the study) from the
    runs, with scipy's paired t interval."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    block = readme[readme.index("<!-- exp3-table:begin -->"):readme.index("<!-- exp3-table:end -->")]
    runs = defaultdict(dict)
    for r in rows("exp3_runs.csv"):
        if r["arm"] == "event":
            runs[r["policy"]][int(r["repetition"])] = r
    col = lambda q, c: np.array([float(runs[q][k][c]) for k in sorted(runs[q])])  # noqa: E731
    lines = [ln for ln in block.splitlines() if ln.startswith("| ") and "policy" not in ln]
    assert len(lines) == 6 and f"{len(runs['baseline'])} repetitions" in block
    for line, q in zip(lines, THESIS + ["handcrafted"]):
        cells = [c.strip() for c in line.strip("| ").split("|")]
        ret = col(q, "mean_return")
        assert close(cells[1], ret.mean()) and close(cells[2], ret.std(ddof=1)), (q, cells)
        if q != "baseline":
            d = ret - col("baseline", "mean_return")
            lo, hi = stats.ttest_1samp(d, 0).confidence_interval(0.95)
            est, a, b = re.findall(NUM, cells[3])
            assert close(est, d.mean()) and close(a, lo) and close(b, hi), (q, cells)
        p2, p5 = re.findall(NUM, cells[4])
        assert close(p2, col(q, "pocket2").mean()) and close(p5, col(q, "pocket5").mean())
        assert close(re.findall(NUM, cells[5])[0], col(q, "median_speed").mean())
