"""End-to-end tests of Experiments 1 and 2 (thesis 7.3, 7.4) at a tiny scale.

Run by `make check` with POOLREPS=<abs path to poolreps>; their figures are
checked in test_report.py, on the quick reproduction that draws them all. Each
test runs the real executable on data/exp1.ini or data/exp2.ini with --set
overrides that shrink it.
"""
import math
import os
from pathlib import Path

import pytest
from conftest import csv_rows, run_experiment, run_cmd

ROOT = Path(__file__).resolve().parent.parent
BIN = os.environ.get("POOLREPS", str(ROOT / "poolreps"))
ENV = dict(os.environ, LC_ALL="C")

EXP1_TINY = ["exp1.train=100", "exp1.test=100", "exp1.subset=50", "exp1.test_subset=50",
             "experiment.repetitions=2", "exp1.n_min_list=2,20,50",
             "exp1.trees_list=1,10", "exp1.cuts_list=1,10", "exp1.map_grid=5"]
EXP2_TINY = ["exp2.sizes=10,30", "exp2.test=40", "experiment.repetitions=2",
             "policy.trees=10"]


run = run_experiment
rows = csv_rows


def read(path):
    return Path(path).read_bytes()


def same_across_threads_and_merge(ini, sets, tmp_path, order, files, runs=("a",)):
    """Each of runs on one thread, b on two, and the three repetitions run
    apart (r0..r2) then merged in the given order (m): files byte-identical."""
    for d in runs:
        run(ini, tmp_path / d, sets + ["experiment.threads=1"])
    run(ini, tmp_path / "b", sets + ["experiment.threads=2"])
    for k in range(3):
        run(ini, tmp_path / f"r{k}", sets + [f"experiment.repetition={k}"])
    p = run_cmd([BIN, "merge", "-q", "-o", str(tmp_path / "m")] +
                [str(tmp_path / f"r{k}") for k in order],
                capture_output=True, text=True, env=ENV, timeout=60)
    assert p.returncode == 0, p.stderr
    for f in files:
        a = read(tmp_path / runs[0] / f)
        for d in runs[1:] + ("b", "m"):
            assert a == read(tmp_path / d / f), (d, f)


# ---- Experiment 1 ----

def test_exp1_schema_and_ranges(tmp_path):
    run("exp1.ini", tmp_path, EXP1_TINY)
    h, mse = rows(tmp_path / "exp1_mse.csv")
    assert h == ["repetition", "sweep", "n_min", "trees", "cuts", "mse"]
    # 2 repetitions x (3 n_min + 2 trees + 2 cuts) settings, repetition-major
    assert len(mse) == 2 * 7
    assert [int(r["repetition"]) for r in mse] == [0] * 7 + [1] * 7
    assert [r["sweep"] for r in mse[:7]] == ["n_min"] * 3 + ["trees"] * 2 + ["cuts"] * 2
    for r in mse:
        assert float(r["mse"]) >= 0
        # the swept parameter varies, the others stay at forest.* (20, 30, 10)
        if r["sweep"] != "n_min":
            assert r["n_min"] == "20"
        if r["sweep"] != "trees":
            assert r["trees"] == "30"
        if r["sweep"] != "cuts":
            assert r["cuts"] == "10"
    h, summ = rows(tmp_path / "exp1_summary.csv")
    assert h == ["sweep", "value", "mean_mse", "std_mse", "forests"]
    assert [(r["sweep"], r["value"]) for r in summ] == [
        ("n_min", "2"), ("n_min", "20"), ("n_min", "50"), ("trees", "1"), ("trees", "10"),
        ("cuts", "1"), ("cuts", "10")]
    # the summary is the mean and sample std of the raw rows
    for r in summ:
        v = [float(x["mse"]) for x in mse if x["sweep"] == r["sweep"] and x[r["sweep"]] == r["value"]]
        assert int(r["forests"]) == len(v) == 2
        m = sum(v) / 2
        assert float(r["mean_mse"]) == pytest.approx(m, rel=1e-12)
        assert float(r["std_mse"]) == pytest.approx(math.sqrt(sum((x - m) ** 2 for x in v)), rel=1e-12)
    h, mp = rows(tmp_path / "exp1_map.csv")
    assert h == ["repetition", "x1", "y1", "reward", "pred"]
    assert len(mp) == 2 * 25
    for r in mp:
        assert 0.05 - 1e-12 <= float(r["x1"]) <= 0.45 + 1e-12
        assert -0.2 - 1e-12 <= float(r["y1"]) <= 0.2 + 1e-12
        assert float(r["reward"]) <= 0
        assert float(r["pred"]) <= 0
    # both repetitions map the same simulated returns with their own forests
    assert [r["reward"] for r in mp[:25]] == [r["reward"] for r in mp[25:]]
    assert [r["pred"] for r in mp[:25]] != [r["pred"] for r in mp[25:]]
    assert not any(n.startswith(".partial") for n in os.listdir(tmp_path))


def test_exp1_single_leaf_forests_ignore_trees_and_cuts(tmp_path):
    # forest.n_min = the subset size: every tree is one leaf predicting the
    # training mean, so M and K cannot change the test MSE
    run("exp1.ini", tmp_path, EXP1_TINY + ["forest.n_min=50", "exp1.trees_list=1,7,30",
                                           "exp1.cuts_list=1,3,10"])
    _, mse = rows(tmp_path / "exp1_mse.csv")
    for k in "01":
        v = {r["mse"] for r in mse if r["repetition"] == k and r["sweep"] in ("trees", "cuts")}
        assert len(v) == 1
        # and n_min = 50 in the n_min sweep is the same forest
        assert {r["mse"] for r in mse if r["repetition"] == k and r["n_min"] == "50"} == v
    _, mp = rows(tmp_path / "exp1_map.csv")
    assert len({r["pred"] for r in mp if r["repetition"] == "0"}) == 1


