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


def rows(name):
    with open(DATA / name, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def rules():
    c = configparser.ConfigParser(interpolation=None)
    c.read(DATA / "rules.ini", encoding="utf-8")
    return c


def manifest():
    m = defaultdict(dict)
    for r in rows("manifest.csv"):
        m[(r["experiment"], r["unit"])][r["key"]] = r["value"]
    return m


# ---------------------------------------------------------------- oracle

def one_sided(x, bound, alt):
    return stats.ttest_1samp(x, bound, alternative=alt).pvalue


def part(x, kind, a, b=None):
    """(est, lo, hi, p_support, p_refute) of the per-unit values x."""
    x = np.asarray(x, float)
    res = stats.ttest_1samp(x, 0.0)
    lo, hi = res.confidence_interval(0.95)
    if kind == "gt":
        ps, pr = one_sided(x, a, "greater"), one_sided(x, a, "less")
    elif kind == "lt":
        ps, pr = one_sided(x, a, "less"), one_sided(x, a, "greater")
    elif a == -math.inf:
        ps, pr = one_sided(x, b, "less"), one_sided(x, b, "greater")
    else:
        ps = max(one_sided(x, a, "greater"), one_sided(x, b, "less"))
        pr = min(1.0, 2 * min(one_sided(x, a, "less"), one_sided(x, b, "greater")))
    return [x.mean(), lo, hi, ps, pr]


def share(n2, tot, low, high):
    """Pooled share, its interval from inverting the t test of n2 - c tot, TOST."""
    n2, tot = np.asarray(n2, float), np.asarray(tot, float)
    r = n2.sum() / tot.sum()
    q = stats.t.ppf(0.975, len(n2) - 1)
    t = lambda c: stats.ttest_1samp(n2 - c * tot, 0).statistic  # noqa: E731
    from scipy.optimize import brentq
    lo, hi = brentq(lambda c: t(c) - q, -1, r), brentq(lambda c: t(c) + q, r, 2)
    ps = max(one_sided(n2 - low * tot, 0, "greater"), one_sided(n2 - high * tot, 0, "less"))
    pr = min(1.0, 2 * min(one_sided(n2 - low * tot, 0, "less"),
                          one_sided(n2 - high * tot, 0, "greater")))
    return [r, lo, hi, ps, pr]


def oracle():
    """{mode: {label: [est, lo, hi, p_s, p_r, group]}} from the rules' text."""
    R = rules()
    mg = {k: float(v) for k, v in R["margins"].items() if "." not in k}
    man = manifest()
    out = defaultdict(dict)
    c1 = man[("exp1", "1")]
    seeds = sorted({int(r["seed"]) for r in rows("exp1_mse.csv")})
    acc = defaultdict(list)
    for r in rows("exp1_mse.csv"):
        acc[(int(r["seed"]), r["sweep"], int(r["value"]))].append(float(r["mse"]))
    mse = {k: np.mean(v) for k, v in acc.items()}
    rel = lambda sw, v, ref: [mse[(s, sw, v)] / mse[(s, sw, ref)] - 1 for s in seeds]  # noqa
    ev = out["event"]
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
          for r in rows("exp1_map.csv")}
    ev["underestimate at pocketed positions − RMS error elsewhere"] = part(
        [mp[s] for s in seeds], "gt", 0)
    c2 = man[("exp2", "1")]
    top = max(int(x) for x in c2["exp2.sizes"].split(","))
    acc = defaultdict(list)
    for r in rows("exp2_returns.csv"):
        if int(r["size"]) in (0, top):
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
    runs = defaultdict(dict)
    for r in rows("exp3_runs.csv"):
        runs[(r["arm"], r["policy"])][int(r["repetition"])] = r
    curves = defaultdict(dict)
    for r in rows("exp3_curves.csv"):
        its = sorted((int(k[1:]), float(v)) for k, v in r.items() if k.startswith("i"))
        curves[(r["arm"], r["policy"])][int(r["repetition"])] = np.array([v for _, v in its])
    k0 = int(R["study"]["converged_at"])
    blk = int(R["study"]["settle_block"])
    for arm in MODES:
        o = out[arm]
        col = lambda q, c: np.array([float(runs[(arm, q)][k][c])  # noqa: E731
                                     for k in sorted(runs[(arm, q)])])
        ret = {q: col(q, "mean_return") for q in THESIS + ["handcrafted"]}
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
        for q in THESIS:
            cv = np.stack([curves[(arm, q)][k] for k in sorted(curves[(arm, q)])])
            n_it = cv.shape[1]
            x = np.arange(k0 + 1, n_it + 1)
            trend = [stats.linregress(x, c[k0:]).slope * (n_it - k0 - 1) for c in cv]
            settle = cv[:, k0:].mean(axis=1) - cv[:, k0 - blk:k0].mean(axis=1)
            o[f"{q}: trend over iterations {k0 + 1}–{n_it}"] = part(
                trend, "in", -mg["flat"], mg["flat"]) + ["converged"]
            o[f"{q}: window − iterations {k0 - blk + 1}–{k0}"] = part(
                settle, "lt", mg["flat"]) + ["converged"]
            o[f"hand-crafted − {q}"] = part(ret["handcrafted"] - ret[q], "gt",
                                            mg["considerable"]) + ["poor"]
    alpha = float(R["study"]["alpha"])
    for mode, o in out.items():
        labels = list(o)
        ps = [o[k][3] for k in labels] + [o[k][4] for k in labels]
        m = len(ps)
        order = sorted(range(m), key=lambda i: ps[i])
        adj, run = [0.0] * m, 0.0
        for j, i in enumerate(order):
            run = max(run, min(1.0, (m - j) * ps[i]))
            adj[i] = run
        for j, k in enumerate(labels):
            a_s, a_r = adj[j], adj[j + len(labels)]
            v = "agrees" if a_s < alpha else "disagrees" if a_r < alpha else "undecided"
            o[k] = o[k][:5] + [a_s, a_r, v] + (o[k][5:] or [""])
    return out


