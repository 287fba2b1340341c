"""End-to-end tests of Experiment 4's controls (data/exp4_controls.ini:
refit-only, matched resolution, mean-action evaluation, the floor study) and
of scripts/exp4_study.py's statistics and generated docs, at a tiny scale.

Run by `make check` with POOLREPS=<abs path to poolreps> and PYTHON=<python
with numpy and scipy>. The checks recompute from the raw CSVs with numpy and
scipy (no code shared with the C or with the script's statistics).
"""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import stats
from conftest import csv_rows, run_experiment

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
import exp4_study  # noqa: E402

PY = os.environ.get("PYTHON") or "/usr/bin/python3"
POLICIES = ["nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a", "baseline", "handcrafted"]
TREES = POLICIES[:4]
N0, T, SAMPLES, NDEMO, LAST, NMIN, NEVAL = 40, 3, 10, 20, 20, 15, 10
TINY = ["experiment.repetitions=2", "experiment.threads=1", f"exp3.init_samples={N0}",
        f"exp3.window={N0}", f"exp3.samples={SAMPLES}", f"exp3.iterations={T}",
        f"exp3.final_episodes={LAST}", f"policy.n_min={NMIN}", "exp3.baseline_n_min=60",
        "value.n_min=12", f"exp4.n_demo={NDEMO}", f"exp4.mean_eval={NEVAL}"]
INITS = ["imitation", "policy", "refit", "matched", "refit_matched"]
ONE_RESOLUTION = ("baseline", "handcrafted")


def run(out, sets=(), check=True, ini="exp4_controls.ini"):
    return run_experiment(ini, out, list(TINY) + list(sets), check)


def labels():
    out = []
    for p in POLICIES:
        for c in (["none"] if p == "handcrafted" else ["query", "residual"]):
            out += [f"{p}.{i}.{c}" for i in INITS
                    if not (i in ("matched", "refit_matched") and p in ONE_RESOLUTION)]
    return out


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("exp4c_tiny")
    run(out)
    return out


def by_run(rows):
    d = {}
    for r in rows:
        d.setdefault((r["repetition"], r["policy"]), []).append(r)
    return d


def test_variants_and_mean_csv(tiny):
    h, mean = csv_rows(tiny / "exp4_mean.csv")
    assert h == ["repetition", "policy", "states", "mean_return", "pocket_rate", "hit_rate",
                 "n_min", "leaves"]
    assert [(r["repetition"], r["policy"]) for r in mean] == \
        [(k, lab) for k in ("0", "1") for lab in labels()]
    _, eps = csv_rows(tiny / "exp4_episodes.csv")
    assert list(dict.fromkeys(r["policy"] for r in eps)) == labels()
    for r in mean:
        assert int(r["states"]) == NEVAL
        assert -10 < float(r["mean_return"]) <= 0
        assert 0 <= float(r["pocket_rate"]) <= float(r["hit_rate"]) <= 1


def test_matched_uses_pi0_resolution(tiny):
    """n_min of the last fit: pi_0's fraction (0.1) of the window for matched
    and refit_matched, policy.n_min for policy and refit, 0.1 x n_demo for
    pi_0; the matched trees have more leaves than the policy.n_min ones on the
    same window size."""
    _, mean = csv_rows(tiny / "exp4_mean.csv")
    m = {(r["repetition"], r["policy"]): r for r in mean}
    for (k, lab), r in m.items():
        p, i, c = lab.split(".")
        if p not in TREES:
            assert int(r["n_min"]) == (0 if p == "handcrafted" else 60), lab
            continue
        want = {"imitation": round(0.1 * NDEMO), "policy": NMIN, "refit": NMIN,
                "matched": round(0.1 * N0), "refit_matched": round(0.1 * N0)}[i]
        assert int(r["n_min"]) == want, lab
        if i == "matched":
            assert int(r["leaves"]) > int(m[(k, f"{p}.policy.{c}")]["leaves"]), lab
            assert int(r["leaves"]) > int(m[(k, f"{p}.refit.{c}")]["leaves"]), lab


