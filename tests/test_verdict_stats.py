"""scripts/verdict_stats.py against scipy.stats's own tests, on many seeded
random problems and degenerate ones (n = 2, zero spread, ties in Holm)."""
import itertools
import math
import os
import sys

import numpy as np
import pytest
from scipy import optimize, stats

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "scripts"))
import verdict_stats as vs  # noqa: E402

SEEDS = range(40)


def problem(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 60))
    a = rng.normal(rng.normal(0, 1), rng.uniform(0.01, 3), n)
    b = a * rng.uniform(-1, 1) + rng.normal(0, rng.uniform(0.01, 2), n)
    return rng, a, b


@pytest.mark.parametrize("seed", SEEDS)
def test_paired_interval_and_one_sided_tests(seed):
    rng, a, b = problem(seed)
    e = vs.paired(a, b)
    d = a - b
    lo, hi = stats.t.interval(0.95, len(d) - 1, loc=d.mean(), scale=stats.sem(d))
    assert vs.interval(e) == pytest.approx((lo, hi), rel=1e-10, abs=1e-12)
    bound = float(rng.normal(d.mean(), 2 * stats.sem(d)))
    for alt, fn in (("greater", vs.p_greater), ("less", vs.p_less)):
        ref = stats.ttest_1samp(d, bound, alternative=alt).pvalue
        assert fn(e, bound) == pytest.approx(ref, rel=1e-9, abs=1e-14)
        ref = stats.ttest_rel(a, b, alternative=alt).pvalue
        assert fn(e) == pytest.approx(ref, rel=1e-9, abs=1e-14)


@pytest.mark.parametrize("seed", SEEDS)
def test_welch(seed):
    rng, a, _ = problem(seed)
    b = rng.normal(0.3, rng.uniform(0.1, 4), int(rng.integers(2, 40)))
    e = vs.welch(a, b)
    for alt, fn in (("greater", vs.p_greater), ("less", vs.p_less)):
        ref = stats.ttest_ind(a, b, equal_var=False, alternative=alt).pvalue
        assert fn(e) == pytest.approx(ref, rel=1e-9, abs=1e-14)
    # the interval is where the two-sided Welch test does not reject at 5 %
    lo, hi = vs.interval(e)
    for edge in (lo, hi):
        assert stats.ttest_ind(a - edge, b, equal_var=False).pvalue == pytest.approx(0.05, abs=1e-9)


@pytest.mark.parametrize("seed", SEEDS)
def test_tost_and_its_complement(seed):
    rng, a, b = problem(seed)
    d = a - b
    half = float(rng.uniform(0.05, 2)) * max(stats.sem(d), 1e-3)
    low, high = d.mean() + float(rng.normal(0, 1)) * half - half, 0.0
    high = low + 2 * half
    e = vs.paired(a, b)
    p1 = stats.ttest_1samp(d, low, alternative="greater").pvalue
    p2 = stats.ttest_1samp(d, high, alternative="less").pvalue
    assert vs.p_tost(e, low, high) == pytest.approx(max(p1, p2), rel=1e-9, abs=1e-14)
    out = min(1, 2 * min(stats.ttest_1samp(d, low, alternative="less").pvalue,
                         stats.ttest_1samp(d, high, alternative="greater").pvalue))
    assert vs.p_outside(e, low, high) == pytest.approx(out, rel=1e-9, abs=1e-14)
    assert vs.p_tost(e, -math.inf, high) == pytest.approx(p2, rel=1e-9, abs=1e-14)
    # the equivalence holds at 5 % exactly when the 90 % interval lies inside
    lo90, hi90 = stats.t.interval(0.90, len(d) - 1, loc=d.mean(), scale=stats.sem(d))
    assert (vs.p_tost(e, low, high) < 0.05) == (low < lo90 and hi90 < high)


def holm_reference(ps):
    """Holm by its definition: reject in order while p_(k) <= alpha / (m - k + 1);
    the adjusted p-value is the smallest alpha at which H_k is rejected."""
    m = len(ps)
    order = sorted(range(m), key=lambda i: ps[i])
    out, running = [0.0] * m, 0.0
    for k, i in enumerate(order):
        running = max(running, min(1.0, (m - k) * ps[i]))
        out[i] = running
    return out


