"""Differential tests: the linear weighted-ML fit with both covariance
centres (policy.cov_center = new | old) and contextual CMA-ES, against
numpy references written from the equations in docs/policies.md (no code
shared with the C). The C side runs through tests/ref_driver.c, built next to
the binary under test ($POOLREPS: build/<kind>/poolreps ->
build/<kind>/tests/ref_driver; `make check` builds it).

Tolerances (stated per test): relative to the largest entry of the
reference matrix, scaled by the condition number where a solve is involved.
"""
import os
from pathlib import Path

import numpy as np
import pytest
from conftest import run_cmd

ROOT = Path(__file__).resolve().parent.parent
AFFINE, QUADRATIC = 1, 2
NEW, OLD = 0, 1


def driver_path():
    binary = os.environ.get("POOLREPS") or str(ROOT / "poolreps")
    base = Path(binary).resolve().parent
    for cand in (base / "tests" / "ref_driver", ROOT / "build" / "rel" / "tests" / "ref_driver"):
        if os.access(cand, os.X_OK):
            return cand
    pytest.skip("no ref_driver next to the binary (make check builds it)")


def run_driver(text):
    r = run_cmd([str(driver_path())], input=text.encode(), capture_output=True,
                       timeout=60)
    assert r.returncode == 0, r.stderr.decode()
    return [np.array([float(x) for x in line.split()]) for line in r.stdout.decode().splitlines()]


def fmt(v):
    return " ".join(repr(float(x)) for x in np.ravel(v))


# ---- references ----

def features(kind, S):
    """psi(s): [1, s] or [1, s, s_j s_k (j <= k)], one row per state."""
    n, ds = S.shape
    cols = [np.ones(n)] + [S[:, j] for j in range(ds)]
    if kind == QUADRATIC:
        cols += [S[:, j] * S[:, k] for j in range(ds) for k in range(j, ds)]
    return np.column_stack(cols)


def ref_wls(kind, S, A, w, lam):
    """The mean of the weighted ML fit (eq. 3.10) as docs/policies.md
    defines it: w normalised to sum 1, features psi(s - c) of the states
    about their weighted mean c; minimise sum_i w_i |a_i - W psi_i|^2 +
    lam sum_j v_j |W_j|^2 over the columns j of the non-constant features,
    v_j their weighted variances (lam on standardised slopes, intercept
    free): the SVD of the centred, standardised, sqrt(w)-weighted design,
    singular values below 1e-12 of the largest dropped (minimum norm in
    standardised units), filter s / (s^2 + lam). Returns W for psi(s)
    itself (the library's pr_policy_linear_params), found as the W' with
    W' psi(x) = W psi(x - c) at generic points x, and the condition number
    of the standardised normal matrix."""
    wn = w / w.sum()
    c = wn @ S
    P = features(kind, S - c)[:, 1:]
    mu = wn @ P
    sd = np.sqrt(wn @ (P - mu) ** 2)
    live = sd > 0
    Z = np.zeros_like(P)
    Z[:, live] = np.sqrt(wn)[:, None] * (P[:, live] - mu[live]) / sd[live]
    abar = wn @ A
    Y = np.sqrt(wn)[:, None] * (A - abar)
    U, sv, Vt = np.linalg.svd(Z, full_matrices=False)
    keep = sv > 1e-12 * sv.max() if sv.size and sv.max() > 0 else np.zeros(sv.shape, bool)
    f = np.where(keep, sv / np.where(keep, sv ** 2 + lam, 1.0), 0.0)
    Bs = Vt.T @ (f[:, None] * (U.T @ Y))
    B = np.zeros_like(Bs)
    B[live] = Bs[live] / sd[live, None]
    W = np.column_stack([abar - mu @ B, B.T])            # for psi(s - c)
    X = c + np.random.default_rng(0).uniform(-1, 1, (3 * W.shape[1], S.shape[1]))
    Wu = np.linalg.lstsq(features(kind, X), features(kind, X - c) @ W.T, rcond=None)[0].T
    cond = (sv[keep].max() ** 2 + lam) / (sv[keep].min() ** 2 + lam) if keep.any() else 1.0
    return Wu, cond


def ref_fit(kind, S, A, w, M, lam, min_std, center):
    """Weighted ML (eq. 3.10): W by ref_wls, Sigma = sum_i w_i r_i r_i^T
    (w normalised) with r_i = a_i - W psi_i (new) or a_i - m_i (old);
    eigenvalues of Sigma floored at min_std^2."""
    Psi = features(kind, S)
    wn = w / w.sum()
    W, cond = ref_wls(kind, S, A, w, lam)
    Wt = W.T
    R = A - (Psi @ Wt if center == NEW else M)
    Sig = (wn[:, None] * R).T @ R
    ev, V = np.linalg.eigh(0.5 * (Sig + Sig.T))
    ev = np.maximum(ev, min_std ** 2 if min_std > 0 else 1e-300)
    return W, (V * ev) @ V.T, cond


