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


TINY_EXP3 = ["exp3.iterations=5", "exp3.init_samples=60", "exp3.window=60", "exp3.samples=10",
             "policy.n_min=20", "exp3.baseline_n_min=100", "exp3.final_episodes=30",
             "experiment.repetitions=2"]


def episodes_by_run(path):
    """{(policy, repetition): [(iteration, vx, vy), ...]} of exp3_episodes.csv."""
    out = {}
    for r in csv_rows(path)[1]:
        out.setdefault((r["policy"], r["repetition"]), []).append((r["iteration"], r["vx"], r["vy"]))
    return out


@pytest.mark.slow
def test_exp3_old_centre_every_variant(tmp_path):
    """policy.cov_center = old reaches every Experiment 3 variant (the tree-LWR
    fits centre eq. 6.8 on the recorded sampling means): each variant shares
    the default's initial episodes and then draws other actions; the output
    does not depend on the thread count."""
    run_experiment("exp3.ini", tmp_path / "new", TINY_EXP3)
    for t in ("1", "2"):
        run_experiment("exp3.ini", tmp_path / f"old{t}",
                       TINY_EXP3 + ["policy.cov_center=old", f"experiment.threads={t}"])
    for f in ("exp3_episodes.csv", "exp3_reps.csv"):
        assert (tmp_path / "old1" / f).read_bytes() == (tmp_path / "old2" / f).read_bytes()
    new, old = episodes_by_run(tmp_path / "new" / "exp3_episodes.csv"), \
        episodes_by_run(tmp_path / "old1" / "exp3_episodes.csv")
    assert len(old) == 12
    for run, eps in old.items():
        assert [e for e in eps if e[0] == "0"] == [e for e in new[run] if e[0] == "0"]
        assert [e for e in eps if e[0] != "0"] != [e for e in new[run] if e[0] != "0"], run


def table_cells(text):
    """The rows of a markdown table in text (header and rule left out) as lists of cells."""
    rows = [line.strip("|").split(" | ") for line in text.splitlines() if line.startswith("| ")]
    return [[c.strip() for c in r] for r in rows[1:]]


@pytest.mark.slow
def test_exp3_explore_table(tmp_path):
    """scripts/exp3_explore.sh runs the arms and scripts/exp3_table.py --compare
    gives, per arm and policy, the paired difference of the per-repetition
    means (mean ± sd / sqrt(n)) and the pocket counts that poolreps's own
    exp3_final.csv implies; the ccmaes arm lists only the hand-crafted
    variant; the table replaces the marked block of a document; an arm with
    another seed is refused."""
    doc = tmp_path / "doc.md"
    doc.write_text("before\n<!-- explore-2:begin -->\nold table\n<!-- explore-2:end -->\nafter\n")
    sets = [x for s in TINY_EXP3[:-1] for x in ("--set", s)]
    env = dict(os.environ, LC_ALL="C", POOLREPS=os.environ.get("POOLREPS", str(ROOT / "poolreps")),
               PYTHON=os.environ.get("PYTHON") or sys.executable)
    out = tmp_path / "arms"
    p = subprocess.run(["sh", str(ROOT / "scripts" / "exp3_explore.sh"), str(out), "2", str(doc)] + sets,
                       capture_output=True, text=True, env=env, timeout=600)
    assert p.returncode == 0, p.stderr
    table = (out / "compare.md").read_text()
    assert doc.read_text() == ("before\n<!-- explore-2:begin -->\n" + table +
                               "<!-- explore-2:end -->\nafter\n")

    def final(arm):
        return {(r["policy"], r["repetition"]): r for r in csv_rows(out / arm / "exp3_final.csv")[1]}

    base = final("default")
    rows = table_cells(table)
    arms = {"policy.cov_center = old": "cov_center_old", "exp3.handcrafted_method = ccmaes": "ccmaes",
            "policy.cov = residual": "cov_residual"}
    assert [r[1] for r in rows if r[0] == "exp3.handcrafted_method = ccmaes"] == ["handcrafted"]
    assert "exp3.handcrafted_method = ccmaes: nrvr_rs, rvr_rs, nrvr_a, rvr_a, baseline" in table
    assert len([r for r in rows if r[0] == "policy.cov_center = old"]) == 6
    for label, pol, means, diff, target, other, _speed, _vs in rows:
        fin = final(arms[label])
        d = [float(fin[(pol, k)]["mean_return"]) - float(base[(pol, k)]["mean_return"]) for k in "01"]
        m, se = diff.split(" ± ")
        assert abs(float(m) - sum(d) / 2) <= 5e-4, (label, pol)
        assert abs(float(se) - abs(d[0] - d[1]) / 2) <= 5e-4, (label, pol)
        assert target == f"{base[(pol, '-1')]['pocketed_target']} → {fin[(pol, '-1')]['pocketed_target']}"
        assert other == f"{base[(pol, '-1')]['pocketed_other']} → {fin[(pol, '-1')]['pocketed_other']}"
        assert means == f"{float(base[(pol, '-1')]['mean_return']):.3f} → " \
                        f"{float(fin[(pol, '-1')]['mean_return']):.3f}"
    run_experiment("exp3.ini", tmp_path / "seed2", TINY_EXP3 + ["experiment.seed=2"])
    p = subprocess.run([env["PYTHON"], str(ROOT / "scripts" / "exp3_table.py"), "--compare",
                        str(out / "default"), str(tmp_path / "seed2")], capture_output=True, text=True)
    assert p.returncode != 0 and p.stderr.count("\n") == 1 and "seed 2" in p.stderr
