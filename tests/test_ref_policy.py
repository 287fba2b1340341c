"""Differential tests: `poolreps policy` (tree-LWR, eq. 6.4-6.9) against the
exact rational reference in ref_policy.py, on 200 seeded random problems.

Each problem: 30-150 weighted samples (some weights 0) of a smooth action
field plus noise in 2-D, a policy forest of 1-10 trees, 4 query states (two
of them training states). `poolreps forest --leaves` with the same forest
options and seed gives every training sample's and query's active leaves,
from which the reference computes eq. 6.4-6.9 exactly. Problems come with
state offsets up to 1e6, state scalings 1e-6 ... 1e6 per coordinate, action
scalings 1e-6 ... 1e6, action offsets of 0, 1e3 or 1e6 action scales, weight
scalings, lambda 0, 1e-10 (the thesis's) or 1e-3, and all three covariance
centres: the query mean, each sample's own fit, and (a third of the cases,
policy.cov_center = old, with policy.cov set at random: it has no effect
then) the mean of the policy that drew each sample. Those sampling means
come from a window of 1-4 drawing policies (affine in the state, each off
the true field by its own shift and tilt); in some cases some of them equal
the actions (zero residuals), or all residuals lie along one direction
(a rank-one covariance).

Tolerances, against the exact answer: mean within 1e-9 of (|mu| + the
actions' weighted spread s_a); covariance entries within 1e-9 of the largest
diagonal entry d, plus 16 eps (s_a + |c|) sqrt(d), the round-off of residuals
of size sqrt(d) computed from actions of size s_a + |c| (c the action
offset; it matters only when the neighbourhood is fitted almost exactly,
e.g. 3 samples and 3 coefficients, and the residual covariance is 1e-27 of
the actions' variance). Queries whose status reports a fallback the
reference does not model (2 pseudo-inverse, 8 covariance fallback, 16
min_std floor) are not compared; with the sampling-mean centre, whose
covariance does not depend on the fit, a pseudo-inverse query still has its
covariance compared, and so does a floored one (the floor min_std^2 = 1e-200
only lifts the zero eigenvalue of a rank-one or zero covariance: twice
that, the floor and its round-off, is added to the tolerance). The test checks that most queries are compared.
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
    # drawn after the rest, so the rest of each problem stays as it was:
    # action offsets, and the sampling means of policy.cov_center = old
    aoff = rng.choice([0.0, 1e3, 1e6]) * rng.choice([-1, 1], size=2) * asc
    old = rng.random() < 1 / 3
    Mold = sampling_means(rng, S, A) if old else None
    A = A * asc + aoff
    Mold = None if Mold is None else Mold * asc + aoff
    return S, A, w * wsc, Q, opts, lam, cov, Mold


def sampling_means(rng, S, A):
    """Means of the policies that drew each sample, before the actions are
    scaled: a window of 1-4 policies, each off the true field by its own
    shift and tilt (in the states' standardised coordinates); then, at
    random, half of the means equal to their actions (zero residuals), or
    every residual along one direction (a rank-one covariance)."""
    n = len(S)
    u = (S - S.mean(0)) / S.std(0)
    k = rng.integers(int(rng.integers(1, 5)), size=n)
    shift = rng.normal(size=(4, 2)) * rng.choice([0.01, 0.3, 3.0])
    tilt = rng.normal(size=(4, 2, 2)) * rng.choice([0.0, 0.1])
    M = A - rng.normal(size=(n, 2)) * 0.05 + shift[k] + np.einsum("nij,nj->ni", tilt[k], u)
    kind = rng.choice(["mixture", "some_exact", "rank_one"])
    if kind == "some_exact":
        same = rng.random(n) < 0.5
        M[same] = A[same]
    elif kind == "rank_one":
        d = rng.normal(size=2)
        M = A - rng.normal(size=(n, 1)) * d
    return M


def run(args):
    r = run_cmd([BIN] + args, capture_output=True, text=True, env=ENV, timeout=60)
    assert r.returncode == 0, r.stderr
    return r


def train_args(tmp_path, S, A, w, Mold, tag=""):
    """Write the training CSVs: train{tag}.csv for the forest (its inputs
    are every column but the targets and the weight) and, with the
    sampling-mean columns m0, m1 when Mold is given, ptrain{tag}.csv for the
    policy; return the policy command's training options."""
    write(tmp_path / f"train{tag}.csv", ["s0", "s1", "a0", "a1", "w"], np.c_[S, A, w])
    if Mold is None:
        return ["--train", str(tmp_path / f"train{tag}.csv"), "--state", "s0,s1",
                "--action", "a0,a1", "--weight", "w"]
    write(tmp_path / f"ptrain{tag}.csv", ["s0", "s1", "a0", "a1", "w", "m0", "m1"], np.c_[S, A, w, Mold])
    return ["--train", str(tmp_path / f"ptrain{tag}.csv"), "--state", "s0,s1", "--action", "a0,a1",
            "--weight", "w", "--old-mean", "m0,m1", "--set", "policy.cov_center=old"]


@pytest.mark.parametrize("seed", range(NCASES))
def test_policy_against_reference(tmp_path, seed):
    S, A, w, Q, opts, lam, cov, Mold = make_case(seed)
    n = len(S)
    targs = train_args(tmp_path, S, A, w, Mold)
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
    run(["policy"] + targs + ["-i", str(tmp_path / "q.csv"), "-o", str(tmp_path / "out.csv")] + psets)
    leaves = np.loadtxt(tmp_path / "leaves.csv", delimiter=",", skiprows=1, dtype=int, ndmin=2)
    out = np.loadtxt(tmp_path / "out.csv", delimiter=",", skiprows=1, ndmin=2)
    wn = w / w.sum()
    spread = np.sqrt((wn[:, None] * (A - wn @ A) ** 2).sum(0)).max()
    # the size of the actions' values: their spread plus their offset
    size = spread + np.abs(wn @ A).max()
    centre = cov if Mold is None else "old"
    compared = 0
    for k in range(len(Q)):
        status = int(out[k, -1])
        # with the sampling-mean centre the covariance does not depend on
        # the fit (compared even with a pseudo-inverse), and a floored one
        # (a rank-one covariance's zero eigenvalue raised to min_std^2) is
        # compared with 2 min_std^2 = 2e-200 (the floor and its round-off) added
        # to the tolerance
        if status & 8 or (status & (2 | 16) and Mold is None):
            continue
        mu, C = ref_policy.lwr(S, A, w, leaves[:n], leaves[n + k], Q[k], lam, centre, Mold)
        if C is None:
            continue
        if mu is not None and not status & 2:
            mean = out[k, 2:4]
            tol_mu = 1e-9 * (np.abs(mu).max() + spread)
            assert np.abs(mean - mu).max() <= tol_mu, (seed, k, mean, mu)
        c = np.array([[out[k, 4], out[k, 5]], [out[k, 5], out[k, 6]]])
        big = max(C[0][0], C[1][1])
        tol_c = 1e-9 * big + 16 * np.finfo(float).eps * size * np.sqrt(big) + 2e-200
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


def policy_out(tmp_path, S, A, w, Mold, Q, opts, lam, cov, seed, tag):
    targs = train_args(tmp_path, S, A, w, Mold, tag)
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
    run(["policy"] + targs + ["-i", str(tmp_path / f"q{tag}.csv"), "-o", str(tmp_path / f"out{tag}.csv")]
        + psets)
    return (np.loadtxt(tmp_path / f"out{tag}.csv", delimiter=",", skiprows=1, ndmin=2),
            (tmp_path / f"leaves{tag}.csv").read_text())


@pytest.mark.parametrize("seed", range(30))
def test_policy_invariance(tmp_path, seed):
    """Mean and covariance follow state offsets (up to 1e6 spreads), action
    offsets (up to 1e3 spreads, the sampling means with them) and state and
    action scalings (1e-6 ... 1e6) to 1e-9 relative, and weight scalings
    (1e-6 ... 1e6) with lambda = 0 (eq. 6.6's ridge acts on the raw weights,
    so only then is the answer independent of their scale); for all three
    centres of eq. 6.8 (the cases of make_case: a third of them centred on
    the sampling means). Compared when the forest splits the transformed
    samples the same way (its thresholds are drawn in the transformed
    coordinates)."""
    rng = np.random.default_rng(9000 + seed)
    S, A, w, Q, opts, _, cov, Mold = make_case(seed)
    # an untransformed base problem: unit spreads, queries inside
    S = (S - S.mean(0)) / S.std(0)
    Q = S[:4].copy() if seed % 2 else rng.uniform(-1, 1, size=(4, 2))
    a0, asd = A.mean(0), (A - A.mean(0)).std()
    A = (A - a0) / asd
    Mold = None if Mold is None else (Mold - a0) / asd
    w = w / w.max()
    lam = 0.0 if seed % 3 == 0 else 1e-10
    base, leaves = policy_out(tmp_path, S, A, w, Mold, Q, opts, lam, cov, seed, "b")
    spread = A.std(0).max()
    # offsets of up to 1e6 spreads (the states then carry round-off of
    # 1e6 eps = 2e-10 of their spread), scalings 1e-6 ... 1e6
    ssc = 10.0 ** rng.uniform(-6, 6, size=2)
    soff = rng.choice([1e3, 1e6], size=2) * rng.choice([-1, 1], size=2) * ssc
    asc = 10.0 ** rng.uniform(-6, 6)
    aoff = rng.choice([0.0, 1e3], size=2) * rng.choice([-1, 1], size=2) * asc
    wsc = 10.0 ** rng.uniform(-6, 6) if lam == 0.0 else 1.0
    out, lv = policy_out(tmp_path, S * ssc + soff, A * asc + aoff, w * wsc,
                         None if Mold is None else Mold * asc + aoff, Q * ssc + soff, opts, lam, cov,
                         seed, "t")
    if lv != leaves:
        pytest.skip("the transformed states fall differently at a threshold")
    # the floor min_std (bit 16) is absolute, 1e-100 here: whether it lifts
    # a rank-one covariance's zero eigenvalue (which is round-off) depends
    # on the scale; every other status bit must agree
    assert ((out[:, -1].astype(int) ^ base[:, -1].astype(int)) & ~16 == 0).all()
    mean = (out[:, 2:4] - aoff) / asc
    c = out[:, 4:7] / asc**2
    # the offset actions carry round-off of |aoff| eps
    size = spread + np.abs(aoff).max() / asc
    assert np.abs(mean - base[:, 2:4]).max() <= 1e-9 * (np.abs(base[:, 2:4]).max() + spread)
    for k in range(len(Q)):
        big = max(base[k, 4], base[k, 6])
        assert np.abs(c[k] - base[k, 4:7]).max() <= 1e-9 * big + 16 * np.finfo(float).eps * size * np.sqrt(big)


@pytest.mark.parametrize("far", [1e155, -1e200])
def test_policy_failure_names_its_row(tmp_path, far):
    """A query state far outside the training states (1e155, -1e200 on
    states in [-1, 1]) overflows the covariance's eigen-decomposition: exit
    3 with one line naming the file, the line and the state's value, and no
    output file (the earlier rows are not committed)."""
    rng = np.random.default_rng(17)
    S = rng.uniform(-1, 1, size=(200, 2))
    A = S @ np.array([[1.0, 0.5], [0.2, -1.0]]) + 0.1 * rng.normal(size=(200, 2))
    targs = train_args(tmp_path, S, A, rng.uniform(size=200), None)
    write(tmp_path / "q.csv", ["s0", "s1"], [[0.1, 0.2], [0.5, -0.5], [0.0, far], [0.3, 0.3]])
    out = tmp_path / "out.csv"
    r = run_cmd([BIN, "policy"] + targs + ["-i", str(tmp_path / "q.csv"), "-o", str(out)],
                capture_output=True, text=True, env=ENV, timeout=60)
    assert r.returncode == 3 and not out.exists(), r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert f"q.csv:4: state s1 = {far:.17g}" in r.stderr, r.stderr
