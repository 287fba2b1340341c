"""PocketEnv: the pool table as a one-shot-per-episode Gymnasium environment."""
from __future__ import annotations

import ctypes
import numbers
import threading
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import _lib
from ._lib import addr, array, check, chunks, config, errbuf, lib
from .core import SHORT_ROWS, row_params, shoot_rows

try:
    import gymnasium
    from gymnasium import spaces
except ImportError:  # the environment works without it; spaces are then Bounds
    gymnasium = None

ENV_ID = "poolreps/PocketEnv-v0"
# rgb_array_list and human: a shot's frames cover at most this much
# simulated time, then the final frame (under the exponential law a slow
# ball creeps on visibly for tens of seconds)
MAX_CLIP_SECONDS = 10.0

Floats = npt.NDArray[np.float64]
Bools = npt.NDArray[np.bool_]
Pixels = npt.NDArray[np.uint8]


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
    trajectory. 'rgb_array_list': render() returns the frames since the
    last render() or reset(): the start state, then along each shot one
    frame every 1/render_fps s of simulated time (the simulator's own
    positions, trails so far) up to the last visible motion, and the final
    frame; gymnasium.utils.save_video writes them as a clip. 'human' plays
    each shot's frames at render_fps with matplotlib.
    """

    metadata = {"render_modes": ["rgb_array", "rgb_array_list", "human"], "render_fps": 30}

    def __init__(self, set: Optional[Dict[str, Any]] = None, render_mode: Optional[str] = None,
                 normalize_actions: bool = False, width: int = 400, height: int = 200,
                 randomize: Optional[Dict[str, Tuple[float, float]]] = None) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode: {render_mode!r} is not one of "
                             f"{self.metadata['render_modes']} or None")
        self._args = {"set": dict(set or {}), "render_mode": render_mode,
                      "normalize_actions": bool(normalize_actions), "width": int(width),
                      "height": int(height), "randomize": dict(randomize or {})}
        self._cfg = config(_lib.assignments({"experiment.name": "exp3", **(set or {})}))
        self.render_mode = render_mode
        self.normalize_actions = bool(normalize_actions)
        self.half = np.array([self._cfg.number("table.length"),
                              self._cfg.number("table.width")]) / 2
        self.n_balls = int(self._cfg.number("table.balls"))
        self.max_speed = self._cfg.number("sim.max_speed")
        self._rand = self._randomize(randomize)
        low, high = -np.tile(self.half, self.n_balls), np.tile(self.half, self.n_balls)
        # typed as gymnasium's Box (what they are with gymnasium installed),
        # so that user code passes mypy --strict
        box: Any = spaces.Box if gymnasium else Bounds
        self.observation_space: spaces.Box = box(low, high, dtype=np.float64)
        if self.normalize_actions:
            self.action_space: spaces.Box = box(-np.ones(2, np.float32),
                                                np.ones(2, np.float32), dtype=np.float32)
        else:
            v = np.full(2, self.max_speed)
            self.action_space = box(-v, v, dtype=np.float64)
        self._lock = threading.Lock()  # guards the start-state generator
        self._rng = None
        self._state = None
        self._params = None    # this episode's randomized values: {key: (1,) array}
        self._last = None      # (start state, velocity, final state, params) of the last shot
        self._renderer = None
        self._frames: List[np.ndarray] = []  # rgb_array_list: frames not yet rendered

    def __repr__(self) -> str:
        a = self._args
        extra = "".join(f", {k}={a[k]!r}" for k in ("render_mode", "normalize_actions",
                                                    "randomize") if a[k])
        return f"PocketEnv(set={a['set']!r}{extra})"

    # ---- pickling: the keys, the generators' states and the episode ----------

    def __getstate__(self) -> Dict[str, Any]:
        with self._lock:
            rng = None if self._rng is None else _lib.rng_state(self._rng)
        return _lib.pickle_state(self, args=self._args, rng=rng, state=self._state,
                                 last=self._last, params=self._params)

    def __setstate__(self, st: Dict[str, Any]) -> None:
        _lib.check_pickle("PocketEnv", st)
        self.__init__(**st["args"])
        if st["rng"] is not None:
            self._rng = _lib.rng_from_state(st["rng"])
        self._state, self._last = st["state"], st["last"]
        self._params = st.get("params")
        _lib.restore_np_random(self, st)

    # ---- domain randomisation -------------------------------------------------

    def _randomize(self, randomize):
        """(keys, low, high) of randomize={key: (low, high)}, or None; the
        keys checked as shoot's params check them."""
        if not randomize:
            return None
        keys = tuple(randomize)
        bounds = []
        for k in keys:
            b = np.asarray(randomize[k], dtype=object)
            if b.shape != (2,):
                raise ValueError(f"randomize[{k!r}]: expected (low, high), got {randomize[k]!r}")
            lo, hi = array(f"randomize[{k!r}]", list(b), 1, rows=2)
            if not lo <= hi:
                raise ValueError(f"randomize[{k!r}]: low {lo!r} > high {hi!r}")
            bounds.append((lo, hi))
        low, high = np.array(bounds).T.copy()
        # a shot of no rows checks the keys (unknown, not a number, another section)
        shoot_rows(self._cfg, np.empty((0, 2 * self.n_balls)), np.empty((0, 2)),
                   (keys, np.empty((0, len(keys)))))
        for k, b in zip(keys, bounds):  # both ends as --set values (the range is an interval)
            for v in b:
                try:
                    config(_lib.assignments({"experiment.name": "exp3", **self._args["set"],
                                             k: v}))
                except ValueError as e:
                    raise ValueError(f"randomize[{k!r}]: {e}") from None
        return keys, low, high

    def draw_params(self, u: Floats) -> Dict[str, Floats]:
        """{key: values} of randomize for uniform draws u (n, keys) in [0, 1)."""
        keys, low, high = self._rand
        v = low + (high - low) * u
        return {k: v[:, j].copy() for j, k in enumerate(keys)}

    def _draw_params(self, n):
        """n rows of randomized values from the start-state generator
        (after the start state), or None without randomize."""
        if self._rand is None:
            return None
        u = np.empty((n, len(self._rand[0])))
        with self._lock:
            if self._rng is None:
                self._seed_rng(None, None)
            rngs = (ctypes.c_void_p * max(n, 1))(*([self._rng.ptr] * n))
            lib.pr_bind_uniforms_each(rngs, n, u.shape[1], addr(u))
        return self.draw_params(u)

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
            ptr = lib.pr_bind_rng_new(_lib.env_seed("seed", seed))
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
              options: Optional[Dict[str, Any]] = None) -> Tuple[Floats, Dict[str, Any]]:
        """(observation, info). seed reseeds the start-state generator (and
        np_random); options={'state': positions} starts from given positions
        instead; options={'repetition': k} switches to Experiment 3's start
        states of repetition k for experiment.seed = seed: the n-th reset
        from then on returns the start state of that run's n-th episode.
        With randomize, the episode's values are drawn next from the same
        generator, and info holds them ({key: value})."""
        options = _lib.options(options, ("state", "repetition"))
        rep = options.get("repetition")
        # checked first: a refused seed leaves np_random as it was
        if seed is not None:  # Experiment 3's seeds are experiment.seed values
            (_lib.seed_value if rep is not None else _lib.env_seed)("seed", seed)
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
        self._params = self._draw_params(1)
        self._last = None
        if self.render_mode == "rgb_array_list":
            self._frames = [self._get_renderer().frame(state, None)]
        return state.copy(), {} if self._params is None else \
            {k: float(v[0]) for k, v in self._params.items()}

    def reset_batch(self, n: int, seed: Optional[int] = None,
                    repetition: Optional[int] = None) -> Tuple[Floats, Dict[str, Floats]]:
        """n start states at once, (n, 2*n_balls), and an info dict (with
        randomize, {key: (n,) values}, drawn after the n states: pass them
        to step_batch as params); seed and repetition as for reset()."""
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, numbers.Integral) or n < 0:
            raise ValueError(f"n: must be a whole number >= 0 (got {n!r})")
        states = self._draw(int(n), seed, repetition)
        return states, self._draw_params(states.shape[0]) or {}

    # ---- shots ----------------------------------------------------------------

    def velocity(self, actions: Any, name: str = "actions") -> Tuple[Floats, Bools]:
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

    def step(self, action: Any) -> Tuple[Floats, float, bool, bool, Dict[str, Any]]:
        """(observation, reward, terminated, truncated, info): one shot; the
        episode is over (terminated is True)."""
        if self._state is None:
            raise RuntimeError("PocketEnv: call reset() before step()")
        a = array("action", action, 1, rows=2)
        obs, reward, _, _, info = self.step_batch(self._state[None, :], a[None, :],
                                                  self._params)
        self._last = (self._state, info["velocity"][0], obs[0], self._params)
        self._state = None
        if self.render_mode == "rgb_array_list":
            self._frames += self._shot_frames()
        if self.render_mode == "human":
            self.render()
        return obs[0], float(reward[0]), True, False, {k: v[0] for k, v in info.items()}

    def step_batch(self, states: Any, actions: Any, params: Optional[Dict[str, Any]] = None,
                   threads: int = 1) -> Tuple[Floats, Floats, Bools, Bools, Dict[str, Any]]:
        """One shot from each row of states (N, 2*n_balls) with actions
        (N, 2): (observations, rewards, terminated, truncated, info), each
        with N rows; info holds pocket, hit, min_gap, t_end, events, clipped
        and velocity (the velocity shot, m/s), and params' keys. params:
        keys per row as for poolreps.shoot (e.g. reset_batch's info);
        threads as for poolreps.shoot (the same numbers for any count)."""
        return self._step_batch(states, actions, params, threads, SHORT_ROWS)

    def _step_batch(self, states: Any, actions: Any, params: Optional[Dict[str, Any]],
                    threads: int, short: int
                    ) -> Tuple[Floats, Floats, Bools, Bools, Dict[str, Any]]:
        """step_batch, up to short rows without a worker thread (shoot_rows)."""
        S = array("states", states, 2, cols=2 * self.n_balls, allow_empty=True, finite=False)
        A, clipped = self.velocity(np.asarray(actions) if hasattr(actions, "shape") else actions)
        if A.shape[0] != S.shape[0]:
            raise ValueError(f"actions: expected {S.shape[0]} rows, got shape {A.shape}")
        n = S.shape[0]
        rows = row_params(params, n)
        r = shoot_rows(self._cfg, S, A, rows, threads, short)
        info = {k: r[k] for k in ("pocket", "hit", "min_gap", "t_end", "events")}
        if rows:
            info.update({k: rows[1][:, j].copy() for j, k in enumerate(rows[0])})
        info["clipped"] = clipped
        info["velocity"] = A.copy() if A is actions else A  # never the caller's array
        return (r["final"].reshape(n, -1), r["reward"], np.ones(n, dtype=bool),
                np.zeros(n, dtype=bool), info)

    def trajectory(self) -> Optional[Floats]:
        """The last shot's trajectory: rows t, x, y, ball (one per ball at
        the start, at every event and at the end); None before a shot."""
        if self._last is None:
            return None
        start, v = self._last[:2]
        params = self._last[3] if len(self._last) > 3 else None
        cfg = self._cfg if not params else config(_lib.assignments(
            {"experiment.name": "exp3", **self._args["set"],
             **{k: float(x[0]) for k, x in params.items()}}))
        rows, n = ctypes.c_void_p(), ctypes.c_long()
        err = errbuf()
        v = np.ascontiguousarray(v, dtype=np.float64)
        check(lib.pr_bind_trace(cfg.ptr, self.n_balls, addr(start), addr(v),
                                ctypes.byref(rows), ctypes.byref(n), err), err)
        try:
            return np.ctypeslib.as_array(ctypes.cast(rows.value, ctypes.POINTER(ctypes.c_double)),
                                         (n.value, 4)).copy()
        finally:
            lib.pr_bind_free(rows)

    # ---- rendering ------------------------------------------------------------

    def _get_renderer(self):
        from .render import Renderer
        if self._renderer is None:
            self._renderer = Renderer(self._cfg, self._args["width"], self._args["height"])
        return self._renderer

    def _shot_frames(self) -> List[np.ndarray]:
        """The last shot's frames after its start (Renderer.clip): positions every
        1/render_fps s from the simulator itself, the shot simulated again
        with sim.max_time = t per frame (one batch call, the law's own
        motion), for at most MAX_CLIP_SECONDS."""
        start, v, final = self._last[:3]
        params = self._last[3] if len(self._last) > 3 else None
        trace = self.trajectory()
        fps = self.metadata["render_fps"]
        t_end = float(trace[:, 0].max())
        times = np.arange(1, int(np.ceil(min(t_end, MAX_CLIP_SECONDS) * fps)) + 1) / fps
        times = times[times < t_end]
        n = len(times)
        keys = {k: np.repeat(x[0], n) for k, x in (params or {}).items()}
        keys["sim.max_time"] = times
        at = shoot_rows(self._cfg, np.tile(start, (n, 1)), np.tile(v, (n, 1)),
                        row_params(keys, n))
        return self._get_renderer().clip(final, trace, times, at["final"].reshape(n, -1))

    def render(self) -> Union[Pixels, List[Pixels], None]:
        """rgb_array: the frame; rgb_array_list: the frames since the last
        render() or reset() (then forgotten); human: play the last shot in a
        matplotlib window; no render_mode: None."""
        if self.render_mode is None:
            return None
        if self.render_mode == "rgb_array_list":
            frames, self._frames = self._frames, []
            return frames
        r = self._get_renderer()
        if self._last is not None:
            frame = r.frame(self._last[2], self.trajectory())
        else:
            frame = r.frame(self._state, None)
        if self.render_mode == "rgb_array":
            return frame
        frames = [frame] if self._last is None else \
            [r.frame(self._last[0], None)] + self._shot_frames()
        for f in frames:
            r.show(f, 1 / self.metadata["render_fps"])
        return None

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
