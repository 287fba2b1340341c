"""End-to-end tests of Experiment 3 (thesis 7.5) at a tiny scale.

Run by `make check` with POOLREPS=<abs path to poolreps>; their figures are
checked in test_report.py, on the quick reproduction that draws them all. Each
test runs the real executable on data/exp3.ini with --set overrides that
shrink it.
"""
import math
import os
from pathlib import Path

import pytest
from conftest import csv_rows, run_experiment, run_cmd

ROOT = Path(__file__).resolve().parent.parent
BIN = os.environ.get("POOLREPS", str(ROOT / "poolreps"))
ENV = dict(os.environ, LC_ALL="C")

POLICIES = ["nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a", "baseline", "handcrafted"]
# 2 repetitions x 6 policies x (40 + 3 x 10) episodes
TINY = ["experiment.repetitions=2", "experiment.threads=1", "exp3.init_samples=40",
        "exp3.window=40", "exp3.samples=10", "exp3.iterations=3", "exp3.final_episodes=20",
        "policy.n_min=15", "exp3.baseline_n_min=60", "value.n_min=12"]
RAW = ["exp3_episodes.csv", "exp3_reps.csv"]
DERIVED = ["exp3_curve.csv", "exp3_final.csv", "exp3_pockets.csv", "exp3_dist.csv",
           "exp3_reps_summary.csv"]
TARGETS = {2: (0.5, -0.25), 5: (0.5, 0.25)}


def run(out, sets=(), check=True, extra=()):
    return run_experiment("exp3.ini", out, sets, check, extra)


rows = csv_rows


def csv_bytes(d):
    return {n: (Path(d) / n).read_bytes() for n in RAW + DERIVED}


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("exp3_tiny")
    run(out, TINY)
    return out


def test_schema_and_ranges(tiny):
    h, eps = rows(tiny / "exp3_episodes.csv")
    assert h == ["repetition", "policy", "iteration", "x0", "y0", "x1", "y1", "vx", "vy",
                 "return", "rx", "ry", "pocket", "hit"]
    per_run = 40 + 3 * 10
    assert len(eps) == 2 * 6 * per_run
    # repetition-major, then policies in exp3.policies order, episodes in order
    expect = [(k, p) for k in ("0", "1") for p in POLICIES for _ in range(per_run)]
    assert [(r["repetition"], r["policy"]) for r in eps] == expect
    for j in range(0, len(eps), per_run):
        its = [int(r["iteration"]) for r in eps[j:j + per_run]]
        assert its == [0] * 40 + [1] * 10 + [2] * 10 + [3] * 10
    for r in eps:
        ret = float(r["return"])
        assert ret <= 0
        # start state: cue at (-0.25, 0), reward ball in its box (data/exp3.ini)
        assert (float(r["x0"]), float(r["y0"])) == (-0.25, 0.0)
        assert 0.05 <= float(r["x1"]) <= 0.15 and -0.1 <= float(r["y1"]) <= 0.1
        pk = int(r["pocket"])
        assert -1 <= pk <= 5 and r["hit"] in ("0", "1")
        rx, ry = float(r["rx"]), float(r["ry"])
        d = min(math.hypot(rx - x, ry - y) for x, y in TARGETS.values())
        if pk in TARGETS:
            assert ret == 0.0
        elif r["hit"] == "1":
            # eq. 7.7: minus the distance of the final position to the nearest target
            assert ret == pytest.approx(-d, abs=1e-12)
        else:
            assert ret < -d + 1e-12  # the miss penalty comes on top
    # every run starts with the same initial episodes (common random numbers)
    first = [tuple(r[c] for c in h[2:]) for r in eps[:40]]
    for j in range(per_run, 6 * per_run, per_run):
        assert [tuple(r[c] for c in h[2:]) for r in eps[j:j + 40]] == first

    h, reps = rows(tiny / "exp3_reps.csv")
    assert h == ["repetition", "policy", "iteration", "eta", "kl", "ess", "bound", "residual",
                 "q_ess", "features", "dual_evals", "redraws", "policy_flags", "kl_gap",
                 "residual_rel", "status"]
    assert len(reps) == 2 * 6 * 3
    for r in reps:
        assert 1 <= int(r["iteration"]) <= 3
        assert float(r["eta"]) >= 0 and float(r["kl"]) >= 0
        assert 1 - 1e-9 <= float(r["ess"]) <= 40 + 1e-9
        assert 1 - 1e-9 <= float(r["q_ess"]) <= 40 + 1e-9
        # every solve is certified: active (KL = eps, features matched) or
        # unreachable (eta = 0, the eta -> 0 limit, KL < eps); failed would
        # have failed the run (reps.allow_failed = 0)
        assert float(r["residual_rel"]) <= 1e-9
        if r["bound"] == "1":
            assert r["status"] == "active" and float(r["kl_gap"]) <= 1e-9
            assert float(r["kl"]) == pytest.approx(0.5, abs=1e-9)
        else:
            assert r["status"] == "unreachable" and float(r["kl"]) < 0.5
            assert float(r["eta"]) == 0.0
        if r["policy"] == "handcrafted":
            assert r["features"] == "6"  # 1, x, y, x^2, xy, y^2
        if r["iteration"] == "1":
            # the window holds only pi_0's episodes: importance weights are uniform
            assert float(r["q_ess"]) == pytest.approx(40, rel=1e-9)


