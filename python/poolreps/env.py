"""PocketEnv: the pool table as a one-shot-per-episode Gymnasium environment."""
import threading

import numpy as np

from . import _lib
from ._lib import Handle, addr, array, check, config, errbuf, lib
from .core import shoot_rows

try:
    import gymnasium
    from gymnasium import spaces
except ImportError:  # the environment works without it; spaces are then Bounds
    gymnasium = None


class Bounds:
    """A box of float64 values (what the spaces are without gymnasium)."""

    def __init__(self, low, high):
        self.low = np.asarray(low, dtype=np.float64)
        self.high = np.asarray(high, dtype=np.float64)
        self.shape = self.low.shape
        self.dtype = np.dtype(np.float64)

    def contains(self, x):
        x = np.asarray(x)
        return x.shape == self.shape and bool(np.all((x >= self.low) & (x <= self.high)))

    def sample(self, rng=None):
        rng = np.random.default_rng() if rng is None else rng
        return rng.uniform(self.low, self.high)

    def __repr__(self):
        return f"Bounds(low={self.low}, high={self.high})"


class PocketEnv(gymnasium.Env if gymnasium else object):
    """One shot per episode on the thesis's table (ch. 7).

    reset() draws a start state from start.* (Experiment 3's by default:
    the cue ball at (-0.25, 0), the reward ball uniform in
    [0.05, 0.15] x [-0.1, 0.1]); step(action) shoots the cue ball with
    velocity action (m/s) and ends the episode. Observations are the ball
    positions x0, y0, x1, y1, ... (after a step, the final ones); the reward
    is eq. 7.7's. `set` holds other keys, e.g. {'table.friction': 0.3}.

    An action faster than sim.max_speed is scaled down to that speed (the
    simulator refuses faster ones); info['clipped'] says when.
    """

    metadata = {"render_modes": []}
    render_mode = None

    def __init__(self, set=None):
        self._cfg = config(_lib.assignments({"experiment.name": "exp3", **(set or {})}))
        half = np.array([self._cfg.number("table.length"), self._cfg.number("table.width")]) / 2
        self.n_balls = int(self._cfg.number("table.balls"))
        self.max_speed = self._cfg.number("sim.max_speed")
        low, high = -np.tile(half, self.n_balls), np.tile(half, self.n_balls)
        v = np.full(2, self.max_speed)
        if gymnasium:
            self.observation_space = spaces.Box(low, high, dtype=np.float64)
            self.action_space = spaces.Box(-v, v, dtype=np.float64)
        else:
            self.observation_space, self.action_space = Bounds(low, high), Bounds(-v, v)
        self._lock = threading.Lock()  # the generator is this object's only mutable state
        self._rng = None
        self._state = None

    def _draw(self, n, seed):
        """n start states from the generator (re)seeded with seed if given."""
        with self._lock:
            if seed is not None or self._rng is None:
                if seed is None:
                    seed = int(np.random.SeedSequence().generate_state(1)[0])
                if not 0 <= int(seed) <= 4294967295:
                    raise ValueError(f"seed: must be an integer in 0..4294967295 (got {seed})")
                ptr = lib.pr_bind_rng_new(int(seed))
                if not ptr:
                    raise MemoryError("rng: out of memory")
                self._rng = Handle(ptr, lib.pr_bind_rng_free)
            states = np.empty((n, 2 * self.n_balls))
            err = errbuf()
            check(lib.pr_bind_starts(self._cfg.ptr, self._rng.ptr, n, addr(states), err), err)
        return states

    def reset(self, *, seed=None, options=None):
        """(observation, info). seed reseeds the start-state generator;
        options={'state': positions} starts from given positions instead."""
        if gymnasium:
            super().reset(seed=seed)
        if options and "state" in options:
            if seed is not None:
                self._draw(0, seed)
            state = array("state", options["state"], 1, rows=2 * self.n_balls)
            err = errbuf()
            check(lib.pr_bind_check_state(self._cfg.ptr, addr(state), self.n_balls, err), err)
        else:
            state = self._draw(1, seed)[0]
        self._state = state
        return state.copy(), {}

    def step(self, action):
        """(observation, reward, terminated, truncated, info): one shot; the
        episode is over (terminated is True)."""
        if self._state is None:
            raise RuntimeError("PocketEnv: call reset() before step()")
        a = array("action", action, 1, rows=2)
        obs, reward, _, _, info = self.step_batch(self._state[None, :], a[None, :])
        self._state = None
        return obs[0], float(reward[0]), True, False, {k: v[0] for k, v in info.items()}

    def reset_batch(self, n, seed=None):
        """n start states at once, (n, 2*n_balls), and an empty info dict."""
        return self._draw(int(n), seed), {}

    def step_batch(self, states, actions):
        """One shot from each row of states (N, 2*n_balls) with actions
        (N, 2): (observations, rewards, terminated, truncated, info), each
        with N rows; info holds pocket, hit, min_gap, t_end, events, clipped."""
        S = array("states", states, 2, cols=2 * self.n_balls, allow_empty=True, finite=False)
        A = array("actions", actions, 2, cols=2, rows=S.shape[0], allow_empty=True)
        speed = np.hypot(A[:, 0], A[:, 1])
        clipped = speed > self.max_speed
        if clipped.any():
            # a few ulps below the limit, so that hypot of the result is not above it
            A = A.copy()
            A[clipped] *= (self.max_speed / speed[clipped] * (1 - 2.0**-50))[:, None]
        r = shoot_rows(self._cfg, S, A)
        n = S.shape[0]
        info = {k: r[k] for k in ("pocket", "hit", "min_gap", "t_end", "events")}
        info["clipped"] = clipped
        return (r["final"].reshape(n, -1), r["reward"], np.ones(n, dtype=bool),
                np.zeros(n, dtype=bool), info)

    def close(self):
        pass
