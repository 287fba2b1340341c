"""Property: the policies do not depend on the scale of the weights.

Every weight multiplied by c in 1e-300 ... 1e300:
  - tree-LWR (`poolreps policy`), lambda = 0 (eq. 6.6's ridge acts on the
    raw weights, so only without it does the scale cancel by definition):
    mean and covariance within 1e-12 relative of the unscaled fit, the
    same status flags;
  - the linear weighted-ML fit (tests/ref_driver), lambda = 0 and
    lambda = 1e-3 (its weights are normalised to sum 1, so lambda is
    relative to them and the scale cancels): W and the covariance within
    1e-12 relative.
Before the weights were brought into range, 1e-170 and 1e160 moved the
means by up to 0.33 and raised COVFALL / PINV: sums of w^2 underflowed or
overflowed."""
import numpy as np
import pytest

from test_ref_cov import fmt, run_driver
from test_ref_policy import policy_out

SCALES = [1e-300, 1e-250, 1e-200, 1e-170, 1e-100, 1e-30, 3.7, 1e30, 1e100, 1e160, 1e200, 1e250,
          1e300]


def case(seed):
    rng = np.random.default_rng(77000 + seed)
    n = int(rng.integers(40, 151))
    S = rng.uniform(-1, 1, size=(n, 2))
    A = np.c_[np.sin(2 * S[:, 0]) + 0.5 * S[:, 1], S[:, 0] * S[:, 1] - S[:, 1]]
    A += rng.normal(size=(n, 2)) * 0.1
    # REPS-like weights: a few dominate, some vanish
    w = np.exp(rng.normal(size=n) * rng.choice([0.5, 3.0]))
    w[rng.random(n) < 0.15] = 0.0
    w /= w.max()
    Q = np.vstack([S[:2], rng.uniform(-1, 1, size=(3, 2))])
    opts = {"trees": int(rng.integers(1, 8)), "cuts": int(rng.integers(1, 10)),
            "n_min": int(rng.integers(10, 40)), "n_c": 1, "score": "rvr",
            "replacement": "with", "outputs": "sum"}
    return S, A, w, Q, opts, str(rng.choice(["query", "residual"]))


def rel(a, b):
    return np.abs(a - b).max() / max(np.abs(b).max(), 1e-300)


@pytest.mark.parametrize("seed", range(6))
def test_tree_policy_weight_scale(tmp_path, seed):
    S, A, w, Q, opts, cov = case(seed)
    base, _ = policy_out(tmp_path, S, A, w, None, Q, opts, 0.0, cov, seed, "b")
    for c in SCALES:
        out, _ = policy_out(tmp_path, S, A, w * c, None, Q, opts, 0.0, cov, seed, "t")
        assert (out[:, -1] == base[:, -1]).all(), (c, out[:, -1], base[:, -1])
        assert rel(out[:, 2:4], base[:, 2:4]) <= 1e-12, c
        assert rel(out[:, 4:7], base[:, 4:7]) <= 1e-12, c


def linear_fit(S, A, w, lam):
    n = len(S)
    rows = [fmt(np.r_[S[i], A[i], w[i], A[i]]) for i in range(n)]
    # PR_FEATURES_AFFINE = 1, PR_COV_CENTER_NEW = 0
    out = run_driver(f"fit 1 0 {lam!r} 1e-100 {n} 2 2\n" + "\n".join(rows) + "\n")
    return out[0], out[1]


@pytest.mark.parametrize("lam", [0.0, 1e-3])
@pytest.mark.parametrize("seed", range(4))
def test_linear_fit_weight_scale(seed, lam):
    S, A, w, _, _, _ = case(seed)
    W0, C0 = linear_fit(S, A, w, lam)
    for c in SCALES:
        W, C = linear_fit(S, A, w * c, lam)
        assert rel(W, W0) <= 1e-12 and rel(C, C0) <= 1e-12, c
