"""PocketEnv: the pool table as a one-shot-per-episode Gymnasium environment."""
from __future__ import annotations

import ctypes
import numbers
import threading
from typing import Any, Dict, Optional, Tuple

import numpy as np

from . import _lib
from ._lib import addr, array, check, chunks, config, errbuf, lib
from .core import shoot_rows

try:
    import gymnasium
    from gymnasium import spaces
except ImportError:  # the environment works without it; spaces are then Bounds
    gymnasium = None

ENV_ID = "poolreps/PocketEnv-v0"


class Bounds:
    """A box of values (what the spaces are without gymnasium)."""

    def __init__(self, low, high, dtype=np.float64):
        self.dtype = np.dtype(dtype)
        self.low = np.asarray(low, dtype=self.dtype)
        self.high = np.asarray(high, dtype=self.dtype)
        self.shape = self.low.shape

    def contains(self, x) -> bool:
        x = np.asarray(x)
        return x.shape == self.shape and bool(np.all((x >= self.low) & (x <= self.high)))

    def sample(self, rng=None) -> np.ndarray:
        rng = np.random.default_rng() if rng is None else rng
        return rng.uniform(self.low, self.high).astype(self.dtype)

    def __repr__(self) -> str:
        return f"Bounds(low={self.low}, high={self.high})"


