"""The ask/tell learner outside the pool: Gymnasium's Pendulum-v1.

The context is the pendulum's start state (angle, angular velocity); the
per-episode action is the pair of gains (kp, kd) of a PD law
u = clip(-kp * angle - kd * velocity, -2, 2) run for the whole episode; the
return is the episode's summed reward. Each iteration asks gains for a batch
of start states, plays them, and tells the returns (one REPS update with
tree value features and a tree-LWR policy of the gains given the start).

Run (Gymnasium from build/venv, `make venv`):
    PYTHONPATH=python build/venv/bin/python examples/learn_gym.py [ITERATIONS]
"""
import sys

import gymnasium as gym
import numpy as np

import poolreps

BATCH = 40


def start(env, seed):
    """The start state (angle, angular velocity) that reset(seed) gives."""
    obs, _ = env.reset(seed=seed)
    return np.array([np.arctan2(obs[1], obs[0]), obs[2]])


def play(env, seed, gains):
    """The return of one episode from reset(seed) with PD gains."""
    obs, _ = env.reset(seed=seed)
    total, done = 0.0, False
    while not done:
        angle, velocity = np.arctan2(obs[1], obs[0]), obs[2]
        u = np.clip(-gains[0] * angle - gains[1] * velocity, -2.0, 2.0)
        obs, r, terminated, truncated, _ = env.step([u])
        total += r
        done = terminated or truncated
    return total


def main(iterations):
    env = gym.make("Pendulum-v1")
    learner = poolreps.Learner(2, 2, seed=1, set={"learner.init_std": 5.0})
    seeds = iter(range(10**9))
    for it in range(iterations):
        batch = [next(seeds) for _ in range(BATCH)]
        starts = np.array([start(env, s) for s in batch])  # the contexts
        gains = learner.ask(starts)
        returns = np.array([play(env, s, g) for s, g in zip(batch, gains)])
        learner.tell(starts, gains, returns)
        s = learner.summary
        print(f"iteration {it + 1:3d} mean_return {returns.mean():9.2f} kl {s['kl']:.3f} "
              f"{s['status']}")
    env.close()


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 25)