@pytest.mark.parametrize("seed", SEEDS)
def test_holm(seed):
    rng = np.random.default_rng(seed)
    m = int(rng.integers(1, 80))
    ps = list(rng.uniform(0, 1, m) ** rng.uniform(1, 8))
    if m > 3:
        ps[1] = ps[0]  # a tie
        ps[2] = 0.0
    adj = vs.holm(ps)
    assert adj == pytest.approx(holm_reference(ps), rel=1e-12, abs=0)
    # rejections at alpha are those of the step-down procedure
    for alpha in (0.01, 0.05, 0.2):
        order = sorted(range(m), key=lambda i: ps[i])
        rejected = set()
        for k, i in enumerate(order):
            if ps[i] > alpha / (m - k):
                break
            rejected.add(i)
        assert {i for i in range(m) if adj[i] <= alpha} == rejected


@pytest.mark.parametrize("seed", SEEDS)
def test_fieller(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(5, 60))
    b = rng.poisson(rng.uniform(3, 20), n) + 1
    a = rng.binomial(b, rng.uniform(0.2, 0.8))
    r, lo, hi = vs.fieller(a, b)
    assert r == pytest.approx(a.sum() / b.sum(), rel=1e-12)
    q = stats.t.ppf(0.975, n - 1)

    def tstat(c):
        return stats.ttest_1samp(a - c * b, 0).statistic

    # the interval's ends are where the t statistic of a - c b crosses -+q
    if math.isfinite(lo) and math.isfinite(hi):
        assert lo <= r <= hi
        ref_lo = optimize.brentq(lambda c: tstat(c) - q, -10, r)
        ref_hi = optimize.brentq(lambda c: tstat(c) + q, r, 10)
        assert (lo, hi) == pytest.approx((ref_lo, ref_hi), abs=1e-9)
        assert vs.p_greater(vs.share_estimate(a, b, lo)) == pytest.approx(0.025, abs=1e-9)


def test_degenerate():
    e = vs.paired([1.0, 1.0, 1.0], [0.0, 0.0, 0.0])     # zero spread
    assert e.se == 0 and vs.p_greater(e) == 0.0 and vs.p_less(e) == 1.0
    assert vs.interval(e) == (1.0, 1.0)
    e = vs.one_sample([0.0, 0.0])
    assert vs.p_greater(e) == 0.5 and vs.p_tost(e, -1, 1) == 0.0
    e = vs.one_sample([0.2, 0.5])                        # n = 2
    ref = stats.ttest_1samp([0.2, 0.5], 0.1, alternative="greater").pvalue
    assert vs.p_greater(e, 0.1) == pytest.approx(ref, rel=1e-10)
    for bad in ([1.0], [1.0, math.nan], []):
        with pytest.raises(ValueError):
            vs.one_sample(bad)
    with pytest.raises(ValueError):
        vs.paired([1, 2, 3], [1, 2])
    with pytest.raises(ValueError):
        vs.p_tost(e, 1, 1)
    with pytest.raises(ValueError):
        vs.holm([0.5, 1.5])
    assert vs.holm([]) == []


def test_verdicts():
    A, D, U = vs.AGREES, vs.DISAGREES, vs.UNDECIDED
    assert vs.part_verdict(0.01, 0.9) == A
    assert vs.part_verdict(0.9, 0.01) == D
    assert vs.part_verdict(0.05, 0.05) == U     # not below alpha
    with pytest.raises(ValueError):
        vs.part_verdict(0.01, 0.01)
    for parts in itertools.product((A, D, U), repeat=3):
        got = vs.all_of(parts)
        assert got == (A if set(parts) == {A} else D if D in parts else U)
        n_a, n_d = parts.count(A), parts.count(D)
        assert vs.at_least(parts, 2) == (A if n_a >= 2 else D if 3 - n_d < 2 else U)
    assert vs.combine_modes([A, A, A]) == A
    assert vs.combine_modes([A, U, A]) == U
    assert vs.combine_modes([D, D]) == D


@pytest.mark.parametrize("seed", SEEDS)
def test_trend_is_scipys_linregress(seed):
    rng = np.random.default_rng(1000 + seed)
    n = int(rng.integers(3, 60))
    y = rng.normal(0, rng.uniform(0.01, 2), n) + rng.normal(0, 0.1) * np.arange(n)
    e = vs.trend(y)
    ref = stats.linregress(np.arange(n), y)
    assert e.est == pytest.approx(ref.slope * (n - 1), rel=1e-9, abs=1e-12)
    assert e.se == pytest.approx(ref.stderr * (n - 1), rel=1e-9, abs=1e-12)
    assert e.df == n - 2
    # the one-sided test of the slope: scipy's two-sided p of slope 0, halved
    side = vs.p_greater(e) if ref.slope > 0 else vs.p_less(e)
    assert side == pytest.approx(ref.pvalue / 2, rel=1e-7, abs=1e-14)
    with pytest.raises(ValueError):
        vs.trend([1.0, 2.0])


