"""End-to-end tests of `poolreps reps` and `poolreps policy`.

The binary is $POOLREPS (default ./poolreps at the repository root); run
with LC_ALL=C.
"""
import csv
import math
import os
import random
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import run_cmd

ROOT = Path(__file__).resolve().parent.parent
BIN = os.environ.get("POOLREPS", str(ROOT / "poolreps"))


def run(args, cwd):
    env = dict(os.environ, LC_ALL="C")
    return run_cmd([BIN] + [str(a) for a in args], capture_output=True, text=True,
                          cwd=cwd, env=env, timeout=60)


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def write_rows(path, header, rows):
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        for r in rows:
            f.write(",".join(x if isinstance(x, str) else repr(float(x)) for x in r) + "\n")
    return path


def reps_table(tmp_path, n=40, seed=1, scale=1.0, shift=0.0):
    rnd = random.Random(seed)
    rows = []
    for _ in range(n):
        s = rnd.uniform(-1, 1)
        ret = -2 * s * s + s + rnd.gauss(0, 0.5)
        rows.append([scale * ret + shift, s, s * s, 0.5 + rnd.random()])
    return write_rows(tmp_path / f"reps_{seed}_{scale}_{shift}.csv", ["R", "phi_a", "phi_b", "q"], rows)


def ok(r):
    assert r.returncode == 0, r.stderr
    return r


def fails(r, *words):
    """Non-zero exit, one line on stderr naming every word."""
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


def no_files(tmp_path, *names):
    for n in names:
        assert not (tmp_path / n).exists()
    left = [p.name for p in tmp_path.iterdir() if ".tmp." in p.name]
    assert not left, left


# ---- reps ----------------------------------------------------------------

def test_reps_weights_and_summary(tmp_path):
    inp = reps_table(tmp_path)
    ok(run(["reps", "--return", "R", "--features", "phi*", "--base", "q", "-i", inp,
            "-o", "p.csv", "--summary", "s.csv", "--epsilon", "0.7"], tmp_path))
    p = [float(r["p"]) for r in read_csv(tmp_path / "p.csv")]
    assert len(p) == 40 and all(x > 0 for x in p)
    assert abs(sum(p) - 1) < 1e-12
    s = read_csv(tmp_path / "s.csv")
    assert len(s) == 1
    for col in ("eta", "dual", "kl", "ess", "bound"):
        assert col in s[0]
    s = s[0]
    assert list(s.keys()) == ["eta", "dual", "kl", "ess", "bound", "residual", "iterations",
                              "kl_gap", "residual_rel", "status", "rank", "cond", "path"]
    assert int(s["bound"]) == 1 and s["status"] == "active"
    assert int(s["rank"]) >= 1 and float(s["cond"]) >= 1.0 and s["path"] in ("joint", "search")
    assert float(s["kl_gap"]) <= 1e-9 and float(s["residual_rel"]) <= 1e-9
    assert abs(float(s["kl"]) - 0.7) <= 1e-6
    assert abs(float(s["ess"]) - 1 / sum(x * x for x in p)) < 1e-6
    # KL recomputed from the weights and the normalised base weights
    q = [float(r["q"]) for r in read_csv(inp)]
    kl = sum(pi * math.log(pi / (qi / sum(q))) for pi, qi in zip(p, q))
    assert abs(kl - 0.7) <= 1e-6
    # feature expectations match under p and q
    rows = read_csv(inp)
    for c in ("phi_a", "phi_b"):
        ep = sum(pi * float(r[c]) for pi, r in zip(p, rows))
        eq = sum(qi * float(r[c]) for qi, r in zip(q, rows)) / sum(q)
        assert abs(ep - eq) < 1e-9


def test_reps_prefix_equals_list_and_set_equals_option(tmp_path):
    inp = reps_table(tmp_path)
    ok(run(["reps", "--return", "R", "--features", "phi*", "-i", inp, "-o", "a.csv"], tmp_path))
    ok(run(["reps", "--return", "R", "--features", "phi_a,phi_b", "-i", inp, "-o", "b.csv",
            "--set", "reps.epsilon=0.5"], tmp_path))
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()


def test_reps_no_features_stdin_stdout(tmp_path):
    inp = reps_table(tmp_path)
    r = run_cmd([BIN, "reps", "--return", "R"], input=inp.read_text(), capture_output=True,
                       text=True, cwd=tmp_path, env=dict(os.environ, LC_ALL="C"), timeout=60)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert lines[0] == "p" and len(lines) == 41


