"""A 60-digit REPS reference (mpmath) for problems whose answer depends on
digits a double cannot hold next to each other: one return 1e12 times the
others' spread, near ties 1e-12 apart, returns from 1e-282 to 3e203, and
KL bounds down to 1e-15. Written from the dual (eq. 3.8) alone, sharing
nothing with the C library or with ref_reps.py:

  every double of R, q and phi is converted exactly; the features are
  centred on sum q phi (exact at 60 digits), so the dual is
      h(eta) = min_theta  eta eps + eta log sum q exp((R - theta.psi) / eta);
  theta(eta) by Newton's method on that convex function (Hessian
  Cov_p(psi) / eta); KL(p_eta || q) falls as eta grows, so the root of
  KL = eps is bracketed in log eta and found by bisection refined by
  the secant rule (Illinois), all at 60 digits, where exp never underflows.

Without a root down to eta = 1e-40 of the returns' smallest gap the bound is
taken as unreachable (the answer then is p at that eta, the eta -> 0 limit
to within exp(-1e40)). Needs n d^2 multiplications per Newton step: meant
for a few hundred rows and a few features."""
import mpmath as mp

mp.mp.dps = 60


def _prep(R, q, phi):
    n = len(R)
    Rm = [mp.mpf(float(r)) for r in R]
    qm = [mp.mpf(1) if q is None else mp.mpf(float(x)) for x in (q if q is not None else R)]
    tot = mp.fsum(qm)
    qm = [x / tot for x in qm]
    d = 0 if phi is None or len(phi) == 0 else len(phi[0])
    psi = [[mp.mpf(float(phi[i][j])) for j in range(d)] for i in range(n)]
    for j in range(d):
        mean = mp.fsum(qm[i] * psi[i][j] for i in range(n))
        for i in range(n):
            psi[i][j] -= mean
    # features with no spread (on q > 0) constrain nothing
    keep = [j for j in range(d) if max(abs(psi[i][j]) for i in range(n) if qm[i] > 0) > 0]
    psi = [[row[j] for j in keep] for row in psi]
    on = [i for i in range(n) if qm[i] > 0]
    return Rm, qm, psi, on


def _weights(R, q, psi, on, eta, th):
    z = {}
    for i in on:
        a = R[i] - mp.fsum(th[j] * psi[i][j] for j in range(len(th)))
        z[i] = mp.log(q[i]) + a / eta
    zmax = max(z.values())
    w = {i: mp.exp(z[i] - zmax) if z[i] - zmax > -300 else mp.mpf(0) for i in on}
    s = mp.fsum(w.values())
    p = {i: w[i] / s for i in on}
    kl = mp.fsum(p[i] * (z[i] - zmax - mp.log(s) - mp.log(q[i])) for i in on)
    return p, kl


def _theta(R, q, psi, on, eta, th):
    """Newton on theta at fixed eta (damped by halving while g rises)."""
    d = len(th)
    if d == 0:
        return th

    def g(t):
        vals = [mp.log(q[i]) + (R[i] - mp.fsum(t[j] * psi[i][j] for j in range(d))) / eta
                for i in on]
        zmax = max(vals)
        # terms below exp(-300) of the largest are beyond 60 digits
        return eta * (zmax + mp.log(mp.fsum(mp.exp(v - zmax) for v in vals if v - zmax > -300)))

    gt = g(th)
    for _ in range(200):
        p, _ = _weights(R, q, psi, on, eta, th)
        ep = [mp.fsum(p[i] * psi[i][j] for i in on) for j in range(d)]
        H = mp.matrix(d, d)
        for a in range(d):
            for b in range(a, d):
                H[a, b] = H[b, a] = mp.fsum(p[i] * (psi[i][a] - ep[a]) * (psi[i][b] - ep[b])
                                            for i in on) / eta
        grad = mp.matrix([-x for x in ep])
        scale = max(abs(psi[i][j]) for i in on for j in range(d))
        if max(abs(x) for x in ep) <= mp.mpf(10) ** -55 * scale:
            break
        tr = sum(H[a, a] for a in range(d))
        for a in range(d):
            H[a, a] += mp.mpf(10) ** -50 * tr
        step = mp.lu_solve(H, grad)
        t = 1
        while t > mp.mpf(2) ** -60:
            tn = [th[j] - t * step[j] for j in range(d)]
            gn = g(tn)
            if gn <= gt:
                th, gt = tn, gn
                break
            t /= 2
        else:
            break
    return th


def reps(R, q, phi, eps):
    """dict(status active / unreachable, p (list of floats), eta (return
    units), kl) at 60 digits."""
    Rm, qm, psi, on = _prep(R, q, phi)
    n, d = len(Rm), len(psi[0]) if psi else 0
    eps = mp.mpf(float(eps))
    vals = sorted(set(Rm[i] for i in on))
    if len(vals) == 1:
        return {"status": "unreachable", "p": [float(x) for x in qm], "eta": 0.0, "kl": 0.0}
    spread = vals[-1] - vals[0]
    gap = min(b - a for a, b in zip(vals, vals[1:]))
    th = [mp.mpf(0)] * d

    def f(y):
        nonlocal th
        th = _theta(Rm, qm, psi, on, mp.exp(y), th)
        p, kl = _weights(Rm, qm, psi, on, mp.exp(y), th)
        return mp.log(kl) - mp.log(eps) if kl > 0 else -mp.inf, p, kl

    hi = mp.log(spread) + 10
    while f(hi)[0] > 0:
        hi += 10
    floor = mp.log(gap) - mp.log(mp.mpf(10) ** 40)
    fhi = f(hi)[0]
    # walk down in log eta (theta carried along) until KL exceeds eps
    lo = hi
    while True:
        lo -= 4
        if lo < floor:
            lo = floor
        flo, p, kl = f(lo)
        if flo > 0:
            break
        if lo == floor:
            return {"status": "unreachable", "p": _full(p, n), "eta": 0.0, "kl": float(kl)}
        hi, fhi = lo, flo
    # Illinois: theta carries over from the last eta
    side = 0
    for _ in range(400):
        y = hi - fhi * (hi - lo) / (fhi - flo)
        if not (lo < y < hi):
            y = (lo + hi) / 2
        fy, p, kl = f(y)
        if abs(kl - eps) <= mp.mpf(10) ** -45 * eps or hi - lo < mp.mpf(10) ** -50:
            break
        if fy > 0:
            lo, flo = y, fy
            if side == -1:
                fhi /= 2
            side = -1
        else:
            hi, fhi = y, fy
            if side == 1:
                flo /= 2
            side = 1
    return {"status": "active", "p": _full(p, n), "eta": float(mp.exp(y)), "kl": float(kl)}


def _full(p, n):
    return [float(p.get(i, 0)) for i in range(n)]
