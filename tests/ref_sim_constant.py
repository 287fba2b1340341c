"""An independent event-driven pool simulator under the constant-deceleration
friction law, written from the equations for the differential test of
tests/test_sim_constant.py. It shares no code or method with src/: every
event time is found as a root of a polynomial in the elapsed time s, all of
them by numpy's companion-matrix eigenvalues (np.roots) polished by Newton
steps, and every ball is re-predicted after every event.

Physics (docs/model.md): a moving ball of speed v slows at a constant rate a
along its direction e, p(s) = p + e (v s - a s^2 / 2), and stops when its
speed falls to the stop speed, after s = (v - v_stop) / a. Cushions are the
lines |x| = L/2 - R, |y| = W/2 - R (normal component times -kappa); pockets
capture a centre that enters their radius; two balls touching at 2R
exchange the velocity components along the line of centres."""
import math

import numpy as np

MIN_CLOSING = 1e-9
POCKET, STOP, CUSHION, BALL = 0, 1, 2, 3


def pockets(L, W):
    return [((k % 3 - 1) * L / 2, (-1 if k < 3 else 1) * W / 2) for k in range(6)]


class Ball:
    def __init__(self, x, y):
        self.p = np.array([x, y], dtype=float)
        self.v = np.zeros(2)
        self.state = "rest"  # rest, moving, pocketed
        self.pocket = -1

    def acc(self, a):
        if self.state != "moving":
            return np.zeros(2)
        return -a * self.v / np.linalg.norm(self.v)


def poly_roots_in(coef, lo, hi):
    """Real roots of the polynomial coef (highest power first) in [lo, hi],
    each polished by Newton steps, sorted."""
    return poly_roots_many([coef], lo, hi)[0]


def poly_roots_many(coefs, lo, hi):
    """poly_roots_in for each polynomial of coefs: np.roots's companion
    matrices (leading coefficients below 1e-300 dropped, trailing zeros
    roots at 0), those of one size to np.linalg.eigvals in one call."""
    polys, by_size = [], {}
    for k, coef in enumerate(coefs):
        cf = [float(c) for c in coef]
        if max(abs(c) for c in cf) == 0:
            polys.append(None)
            continue
        cf = cf[next(i for i, c in enumerate(cf) if abs(c) > 1e-300):]
        if len(cf) < 2:
            polys.append(None)
            continue
        m = len(cf)
        while cf[m - 1] == 0:
            m -= 1
        polys.append((cf, len(cf) - m))
        if m > 1:
            A = np.diag(np.ones(m - 2), -1)
            A[0, :] = -np.array(cf[1:m]) / cf[0]
            by_size.setdefault(m, []).append((k, A))
    eig = {}
    for group in by_size.values():
        for (k, _), w in zip(group, np.linalg.eigvals(np.array([A for _, A in group]))):
            eig[k] = list(w)
    return [[] if pc is None else polish(pc[0], eig.get(k, []) + [0.0] * pc[1], lo, hi)
            for k, pc in enumerate(polys)]


def polish(cf, roots, lo, hi):
    """The real ones of roots (of the polynomial cf) polished by Newton steps
    in Python floats (the same Horner sums as np.polyval), those in [lo, hi]
    sorted."""
    n = len(cf) - 1
    df = [c * (n - i) for i, c in enumerate(cf[:-1])]
    out = []
    for r in roots:
        r = complex(r)
        if abs(r.imag) > 1e-6 * (1 + abs(r.real)):
            continue
        x = float(r.real)
        for _ in range(50):
            fd = horner(df, x)
            if fd == 0:
                break
            step = horner(cf, x) / fd
            x -= step
            if abs(step) <= 1e-17 * (1 + abs(x)):
                break
        if lo - 1e-15 <= x <= hi:
            out.append(max(x, lo))
    return sorted(out)


def horner(coef, x):
    y = 0.0
    for c in coef:
        y = y * x + c
    return y


