"""Differential tests: `poolreps reps` against the independent reference in
ref_reps.py (scipy minimisation of the dual, an SLSQP primal solve, linear
programmes for the eta -> 0 limit), on 240 seeded random problems:

  no features; generic dense features with d < n and d >= n; one-hot blocks
  of 1-30 trees (continuous thresholds, so rich forests pin p near q and
  make the bound unreachable); ties in the returns; eps from 1e-6 to 10;
  q uniform or from importance weights, some of them 0; returns shifted by
  up to 1e15 times their spread and scaled by 1e-300 ... 1e300. Then 13
  wide dense problems (32-60 features, 150-3000 rows), whose Newton path
  ends in chord steps, against the reference's minimiser of the dual.

Tolerances (every comparison):
  - the C certificate: |KL - eps| <= 1e-9 (active), relative feature
    residual <= 1e-9, status as the reference decides (active when
    KL(p0||q) > eps, unreachable otherwise; cases within 1e-6 of the
    boundary only need a certified status);
  - weights: max_i |p_C - p_ref| <= 1e-9 (active: the dual's minimiser;
    unreachable: the eta -> 0 limit p0);
  - KL(p_C||q) against the reference's: 1e-9;
  - the primal (active cases, every fourth seed): SLSQP's objective may not
    beat the C answer's sum p R by more than 1e-8 of the return range (the
    primal solver's own accuracy); where SLSQP reaches the optimum (within
    1e-9), its weights agree to 1e-4 (the optimum is unique).
"""
import os

import numpy as np
import pytest

import ref_reps
from conftest import run_cmd

BIN = os.environ.get("POOLREPS") or os.path.join(os.path.dirname(__file__), "..", "poolreps")
ENV = dict(os.environ, LC_ALL="C")
NCASES = 240
KINDS = ["none", "dense", "dense_wide", "onehot", "onehot_rich", "ties"]


def onehot_trees(S, rng, trees, leaves):
    """One-hot active leaves of `trees` random partitions of the states with
    continuous thresholds: each tree splits its largest cell at a uniform
    threshold on a random coordinate until it has `leaves` cells."""
    cols = []
    for _ in range(trees):
        leaf = np.zeros(len(S), int)
        k = 1
        while k < leaves:
            big = np.argmax(np.bincount(leaf, minlength=k))
            idx = np.where(leaf == big)[0]
            if len(idx) < 2:
                break
            dim = rng.integers(S.shape[1])
            t = rng.uniform(S[idx, dim].min(), S[idx, dim].max())
            leaf[idx[S[idx, dim] > t]] = k
            k += 1
        cols.append(np.eye(k)[leaf])
    return np.hstack(cols)


