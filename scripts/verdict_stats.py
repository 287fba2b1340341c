#!/usr/bin/env python3
"""Tests and verdicts for claims judged on independent repetitions.

A stable API for every generated verdict table (docs/verdicts.md and the
studies that reuse it). Each function takes plain sequences of numbers; NaN
values are refused, not dropped (a missing run is an error upstream).

Estimates (a mean difference with its standard error and degrees of freedom):

    e = one_sample(x)          # mean of x
    e = paired(a, b)           # mean of a[k] - b[k]: runs paired by repetition
    e = welch(a, b)            # mean(a) - mean(b), independent samples (Welch)
    e.est, e.se, e.df, e.n     # the estimate, its standard error, df, sample size
    e = trend(y)               # least-squares change across y (slope x (len - 1))
    lo, hi = interval(e)       # 95 % t interval: est -+ t(0.975, df) * se
    m, lo, hi = t_interval(x)  # the same for a plain sample, as the figures print it

Tests (each returns a p-value; small p supports the alternative named):

    p_greater(e, bound=0)      # H1: mean > bound  (one-sided t test; superiority)
    p_less(e, bound=0)         # H1: mean < bound
    p_tost(e, low, high)       # H1: low < mean < high (two one-sided tests: the larger p)
    p_outside(e, low, high)    # H1: mean < low or mean > high (2 x the smaller one-sided p)

    p_signflip(d)              # H1: mean of d != 0, the paired sign-flip
                               # (randomization) test: no normality assumed

Counts (k of n units with a property; exact binomial, Clopper-Pearson):

    p_binom_greater(k, n, c)   # H1: share > c  (P(X >= k) when the share is c)
    p_binom_less(k, n, c)      # H1: share < c  (P(X <= k))
    lo, hi = clopper_pearson(k, n, level)   # the shares neither test rejects

Power (the units needed to decide, if the true mean were the estimate):

    power_t(delta, sd, n, level)   # P(one-sided t test at level rejects), true mean
                                   # delta beyond the bound, noncentral t
    units_needed(sides, power)     # smallest n at which every (delta, sd, level)
                                   # side rejects with joint power >= power

Aggregates of learners' runs (rliable's estimators, one task):

    iqm(x)                         # interquartile mean (floor(n/4) cut from each end)
    prob_improvement(x, y)         # P(X > Y) + P(X = Y) / 2 over all pairs of runs
    bootstrap_ci(stat, samples, reps, seed)   # stratified percentile bootstrap
    performance_profile(x, taus)   # share of runs above each tau

Multiplicity and verdicts:

    holm(ps)                   # Holm-adjusted p-values, same order as ps
    holm_levels(ps, alpha)     # the level each hypothesis was judged at
    part_verdict(p_support, p_refute, alpha=0.05)   # 'agrees' / 'disagrees' / 'undecided'
    all_of(verdicts), at_least(verdicts, k)          # combine the parts of a claim

A claim part is a pair of complementary hypotheses on one quantity: the
support (what the claim says) and the refutation (its complement at the same
bound). The part agrees when the support's adjusted p is below alpha, disagrees
when the refutation's is, and is undecided (not enough power to tell) when
neither is. The rule is fixed before the data are read; only the data decide.
"""
import math
from collections import namedtuple

import numpy as np
from scipy import special, stats

AGREES, DISAGREES, UNDECIDED = "agrees", "disagrees", "undecided"
LEVEL = 0.95
ALPHA = 0.05

Estimate = namedtuple("Estimate", "est se df n")
Estimate.__doc__ = "A mean (difference): estimate, standard error, degrees of freedom, n."


def _values(x, what):
    v = np.asarray(x, float).ravel()
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{what}: non-finite value")
    if len(v) < 2:
        raise ValueError(f"{what}: needs at least 2 values (got {len(v)})")
    return v


def one_sample(x):
    """Mean of x, se = s / sqrt(n), df = n - 1."""
    v = _values(x, "one_sample")
    n = len(v)
    return Estimate(float(v.mean()), float(v.std(ddof=1)) / math.sqrt(n), n - 1, n)