@pytest.mark.parametrize("seed", SEEDS)
def test_binomial_tests_and_clopper_pearson(seed):
    rng = np.random.default_rng(2000 + seed)
    n = int(rng.integers(1, 80))
    k = int(rng.integers(0, n + 1))
    c = float(rng.uniform(0.01, 0.99))
    for alt, fn in (("greater", vs.p_binom_greater), ("less", vs.p_binom_less)):
        ref = stats.binomtest(k, n, c, alternative=alt).pvalue
        assert fn(k, n, c) == pytest.approx(ref, rel=1e-9, abs=1e-14)
    level = float(rng.uniform(0.5, 0.9999))
    ref = stats.binomtest(k, n).proportion_ci(level, method="exact")
    lo, hi = vs.clopper_pearson(k, n, level)
    assert (lo, hi) == pytest.approx((ref.low, ref.high), abs=1e-10)
    # duality: the exact test rejects at (1 - level) / 2 exactly outside the interval
    a = (1 - level) / 2
    for bound in (lo * 0.999, lo * 1.001 + 1e-9, hi * 0.999, min(hi * 1.001, 1 - 1e-12)):
        if 0 < bound < 1:
            assert (vs.p_binom_greater(k, n, bound) < a) == (bound < lo)
            assert (vs.p_binom_less(k, n, bound) < a) == (bound > hi)
    for bad in ((-1, 5), (6, 5), (0, 0), (1.5, 3)):
        with pytest.raises(ValueError):
            vs.p_binom_less(*bad, 0.5)


def holm_levels_ref(ps, alpha):
    """Step-down by hand: reject the smallest while p < alpha / (m - rank);
    tied p-values share the first one's level, whatever the list's order."""
    m, out = len(ps), [None] * len(ps)
    stop, first = None, {}
    for rank, i in enumerate(sorted(range(m), key=lambda j: ps[j])):
        here = alpha / (m - rank)
        if stop is None and not ps[i] < here:
            stop = here
        out[i] = first.setdefault(ps[i], here if stop is None else stop)
    return out


@pytest.mark.parametrize("seed", SEEDS)
def test_holm_levels_give_the_holm_decision(seed):
    rng = np.random.default_rng(3000 + seed)
    m = int(rng.integers(1, 40))
    ps = list(rng.uniform(0, 1, m) ** rng.uniform(1, 8))
    if m > 3:
        ps[1] = ps[2] = ps[0]                       # ties
    alpha = float(rng.choice([0.05, 0.1, 0.01]))
    lv = vs.holm_levels(ps, alpha)
    assert lv == pytest.approx(holm_levels_ref(ps, alpha), rel=1e-12)
    adj = vs.holm(ps)
    for p, a, level in zip(ps, adj, lv):
        assert (p < level) == (a < alpha)
    assert vs.holm_levels([], 0.05) == []
    # the order of the list does not move a level (ties included)
    perm = rng.permutation(m)
    assert [lv[i] for i in perm] == vs.holm_levels([ps[i] for i in perm], alpha)


def power_by_integration(delta, sd, n, level):
    """The one-sided t test's power from its definition: the sample mean is
    N(delta, sd^2 / n), (n - 1) S^2 / sd^2 is chi-square(n - 1), independent;
    P(mean / (S / sqrt n) > c) integrated over the chi-square (no noncentral t)."""
    from scipy import integrate
    c = stats.t.isf(level, n - 1)
    f = lambda v: (stats.norm.sf(c * math.sqrt(v / (n - 1)) - delta * math.sqrt(n) / sd)  # noqa: E731
                   * stats.chi2.pdf(v, n - 1))
    lo, hi = stats.chi2.ppf([1e-12, 1 - 1e-12], n - 1)
    return integrate.quad(f, lo, hi, limit=200, epsabs=1e-10)[0]


@pytest.mark.parametrize("seed", range(12))
def test_power_t_against_its_definition(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 400))
    sd = float(rng.uniform(0.01, 5)) * 10.0 ** int(rng.integers(-3, 3))
    delta = sd * float(rng.uniform(-0.2, 1.5)) * 4 / math.sqrt(n)
    level = float(rng.choice([0.05, 0.01, 1e-3, 3e-4]))
    assert vs.power_t(delta, sd, n, level) == pytest.approx(
        power_by_integration(delta, sd, n, level), abs=1e-6)


