"""End-to-end runs of the exploration options: policy.cov_center, bench.method
= ccmaes, exp3.handcrafted_method = ccmaes, and the comparison plot."""
import os
import sys

import numpy as np
import pytest

from conftest import ROOT, csv_rows, poolreps_path, quick_sets, run_cmd, run_experiment


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


def explore_env():
    return dict(os.environ, POOLREPS=poolreps_path() or str(ROOT / "poolreps"),
                PYTHON=os.environ.get("PYTHON") or sys.executable)


@pytest.fixture(scope="module")
def explore(tmp_path_factory):
    """scripts/exp3_explore.sh on Experiment 3's quick settings: the folders
    default, cov_center_old and ccmaes, compare.md, and a document whose
    marked block the table replaced."""
    if poolreps_path() is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    out = tmp_path_factory.mktemp("explore")
    quick = quick_sets("exp3")
    reps = next(q.split("=")[1] for q in quick if q.startswith("experiment.repetitions="))
    doc = out / "doc.md"
    doc.write_text(f"before\n<!-- explore-{reps}:begin -->\nold table\n<!-- explore-{reps}:end -->\nafter\n")
    sets = [x for q in quick if not q.startswith("experiment.repetitions=") for x in ("--set", q)]
    p = run_cmd(["sh", ROOT / "scripts" / "exp3_explore.sh", out / "arms", reps, doc] + sets,
                capture_output=True, text=True, env=explore_env())
    assert p.returncode == 0, p.stderr
    return out / "arms", doc, reps, quick


def result_csvs(d):
    """{name: bytes} of the CSVs of a result folder."""
    return {f.name: f.read_bytes() for f in sorted(d.glob("*.csv"))}


@pytest.mark.slow
def test_exp3_cov_center_new_is_default_old_differs(explore, tmp_path):
    """policy.cov_center = new set explicitly writes the default's bytes;
    = old reaches every Experiment 3 variant (the tree-LWR fits centre eq. 6.8
    on the recorded sampling means, the linear fit on its own): each run
    shares the default's initial episodes and then draws other actions; the
    output does not depend on the thread count."""
    arms, _, _, quick = explore
    run_experiment("exp3.ini", tmp_path / "new", quick + ["policy.cov_center=new"])
    assert result_csvs(tmp_path / "new") == result_csvs(arms / "default")
    run_experiment("exp3.ini", tmp_path / "old1", quick + ["policy.cov_center=old", "experiment.threads=1"])
    assert result_csvs(tmp_path / "old1") == result_csvs(arms / "cov_center_old")
    new, old = episodes_by_run(arms / "default" / "exp3_episodes.csv"), \
        episodes_by_run(arms / "cov_center_old" / "exp3_episodes.csv")
    assert sorted(old) == sorted(new) and len(old) == 12
    for run, eps in old.items():
        assert [e for e in eps if e[0] == "0"] == [e for e in new[run] if e[0] == "0"], run
        assert [e for e in eps if e[0] != "0"] != [e for e in new[run] if e[0] != "0"], run


def episodes_by_run(path):
    """{(policy, repetition): [(iteration, vx, vy), ...]} of exp3_episodes.csv."""
    out = {}
    for r in csv_rows(path)[1]:
        out.setdefault((r["policy"], r["repetition"]), []).append((r["iteration"], r["vx"], r["vy"]))
    return out


def table_cells(text):
    """The rows of a markdown table in text (header and rule left out) as lists of cells."""
    rows = [line.strip("|").split(" | ") for line in text.splitlines() if line.startswith("| ")]
    return [[c.strip() for c in r] for r in rows[1:]]


def reference(folder, last):
    """From exp3_episodes.csv alone, with numpy: {policy: (per-repetition mean
    returns of each run's last `last` episodes, pooled mean return, % pocket 2
    or 5, % other pocket, median speed, median over runs of the spread
    sqrt(var vx + var vy) (ddof 1) of the run's last iteration's actions)}."""
    header, rows = csv_rows(folder / "exp3_episodes.csv")
    e = {h: np.array([r[h] for r in rows], dtype=str if h == "policy" else float) for h in header}
    out = {}
    for pol in np.unique(e["policy"]):
        runs = [np.flatnonzero((e["policy"] == pol) & (e["repetition"] == k))[-last:]
                for k in np.unique(e["repetition"])]
        fin = np.concatenate(runs)
        out[str(pol)] = (np.array([e["return"][r].mean() for r in runs]), e["return"][fin].mean(),
                         100 * np.isin(e["pocket"][fin], (2, 5)).mean(),
                         100 * (~np.isin(e["pocket"][fin], (-1, 2, 5))).mean(),
                         np.median(np.hypot(e["vx"][fin], e["vy"][fin])),
                         np.median([spread(e, r) for r in runs]))
    return out


