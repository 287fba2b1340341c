"""Seeded problem generators for the hard REPS families (shared by the
differential tests; data only, no solver code)."""
import numpy as np

FAMILIES = ["collinear", "extreme", "offsets"]


def make_family(kind, seed):
    """(R, q, phi, eps) of problem `seed` of family `kind`."""
    rng = np.random.default_rng([23, FAMILIES.index(kind), seed])
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
