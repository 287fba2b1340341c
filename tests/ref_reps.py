"""Reference REPS written from the thesis's equations (ch. 3), for the
differential tests in test_ref_reps.py. numpy and scipy only; nothing here is
shared with the C library, and the methods differ where they can:

  primal  (eq. 3.1-3.5): maximise sum p R  subject to  KL(p||q) <= eps,
          sum p phi = phi_hat = sum q phi,  sum p = 1,  p >= 0;
  dual    (eq. 3.8):     g(eta, theta) = eta eps + theta.phi_hat
                                         + eta log sum q exp((R - theta.phi)/eta),
          minimised here by scipy's trust-ncg on (log eta, theta);
  weights (eq. 3.7):     p ∝ q exp((R - theta.phi)/eta).

The bound is unreachable exactly when eps >= KL(p0||q), where p0 is the
eta -> 0 limit of the dual's weights: the point of the optimal face of the
linear programme  max sum p R  s.t.  sum p phi = phi_hat, sum p = 1, p >= 0,
p = 0 where q = 0,  closest to q in KL. Here the face is found by one LP per
candidate sample (the largest p_i on the face) and p0 by minimising the
maximum-entropy dual on that support, again with trust-ncg.
"""
import math

import numpy as np
from scipy import optimize
from scipy.special import logsumexp

HIGHS = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}


def standardise(R, q):
    """(R - max R) / (max R - min R) over the samples with q > 0, computed in
    exact rational arithmetic and rounded once; None if the returns are equal.
    (REPS is invariant to R -> a R + b, a > 0.)"""
    on = [i for i in range(len(R)) if q[i] > 0]
    Rn, _ = dyadic(R)
    hi, lo = max(Rn[i] for i in on), min(Rn[i] for i in on)
    if hi == lo:
        return None
    # int / int is correctly rounded: one rounding of the exact quotient
    return np.array([(r - hi) / (hi - lo) for r in Rn])


def dyadic(xs):
    """Integers N and a shift e with x = N / 2**e exactly for every double x
    of xs: exact rational arithmetic on a common denominator."""
    ratios = [float(x).as_integer_ratio() for x in xs]
    e = max(d.bit_length() - 1 for _, d in ratios)
    return [n << (e - d.bit_length() + 1) for n, d in ratios], e


def prepare(R, q, phi):
    """Normalised q, standardised returns, and the features centred on phi_hat
    and scaled to unit q-weighted spread (the constraint sum p phi = phi_hat
    becomes sum p psi = 0), restricted to the samples with q > 0."""
    q = np.asarray(q, float)
    q = q / q.sum()
    on = q > 0
    Rs = standardise(R, q)
    phi = np.asarray(phi, float).reshape(len(q), -1)
    if phi.size and np.isin(phi, (0.0, 1.0)).all():
        psi = basis(phi - q @ phi)
    else:
        psi = basis_exact(phi, q)
    return q, on, Rs, psi


def basis_exact(phi, q, bits=256):
    """An orthonormal basis of the column space of phi - sum q phi, with the
    weighted mean taken in exact rational arithmetic (offsets of 1e8 times
    the spread leave a double mean off by 1e-7 of it) and modified
    Gram-Schmidt with column pivoting in fixed point at 2**-bits (Python
    integers, one rounding per product): two columns that differ by 1e-10
    of their spread span a direction that a double-precision factorisation
    holds to only 1e-6. Columns are scaled to unit largest magnitude; a
    direction is kept when its remaining norm exceeds 1e-12 of the largest
    column norm (exact dependence leaves about n 2**-bits)."""
    n, d = phi.shape
    if d == 0:
        return phi
    # object arrays of Python integers: exact, numpy only loops over them
    Q = np.array(dyadic(q)[0], dtype=object)
    tot = sum(Q)
    one = 1 << bits
    cols = []
    for j in range(d):
        X = np.array(dyadic(phi[:, j])[0], dtype=object)
        # x - mean is (X tot - sum Q X) over a common denominator, which the
        # scaling to unit largest magnitude cancels
        dev = X * tot - Q @ X
        mag = max(abs(x) for x in dev)
        if mag > 0:
            cols.append(rdiv(dev << bits, mag))
    if not cols:
        return phi[:, :0]
    C = np.array(cols, dtype=object).reshape(len(cols), n)
    norms = [math.isqrt(x) for x in (C * C).sum(axis=1)]
    tol = max(norms) // 10**12
    out = []
    while len(C):
        k = max(range(len(C)), key=lambda i: norms[i])
        if norms[k] <= tol:
            break
        u = rdiv(C[k] << bits, norms[k])
        C, norms = np.delete(C, k, axis=0), norms[:k] + norms[k + 1:]
        out.append(u)
        if len(C):
            dot = (C @ u) >> bits
            C = C - ((dot[:, None] * u[None, :]) >> bits)
            norms = [math.isqrt(x) for x in (C * C).sum(axis=1)]
    if not out:
        return phi[:, :0]
    return (np.array(out, dtype=object) / one).astype(float).T.reshape(n, len(out))