def spread(e, run):
    last = run[e["iteration"][run] == e["iteration"][run].max()]
    return np.sqrt(e["vx"][last].var(ddof=1) + e["vy"][last].var(ddof=1))


def mean_se(cell):
    m, se = cell.split(" ± ")
    return float(m), float(se)


@pytest.mark.slow
def test_exp3_explore_table(explore, tmp_path):
    """scripts/exp3_table.py --compare (through scripts/exp3_explore.sh) against
    an independent numpy computation from each folder's exp3_episodes.csv:
    per arm and policy the pooled means, the paired difference arm − default
    of the per-repetition means (mean and sd (ddof 1) / sqrt(n)), the pocket
    rates, the median speed, the spread of the last iteration's actions and
    the difference to the baseline. Tolerances:
    half a unit of the printed last digit (3 decimals for returns, 1 for
    percentages, 2 for speeds) plus 1e-9. The ccmaes arm lists only the
    hand-crafted variant; without --label an arm is named by its changed key;
    the table replaces the marked block of a document; an arm with another
    seed is refused with one line."""
    arms, doc, reps, quick = explore
    table = (arms / "compare.md").read_text()
    assert doc.read_text() == (f"before\n<!-- explore-{reps}:begin -->\n" + table +
                               f"<!-- explore-{reps}:end -->\nafter\n")
    last = int(next(q.split("=")[1] for q in quick if q.startswith("exp3.final_episodes=")))
    base = reference(arms / "default", last)
    folders = {"policy.cov_center = old": "cov_center_old", "exp3.handcrafted_method = ccmaes": "ccmaes"}
    rows = table_cells(table)
    assert [r[1] for r in rows if r[0] == "exp3.handcrafted_method = ccmaes"] == ["handcrafted"]
    assert "exp3.handcrafted_method = ccmaes: nrvr_rs, rvr_rs, nrvr_a, rvr_a, baseline" in table
    assert [r[1] for r in rows if r[0] == "policy.cov_center = old"] == \
        ["nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a", "baseline", "handcrafted"]
    t3, t1, t2 = 5e-4 + 1e-9, 0.05 + 1e-9, 0.005 + 1e-9
    for label, pol, means, diff, target, other, speed, sprd, vs in rows:
        arm = reference(arms / folders[label], last)
        b, a = base[pol], arm[pol]
        d = a[0] - b[0]
        m, se = mean_se(diff)
        assert abs(m - d.mean()) <= t3 and abs(se - d.std(ddof=1) / np.sqrt(d.size)) <= t3, (label, pol)
        for cell, (x, y), tol in ((means, (b[1], a[1]), t3), (target, (b[2], a[2]), t1),
                                  (other, (b[3], a[3]), t1), (speed, (b[4], a[4]), t2),
                                  (sprd, (b[5], a[5]), t2)):
            got = [float(v) for v in cell.split(" → ")]
            assert abs(got[0] - x) <= tol and abs(got[1] - y) <= tol, (label, pol, cell)
        if pol == "baseline":
            assert vs == "– → –"
            continue
        for cell, ref in zip(vs.split(" → "), (b[0] - base["baseline"][0], a[0] - arm["baseline"][0])):
            m, se = mean_se(cell)
            assert abs(m - ref.mean()) <= t3 and abs(se - ref.std(ddof=1) / np.sqrt(ref.size)) <= t3
    # without --label an arm is named by the keys its config.ini sets differently
    p = run_cmd([explore_env()["PYTHON"], ROOT / "scripts" / "exp3_table.py", "--compare",
                 arms / "default", arms / "ccmaes"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert [r[0] for r in table_cells(p.stdout)] == ["exp3.handcrafted_method=ccmaes"]
    run_experiment("exp3.ini", tmp_path / "seed2", quick + ["experiment.seed=2"])
    p = run_cmd([explore_env()["PYTHON"], ROOT / "scripts" / "exp3_table.py", "--compare",
                 arms / "default", tmp_path / "seed2"], capture_output=True, text=True)
    assert p.returncode != 0 and p.stderr.count("\n") == 1 and "seed 2" in p.stderr
