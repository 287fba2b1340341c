"""End-to-end runs of the exploration options: policy.cov_center, bench.method
= ccmaes, exp3.handcrafted_method = ccmaes, and the comparison plot."""
import os
import sys

import pytest

from conftest import ROOT, csv_rows, run_experiment, run_cmd


def test_bench_methods_and_compare_plot(tmp_path):
    """Tiny sphere runs of the three methods; C-CMA-ES rows carry no dual
    (eta = kl = bound = 0) and its ess is mueff; the comparison script writes
    its table and figure."""
    sets = ["experiment.repetitions=2", "bench.iterations=6"]
    for name, extra in (("creps_new", ["policy.cov_center=new"]),
                        ("creps_old", ["policy.cov_center=old"]),
                        ("ccmaes", ["bench.method=ccmaes"])):
        run_experiment("sphere.ini", tmp_path / f"sphere-{name}", sets + extra)
    _, new = csv_rows(tmp_path / "sphere-creps_new" / "bench_curve.csv")
    _, old = csv_rows(tmp_path / "sphere-creps_old" / "bench_curve.csv")
    _, cm = csv_rows(tmp_path / "sphere-ccmaes" / "bench_curve.csv")
    # the same first generation (same initial distribution and draws) ...
    assert new[0]["mean_return"] == old[0]["mean_return"] == cm[0]["mean_return"]
    # ... then the centres differ
    assert new[3]["mean_std"] != old[3]["mean_std"]
    for r in cm:
        assert float(r["eta"]) == 0 and float(r["kl"]) == 0 and int(r["bound"]) == 0
        assert 10 < float(r["ess"]) < 25
    for r in new + old:
        assert abs(float(r["kl"]) - 1.0) < 1e-6 and int(r["bound"]) == 1
    py = os.environ.get("PYTHON") or sys.executable
    p = run_cmd([py, str(ROOT / "scripts" / "plot_bench_compare.py"), str(tmp_path)],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "| sphere | ccmaes | 6 |" in p.stdout
    assert (tmp_path / "bench_compare.png").stat().st_size > 10000
    _, rows = csv_rows(tmp_path / "bench_compare.csv")
    assert [r["method"] for r in rows] == ["creps_new", "creps_old", "ccmaes"]


def test_benchmark_default_centre(poolreps):
    """The benchmarks default to cov_center = old, the experiments to new; a
    key set explicitly wins."""
    def centre(*args):
        r = poolreps(["config", *args])
        assert r.returncode == 0, r.stderr
        return [l for l in r.stdout.decode().splitlines() if l.startswith("cov_center")]
    assert centre("-c", ROOT / "data" / "sphere.ini") == ["cov_center = old"]
    assert centre("-c", ROOT / "data" / "exp3.ini") == ["cov_center = new"]
    assert centre("-c", ROOT / "data" / "sphere.ini", "--set", "policy.cov_center=new") == \
        ["cov_center = new"]


@pytest.mark.parametrize("key,value", [("bench.method", "cmaes"), ("policy.cov_center", "mid"),
                                       ("exp3.handcrafted_method", "reps")])
def test_bad_method_values(tmp_path, key, value):
    p = run_experiment("quadratic.ini", tmp_path / "o", [f"{key}={value}"], check=False)
    assert p.returncode == 1
    assert p.stderr.count("\n") == 1 and key in p.stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
@pytest.mark.parametrize("sets", [["exp3.handcrafted_method=ccmaes"], ["policy.cov_center=old"]])
def test_exp3_handcrafted_variants(tmp_path, sets):
    """Experiment 3's hand-crafted loop with C-CMA-ES or the old centre, small
    sizes; output does not depend on the thread count."""
    base = ["exp3.policies=handcrafted", "exp3.iterations=8", "exp3.init_samples=40",
            "exp3.window=40", "exp3.samples=10", "experiment.repetitions=2",
            "exp3.final_episodes=20"] + sets
    run_experiment("exp3.ini", tmp_path / "a", base + ["experiment.threads=2"])
    run_experiment("exp3.ini", tmp_path / "b", base + ["experiment.threads=1"])
    for f in ("exp3_episodes.csv", "exp3_reps.csv"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()
    _, reps = csv_rows(tmp_path / "a" / "exp3_reps.csv")
    assert len(reps) == 16
    if "ccmaes" in sets[0]:
        assert all(float(r["eta"]) == 0 and int(r["features"]) == 6 for r in reps)
        assert [float(r["q_ess"]) for r in reps[:2]] == [40.0, 10.0]