# ---------------------------------------------------------------- the page

def page_parts():
    """{mode: {label: (estimate cell, p, p Holm, p refute, p refute Holm, verdict)}}."""
    text = (ROOT / "docs" / "verdicts.md").read_text(encoding="utf-8")
    label_of = {v: k for k, v in MODES.items()}
    got = defaultdict(dict)
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 9 and cells[2] in label_of:
            got[label_of[cells[2]]][cells[0]] = cells[3:]
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


def test_every_part_recomputed():
    want = oracle()
    got, _ = page_parts()
    assert set(got) == set(want)
    for mode in want:
        assert set(got[mode]) == set(want[mode]), mode
        for label, (est, lo, hi, ps, pr, a_s, a_r, v, _g) in want[mode].items():
            cell, p1, p2, p3, p4, verdict = got[mode][label]
            nums = re.findall(NUM, cell)
            scale = 100 if "% of the MSE" in cell else 1
            assert len(nums) == 3, (mode, label, cell)
            for s, x in zip(nums, (est, lo, hi)):
                assert close(s, x, scale), (mode, label, cell, est, lo, hi)
            for s, x in zip((p1, p2, p3, p4), (ps, a_s, pr, a_r)):
                assert close(s, x), (mode, label, s, x)
            assert verdict == v, (mode, label)


