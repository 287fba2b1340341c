"""`poolreps reps` on bad and on degenerate but legal inputs.

Bad input (one stderr line, exit 1 or 2, nothing written): fewer than 2 rows,
non-finite returns or features, an empty feature cell, a feature list that
matches no column. Degenerate legal input gets a certified answer:
constant returns (p = q, unreachable), features equal on every row
(dropped: plain REPS), d >> n generic features with offsets (only p = q
matches them: unreachable, p = q), duplicated and nearly duplicated
columns (the same answer as without the duplicate)."""
import os

import numpy as np
import pytest

from conftest import run_cmd
from test_ref_reps import run_c

BIN = os.environ.get("POOLREPS") or os.path.join(os.path.dirname(__file__), "..", "poolreps")
ENV = dict(os.environ, LC_ALL="C")


@pytest.mark.parametrize("text,features,what", [
    ("R,f\n1,2\n", "f", "at least 2 samples"),
    ("R,f\n1,2\nnan,3\n", "f", "'R'"),
    ("R,f\n1,2\n-inf,3\n", "f", "'R'"),
    ("R,f\n1,2\n2,inf\n", "f", "'f'"),
    ("R,f\n1,\n2,3\n", "f", "'f'"),
    ("R\n1\n2\n", "g*", "g*"),
])
def test_bad_input(tmp_path, text, features, what):
    (tmp_path / "in.csv").write_text(text)
    r = run_cmd([BIN, "reps", "--return", "R", "--features", features, "-i", str(tmp_path / "in.csv"),
                 "-o", str(tmp_path / "p.csv"), "--summary", str(tmp_path / "s.csv")],
                capture_output=True, text=True, env=ENV, timeout=30)
    assert r.returncode in (1, 2), (r.returncode, r.stderr)
    assert len(r.stderr.strip().splitlines()) == 1 and what in r.stderr, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.csv"]


def test_constant_returns(tmp_path):
    rng = np.random.default_rng(1)
    phi = rng.normal(size=(20, 3))
    q = rng.uniform(0.5, 2.0, size=20)
    p, s = run_c(tmp_path, np.full(20, 3.25), q, phi, 0.5)
    assert s["status"] == "unreachable" and s["path"] == "constant"
    assert np.abs(p - q / q.sum()).max() <= 1e-15


def test_equal_features_are_plain_reps(tmp_path):
    rng = np.random.default_rng(2)
    R = rng.normal(size=30)
    p0, s0 = run_c(tmp_path, R, None, np.zeros((30, 0)), 0.3)
    p, s = run_c(tmp_path, R, None, np.full((30, 2), 7.5), 0.3)
    assert s["status"] == s0["status"] == "active" and int(s["rank"]) == 0
    assert np.array_equal(p, p0)


@pytest.mark.parametrize("seed", range(5))
def test_wide_features_with_offsets(tmp_path, seed):
    rng = np.random.default_rng(10 + seed)
    n = 12
    phi = 1e7 + rng.normal(size=(n, 5 * n))
    q = rng.uniform(0.5, 2.0, size=n)
    p, s = run_c(tmp_path, rng.normal(size=n), q, phi, 0.1)
    assert s["status"] == "unreachable" and float(s["residual_rel"]) <= 1e-9
    assert np.abs(p - q / q.sum()).max() <= 1e-8


@pytest.mark.parametrize("delta", [0.0, 1e-12, 1e-9])
def test_duplicate_column(tmp_path, delta):
    """An exact duplicate changes nothing; one off by 1e-12 or 1e-9 of its
    spread is a constraint of its own, but a weak one: the answer must be
    certified, on the original columns."""
    rng = np.random.default_rng(3)
    n = 60
    phi = rng.normal(size=(n, 2))
    R = np.sin(phi[:, 0]) + rng.normal(size=n) * 0.3
    p0, s0 = run_c(tmp_path, R, None, phi, 0.5)
    dup = np.c_[phi, phi[:, 1] + delta * rng.normal(size=n)]
    p, s = run_c(tmp_path, R, None, dup, 0.5)
    assert s["status"] == "active" and float(s["kl_gap"]) <= 1e-9 and float(s["residual_rel"]) <= 1e-9
    if delta == 0.0:
        assert np.abs(p - p0).max() <= 1e-9