@pytest.mark.parametrize("scale,shift", [(1e-6, 0.0), (1e8, 0.0), (1.0, 1e6), (3.0, -7.0)])
def test_reps_affine_invariance(tmp_path, scale, shift):
    ok(run(["reps", "--return", "R", "--features", "phi*", "--base", "q",
            "-i", reps_table(tmp_path), "-o", "ref.csv"], tmp_path))
    ok(run(["reps", "--return", "R", "--features", "phi*", "--base", "q",
            "-i", reps_table(tmp_path, scale=scale, shift=shift), "-o", "x.csv"], tmp_path))
    ref = [float(r["p"]) for r in read_csv(tmp_path / "ref.csv")]
    got = [float(r["p"]) for r in read_csv(tmp_path / "x.csv")]
    for a, b in zip(ref, got):
        assert abs(a - b) <= 1e-8 * a


def test_reps_constant_returns_uniform(tmp_path):
    inp = write_rows(tmp_path / "c.csv", ["R", "phi"], [[-0.3, i / 10] for i in range(10)])
    r = ok(run(["reps", "--return", "R", "--features", "phi", "-i", inp, "-o", "p.csv",
                "--summary", "s.csv"], tmp_path))
    assert "KL bound unreachable" in r.stderr and "all returns are equal" in r.stderr
    p = [float(x["p"]) for x in read_csv(tmp_path / "p.csv")]
    assert all(abs(x - 0.1) < 1e-15 for x in p)
    s = read_csv(tmp_path / "s.csv")[0]
    assert int(s["bound"]) == 0 and float(s["kl"]) == 0.0
    assert s["status"] == "unreachable" and float(s["eta"]) == 0.0


def test_reps_rich_features_bound_inactive(tmp_path):
    # one indicator feature per sample: p is pinned to q, KL cannot reach eps
    n = 12
    rnd = random.Random(3)
    rows = [[rnd.gauss(0, 1)] + [1.0 if j == i else 0.0 for j in range(n)] for i in range(n)]
    inp = write_rows(tmp_path / "rich.csv", ["R"] + [f"leaf{j}" for j in range(n)], rows)
    r = ok(run(["reps", "--return", "R", "--features", "leaf*", "-i", inp, "-o", "p.csv",
                "--summary", "s.csv"], tmp_path))
    assert "KL bound unreachable" in r.stderr
    s = read_csv(tmp_path / "s.csv")[0]
    assert int(s["bound"]) == 0 and float(s["kl"]) < 0.5
    assert s["status"] == "unreachable" and float(s["eta"]) == 0.0
    assert float(s["residual_rel"]) <= 1e-9
    assert all(abs(float(x["p"]) - 1 / n) < 1e-12 for x in read_csv(tmp_path / "p.csv"))


def test_benchmark_uncertified_solve_stops_or_is_counted(tmp_path):
    """A REPS answer that cannot be certified (a dual budget of one
    evaluation) stops a benchmark with one line, unless reps.allow_failed =
    1, which records it: failed 1 per row, failed_frac in the summary."""
    sets = ["--set", "experiment.repetitions=1", "--set", "bench.iterations=3",
            "--set", "reps.max_iter=1"]
    fails(run([ROOT / "data" / "quadratic.ini", "-q",
               "-o", "b"] + sets, tmp_path), "REPS answer not certified", "reps.allow_failed")
    ok(run([ROOT / "data" / "quadratic.ini", "-q", "-o", "b2", "--set", "reps.allow_failed=1"]
           + sets, tmp_path))
    curve = read_csv(tmp_path / "b2" / "bench_curve.csv")
    assert [(r["bound"], r["unreachable"], r["failed"]) for r in curve] == [("0", "0", "1")] * 3
    assert all(r["failed_frac"] == "1" for r in read_csv(tmp_path / "b2" / "bench_summary.csv"))


