"""Differential tests: `poolreps policy` (tree-LWR, eq. 6.4-6.9) against the
exact rational reference in ref_policy.py, on 200 seeded random problems.

Each problem: 30-150 weighted samples (some weights 0) of a smooth action
field plus noise in 2-D, a policy forest of 1-10 trees, 4 query states (two
of them training states). `poolreps forest --leaves` with the same forest
options and seed gives every training sample's and query's active leaves,
from which the reference computes eq. 6.4-6.9 exactly. Problems come with
state offsets up to 1e6, state scalings 1e-6 ... 1e6 per coordinate, action
scalings 1e-6 ... 1e6, weight scalings, lambda 0, 1e-10 (the thesis's) or
1e-3, and both covariance centres.

Tolerances, against the exact answer: mean within 1e-9 of (|mu| + the
actions' weighted spread s_a); covariance entries within 1e-9 of the largest
diagonal entry d, plus 16 eps s_a sqrt(d), the round-off of residuals of
size sqrt(d) computed from actions of size s_a (it matters only when the
neighbourhood is fitted almost exactly, e.g. 3 samples and 3 coefficients,
and the residual covariance is 1e-27 of the actions' variance). Queries whose status reports a fallback the reference
does not model (2 pseudo-inverse, 8 covariance fallback, 16 min_std floor)
are not compared; the test checks that most queries are compared.
"""
import os

import numpy as np
import pytest

import ref_policy
from conftest import run_cmd

BIN = os.environ.get("POOLREPS") or os.path.join(os.path.dirname(__file__), "..", "poolreps")
ENV = dict(os.environ, LC_ALL="C")
NCASES = 200


def write(path, header, rows):
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        for r in rows:
            f.write(",".join(repr(float(x)) for x in r) + "\n")


def make_case(seed):
    rng = np.random.default_rng(5000 + seed)
    n = int(rng.integers(30, 151))
    S = rng.uniform(-1, 1, size=(n, 2))
    A = np.c_[np.sin(2 * S[:, 0]) + 0.5 * S[:, 1], S[:, 0] * S[:, 1] - S[:, 1]]
    A += rng.normal(size=(n, 2)) * rng.choice([0.01, 0.2])
    w = rng.exponential(size=n)
    w[rng.random(n) < 0.2] = 0.0
    w[0] = 1.0
    Q = np.vstack([S[int(rng.integers(n))], S[int(rng.integers(n))], rng.uniform(-1, 1, size=(2, 2))])
    # offsets and scalings of states, actions and weights
    soff = rng.choice([0.0, 1e3, 1e6], size=2) * rng.choice([-1, 1], size=2)
    ssc = 10.0 ** rng.uniform(-6, 6, size=2)
    asc = 10.0 ** rng.uniform(-6, 6)
    wsc = 10.0 ** rng.uniform(-6, 6)
    S, Q = S * ssc + soff, Q * ssc + soff
    opts = {"trees": int(rng.integers(1, 11)), "cuts": int(rng.integers(1, 21)),
            "n_min": int(rng.integers(8, n + 10)), "n_c": 1,
            "score": str(rng.choice(["rvr", "nrvr"])), "replacement": "with", "outputs": "sum"}
    lam = float(rng.choice([0.0, 1e-10, 1e-3]))
    cov = str(rng.choice(["query", "residual"]))
    return S, A * asc, w * wsc, Q, opts, lam, cov


def run(args):
    r = run_cmd([BIN] + args, capture_output=True, text=True, env=ENV, timeout=60)
    assert r.returncode == 0, r.stderr
    return r