def test_derived_match_raw(tiny):
    _, eps = rows(tiny / "exp3_episodes.csv")
    for name in DERIVED:
        with open(tiny / name) as f:
            assert not f.readline().startswith("repetition")
    h, cur = rows(tiny / "exp3_curve.csv")
    assert h == ["policy", "iteration", "episodes", "mean_return", "std_return", "repetitions"]
    assert [(r["policy"], r["iteration"]) for r in cur] == [
        (p, str(t)) for p in POLICIES for t in range(4)]
    for r in cur:
        means = []
        for k in ("0", "1"):
            v = [float(e["return"]) for e in eps if e["policy"] == r["policy"]
                 and e["repetition"] == k and e["iteration"] == r["iteration"]]
            means.append(sum(v) / len(v))
        m = sum(means) / 2
        assert float(r["mean_return"]) == pytest.approx(m, rel=1e-12, abs=1e-15)
        assert float(r["std_return"]) == pytest.approx(
            math.sqrt(sum((x - m) ** 2 for x in means)), rel=1e-9, abs=1e-15)
        assert int(r["episodes"]) == 40 + 10 * int(r["iteration"])
    h, fin = rows(tiny / "exp3_final.csv")
    assert h == ["policy", "repetition", "episodes", "mean_return", "std_return",
                 "pocketed_target", "pocketed_other", "mean_distance"]
    assert len(fin) == 6 * 3
    for r in fin:
        sel = [e for e in eps if e["policy"] == r["policy"]]
        if r["repetition"] != "-1":
            sel = [e for e in sel if e["repetition"] == r["repetition"]]
        else:
            assert int(r["episodes"]) == 40
        # the last 20 episodes of each run: iterations 2 and 3
        sel = [e for e in sel if int(e["iteration"]) >= 2]
        assert int(r["episodes"]) == len(sel)
        v = [float(e["return"]) for e in sel]
        assert float(r["mean_return"]) == pytest.approx(sum(v) / len(v), rel=1e-12, abs=1e-15)
        assert int(r["pocketed_target"]) == sum(int(e["pocket"]) in TARGETS for e in sel)
    h, pk = rows(tiny / "exp3_pockets.csv")
    assert h == ["policy", "pocket", "target", "count", "fraction"]
    for p in POLICIES:
        r = [x for x in pk if x["policy"] == p]
        assert [x["pocket"] for x in r] == [str(i) for i in range(-1, 6)]
        assert sum(int(x["count"]) for x in r) == 40
    h, dist = rows(tiny / "exp3_dist.csv")
    assert h == ["policy", "bin_lo", "bin_hi", "count", "fraction"]
    for p in POLICIES:
        r = [x for x in dist if x["policy"] == p]
        assert sum(int(x["count"]) for x in r) == 40
        assert float(r[0]["bin_lo"]) == 0 and float(r[0]["bin_hi"]) == 0.05
    h, rs = rows(tiny / "exp3_reps_summary.csv")
    _, reps = rows(tiny / "exp3_reps.csv")
    assert [x["policy"] for x in rs] == POLICIES
    for x in rs:
        assert int(x["solves"]) == 6
        assert int(x["bound_active"]) + int(x["bound_inactive"]) == 6
        mine = [r for r in reps if r["policy"] == x["policy"]]
        assert float(x["max_residual"]) == max(float(r["residual"]) for r in mine)
        assert float(x["max_residual_rel"]) == max(float(r["residual_rel"]) for r in mine)
        assert int(x["unreachable"]) == sum(r["status"] == "unreachable" for r in mine)
        assert int(x["failed"]) == 0
        assert int(x["bound_inactive"]) == int(x["unreachable"]) + int(x["failed"])