def c_fit(kind, S, A, w, M, lam, min_std, center):
    n, ds = S.shape
    da = A.shape[1]
    rows = [f"{fmt(S[i])} {fmt(A[i])} {w[i]!r} {fmt(M[i])}" for i in range(n)]
    out = run_driver(f"fit {kind} {center} {lam!r} {min_std!r} {n} {ds} {da}\n" + "\n".join(rows))
    nf = features(kind, S[:1]).shape[1]
    return out[0].reshape(da, nf), out[1].reshape(da, da)


def problem(rng, n, ds, da, kind="plain"):
    """Samples of an old linear policy; REPS-like weights exp(R / T)."""
    S = rng.uniform(-1, 1, (n, ds))
    Wold = rng.normal(0, 1, (da, 1 + ds))
    M = features(AFFINE, S) @ Wold.T
    A = M + rng.normal(0, 0.5, (n, da))
    R = -np.sum((A - S[:, :1]) ** 2, axis=1)
    w = np.exp((R - R.max()) / rng.uniform(0.2, 5.0))
    if kind == "zeros":        # some weights exactly 0
        w[rng.random(n) < 0.4] = 0.0
        w[0] = 1.0
    elif kind == "duplicate":  # rank-deficient design: two distinct states only
        S[:] = S[rng.integers(0, 2, n) * 0 + np.arange(n) % 2]
        M = features(AFFINE, S) @ Wold.T
    elif kind == "few":        # fewer weighted samples than coefficients
        w[:] = 0.0
        w[: max(1, ds)] = 1.0
    elif kind == "one":        # one effective sample: Sigma_new = 0 (floor)
        w[:] = 0.0
        w[3] = 2.5
    return S, A, w, M


def check_fit(S, A, w, M, lam, min_std, center, kind=AFFINE, tol=1e-10):
    Wr, Cr, cond = ref_fit(kind, S, A, w, M, lam, min_std, center)
    Wc, Cc = c_fit(kind, S, A, w, M, lam, min_std, center)
    # W: a solve, so relative error up to cond * eps-size. Sigma: sums of
    # products relative to its size; for `new` the residuals also carry W's
    # round-off, delta r ~ 1e-13 k |A|, which matters when the fit is nearly
    # exact (Sigma ~ r^2 tiny): |delta Sigma| <= 2 |r| delta r
    k = max(1.0, cond * 1e-6)
    wtol = tol * k * max(1.0, np.abs(Wr).max())
    assert np.abs(Wc - Wr).max() <= wtol, (np.abs(Wc - Wr).max(), wtol)
    cmax = np.abs(Cr).max()
    ctol = tol * k * cmax
    if center == NEW:
        ctol += 2e-13 * k * np.sqrt(cmax) * np.abs(A).max()
    assert np.abs(Cc - Cr).max() <= ctol, (np.abs(Cc - Cr).max(), ctol)
    return Wc, Cc


@pytest.mark.parametrize("center", [NEW, OLD])
def test_fit_random_problems(center):
    """60 seeded problems (n 4..80, ds 1..3, da 1..4, both feature kinds);
    tolerance 1e-10 relative (times cond/1e6 where the normal matrix is
    worse conditioned than 1e6)."""
    for seed in range(60):
        rng = np.random.default_rng(seed)
        n, ds, da = int(rng.integers(4, 81)), int(rng.integers(1, 4)), int(rng.integers(1, 5))
        kind = AFFINE if seed % 3 else QUADRATIC
        if kind == QUADRATIC:
            n = max(n, 12)
        S, A, w, M = problem(rng, n, ds, da)
        check_fit(S, A, w, M, 1e-10 if seed % 2 else 0.0, 1e-9, center, kind)


@pytest.mark.parametrize("center", [NEW, OLD])
@pytest.mark.parametrize("kind", ["zeros", "duplicate", "few", "one"])
def test_fit_degenerate(center, kind):
    """Zero weights, a rank-deficient design (pseudo-inverse), fewer weighted
    samples than coefficients, a single effective sample (Sigma_new = 0,
    floored at min_std^2); 10 seeds each, tolerance 1e-9 relative."""
    for seed in range(10):
        rng = np.random.default_rng(100 + seed)
        S, A, w, M = problem(rng, int(rng.integers(6, 40)), 2, 2, kind)
        check_fit(S, A, w, M, 0.0 if seed % 2 else 1e-8, 1e-6, center, tol=1e-9)


