"""The Python package (python/poolreps) against the CLI on seeded random
inputs: the same C code runs behind both, so every number must be equal bit
for bit (the CLI writes the shortest decimal that reads back exactly). Also
bad inputs, the Gymnasium environment, threads and memory.

`make check` sets POOLREPS_LIB to the library it built; without it the
package finds build/rel/libpoolreps.so.0 of this checkout."""
import csv
import io
import os
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from conftest import ROOT, run_poolreps, run_cmd

sys.path.insert(0, str(ROOT / "python"))
import poolreps  # noqa: E402

# make check SAN=1 runs this file with the sanitizer runtimes preloaded
UNDER_ASAN = "libasan" in os.environ.get("LD_PRELOAD", "")


def fmt(v):
    return repr(float(v))


def write_csv(path, header, rows):
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        for r in rows:
            f.write(",".join(fmt(v) for v in r) + "\n")


def run_ok(args, stdin=None):
    """Run poolreps and assert it succeeded; returns its stdout as text."""
    p = run_poolreps(args, input=stdin.encode() if stdin is not None else None)
    assert p.returncode == 0, p.stderr.decode()
    return p.stdout.decode()


def cli(args, stdin=None):
    """Run poolreps; return its output CSV as (header, float array)."""
    return read_csv_text(run_ok(args, stdin))


def read_csv_text(text):
    rows = list(csv.reader(io.StringIO(text)))
    return rows[0], np.array([[float(x) for x in r] for r in rows[1:]]).reshape(-1, len(rows[0]))


def read_csv(path):
    return read_csv_text(Path(path).read_text())


def cli_error(args, stdin=None):
    """The CLI's one-line message for a failing command, without 'poolreps: '."""
    p = run_poolreps(args, input=stdin.encode() if stdin is not None else None)
    assert p.returncode != 0
    lines = p.stderr.decode().splitlines()
    assert len(lines) == 1 and lines[0].startswith("poolreps: ")
    return lines[0][len("poolreps: "):]


def sets_args(keys):
    out = []
    for k, v in keys.items():
        out += ["--set", f"{k}={v}"]
    return out


# ---- shoot -------------------------------------------------------------------

def random_states(rng, n, nballs):
    """Valid start states of nballs balls anywhere on the table, drawn by the
    library (start boxes = the whole table)."""
    env = poolreps.PocketEnv(set={"table.balls": nballs,
                                  "start.cue_box": "-0.485,0.485,-0.235,0.235",
                                  "start.reward_box": "-0.485,0.485,-0.235,0.235"})
    return env.reset_batch(n, seed=int(rng.integers(1 << 32)))[0]


def shoot_cli(balls, actions, keys):
    nb = balls.shape[1] // 2
    head = [f"{c}{i}" for i in range(nb) for c in "xy"] + ["vx", "vy"]
    text = ",".join(head) + "\n" + "".join(
        ",".join(fmt(v) for v in np.r_[b, a]) + "\n" for b, a in zip(balls, actions))
    return cli(["shoot", *sets_args(keys)], text)


@pytest.mark.parametrize("seed,nballs,mode,n", [(1, 2, "event", 400), (2, 3, "event", 300),
                                               (3, 6, "event", 200), (4, 2, "stepped", 40),
                                               (5, 4, "stepped", 20)])
def test_shoot_equals_the_cli(seed, nballs, mode, n):
    rng = np.random.default_rng(seed)
    balls = random_states(rng, n, nballs)
    actions = rng.normal(0, 0.6, (n, 2))
    actions[:5] = 0  # a shot that does not move
    keys = {"reward.miss_penalty": 2, "table.friction": 0.3} if seed % 2 else {}
    keys["table.balls"] = nballs  # as for the command: validation counts table.balls
    keys["table.reward_balls"] = min(2, nballs - 1)
    keys["sim.mode"] = mode
    r = poolreps.shoot(balls, actions, mode=mode, set=keys)
    head, ref = shoot_cli(balls, actions, keys)
    col = {h: ref[:, i] for i, h in enumerate(head)}
    for b in range(nballs):
        assert np.array_equal(r["final"][:, b, 0], col[f"x{b}"])
        assert np.array_equal(r["final"][:, b, 1], col[f"y{b}"])
        assert np.array_equal(r["pocket"][:, b], col[f"pocket{b}"])
    for k in ("hit", "min_gap", "reward", "t_end", "events"):
        assert np.array_equal(r[k], col[k]), k
    assert r["final"].shape == (n, nballs, 2) and r["hit"].dtype == np.bool_


