"""The Experiment 3 power study (make power, docs/power.md).

The statistics of scripts/power_stats.py against independent numpy/scipy
references on synthetic data with known effects, and the
whole pipeline (scripts/power.sh: jobs.sh, GNU Parallel, poolreps merge,
statistics, report) on a tiny Experiment 3 run by the real binary.
Run by `make check` with POOLREPS=<abs path to poolreps>.
"""
import csv
import importlib.util
import math
import os
import re
import shlex
import shutil
import sys

import numpy as np
import pytest
from scipy import stats

from conftest import ROOT, poolreps_path, run_cmd

sys.path.insert(0, str(ROOT / "scripts"))  # power_stats imports its neighbours
spec = importlib.util.spec_from_file_location("power_stats", ROOT / "scripts" / "power_stats.py")
ps = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ps)

# tiny Experiment 3: every variant, a few iterations, small forests (about
# 0.05 s per repetition and arm)
TINY = ["exp3.iterations=4", "exp3.init_samples=40", "exp3.window=40", "exp3.samples=10",
        "exp3.final_episodes=20", "policy.n_min=15", "exp3.baseline_n_min=60",
        "value.n_min=12", "value.trees=3", "policy.trees=3"]
REPS = 4


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


# ------------------------------------------------------------ paired t interval

def reference_t(a, b):
    """scipy's paired t test interval, an implementation independent of ours."""
    ci = stats.ttest_rel(a, b).confidence_interval(0.95)
    return ci.low, ci.high