@pytest.mark.parametrize("center", [NEW, OLD])
def test_fit_extreme_scales(center):
    """Actions scaled by 1e-6 and 1e6 and offset by 1e6 (sampling means with
    them); weights scaled by 1e-200 and 1e200 (normalised away). Tolerance
    1e-9 relative to the reference covariance."""
    for seed in range(8):
        rng = np.random.default_rng(200 + seed)
        S, A, w, M = problem(rng, 40, 2, 3)
        for a_scale, a_off, w_scale in ((1e-6, 0.0, 1e-200), (1e6, 0.0, 1e200), (1.0, 1e6, 1.0)):
            check_fit(S, a_scale * A + a_off, w_scale * w, a_scale * M + a_off, 0.0,
                      1e-12 * a_scale, center, tol=1e-9)


def test_fit_invariances_and_shift():
    """Permuting the samples changes nothing (1e-12 relative); scaling the
    actions scales Sigma by the square (1e-12 relative); and Sigma_old -
    Sigma_new = sum_i w_i delta_i delta_i^T, delta_i = (W - W_old) psi_i,
    computed in numpy from the C outputs (1e-10 relative)."""
    for seed in range(10):
        rng = np.random.default_rng(300 + seed)
        S, A, w, M = problem(rng, 50, 2, 2)
        Wn, Cn = c_fit(AFFINE, S, A, w, M, 0.0, 1e-12, NEW)
        Wo, Co = c_fit(AFFINE, S, A, w, M, 0.0, 1e-12, OLD)
        assert np.array_equal(Wn, Wo)
        # the old means come from W_old psi: recover W_old by least squares
        Psi = features(AFFINE, S)
        Wold = np.linalg.lstsq(Psi, M, rcond=None)[0].T
        delta = Psi @ (Wn - Wold).T
        wn = w / w.sum()
        D = (wn[:, None] * delta).T @ delta
        assert np.abs(Co - Cn - D).max() <= 1e-10 * np.abs(Co).max()
        p = rng.permutation(len(w))
        for center, C0 in ((NEW, Cn), (OLD, Co)):
            _, Cp = c_fit(AFFINE, S[p], A[p], w[p], M[p], 0.0, 1e-12, center)
            assert np.abs(Cp - C0).max() <= 1e-12 * np.abs(C0).max()
            _, Cs = c_fit(AFFINE, S, 3.0 * A, w, 3.0 * M, 0.0, 1e-12, center)
            assert np.abs(Cs - 9.0 * C0).max() <= 1e-12 * 9.0 * np.abs(C0).max()


def test_fit_old_without_means_refused(tmp_path):
    """cov_center = old with a non-finite sampling mean is refused."""
    r = run_cmd([str(driver_path())], input=b"fit 1 1 0 0 2 1 1\n0 1 1 nan\n1 2 1 0.5\n",
                       capture_output=True, timeout=60)
    assert r.returncode == 3 and b"sampling mean" in r.stderr


# ---- contextual CMA-ES ----