class Sim:
    def __init__(self, L=1.0, W=0.5, R=0.015, rp=0.03, kappa=0.8, a=0.0625, v_stop=0.002,
                 max_time=120.0, nreward=1):
        self.L, self.W, self.R, self.rp = L, W, R, rp
        self.kappa, self.a, self.v_stop, self.max_time = kappa, a, v_stop, max_time
        self.hx, self.hy = L / 2 - R, W / 2 - R
        self.pk = pockets(L, W)
        self.nreward = nreward

    def stop_time(self, b):
        return max(0.0, (np.linalg.norm(b.v) - self.v_stop) / self.a)

    def position(self, b, s):
        return b.p + b.v * s + 0.5 * b.acc(self.a) * s * s

    def own_events(self, i, b):
        """(s, type, other) candidates of ball i: stop, cushions, pockets."""
        S = self.stop_time(b)
        ev = [(S, STOP, -1)]
        acc = b.acc(self.a)
        for axis, lim in ((0, self.hx), (1, self.hy)):
            for sign, cid in ((-1, 2 * axis), (1, 2 * axis + 1)):
                # p + v s + acc s^2 / 2 = sign * lim, crossed outwards
                roots = poly_roots_in([0.5 * acc[axis], b.v[axis], b.p[axis] - sign * lim], 0, S)
                out = [r for r in roots if (b.v[axis] + acc[axis] * r) * sign > 0]
                if out:
                    ev.append((out[0], CUSHION, cid))
        A, B = 0.5 * acc, b.v
        Cs = [b.p - np.array(pk) for pk in self.pk]
        # |C + v s + acc s^2/2|^2 = rp^2, entering (the six quartics solved together)
        roots = poly_roots_many([[A @ A, 2 * A @ B, B @ B + 2 * A @ C, 2 * B @ C, C @ C - self.rp ** 2]
                                 for C in Cs], 0, S)
        for j, C in enumerate(Cs):
            if C @ C <= self.rp ** 2:
                if C @ B < 0:
                    ev.append((0.0, POCKET, j))
                continue
            for r in roots[j]:
                dd = C + B * r + A * r * r
                if dd @ (B + 2 * A * r) < 0:
                    ev.append((r, POCKET, j))
                    break
        return ev

    def pair_event(self, bi, bj):
        if bi.state != "moving" and bj.state != "moving":
            return None
        S = min(self.stop_time(b) for b in (bi, bj) if b.state == "moving")
        D = bj.p - bi.p
        Wv = bj.v - bi.v
        H = 0.5 * (bj.acc(self.a) - bi.acc(self.a))
        r2 = (2 * self.R) ** 2
        coef = [H @ H, 2 * H @ Wv, Wv @ Wv + 2 * H @ D, 2 * Wv @ D, D @ D - r2]
        cands = []
        if D @ D <= r2 and D @ Wv < 0:
            cands.append(0.0)
        cands += poly_roots_in(coef, 0, S)
        def g(x):
            d = D + Wv * x + H * x * x
            return d @ d - r2

        for r in cands:
            d = D + Wv * r + H * r * r
            dv = Wv + 2 * H * r
            # a contact enters the overlap (a tangential touch, a double
            # root, does not) and closes at MIN_CLOSING or faster
            if g(r + 1e-7) < 0 and -(d @ dv) / math.sqrt(d @ d) >= MIN_CLOSING:
                return r
        return None

    def advance(self, s):
        for b in self.balls:
            if b.state == "moving":
                nv = b.v + b.acc(self.a) * s
                b.p = self.position(b, s)
                b.v = nv

    def new_ball(self, x, y):
        return Ball(x, y)

    def settle(self, b):
        """A ball's STOP event."""
        b.v = np.zeros(2)
        b.state = "rest"

    def changed(self, b):
        """After a bounce or a hit changed b.v."""
        b.state = "moving" if b.v.any() else "rest"

    def shoot(self, state, action):
        n = len(state) // 2
        self.balls = [self.new_ball(state[2 * i], state[2 * i + 1]) for i in range(n)]
        if math.hypot(*action) >= self.v_stop:
            self.balls[0].v = np.array(action, dtype=float)
            self.changed(self.balls[0])
        t = 0.0
        hit = False
        events = 0
        while True:
            best = None
            for i, b in enumerate(self.balls):
                if b.state != "moving":
                    continue
                for s, typ, other in self.own_events(i, b):
                    key = (s, typ, i)
                    if best is None or key < best[0]:
                        best = (key, other)
            for i in range(n):
                for j in range(i + 1, n):
                    bi, bj = self.balls[i], self.balls[j]
                    if bi.state == "pocketed" or bj.state == "pocketed":
                        continue
                    s = self.pair_event(bi, bj)
                    if s is not None and (best is None or (s, BALL, i) < best[0]):
                        best = ((s, BALL, i), j)
            if best is None:
                break
            (s, typ, i), other = best
            if t + s > self.max_time:
                self.advance(self.max_time - t)
                t = self.max_time
                break
            self.advance(s)
            t += s
            events += 1
            b = self.balls[i]
            if typ == STOP:
                self.settle(b)
            elif typ == POCKET:
                b.p = np.array(self.pk[other])
                b.v = np.zeros(2)
                b.state = "pocketed"
                b.pocket = other
            elif typ == CUSHION:
                axis = other // 2
                b.p[axis] = self.hx if other == 1 else -self.hx if other == 0 else \
                    self.hy if other == 3 else -self.hy
                b.v[axis] *= -self.kappa
                self.changed(b)
            else:
                bj = self.balls[other]
                nrm = (bj.p - b.p) / np.linalg.norm(bj.p - b.p)
                dv = (bj.v - b.v) @ nrm
                b.v = b.v + dv * nrm
                bj.v = bj.v - dv * nrm
                for q in (b, bj):
                    self.changed(q)
                if (i == 0 and 1 <= other <= self.nreward) or (other == 0 and 1 <= i <= self.nreward):
                    hit = True
        return {
            "final": [c for b in self.balls for c in b.p],
            "pocket": [b.pocket for b in self.balls],
            "hit": hit,
            "t_end": t,
            "events": events,
        }