def paired(a, b):
    """Mean of the paired differences a[k] - b[k] (same length, same order)."""
    a, b = np.asarray(a, float).ravel(), np.asarray(b, float).ravel()
    if a.shape != b.shape:
        raise ValueError(f"paired: lengths differ ({len(a)} and {len(b)})")
    return one_sample(a - b)


def welch(a, b):
    """mean(a) - mean(b) of independent samples: se^2 = s_a^2/n_a + s_b^2/n_b,
    Welch-Satterthwaite df. n is n_a + n_b."""
    a, b = _values(a, "welch"), _values(b, "welch")
    va, vb = a.var(ddof=1) / len(a), b.var(ddof=1) / len(b)
    se2 = va + vb
    if se2 == 0:
        df = float(len(a) + len(b) - 2)
    else:
        df = se2 ** 2 / (va ** 2 / (len(a) - 1) + vb ** 2 / (len(b) - 1))
    return Estimate(float(a.mean() - b.mean()), math.sqrt(se2), float(df), len(a) + len(b))


def trend(y):
    """The least-squares line through y against 0, 1, ..., n - 1: its change
    from the first to the last point, slope x (n - 1), with the standard error
    from the residuals about the line (df = n - 2)."""
    v = _values(y, "trend")
    n = len(v)
    if n < 3:
        raise ValueError(f"trend: needs at least 3 values (got {n})")
    x = np.arange(n) - (n - 1) / 2
    sxx = float(x @ x)
    slope = float(x @ (v - v.mean())) / sxx
    resid = v - v.mean() - slope * x
    s2 = float(resid @ resid) / (n - 2)
    return Estimate(slope * (n - 1), math.sqrt(s2 / sxx) * (n - 1), n - 2, n)


def interval(e, level=LEVEL):
    """Two-sided t interval (lo, hi) of the estimate."""
    if not 0 < level < 1:
        raise ValueError(f"interval: level must be in (0, 1) (got {level})")
    # stats.t.ppf(q, df) is special.stdtrit(df, q) for q in (0, 1), behind the
    # same per-call checks as stats.t.sf (see p_greater)
    half = float(special.stdtrit(e.df, 0.5 + level / 2)) * e.se
    return e.est - half, e.est + half


def t_interval(x, level=LEVEL):
    """(mean, lo, hi) of x: its two-sided t interval, mean -+ t(0.5 + level /
    2, n - 1) s / sqrt(n) (the same bounds as interval(one_sample(x)), in the
    order of operations the figures and the power study always used)."""
    v = _values(x, "t_interval")
    n = len(v)
    m = float(v.mean())
    half = float(special.stdtrit(n - 1, 0.5 + level / 2)) * float(v.std(ddof=1)) / math.sqrt(n)
    return m, m - half, m + half


def _t(e, bound):
    """t statistic of the estimate against bound; +-inf when se is 0."""
    d = e.est - bound
    if e.se == 0:
        return math.inf if d > 0 else -math.inf if d < 0 else 0.0
    return d / e.se


def p_greater(e, bound=0.0):
    """One-sided p of H0: mean <= bound against H1: mean > bound."""
    # stats.t.sf(x, df) is special.stdtr(df, -x) behind per-call argument
    # checks that cost more than the function (tens of thousands of calls)
    return float(special.stdtr(e.df, -_t(e, bound)))


def p_less(e, bound=0.0):
    """One-sided p of H0: mean >= bound against H1: mean < bound."""
    return float(special.stdtr(e.df, _t(e, bound)))


def p_tost(e, low, high):
    """Equivalence, H1: low < mean < high, by two one-sided tests at the same
    level: the larger of their p-values. low may be -inf (one-sided bound)."""
    if not low < high:
        raise ValueError(f"p_tost: need low < high (got {low}, {high})")
    return max(p_greater(e, low) if math.isfinite(low) else 0.0,
               p_less(e, high) if math.isfinite(high) else 0.0)


