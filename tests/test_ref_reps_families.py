"""Differential tests on the three families where a plain Newton solver
fails although a certified answer exists (tests/reps_families.py): nearly
collinear feature columns (one column a multiple of another plus 1e-10 ...
1e-6 of its spread), one extreme return or Cauchy tails in samples of
1000-5000, and features with large offsets and d >= n - 1 (only p = q is
feasible). 100 seeded problems per family, against the independent
reference of ref_reps.py (exact-rational centring and standardisation,
scipy's trust-ncg on the dual, HiGHS for the eta -> 0 limit).

Tolerances: the C certificate (status active or unreachable, |KL - eps| <=
1e-9 when active, relative residual <= 1e-9), the status the reference
decides (cases within 1e-6 of the boundary excepted), and max |p_C - p_ref|
<= 1e-8 wherever the reference itself converged (its dual gradient below
1e-9); the cases where it did not are counted and must stay few."""
import os

import numpy as np
import pytest

import ref_reps
from reps_families import FAMILIES, WIDE, WIDE_SPAN, make_family
from conftest import run_cmd
from test_ref_reps import BIN, ENV, run_c, write_case

NSEEDS = 100


@pytest.mark.parametrize("kind", FAMILIES)
@pytest.mark.parametrize("seed", range(NSEEDS))
def test_family_against_reference(tmp_path, kind, seed):
    check_against_reference(tmp_path, kind, seed)


@pytest.mark.parametrize("seed", range(40))
def test_wide_dense_path_against_reference(tmp_path, seed):
    """The dense path of 32 or more free features with n > d (its rank-k
    Hessian kernel and least-squares start), same tolerances."""
    check_against_reference(tmp_path, WIDE, seed)


@pytest.mark.parametrize("seed", range(40))
def test_wide_span_against_reference(tmp_path, seed):
    """At least as many dense features as samples, of low rank, with near
    duplicate columns: solved on the span of the features from the start
    (path ending in span), same tolerances."""
    check_against_reference(tmp_path, WIDE_SPAN, seed)


@pytest.mark.parametrize("kind", ["extreme", WIDE])
@pytest.mark.parametrize("seed", range(20))
def test_matrix_free_against_reference(tmp_path, kind, seed):
    """reps.solver = cg (Newton steps by conjugate gradients on Hessian-vector
    products, no Hessian formed; path with cg): same tolerances on
    well-conditioned features. Nearly dependent ones (a condition number of
    the centred, column-scaled features above 1e6: wide_dense's near
    duplicates) need the reduced basis, which takes a factorisation: there
    the solve must fail its certificate (exit 3), never answer wrongly."""
    R, q, phi, eps = make_family(kind, seed)
    dev = phi - phi.mean(0)
    scale = np.abs(dev).max(0)
    if phi.shape[1] and np.linalg.cond(dev[:, scale > 0] / scale[scale > 0]) > 1e6:
        r = run_cmd(cg_args(tmp_path, R, q, phi, eps), capture_output=True, text=True, env=ENV,
                    timeout=60)
        assert r.returncode in (0, 3), r.stderr
        if r.returncode == 3:
            assert "no certified answer" in r.stderr and len(r.stderr.splitlines()) == 1
        return
    check_against_reference(tmp_path, kind, seed, ("--set", "reps.solver=cg"))


def cg_args(tmp_path, R, q, phi, eps):
    write_case(tmp_path / "in.csv", R, q, phi)
    return [BIN, "reps", "--return", "R", "--base", "q", "-i", str(tmp_path / "in.csv"),
            "-o", str(tmp_path / "p.csv"), "--epsilon", repr(eps), "-q", "--features", "phi*",
            "--set", "reps.solver=cg"]


def check_against_reference(tmp_path, kind, seed, extra=()):
    R, q, phi, eps = make_family(kind, seed)
    qq = np.ones(len(R)) if q is None else q
    p, s = run_c(tmp_path, R, q, phi, eps, extra)
    if extra and phi.shape[1]:
        assert "cg" in s["path"].split("+"), s
    if kind == WIDE_SPAN:
        # no Newton step on a Hessian of order d, no retry
        assert s["path"].endswith("span") and "reduced" not in s["path"], s
    assert s["status"] in ("active", "unreachable"), s
    assert float(s["residual_rel"]) <= 1e-9, s
    if s["status"] == "active":
        assert float(s["kl_gap"]) <= 1e-9, s
    else:
        assert float(s["eta"]) == 0.0 and float(s["kl"]) < eps, s
    assert int(s["rank"]) >= 0 and float(s["cond"]) >= 1.0 and s["path"], s
    # a first attempt that stalls leaves its evaluations to the reduced basis
    # instead of spending reps.max_iter (2000) on them
    assert int(s["iterations"]) < 2000, s
    ref = ref_reps.reps(R, qq, phi, eps)
    if abs(ref["kl0"] - eps) > 1e-6:
        assert s["status"] == ref["status"], (s, ref["kl0"], eps)
    if kind == "offsets":
        # only p = q matches the features
        assert s["status"] == "unreachable" and np.abs(p - qq / qq.sum()).max() <= 1e-8
    if s["status"] != ref["status"]:
        return
    if ref["status"] == "active" and not ref["gmax"] <= 1e-9:
        pytest.skip(f"the reference did not converge (gradient {ref['gmax']:.2g})")
    assert np.abs(p - ref["p"]).max() <= 1e-8, np.abs(p - ref["p"]).max()
    assert abs(float(s["kl"]) - ref["kl"]) <= 1e-9
