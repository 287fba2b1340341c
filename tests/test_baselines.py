"""Experiment 5 (docs/baselines.md): the machinery of `make baselines`.

The smoke run needs Stable-Baselines3 and pycma in build/baselines/venv
(`make baselines` installs them from PyPI) and skips, saying so, without
them; the statistics and the offline failure need neither."""
import csv
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from conftest import ROOT, poolreps_path, run_cmd

sys.path.insert(0, str(ROOT / "scripts"))
import baselines_report as br  # noqa: E402

VENV = Path(os.environ.get("BASELINES_VENV", ROOT / "build/baselines/venv"))
SCRIPT = ROOT / "scripts/baselines.sh"


def have_sb3():
    py = VENV / "bin/python"
    return py.exists() and subprocess.run(
        [str(py), "-c", "import stable_baselines3, cma"], capture_output=True).returncode == 0


def script_env(**kw):
    env = dict(os.environ)
    env.update(POOLREPS=poolreps_path() or "poolreps", PYTHON=sys.executable,
               POOLREPS_LIB=os.environ.get("POOLREPS_LIB",
                                           str(ROOT / "build/rel/libpoolreps.so.0")))
    env.update({k: str(v) for k, v in kw.items()})
    return env


def test_without_network_it_fails_in_one_line_and_changes_nothing(tmp_path):
    venv = tmp_path / "no" / "venv"
    out = tmp_path / "out"
    env = script_env(BASELINES_VENV=venv, PIP_INDEX_URL="http://127.0.0.1:9/simple",
                     PIP_RETRIES=0, PIP_TIMEOUT=2, PIP_NO_CACHE_DIR=1)
    env.pop("PIP_FIND_LINKS", None)
    p = run_cmd(["sh", SCRIPT, "run", out, 2], capture_output=True, text=True, env=env,
                timeout=300)
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2, p.stderr
    assert len(lines) == 1 and lines[0].startswith(
        "baselines: could not install stable-baselines3 cma gymnasium from PyPI"), p.stderr
    assert sorted(tmp_path.iterdir()) == []  # no venv, no folder for it, no output


def test_holm_and_intervals_match_their_definitions():
    rng = np.random.default_rng(3)
    for _ in range(50):
        ps = list(rng.uniform(0, 0.2, rng.integers(1, 8)))
        adj = br.holm(ps)
        m = len(ps)
        order = np.argsort(ps)
        ref = np.maximum.accumulate([min(1, (m - r) * ps[i]) for r, i in enumerate(order)])
        assert np.allclose(np.array(adj)[order], ref)
        x = rng.normal(size=rng.integers(2, 20))
        mean, lo, hi = br.t_interval(x)
        want = stats.t.interval(0.95, len(x) - 1, loc=x.mean(), scale=stats.sem(x))
        assert math.isclose(lo, want[0], rel_tol=1e-12) and math.isclose(hi, want[1],
                                                                          rel_tol=1e-12)
    adj = br.holm([0.01, math.nan, 0.04])
    assert adj[0] == 0.02 and math.isnan(adj[1]) and adj[2] == 0.04
    assert math.isnan(br.t_interval([1.0])[1])