def p_outside(e, low, high):
    """The complement of p_tost's alternative, H1: mean < low or mean > high:
    twice the smaller one-sided p (Bonferroni over the two directions)."""
    if not low < high:
        raise ValueError(f"p_outside: need low < high (got {low}, {high})")
    ps = [p_less(e, low) if math.isfinite(low) else 1.0,
          p_greater(e, high) if math.isfinite(high) else 1.0]
    return min(1.0, 2 * min(ps)) if all(map(math.isfinite, (low, high))) else min(ps)


# p_signflip: exact up to this many differences (2^20 sums per half), then
# SIGNFLIP_DRAWS seeded random sign vectors; |sums| within SIGNFLIP_RTOL of
# sum |d| of the observed one count as ties (rounding of theoretically equal
# sums; scipy's permutation_test uses 1e-14 of the observed statistic)
SIGNFLIP_EXACT_MAX = 40
SIGNFLIP_DRAWS = 100000
SIGNFLIP_RTOL = 1e-12


def _flip_sums(x):
    """sum(s_i x_i) for all 2^len(x) sign vectors s; the first is the all-plus
    sum and the last its exact negative (each step forms a + v and -a - v,
    which round alike)."""
    s = np.zeros(1)
    for v in x:
        s = np.concatenate([s + v, s - v])
    return s


