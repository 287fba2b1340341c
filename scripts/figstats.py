#!/usr/bin/env python3
"""Small statistics shared by the plot scripts and the claims table
(standard library only, so that scripts/claims.py runs without numpy).

    mean_ci([0.1, 0.3, 0.2])         -> (0.2, lo, hi): mean and 95 % t interval
    paired(a, b)                     -> [a[k] - b[k] for the keys both have]
    t_quantile(0.975, 4)             -> 2.7764451...

Intervals are Student-t intervals of a mean over independent repetitions
(runs, forests): mean +- t(1 - alpha/2, n - 1) * s / sqrt(n), s the sample
standard deviation. With fewer than two values there is no interval (None).
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import math
import statistics


def t_cdf(t, df):
    """P(T <= t) for Student's t with an integer number df >= 1 of degrees of
    freedom, from the finite series for P(|T| <= t) (Abramowitz and Stegun
    26.7.3 and 26.7.4)."""
    if df < 1 or int(df) != df:
        raise ValueError(f"t_cdf: df must be a positive integer (got {df})")
    df = int(df)
    theta = math.atan(abs(t) / math.sqrt(df))
    s, c = math.sin(theta), math.cos(theta)
    if df % 2:  # odd: 2/pi (theta + sin cos (1 + 2/3 cos^2 + 2*4/(3*5) cos^4 ...))
        total, term = 0.0, c
        for k in range(1, (df - 1) // 2 + 1):
            total += term
            term *= c * c * (2 * k) / (2 * k + 1)
        inside = 2 / math.pi * (theta + s * total)
    else:  # even: sin (1 + 1/2 cos^2 + 1*3/(2*4) cos^4 ...)
        total, term = 0.0, 1.0
        for k in range(1, df // 2 + 1):
            total += term
            term *= c * c * (2 * k - 1) / (2 * k)
        inside = s * total
    inside = min(1.0, inside)
    return 0.5 + 0.5 * inside if t >= 0 else 0.5 - 0.5 * inside


def t_quantile(p, df):
    """The t with t_cdf(t, df) = p (0 < p < 1), by bisection to 1e-12."""
    if not 0 < p < 1:
        raise ValueError(f"t_quantile: p must be in (0, 1) (got {p})")
    if p < 0.5:
        return -t_quantile(1 - p, df)
    lo, hi = 0.0, 1.0
    while t_cdf(hi, df) < p:
        hi *= 2
    while hi - lo > 1e-12 * max(1.0, hi):
        mid = (lo + hi) / 2
        if t_cdf(mid, df) < p:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2


def mean_ci(values, level=0.95):
    """(mean, lo, hi): the mean of values and its two-sided Student-t
    interval at level; lo = hi = None for fewer than two values."""
    values = [float(v) for v in values]
    if not values:
        raise ValueError("mean_ci: no values")
    m = statistics.fmean(values)
    if len(values) < 2:
        return m, None, None
    t = t_quantile(0.5 + level / 2, len(values) - 1)
    half = t * statistics.stdev(values) / math.sqrt(len(values))
    return m, m - half, m + half


def paired(a, b):
    """Differences a[k] - b[k] over the keys (repetitions) both dicts hold,
    in key order."""
    return [a[k] - b[k] for k in sorted(set(a) & set(b))]


def fmt_ci(values, digits=3, level=0.95):
    """'+0.012 [-0.003, +0.027]' (mean and interval) or '+0.012' for one value."""
    m, lo, hi = mean_ci(values, level)
    if lo is None:
        return f"{m:+.{digits}f}"
    return f"{m:+.{digits}f} [{lo:+.{digits}f}, {hi:+.{digits}f}]"


if __name__ == "__main__":
    print(__doc__)
