"""An independent event-driven pool simulator under the sliding-then-rolling
friction law (table.friction_law = slide_roll), for tests/test_sim_slide.py:
tests/ref_sim_constant.py's (every event time a root of a polynomial in the
elapsed time from numpy's companion-matrix eigenvalues, every ball
re-predicted after every event) with the law's phases, written from the
equations of docs/model.md and sharing no code with src/.

A ball carries v and its rolling spin w (a velocity). Sliding (v != w) it
accelerates at -mu_s g c, c the unit slip (v - w), and w at +5/2 mu_s g c,
until v = w after |v - w| / (7/2 mu_s g); rolling, at -mu_r g v/|v| until
the stop speed. Collisions and cushions change v, never w."""
import numpy as np

from ref_sim_constant import Ball, Sim

G = 9.81


class SlideBall(Ball):
    def __init__(self, x, y, ms, mr):
        super().__init__(x, y)
        self.w = np.zeros(2)
        self.phase = None
        self.c = None  # the slip direction, constant over a slide
        self.ms, self.mr = ms, mr

    def acc(self, a):
        if self.state != "moving":
            return np.zeros(2)
        if self.phase == "slide":
            return -self.ms * G * self.c
        return -self.mr * G * self.v / np.linalg.norm(self.v)


class SlideSim(Sim):
    def __init__(self, ms=0.2, mr=0.01, **kw):
        super().__init__(**kw)
        self.ms, self.mr = ms, mr

    def new_ball(self, x, y):
        return SlideBall(x, y, self.ms, self.mr)

    def stop_time(self, b):
        """The end of b's phase."""
        if b.phase == "slide":
            return b.slip / (3.5 * self.ms * G)
        return max(0.0, (np.linalg.norm(b.v) - self.v_stop) / (self.mr * G))

    def advance(self, s):
        for b in self.balls:
            if b.state == "moving":
                acc = b.acc(0)
                b.p = self.position(b, s)
                b.v = b.v + acc * s
                b.w = b.w - 2.5 * acc * s if b.phase == "slide" else b.v.copy()
                if b.phase == "slide":
                    b.slip -= 3.5 * self.ms * G * s

    def settle(self, b):
        if b.phase == "slide":
            b.w = b.v.copy()
            b.phase = "roll"
            self.changed(b)
        else:
            b.v, b.w = np.zeros(2), np.zeros(2)
            b.state = "rest"

    def changed(self, b):
        if (b.v != b.w).any():
            b.phase, b.state = "slide", "moving"
            b.slip = np.linalg.norm(b.v - b.w)
            b.c = (b.v - b.w) / b.slip
        elif b.v.any():
            b.phase, b.state = "roll", "moving"
        else:
            b.state = "rest"