def make_case(seed):
    rng = np.random.default_rng(1000 + seed)
    kind = KINDS[seed % len(KINDS)]
    n = int(rng.integers(8, 41))
    S = rng.uniform(size=(n, 2))
    if kind == "none":
        phi = np.zeros((n, 0))
    elif kind == "dense":
        phi = rng.normal(size=(n, int(rng.integers(1, max(2, n // 3)))))
    elif kind == "dense_wide":
        phi = rng.normal(size=(n, n + int(rng.integers(0, 6))))
    elif kind == "onehot":
        phi = onehot_trees(S, rng, int(rng.integers(1, 31)), int(rng.integers(2, 5)))
    elif kind == "onehot_rich":
        phi = onehot_trees(S, rng, int(rng.integers(10, 31)), int(rng.integers(4, 9)))
    else:
        phi = np.c_[S, S[:, 0] * S[:, 1]]
    R = np.sin(3 * S[:, 0]) - S[:, 1] + rng.normal(size=n) * rng.choice([0.05, 0.5])
    if kind == "ties":
        R = np.round(R * 4) / 4
    q = None
    if rng.random() < 0.6:
        # importance weights: ratios of Gaussian densities, some samples dropped
        q = np.exp(rng.normal(0.0, rng.choice([0.3, 1.5]), size=n))
        if rng.random() < 0.5:
            q[rng.random(n) < 0.25] = 0.0
            q[int(rng.integers(n))] = 1.0
    eps = float(10 ** rng.uniform(-6, 1))
    scale = float(rng.choice([1e-300, 1e-161, 1e-6, 1.0, 1e154, 1e300]))
    offset = float(rng.choice([0.0, 0.0, 1e6, 1e15])) if scale <= 1e150 else 0.0
    return kind, (R + offset) * scale, q, phi, eps


def write_case(path, R, q, phi):
    with open(path, "w") as f:
        f.write(",".join(["R", "q"] + [f"phi{j}" for j in range(phi.shape[1])]) + "\n")
        for i in range(len(R)):
            row = [R[i], 1.0 if q is None else q[i]] + list(phi[i])
            f.write(",".join(repr(float(x)) for x in row) + "\n")


def run_c(tmp_path, R, q, phi, eps, extra=()):
    inp = tmp_path / "in.csv"
    write_case(inp, R, q, phi)
    args = [BIN, "reps", "--return", "R", "--base", "q", "-i", str(inp), "-o", str(tmp_path / "p.csv"),
            "--summary", str(tmp_path / "s.csv"), "--epsilon", repr(eps), "-q"]
    if phi.shape[1]:
        args += ["--features", "phi*"]
    args += list(extra)
    r = run_cmd(args, capture_output=True, text=True, env=ENV, timeout=60)
    assert r.returncode == 0, r.stderr
    p = np.loadtxt(tmp_path / "p.csv", skiprows=1, ndmin=1)
    with open(tmp_path / "s.csv") as f:
        head = f.readline().strip().split(",")
        vals = f.readline().strip().split(",")
    return p, dict(zip(head, vals))


@pytest.mark.parametrize("seed", range(NCASES))
def test_reps_against_reference(tmp_path, seed):
    kind, R, q, phi, eps = make_case(seed)
    n = len(R)
    qq = np.ones(n) if q is None else q
    p, s = run_c(tmp_path, R, q, phi, eps)
    ref = ref_reps.reps(R, qq, phi, eps)
    # the certificate
    assert float(s["residual_rel"]) <= 1e-9, s
    assert s["status"] in ("active", "unreachable"), s
    if abs(ref["kl0"] - eps) > 1e-6:
        assert s["status"] == ref["status"], (kind, s, ref["kl0"], eps)
    if s["status"] == "active":
        assert int(s["bound"]) == 1 and float(s["kl_gap"]) <= 1e-9
    else:
        assert int(s["bound"]) == 0 and float(s["eta"]) == 0.0 and float(s["kl"]) < eps
    if s["status"] != ref["status"]:
        return
    assert np.abs(p - ref["p"]).max() <= 1e-9, (kind, np.abs(p - ref["p"]).max())
    assert abs(float(s["kl"]) - ref["kl"]) <= 1e-9
    if ref["status"] == "active" and seed % 4 == 0:
        on = qq > 0
        pp = ref_reps.primal_solve(ref["R"], ref["q"], ref["psi"], eps)
        assert pp @ ref["R"] <= p[on] @ ref["R"] + 1e-8
        # the optimum is unique: where SLSQP reaches it, the weights agree
        if pp @ ref["R"] >= p[on] @ ref["R"] - 1e-9:
            assert np.abs(pp - p[on]).max() <= 1e-4


def test_affine_invariance_exact():
    """Exact shifts and power-of-two scalings of the returns give the same
    weights to the last bit (the standardisation is exact for them), and the
    issue's scales 1e-161 / 1e154 solve like scale 1."""
    import tempfile
    from pathlib import Path
    rng = np.random.default_rng(7)
    n = 30
    S = rng.uniform(size=(n, 2))
    phi = onehot_trees(S, rng, 5, 3)
    base = np.round(rng.normal(size=n) * 2**20) / 2**20
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        ref, _ = run_c(d, base, None, phi, 0.5)
        for R in (base + 2.0**30, base * 2.0**-1000, base * 2.0**1000, (base - 2.0**30) * 2.0**-50):
            p, s = run_c(d, R, None, phi, 0.5)
            assert s["status"] == "active"
            assert np.array_equal(p, ref)
        for sc in (1e-161, 1e154):
            p, s = run_c(d, base * sc, None, phi, 0.5)
            assert s["status"] == "active" and np.abs(p - ref).max() <= 1e-12


@pytest.mark.parametrize("seed", range(12))
def test_wide_dense_chord_steps_against_reference(tmp_path, seed):
    """Wide dense problems (32 or more features) take chord steps near the
    root, reusing the last Hessian (path `joint+chord`): their answer is
    still the dual's minimiser. Offsets, column scales over four decades,
    heavy-tailed returns, reachable bounds (eps <= 0.5 with n >= 150); the
    reference minimises the dual from scratch (ref_reps.dual_solve on its
    own exactly centred basis)."""
    rng = np.random.default_rng(7700 + seed)
    n, d = int(rng.integers(150, 500)), int(rng.integers(32, 61))
    phi = rng.normal(size=(n, d)) * 10.0 ** rng.uniform(-2, 2, size=d) + rng.choice([0.0, 1e4])
    R = (phi[:, :3] / phi[:, :3].std(0)) @ rng.normal(size=3) + rng.standard_t(3, size=n)
    eps = float(rng.choice([1e-3, 0.1, 0.5]))
    p, s = run_c(tmp_path, R, None, phi, eps)
    q, on, Rs, psi = ref_reps.prepare(R, np.ones(n), phi)
    _, p_ref, kl_ref, gmax = ref_reps.dual_solve(Rs[on], np.log(q[on]), psi[on], eps)
    assert gmax <= 1e-12 and abs(kl_ref - eps) <= 1e-12, (gmax, kl_ref)
    assert s["status"] == "active" and float(s["kl_gap"]) <= 1e-9, s
    assert np.abs(p - p_ref).max() <= 1e-9, (s["path"], np.abs(p - p_ref).max())


def test_wide_dense_problems_take_chord_steps(tmp_path):
    """The chord steps are taken, not skipped: on dense200's kind of problem
    (n = 3000, d = 60, eps = 0.5) the summary's path is joint+chord, and the
    answer is the reference's."""
    rng = np.random.default_rng(31)
    phi = rng.normal(size=(3000, 60))
    R = phi[:, :3].sum(1) + rng.normal(size=3000)
    p, s = run_c(tmp_path, R, None, phi, 0.5)
    assert s["status"] == "active" and s["path"] == "joint+chord", s
    q, on, Rs, psi = ref_reps.prepare(R, np.ones(3000), phi)
    _, p_ref, _, _ = ref_reps.dual_solve(Rs[on], np.log(q[on]), psi[on], 0.5)
    assert np.abs(p - p_ref).max() <= 1e-9