def test_controls_share_the_start(tiny):
    """Common random numbers: policy, refit, matched and refit_matched runs of a policy and
    covariance play the same iteration-0 episodes of pi_0, and all runs of a
    repetition the same start states; pi_0's mean action is the same under
    both covariances and for nrvr_x and rvr_x (one fitted pi_0)."""
    _, eps = csv_rows(tiny / "exp4_episodes.csv")
    runs = by_run(eps)
    cols = ["x1", "y1", "vx", "vy", "return"]
    for k in ("0", "1"):
        for p in TREES:
            for c in ("query", "residual"):
                it0 = [[tuple(r[x] for x in cols) for r in runs[(k, f"{p}.{i}.{c}")]
                        if r["iteration"] == "0"] for i in INITS[1:]]
                assert all(x == it0[0] for x in it0)
        starts = {lab: [(r["x1"], r["y1"]) for r in rs] for (kk, lab), rs in runs.items()
                  if kk == k}
        assert len(set(map(tuple, starts.values()))) == 1
    _, mean = csv_rows(tiny / "exp4_mean.csv")
    m = {(r["repetition"], r["policy"]): r["mean_return"] for r in mean}
    for k in ("0", "1"):
        for s in ("rs", "a"):
            vals = {m[(k, f"{v}_{s}.imitation.{c}")] for v in ("nrvr", "rvr")
                    for c in ("query", "residual")}
            assert len(vals) == 1


@pytest.mark.parametrize("init", ["refit", "refit_matched"])
def test_refit_rows_solve_nothing(tiny, init):
    _, reps = csv_rows(tiny / "exp4_reps.csv")
    refit = [r for r in reps if f".{init}." in r["policy"]]
    assert len(refit) == 2 * T * sum(f".{init}." in lab for lab in labels()) > 0
    for r in refit:
        assert float(r["eta"]) == 0 and float(r["kl"]) == 0
        assert float(r["ess"]) == float(r["q_ess"])
    # REPS rows do solve
    assert all(float(r["kl"]) > 0 for r in reps if ".policy." in r["policy"])


def test_mean_eval_changes_nothing_else(tmp_path):
    """exp4.mean_eval draws from its own stream: every other CSV of the
    default variants is byte-identical with and without it, and without it
    there is no exp4_mean.csv."""
    a, b = tmp_path / "a", tmp_path / "b"
    sets = [s for s in TINY if not s.startswith("exp4.mean_eval")]
    run_experiment("exp4.ini", a, sets)
    run_experiment("exp4.ini", b, sets + ["exp4.mean_eval=5"])
    assert not (a / "exp4_mean.csv").exists() and (b / "exp4_mean.csv").exists()
    for f in sorted(a.glob("exp4_*.csv")):
        assert f.read_bytes() == (b / f.name).read_bytes(), f.name


def test_single_variant_equals_its_rows(tiny, tmp_path):
    """experiment.variant = v writes exactly v's rows of the full run (the
    controls' streams depend on the variant, not on the list)."""
    labs = labels()
    _, full = csv_rows(tiny / "exp4_episodes.csv")
    for lab in ("rvr_a.matched.residual", "baseline.refit.query", "nrvr_rs.refit_matched.query"):
        v = labs.index(lab)
        out = tmp_path / lab
        run(out, [f"experiment.variant={v}"])
        _, one = csv_rows(out / "exp4_episodes.csv")
        assert one == [r for r in full if r["policy"] == lab]