def test_reps_bad_input(tmp_path):
    good = reps_table(tmp_path)
    args = ["reps", "--return", "R", "--features", "phi*", "--base", "q", "-o", "p.csv",
            "--summary", "s.csv", "-i"]
    fails(run(["reps", "--return", "nope", "-i", good, "-o", "p.csv"], tmp_path), "nope")
    fails(run(["reps", "--return", "R", "--features", "phi_a,zeta", "-i", good, "-o", "p.csv"],
              tmp_path), "zeta")
    fails(run(["reps", "--return", "R", "--features", "psi*", "-i", good, "-o", "p.csv"],
              tmp_path), "psi")
    fails(run(["reps", "--return", "R", "--base", "w", "-i", good, "-o", "p.csv"], tmp_path), "'w'")
    rows = read_csv(good)
    text = good.read_text().splitlines()
    # NaN in the data: file, line and column
    bad = text[:]
    bad[5] = "nan," + ",".join(bad[5].split(",")[1:])
    (tmp_path / "nan.csv").write_text("\n".join(bad) + "\n")
    fails(run(args + ["nan.csv"], tmp_path), "nan.csv:6", "R")
    # a negative base weight
    bad = text[:]
    f = bad[3].split(",")
    f[3] = "-0.5"
    bad[3] = ",".join(f)
    (tmp_path / "neg.csv").write_text("\n".join(bad) + "\n")
    fails(run(args + ["neg.csv"], tmp_path), "neg.csv:4", "'q'", ">= 0")
    # all-zero base weights
    zero = write_rows(tmp_path / "zero.csv", ["R", "phi_a", "phi_b", "q"],
                      [[r["R"], r["phi_a"], r["phi_b"], "0"] for r in rows])
    fails(run(args + [zero], tmp_path), "zero.csv", "all zero")
    # epsilon <= 0, from the option and from the configuration
    fails(run(args + [good, "--epsilon", "0"], tmp_path), "epsilon")
    fails(run(args + [good, "--epsilon", "-1"], tmp_path), "epsilon")
    fails(run(args + [good, "--set", "reps.epsilon=0"], tmp_path), "reps.epsilon")
    # an empty table
    (tmp_path / "empty.csv").write_text("R,phi_a,phi_b,q\n")
    fails(run(args + ["empty.csv"], tmp_path), "empty.csv")
    no_files(tmp_path, "p.csv", "s.csv")


def dense_table(path, rng, n, d):
    """A wide dense problem (the rank-k update's path: d >= 32), with a
    feature offset, mixed scales and heavy-tailed returns."""
    phi = rng.normal(size=(n, d)) * 10.0 ** rng.uniform(-3, 3, size=d) + rng.choice([0, 1e4])
    R = phi[:, :3] @ rng.normal(size=3) + rng.standard_t(2, size=n)
    return write_rows(path, ["R"] + [f"phi{j}" for j in range(d)], np.c_[R, phi])