@pytest.mark.parametrize("seed", range(40))
def test_paired_t_equals_scipy_ttest_rel(seed):
    """Random sizes 2..200, offsets up to 1e6 and scales 1e-6..1e6, some
    pairs with a common offset much larger than the difference. Tolerance:
    1e-9 of the interval's half width plus 1e-12 of the data's magnitude
    (the two codes sum in different orders)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 200))
    scale = 10.0 ** rng.uniform(-6, 6)
    offset = rng.choice([0.0, 10.0 ** rng.uniform(0, 6)])
    b = offset + scale * rng.normal(size=n)
    a = b + scale * (rng.normal(loc=rng.uniform(-1, 1), size=n) * rng.uniform(0.01, 2))
    m, lo, hi, k = ps.paired_t(a - b)
    rlo, rhi = reference_t(a, b)
    assert k == n
    tol = 1e-9 * (hi - lo) + 1e-12 * (abs(offset) + scale)
    assert abs(lo - rlo) <= tol and abs(hi - rhi) <= tol
    assert lo <= m <= hi


def test_paired_t_degenerate_and_invariant():
    rng = np.random.default_rng(7)
    # constant differences: a zero-width interval at the difference
    m, lo, hi, n = ps.paired_t(np.full(5, 0.25))
    assert (m, lo, hi, n) == (0.25, 0.25, 0.25, 5)
    # fewer than two pairs (NaN pairs dropped): no interval
    m, lo, hi, n = ps.paired_t([0.3, math.nan])
    assert n == 1 and m == 0.3 and math.isnan(lo) and math.isnan(hi)
    assert ps.paired_t([])[3] == 0
    d = rng.normal(0.1, 1, size=30)
    base = ps.paired_t(d)
    # permutation of the pairs: unchanged (to rounding)
    assert np.allclose(ps.paired_t(rng.permutation(d))[:3], base[:3], rtol=0, atol=1e-14)
    # scale: the interval scales (tolerance 1e-12 relative)
    assert np.allclose(ps.paired_t(1e3 * d)[:3], np.array(base[:3]) * 1e3, rtol=1e-12)
    # an offset common to both members of every pair: unchanged (1e-9 absolute
    # after subtracting offsets of 1e6)
    b = rng.normal(size=30)
    assert np.allclose(ps.paired_t((b + d + 1e6) - (b + 1e6))[:3], base[:3], rtol=0, atol=1e-9)


@pytest.mark.parametrize("n", [5, 50])
def test_paired_t_covers_a_known_effect(n):
    """4000 seeded synthetic studies of n paired runs with a known effect
    0.1, a shared per-repetition term (common random numbers) and normal
    noise: the 95 % interval must cover 0.1 in 95 % of them, within 4
    binomial standard deviations (sqrt(0.95 * 0.05 / 4000) = 0.0034)."""
    rng = np.random.default_rng(100 + n)
    trials, effect = 4000, 0.1
    common = rng.normal(size=(trials, n))
    base = -0.9 + 0.15 * common + 0.1 * rng.normal(size=(trials, n))
    var = base + effect + 0.2 * rng.normal(size=(trials, n))
    hits = 0
    for t in range(trials):
        _, lo, hi, _ = ps.paired_t(var[t] - base[t])
        hits += lo <= effect <= hi
    sd = math.sqrt(0.95 * 0.05 / trials)
    assert abs(hits / trials - 0.95) <= 4 * sd


# ------------------------------------------------------------ bootstrap

def test_bootstrap_interval_matches_scipy_bootstrap():
    """The percentile interval of a paired mean difference against
    scipy.stats.bootstrap(paired=True, method='percentile'), which draws its
    own resamples: endpoints agree within 5 % of the interval's width (the
    Monte Carlo error of each endpoint at 10000 resamples is about 1 %)."""
    for seed in range(5):
        rng = np.random.default_rng(seed)
        n = 50
        b = rng.normal(-0.9, 0.15, size=n)
        a = b + rng.normal(0.1, 0.25, size=n) ** 3
        idx = ps.resamples(n, 10000, seed)
        lo, hi = ps.boot_mean_ci(a - b, idx)
        ref = stats.bootstrap((a, b), lambda x, y, axis=-1: np.mean(x - y, axis=axis),
                              paired=True, vectorized=True, n_resamples=10000,
                              method="percentile",
                              random_state=np.random.default_rng(1000 + seed)).confidence_interval
        width = ref.high - ref.low
        assert abs(lo - ref.low) <= 0.05 * width and abs(hi - ref.high) <= 0.05 * width


def test_bootstrap_covers_a_known_effect():
    """1000 seeded synthetic studies of 50 pairs, 2000 resamples each: the
    percentile interval covers the known effect in 95 % of them within 4
    binomial standard deviations (0.0276), less the percentile method's known
    shortfall at n = 50 (it uses the 1/n variance and the normal quantile:
    about 0.008 for normal data); bounds [0.914, 0.978]."""
    rng = np.random.default_rng(3)
    trials, n, effect = 1000, 50, 0.1
    idx = ps.resamples(n, 2000, 11)
    d = effect + 0.3 * rng.normal(size=(trials, n))
    hits = 0
    for t in range(trials):
        lo, hi = ps.boot_mean_ci(d[t], idx)
        hits += lo <= effect <= hi
    assert 0.914 <= hits / trials <= 0.978


def test_resamples_are_seeded_and_keep_pairs():
    a = ps.resamples(7, 50, 3)
    assert a.shape == (50, 7) and a.min() >= 0 and a.max() < 7
    assert np.array_equal(a, ps.resamples(7, 50, 3))
    assert not np.array_equal(a, ps.resamples(7, 50, 4))
    # replicates that are all NaN (no ball to share) give no interval
    lo, hi = ps.percentile_ci([math.nan, math.nan])
    assert math.isnan(lo) and math.isnan(hi)


def reference_rank_probabilities(means, idx):
    """Loop over resamples with scipy.stats.rankdata (1 = highest mean)."""
    k = len(means)
    counts = np.zeros((k, k))
    for row in idx:
        r = stats.rankdata(-means[:, row].mean(axis=1), method="ordinal")
        counts[np.arange(k), r - 1] += 1
    return counts / len(idx)


def test_rank_probabilities_against_reference_and_known_orders():
    rng = np.random.default_rng(5)
    n = 30
    means = rng.normal(size=(5, n)) * 0.3 + np.array([[0.0], [0.05], [0.1], [0.4], [-0.2]])
    idx = ps.resamples(n, 2000, 9)
    prob, point = ps.rank_probabilities(means, idx)
    assert np.array_equal(prob, reference_rank_probabilities(means, idx))
    assert np.allclose(prob.sum(axis=0), 1) and np.allclose(prob.sum(axis=1), 1)
    assert list(point) == list(stats.rankdata(-means.mean(axis=1), method="ordinal"))
    # well separated variants: their ranks are certain
    sep = np.array([[3.0], [1.0], [2.0]]) + 0.01 * rng.normal(size=(3, n))
    prob, point = ps.rank_probabilities(sep, idx)
    assert list(point) == [1, 3, 2]
    assert np.array_equal(prob, np.array([[1, 0, 0], [0, 0, 1], [0, 1, 0]], float))
    # two exchangeable variants: each ranks first in about half of the
    # resamples, over 200 seeded datasets (mean within 4 standard errors of
    # 0.5; the standard error of one dataset's share is at most 0.5)
    firsts = []
    for s in range(200):
        x = np.random.default_rng(s).normal(size=(2, n))
        firsts.append(ps.rank_probabilities(x, idx[:200])[0][0, 0])
    assert abs(np.mean(firsts) - 0.5) <= 4 * 0.5 / math.sqrt(200)


def test_pocket_share_against_a_loop():
    rng = np.random.default_rng(2)
    counts = rng.integers(0, 6, size=(12, len(ps.POCKETS)))
    idx = ps.resamples(12, 500, 1)
    (est, lo, hi), tot = ps.share2(counts, idx)
    i2, i5 = ps.POCKETS.index(2), ps.POCKETS.index(5)
    assert tot == counts[:, i2].sum() + counts[:, i5].sum()
    assert est == pytest.approx(counts[:, i2].sum() / tot, rel=1e-15)
    reps = [counts[r, i2].sum() / (counts[r, i2].sum() + counts[r, i5].sum()) for r in idx]
    assert (lo, hi) == tuple(np.percentile(reps, [2.5, 97.5]))


# ------------------------------------------------------------ pipeline

@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """A tiny study through scripts/power.sh: (study folder, docs folder)."""
    binary = poolreps_path()
    if binary is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    if shutil.which("parallel") is None:
        pytest.skip("GNU parallel not installed")
    root = tmp_path_factory.mktemp("power")
    out, docs = root / "study", root / "docs"
    sets = [a for s in TINY for a in ("--set", s)]
    p = run_cmd(["sh", ROOT / "scripts" / "power.sh", out, str(REPS), docs,
                        sys.executable] + sets, capture_output=True, text=True, cwd=root,
                       env=dict(os.environ, POOLREPS=binary, LC_ALL="C"),
                       timeout=600 * float(os.environ.get("POOLREPS_TIMEOUT_SCALE", "1")))
    assert p.returncode == 0, p.stdout + p.stderr
    return out, docs


@pytest.mark.slow
def test_study_writes_report_and_intervals(study):
    out, docs = study
    for arm in ps.ARMS:
        jobs = (out / "runs" / arm / "jobs.txt").read_text().splitlines()
        assert len(jobs) == REPS, jobs
        assert (out / arm / "exp3_episodes.csv").is_file()
    md = (docs / "power.md").read_text(encoding="utf-8")
    assert "{{" not in md and not re.search(r"\bnan\b", md, re.I)
    assert f"at {REPS} repetitions" in md
    for name in ("power_effects.png", "power_effects.svg"):
        assert (docs / "figures" / name).stat().st_size > 1000
    assert (docs / "figures" / "power_effects.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the verdicts are docs/verdicts.md's alone
    assert not (out / "power_claims.csv").exists()
    assert not re.search(r"\b(agrees|disagrees|undecided)\b", md), md
    effects = rows(out / "power_effects.csv")
    assert len(effects) == 3 * 6
    for e in effects:
        assert int(e["repetitions"]) == REPS
        v = {k: float(e[k]) for k in ("effect", "t_lo", "t_hi", "boot_lo", "boot_hi",
                                      "mean_return", "mean_lo", "mean_hi")}
        if e["policy"] == "baseline":
            assert v["effect"] == 0 and v["t_lo"] == 0 and v["t_hi"] == 0
        else:
            assert v["t_lo"] < v["effect"] < v["t_hi"]
            assert v["boot_lo"] <= v["effect"] <= v["boot_hi"]
        assert v["mean_lo"] <= v["mean_return"] <= v["mean_hi"]
    timing = rows(out / "timing.csv")
    assert [t["phase"] for t in timing] == ["runs", "merge"]
    assert all(float(t["wall_seconds"]) >= 0 for t in timing)
    assert "**" + f"{sum(float(t['wall_seconds']) for t in timing):.0f} s" in md


@pytest.mark.slow
def test_study_effects_equal_an_independent_computation(study):
    """From poolreps's own exp3_final.csv (not the episodes the script
    reads): per arm and variant, scipy's paired t interval against the
    baseline equals the script's (1e-12 absolute)."""
    out, _ = study
    got = {(r["arm"], r["policy"]): r for r in rows(out / "power_effects.csv")}
    for arm in ps.ARMS:
        final = [r for r in rows(out / arm / "exp3_final.csv") if r["repetition"] != "-1"]
        mean = {(r["policy"], int(r["repetition"])): float(r["mean_return"]) for r in final}
        reps = sorted({k for _, k in mean})
        assert reps == list(range(REPS))
        for p in sorted({p for p, _ in mean} - {"baseline"}):
            a = np.array([mean[(p, k)] for k in reps])
            b = np.array([mean[("baseline", k)] for k in reps])
            lo, hi = reference_t(a, b)
            e = got[(arm, p)]
            assert float(e["effect"]) == pytest.approx(np.mean(a - b), abs=1e-12)
            assert float(e["t_lo"]) == pytest.approx(lo, abs=1e-12)
            assert float(e["t_hi"]) == pytest.approx(hi, abs=1e-12)