def test_exp1_reproducible_threads_and_merge(tmp_path):
    sets = EXP1_TINY + ["experiment.repetitions=3", "exp1.train=150", "exp1.test=150"]
    same_across_threads_and_merge("exp1.ini", sets, tmp_path, (2, 0, 1),
                                  ("exp1_mse.csv", "exp1_map.csv", "exp1_summary.csv"))
    # a single repetition holds only its own rows
    _, r1 = rows(tmp_path / "r1" / "exp1_mse.csv")
    assert {r["repetition"] for r in r1} == {"1"}
    # another seed gives other data
    run("exp1.ini", tmp_path / "s", sets, extra=["--seed", "7"])
    assert read(tmp_path / "s" / "exp1_mse.csv") != read(tmp_path / "a" / "exp1_mse.csv")


def test_exp1_bad_sizes_fail_cleanly(tmp_path):
    out = tmp_path / "bad"
    p = run("exp1.ini", out, EXP1_TINY + ["exp1.subset=60"], check=False)
    assert p.returncode == 1
    assert "exp1.train" in p.stderr and "\n" == p.stderr[-1] and p.stderr.count("\n") == 1
    assert not out.exists() or not [n for n in os.listdir(out) if n.endswith(".csv")]
    p = run("exp1.ini", out, EXP1_TINY + ["exp1.n_min_list=2,2.5"], check=False)
    assert p.returncode == 1 and "exp1.n_min_list" in p.stderr


# ---- Experiment 2 ----

def test_exp2_schema_and_ranges(tmp_path):
    run("exp2.ini", tmp_path, EXP2_TINY)
    h, ret = rows(tmp_path / "exp2_returns.csv")
    assert h == ["repetition", "size", "policy", "mode", "mean_return", "std_return", "n",
                 "pocketed", "policy_flags"]
    # per repetition: the expert, then 2 sizes x 3 policies x 2 modes
    assert len(ret) == 2 * 13
    keys = [(r["size"], r["policy"], r["mode"]) for r in ret[:13]]
    assert keys[0] == ("0", "expert", "mean")
    assert keys[1:] == [(s, p, m) for s in ("10", "30") for p in ("single", "s_a", "s_rs")
                        for m in ("mean", "sample")]
    for r in ret:
        assert float(r["mean_return"]) <= 0
        assert float(r["std_return"]) >= 0
        assert int(r["n"]) == 40
        assert 0 <= float(r["pocketed"]) <= 1
        if float(r["pocketed"]) == 1:
            assert float(r["mean_return"]) == 0
        # PR_POLICY_* bits; the expert is no fitted policy
        assert 0 <= int(r["policy_flags"]) < 64
        if r["policy"] == "expert":
            assert r["policy_flags"] == "0"
    # the ghost-ball expert pockets (nearly) every test shot (thesis 7.4.1)
    for r in ret:
        if r["policy"] == "expert":
            assert float(r["pocketed"]) >= 0.95
    h, summ = rows(tmp_path / "exp2_summary.csv")
    assert h == ["size", "policy", "mode", "mean_return", "two_se", "two_se_shots",
                 "repetitions", "shots", "pocketed", "policy_flags"]
    assert len(summ) == 13
    for s in summ:
        v = [float(r["mean_return"]) for r in ret
             if (r["size"], r["policy"], r["mode"]) == (s["size"], s["policy"], s["mode"])]
        assert len(v) == int(s["repetitions"]) == 2
        assert int(s["shots"]) == 80
        m = sum(v) / 2
        assert float(s["mean_return"]) == pytest.approx(m, rel=1e-12, abs=1e-15)
        se = math.sqrt(sum((x - m) ** 2 for x in v) / 1 / 2)
        assert float(s["two_se"]) == pytest.approx(2 * se, rel=1e-9, abs=1e-15)
        assert float(s["two_se_shots"]) >= 0


def test_exp2_rows_do_not_depend_on_the_size_list(tmp_path):
    # each (repetition, size, policy) has its own streams and nested training
    # sets, so running one size alone reproduces its rows
    run("exp2.ini", tmp_path / "all", EXP2_TINY)
    run("exp2.ini", tmp_path / "one", EXP2_TINY + ["exp2.sizes=30"])
    _, a = rows(tmp_path / "all" / "exp2_returns.csv")
    _, b = rows(tmp_path / "one" / "exp2_returns.csv")
    assert [r for r in a if r["size"] in ("0", "30")] == b


def test_exp2_reproducible_threads_and_merge(tmp_path):
    sets = EXP2_TINY + ["experiment.repetitions=3"]
    same_across_threads_and_merge("exp2.ini", sets, tmp_path, (1, 2, 0),
                                  ("exp2_returns.csv", "exp2_summary.csv"), runs=("a", "a2"))


def test_exp2_bad_sizes_fail_cleanly(tmp_path):
    p = run("exp2.ini", tmp_path / "bad", EXP2_TINY + ["exp2.sizes=10,1.5"], check=False)
    assert p.returncode == 1 and "exp2.sizes" in p.stderr
    assert not (tmp_path / "bad" / "exp2_returns.csv").exists()


