"""PocketVectorEnv: N pool tables stepped by one batch call (a native
Gymnasium VectorEnv; `gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=N)`)."""
from __future__ import annotations

import ctypes
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt
import gymnasium
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from . import _lib
from ._lib import addr, check, errbuf, lib
from .core import thread_count
from .env import PocketEnv

Obs = npt.NDArray[np.float64]

# A step of up to this many sub-envs runs without the Ctrl-C worker thread
# (core.shoot_rows), whose start costs as much as about 100 shots: a few
# milliseconds of shots, after which the KeyboardInterrupt arrives.
STEP_ROWS = 4096


class PocketVectorEnv(VectorEnv):  # type: ignore[misc]
    """num_envs PocketEnvs in one object: step(actions) shoots all of them
    with one call into the library and resets them in the same step
    (autoreset_mode SAME_STEP: every episode is one shot, so the observation
    returned is the next episode's start state; info["final_obs"] holds the
    positions after the shot).

    Sub-env i draws its start states from its own generator, seeded as a
    PocketEnv reset with seed + i (wrapped to 0..2**32-1): the start
    states, rewards and observations equal those of a SyncVectorEnv of
    PocketEnvs (autoreset_mode SAME_STEP) on the same seeds, randomized
    parameters (randomize=) included. threads: each step's shots are split
    over up to this many threads (0, the default: one per CPU this process
    may run on; 1 for one env per core, e.g. under SubprocVecEnv); every
    number is the same whatever the count. Other keyword arguments are
    PocketEnv's (set, normalize_actions, randomize). A pickled or copied
    PocketVectorEnv steps on with the same numbers.
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(self, num_envs: int = 1, threads: int = 0, **kwargs: Any) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs: must be an integer >= 1 (got {num_envs!r})")
        self.threads = thread_count(threads)
        if kwargs.get("render_mode") is not None:
            raise ValueError("PocketVectorEnv: render_mode is not supported; render a PocketEnv")
        kwargs.pop("render_mode", None)
        self.env = PocketEnv(**kwargs)
        self.num_envs = num_envs
        self.render_mode = None
        self.single_observation_space = self.env.observation_space
        self.single_action_space = self.env.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._rngs: List[_lib.Handle] = []
        self._ptrs = (ctypes.c_void_p * num_envs)()
        self._states: Optional[Obs] = None
        self._params: Optional[Dict[str, npt.NDArray[np.float64]]] = None

    def __repr__(self) -> str:
        return f"PocketVectorEnv(num_envs={self.num_envs}, threads={self.threads}, {self.env!r})"

    # ---- pickling: the keys, each sub-env's generator and the pending starts --

    def __getstate__(self) -> Dict[str, Any]:
        return _lib.pickle_state(self, num_envs=self.num_envs, threads=self.threads,
                                 args=self.env._args,
                                 rngs=[_lib.rng_state(h) for h in self._rngs],
                                 states=self._states, params=self._params)

    def __setstate__(self, st: Dict[str, Any]) -> None:
        _lib.check_pickle("PocketVectorEnv", st)
        self.__init__(st["num_envs"], st["threads"], **st["args"])
        self._rngs = [_lib.rng_from_state(b) for b in st["rngs"]]
        for i, h in enumerate(self._rngs):
            self._ptrs[i] = h.ptr
        self._states, self._params = st["states"], st["params"]
        _lib.restore_np_random(self, st)

    def _seed(self, seeds: Sequence[int]) -> None:
        self._rngs = [_lib.rng_handle(lib.pr_bind_rng_new(_lib.env_seed(f"seed[{i}]", s)))
                      for i, s in enumerate(seeds)]
        for i, h in enumerate(self._rngs):
            self._ptrs[i] = h.ptr

    def _starts(self) -> Obs:
        """Each sub-env's next start state, then its randomized values (as
        PocketEnv.reset draws them) into self._params."""
        states = np.empty((self.num_envs, 2 * self.env.n_balls))
        err = errbuf()
        check(lib.pr_bind_starts_each(self.env._cfg.ptr, self._ptrs, self.num_envs,
                                      addr(states), err), err)
        self._draw_params()
        return states

    def _draw_params(self) -> None:
        if self.env._rand is not None:
            u = np.empty((self.num_envs, len(self.env._rand[0])))
            lib.pr_bind_uniforms_each(self._ptrs, self.num_envs, u.shape[1], addr(u))
            self._params = self.env.draw_params(u)

    def _episode_info(self) -> Dict[str, Any]:
        """The new episodes' randomized values, as SyncVectorEnv gathers
        PocketEnv.reset's info: {key: (num_envs,), '_key': mask}."""
        info: Dict[str, Any] = {}
        for k, v in (self._params or {}).items():
            info[k], info["_" + k] = v, self._mask()
        return info

    def _given(self, state: Any) -> Obs:
        s = _lib.array("state", state, 2, rows=self.num_envs, cols=2 * self.env.n_balls)
        err = errbuf()
        for i, row in enumerate(s):
            if lib.pr_bind_check_state(self.env._cfg.ptr, addr(row), self.env.n_balls, err):
                raise ValueError(f"state[{i}]: {err.value.decode(errors='replace')}")
        return s

    def reset(self, *, seed: Union[int, Sequence[int], None] = None,
              options: Optional[Dict[str, Any]] = None) -> Tuple[Obs, Dict[str, Any]]:
        """(observations (num_envs, 2*n_balls), {}). seed: an int (sub-env i
        gets seed + i) or one seed per sub-env; None continues the streams
        (the first time: seeds drawn from np_random). options:
        {'state': (num_envs, 2*n_balls) positions} starts from them."""
        options = _lib.options(options, ("state",))
        given = None if "state" not in options else self._given(options["state"])
        if isinstance(seed, (list, tuple)):
            if len(seed) != self.num_envs:
                raise ValueError(f"seed: expected {self.num_envs} seeds, got {len(seed)}")
            seeds = [_lib.env_seed(f"seed[{i}]", s) for i, s in enumerate(seed)]
            super().reset(seed=None)
        elif seed is not None:
            base = _lib.env_seed("seed", seed)
            seeds = [base + i for i in range(self.num_envs)]
            super().reset(seed=seed)
        else:
            seeds = [] if self._rngs else \
                [int(s) for s in self.np_random.integers(0, 2**32, self.num_envs)]
        if seeds:
            self._seed(seeds)
        if given is None:
            self._states = self._starts()
        else:
            self._states = given
            self._draw_params()
        return self._states.copy(), self._episode_info()

    def step(self, actions: Any) -> Tuple[Obs, npt.NDArray[np.float64], npt.NDArray[np.bool_],
                                          npt.NDArray[np.bool_], Dict[str, Any]]:
        """One shot in every sub-env, then its reset: (next start states,
        rewards, terminated (all True), truncated (all False), info), info
        laid out as SyncVectorEnv's: final_obs (num_envs, 2*n_balls), the
        positions after the shot, and final_info, PocketEnv's per-shot
        arrays (pocket, hit, min_gap, t_end, events, clipped, velocity);
        each key with its '_key' mask (all True). The arrays are typed
        (float64, bool, int), not object arrays."""
        if self._states is None:
            raise RuntimeError("PocketVectorEnv: call reset() before step()")
        final, rewards, terminated, truncated, shot = self.env._step_batch(
            self._states, actions, self._params, self.threads, STEP_ROWS)
        self._states = self._starts()
        for k in list(shot):
            shot["_" + k] = self._mask()
        info = {**self._episode_info(), "final_obs": final, "_final_obs": self._mask(),
                "final_info": shot, "_final_info": self._mask()}
        return self._states.copy(), rewards, terminated, truncated, info

    def _mask(self) -> npt.NDArray[np.bool_]:
        return np.ones(self.num_envs, dtype=np.bool_)

    def close_extras(self, **kwargs: Any) -> None:
        self.env.close()