@pytest.mark.parametrize("seed", range(NCASES))
def test_policy_against_reference(tmp_path, seed):
    S, A, w, Q, opts, lam, cov = make_case(seed)
    n = len(S)
    write(tmp_path / "train.csv", ["s0", "s1", "a0", "a1", "w"], np.c_[S, A, w])
    write(tmp_path / "test.csv", ["s0", "s1"], np.vstack([S, Q]))
    write(tmp_path / "q.csv", ["s0", "s1"], Q)
    fsets, psets = ["--seed", str(seed)], ["--seed", str(seed)]
    for k, v in opts.items():
        fsets += ["--set", f"forest.{k}={v}"]
        psets += ["--set", f"policy.{k}={v}"]
    psets += ["--set", f"policy.lambda={lam!r}", "--set", f"policy.cov={cov}",
              "--set", "policy.min_std=1e-100"]
    run(["forest", "--train", str(tmp_path / "train.csv"), "--test", str(tmp_path / "test.csv"),
         "--target", "a0,a1", "--weight", "w", "--leaves", str(tmp_path / "leaves.csv"),
         "-o", str(tmp_path / "pred.csv")] + fsets)
    run(["policy", "--train", str(tmp_path / "train.csv"), "--state", "s0,s1", "--action", "a0,a1",
         "--weight", "w", "-i", str(tmp_path / "q.csv"), "-o", str(tmp_path / "out.csv")] + psets)
    leaves = np.loadtxt(tmp_path / "leaves.csv", delimiter=",", skiprows=1, dtype=int, ndmin=2)
    out = np.loadtxt(tmp_path / "out.csv", delimiter=",", skiprows=1, ndmin=2)
    wn = w / w.sum()
    spread = np.sqrt((wn[:, None] * (A - wn @ A) ** 2).sum(0)).max()
    compared = 0
    for k in range(len(Q)):
        status = int(out[k, -1])
        if status & (2 | 8 | 16):
            continue
        ref = ref_policy.lwr(S, A, w, leaves[:n], leaves[n + k], Q[k], lam, cov)
        if ref is None or ref[1] is None:
            continue
        mu, C = ref
        mean = out[k, 2:4]
        c = np.array([[out[k, 4], out[k, 5]], [out[k, 5], out[k, 6]]])
        tol_mu = 1e-9 * (np.abs(mu).max() + spread)
        assert np.abs(mean - mu).max() <= tol_mu, (seed, k, mean, mu)
        big = max(C[0][0], C[1][1])
        tol_c = 1e-9 * big + 16 * np.finfo(float).eps * spread * np.sqrt(big)
        assert np.abs(c - np.array(C)).max() <= tol_c, (seed, k, c, C)
        compared += 1
    # the fallbacks are rare here: most queries must be compared
    assert compared >= 2, (seed, out[:, -1])


def test_offset_case_of_the_issue(tmp_path):
    """One tree, one leaf (a global weighted linear fit), states 1000 +- 1,
    actions 2 (s - 1000) + noise: the mean follows the slope (it used to be
    -0.018 everywhere), at 1e6 as at 0."""
    rng = np.random.default_rng(3)
    x = rng.uniform(-1, 1, 200)
    a = 2 * x + 0.01 * rng.normal(size=200)
    res = {}
    for off in (0.0, 1000.0, 1e6):
        write(tmp_path / "t.csv", ["s", "a", "w"], np.c_[x + off, a, np.ones(200)])
        write(tmp_path / "q.csv", ["s"], np.array([[-0.5 + off], [0.0 + off], [0.5 + off]]))
        run(["policy", "--train", str(tmp_path / "t.csv"), "--state", "s", "--action", "a",
             "--weight", "w", "-i", str(tmp_path / "q.csv"), "-o", str(tmp_path / "o.csv"),
             "--set", "policy.trees=1", "--set", "policy.n_min=1000"])
        out = np.loadtxt(tmp_path / "o.csv", delimiter=",", skiprows=1)
        assert (out[:, -1] == 0).all()
        res[off] = out[:, 1:3]
    assert abs(res[1000.0][0, 0] + 1.0) < 0.01 and abs(res[1000.0][2, 0] - 1.0) < 0.01
    for off in (1000.0, 1e6):
        # the states x + off are rounded (ulp 1e-10 at 1e6): 1e-9 of the spread
        assert np.abs(res[off] - res[0.0]).max() <= 1e-9 * 2


