"""reps.solver = nlopt: NLopt's L-BFGS on the same dual, its answer then
polished by the Newton search, so that it carries Newton's certificate or
none. On the oracle problems of test_ref_reps.py and the hard and dynamic
families of reps_families.py, wherever the nlopt solver answers, its
status is Newton's and its weights agree with Newton's to 1e-8 (Newton's
agree with the independent references: test_ref_reps*.py); an uncertified
answer exits 3 (never a silent wrong p), and at least 95 % of the active
problems Newton answers must certify. The Python reps(solver=...) reaches
the key."""
import os

import numpy as np
import pytest

from conftest import run_cmd
from reps_families import make_family
from test_ref_reps import make_case, write_case

BIN = os.environ.get("POOLREPS") or os.path.join(os.path.dirname(__file__), "..", "poolreps")
ENV = dict(os.environ, LC_ALL="C")


def solve(tmp_path, R, q, phi, eps, solver):
    tmp_path = tmp_path / solver
    tmp_path.mkdir()
    write_case(tmp_path / "in.csv", R, q, phi)
    args = [BIN, "reps", "--return", "R", "--base", "q", "-i", str(tmp_path / "in.csv"),
            "-o", str(tmp_path / "p.csv"), "--summary", str(tmp_path / "s.csv"), "--epsilon", repr(eps),
            "-q", "--set", f"reps.solver={solver}"]
    if phi.shape[1]:
        args += ["--features", "phi*"]
    r = run_cmd(args, capture_output=True, text=True, env=ENV, timeout=120)
    if r.returncode == 3:
        assert "no certified answer" in r.stderr and not (tmp_path / "p.csv").exists()
        return None, None
    assert r.returncode == 0, r.stderr
    with open(tmp_path / "s.csv") as f:
        s = dict(zip(f.readline().strip().split(","), f.readline().strip().split(",")))
    return np.loadtxt(tmp_path / "p.csv", skiprows=1, ndmin=1), s


def cases():
    for seed in range(0, 240, 4):
        kind, R, q, phi, eps = make_case(seed)
        yield f"oracle-{kind}-{seed}", (R, q, phi, eps)
    for kind in ("collinear", "extreme", "offsets"):
        for seed in range(0, 100, 10):
            yield f"{kind}-{seed}", make_family(kind, seed)
    for seed in range(0, 40, 2):
        yield f"dynamic-{seed}", make_family("dynamic", seed)


CASES = dict(cases())
TALLY = {"active": 0, "certified": 0}


@pytest.mark.parametrize("name", list(CASES))
def test_nlopt_agrees_with_newton(tmp_path, name):
    R, q, phi, eps = CASES[name]
    p0, s0 = solve(tmp_path, R, q, phi, eps, "newton")
    assert s0 is not None
    p1, s1 = solve(tmp_path, R, q, phi, eps, "nlopt")
    if s0["status"] == "active":
        TALLY["active"] += 1
    if s1 is None:
        return
    assert "nlopt" in s1["path"] and s1["status"] == s0["status"], (s0, s1)
    assert float(s1["kl_gap"]) <= 1e-9 or s1["status"] == "unreachable"
    assert float(s1["residual_rel"]) <= 1e-9
    if s1["status"] == "active":
        TALLY["certified"] += 1
    assert np.abs(p1 - p0).max() <= 1e-8, np.abs(p1 - p0).max()


def test_nlopt_certifies_most_active_problems():
    if TALLY["active"] < 20:
        pytest.skip("run with the agreement tests (same session, no -n)")
    assert TALLY["certified"] >= 0.95 * TALLY["active"], TALLY


def test_python_solver_argument():
    if os.environ.get("SAN") == "1" and "libasan" not in os.environ.get("LD_PRELOAD", ""):
        pytest.skip("the sanitized library loads only with its runtimes preloaded")
    poolreps = pytest.importorskip("poolreps")
    rng = np.random.default_rng(4)
    phi = rng.normal(size=(200, 3))
    R = phi[:, 0] + rng.normal(size=200)
    a = poolreps.reps(R, phi, epsilon=0.3)
    b = poolreps.reps(R, phi, epsilon=0.3, solver="nlopt")
    assert a["status"] == b["status"] == "active"
    assert np.abs(a["p"] - b["p"]).max() <= 1e-8
    with pytest.raises(Exception, match="solver"):
        poolreps.reps(R, phi, epsilon=0.3, solver="simplex")
