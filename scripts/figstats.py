#!/usr/bin/env python3
"""Small statistics shared by the plot scripts and the claims table, over
the one statistics module (scripts/verdict_stats.py).

    mean_ci([0.1, 0.3, 0.2])         -> (0.2, lo, hi): mean and 95 % t interval
    paired(a, b)                     -> [a[k] - b[k] for the keys both have]

Intervals are Student-t intervals of a mean over independent repetitions
(runs, forests): mean +- t(1 - alpha/2, n - 1) * s / sqrt(n), s the sample
standard deviation (verdict_stats.t_interval). With fewer than
two values there is no interval (None).
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import statistics

import verdict_stats as vs


def mean_ci(values, level=0.95):
    """(mean, lo, hi): the mean of values and its two-sided Student-t
    interval at level; lo = hi = None for fewer than two values."""
    values = [float(v) for v in values]
    if not values:
        raise ValueError("mean_ci: no values")
    if len(values) < 2:
        return statistics.fmean(values), None, None
    return vs.t_interval(values, level)


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