@pytest.mark.parametrize("seed", range(6))
def test_reps_threads_give_the_same_bytes(tmp_path, seed):
    """--threads splits the dense Hessian's rank-k update: weights and
    summary byte for byte those of one thread, for any count (the rows of
    the Hessian split unevenly for most of them; 0 is one per CPU, and a
    count above the CPUs runs one thread per CPU: tests/test_syrk.c checks
    the kernel on every split into 1 to 7 parts). The problems are large
    enough (n d^2 / 2 >= 2e6 multiply-adds per Hessian, d rounded up to
    16) for the threads to start."""
    rng = np.random.default_rng(900 + seed)
    d = int(rng.integers(32, 70))
    nfp = -(-d // 16) * 16  # the kernel's padded width
    n = int(4.4e6 / nfp**2) + int(rng.integers(0, 400))
    t = dense_table(tmp_path / "t.csv", rng, n, d)
    eps = float(rng.choice([1e-3, 0.1, 1.0]))
    outs = []
    for threads in (1, 2, 3, 0):
        ok(run(["reps", "--return", "R", "--features", "phi*", "--epsilon", eps, "--threads",
                threads, "-i", t, "-o", f"p{threads}.csv", "--summary", f"s{threads}.csv"],
               tmp_path))
        outs.append(((tmp_path / f"p{threads}.csv").read_bytes(),
                     (tmp_path / f"s{threads}.csv").read_bytes()))
    assert all(o == outs[0] for o in outs[1:])
    assert read_csv(tmp_path / "s1.csv")[0]["status"] in ("active", "unreachable")


@pytest.mark.parametrize("value", ["65", "1.5", "two", "-1", "", "0x2", "1e1", "+2", " 2", "2 ", "640"])
def test_reps_bad_threads(tmp_path, value):
    good = reps_table(tmp_path)
    fails(run(["reps", "--return", "R", "--features", "phi*", "-i", good, "-o", "p.csv",
               "--threads", value], tmp_path), "--threads")
    no_files(tmp_path, "p.csv")


# ---- policy --------------------------------------------------------------

def policy_train(tmp_path, n=200, seed=2):
    """Cue ball fixed, reward ball in the Experiment 1/2 box; a linear
    'expert' a = 0.5 * (r - c) plus noise, random weights."""
    rnd = random.Random(seed)
    rows = []
    for _ in range(n):
        x1, y1 = rnd.uniform(0.05, 0.45), rnd.uniform(-0.2, 0.2)
        vx = 0.5 * (x1 + 0.25) + rnd.gauss(0, 0.01)
        vy = 0.5 * y1 + rnd.gauss(0, 0.01)
        rows.append([-0.25, 0.0, x1, y1, vx, vy, rnd.random(), x1 + 0.1, y1 - 0.05])
    return write_rows(tmp_path / "train.csv",
                      ["x0", "y0", "x1", "y1", "vx", "vy", "w", "rx", "ry"], rows)


def policy_query(tmp_path):
    return write_rows(tmp_path / "q.csv", ["x0", "y0", "x1", "y1"],
                      [[-0.25, 0, 0.2, 0.1], [-0.25, 0, 0.4, -0.1], [-0.25, 0, 0.1, 0.0]])


POLICY = ["policy", "--state", "x0,y0,x1,y1", "--action", "vx,vy", "--weight", "w"]


def test_policy_mean_cov(tmp_path):
    tr, q = policy_train(tmp_path), policy_query(tmp_path)
    ok(run(POLICY + ["--train", tr, "-i", q, "-o", "out.csv"], tmp_path))
    out = read_csv(tmp_path / "out.csv")
    assert list(out[0].keys()) == ["x0", "y0", "x1", "y1", "mean_vx", "mean_vy",
                                   "cov_0_0", "cov_0_1", "cov_1_1", "status"]
    assert len(out) == 3
    for r in out:
        x1, y1 = float(r["x1"]), float(r["y1"])
        assert abs(float(r["mean_vx"]) - 0.5 * (x1 + 0.25)) < 0.02
        assert abs(float(r["mean_vy"]) - 0.5 * y1) < 0.02
        c00, c01, c11 = float(r["cov_0_0"]), float(r["cov_0_1"]), float(r["cov_1_1"])
        assert c00 > 0 and c11 > 0 and c00 * c11 - c01 * c01 > 0


def test_policy_single_node_is_weighted_regression(tmp_path):
    tr, q = policy_train(tmp_path), policy_query(tmp_path)
    ok(run(POLICY + ["--train", tr, "-i", q, "-o", "out.csv", "--set", "policy.n_min=1000"],
           tmp_path))
    rows = read_csv(tr)
    S = np.array([[1.0, float(r["x1"]), float(r["y1"])] for r in rows])
    A = np.array([[float(r["vx"]), float(r["vy"])] for r in rows])
    w = np.array([float(r["w"]) for r in rows])
    # the constant cue-ball columns add nothing: regress on [1, x1, y1]
    beta = np.linalg.solve(S.T @ (w[:, None] * S), S.T @ (w[:, None] * A))
    Z = (w.sum() ** 2 - (w * w).sum()) / w.sum()
    for r in read_csv(tmp_path / "out.csv"):
        s = np.array([1.0, float(r["x1"]), float(r["y1"])])
        mu = s @ beta
        assert abs(float(r["mean_vx"]) - mu[0]) < 1e-8
        assert abs(float(r["mean_vy"]) - mu[1]) < 1e-8
        D = A - mu
        cov = (w[:, None, None] * D[:, :, None] * D[:, None, :]).sum(0) / Z  # eq. 6.8-6.9
        assert abs(float(r["cov_0_0"]) - cov[0, 0]) < 1e-9
        assert abs(float(r["cov_0_1"]) - cov[0, 1]) < 1e-9
        assert abs(float(r["cov_1_1"]) - cov[1, 1]) < 1e-9


def test_policy_samples(tmp_path):
    tr, q = policy_train(tmp_path), policy_query(tmp_path)
    ok(run(POLICY + ["--train", tr, "-i", q, "-o", "a.csv", "--sample", "4", "--seed", "5"],
           tmp_path))
    ok(run(POLICY + ["--train", tr, "-i", q, "-o", "b.csv", "--sample", "4", "--seed", "5"],
           tmp_path))
    ok(run(POLICY + ["--train", tr, "-i", q, "-o", "c.csv", "--sample", "4", "--seed", "6"],
           tmp_path))
    a = read_csv(tmp_path / "a.csv")
    assert list(a[0].keys())[:7] == ["x0", "y0", "x1", "y1", "sample", "vx", "vy"]
    assert len(a) == 12
    assert [int(r["sample"]) for r in a] == [0, 1, 2, 3] * 3
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()
    assert (tmp_path / "a.csv").read_text() != (tmp_path / "c.csv").read_text()
    for r in a:
        assert abs(float(r["vx"]) - float(r["mean_vx"])) < 6 * math.sqrt(float(r["cov_0_0"]))


def test_policy_reward_state_target(tmp_path):
    tr, q = policy_train(tmp_path), policy_query(tmp_path)
    ok(run(POLICY + ["--train", tr, "-i", q, "-o", "out.csv", "--target", "rx,ry",
                     "--set", "policy.target=reward_state", "--set", "policy.n_min=20"], tmp_path))
    assert len(read_csv(tmp_path / "out.csv")) == 3
    fails(run(POLICY + ["--train", tr, "-i", q, "-o", "out2.csv",
                        "--set", "policy.target=reward_state"], tmp_path), "--target")
    no_files(tmp_path, "out2.csv")


def test_policy_bad_input(tmp_path):
    tr, q = policy_train(tmp_path), policy_query(tmp_path)
    fails(run(["policy", "--state", "x0,y0,x1,y1", "--action", "vx,vy", "-i", q, "-o", "o.csv"],
              tmp_path), "--train")
    fails(run(["policy", "--train", tr, "--state", "x0,y0,x1,y1,z", "--action", "vx,vy",
               "-i", q, "-o", "o.csv"], tmp_path), "'z'")
    fails(run(POLICY[:5] + ["--weight", "ww", "--train", tr, "-i", q, "-o", "o.csv"], tmp_path),
          "'ww'")
    qq = write_rows(tmp_path / "qq.csv", ["x0", "y0", "x1"], [[-0.25, 0, 0.2]])
    fails(run(POLICY + ["--train", tr, "-i", qq, "-o", "o.csv"], tmp_path), "qq.csv", "'y1'")
    text = tr.read_text().splitlines()
    f = text[7].split(",")
    f[6] = "-1"
    text[7] = ",".join(f)
    (tmp_path / "neg.csv").write_text("\n".join(text) + "\n")
    fails(run(POLICY + ["--train", "neg.csv", "-i", q, "-o", "o.csv"], tmp_path),
          "neg.csv:8", "'w'")
    rows = [list(r.values()) for r in read_csv(tr)]
    for r in rows:
        r[6] = "0"
    zero = write_rows(tmp_path / "zero.csv", list(read_csv(tr)[0].keys()), rows)
    fails(run(POLICY + ["--train", zero, "-i", q, "-o", "o.csv"], tmp_path), "zero.csv",
          "all zero")
    text = tr.read_text().splitlines()
    text[3] = text[3].replace(text[3].split(",")[4], "nan", 1)
    (tmp_path / "nan.csv").write_text("\n".join(text) + "\n")
    fails(run(POLICY + ["--train", "nan.csv", "-i", q, "-o", "o.csv"], tmp_path), "nan.csv:4")
    no_files(tmp_path, "o.csv")


def test_a_subnormal_feature_is_named_not_blamed_on_the_returns(tmp_path):
    """Features scaled by 1e-310 (subnormal) make theta, in return units per
    feature unit, overflow: exit 3 with one line naming the feature and
    both spreads, not 'returns too far apart' for returns a unit apart."""
    rnd = np.random.default_rng(0)
    R, f = rnd.normal(size=30), rnd.normal(size=30) * 1e-310
    write_rows(tmp_path / "in.csv", ["R", "f"], zip(R, f))
    r = run(["reps", "--return", "R", "--features", "f", "-i", "in.csv", "-o", "p.csv"], tmp_path)
    assert r.returncode == 3 and r.stderr.count("\n") == 1, r.stderr
    assert r.stderr.startswith("poolreps: reps: feature 0: theta overflows: returns spread "), r.stderr
    assert re.search(r"per feature spread [0-9.]+e-310 is beyond a double\n$", r.stderr), r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.csv"]