def write_rows(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


def test_the_tables_pair_by_seed_and_adjust_within_a_budget(tmp_path):
    rng = np.random.default_rng(1)
    rows = []
    base = rng.normal(-1, 0.3, 10)
    for k in range(10):
        rows.append(["reps_handcrafted", k, 2200, base[k], "", "", ""])
        rows.append(["sac", k, 2200, base[k] - 0.5 + rng.normal(0, 0.01), -0.9, 1, 2])
        rows.append(["ppo", k, 2200, base[k] + rng.normal(0, 0.3), "", 1, 2])
    data = tmp_path / "data"
    data.mkdir()
    write_rows(data / "runs.csv", ["learner", "seed", "budget", "last500_mean",
                                   "deterministic_mean", "wall_s", "cpu_s"], rows)
    t = {r["learner"]: r for r in br.budget_table(br.read(data / "runs.csv"), 2200)}
    d = [r[3] for r in rows if r[0] == "sac"]
    diff = np.array(d) - base
    assert math.isclose(t["sac"]["diff"][0], diff.mean(), rel_tol=1e-12)
    assert t["sac"]["verdict"] == "below" and t["sac"]["pairs"] == 10
    d_ppo = np.array([r[3] for r in rows if r[0] == "ppo"]) - base

    def flip(d):   # scipy's exact sign-flip test (the oracle of verdict_stats too)
        return stats.permutation_test((d,), np.mean, permutation_type="samples",
                                      n_resamples=np.inf).pvalue
    want = br.holm([flip(diff), flip(d_ppo)])
    assert math.isclose(t["sac"]["p"], want[0]) and math.isclose(t["ppo"]["p"], want[1])
    want = br.holm([stats.ttest_1samp(diff, 0).pvalue, stats.ttest_1samp(d_ppo, 0).pvalue])
    assert math.isclose(t["sac"]["p_t"], want[0]) and math.isclose(t["ppo"]["p_t"], want[1])
    assert t["reps_handcrafted"]["verdict"] == "reference"


@pytest.mark.slow
def test_smoke_run_writes_the_csvs_and_the_report(tmp_path):
    if os.environ.get("SAN") == "1":
        pytest.skip("under SAN=1 the learners' Python would load the sanitized library without "
                    "the sanitizer runtime preloaded: the smoke run tests the release build")
    if not have_sb3():
        pytest.skip(f"Stable-Baselines3 and pycma are not installed in {VENV} (make "
                    "baselines installs them from PyPI): the Experiment 5 smoke run is skipped")
    out, docs, data = tmp_path / "out", tmp_path / "docs", tmp_path / "data"
    t0 = time.time()
    p = run_cmd(["sh", SCRIPT, "smoke", out], capture_output=True, text=True,
                env=script_env(BASELINES_VENV=VENV, BASELINES_DOCS=docs, BASELINES_DATA=data),
                timeout=300)
    assert p.returncode == 0, p.stderr
    secs = time.time() - t0
    runs = br.read(data / "runs.csv")
    learners = {r["learner"] for r in runs}
    assert learners == {"cma_linear", "sac", "ppo", "reps_handcrafted",
                        "reps_tree_nrvr_a", "ccmaes_handcrafted"}
    # a poolreps learner's value is the mean of its episodes 100..599 (independently)
    with open(out / "reps/creps_handcrafted/exp3_episodes.csv") as f:
        R = [float(r["return"]) for r in csv.DictReader(f) if r["repetition"] == "1"]
    got = [float(r["last500_mean"]) for r in runs
           if r["learner"] == "reps_handcrafted" and r["seed"] == "1" and r["budget"] == "600"]
    assert got == [float(np.mean(R[100:600]))]
    assert (docs / "figures/baselines.png").stat().st_size > 10000
    text = (docs / "baselines.md").read_text()
    assert "**600 episodes**" in text and "SAC (SB3 defaults)" in text
    # every learner has its mean-action evaluation, the poolreps ones too
    assert all(r["deterministic_mean"] for r in runs), [r for r in runs if not r["deterministic_mean"]]
    # every run's clipped actions are counted, at every budget it reached
    clipped = {(r["learner"], r["seed"], r["budget"]) for r in br.read(data / "clipped.csv")}
    assert clipped == {(r["learner"], r["seed"], r["budget"]) for r in runs}
    print(f"smoke run: {secs:.1f} s")


@pytest.mark.parametrize("policy", ["handcrafted", "nrvr_a"])
def test_a_longer_poolreps_run_starts_with_the_shorter_one(tmp_path, policy):
    # what lets one long run per seed stand for every budget
    from conftest import run_poolreps
    out = {}
    for it in (3, 8):
        p = run_poolreps([ROOT / "data/exp3.ini", "-q", "-o", tmp_path / f"i{it}",
                          "--set", f"exp3.iterations={it}", "--set", "experiment.repetitions=2",
                          "--set", f"exp3.policies={policy}"])
        assert p.returncode == 0, p.stderr
        with open(tmp_path / f"i{it}/exp3_episodes.csv") as f:
            out[it] = [(r["repetition"], r["return"]) for r in csv.DictReader(f)]
    for k in ("0", "1"):
        short = [r for r in out[3] if r[0] == k]
        long = [r for r in out[8] if r[0] == k]
        assert len(short) == 260 and long[:260] == short


def test_docs_baselines_md_is_what_the_committed_csvs_give(tmp_path):
    import shutil
    readme = tmp_path / "README.md"
    shutil.copy(ROOT / "README.md", readme)
    br.report(ROOT / "data/baselines", tmp_path / "docs", readme)
    assert (tmp_path / "docs/baselines.md").read_text() == (ROOT / "docs/baselines.md").read_text()
    assert readme.read_text() == (ROOT / "README.md").read_text()


def fake_run(out, learner, seed, budgets, shift):
    """One run file as scripts/baselines.py writes it, with made-up returns
    and clipped counts."""
    rows = []
    for b in budgets:
        rows.append([learner, seed, "curve", b, -1 + shift + 0.001 * seed, "", "", "", ""])
        rows.append([learner, seed, "budget", b, -1 + shift + 0.001 * seed, -0.9, 2.5 * b,
                     2.0 * b, b // 3 + seed])
    (out / "runs").mkdir(parents=True, exist_ok=True)
    write_rows(out / "runs" / f"{learner}_s{seed}_b{'_'.join(map(str, budgets))}.csv",
               ["learner", "seed", "kind", "episodes", "last500_mean", "deterministic_mean",
                "wall_s", "cpu_s", "clipped"], rows)
    (out / "budgets.txt").write_text("300,600\n")


def test_merge_replaces_one_learner_as_a_full_collect_would(tmp_path):
    """A learner run apart (here ppo, at a longer budget) merged into the data
    gives the bytes a collect of every run together gives; the other learners'
    rows stay; budgets that differ are refused."""
    full, old, apart = tmp_path / "full", tmp_path / "old", tmp_path / "apart"
    for s in range(3):
        for o in (full, old):
            fake_run(o, "cma_linear", s, [300, 600], 0.0)
            fake_run(o, "sac", s, [300], 0.1)
        fake_run(old, "ppo", s, [300], 0.2)
        fake_run(full, "ppo", s, [300, 600], 0.3)
        fake_run(apart, "ppo", s, [300, 600], 0.3)
    br.collect(full, tmp_path / "want")
    br.collect(old, tmp_path / "got")
    br.merge(apart, tmp_path / "got")
    for f in ("runs.csv", "curve.csv", "timing.csv", "clipped.csv", "budgets.txt"):
        assert (tmp_path / "got" / f).read_bytes() == (tmp_path / "want" / f).read_bytes(), f
    (apart / "budgets.txt").write_text("300\n")
    before = {p.name: p.read_bytes() for p in (tmp_path / "got").iterdir()}
    with pytest.raises(SystemExit, match="differs"):
        br.merge(apart, tmp_path / "got")
    assert {p.name: p.read_bytes() for p in (tmp_path / "got").iterdir()} == before


@pytest.mark.parametrize("method", ["creps", "ccmaes"])
def test_exp3_mean_eval_shoots_from_the_python_learners_evaluation_states(tmp_path, method):
    """exp3.mean_eval: pi_0's mean action is (0, 0), so its evaluation's mean
    return is that of a still cue ball from the evaluation states, which
    PocketEnv.reset_batch(n, seed=mean_eval_seed + k) draws for the Python
    learners (the oracle: the binding's own start states and shots). Later
    rows come every mean_eval_every episodes; without the key no file."""
    from conftest import run_poolreps
    if os.environ.get("SAN") == "1":
        pytest.skip("under SAN=1 the binding would load the sanitized library without the "
                    "sanitizer runtime preloaded")
    sys.path.insert(0, str(ROOT / "python"))
    import poolreps
    base = [ROOT / "data/exp3.ini", "-q", "--set", "exp3.iterations=3",
            "--set", "experiment.repetitions=2", "--set", "exp3.policies=handcrafted",
            "--set", f"exp3.handcrafted_method={method}", "--set", "exp3.truncation=clip"]
    p = run_poolreps(base + ["-o", tmp_path / "a", "--set", "exp3.mean_eval=40",
                             "--set", "exp3.mean_eval_every=40", "--set",
                             "exp3.mean_eval_seed=77"])
    assert p.returncode == 0, p.stderr
    rows = br.read(tmp_path / "a/exp3_mean.csv")
    # 200 episodes at iteration 0, then 20 per iteration: 200, 240
    assert [(r["repetition"], r["episodes"]) for r in rows] == [
        ("0", "200"), ("0", "240"), ("1", "200"), ("1", "240")]
    env = poolreps.PocketEnv()
    for r in rows[::2]:
        S = env.reset_batch(40, seed=77 + int(r["repetition"]))[0]
        want = float(env.step_batch(S, np.zeros((40, 2)))[1].mean())
        assert math.isclose(float(r["mean_return"]), want, rel_tol=1e-12), r
    assert all(r["states"] == "40" for r in rows)
    assert rows[1]["mean_return"] != rows[0]["mean_return"]  # the learned mean moved
    p = run_poolreps(base + ["-o", tmp_path / "b"])
    assert p.returncode == 0, p.stderr
    assert not (tmp_path / "b/exp3_mean.csv").exists()
    for f in ("exp3_episodes.csv", "exp3_reps.csv"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f


def test_merge_adds_seeds_run_apart_and_keeps_the_others(tmp_path):
    """Seeds 3-4 of a learner, run apart, merged into data holding its seeds
    0-2: the bytes of a collect of all five runs together."""
    full, old, apart = tmp_path / "full", tmp_path / "old", tmp_path / "apart"
    for s in range(5):
        fake_run(full, "sac", s, [300, 600] if s < 3 else [300], 0.1)
        fake_run(old if s < 3 else apart, "sac", s, [300, 600] if s < 3 else [300], 0.1)
    br.collect(full, tmp_path / "want")
    br.collect(old, tmp_path / "got")
    br.merge(apart, tmp_path / "got")
    for f in ("runs.csv", "curve.csv", "timing.csv"):
        assert (tmp_path / "got" / f).read_bytes() == (tmp_path / "want" / f).read_bytes(), f
    assert len({r["seed"] for r in br.read(tmp_path / "got/runs.csv")}) == 5


def test_report_check_fails_on_a_changed_page_and_writes_nothing(tmp_path):
    import shutil
    docs, readme = tmp_path / "docs", tmp_path / "README.md"
    shutil.copy(ROOT / "README.md", readme)
    br.report(ROOT / "data/baselines", docs, readme)
    br.report(ROOT / "data/baselines", docs, readme, check=True)  # agrees
    page = docs / "baselines.md"
    page.write_text(page.read_text().replace("| 20 |", "| 21 |", 1))
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    p = run_cmd([sys.executable, ROOT / "scripts/baselines_report.py", "report",
                 ROOT / "data/baselines", docs, readme, "--check"],
                capture_output=True, text=True)
    assert p.returncode == 1 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert "baselines.md" in p.stderr
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before


def test_clipped_actions_of_a_poolreps_run_are_its_fast_draws(tmp_path):
    """With sim.max_speed low enough that pi_0 draws beyond it, the count per
    episode (a speed at the limit) adds up, iteration by iteration, to the
    redraws column poolreps counts under exp3.truncation = clip; iteration 0,
    which that column leaves out, is counted too; a column that disagrees is
    refused in one line."""
    from conftest import run_poolreps
    out = tmp_path / "r"
    p = run_poolreps([ROOT / "data/exp3.ini", "-q", "-o", out, "--set", "exp3.iterations=4",
                      "--set", "experiment.repetitions=2", "--set", "exp3.policies=handcrafted",
                      "--set", "exp3.truncation=clip", "--set", "sim.max_speed=0.15"])
    assert p.returncode == 0, p.stderr
    episodes = br.read(out / "exp3_episodes.csv")
    flags = br.clipped_flags(out, episodes)
    reps = br.read(out / "exp3_reps.csv")
    for k in (0, 1):
        it = np.array([int(r["iteration"]) for r in episodes if r["repetition"] == str(k)])
        assert len(flags[k]) == len(it) == 280
        assert 0 < flags[k][it == 0].sum() < 200   # pi_0 = N(0, 0.1^2 I): some beyond 0.15
        for r in reps:
            if r["repetition"] == str(k):
                assert flags[k][it == int(r["iteration"])].sum() == int(r["redraws"])
    assert sum(int(r["redraws"]) for r in reps) > 0
    rows = [r for r in reps]
    rows[3]["redraws"] = str(int(rows[3]["redraws"]) + 1)
    write_rows(out / "exp3_reps.csv", list(rows[0]), [list(r.values()) for r in rows])
    with pytest.raises(SystemExit, match="exp3_reps.csv: repetition .* redraws"):
        br.clipped_flags(out, episodes)


def test_clipped_table_and_what_is_not_recorded():
    runs = [{"learner": "sac", "seed": str(s), "budget": str(b), "cpu_s": str(b / 100)}
            for s in range(2) for b in (300, 600)]
    runs += [{"learner": "ppo", "seed": "0", "budget": "300", "cpu_s": "1"}]
    clipped = [{"learner": "sac", "seed": str(s), "budget": "300", "episodes": "300",
                "clipped": str(30 * (s + 1))} for s in range(2)]
    clipped += [{"learner": "ppo", "seed": "0", "budget": "300", "episodes": "300",
                 "clipped": "0"}]
    rows, note = br.clipped_rows(runs, clipped, [300, 600])
    assert "| SAC (SB3 defaults) | 15.0 % (2) | not recorded |" in rows
    assert "| PPO (SB3 defaults) | 0 % (1) | — |" in rows
    # the two SAC seeds rerun to 600 episodes: 6 + 6 CPU seconds
    assert note == ("Not recorded: SAC (SB3 defaults) at 600 episodes (the runs before the "
                    "count; rerunning them costs about 12 CPU seconds).")
    assert br.clipped_rows(runs[-1:], clipped[-1:], [300])[1] == ""
    # one seed of two counted at 300: named with the share of seeds
    rows, note = br.clipped_rows(runs, clipped[1:], [300, 600])
    assert "| SAC (SB3 defaults) | 20.0 % (1) | not recorded |" in rows
    assert note.startswith("Not recorded: SAC (SB3 defaults) at 300 (1 of 2 seeds) and 600 "
                           "episodes")


def test_the_setup_prints_one_value_or_both_and_the_differences():
    values = br.setup()
    text = br.setup_text(values)
    assert "σ₀ = 0.1 m/s" in text and "Differences" not in text
    assert "on 2,000 fresh start states (seed 1,000,000 + k)" in text
    assert "the cue ball\nat (−0.25, 0)" in text
    values["sigma"] = (0.2, 0.1)
    values["eval_seed"] = (5, 1000000)
    text = br.setup_text(values)
    assert "σ₀ = 0.2 (Python learners; poolreps learners 0.1) m/s" in text
    assert text.endswith("- **Differences** between the Python and the poolreps learners' "
                         "settings: sigma, eval_seed.")


def test_the_python_learners_play_exp3_ini_start_boxes():
    """PocketEnv's start boxes (its defaults) are data/exp3.ini's, which the
    page prints for every learner."""
    if os.environ.get("SAN") == "1":
        pytest.skip("under SAN=1 the binding would load the sanitized library without the "
                    "sanitizer runtime preloaded")
    sys.path.insert(0, str(ROOT / "python"))
    import poolreps
    cfg = poolreps.PocketEnv()._cfg
    want = br.setup()
    for key, item in (("start.cue_box", "cue"), ("start.reward_box", "box")):
        assert tuple(float(v) for v in cfg.text(key).split(",")) == want[item][1]


def test_t_changes_names_every_verdict_the_t_test_would_change():
    t = {300: [{"learner": "sac", "verdict": "below", "verdict_t": "below", "p_t": 0.01},
               {"learner": "ppo", "verdict": "no difference shown", "verdict_t": "below",
                "p_t": 0.03}],
         600: [{"learner": "sac", "verdict": "no difference shown", "verdict_t": "above",
                "p_t": 0.04}]}
    assert br.t_changes(t, [300, 600]) == (
        "Under the paired t test 2 verdicts differ: PPO (SB3 defaults) at 300 episodes "
        "would be *below* (Holm p 0.030); SAC (SB3 defaults) at 600 episodes would be "
        "*above* (Holm p 0.040).")
    assert br.t_changes({300: t[300][:1]}, [300]) == "Under the paired t test no verdict differs."