def test_refit_matched_changes_no_other_run(tiny, tmp_path):
    """refit_matched came after the other inits with streams of its own: the
    runs without it are byte-identical rows of the run with it; it is the
    matched run without REPS (same pi_0 and iteration 0, then apart)."""
    out = tmp_path / "without"
    run(out, ["exp4.inits=imitation,policy,refit,matched"])
    for name in ("exp4_episodes.csv", "exp4_final.csv", "exp4_mean.csv"):
        _, full = csv_rows(tiny / name)
        _, part = csv_rows(out / name)
        assert part == [r for r in full if ".refit_matched." not in r["policy"]], name
        assert len(part) < len(full)
    _, eps = csv_rows(tiny / "exp4_episodes.csv")
    runs = by_run(eps)
    for k in ("0", "1"):
        for p in TREES:
            a, b = ([{c: r[c] for c in r if c != "policy"} for r in runs[(k, f"{p}.{i}.query")]]
                    for i in ("refit_matched", "matched"))
            assert first_diff(a, b) == 1


def first_diff(a, b):
    """First iteration whose episodes differ between row lists a and b."""
    for x, y in zip(a, b):
        if x != y:
            return int(x["iteration"])
    return None


def test_floor_changes_exactly_the_floored_fits(tmp_path):
    """policy.min_std 1 mm/s against 1e-9 m/s (the floor practically off),
    runs from scratch (pi_0 = N(0, 0.01 I), never floored): the summary's
    floor_iterations count the raw rows flagged floored; a run with no
    floored iteration under either floor (1e-9 m/s still lifts a degenerate
    variance) plays the same episodes under both floors; in one with
    some, the episodes part at the first floored iteration or the next (the
    floor changed a draw of pi_t, or only the densities pi_t gives the window,
    and with them pi_{t+1})."""
    a, b = tmp_path / "a", tmp_path / "b"
    sets = ["exp4.inits=scratch", "exp4.covs=residual", "exp4.mean_eval=0",
            "experiment.repetitions=3"]
    run(a, sets + ["policy.min_std=0.001"])
    run(b, sets + ["policy.min_std=1e-9"])
    _, summ = csv_rows(a / "exp4_reps_summary.csv")
    floored = {r["policy"]: int(r["floor_iterations"]) for r in summ}
    _, reps = csv_rows(a / "exp4_reps.csv")
    _, reps_b = csv_rows(b / "exp4_reps.csv")
    first = {}
    for r in reps + reps_b:
        if int(r["policy_flags"]) & 16:
            k = (r["repetition"], r["policy"])
            first[k] = min(first.get(k, T + 1), int(r["iteration"]))
    for lab, n in floored.items():
        assert n == sum(1 for r in reps if r["policy"] == lab and int(r["policy_flags"]) & 16)
    ea = by_run(csv_rows(a / "exp4_episodes.csv")[1])
    eb = by_run(csv_rows(b / "exp4_episodes.csv")[1])
    nfloored = 0
    for k in ea:
        d = first_diff(ea[k], eb[k])
        if k not in first:
            assert d is None, k
        else:
            nfloored += 1
            # at the last iteration a floor in pi_T's densities of the window
            # has nothing later to change
            want = (first[k], None) if first[k] == T else (first[k], first[k] + 1)
            assert d in want, (k, first[k], d)
    assert 0 < nfloored < len(ea), "every run or none floored: the test tells nothing apart"


def refused(p, key):
    assert p.returncode == 1, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and key in lines[0], p.stderr


@pytest.mark.parametrize("sets,key", [
    (["exp4.inits=refit"], "data/exp4.ini"),  # its [reps] epsilon, with the line
    (["exp4.inits=refit,imitation", "reps.epsilon=0.1"], "reps.epsilon"),
    (["exp4.inits=matched", "policy.n_min=10"], "policy.n_min"),
    (["exp4.inits=matched,imitation", "policy.n_min=10"], "policy.n_min"),
    (["exp4.inits=refit_matched,imitation", "reps.epsilon=0.1"], "reps.epsilon"),
    (["exp4.inits=refit_matched", "policy.n_min=10", "reps.epsilon=0.1"], "reps.epsilon"),
    (["exp4.inits=matched,refit_matched", "policy.n_min=10"], "policy.n_min"),
    (["exp4.inits=policy,bogus"], "exp4.inits"),
])
def test_bad_control_keys(tmp_path, sets, key):
    out = tmp_path / "out"
    refused(run_experiment("exp4.ini", out, list(TINY) + sets, check=False), key)
    assert not out.exists()