def test_shoot_takes_any_layout_and_dtype():
    rng = np.random.default_rng(9)
    balls = random_states(rng, 50, 2)
    actions = rng.normal(0, 0.3, (50, 2))
    ref = poolreps.shoot(balls, actions)
    fortran = poolreps.shoot(np.asfortranarray(balls), actions[::1].T.copy().T)
    strided = poolreps.shoot(np.repeat(balls, 2, axis=0)[::2], actions.astype(np.float32))
    for k in ref:
        assert np.array_equal(ref[k], fortran[k])
    assert np.array_equal(strided["final"].shape, ref["final"].shape)
    ints = poolreps.shoot(np.array([[-250, 0, 100, 0]]) / 1000, np.array([[1, 0]]))
    assert ints["hit"][0]
    empty = poolreps.shoot(np.zeros((0, 4)), np.zeros((0, 2)))
    assert empty["final"].shape == (0, 2, 2)


@pytest.mark.parametrize("balls,actions,msg", [
    (np.zeros((3, 3)), np.zeros((3, 2)), "balls: expected 2 columns per ball"),
    (np.zeros(4), np.zeros((1, 2)), "balls: expected a 2-D array"),
    ([[-0.25, 0, 0.1, 0]], [[0, 0]] * 2, "actions: expected 1 rows"),
    ([[-0.25, 0, 0.1, 0]] * 2 + [[-0.25, 0, np.inf, 0]], [[0, 0]] * 3,
     "row 2: ball 1: position is not finite"),
    ([[-0.25, 0, 0.1, 0]] * 2, [[0, 0], [np.nan, 0]], "row 1: action: velocity is not finite"),
    ([[-0.25, 0, 0.1, 0]], [[0, 0], [0, 0]], "actions: expected 1 rows"),
    ([[-0.25, 0, 0.1, 0]], [[0, 0, 0]], "actions: expected 2 columns"),
    ([["a", "b", "c", "d"]], [[0, 0]], "balls: expected real numbers"),
    ([[-0.25, 0, 0.1, 0]], [[1j, 0]], "actions: expected real numbers"),
])
def test_shoot_rejects_bad_arrays(balls, actions, msg):
    with pytest.raises(ValueError) as e:
        poolreps.shoot(balls, actions)
    assert msg in str(e.value)


@pytest.mark.parametrize("row,keys", [
    ("-0.25,0,0.1,0,20,0", {}),                      # faster than sim.max_speed
    ("-0.25,0,-0.24,0,1,0", {}),                     # overlapping balls
    ("-0.6,0,0.1,0,1,0", {}),                        # off the table
    ("-0.25,0,0.1,0,1,0", {"table.friction": -1}),  # out of range key
    ("-0.25,0,0.1,0,1,0", {"table.frictio": 1}),    # unknown key
    ("-0.25,0,0.1,0,1,0", {"sim.mode": "exact"}),   # not a choice
    ("-0.25,0,0.1,0,1,0", {"table.reward_balls": 2, "table.balls": 3}),  # too few balls
    ("-0.25,0,0.1,0,1,0", {"sim.max_events": 1}),   # numerical: event limit
])
def test_shoot_errors_carry_the_cli_message(row, keys):
    """The same one-line message as the command; rows are numbered from 0
    where the command names <stdin>:LINE (line 2 is row 0)."""
    want = cli_error(["shoot", *sets_args(keys)], "x0,y0,x1,y1,vx,vy\n" + row + "\n")
    v = [float(x) for x in row.split(",")]
    with pytest.raises(ValueError) as e:
        poolreps.shoot([v[:4]], [v[4:]], set=keys)
    assert str(e.value) == want.replace("<stdin>:2: ", "row 0: ").replace("<stdin>:1: ", "")
    if "max_events" in keys:
        assert isinstance(e.value, poolreps.NumericalError)


def test_key_values_of_every_type_reach_the_config():
    # lists, ints, floats and text are formatted as --set would read them
    env = poolreps.PocketEnv(set={"reward.targets": [0, 3], "table.balls": 3,
                                  "table.friction": 0.125, "sim.mode": "stepped"})
    assert env.n_balls == 3
    for bad in ({"table.friction": True}, {"table.friction": object()}, {1: 2}):
        with pytest.raises(ValueError):
            poolreps.shoot([[-0.25, 0, 0.1, 0]], [[0, 0]], set=bad)


def test_config_reads_keys_through_the_public_accessors():
    from poolreps import _lib
    cfg = _lib.Config(("reps.epsilon=0.30000000000000004", "sim.mode=stepped"))
    assert cfg.number("reps.epsilon") == 0.1 + 0.2
    assert cfg.number("table.balls") == 2 and cfg.text("sim.mode") == "stepped"
    assert cfg.text("reps.epsilon") == cfg.values()["reps.epsilon"]
    with pytest.raises(ValueError, match="sim.mode: not a number key"):
        cfg.number("sim.mode")
    with pytest.raises(ValueError, match="reps.nope: unknown key"):
        cfg.text("reps.nope")