@pytest.mark.parametrize("seed", range(8))
def test_units_needed_is_the_smallest_n(seed):
    """The smallest n: the integrated power reaches 0.8 there and not one
    unit earlier, one side and two (an equivalence band: both must reject,
    their misses added)."""
    rng = np.random.default_rng(100 + seed)
    sd = float(rng.uniform(0.1, 3))
    sides = [(sd * float(rng.uniform(0.15, 1.2)), sd, float(rng.choice([0.05, 1e-3])))
             for _ in range(1 + seed % 2)]
    joint = lambda n: 1 - sum(1 - power_by_integration(d, s, n, lv)  # noqa: E731
                              for d, s, lv in sides)
    n = vs.units_needed(sides, 0.8)
    assert joint(n) >= 0.8 and (n == 2 or joint(n - 1) < 0.8), (n, joint(n), joint(n - 1))


def test_units_needed_textbook_and_degenerate():
    # Cohen's d = 0.5, one-sided alpha 0.05, power 0.8: 27 (G*Power's one-sample t)
    assert vs.units_needed([(0.5, 1.0, 0.05)], 0.8) == 27
    assert vs.units_needed([(0.0, 1.0, 0.05)], 0.8) == math.inf      # on the bound
    assert vs.units_needed([(-0.1, 1.0, 0.05)], 0.8) == math.inf     # the other way
    assert vs.units_needed([(1e-4, 1.0, 0.05)], 0.8) == math.inf     # beyond 10^6
    assert vs.units_needed([], 0.8) == math.inf
    assert vs.units_needed([(1.0, 0.0, 0.05)], 0.8) == 2             # no spread
    with pytest.raises(ValueError):
        vs.power_t(0.1, 1.0, 1, 0.05)


@pytest.mark.parametrize("seed", range(20))
def test_iqm_and_probability_of_improvement(seed):
    """Against scipy: trim_mean at 0.25 (what rliable's IQM calls) and the
    Mann-Whitney U statistic over n_x n_y, ties included (rounded scores)."""
    rng = np.random.default_rng(500 + seed)
    x = np.round(rng.standard_t(3, int(rng.integers(2, 40))) * 10 ** rng.uniform(-3, 3), 1)
    y = np.round(rng.normal(0.3, 1, int(rng.integers(2, 40))) * 10 ** rng.uniform(-3, 3), 1)
    assert vs.iqm(x) == pytest.approx(stats.trim_mean(x, 0.25), rel=1e-12, abs=1e-12)
    u = stats.mannwhitneyu(x, y, alternative="greater").statistic
    assert vs.prob_improvement(x, y) == pytest.approx(u / (len(x) * len(y)), rel=1e-12)
    assert vs.prob_improvement(x, y) + vs.prob_improvement(y, x) == pytest.approx(1.0)
    assert vs.iqm(x + 5.0) == pytest.approx(vs.iqm(x) + 5.0)          # offset
    assert vs.iqm(rng.permutation(x)) == vs.iqm(x)                     # order
    taus = np.linspace(x.min() - 1, x.max() + 1, 7)
    assert vs.performance_profile(x, taus) == pytest.approx([(x > t).mean() for t in taus])


def test_stratified_bootstrap_is_the_percentile_of_resampled_statistics():
    """The interval against a direct loop over the same seeded draws: each
    learner's runs resampled on their own, scipy's trim_mean on each, numpy's
    percentile; and it is reproducible and covers the estimate."""
    rng = np.random.default_rng(9)
    a, b = rng.normal(0, 1, 10), rng.normal(0.5, 2, 13)
    lo, hi = vs.bootstrap_ci(lambda x, y: vs.iqm(x) - vs.iqm(y), [a, b], 400, 7)
    g = np.random.default_rng(7)
    reps = []
    for _ in range(400):
        ia, ib = g.integers(0, 10, 10), g.integers(0, 13, 13)
        reps.append(stats.trim_mean(a[ia], 0.25) - stats.trim_mean(b[ib], 0.25))
    assert (lo, hi) == pytest.approx(tuple(np.percentile(reps, [2.5, 97.5])), rel=1e-12)
    assert vs.bootstrap_ci(lambda x, y: vs.iqm(x) - vs.iqm(y), [a, b], 400, 7) == (lo, hi)
    assert lo <= vs.iqm(a) - vs.iqm(b) <= hi


