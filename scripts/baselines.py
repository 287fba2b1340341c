#!/usr/bin/env python3
"""Experiment 5: standard learners on Experiment 3's task (docs/baselines.md).

    baselines.py run LEARNER SEED OUT.csv [--budgets 2200,22000,55000] [--curve-every 1100]
    baselines.py learners

One run = one learner and seed, trained for the largest budget; at every
budget it records the mean return of the last 500 training episodes (as
Experiment 3 evaluates), how many training actions were clipped onto
sim.max_speed so far (PocketEnv's info['clipped']) and the mean return of the learner's deterministic
action (SB3's deterministic=True, the CMA-ES mean) on 2000 fresh start
states, the same 2000 for every learner of a seed. Every --curve-every
episodes it also records the mean of the last 500 episodes (the
sample-efficiency curve). The task is poolreps.PocketEnv: Experiment 3's
start states (the n-th episode of seed k starts where repetition k of
Experiment 3 with experiment.seed = 1 starts its n-th episode), reward
eq. 7.7, velocities above sim.max_speed scaled down to it.

Learners, none tuned (an equal tuning budget: none): sac, ppo
(Stable-Baselines3's defaults on normalize_actions=True), cma_linear
(pycma on the hand-crafted linear policy's parameters). The REPS learners and our contextual CMA-ES run
through `poolreps` (scripts/baselines.sh).
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import csv
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "python"))
import poolreps  # noqa: E402

LAST = 500          # Experiment 3's evaluation: the last 500 episodes
EVAL_STARTS = 2000  # deterministic evaluation on this many fresh start states
EVAL_SEED = 1000000  # + seed: the evaluation starts, apart from every training stream
# data/exp3.ini's values, which the poolreps learners read (docs/baselines.md
# prints both sides): experiment.seed of the training start states, the reward
# ball's start box (start.reward_box; the features' scale) and exp3.init_std
# (pycma's sigma0: the initial policy's std on the constant feature, m/s)
EXP3_SEED = 1
REWARD_BOX = (0.05, 0.15, -0.1, 0.1)
SIGMA0 = 0.1

LEARNERS = ["sac", "ppo", "cma_linear"]


def cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


class Recorder:
    """The training returns, episode by episode, and the rows to write."""

    def __init__(self, learner, seed, budgets, curve_every, evaluate):
        self.learner, self.seed = learner, seed
        self.budgets, self.curve_every = sorted(budgets), curve_every
        self.evaluate = evaluate
        self.returns = []
        self.clipped = 0    # training actions clipped onto sim.max_speed so far
        self.rows = []
        self.t0, self.c0 = time.time(), cpu_seconds()

    def add(self, rewards, policy, clipped):
        for r, c in zip(np.atleast_1d(rewards), np.atleast_1d(clipped)):
            self.returns.append(float(r))
            self.clipped += bool(c)
            n = len(self.returns)
            last = float(np.mean(self.returns[-LAST:]))
            if n % self.curve_every == 0:
                self.rows.append(["curve", n, last, "", "", "", ""])
            if n in self.budgets:
                self.rows.append(["budget", n, last, self.evaluate(policy),
                                  round(time.time() - self.t0, 3),
                                  round(cpu_seconds() - self.c0, 3), self.clipped])

    @property
    def done(self):
        return len(self.returns) >= self.budgets[-1]

    def write(self, path):
        tmp = Path(str(path) + ".tmp")
        with open(tmp, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["learner", "seed", "kind", "episodes", "last500_mean", "deterministic_mean",
                        "wall_s", "cpu_s", "clipped"])
            for r in self.rows:
                w.writerow([self.learner, self.seed, *r])
        os.replace(tmp, path)


class Exp3Env(poolreps.PocketEnv):
    """PocketEnv whose start states are Experiment 3's stream of one
    repetition, whatever seed the learner passes to reset()."""

    def __init__(self, repetition, **kw):
        super().__init__(**kw)
        self._rep = repetition
        self._started = False

    def reset(self, *, seed=None, options=None):
        if not self._started:
            self._started = True
            return super().reset(seed=EXP3_SEED, options={"repetition": self._rep})
        return super().reset(options=options)


def eval_states(seed):
    env = poolreps.PocketEnv()
    return env, env.reset_batch(EVAL_STARTS, seed=EVAL_SEED + seed)[0]


def run_sb3(learner, seed, rec):
    import torch
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.callbacks import BaseCallback

    torch.set_num_threads(1)
    algo = SAC if learner == "sac" else PPO
    env = Exp3Env(seed, normalize_actions=True)
    ev_env, ev_states = eval_states(seed)
    ev_env.normalize_actions = True

    def evaluate(model):
        a, _ = model.predict(ev_states, deterministic=True)
        return float(ev_env.step_batch(ev_states, a)[1].mean())

    rec.evaluate = evaluate

    class Cb(BaseCallback):
        def _on_step(self):
            rec.add(self.locals["rewards"], self.model,
                    [i["clipped"] for i in self.locals["infos"]])
            return not rec.done

    model = algo("MlpPolicy", env, seed=seed, device="cpu", verbose=0)
    model.learn(total_timesteps=rec.budgets[-1], callback=Cb())


def linear_features(cfg_env, S):
    """The hand-crafted features of Experiment 3: 1, u, v, u^2, uv, v^2 of
    the reward ball's position scaled to [-1, 1]^2 on its start box."""
    lo, hi = np.array(REWARD_BOX[::2]), np.array(REWARD_BOX[1::2])
    uv = 2 * (S[:, 2:4] - lo) / (hi - lo) - 1
    u, v = uv[:, 0], uv[:, 1]
    return np.column_stack([np.ones_like(u), u, v, u * u, u * v, v * v])


def run_cma(seed, rec):
    import cma

    env = poolreps.PocketEnv()
    starts = env.reset_batch(rec.budgets[-1], seed=EXP3_SEED, repetition=seed)[0]
    ev_env, ev_states = eval_states(seed)
    phi_ev = linear_features(ev_env, ev_states)

    def act(theta, phi):
        return phi @ np.asarray(theta).reshape(6, 2)

    rec.evaluate = lambda theta: float(ev_env.step_batch(ev_states, act(theta, phi_ev))[1].mean())
    es = cma.CMAEvolutionStrategy(np.zeros(12), SIGMA0,
                                  {"seed": seed + 1, "verbose": -9, "maxfevals": 10**9})
    i = 0
    while not rec.done:
        X = es.ask()
        n = min(len(X), rec.budgets[-1] - i)
        S = starts[i:i + n]
        phi = linear_features(env, S)
        a = np.array([act(x, p[None, :])[0] for x, p in zip(X[:n], phi)])
        _, r, _, _, info = env.step_batch(S, a)
        for k in range(n):
            rec.add(r[k], es.mean, info["clipped"][k])
        i += n
        if n == len(X):
            es.tell(X, list(-r))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("learner", choices=LEARNERS)
    r.add_argument("seed", type=int)
    r.add_argument("out")
    r.add_argument("--budgets", default="2200,22000,55000")
    r.add_argument("--curve-every", type=int, default=1100)
    sub.add_parser("learners")
    a = ap.parse_args(argv)
    if a.cmd == "learners":
        print(" ".join(LEARNERS))
        return 0
    budgets = [int(b) for b in a.budgets.split(",")]
    rec = Recorder(a.learner, a.seed, budgets, a.curve_every, None)
    if a.learner == "cma_linear":
        run_cma(a.seed, rec)
    else:
        run_sb3(a.learner, a.seed, rec)
    rec.write(a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
