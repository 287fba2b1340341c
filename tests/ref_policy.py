"""Reference tree-LWR policy (thesis ch. 6, eq. 6.4-6.9) in exact rational
arithmetic, for the differential tests in test_ref_policy.py. Python's
fractions only; nothing is shared with the C library.

Given the training states S, actions A, REPS weights w, every training
sample's active leaf per tree and the query's (as `poolreps forest --leaves`
prints them), at the query state s:

  eq. 6.4   w_i^ = (w_i / M) * #{trees where sample i and s share the leaf}
            (no weight at all: the global weights w_i instead);
  eq. 6.6   the weighted ridge regression of a on [1, s]. The ridge is read
            in centred, standardised coordinates, as the library documents
            it: the intercept is not penalised and lambda acts on the
            slopes measured in weighted standard deviations of the states,
            with the raw weights w^ of eq. 6.6, i.e. the slopes B solve
              (C_ss + (lambda / sum w^) diag(C_ss)) B = C_sa,
            C the w^-weighted covariances (per unit weight);
  eq. 6.7   mu = a_bar + B^T (s - s_bar); with fewer weighted samples than
            ds + 1 (too few for the ds + 1 coefficients) mu = a_bar;
  eq. 6.8   Sigma = sum w^ (a_i - mu)(a_i - mu)^T / Z  (query-centred), or
            about each sample's own fit a_bar + B^T (s_i - s_bar) (residual),
            or about m_i, the mean of the policy that drew sample i at s_i
            (old: Sigma = sum w^ (a_i - m_i)(a_i - m_i)^T / Z, whatever the fit);
  eq. 6.9   Z = ((sum w^)^2 - sum w^2) / sum w^.
Everything is exact; the results are rounded once to floats.
"""
from fractions import Fraction


def solve(M, b):
    """Exact Gauss-Jordan for a square system with several right-hand sides
    (b: rows x cols). Returns None if M is singular."""
    n = len(M)
    aug = [list(M[i]) + list(b[i]) for i in range(n)]
    for c in range(n):
        piv = next((r for r in range(c, n) if aug[r][c] != 0), None)
        if piv is None:
            return None
        aug[c], aug[piv] = aug[piv], aug[c]
        inv = 1 / aug[c][c]
        aug[c] = [x * inv for x in aug[c]]
        for r in range(n):
            if r != c and aug[r][c] != 0:
                f = aug[r][c]
                aug[r] = [x - f * y for x, y in zip(aug[r], aug[c])]
    return [row[n:] for row in aug]


def lwr(S, A, w, leaves, qleaves, s, lam, cov="query", Mold=None):
    """Mean (da floats) and covariance (da x da floats) at s. The mean is
    None when the standardised normal matrix is singular (a rank-deficient
    neighbourhood: compared elsewhere), and so is the covariance unless it
    is centred on the sampling means Mold (cov = "old", n x da); the
    covariance is None when Z = 0."""
    F = Fraction
    n, ds, da, M = len(S), len(S[0]), len(A[0]), len(qleaves)
    wh = [F(w[i]) / M * sum(1 for t in range(M) if leaves[i][t] == qleaves[t]) for i in range(n)]
    tot = sum(wh)
    if tot == 0:
        wh = [F(x) for x in w]
        tot = sum(wh)
    Sf = [[F(x) for x in row] for row in S]
    Af = [[F(x) for x in row] for row in A]
    sbar = [sum(wh[i] * Sf[i][j] for i in range(n)) / tot for j in range(ds)]
    abar = [sum(wh[i] * Af[i][j] for i in range(n)) / tot for j in range(da)]
    xs = [[Sf[i][j] - sbar[j] for j in range(ds)] for i in range(n)]
    xa = [[Af[i][j] - abar[j] for j in range(da)] for i in range(n)]
    Css = [[sum(wh[i] * xs[i][j] * xs[i][k] for i in range(n)) / tot for k in range(ds)]
           for j in range(ds)]
    Csa = [[sum(wh[i] * xs[i][j] * xa[i][k] for i in range(n)) / tot for k in range(da)]
           for j in range(ds)]
    lamf = F(lam) / tot
    N = [[Css[j][k] + (lamf * Css[j][j] if j == k else 0) for k in range(ds)] for j in range(ds)]
    if sum(1 for x in wh if x > 0) < ds + 1:
        # fewer weighted samples than coefficients: no slope, the weighted mean
        B = [[F(0)] * da for _ in range(ds)]
    else:
        B = solve(N, Csa)
    if B is None and cov != "old":
        return None, None
    sq = [F(x) for x in s]
    mu = None if B is None else \
        [abar[m] + sum(B[j][m] * (sq[j] - sbar[j]) for j in range(ds)) for m in range(da)]
    s2 = sum(x * x for x in wh)
    Z = (tot * tot - s2) / tot
    fmu = None if mu is None else [float(x) for x in mu]
    if Z == 0:
        return fmu, None
    C = [[F(0)] * da for _ in range(da)]
    for i in range(n):
        if wh[i] == 0:
            continue
        if cov == "query":
            r = [Af[i][m] - mu[m] for m in range(da)]
        elif cov == "residual":
            r = [xa[i][m] - sum(B[j][m] * xs[i][j] for j in range(ds)) for m in range(da)]
        else:
            r = [Af[i][m] - F(Mold[i][m]) for m in range(da)]
        for a in range(da):
            for b in range(da):
                C[a][b] += wh[i] * r[a] * r[b]
    return fmu, [[float(C[a][b] / Z) for b in range(da)] for a in range(da)]