def rdiv(a, b):
    """a / b rounded to the nearest integer (b > 0)."""
    return (2 * a + b) // (2 * b)


def basis(psi):
    """An orthonormal basis of the column space of psi (the constraints
    sum p psi = 0 only depend on it): dependent features, such as the leaves
    of one tree, which always sum to 1, would make the dual's Hessian
    singular. Columns are scaled to unit largest magnitude first, so that
    the rank decision does not depend on the features' units; a direction
    is kept above 1e-12 of the largest singular value (exact dependence
    leaves round-off near 1e-16; nearly collinear columns that differ by
    1e-10 of their spread are genuine constraints)."""
    if psi.shape[1] == 0:
        return psi
    mag = np.abs(psi).max(axis=0)
    psi = psi[:, mag > 0] / mag[mag > 0]
    if psi.shape[1] == 0:
        return psi
    U, sv, _ = np.linalg.svd(psi, full_matrices=False)
    return U[:, sv > 1e-12 * sv.max()]


def dual_terms(y, th, R, lq, psi, eps):
    """g, gradient and Hessian in (y = log eta, theta), and p, KL."""
    eta = np.exp(y)
    A = R - psi @ th
    z = lq + A / eta
    lz = logsumexp(z)
    p = np.exp(z - lz)
    u = A / eta
    kl = p @ (z - lz - lq)
    g = eta * eps + eta * lz
    ep = p @ psi
    cov = (psi * p[:, None]).T @ psi - np.outer(ep, ep)
    cu = (psi * p[:, None]).T @ u - ep * (p @ u)
    vu = p @ u**2 - (p @ u)**2
    grad = np.concatenate(([eta * (eps - kl)], -ep))
    H = np.empty((len(th) + 1, len(th) + 1))
    H[0, 0] = eta * (eps - kl) + eta * vu
    H[0, 1:] = H[1:, 0] = cu
    H[1:, 1:] = cov / eta
    return g, grad, H, p, kl


def last_of(fn):
    """fn(x) remembered for the last x: the solvers ask for the value,
    gradient and Hessian at one point in three calls."""
    last = {}

    def at(x):
        key = np.asarray(x, float).tobytes()
        if key not in last:
            last.clear()
            last[key] = fn(x)
        return tuple(v.copy() if isinstance(v, np.ndarray) else v for v in last[key])
    return at


def dual_solve(R, lq, psi, eps):
    """Minimise the dual (eq. 3.8) over (log eta, theta) from (0, 0)."""
    d = psi.shape[1]

    terms = last_of(lambda x: dual_terms(x[0], x[1:], R, lq, psi, eps))

    def f(x):
        return terms(x)[0]

    def jac(x):
        return terms(x)[1]

    def hess(x):
        return terms(x)[2]

    x = optimize.minimize(f, np.zeros(d + 1), jac=jac, hess=hess, method="trust-ncg",
                          options={"gtol": 1e-13, "maxiter": 500}).x
    x = newton_polish(x, jac, hess)
    _, grad, _, p, kl = dual_terms(x[0], x[1:], R, lq, psi, eps)
    return np.exp(x[0]), p, kl, float(np.abs(grad).max())


def newton_polish(x, jac, hess):
    """Full Newton steps (least-squares solves) while they shrink the
    gradient: trust-ncg stops once its model's predicted decrease drowns in
    the round-off of g, with the gradient still near 1e-9."""
    g = jac(x)
    for _ in range(20):
        xn = x - np.linalg.lstsq(hess(x), g, rcond=None)[0]
        gn = jac(xn)
        if not np.abs(gn).max() < np.abs(g).max():
            break
        x, g = xn, gn
    return x


