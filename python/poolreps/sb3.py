"""PocketVecEnv: the native vector env (poolreps.vector.PocketVectorEnv) as a
Stable-Baselines3 VecEnv, so that SB3's learners step N tables with one
batch call per step instead of DummyVecEnv's Python loop. Needs
stable-baselines3 (imported here, not by `import poolreps`).

    from poolreps.sb3 import PocketVecEnv
    from stable_baselines3 import PPO
    PPO("MlpPolicy", PocketVecEnv(64, normalize_actions=True, seed=1)).learn(100_000)

Each step returns what SB3's DummyVecEnv of PocketEnvs returns on the same
seeds (`make_vec_env("poolreps/PocketEnv-v0", n_envs=N, seed=s)`): the next
episodes' start states (every episode is one shot, so every step ends one),
float32 rewards, dones all True, and per env PocketEnv's step info plus
`terminal_observation` (the positions after the shot) and
`TimeLimit.truncated` (False); `reset_infos` holds the new episodes'
randomized values.
"""
from __future__ import annotations

from typing import Any, Dict, List, Optional

import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import (VecEnv, VecEnvIndices, VecEnvObs,
                                                           VecEnvStepReturn)

from .vector import PocketVectorEnv


class PocketVecEnv(VecEnv):  # type: ignore[misc]
    """n_envs PocketEnvs stepped by one batch call, as an SB3 VecEnv.

    seed: as SB3's VecEnv.seed (sub-env i gets seed + i) for the first
    reset; threads and the other keyword arguments are PocketVectorEnv's
    (set, normalize_actions, randomize). All sub-envs share one
    configuration, so get_attr returns the same value for each, and
    set_attr and env_method refuse to act on only some of them.
    """

    def __init__(self, n_envs: int, seed: Optional[int] = None, **kwargs: Any) -> None:
        self.venv = PocketVectorEnv(num_envs=n_envs, **kwargs)
        super().__init__(n_envs, self.venv.single_observation_space,
                         self.venv.single_action_space)
        if seed is not None:
            self.seed(seed)
        self._actions: Optional[np.ndarray] = None

    def reset(self) -> VecEnvObs:
        seeds, options = self._seeds, self._options
        if all(s is None for s in seeds):
            seed: Any = None
        elif any(s is None for s in seeds):
            raise ValueError("PocketVecEnv: seed all sub-envs or none")
        else:
            seed = list(seeds)
        opts = None
        if any(options):
            if any(set(o) != {"state"} for o in options):
                raise ValueError("PocketVecEnv: the only option is 'state', for every sub-env")
            opts = {"state": np.stack([np.asarray(o["state"], dtype=np.float64)
                                       for o in options])}
        obs, info = self.venv.reset(seed=seed, options=opts)
        self.reset_infos = self._per_env(info)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("PocketVecEnv: step_async() before step_wait()")
        obs, rewards, terminated, truncated, info = self.venv.step(self._actions)
        self._actions = None
        shot = {k: v for k, v in info["final_info"].items() if k[0] != "_"}
        infos = self._per_env(shot)
        for i, d in enumerate(infos):
            d["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            d["terminal_observation"] = info["final_obs"][i]
        new = {k: v for k, v in info.items() if k[0] != "_" and k not in ("final_obs", "final_info")}
        self.reset_infos = self._per_env(new)
        return obs, rewards.astype(np.float32), terminated | truncated, infos

    def _per_env(self, arrays: Dict[str, Any]) -> List[Dict[str, Any]]:
        """{key: (n_envs, ...) array} as one dict per env ({key: row}),
        without the '_key' masks."""
        rows: List[Dict[str, Any]] = [{} for _ in range(self.num_envs)]
        for k, v in arrays.items():
            if k[0] == "_":
                continue
            for i in range(self.num_envs):
                rows[i][k] = v[i].copy() if v.ndim > 1 else v[i]
        return rows

    def close(self) -> None:
        self.venv.close()

    def _all(self, indices: VecEnvIndices, what: str) -> List[int]:
        idx = list(self._get_indices(indices))
        if sorted(idx) != list(range(self.num_envs)):
            raise ValueError(f"PocketVecEnv: {what} acts on every sub-env at once (they share "
                             "one configuration)")
        return idx

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> List[Any]:
        value = getattr(self.venv.env, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        self._all(indices, "set_attr")
        setattr(self.venv.env, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> List[Any]:
        idx = self._all(indices, "env_method")
        out = getattr(self.venv.env, method_name)(*method_args, **method_kwargs)
        return [out for _ in idx]

    def env_is_wrapped(self, wrapper_class: type, indices: VecEnvIndices = None) -> List[bool]:
        return [False for _ in self._get_indices(indices)]
