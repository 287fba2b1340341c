"""Contextual REPS on PocketEnv with tree features and the tree-LWR policy.

The context is the reward ball's start (Experiment 3's region); the action
is the cue ball's velocity. Each iteration: shoot a batch with the current
policy; fit a forest from contexts to returns and use its active leaves as
REPS value features (thesis eq. 5.4); REPS weights the batch within a KL
bound (eq. 3.7-3.8); the tree-LWR policy is refitted to the weighted batch
(eq. 6.4-6.9). Run: PYTHONPATH=python python3 examples/python/reps_loop.py
"""
import numpy as np

import poolreps

env = poolreps.PocketEnv()          # one shot per episode, Exp. 3's start states
BATCH, ITERATIONS, EPSILON = 200, 15, 0.5

# the initial policy, N(0, 0.1^2 I), whatever the context
states, _ = env.reset_batch(BATCH, seed=1)
actions = np.random.default_rng(1).normal(0, 0.1, (BATCH, 2))

for it in range(ITERATIONS + 1):
    obs, returns, *_ = env.step_batch(states, actions)
    print(f"iteration {it:2d} mean_return {returns.mean():.4f} "
          f"pocketed {np.mean(returns == 0):.2f}")
    if it == ITERATIONS:
        break
    context = states[:, 2:4]        # the reward ball: the cue ball always starts at (-0.25, 0)

    # value features: the leaves of a forest fitted from contexts to returns
    value = poolreps.Forest(trees=10, n_min=60, score="nrvr", seed=it).fit(context, returns)
    phi = value.leaf_features(context)

    # REPS: weights p within KL(p || uniform) <= epsilon, matching the features
    w = poolreps.reps(returns, phi, epsilon=EPSILON)

    # the tree-LWR policy fitted to the weighted shots
    policy = poolreps.Policy(n_min=40, seed=it).fit(context, actions, w["p"])

    # the next batch: new contexts, actions drawn from the new policy
    states, _ = env.reset_batch(BATCH)
    actions = policy.sample(states[:, 2:4], seed=it)