# ---- forest --------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(6))
def test_forest_equals_the_cli(tmp_path, seed):
    rng = np.random.default_rng(100 + seed)
    n, d, dy = int(rng.integers(30, 400)), int(rng.integers(1, 5)), 1 + seed % 2
    X = rng.normal(size=(n, d)) * rng.uniform(0.01, 100, d) + rng.normal(0, 50, d)
    Y = np.sin(X[:, :1] * 2 / (1 + abs(X[:, :1]))) + rng.normal(0, 0.1, (n, dy))
    if seed == 3:
        X[:, 0] = 1.0  # a constant input column
    w = rng.uniform(0, 2, n) if seed % 3 == 0 else None
    keys = {"trees": int(rng.integers(1, 20)), "n_min": int(rng.integers(2, 30)),
            "cuts": int(rng.integers(1, 12)),
            "replacement": ["with", "without"][seed % 2], "score": ["rvr", "nrvr"][seed // 3],
            "outputs": ["sum", "relative"][seed % 2]}
    Xt = rng.normal(size=(100, d)) * X.std(0) + X.mean(0)
    f = poolreps.Forest(seed=seed * 7, **keys)
    f.fit(X, Y[:, 0] if dy == 1 else Y, sample_weight=w)

    xs = [f"x{j}" for j in range(d)]
    ys = [f"y{k}" for k in range(dy)]
    cols = xs + ys + (["w"] if w is not None else [])
    write_csv(tmp_path / "train.csv", cols, np.column_stack([X, Y] + ([w] if w is not None else [])))
    write_csv(tmp_path / "test.csv", xs, Xt)
    args = ["forest", "--train", tmp_path / "train.csv", "--test", tmp_path / "test.csv",
            "--target", "y*", "--leaves", tmp_path / "leaves.csv", "-o", tmp_path / "pred.csv",
            "-q", "--seed", seed * 7, *sets_args({f"forest.{k}": v for k, v in keys.items()})]
    if w is not None:
        args += ["--weight", "w"]
    run_ok(args)
    _, pred = read_csv(tmp_path / "pred.csv")
    _, leaves = read_csv(tmp_path / "leaves.csv")
    mine = f.predict(Xt)
    assert mine.shape == ((100,) if dy == 1 else (100, dy))
    assert np.array_equal(mine.reshape(100, dy), pred)
    assert np.array_equal(f.apply(Xt), leaves)
    off = f.leaf_offsets
    assert off[0] == 0 and len(off) == keys["trees"] + 1
    phi = f.leaf_features(Xt)
    assert phi.shape == (100, off[-1]) and np.all(phi.sum(1) == keys["trees"])
    assert f.get_params()["forest.trees"] == str(keys["trees"])


def test_forest_bad_inputs():
    X, y = np.random.default_rng(1).normal(size=(20, 2)), np.zeros(20)
    for kw, msg in [({"trees": 0}, "--set: forest.trees: 0 out of range: must be >= 1"),
                    ({"tres": 5}, "--set: forest.tres: unknown key"),
                    ({"score": "best"}, "--set: forest.score: 'best' is not one of rvr|nrvr"),
                    ({"seed": -1}, "--set: experiment.seed: -1 out of range")]:
        with pytest.raises(ValueError) as e:
            poolreps.Forest(**kw)
        assert str(e.value).startswith(msg)
    with pytest.raises(ValueError) as e:
        poolreps.Forest(n_min=0)
    assert str(e.value) == cli_error(["config", "--set", "forest.n_min=0"])
    f = poolreps.Forest(trees=3)
    with pytest.raises(ValueError, match="call fit"):
        f.predict(X)
    with pytest.raises(ValueError, match="sample_weight"):
        f.fit(X, y, sample_weight=np.ones(19))
    with pytest.raises(ValueError, match="weight"):
        f.fit(X, y, sample_weight=-np.ones(20))
    with pytest.raises(ValueError, match=r"X\[3, 1\]: not a finite"):
        Xn = X.copy()
        Xn[3, 1] = np.nan
        f.fit(Xn, y)
    with pytest.raises(ValueError, match="fewer than n_c"):
        poolreps.Forest(n_c=30, n_min=40).fit(X, y)
    f.fit(X, y)
    with pytest.raises(ValueError, match="expected 2 columns"):
        f.predict(np.zeros((4, 3)))


# ---- reps ----------------------------------------------------------------------

REPS_SUMMARY = ("eta", "dual", "kl", "ess", "bound", "residual", "iterations", "kl_gap",
                "residual_rel", "status", "rank", "cond", "path")


@pytest.mark.parametrize("seed", range(8))
def test_reps_equals_the_cli(tmp_path, seed):
    rng = np.random.default_rng(200 + seed)
    n, d = int(rng.integers(5, 300)), (0, 1, 2, 3, 1, 2, 2, 40)[seed]
    if seed == 7:
        n = 40  # one-hot feature per sample: p cannot move off q, KL unreachable
    scale, offset = 10.0 ** rng.uniform(-3, 3), rng.normal(0, 1e3)
    R = offset + scale * rng.normal(size=n)
    phi = rng.normal(size=(n, d))
    if seed == 5:
        phi[:, 1] = phi[:, 0]           # rank-deficient features
    if seed == 6:
        R[:] = 3.0                      # constant returns
    if seed == 7:
        phi = np.eye(n)
    q = rng.uniform(0, 1, n) if seed % 2 else None
    eps = [0.1, 0.5, 1.0, 2.0][seed % 4]
    r = poolreps.reps(R, phi if d else None, epsilon=eps, base=q)

    cols = ["R"] + [f"phi{j}" for j in range(d)] + (["q"] if q is not None else [])
    write_csv(tmp_path / "in.csv", cols, np.column_stack([R, phi] + ([q] if q is not None else [])))
    args = ["reps", "-i", tmp_path / "in.csv", "--return", "R", "--epsilon", eps, "-q",
            "--summary", tmp_path / "s.csv", "-o", tmp_path / "p.csv"]
    if d:
        args += ["--features", "phi*"]
    if q is not None:
        args += ["--base", "q"]
    run_ok(args)
    _, pc = read_csv(tmp_path / "p.csv")
    rows = list(csv.reader(io.StringIO((tmp_path / "s.csv").read_text())))
    head, summary = rows[0], rows[1]
    assert np.array_equal(r["p"], pc[:, 0])
    for h, v in zip(head, summary):
        assert r[h] == (v if h in ("status", "path") else float(v)), h
    assert tuple(head) == REPS_SUMMARY
    assert r["constant"] == (seed == 6)
    assert r["status"] in ("active", "unreachable") and r["bound"] == (r["status"] == "active")
    if seed == 7:
        assert r["bound"] == 0 and r["kl"] < eps and r["status"] == "unreachable"
    assert r["theta"].shape == (d,)
    assert abs(r["p"].sum() - 1) < 1e-12


def test_reps_one_dimensional_features_and_keys():
    rng = np.random.default_rng(3)
    s = rng.uniform(-1, 1, 100)
    R = -(s - 0.3) ** 2 + rng.normal(0, 0.1, 100)
    a = poolreps.reps(R, s, epsilon=0.4)
    b = poolreps.reps(R, s[:, None], set={"reps.epsilon": 0.4})
    assert np.array_equal(a["p"], b["p"]) and abs(a["kl"] - 0.4) <= 1e-6
    c = poolreps.reps(R, s[:, None], set={"epsilon": 0.4})  # bare keys are reps.*
    assert np.array_equal(a["p"], c["p"])


def test_reps_sparse_one_hot_features_agree_with_dense():
    sparse = pytest.importorskip("scipy.sparse")
    rng = np.random.default_rng(4)
    X = rng.uniform(size=(150, 2))
    R = -np.abs(X[:, 0] - 0.5) + rng.normal(0, 0.05, 150)
    f = poolreps.Forest(trees=5, n_min=30).fit(X, R)
    dense = f.leaf_features(X)
    a = poolreps.reps(R, dense, epsilon=0.5)
    b = poolreps.reps(R, sparse.csr_matrix(dense), epsilon=0.5)
    # dense and one-hot paths of the solver: same problem, same certified optimum
    assert a["status"] == b["status"] != "failed"
    if a["bound"]:
        assert abs(a["kl"] - b["kl"]) <= 2e-9
    assert np.abs(a["p"] - b["p"]).max() <= 1e-8 * a["p"].max()


@pytest.mark.parametrize("kw,exc,msg", [
    ({"returns": [1, 2, np.nan]}, ValueError, r"returns\[2\]: not a finite"),
    ({"returns": [[1, 2]]}, ValueError, "returns: expected a 1-D array"),
    ({"returns": []}, ValueError, "returns: empty array"),
    ({"returns": [1, 2, 3], "features": np.ones((2, 1))}, ValueError, "features: expected 3 rows"),
    ({"returns": [1, 2, 3], "base": [1, -1, 1]}, ValueError, r"base\[1\]: base weight must be >= 0"),
    ({"returns": [1, 2, 3], "base": [0, 0, 0]}, ValueError, "base weights"),
    ({"returns": [1, 2, 3], "epsilon": -1}, ValueError,
     r"^--set: reps\.epsilon: -1 out of range: must be >= 1e-12 and <= 1000000$"),
    ({"returns": [1, 2, 3], "epsilon": float("nan")}, ValueError, "reps.epsilon: not a finite"),
])
def test_reps_bad_inputs(kw, exc, msg):
    with pytest.raises(exc, match=msg):
        poolreps.reps(**kw)


def test_reps_uncertified_answer_raises_unless_allowed():
    rng = np.random.default_rng(5)
    R, phi = rng.normal(size=60), rng.normal(size=(60, 3))
    with pytest.raises(poolreps.NumericalError, match="^reps: no certified answer: "):
        poolreps.reps(R, phi, set={"reps.max_iter": 1})
    r = poolreps.reps(R, phi, set={"reps.max_iter": 1, "reps.allow_failed": 1})
    assert r["status"] == "failed" and r["bound"] == 0 and r["reason"]


def test_reps_key_message_equals_the_cli():
    want = cli_error(["config", "--set", "reps.max_iter=0"])
    with pytest.raises(ValueError) as e:
        poolreps.reps([1.0, 2.0], set={"reps.max_iter": 0})
    assert str(e.value) == want


# ---- policy --------------------------------------------------------------------

def policy_problem(seed):
    rng = np.random.default_rng(300 + seed)
    n, ds, da = int(rng.integers(60, 300)), 1 + seed % 2, 1 + (seed // 2) % 2
    S = rng.uniform(-1, 1, (n, ds))
    A = S[:, :1] @ np.ones((1, da)) * 0.5 + rng.normal(0, 0.2, (n, da))
    Y = A * 0.3 + rng.normal(0, 0.01, (n, da))  # stands in for final reward-ball positions
    w = rng.exponential(1, n)
    w[:5] = 0
    Q = rng.uniform(-1.2, 1.2, (40, ds))
    return rng, S, A, Y, w, Q


@pytest.mark.parametrize("seed", range(6))
def test_policy_equals_the_cli(tmp_path, seed):
    rng, S, A, Y, w, Q = policy_problem(seed)
    ds, da = S.shape[1], A.shape[1]
    keys = {"n_min": int(rng.integers(5, 60)), "trees": int(rng.integers(1, 12)),
            "cov": ["query", "residual"][seed % 2], "target": ["action", "reward_state"][seed % 3 == 2]}
    pol = poolreps.Policy(seed=seed, **keys)
    pol.fit(S, A, w, target=Y if keys["target"] == "reward_state" else None)
    mean, cov, status = pol.mean_cov(Q, status=True)
    draws = pol.sample(Q, seed, n=3)

    sc, ac, yc = ([f"{p}{j}" for j in range(k)] for p, k in (("s", ds), ("a", da), ("y", da)))
    write_csv(tmp_path / "train.csv", sc + ac + yc + ["w"], np.column_stack([S, A, Y, w]))
    write_csv(tmp_path / "q.csv", sc, Q)
    args = ["policy", "--train", tmp_path / "train.csv", "--state", "s*", "--action", "a*",
            "--weight", "w", "-i", tmp_path / "q.csv", "-q", "--seed", seed,
            *sets_args({f"policy.{k}": v for k, v in keys.items()})]
    if keys["target"] == "reward_state":
        args += ["--target", "y*"]
    head, ref = cli(args)
    col = {h: ref[:, i] for i, h in enumerate(head)}
    for j in range(da):
        assert np.array_equal(mean[:, j], col[f"mean_a{j}"])
        for l in range(j, da):
            assert np.array_equal(cov[:, j, l], col[f"cov_{j}_{l}"])
            assert np.array_equal(cov[:, l, j], col[f"cov_{j}_{l}"])
    assert np.array_equal(status, col["status"])

    for k, mine in ((3, draws), (1, pol.sample(Q, seed))):
        head, ref = cli(args + ["--sample", k])
        col = {h: ref[:, i] for i, h in enumerate(head)}
        assert mine.shape == ((40, 3, da) if k == 3 else (40, da))
        for j in range(da):
            assert np.array_equal(mine[..., j].ravel(), col[f"a{j}"])


def mvn_logpdf(a, mean, cov):
    """log N(a | mean, cov), written from the density (not the library's code)."""
    out = np.empty(len(a))
    for i in range(len(a)):
        diff = a[i] - mean[i]
        sign, logdet = np.linalg.slogdet(cov[i])
        assert sign > 0
        out[i] = -0.5 * (len(diff) * np.log(2 * np.pi) + logdet
                         + diff @ np.linalg.solve(cov[i], diff))
    return out


@pytest.mark.parametrize("seed", range(4))
def test_policy_log_prob_is_the_gaussian_density(seed):
    rng, S, A, _, w, Q = policy_problem(seed)
    pol = poolreps.Policy(n_min=20).fit(S, A, w)
    mean, cov = pol.mean_cov(Q)
    acts = mean + rng.normal(0, 0.3, mean.shape)
    lp = pol.log_prob(Q, acts)
    ref = mvn_logpdf(acts, mean, cov)
    # tolerance: two factorisations of the same symmetric matrix (the library
    # keeps its eigen-decomposition, the reference solves with the rounded
    # matrix) differ by about cond(cov) * eps relative in the quadratic form;
    # 64 * eps * cond * |log p| plus 1e-9 (1e-9 relative when cond is modest)
    cond = np.linalg.cond(cov)
    tol = 64 * np.finfo(float).eps * cond * np.abs(ref) + 1e-9 * (1 + np.abs(ref))
    assert np.all(np.abs(lp - ref) <= tol)
    assert np.isfinite(lp).all()


def test_policy_draws_follow_mean_and_cov():
    rng, S, A, _, w, Q = policy_problem(1)
    pol = poolreps.Policy(n_min=20).fit(S, A, w)
    mean, cov = pol.mean_cov(Q[:1])
    d = pol.sample(Q[:1], 11, n=20000)[0]
    # 20000 draws: the sample mean is within 5 standard errors
    assert np.all(np.abs(d.mean(0) - mean[0]) < 5 * np.sqrt(np.diag(cov[0]) / 20000))
    assert np.allclose(np.cov(d.T).reshape(cov[0].shape), cov[0], rtol=0.1, atol=1e-6)


def test_policy_bad_inputs():
    _, S, A, Y, w, Q = policy_problem(0)
    p = poolreps.Policy(n_min=20)
    for args, msg in [((S, A[:-1], w), "A: expected"), ((S, A, w[:-1]), "w: expected"),
                      ((S, A, -w), r"w\[\d+\]: weight must be >= 0"),
                      ((S, A, 0 * w), "w: weights are all zero"),
                      ((S[:, 0], A, w), "S: expected a 2-D array")]:
        with pytest.raises(ValueError, match=msg):
            p.fit(*args)
    with pytest.raises(ValueError, match="reward_state needs"):
        poolreps.Policy(target="reward_state").fit(S, A, w)
    with pytest.raises(ValueError, match="call fit"):
        p.mean_cov(Q)
    p.fit(S, A, None)
    with pytest.raises(ValueError, match="columns"):
        p.mean_cov(np.zeros((3, S.shape[1] + 1)))
    with pytest.raises(ValueError, match="rows"):
        p.log_prob(Q, np.zeros((len(Q) + 1, A.shape[1])))
    with pytest.raises(ValueError, match="seed"):
        p.sample(Q, -1)
    with pytest.raises(ValueError) as e:
        poolreps.Policy(lambda_=1)
    assert str(e.value) == cli_error(["config", "--set", "policy.lambda_=1"])


# ---- PocketEnv -------------------------------------------------------------------

def test_env_starts_from_experiment_3s_region():
    env = poolreps.PocketEnv()
    states, _ = env.reset_batch(4000, seed=5)
    assert states.shape == (4000, 4)
    assert np.all(states[:, 0] == -0.25) and np.all(states[:, 1] == 0)
    x, y = states[:, 2], states[:, 3]
    assert x.min() >= 0.05 and x.max() <= 0.15 and y.min() >= -0.1 and y.max() <= 0.1
    # uniform on the box: means within 4 standard errors, spread to the edges
    assert abs(x.mean() - 0.1) < 4 * 0.1 / np.sqrt(12 * 4000)
    assert abs(y.mean()) < 4 * 0.2 / np.sqrt(12 * 4000)
    assert x.max() - x.min() > 0.099 and y.max() - y.min() > 0.198
    o1, _ = env.reset(seed=8)
    o2, _ = env.reset(seed=8)
    o3, _ = env.reset()
    assert np.array_equal(o1, o2) and not np.array_equal(o2, o3)
    assert env.observation_space.contains(o1)


def test_env_step_is_the_simulator():
    env = poolreps.PocketEnv(set={"table.friction": 0.3})
    rng = np.random.default_rng(6)
    states, _ = env.reset_batch(300, seed=1)
    actions = rng.normal(0, 0.4, (300, 2))
    actions[0] = [30, 0]                                  # faster than sim.max_speed
    obs, rew, term, trunc, info = env.step_batch(states, actions)
    clipped = actions.copy()
    clipped[0] = [10 * (1 - 2.0**-50), 0]
    ref = poolreps.shoot(states, clipped, set={"experiment.name": "exp3", "table.friction": 0.3})
    assert np.array_equal(obs, ref["final"].reshape(300, 4))
    assert np.array_equal(rew, ref["reward"]) and term.all() and not trunc.any()
    assert info["clipped"][0] and not info["clipped"][1:].any()
    for i in (1, 2, 3):
        env.reset(options={"state": states[i]})
        o, r, t, tr, inf = env.step(actions[i])
        assert np.array_equal(o, obs[i]) and r == rew[i] and t is True and tr is False
        assert inf["hit"] == info["hit"][i]
    with pytest.raises(RuntimeError, match="reset"):
        env.step(actions[0])
    with pytest.raises(ValueError, match="ball"):
        env.reset(options={"state": [-0.25, 0, -0.25, 0.01]})
    with pytest.raises(ValueError, match="action"):
        env.reset(seed=1)
        env.step([np.nan, 0])


def test_env_spaces():
    env = poolreps.PocketEnv(set={"table.balls": 3, "sim.max_speed": 4})
    assert env.observation_space.shape == (6,) and env.action_space.shape == (2,)
    assert np.array_equal(env.action_space.high, [4, 4])
    assert np.array_equal(env.observation_space.high, [0.5, 0.25] * 3)
    obs, _ = env.reset(seed=2)
    assert env.observation_space.contains(obs)
    obs, *_ = env.step(env.action_space.sample())
    assert env.observation_space.contains(obs)


def test_env_passes_gymnasiums_checker():
    gymnasium = pytest.importorskip("gymnasium")
    from gymnasium.utils.env_checker import check_env
    env = poolreps.PocketEnv()
    assert isinstance(env.action_space, gymnasium.spaces.Box)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, skip_render_check=True)
    # the one advice it may give: actions are velocities in m/s, not scaled to [-1, 1]
    other = [str(w.message) for w in caught if "symmetric and normalized" not in str(w.message)]
    assert other == []


# ---- threads and memory ----------------------------------------------------------

def test_objects_are_safe_to_share_between_threads():
    rng = np.random.default_rng(7)
    X = rng.normal(size=(400, 3))
    f = poolreps.Forest(trees=10).fit(X, X[:, 0])
    _, S, A, _, w, Q = policy_problem(2)
    pol = poolreps.Policy(n_min=20).fit(S, A, w)
    env = poolreps.PocketEnv()
    balls, _ = env.reset_batch(2000, seed=3)
    acts = rng.normal(0, 0.5, (2000, 2))
    ref = (f.predict(X), pol.mean_cov(Q)[1], poolreps.shoot(balls, acts)["reward"])
    bad = []

    def work():
        for _ in range(20):
            got = (f.predict(X), pol.mean_cov(Q)[1], poolreps.shoot(balls, acts)["reward"])
            bad.extend(i for i in range(3) if not np.array_equal(got[i], ref[i]))
            f2 = poolreps.Forest(trees=10).fit(X, X[:, 0])  # the same seed: the same forest
            bad.extend([9] if not np.array_equal(f2.predict(X), ref[0]) else [])

    threads = [threading.Thread(target=work) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert bad == []


def test_long_calls_release_the_gil():
    env = poolreps.PocketEnv()
    balls, _ = env.reset_batch(100000, seed=4)
    acts = np.random.default_rng(4).normal(0, 0.1, (100000, 2))
    big_b, big_a = np.tile(balls, (10, 1)), np.tile(acts, (10, 1))
    ticks, span = [], []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(time.monotonic())
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    time.sleep(0.05)
    t0 = time.monotonic()
    poolreps.shoot(big_b, big_a)  # 1 M shots: a few tenths of a second
    span = (t0, time.monotonic())
    stop.set()
    t.join()
    inside = [x for x in ticks if span[0] + 0.02 < x < span[1] - 0.02]
    # with the GIL held the other thread could not run at all during the call
    assert span[1] - span[0] > 0.1 and len(inside) >= 10


def rss_kib():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") // 1024


@pytest.mark.skipif(UNDER_ASAN, reason="AddressSanitizer keeps freed memory in quarantine")
def test_no_memory_growth_over_10000_calls():
    rng = np.random.default_rng(8)
    X = rng.normal(size=(30, 2))
    y = X[:, 0] + rng.normal(0, 0.1, 30)
    S, A, w = X[:, :1], rng.normal(size=(30, 2)), rng.uniform(0.1, 1, 30)
    env = poolreps.PocketEnv()
    balls = env.reset_batch(4, seed=1)[0]

    def calls():
        poolreps.shoot(balls, [[0.3, 0.01]] * 4)
        f = poolreps.Forest(trees=3, n_min=5).fit(X, y)
        f.predict(X[:3])
        f.apply(X[:3])
        poolreps.reps(y, X, epsilon=0.5)
        p = poolreps.Policy(trees=2, n_min=10).fit(S, A, w)
        p.mean_cov(S[:2])
        p.sample(S[:2], 1)
        p.log_prob(S[:2], A[:2])
        env.reset()
        env.step([0.2, 0.0])
        for bad in (lambda: poolreps.shoot([[0, 0, 0, 0]], [[0, 0]]),
                    lambda: poolreps.Forest(trees=0)):
            try:
                bad()
            except ValueError:
                pass

    for _ in range(1000):
        calls()
    before = rss_kib()
    for _ in range(10000):
        calls()
    grown = rss_kib() - before
    # a leak of one small C object per call would be 10000 x >= 200 bytes = 2 MiB
    assert grown < 1024, f"resident memory grew by {grown} KiB"


@pytest.mark.skipif(not UNDER_ASAN, reason="runs under make check SAN=1 (sanitizers preloaded)")
def test_leak_checker_sees_the_library():
    """Under the sanitizers, a library object the package forgot to free is
    reported, whatever tests/lsan-python.supp hides of the interpreter's."""
    code = ("import numpy as np, poolreps, poolreps.core as c\n"
            "c.lib.pr_reps_result_free = lambda p: None\n"
            "poolreps.reps(np.arange(20.0), np.ones((20, 1)))\n")
    p = run_cmd([sys.executable, "-c", code], capture_output=True,
                                     text=True, env=dict(os.environ,
                                                         PYTHONPATH=str(ROOT / "python")))
    assert p.returncode != 0 and "Direct leak" in p.stderr and "pr_reps_solve" in p.stderr


def test_the_calls_in_docs_python_md_run():
    text = (ROOT / "docs/python.md").read_text()
    code = text.split("```python\n")[1].split("```")[0]
    ns = {}
    exec(compile(code, "docs/python.md", "exec"), ns)
    assert ns["r"]["pocket"][0, 1] == 2 and ns["r"]["reward"][0] == 0  # the README's shot
    assert ns["mean"].shape == (5, 2) and abs(ns["w"]["kl"] - 0.5) <= 1e-6


# ---- the example -----------------------------------------------------------------

def test_reps_loop_example_learns():
    env = dict(os.environ, PYTHONPATH=str(ROOT / "python"))
    p = run_cmd([sys.executable, str(ROOT / "examples/python/reps_loop.py")],
                                     capture_output=True, text=True, env=env, timeout=600)
    assert p.returncode == 0, p.stderr
    rows = [l.split() for l in p.stdout.splitlines() if l.startswith("iteration")]
    first, last = float(rows[0][3]), float(rows[-1][3])
    assert len(rows) >= 10
    # the initial policy N(0, 0.1^2 I) scores about -2.8; learning gains at least 0.5
    assert last > first + 0.5, p.stdout


def test_forest_weight_scale_changes_no_bit():
    """sample_weight times 1e-170 or 1e160 gives the same predictions, bit
    for bit, as the command's --weight (test_forest_cli.py)."""
    rng = np.random.default_rng(8)
    X = rng.uniform(size=(200, 2))
    y = X[:, 0] ** 2 + rng.normal(0, 0.1, 200)
    w = rng.exponential(size=200)
    Xt = rng.uniform(size=(50, 2))
    preds = [poolreps.Forest(seed=3).fit(X, y, sample_weight=w * s).predict(Xt).tobytes()
             for s in (1.0, 1e-170, 1e160)]
    assert preds[0] == preds[1] == preds[2]


def test_policy_failure_names_its_row():
    """A numerical failure at one query state (1e155 on training states in
    [-1, 1]) names the row and the state's value, as the command names its
    line (test_ref_policy.py)."""
    rng = np.random.default_rng(1)
    S = rng.uniform(-1, 1, (200, 2))
    A = S @ np.array([[1.0, 0.5], [0.2, -1.0]]) + 0.1 * rng.normal(size=(200, 2))
    p = poolreps.Policy(seed=1).fit(S, A, rng.uniform(size=200))
    with pytest.raises(poolreps.NumericalError, match=r"^row 1: state 1 = 1e\+155: policy: "):
        p.mean_cov(np.array([[0.1, 0.2], [0.0, 1e155]]))