def test_refit_refuses_any_reps_key(tmp_path):
    """Without a [reps] section in the file, each reps key given by --set is
    named."""
    text = (ROOT / "data" / "exp4.ini").read_text()
    ini = tmp_path / "noreps.ini"
    ini.write_text(text[:text.index("[reps]")])
    for key, v in (("reps.max_iter", "50"), ("reps.ridge", "0.1"), ("reps.allow_failed", "1")):
        cmd = [os.environ.get("POOLREPS", str(ROOT / "poolreps")), str(ini), "-q", "-o",
               str(tmp_path / "o")]
        for s in list(TINY) + ["exp4.inits=refit", f"{key}={v}"]:
            cmd += ["--set", s]
        refused(subprocess.run(cmd, capture_output=True, text=True), key)
        assert not (tmp_path / "o").exists()
    cmd = [os.environ.get("POOLREPS", str(ROOT / "poolreps")), str(ini), "-q", "-o",
           str(tmp_path / "ok")]
    for s in list(TINY) + ["exp4.inits=refit", "experiment.repetitions=1"]:
        cmd += ["--set", s]
    p = subprocess.run(cmd, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr


def test_control_keys_accepted_with_a_reps_run(tmp_path):
    run_experiment("exp4.ini", tmp_path / "o", list(TINY) +
                   ["exp4.inits=refit,policy", "reps.epsilon=0.1",
                    "experiment.repetitions=1"])


# ---- scripts/exp4_study.py ----

def test_holm_and_paired_against_scipy():
    rng = np.random.default_rng(5)
    for _ in range(50):
        n = int(rng.integers(2, 30))
        x = rng.normal(size=n)
        y = x + rng.normal(rng.normal(), 1.0 + rng.random(), size=n)
        m, lo, hi, p, nn = exp4_study.paired(x, y)
        t = stats.ttest_rel(x, y)
        d = x - y
        ci = stats.t.interval(0.95, n - 1, loc=d.mean(), scale=stats.sem(d))
        assert nn == n and np.isclose(p, t.pvalue, rtol=1e-10, atol=0)
        assert np.isclose(m, d.mean()) and np.allclose([lo, hi], ci, rtol=1e-10)
        ps = rng.random(int(rng.integers(1, 12))) ** 3
        assert np.allclose(exp4_study.holm(ps), holm_def(ps), rtol=0, atol=1e-15)
    # degenerate: constant differences
    assert exp4_study.paired([1.0, 2.0], [1.0, 2.0])[3] == 1.0
    assert exp4_study.paired([1.0, 2.0], [0.5, 1.5])[3] == 0.0


def holm_def(ps):
    """Holm from its definition: max over j <= rank of (k - j) p_(j), capped."""
    k, order = len(ps), np.argsort(ps, kind="stable")
    want = np.empty(k)
    for r, i in enumerate(order):
        want[i] = min(1.0, max((k - j) * ps[order[j]] for j in range(r + 1)))
    return want


def test_margin_verdicts_against_scipy():
    """Worse / better than the margin and within it (TOST), Holm over the
    three tests of every comparison: against scipy's one-sample t tests."""
    rng = np.random.default_rng(7)
    m = 0.05
    seen = set()
    for _ in range(40):
        fam = []
        for _ in range(int(rng.integers(1, 8))):
            n = int(rng.integers(3, 30))
            x = rng.normal(size=n)
            y = x - rng.normal(rng.normal(0, 0.08), rng.uniform(0.005, 0.1), size=n)
            fam.append({"x": list(x), "y": list(y), "diff": float(np.mean(x - y))})
        exp4_study.margin_verdicts(fam, m)
        ps = []
        for r in fam:
            d = np.subtract(r["x"], r["y"])
            t = lambda mu, alt: stats.ttest_1samp(d, mu, alternative=alt).pvalue  # noqa: E731
            ps += [t(-m, "less"), t(m, "greater"), max(t(-m, "greater"), t(m, "less"))]
        adj = holm_def(np.array(ps))
        for i, r in enumerate(fam):
            b, a, w = adj[3 * i: 3 * i + 3]
            assert np.allclose([r["p_below_holm"], r["p_above_holm"], r["p_within_holm"]],
                               [b, a, w], rtol=1e-9, atol=1e-12)
            want = ("degrades" if b < 0.05 else "improves" if a < 0.05 else
                    "within" if w < 0.05 else "undecided")
            assert r["margin_verdict"] == want
            seen.add(want)
    assert seen == {"degrades", "improves", "within", "undecided"}


def test_split_adds_up():
    """Every REPS effect is its reweighting plus its refitting, run by run,
    in the committed verdicts.csv: total = (A vs control) + (control vs
    imitation) for the mean differences."""
    rows = csv_rows(ROOT / "docs" / "exp4_study" / "verdicts.csv")[1]
    by = {(r["measure"], r["arm_a"], r["variant_a"], r["arm_b"], r["variant_b"]): float(r["diff"])
          for r in rows}
    n = 0
    for (meas, aa, va, ab, vb), d in by.items():
        p, i, c = va.split(".")
        if vb != f"{p}.imitation.{c}" or i not in ("policy", "matched"):
            continue
        ctl = "refit" if i == "policy" else "refit_matched"
        carm = "main" if aa.startswith("eps") else aa
        cv = f"{p}.{ctl}.{c}"
        key1, key2 = (meas, aa, va, carm, cv), (meas, carm, cv, ab, vb)
        if key1 in by and key2 in by:
            assert np.isclose(d, by[key1] + by[key2], rtol=0, atol=2e-8), (meas, aa, va)
            n += 1
    assert n >= 2 * (8 + 8 + 11 + 4)


def test_headline_split_intervals():
    """The headline's three mean changes and their 95 % intervals, from
    runs.csv by numpy and scipy: per repetition, the mean over the 8 tree
    cells of matched - imitation, refit_matched - imitation and matched -
    refit_matched in the main arm; scipy's t interval over the repetitions."""
    runs = csv_rows(ROOT / "docs" / "exp4_study" / "runs.csv")[1]
    val = {(r["arm"], r["variant"], r["repetition"]): r for r in runs}
    reps = sorted({r["repetition"] for r in runs}, key=int)
    cells = [(p, c) for p in TREES for c in ("query", "residual")]
    text = (ROOT / "docs" / "exp4.md").read_text()
    for col, lead in (("final_return", "of its mean change, "),
                      ("mean_action_return", "By mean actions the change is ")):
        def mean_change(a, b):
            d = [np.mean([float(val[("main", f"{p}.{a}.{c}", k)][col]) -
                          float(val[("main", f"{p}.{b}.{c}", k)][col]) for p, c in cells])
                 for k in reps]
            m, se = np.mean(d), stats.sem(d)
            lo, hi = stats.t.interval(0.95, len(d) - 1, loc=m, scale=se)
            return f"{m:+.3f} m [{lo:+.3f}, {hi:+.3f}]"
        want = [mean_change("matched", "imitation"), mean_change("refit_matched", "imitation"),
                mean_change("matched", "refit_matched")]
        i = text.index(lead) + len(lead)
        got = text[i:text.index(".", text.index("]", text.index("]", text.index("]", i) + 1) + 1))]
        for w in want:
            assert w in got, (col, w, got)


@pytest.mark.slow
def test_study_script_runs_its_own_arms(tmp_path):
    """scripts/exp4_study.sh at a tiny size: the six arms of the study (not
    study_lib.sh's physics arms), every control in runs.csv, and the answer
    generated from them."""
    out, docs = tmp_path / "out", tmp_path / "docs"
    docs.mkdir()
    opts = [w for s in TINY if not s.startswith("experiment.") for w in ("--set", s)]
    env = dict(os.environ, NICE="0",
               POOLREPS=os.environ.get("POOLREPS", str(ROOT / "poolreps")))
    p = subprocess.run(["sh", str(ROOT / "scripts" / "exp4_study.sh"), str(out), "2", str(docs),
                        PY] + opts, capture_output=True, text=True, env=env, cwd=ROOT)
    assert p.returncode == 0, p.stderr
    _, runs = csv_rows(docs / "exp4_study" / "runs.csv")
    assert sorted({r["arm"] for r in runs}) == sorted(
        ["main", "eps0.1", "eps0.25", "floor3", "floor10", "floor0"])
    assert {r["init"] for r in runs if r["arm"] == "main"} == set(INITS)
    assert {r["init"] for r in runs if r["arm"] == "floor0"} == set(INITS)
    doc = tmp_path / "exp4.md"
    doc.write_text((ROOT / "docs" / "exp4.md").read_text())
    p = subprocess.run([PY, str(ROOT / "scripts" / "exp4_study.py"), "docs",
                        str(docs / "exp4_study"), "--doc", str(doc)],
                       capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0 and "2 paired repetitions" in doc.read_text(), p.stderr


def test_docs_match_the_committed_csvs():
    """docs/exp4.md's and README.md's generated blocks are those of
    docs/exp4_study/*.csv."""
    p = subprocess.run([PY, str(ROOT / "scripts" / "exp4_study.py"), "docs",
                        str(ROOT / "docs" / "exp4_study"), "--doc", str(ROOT / "docs" / "exp4.md"),
                        "--readme", str(ROOT / "README.md"), "--check"],
                       capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0, p.stderr


def test_docs_check_fails_on_a_changed_number(tmp_path):
    doc = tmp_path / "exp4.md"
    text = (ROOT / "docs" / "exp4.md").read_text()
    i = text.index("\n| nrvr_rs", text.index("<!-- exp4-study:split -->"))
    while not text[i].isdigit():
        i += 1
    doc.write_text(text[:i] + ("2" if text[i] == "1" else "1") + text[i + 1:])
    p = subprocess.run([PY, str(ROOT / "scripts" / "exp4_study.py"), "docs",
                        str(ROOT / "docs" / "exp4_study"), "--doc", str(doc), "--check"],
                       capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 1 and "split" in p.stderr


def test_docs_refuse_verdicts_not_those_of_the_runs(tmp_path):
    """verdicts.csv (the differences, p-values and verdict words the tables
    print) must be what runs.csv gives: a run's return changed, or a verdict
    word edited, is refused by `docs` and by `docs --check`."""
    src = ROOT / "docs" / "exp4_study"
    for name in ("runs.csv", "verdicts.csv", "timing.csv", "curves.csv"):
        (tmp_path / name).write_text((src / name).read_text())
    runs = (tmp_path / "runs.csv").read_text().splitlines()
    head = runs[0].split(",")
    row = runs[1].split(",")
    col = head.index("final_return")
    row[col] = repr(float(row[col]) + 0.5)
    (tmp_path / "runs.csv").write_text("\n".join([runs[0], ",".join(row)] + runs[2:]) + "\n")
    doc = tmp_path / "exp4.md"
    doc.write_text((ROOT / "docs" / "exp4.md").read_text())
    for extra in ([], ["--check"]):
        p = subprocess.run([PY, str(ROOT / "scripts" / "exp4_study.py"), "docs", str(tmp_path),
                            "--doc", str(doc)] + extra, capture_output=True, text=True, cwd=ROOT)
        assert p.returncode != 0 and "verdicts.csv" in p.stderr, (extra, p.stderr)
    (tmp_path / "runs.csv").write_text((src / "runs.csv").read_text())
    ver = (tmp_path / "verdicts.csv").read_text()
    (tmp_path / "verdicts.csv").write_text(ver.replace(",degrades\n", ",improves\n", 1))
    p = subprocess.run([PY, str(ROOT / "scripts" / "exp4_study.py"), "docs", str(tmp_path),
                        "--doc", str(doc), "--check"], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode != 0 and "verdicts.csv" in p.stderr, p.stderr
