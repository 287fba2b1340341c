"""Seeded problem generators for the hard REPS families (shared by the
differential tests; data only, no solver code)."""
import numpy as np

FAMILIES = ["collinear", "extreme", "offsets"]
# the solver's wide dense path (32 or more free features, n > d: its own
# rank-k Hessian kernel and the least-squares start); not one of the three
# hard families, so it has its own, smaller test
WIDE = "wide_dense"
# returns and KL bounds beyond a double's digits side by side (one return
# 1e6 ... 1e14 of the others' spread away, near ties 1e-14 ... 1e-10 of it
# apart, returns scaled by up to 1e+-280, KL bounds down to 1e-12): their
# reference is the 60-digit ref_reps_mp.py, which the family test uses
DYNAMIC = "dynamic"
# at least as many dense features as samples, of low rank, some with a near
# duplicate column: the solver's span path (d >= n)
WIDE_SPAN = "wide_span"
# each family's stream index (the seeds of both later families, added side
# by side, start from the index after WIDE)
_STREAM = {k: i for i, k in enumerate(FAMILIES + [WIDE])}
_STREAM[DYNAMIC] = _STREAM[WIDE_SPAN] = len(_STREAM)


def make_family(kind, seed):
    """(R, q, phi, eps) of problem `seed` of family `kind`."""
    rng = np.random.default_rng([23, _STREAM[kind], seed])
    if kind == WIDE:
        return wide_dense(rng)
    if kind == DYNAMIC:
        return dynamic(rng, seed % 4)
    if kind == WIDE_SPAN:
        return wide_span(rng)
    if kind == "collinear":
        n = int(rng.integers(20, 201))
        d = int(rng.integers(2, 7))
        S = rng.uniform(size=(n, 2))
        phi = rng.normal(size=(n, d)) * 10 ** rng.uniform(-3, 3, size=d)
        k = int(rng.integers(d))
        delta = 10 ** rng.uniform(-10, -6)
        spread = phi[:, k].max() - phi[:, k].min()
        near = phi[:, k] * rng.choice([1.0, -2.5]) + delta * spread * rng.normal(size=n)
        phi = np.c_[phi, near]
        R = np.sin(3 * S[:, 0]) - S[:, 1] + phi[:, 0] / (1 + np.abs(phi[:, 0]).max()) \
            + rng.normal(size=n) * 0.3
    elif kind == "extreme":
        n = int(rng.integers(1000, 5001))
        d = int(rng.integers(0, 5))
        S = rng.uniform(size=(n, 2))
        phi = np.c_[S, S[:, :1] ** 2, S[:, 0] * S[:, 1]][:, :d]
        if rng.random() < 0.5:
            R = rng.normal(size=n)
            R[int(rng.integers(n))] = rng.choice([-1.0, 1.0]) * 10 ** rng.uniform(2, 3)
        else:
            R = rng.standard_cauchy(size=n)
    else:
        n = int(rng.integers(6, 41))
        d = n - 1 + int(rng.integers(0, 6))
        off = 10 ** rng.uniform(3, 8, size=d) * rng.choice([-1.0, 1.0], size=d)
        phi = off + rng.normal(size=(n, d)) * 10 ** rng.uniform(-2, 1, size=d)
        R = rng.normal(size=n)
    q = None
    if rng.random() < 0.4:
        q = np.exp(rng.normal(0.0, 0.5, size=n))
    eps = float(10 ** rng.uniform(-3, 0.5))
    return R, q, phi, eps


def wide_dense(rng):
    """d in 32..48 dense features of mixed scales and offsets, n from d + 5
    to 200, returns with a heavy tail in a third of the cases, a near
    duplicate column in a quarter."""
    d = int(rng.integers(32, 49))
    n = int(rng.integers(d + 5, 201))
    S = rng.uniform(size=(n, 2))
    phi = (rng.normal(size=(n, d)) * 10 ** rng.uniform(-2, 2, size=d)
           + rng.choice([0.0, 1.0], size=d) * 10 ** rng.uniform(0, 4, size=d))
    if rng.random() < 0.25:
        k = int(rng.integers(d))
        phi[:, (k + 1) % d] = phi[:, k] * 3.0 + 1e-7 * phi[:, k].std() * rng.normal(size=n)
    R = np.sin(3 * S[:, 0]) - S[:, 1] + (phi[:, :3] / np.abs(phi[:, :3]).max(0)) @ rng.normal(size=3)
    if rng.random() < 1 / 3:
        R = R + rng.standard_t(2, size=n)
    q = np.exp(rng.normal(0.0, 0.5, size=n)) if rng.random() < 0.5 else None
    eps = float(10 ** rng.uniform(-3, 0.5))
    return R, q, phi, eps


def dynamic(rng, variant):
    """n in 3..60, 0-2 dense features; variant 0: one return 1e6 ... 1e14
    of the spread below the others; 1: the largest return tied to 1e-14 ...
    1e-10 of the spread by another; 2: eps from 1e-12 to 1e-6; 3: the
    returns scaled by 1e+-280 with one 1e4 ... 1e10 of their spread below."""
    n = int(rng.integers(3, 61))
    d = int(rng.integers(0, 3)) if n > 8 else 0
    S = rng.uniform(size=(n, 2))
    phi = np.c_[S, S[:, 0] * S[:, 1]][:, :d]
    R = np.sin(3 * S[:, 0]) - S[:, 1] + rng.normal(size=n) * 0.5
    spread = R.max() - R.min()
    eps = float(10 ** rng.uniform(-2, 0.3))
    far = int(rng.integers(n))
    if variant == 0:
        R[far] = R.min() - 10 ** rng.uniform(6, 14) * spread
    elif variant == 1:
        top = int(np.argmax(R))
        R[(top + 1) % n] = R[top] - 10 ** rng.uniform(-14, -10) * spread
    elif variant == 2:
        eps = float(10 ** rng.uniform(-12, -6))
    else:
        R[far] = R.min() - 10 ** rng.uniform(4, 10) * spread
        R = R * 10 ** rng.uniform(-280, 280)
    q = np.exp(rng.normal(0.0, 0.5, size=n)) if rng.random() < 0.4 else None
    return R, q, phi, eps


def wide_span(rng):
    """n in 8..60 samples, d in n..2n dense features B C of rank k in 1..n+1
    (k >= n - 1: only p = q matches them), column scales over four decades,
    in half the cases one column three times another plus 1e-8 ... 1e-6 of
    its spread (one more direction, nearly dependent; closer ones are the
    collinear family's), returns that depend
    on B, with a heavy tail in a third of the cases."""
    n = int(rng.integers(8, 61))
    d = int(rng.integers(n, 2 * n + 1))
    k = int(rng.integers(1, n + 2))
    S = rng.uniform(size=(n, 2))
    B = rng.normal(size=(n, k))
    phi = B @ (rng.normal(size=(k, d)) * 10 ** rng.uniform(-2, 2, size=d))
    if rng.random() < 0.5:
        j = int(rng.integers(d))
        delta = 10 ** rng.uniform(-8, -6)
        spread = phi[:, j].max() - phi[:, j].min()
        phi[:, (j + 1) % d] = phi[:, j] * 3.0 + delta * spread * rng.normal(size=n)
    R = np.sin(3 * S[:, 0]) - S[:, 1] + B[:, :2] @ rng.normal(size=min(k, 2))
    if rng.random() < 1 / 3:
        R = R + rng.standard_t(2, size=n)
    q = np.exp(rng.normal(0.0, 0.5, size=n)) if rng.random() < 0.5 else None
    eps = float(10 ** rng.uniform(-3, 0.5))
    return R, q, phi, eps