# ------------------------------------------------ the paired sign-flip test

def signflip_problem(seed):
    """Seeded differences of every kind the test must handle: continuous,
    integer ties, zeros, all equal, decimal ties, Cauchy tails, huge offsets
    and scales."""
    rng = np.random.default_rng(700 + seed)
    n = int(rng.integers(2, 13))
    kind = seed % 8
    if kind == 0:
        d = rng.normal(rng.normal(0, 1), rng.uniform(0.1, 2), n)
    elif kind == 1:                       # integer ties and zeros
        d = rng.integers(-3, 4, n).astype(float)
    elif kind == 2:                       # all equal
        d = np.full(n, rng.normal(0, 5))
    elif kind == 3:                       # ties of decimals (0.1 + 0.2 != 0.3)
        d = rng.integers(-4, 5, n) / 10
    elif kind == 4:                       # heavy tails
        d = rng.standard_cauchy(n)
    elif kind == 5:                       # pairs at a huge offset: cancellation
        a = 1e9 + rng.normal(0, 1, n)
        d = a - (1e9 + rng.normal(0.3, 1, n))
    elif kind == 6:                       # a huge or tiny scale
        d = rng.normal(0.4, 1, n) * 10.0 ** rng.choice([-6, 12])
    else:                                 # a few zeros among continuous values
        d = rng.normal(0.5, 1, n) * (rng.uniform(size=n) > 0.3)
    return d


@pytest.mark.parametrize("seed", range(64))
def test_signflip_is_scipys_exact_permutation_test(seed):
    """The exact p against scipy's permutation_test over all 2^n sign
    vectors of the sample (permutation_type 'samples'), two-sided."""
    d = signflip_problem(seed)
    ref = stats.permutation_test((d,), np.mean, permutation_type="samples",
                                 n_resamples=np.inf, alternative="two-sided").pvalue
    assert vs.p_signflip(d) == pytest.approx(min(1.0, ref), rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("seed", range(64))
def test_signflip_invariances(seed):
    """The same p for d scaled by c > 0, for -d, and in any order."""
    d = signflip_problem(seed)
    rng = np.random.default_rng(seed)
    p = vs.p_signflip(d)
    for c in (3.7, 1e-150, 1e150, 2.0 ** -40):
        assert vs.p_signflip(c * d) == p
    assert vs.p_signflip(-d) == p
    for _ in range(3):
        assert vs.p_signflip(rng.permutation(d)) == p


@pytest.mark.parametrize("n", [13, 17, 24, 31, 40])
def test_signflip_on_signed_ranks_is_the_exact_wilcoxon_test(n):
    """Beyond scipy's reach: on signed ranks the sign-flip sum is 2 W - n(n+1)/2
    of the signed-rank statistic W, so the p is scipy's exact Wilcoxon p."""
    rng = np.random.default_rng(n)
    d = rng.permutation(np.arange(1, n + 1)) * np.where(rng.uniform(size=n) < 0.3, -1.0, 1.0)
    ref = stats.wilcoxon(d, method="exact").pvalue
    assert vs.p_signflip(d) == pytest.approx(ref, rel=1e-9)


def test_signflip_degenerate_and_monte_carlo():
    """Known answers, and the seeded Monte Carlo beyond the exact range within
    its sampling error of the exact p."""
    assert vs.p_signflip([0.0, 0.0, 0.0]) == 1.0
    assert vs.p_signflip([2.5] * 10) == 2 / 2 ** 10
    assert vs.p_signflip([1.0, -1.0]) == 1.0
    assert vs.p_signflip([1.0, 1.0 + 1e-15, -2.0]) == 1.0       # a tie of 0 with 0
    with pytest.raises(ValueError):
        vs.p_signflip([1.0])
    with pytest.raises(ValueError):
        vs.p_signflip([1.0, math.nan])
    rng = np.random.default_rng(3)
    d = rng.normal(0.35, 1, 22)
    exact = vs.p_signflip(d)
    mc = vs.p_signflip(d, seed=5, exact_max=10, draws=40000)
    assert abs(mc - exact) < 4 * math.sqrt(exact * (1 - exact) / 40000)
    assert vs.p_signflip(d, seed=5, exact_max=10, draws=40000) == mc   # seeded
    big = rng.normal(0.2, 1, 300)
    p = vs.p_signflip(big, draws=20000)
    assert abs(p - stats.ttest_1samp(big, 0).pvalue) < 0.02     # large n: the t test's