class RefCCMAES:
    """Contextual CMA-ES from the equations of docs/policies.md."""

    def __init__(self, W0, sigma0, lam, ds):
        self.W = np.array(W0, dtype=float)
        self.da = self.W.shape[0]
        self.ds = ds
        self.C = np.eye(self.da)
        self.sigma = sigma0
        self.lam = lam
        self.pc = np.zeros(self.da)
        self.ps = np.zeros(self.da)
        self.g = 0

    def update(self, S, X, R, Bf):
        n, da = X.shape
        ntot = da + self.ds
        beta = np.linalg.lstsq(Bf, R, rcond=1e-12)[0]
        adv = R - Bf @ beta
        mu = n // 2
        ranks = np.empty(n, int)
        ranks[np.argsort(-adv, kind="stable")] = np.arange(1, n + 1)
        d = np.where(ranks <= mu, np.log(mu + 0.5) - np.log(ranks), 0.0)
        d /= d.sum()
        mueff = 1.0 / np.sum(d ** 2)
        cs = (mueff + 2) / (ntot + mueff + 5)
        ds_ = 1 + 2 * max(0.0, np.sqrt((mueff - 1) / (ntot + 1)) - 1) + cs + np.log(self.ds + 1)
        cc = (4 + mueff / ntot) / (ntot + 4 + 2 * mueff / ntot)
        c1 = 2 / ((ntot + 1.3) ** 2 + mueff)
        cmu = min(1 - c1, 2 * (mueff - 2 + 1 / mueff) / ((ntot + 2) ** 2 + mueff))
        chin = np.sqrt(da) * (1 - 1 / (4 * da) + 1 / (21 * da ** 2))
        Psi = features(AFFINE, S)
        Mold = Psi @ self.W.T
        Wn = ref_wls(AFFINE, S, X, d, self.lam)[0]
        y = (Wn - self.W) @ Psi.mean(axis=0) / self.sigma
        ev, V = np.linalg.eigh(self.C)
        Cinvsqrt = (V / np.sqrt(ev)) @ V.T
        self.ps = (1 - cs) * self.ps + np.sqrt(cs * (2 - cs) * mueff) * (Cinvsqrt @ y)
        psn = np.linalg.norm(self.ps)
        hsig = psn / np.sqrt(1 - (1 - cs) ** (2 * (self.g + 1))) < (1.4 + 2 / (da + 1)) * chin
        self.pc = (1 - cc) * self.pc + hsig * np.sqrt(cc * (2 - cc) * mueff) * y
        Y = (X - Mold) / self.sigma
        rank_mu = (d[:, None] * Y).T @ Y
        dh = (1 - hsig) * cc * (2 - cc)
        self.C = ((1 + c1 * dh - c1 - cmu) * self.C + c1 * np.outer(self.pc, self.pc)
                  + cmu * rank_mu)
        self.sigma *= np.exp(cs / ds_ * (psn / chin - 1))
        self.W = Wn
        self.g += 1


@pytest.mark.parametrize("seed", range(12))
def test_ccmaes_against_reference(seed):
    """12 seeded runs of 15 generations (ds 1..2, da 1..6, n 6..40, returns
    of a shifted sphere or Rosenbrock, contexts with offsets up to 5, return
    offsets up to 1e4): after every generation sigma, W and C agree with the
    reference within 1e-8 relative (errors compound over generations through
    sigma and C^-1/2). Batches are sampled from the reference's distribution."""
    rng = np.random.default_rng(1000 + seed)
    ds, da, n = int(rng.integers(1, 3)), int(rng.integers(1, 7)), int(rng.integers(6, 41))
    off = rng.uniform(-5, 5)
    G = rng.normal(0, 1, (da, ds))
    W0 = np.column_stack([rng.normal(0, 1, da), np.zeros((da, ds))])
    ref = RefCCMAES(W0, rng.uniform(0.3, 2.0), 1e-10, ds)
    lines = [f"cmaes {ds} {da} {features(QUADRATIC, np.zeros((1, ds))).shape[1]} "
             f"{ref.sigma!r} 1e-10 15 {n}", fmt(W0)]
    batches = []
    for _ in range(15):
        S = rng.uniform(1, 2, (n, ds)) + off
        mean = features(AFFINE, S) @ ref.W.T
        L = np.linalg.cholesky(ref.sigma ** 2 * ref.C)
        X = mean + rng.normal(0, 1, (n, da)) @ L.T
        Y = X + (S - off) @ G.T
        if seed % 2:
            R = -np.sum(Y ** 2, axis=1) + rng.uniform(-1e4, 1e4)
        else:
            R = -np.sum(100 * (Y[:, 1:] - Y[:, :-1] ** 2) ** 2 + (1 - Y[:, :-1]) ** 2, axis=1) \
                if da > 1 else -np.sum(Y ** 2, axis=1)
        Bf = features(QUADRATIC, S)
        batches.append((S, X, R, Bf))
        ref.update(S, X, R, Bf)
        lines += [f"{fmt(S[i])} {fmt(X[i])} {R[i]!r} {fmt(Bf[i])}" for i in range(n)]
    out = run_driver("\n".join(lines) + "\n")
    # replay the reference to compare generation by generation
    ref2 = RefCCMAES(W0, float(lines[0].split()[4]), 1e-10, ds)
    for g, (S, X, R, Bf) in enumerate(batches):
        ref2.update(S, X, R, Bf)
        sigma, W, C = out[3 * g][0], out[3 * g + 1].reshape(ref2.W.shape), out[3 * g + 2]
        C = C.reshape(da, da)
        assert abs(sigma - ref2.sigma) <= 1e-8 * ref2.sigma, (g, sigma, ref2.sigma)
        assert np.abs(W - ref2.W).max() <= 1e-8 * max(1.0, np.abs(ref2.W).max()), g
        assert np.abs(C - ref2.C).max() <= 1e-8 * np.abs(ref2.C).max(), g