@pytest.mark.slow
def test_study_pockets_equal_poolreps_counts(study):
    """Per-pocket totals equal poolreps's exp3_pockets.csv; each interval
    holds its mean."""
    out, _ = study
    got = rows(out / "power_pockets.csv")
    for arm in ps.ARMS:
        ref = {(r["policy"], int(r["pocket"])): int(r["count"])
               for r in rows(out / arm / "exp3_pockets.csv")}
        mine = {(r["policy"], int(r["pocket"])): int(r["total"]) for r in got if r["arm"] == arm}
        assert mine == ref
    for r in got:
        assert float(r["lo"]) <= float(r["per_run"]) <= float(r["hi"])
        assert float(r["per_run"]) == pytest.approx(int(r["total"]) / REPS, rel=1e-15)
    ranks = rows(out / "power_ranks.csv")
    for arm in ps.ARMS:
        for p in ps.THESIS:
            pr = [float(r["probability"]) for r in ranks if r["arm"] == arm and r["policy"] == p]
            assert len(pr) == 5 and sum(pr) == pytest.approx(1, abs=1e-12)


@pytest.mark.slow
def test_report_is_deterministic(study, tmp_path):
    out, docs = study
    p = run_cmd([sys.executable, ROOT / "scripts" / "power_stats.py", out,
                 "--docs", tmp_path / "docs"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    for f in ("power.md", "figures/power_effects.png", "figures/power_effects.svg"):
        assert (tmp_path / "docs" / f).read_bytes() == (docs / f).read_bytes(), f


@pytest.mark.slow
def test_bad_study_fails_with_one_line(study, tmp_path):
    out, _ = study
    script = [sys.executable, ROOT / "scripts" / "power_stats.py"]
    p = run_cmd(script + [tmp_path], capture_output=True, text=True)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "event and stepped" in p.stderr
    # a truncated arm: named, exit 3, nothing written
    bad = tmp_path / "bad"
    for arm in ("event", "stepped"):
        shutil.copytree(out / arm, bad / arm)
    path = bad / "stepped" / "exp3_episodes.csv"
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines[:-1]))
    p = run_cmd(script + [bad, "--docs", bad / "docs"], capture_output=True, text=True)
    assert p.returncode == 3 and p.stderr.count("\n") == 1, p.stderr
    assert "exp3_episodes.csv" in p.stderr and "episodes, expected" in p.stderr
    assert sorted(os.listdir(bad)) == ["event", "stepped"]
    # a malformed number: file and line named, exit 2
    fields = lines[5].split(",")
    fields[2] = "x"
    path.write_text("".join(lines[:5]) + ",".join(fields) + "".join(lines[6:]))
    p = run_cmd(script + [bad], capture_output=True, text=True)
    assert p.returncode == 2 and "exp3_episodes.csv:6:" in p.stderr, p.stderr