class PocketEnv(gymnasium.Env if gymnasium else object):
    """One shot per episode on the thesis's table (ch. 7).

    reset() draws a start state from start.* (Experiment 3's by default:
    the cue ball at (-0.25, 0), the reward ball uniform in
    [0.05, 0.15] x [-0.1, 0.1]); step(action) shoots the cue ball and ends
    the episode. Observations are the ball positions x0, y0, x1, y1, ...
    (after a step, the final ones); the reward is eq. 7.7's. `set` holds
    other keys, e.g. {'table.friction': 0.3}.

    Actions: the cue ball's velocity in m/s within +-sim.max_speed per
    component; with normalize_actions=True an action a in [-1, 1]^2 means
    the velocity a * sim.max_speed. A velocity faster than sim.max_speed
    (the simulator refuses it) is scaled down to that speed, keeping its
    direction; info['clipped'] says when. (Experiment 3 instead draws such
    an action again from its Gaussian: an environment is handed one action
    and cannot redraw it.)

    render_mode 'rgb_array': render() returns a (height, width, 3) uint8
    image of the table, the pockets, the balls and the last shot's
    trajectory; 'human' shows it with matplotlib.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 30}

    def __init__(self, set: Optional[Dict[str, Any]] = None, render_mode: Optional[str] = None,
                 normalize_actions: bool = False, width: int = 400, height: int = 200) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode: {render_mode!r} is not one of "
                             f"{self.metadata['render_modes']} or None")
        self._args = {"set": dict(set or {}), "render_mode": render_mode,
                      "normalize_actions": bool(normalize_actions), "width": int(width),
                      "height": int(height)}
        self._cfg = config(_lib.assignments({"experiment.name": "exp3", **(set or {})}))
        self.render_mode = render_mode
        self.normalize_actions = bool(normalize_actions)
        self.half = np.array([self._cfg.number("table.length"),
                              self._cfg.number("table.width")]) / 2
        self.n_balls = int(self._cfg.number("table.balls"))
        self.max_speed = self._cfg.number("sim.max_speed")
        low, high = -np.tile(self.half, self.n_balls), np.tile(self.half, self.n_balls)
        box = spaces.Box if gymnasium else Bounds
        self.observation_space = box(low, high, dtype=np.float64)
        if self.normalize_actions:
            self.action_space = box(-np.ones(2, np.float32), np.ones(2, np.float32),
                                    dtype=np.float32)
        else:
            v = np.full(2, self.max_speed)
            self.action_space = box(-v, v, dtype=np.float64)
        self._lock = threading.Lock()  # guards the start-state generator
        self._rng = None
        self._state = None
        self._last = None      # (start state, velocity, final state) of the last shot
        self._renderer = None

    def __repr__(self) -> str:
        a = self._args
        extra = "".join(f", {k}={a[k]!r}" for k in ("render_mode", "normalize_actions")
                        if a[k])
        return f"PocketEnv(set={a['set']!r}{extra})"

    # ---- pickling: the keys, the generators' states and the episode ----------

    def __getstate__(self) -> Dict[str, Any]:
        with self._lock:
            rng = None if self._rng is None else _lib.rng_state(self._rng)
        return {"format": 1, "args": self._args, "rng": rng, "state": self._state,
                "last": self._last, "np_random": getattr(self, "_np_random", None),
                "np_random_seed": getattr(self, "_np_random_seed", None)}

    def __setstate__(self, st: Dict[str, Any]) -> None:
        if not isinstance(st, dict) or st.get("format") != 1:
            v = st.get("format") if isinstance(st, dict) else None
            raise ValueError(f"PocketEnv: pickle format version {v}, this poolreps reads "
                             f"version 1")
        self.__init__(**st["args"])
        if st["rng"] is not None:
            self._rng = _lib.rng_from_state(st["rng"])
        self._state, self._last = st["state"], st["last"]
        if st["np_random"] is not None:
            self._np_random = st["np_random"]
            self._np_random_seed = st["np_random_seed"]

    # ---- start states ---------------------------------------------------------

    def _seed_rng(self, seed, repetition):
        """The start-state generator: Experiment 3's stream of (seed,
        repetition) when repetition is given (seed None: experiment.seed),
        else a GSL mt19937 set to seed; seed None and no generator yet: a
        seed drawn from np_random."""
        if repetition is not None:
            s = int(self._cfg.number("experiment.seed")) if seed is None else seed
            ptr = lib.pr_bind_exp3_start_rng(_lib.seed_value("seed", s),
                                             _lib.seed_value("repetition", repetition))
        else:
            if seed is None:
                seed = int(self.np_random.integers(0, 2**32)) if gymnasium else \
                    int(np.random.SeedSequence().generate_state(1)[0])
            ptr = lib.pr_bind_rng_new(_lib.seed_value("seed", seed))
        self._rng = _lib.rng_handle(ptr)

    def _draw(self, n, seed, repetition=None):
        """n start states from the generator, (re)seeded first if asked."""
        with self._lock:
            if seed is not None or repetition is not None or self._rng is None:
                self._seed_rng(seed, repetition)
            states = np.empty((n, 2 * self.n_balls))
            err = errbuf()
            w = states.shape[1]
            for lo, hi in chunks(n):
                check(lib.pr_bind_starts(self._cfg.ptr, self._rng.ptr, hi - lo,
                                         addr(states) + 8 * lo * w, err), err)
        return states

    def reset(self, *, seed: Optional[int] = None,
              options: Optional[Dict[str, Any]] = None) -> Tuple[np.ndarray, Dict]:
        """(observation, info). seed reseeds the start-state generator (and
        np_random); options={'state': positions} starts from given positions
        instead; options={'repetition': k} switches to Experiment 3's start
        states of repetition k for experiment.seed = seed: the n-th reset
        from then on returns the start state of that run's n-th episode."""
        options = options or {}
        rep = options.get("repetition")
        # checked first: a refused seed leaves np_random as it was
        if seed is not None:
            _lib.seed_value("seed", seed)
        if rep is not None:
            _lib.seed_value("repetition", rep)
        if gymnasium:
            super().reset(seed=seed)
        if "state" in options:
            if seed is not None or rep is not None:
                self._draw(0, seed, rep)
            state = array("state", options["state"], 1, rows=2 * self.n_balls)
            err = errbuf()
            check(lib.pr_bind_check_state(self._cfg.ptr, addr(state), self.n_balls, err), err)
        else:
            state = self._draw(1, seed, rep)[0]
        self._state = state
        self._last = None
        return state.copy(), {}

    def reset_batch(self, n: int, seed: Optional[int] = None,
                    repetition: Optional[int] = None) -> Tuple[np.ndarray, Dict]:
        """n start states at once, (n, 2*n_balls), and an empty info dict;
        seed and repetition as for reset()."""
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, numbers.Integral) or n < 0:
            raise ValueError(f"n: must be a whole number >= 0 (got {n!r})")
        return self._draw(int(n), seed, repetition), {}

    # ---- shots ----------------------------------------------------------------

    def velocity(self, actions: Any, name: str = "actions") -> Tuple[np.ndarray, np.ndarray]:
        """Velocities (N, 2) in m/s for actions (N, 2) (scaled by
        sim.max_speed under normalize_actions, then clipped to it), and
        which were clipped."""
        A = array(name, actions, 2, cols=2, allow_empty=True)
        with np.errstate(over="ignore"):
            if self.normalize_actions:
                A = A * self.max_speed
            speed = np.hypot(A[:, 0], A[:, 1])
        # a finite action whose speed overflows: its direction from the
        # action scaled down by its largest component, which cannot overflow
        huge = ~np.isfinite(speed)
        if huge.any():
            a = array(name, actions, 2, cols=2)[huge]
            u = a / np.abs(a).max(axis=1)[:, None]
            A = A.copy()
            A[huge] = u * (self.max_speed / np.hypot(u[:, 0], u[:, 1]))[:, None]
            speed[huge] = np.inf
        clipped = speed > self.max_speed
        if clipped.any():
            # a few ulps below the limit, so that hypot of the result is not above it
            A = A.copy()
            A[clipped] *= (np.where(huge, 1.0, self.max_speed / speed) * (1 - 2.0**-50))[clipped, None]
        return A, clipped

    def step(self, action: Any) -> Tuple[np.ndarray, float, bool, bool, Dict[str, Any]]:
        """(observation, reward, terminated, truncated, info): one shot; the
        episode is over (terminated is True)."""
        if self._state is None:
            raise RuntimeError("PocketEnv: call reset() before step()")
        a = array("action", action, 1, rows=2)
        obs, reward, _, _, info = self.step_batch(self._state[None, :], a[None, :])
        self._last = (self._state, info["velocity"][0], obs[0])
        self._state = None
        if self.render_mode == "human":
            self.render()
        return obs[0], float(reward[0]), True, False, {k: v[0] for k, v in info.items()}

    def step_batch(self, states: Any, actions: Any):
        """One shot from each row of states (N, 2*n_balls) with actions
        (N, 2): (observations, rewards, terminated, truncated, info), each
        with N rows; info holds pocket, hit, min_gap, t_end, events, clipped
        and velocity (the velocity shot, m/s)."""
        S = array("states", states, 2, cols=2 * self.n_balls, allow_empty=True, finite=False)
        A, clipped = self.velocity(np.asarray(actions) if hasattr(actions, "shape") else actions)
        if A.shape[0] != S.shape[0]:
            raise ValueError(f"actions: expected {S.shape[0]} rows, got shape {A.shape}")
        r = shoot_rows(self._cfg, S, A)
        n = S.shape[0]
        info = {k: r[k] for k in ("pocket", "hit", "min_gap", "t_end", "events")}
        info["clipped"] = clipped
        info["velocity"] = A
        return (r["final"].reshape(n, -1), r["reward"], np.ones(n, dtype=bool),
                np.zeros(n, dtype=bool), info)

    def trajectory(self) -> Optional[np.ndarray]:
        """The last shot's trajectory: rows t, x, y, ball (one per ball at
        the start, at every event and at the end); None before a shot."""
        if self._last is None:
            return None
        start, v, _ = self._last
        rows, n = ctypes.c_void_p(), ctypes.c_long()
        err = errbuf()
        v = np.ascontiguousarray(v, dtype=np.float64)
        check(lib.pr_bind_trace(self._cfg.ptr, self.n_balls, addr(start), addr(v),
                                ctypes.byref(rows), ctypes.byref(n), err), err)
        try:
            return np.ctypeslib.as_array(ctypes.cast(rows.value, ctypes.POINTER(ctypes.c_double)),
                                         (n.value, 4)).copy()
        finally:
            lib.pr_bind_free(rows)

    # ---- rendering ------------------------------------------------------------

    def render(self) -> Optional[np.ndarray]:
        """rgb_array: the frame; human: draw it in a matplotlib window; no
        render_mode: None."""
        if self.render_mode is None:
            return None
        from .render import Renderer
        if self._renderer is None:
            self._renderer = Renderer(self._cfg, self._args["width"], self._args["height"])
        if self._last is not None:
            frame = self._renderer.frame(self._last[2], self.trajectory())
        else:
            frame = self._renderer.frame(self._state, None)
        if self.render_mode == "rgb_array":
            return frame
        self._renderer.show(frame)
        return None

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