def p_signflip(d, seed=0, exact_max=SIGNFLIP_EXACT_MAX, draws=SIGNFLIP_DRAWS):
    """Two-sided p of the paired sign-flip (randomization) test of H0: the
    differences d are symmetric about 0, with the statistic |sum(d)|: the
    share of the 2^n sign vectors s with |sum(s_i d_i)| >= |sum(d)|. Exact
    for n <= exact_max (meet in the middle: each half's 2^(n/2) sums, one
    half sorted, counted by bisection); beyond, (1 + hits) / (1 + draws) over
    draws random sign vectors of a numpy Generator seeded with seed."""
    v = _values(d, "p_signflip")
    n = len(v)
    gamma = SIGNFLIP_RTOL * float(np.abs(v).sum())
    if n <= exact_max:
        left, right = _flip_sums(v[:n // 2]), _flip_sums(v[n // 2:])
        t = abs(left[0] + right[0]) - gamma
        if t <= 0:
            return 1.0
        right.sort()
        hits = (len(right) - np.searchsorted(right, t - left, "left")).sum() + \
            np.searchsorted(right, -t - left, "right").sum()
        return float(hits) / 2.0 ** n
    t = abs(float(v.sum())) - gamma
    if t <= 0:
        return 1.0
    rng = np.random.default_rng(seed)
    hits, left = 0, draws
    while left > 0:
        k = min(left, max(1, 2 ** 22 // n))
        signs = rng.integers(0, 2, (k, n)) * 2.0 - 1.0
        hits += int((np.abs(signs @ v) >= t).sum())
        left -= k
    return (1 + hits) / (1 + draws)


def holm(ps):
    """Holm's step-down adjustment: the k-th smallest of m p-values becomes
    max over j <= k of min(1, (m - j + 1) p_(j)). Same order as ps."""
    p = np.asarray(ps, float)
    if p.ndim != 1 or not np.all((p >= 0) & (p <= 1)):
        raise ValueError("holm: p-values must be a list of numbers in [0, 1]")
    m = len(p)
    order = np.argsort(p, kind="stable")
    adj = np.minimum(1.0, np.maximum.accumulate((m - np.arange(m)) * p[order]))
    out = np.empty(m)
    out[order] = adj
    return [float(x) for x in out]


def holm_levels(ps, alpha=ALPHA):
    """The level Holm's step-down procedure judged each p-value at: the k-th
    smallest against alpha / (m - k + 1) until the first that fails; that one
    and every larger p against the level of the first failure. So p < level
    exactly when holm(ps) < alpha, and a confidence bound at 1 - level gives
    the same decision as the adjusted p-value. Tied p-values share the level
    of the first of them (the strictest), so the levels do not depend on the
    order of the list. Same order as ps."""
    p = np.asarray(ps, float)
    holm(p)  # the same validation
    m = len(p)
    order = np.argsort(p, kind="stable")
    sp = p[order]
    levels = alpha / (m - np.arange(m))
    fails = np.nonzero(sp >= levels)[0]
    if len(fails):
        levels[fails[0]:] = levels[fails[0]]
    first = np.searchsorted(sp, sp, side="left")   # each p's first tie
    levels = levels[first]
    out = np.empty(m)
    out[order] = levels
    return [float(x) for x in out]


def _count(k, n):
    if not (isinstance(k, (int, np.integer)) and isinstance(n, (int, np.integer))
            and 0 <= k <= n and n > 0):
        raise ValueError(f"binomial: need integers 0 <= k <= n, n > 0 (got {k}, {n})")


def p_binom_greater(k, n, c):
    """Exact one-sided p of H0: share <= c against H1: share > c."""
    _count(k, n)
    return float(stats.binom.sf(k - 1, n, c))


def p_binom_less(k, n, c):
    """Exact one-sided p of H0: share >= c against H1: share < c."""
    _count(k, n)
    return float(stats.binom.cdf(k, n, c))


def clopper_pearson(k, n, level=LEVEL):
    """Two-sided Clopper-Pearson interval of a share k / n: each end the
    one-sided bound at (1 + level) / 2, from the beta quantiles, so that
    p_binom_greater(k, n, c) < (1 - level) / 2 exactly when c < lo."""
    _count(k, n)
    a = (1 - level) / 2
    lo = 0.0 if k == 0 else float(stats.beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(stats.beta.isf(a, k + 1, n - k))
    return lo, hi


def part_verdict(p_support, p_refute, alpha=ALPHA):
    """agrees when the support is significant, disagrees when the refutation
    is, undecided when neither (both cannot be: they are complementary)."""
    s, r = p_support < alpha, p_refute < alpha
    if s and r:
        raise ValueError("part_verdict: support and refutation both significant")
    return AGREES if s else DISAGREES if r else UNDECIDED


def all_of(verdicts):
    """A claim about every part: agrees when each part agrees, disagrees when
    any part disagrees, else undecided."""
    v = list(verdicts)
    if not v:
        raise ValueError("all_of: no parts")
    if all(x == AGREES for x in v):
        return AGREES
    return DISAGREES if DISAGREES in v else UNDECIDED


def at_least(verdicts, k):
    """'At least k parts hold': agrees when k parts agree, disagrees when fewer
    than k parts could (agree or undecided), else undecided."""
    v = list(verdicts)
    if sum(x == AGREES for x in v) >= k:
        return AGREES
    return DISAGREES if sum(x != DISAGREES for x in v) < k else UNDECIDED


def combine_modes(verdicts):
    """One verdict over several replications (physics modes): the common
    verdict when they all give it, else undecided."""
    v = list(verdicts)
    if not v:
        raise ValueError("combine_modes: no verdicts")
    return v[0] if all(x == v[0] for x in v) else UNDECIDED


def fieller(num, den, level=LEVEL):
    """Ratio of means sum(num) / sum(den) over paired per-repetition values
    (e.g. balls in one pocket over balls in both) and its Fieller interval:
    every c for which the t test of mean(num - c den) = 0 is not rejected at
    1 - level (two-sided). Returns (ratio, lo, hi); lo or hi is +-inf when the
    set is unbounded (the denominator's mean not significantly above 0)."""
    a, b = _values(num, "fieller"), _values(den, "fieller")
    if a.shape != b.shape:
        raise ValueError(f"fieller: lengths differ ({len(a)} and {len(b)})")
    n = len(a)
    if b.mean() <= 0:
        raise ValueError("fieller: the denominator's mean must be positive")
    q = stats.t.ppf(0.5 + level / 2, n - 1) ** 2 / n
    cov = np.cov(a, b, ddof=1)
    ma, mb = a.mean(), b.mean()
    # (ma - c mb)^2 <= q (saa - 2 c sab + c^2 sbb): A c^2 - 2 B c + C <= 0
    A, B, C = mb * mb - q * cov[1, 1], ma * mb - q * cov[0, 1], ma * ma - q * cov[0, 0]
    r = float(ma / mb)
    if A <= 0:
        return r, -math.inf, math.inf
    disc = math.sqrt(max(B * B - A * C, 0.0))
    return r, float((B - disc) / A), float((B + disc) / A)


def share_estimate(num, den, c):
    """The estimate mean(num - c den) whose sign says whether the ratio
    sum(num) / sum(den) is above (> 0) or below c: tests of a ratio bound."""
    a, b = np.asarray(num, float), np.asarray(den, float)
    return one_sample(a - c * b)


def power_t(delta, sd, n, level):
    """Power of the one-sided one-sample t test at level with n units when
    the true mean lies delta beyond the bound (towards H1) and the units' SD
    is sd: P(T > t(1 - level, n - 1)), T noncentral t with noncentrality
    delta sqrt(n) / sd."""
    if n < 2 or not 0 < level < 1:
        raise ValueError(f"power_t: need n >= 2 and 0 < level < 1 (got {n}, {level})")
    crit = float(special.stdtrit(n - 1, 1 - level))
    if sd == 0:
        return 1.0 if delta > 0 else 0.0
    with np.errstate(all="ignore"):   # far tails: scipy clips its 0/0 to 0 or 1
        return float(stats.nct.sf(crit, n - 1, delta * math.sqrt(n) / sd))


UNITS_MAX = 10 ** 6


def units_needed(sides, power):
    """The smallest n at which a decision that needs every one-sided test of
    sides, each (delta, sd, level), has power at least power; the joint power
    is bounded below by 1 - sum of the sides' misses (Bonferroni). math.inf
    when a side's delta is not positive or n would exceed UNITS_MAX."""
    if not sides or any(not delta > 0 for delta, _, _ in sides):
        return math.inf

    def ok(n):
        return 1 - sum(1 - power_t(dl, sd, n, lv) for dl, sd, lv in sides) >= power
    hi = 2
    while not ok(hi):
        if hi >= UNITS_MAX:
            return math.inf
        hi = min(2 * hi, UNITS_MAX)
    lo = max(2, hi // 2)
    if ok(lo):
        return lo
    while hi - lo > 1:   # ok(hi), not ok(lo): the power grows with n
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
    return hi


# ------------------------------------------------ aggregate scores of learners
# (Agarwal et al., NeurIPS 2021, "Deep RL at the edge of the statistical
# precipice": the estimators of the rliable library, on one task)

def iqm(x):
    """Interquartile mean as rliable computes it: the sorted values with
    floor(n / 4) cut from each end, averaged."""
    v = np.sort(_values(x, "iqm"))
    k = len(v) // 4
    return float(v[k:len(v) - k].mean())


def prob_improvement(x, y):
    """P(X > Y) + P(X = Y) / 2 of one run of x against one run of y, over
    every pair (the Mann-Whitney U statistic over n_x n_y)."""
    a, b = _values(x, "prob_improvement"), _values(y, "prob_improvement")
    gt = (a[:, None] > b[None, :]).sum()
    eq = (a[:, None] == b[None, :]).sum()
    return float((gt + 0.5 * eq) / (len(a) * len(b)))


def bootstrap_ci(stat, samples, reps, seed, level=LEVEL):
    """Percentile interval of stat(*samples) under the stratified bootstrap:
    each sample (a learner's runs) resampled with replacement on its own, by a
    numpy Generator seeded with seed. Returns (lo, hi)."""
    rng = np.random.default_rng(seed)
    vals = [_values(s, "bootstrap_ci") for s in samples]
    out = np.empty(reps)
    for i in range(reps):
        out[i] = stat(*[v[rng.integers(0, len(v), len(v))] for v in vals])
    a = (1 - level) / 2
    return float(np.quantile(out, a)), float(np.quantile(out, 1 - a))


def performance_profile(x, taus):
    """The share of runs whose score exceeds each tau."""
    v = _values(x, "performance_profile")
    return [float(np.mean(v > t)) for t in taus]