def test_repository_report_has_no_verdicts():
    """docs/power.md describes the verdict study at its size; its verdicts
    are docs/verdicts.md's."""
    md = (ROOT / "docs" / "power.md").read_text(encoding="utf-8")
    assert not re.search(r"\b(agrees|disagrees|undecided)\b", md)
    assert "verdicts.md" in md and " 50 repetitions" not in md and "at 50 " not in md
    assert "<!-- power:" not in (ROOT / "README.md").read_text(encoding="utf-8")


def test_power_never_writes_docs():
    """make power reports into OUT/power at any size: docs/power.md is the
    verdict study's (make verdicts)."""
    make = shutil.which("make")
    if make is None:
        pytest.skip("make not installed")

    def recipe(*args):
        p = run_cmd([make, "-n", "-s", "power", *args], cwd=ROOT, capture_output=True,
                           text=True, timeout=60)
        assert p.returncode == 0, p.stderr
        line = [x for x in p.stdout.splitlines() if "scripts/power.sh" in x]
        assert len(line) == 1, p.stdout
        return shlex.split(line[0])[2:6]

    assert recipe("OUT=/o")[:3] == ["/o/power", "50", "/o/power"]
    assert recipe("POWER_REPS=4", "OUT=/o")[:3] == ["/o/power", "4", "/o/power"]
    assert recipe("POWER_ARGS=--set exp3.iterations=5", "OUT=/o")[2] == "/o/power"