def lp_limit(R, q, psi):
    """The eta -> 0 limit p0 on the samples with q > 0 (psi, R, q restricted):
    LP value, the face support (one LP per sample with zero reduced cost:
    the largest p_i over the optimal face), and the maximum-entropy point of
    the face (trust-ncg on its dual). Returns p0, KL(p0||q)."""
    n, d = psi.shape
    Aeq = np.vstack([psi.T, np.ones(n)])
    beq = np.concatenate([np.zeros(d), [1.0]])
    lp = optimize.linprog(-R, A_eq=Aeq, b_eq=beq, bounds=(0, None), method="highs",
                          options=HIGHS)
    assert lp.status == 0, lp.message
    # reduced costs from the duals (HiGHS marginals of the equality rows)
    y = lp.eqlin.marginals
    rc = -R - Aeq.T @ y
    cand = set(np.where(rc <= 1e-9 * (1 + np.abs(R).max()))[0])
    # every optimal p vanishes where rc > 0: the face is the feasible set on cand
    bounds = [(0, None) if j in cand else (0, 0) for j in range(n)]
    support, seen = [], {j for j in cand if lp.x[j] > 1e-6}
    for i in sorted(cand):
        # a point of the face with p_i clearly above 1e-9 already shows that
        # the largest p_i exceeds it: no LP needed for i
        if i not in seen:
            c = np.zeros(n)
            c[i] = -1.0
            r = optimize.linprog(c, A_eq=Aeq, b_eq=beq, bounds=bounds, method="highs", options=HIGHS)
            if not (r.status == 0 and -r.fun > 1e-9):
                continue
            seen |= {j for j in cand if r.x[j] > 1e-6}
        support.append(i)
    S = np.array(support)
    qs, ps = q[S] / q[S].sum(), basis(psi[S])
    lqs = np.log(qs)
    d = ps.shape[1]

    @last_of
    def terms(lam):
        z = lqs - ps @ lam
        lz = logsumexp(z)
        p = np.exp(z - lz)
        ep = p @ ps
        return lz, -ep, (ps * p[:, None]).T @ ps - np.outer(ep, ep), p

    lam = np.zeros(d)
    if d:
        lam = optimize.minimize(lambda x: terms(x)[0], lam, jac=lambda x: terms(x)[1],
                                hess=lambda x: terms(x)[2], method="trust-ncg",
                                options={"gtol": 1e-14, "maxiter": 500}).x
        lam = newton_polish(lam, lambda x: terms(x)[1], lambda x: terms(x)[2])
    p0 = np.zeros(n)
    p0[S] = terms(lam)[3]
    nz = p0 > 0
    return p0, float(p0[nz] @ np.log(p0[nz] / q[nz]))


def primal_solve(R, q, psi, eps):
    """The primal (eq. 3.1-3.5) by SLSQP on the samples with q > 0."""
    n = len(R)

    def negobj(p):
        return -(p @ R)

    def klcon(p):
        pp = np.clip(p, 1e-300, None)
        return eps - np.sum(pp * np.log(pp / q))

    cons = [{"type": "eq", "fun": lambda p: np.concatenate([psi.T @ p, [p.sum() - 1.0]])},
            {"type": "ineq", "fun": klcon}]
    res = optimize.minimize(negobj, q.copy(), jac=lambda p: -R, method="SLSQP",
                            bounds=[(0.0, 1.0)] * n, constraints=cons,
                            options={"ftol": 1e-14, "maxiter": 1000})
    return res.x


def reps(R, q, phi, eps):
    """Reference answer: dict(status in active / unreachable, p (n), kl)."""
    q, on, Rs, psi = prepare(R, q, phi)
    n = len(q)
    out = {"p": np.zeros(n)}
    if Rs is None:
        out.update(status="unreachable", p=q.copy(), kl=0.0, kl0=0.0)
        return out
    Ro, qo, po = Rs[on], q[on], psi[on]
    p0, kl0 = lp_limit(Ro, qo, po)
    out["kl0"] = kl0
    if kl0 <= eps:
        out["p"][on] = p0
        out.update(status="unreachable", kl=kl0)
        return out
    eta, p, kl, gmax = dual_solve(Ro, np.log(qo), po, eps)
    out["p"][on] = p
    out.update(status="active", kl=kl, eta=eta, gmax=gmax, R=Ro, q=qo, psi=po)
    return out
