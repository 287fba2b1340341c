"""poolreps.sb3.PocketVecEnv, the native vector env as a Stable-Baselines3
VecEnv, against SB3's own DummyVecEnv of PocketEnvs (make_vec_env) on the
same seeds, and a few PPO updates through it. Runs in the Python of
build/baselines/venv (`scripts/baselines.sh venv` installs SB3 there) and
skips, saying so, without it."""
import os
import subprocess
import textwrap
from pathlib import Path

import pytest

from conftest import ROOT, run_cmd

VENV = Path(os.environ.get("BASELINES_VENV", ROOT / "build/baselines/venv"))

SCRIPT = '''
import numpy as np
import poolreps
from poolreps.sb3 import PocketVecEnv
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import VecEnv, VecMonitor

n = 6
kw = {"normalize_actions": True, "randomize": {"table.friction": (0.1, 0.6)}}
# a seed at the top of the range: sub-env seeds wrap as Gymnasium's do
ours = VecMonitor(PocketVecEnv(n, seed=2**32 - 3, threads=2, **kw))
ref = make_vec_env("poolreps/PocketEnv-v0", n_envs=n, seed=2**32 - 3, env_kwargs=kw)
assert isinstance(ours.unwrapped, VecEnv)
assert ours.observation_space == ref.observation_space
assert ours.action_space == ref.action_space
assert np.array_equal(ours.reset(), ref.reset())
assert ours.unwrapped.reset_infos == ref.reset_infos
rng = np.random.default_rng(1)
for t in range(4):
    act = rng.uniform(-1, 1, (n, 2)).astype(np.float32)
    o1, r1, d1, i1 = ours.step(act)
    o2, r2, d2, i2 = ref.step(act)
    assert np.array_equal(o1, o2) and o1.dtype == o2.dtype
    assert np.array_equal(r1, r2) and r1.dtype == r2.dtype
    assert np.array_equal(d1, d2) and d1.all()
    for a, b in zip(i1, i2):
        assert set(a) == set(b), (sorted(a), sorted(b))
        for k in b:
            if k == "episode":  # VecMonitor's (float32) and Monitor's (rounded to 1e-6)
                assert a[k]["l"] == b[k]["l"] == 1
                assert abs(a[k]["r"] - b[k]["r"]) <= 1e-6 * (1 + abs(b[k]["r"]))
            else:
                assert np.array_equal(a[k], b[k]), k
    assert ours.unwrapped.reset_infos == ref.reset_infos
ours.seed(5)
ref.seed(5)
assert np.array_equal(ours.reset(), ref.reset())
assert ours.get_attr("normalize_actions") == [True] * n
for bad in (lambda: ours.set_attr("x", 1, indices=[0]),
            lambda: ours.env_method("reset", indices=[1])):
    try:
        bad()
        raise AssertionError("acted on some sub-envs only")
    except ValueError as e:
        assert "every sub-env" in str(e)
model = PPO("MlpPolicy", VecMonitor(PocketVecEnv(8, normalize_actions=True, seed=1)),
            n_steps=32, batch_size=64, n_epochs=2, seed=0, device="cpu")
model.learn(512)
assert model.num_timesteps == 512 and len(model.ep_info_buffer) == 100
print("ok")
'''


def test_pocket_vec_env_equals_dummy_vec_env_and_trains_ppo():
    if os.environ.get("SAN") == "1":
        pytest.skip("under SAN=1 SB3's Python would load the sanitized library without the "
                    "sanitizer runtime preloaded")
    py = VENV / "bin/python"
    if not py.exists() or subprocess.run([str(py), "-c", "import stable_baselines3"],
                                         capture_output=True).returncode:
        pytest.skip(f"Stable-Baselines3 is not installed in {VENV} (scripts/baselines.sh venv "
                    "installs it from PyPI)")
    env = dict(os.environ, PYTHONPATH=str(ROOT / "python"),
               POOLREPS_LIB=os.environ.get("POOLREPS_LIB",
                                           str(ROOT / "build/rel/libpoolreps.so.0")))
    p = run_cmd([str(py), "-c", textwrap.dedent(SCRIPT)], capture_output=True, text=True,
                env=env, timeout=600)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["ok"]