def test_claim_verdicts_follow_their_parts():
    want = oracle()
    _, text = page_parts()
    R = rules()
    many = int(R["study"]["many"])
    per_claim = {}
    for sec in re.split(r"\n### ", text)[1:]:
        cid = re.search(r"\(`(\w+)`\)", sec.splitlines()[0]).group(1)
        labels = {line.split("|")[1].strip() for line in sec.splitlines()
                  if line.count("|") == 10 and line.split("|")[3].strip() in MODES.values()}
        per_claim[cid] = (labels, re.search(r"\*\*Verdict\*\*: (.*)", sec).group(1))
    assert len(per_claim) == 13
    for cid, (labels, line) in per_claim.items():
        for mode, name in MODES.items():
            parts = [want[mode][k] for k in labels if k in want[mode]]
            if not parts:
                assert f"{name}: **" not in line
                continue
            vs = [p[7] for p in parts]

            def all_of(v):
                return "agrees" if all(x == "agrees" for x in v) else \
                    "disagrees" if "disagrees" in v else "undecided"
            if cid == "converged":
                conv = all_of([p[7] for p in parts if p[8] == "converged"])
                poor = [p[7] for p in parts if p[8] == "poor"]
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
    # the other generated blocks (sensitivity_stats.py, checked by test_sensitivity)
    outside = re.sub(r"<!-- sensitivity:\w+ -->.*?<!-- /sensitivity -->", "",
                     readme.replace(block, ""), flags=re.S)
    for word in ("agrees", "disagrees", "undecided", "does not agree", "partly"):
        assert word not in outside, word


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
    readme.write_text("a\n<!-- verdicts:begin -->\nold\n<!-- verdicts:end -->\nb\n")
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


def shift_seed(rs):
    return [r if r[0] != "20" else ["21"] + r[1:] for r in rs]


@pytest.mark.parametrize("case,code,words", [
    ("missing", 2, ["exp1_map.csv", "missing"]),
    ("partial", 3, ["exp3_runs.csv", "arm stepped policy rvr_a repetition 17"]),
    ("curves", 3, ["exp3_curves.csv", "arm stepped policy rvr_a repetition 17"]),
    ("mixed", 3, ["manifest.csv", "exp3.iterations"]),
    ("seed", 3, ["exp1_map.csv", "seed 20"]),
    ("malformed", 2, ["exp3_runs.csv", "mean_return"]),
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
    data, docs, readme = study
    p = generate(data, docs, readme, "--check")
    assert p.returncode == 1 and "differs" in p.stderr
    assert generate(data, docs, readme).returncode == 0
    assert generate(data, docs, readme, "--check").returncode == 0
    text = readme.read_text()
    assert text.startswith("a\n<!-- verdicts:begin -->") and text.endswith("<!-- verdicts:end -->\nb\n")
    (docs / "verdicts.md").write_text((docs / "verdicts.md").read_text() + " ")
    p = generate(data, docs, readme, "--check")
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
               STUDY_EXP2=tiny("exp2.sizes=10,50", "exp2.test=100", "experiment.repetitions=2"))
    data, docs = tmp_path / "data", tmp_path / "docs"
    docs.mkdir()
    p = subprocess.run(["sh", ROOT / "scripts" / "study.sh", tmp_path / "out", "3", "3", data,
                        docs, PY], capture_output=True, text=True, env=env, cwd=tmp_path,
                       timeout=600)
    assert p.returncode == 0, p.stdout + p.stderr
    assert sorted(x.name for x in data.iterdir()) == sorted(
        ["manifest.csv", "exp3_runs.csv", "exp3_curves.csv", "exp1_mse.csv", "exp1_map.csv",
         "exp2_returns.csv", "timing.csv"])
    assert len(list(csv.DictReader(open(data / "exp3_runs.csv")))) == 3 * 6 * 3
    assert (docs / "power.md").is_file()
    rules_text = (DATA / "rules.ini").read_text(encoding="utf-8")
    (data / "rules.ini").write_text(rules_text.replace("converged_at = 60", "converged_at = 3")
                                    .replace("settle_block = 5", "settle_block = 2"))
    readme = tmp_path / "README.md"
    readme.write_text("<!-- verdicts:begin -->\n<!-- verdicts:end -->\n")
    p = generate(data, docs, readme)
    assert p.returncode == 0, p.stderr
    md = (docs / "verdicts.md").read_text(encoding="utf-8")
    assert "3 repetitions per mode" in md and "3 seeds" in md and "nan" not in md.lower()
    # the repository's rules do not fit 6 iterations: refused, nothing written
    (data / "rules.ini").write_text(rules_text)
    before = snapshot(docs) | {str(readme): readme.read_text()}
    p = generate(data, docs, readme)
    assert p.returncode == 3 and "converged_at" in p.stderr and p.stderr.count("\n") == 1
    assert snapshot(docs) | {str(readme): readme.read_text()} == before