def policy_out(tmp_path, S, A, w, Q, opts, lam, cov, seed, tag):
    write(tmp_path / f"train{tag}.csv", ["s0", "s1", "a0", "a1", "w"], np.c_[S, A, w])
    write(tmp_path / f"q{tag}.csv", ["s0", "s1"], Q)
    fsets, psets = ["--seed", str(seed)], ["--seed", str(seed)]
    for k, v in opts.items():
        fsets += ["--set", f"forest.{k}={v}"]
        psets += ["--set", f"policy.{k}={v}"]
    psets += ["--set", f"policy.lambda={lam!r}", "--set", f"policy.cov={cov}",
              "--set", "policy.min_std=1e-100"]
    run(["forest", "--train", str(tmp_path / f"train{tag}.csv"), "--test", str(tmp_path / f"train{tag}.csv"),
         "--target", "a0,a1", "--weight", "w", "--leaves", str(tmp_path / f"leaves{tag}.csv"),
         "-o", str(tmp_path / f"pred{tag}.csv")] + fsets)
    run(["policy", "--train", str(tmp_path / f"train{tag}.csv"), "--state", "s0,s1", "--action", "a0,a1",
         "--weight", "w", "-i", str(tmp_path / f"q{tag}.csv"), "-o", str(tmp_path / f"out{tag}.csv")] + psets)
    return (np.loadtxt(tmp_path / f"out{tag}.csv", delimiter=",", skiprows=1, ndmin=2),
            (tmp_path / f"leaves{tag}.csv").read_text())


@pytest.mark.parametrize("seed", range(20))
def test_policy_invariance(tmp_path, seed):
    """Mean and covariance follow state offsets (up to 1e6 spreads) and state and
    action scalings (1e-6 ... 1e6) to 1e-9 relative, and weight scalings
    (1e-6 ... 1e6) with lambda = 0 (eq. 6.6's ridge acts on the raw weights,
    so only then is the answer independent of their scale). Compared when
    the forest splits the transformed samples the same way (its thresholds
    are drawn in the transformed coordinates)."""
    rng = np.random.default_rng(9000 + seed)
    S, A, w, Q, opts, _, cov = make_case(seed)
    # an untransformed base problem: unit spreads, queries inside
    S = (S - S.mean(0)) / S.std(0)
    Q = S[:4].copy() if seed % 2 else rng.uniform(-1, 1, size=(4, 2))
    A = A / A.std()
    w = w / w.max()
    lam = 0.0 if seed % 3 == 0 else 1e-10
    base, leaves = policy_out(tmp_path, S, A, w, Q, opts, lam, cov, seed, "b")
    spread = A.std(0).max()
    # offsets of up to 1e6 spreads (the states then carry round-off of
    # 1e6 eps = 2e-10 of their spread), scalings 1e-6 ... 1e6
    ssc = 10.0 ** rng.uniform(-6, 6, size=2)
    soff = rng.choice([1e3, 1e6], size=2) * rng.choice([-1, 1], size=2) * ssc
    asc = 10.0 ** rng.uniform(-6, 6)
    wsc = 10.0 ** rng.uniform(-6, 6) if lam == 0.0 else 1.0
    out, lv = policy_out(tmp_path, S * ssc + soff, A * asc, w * wsc, Q * ssc + soff, opts, lam, cov,
                         seed, "t")
    if lv != leaves:
        pytest.skip("the transformed states fall differently at a threshold")
    assert (out[:, -1] == base[:, -1]).all()
    mean = out[:, 2:4] / asc
    c = out[:, 4:7] / asc**2
    assert np.abs(mean - base[:, 2:4]).max() <= 1e-9 * (np.abs(base[:, 2:4]).max() + spread)
    for k in range(len(Q)):
        big = max(base[k, 4], base[k, 6])
        assert np.abs(c[k] - base[k, 4:7]).max() <= 1e-9 * big + 16 * np.finfo(float).eps * spread * np.sqrt(big)