def test_reps_improves_on_initial_policy(tmp_path):
    """REPS on Experiment 3's setup as shipped (200 initial episodes of
    N(0, 0.01 I), 20 per iteration, window 200), 10 iterations: iterations
    7-10 (80 episodes) must beat the initial policy by a wide margin. The
    initial policy mostly misses the ball (miss penalty): mean about -2.8,
    and the mean of 80 episodes has a standard error of about 0.15. With
    REPS weights equal to q the policies would not move at all."""
    sets = ["experiment.repetitions=1", "exp3.iterations=10",
            "exp3.policies=handcrafted,baseline,nrvr_rs"]
    run(tmp_path, sets)
    _, cur = rows(tmp_path / "exp3_curve.csv")
    for p, margin in (("handcrafted", 1.5), ("baseline", 0.8), ("nrvr_rs", 0.8)):
        c = {int(r["iteration"]): float(r["mean_return"]) for r in cur if r["policy"] == p}
        init = c[0]
        late = sum(c[t] for t in range(7, 11)) / 4
        assert init < -2.0, (p, init)
        assert late > init + margin, (p, init, late)


def test_same_seed_same_bytes_any_threads(tiny, tmp_path):
    a = csv_bytes(tiny)
    run(tmp_path / "t2", [s for s in TINY if not s.startswith("experiment.threads")] +
        ["experiment.threads=2"])
    assert csv_bytes(tmp_path / "t2") == a
    run(tmp_path / "seed", TINY, extra=["--seed", "2"])
    assert csv_bytes(tmp_path / "seed")["exp3_episodes.csv"] != a["exp3_episodes.csv"]


def test_repetitions_merge_to_the_single_run(tiny, tmp_path):
    for k in (0, 1):
        run(tmp_path / f"r{k}", TINY + [f"experiment.repetition={k}"])
        _, eps = rows(tmp_path / f"r{k}" / "exp3_episodes.csv")
        assert {r["repetition"] for r in eps} == {str(k)}
    p = run_cmd([BIN, "merge", "-q", "-o", str(tmp_path / "m"), str(tmp_path / "r1"),
                        str(tmp_path / "r0")], capture_output=True, text=True, env=ENV,
                       timeout=60)
    assert p.returncode == 0, p.stderr
    assert csv_bytes(tmp_path / "m") == csv_bytes(tiny)


def test_subset_of_policies_gives_the_same_runs(tiny, tmp_path):
    """A run's episodes depend on (seed, repetition, policy) only."""
    run(tmp_path, TINY + ["exp3.policies=handcrafted,rvr_a"])
    _, small = rows(tmp_path / "exp3_episodes.csv")
    _, full = rows(tiny / "exp3_episodes.csv")
    for p in ("handcrafted", "rvr_a"):
        assert [r for r in small if r["policy"] == p] == [r for r in full if r["policy"] == p]


@pytest.mark.parametrize("sets,msg", [
    (["exp3.policies=nrvr_rs,foo"], "exp3.policies"),
    (["exp3.policies=rvr_a,rvr_a"], "listed twice"),
    (["value.features=both"], "value.features"),
    (["exp3.window=0"], "exp3.window"),
    (["table.balls=3", "table.reward_balls=2"], "reward_balls"),
])
def test_bad_parameters_fail_cleanly(tmp_path, sets, msg):
    p = run(tmp_path / "out", TINY + sets, check=False)
    assert p.returncode == 1, p.stderr
    assert msg in p.stderr
    # a failed run leaves nothing behind, not even the folder it would have made
    assert not (tmp_path / "out").exists()


def test_uncertified_solve_stops_the_run_unless_allowed(tmp_path):
    """A REPS answer that cannot be certified (a budget of one dual
    evaluation) stops the run with one line naming the run and the reason;
    with reps.allow_failed = 1 it is recorded (status failed) and counted."""
    sets = TINY + ["exp3.policies=nrvr_rs,handcrafted", "reps.max_iter=1",
                   "experiment.repetitions=1"]
    p = run(tmp_path / "a", sets, check=False)
    assert p.returncode == 3
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "reps.allow_failed" in lines[0], p.stderr
    run(tmp_path / "b", sets + ["reps.allow_failed=1"])
    _, reps = rows(tmp_path / "b" / "exp3_reps.csv")
    assert reps and all(r["status"] == "failed" and r["bound"] == "0" for r in reps)
    _, summ = rows(tmp_path / "b" / "exp3_reps_summary.csv")
    for s in summ:
        assert int(s["failed"]) == int(s["solves"]) == 3
        assert int(s["bound_inactive"]) == int(s["unreachable"]) + int(s["failed"])
