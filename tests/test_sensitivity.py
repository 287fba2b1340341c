"""The sensitivity study (make sensitivity, docs/sensitivity.md): the QUICK=1
pipeline end to end on the real binary (scripts/sensitivity.sh: sweeps,
GNU Parallel, collect, verdicts, report), that the committed report and
README sentence are exactly what the committed CSVs generate, and the flip
logic on hand-made verdicts.
Run by `make check` with POOLREPS=<abs path to poolreps>.
"""
import csv
import importlib.util
import re
import shutil
import sys

import pytest

from conftest import ROOT, poolreps_path, run_cmd

sys.path.insert(0, str(ROOT / "scripts"))
spec = importlib.util.spec_from_file_location("sensitivity_stats",
                                              ROOT / "scripts" / "sensitivity_stats.py")
ss = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ss)
DATA = ROOT / "docs" / "data" / "sensitivity"


def quick_args():
    """The QUICK=1 settings, from the Makefile's recipe."""
    p = run_cmd(["make", "-n", "-s", "sensitivity", "QUICK=1", "OUT=/o"], cwd=ROOT,
                capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    line = next(x for x in p.stdout.splitlines() if "sensitivity.sh" in x)
    words = line.split()
    return [w.strip('"') for w in words[words.index('"/o/sensitivity/docs"') + 2:]], words


def test_quick_study(tmp_path):
    """QUICK=1 on every point: one merged run per point, every claim's
    verdict at every point, a report without placeholders or NaN."""
    binary = poolreps_path()
    if binary is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    if shutil.which("parallel") is None:
        pytest.skip("GNU parallel not installed")
    args, words = quick_args()
    assert words[3] == "3"
    out, docs = tmp_path / "study", tmp_path / "docs"
    docs.mkdir()
    p = run_cmd(["sh", ROOT / "scripts" / "sensitivity.sh", out, "3", docs, sys.executable]
                + args, capture_output=True, text=True, cwd=tmp_path, timeout=300,
                env=dict(__import__("os").environ, POOLREPS=binary, LC_ALL="C"))
    assert p.returncode == 0, p.stdout + p.stderr
    for name, *_ in ss.POINTS:
        assert (out / name / "exp3_episodes.csv").is_file()
    with open(docs / "data" / "sensitivity" / "claims.csv", newline="") as f:
        claims = list(csv.DictReader(f))
    assert {(r["point"], r["claim"]) for r in claims} == {
        (n, c) for n, *_ in ss.POINTS for c in ss.CLAIMS}
    assert {r["verdict"] for r in claims} <= set(ss.SYMBOL)
    md = (docs / "sensitivity.md").read_text(encoding="utf-8")
    assert not re.search(r"\bnan\b", md, re.I)
    assert "at 3 repetitions" in md and "CPU seconds" in md
    for _, choice, label, _, _ in ss.POINTS[1:]:
        assert f"| {label} " in md or label in md


def test_point_options_are_keys():
    """Every point's options are valid keys: `poolreps config` accepts them."""
    binary = poolreps_path()
    if binary is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    for name, _, _, sets, ref in ss.POINTS:
        assert ref is None or ref in ss.BY_NAME
        args = [binary, "config", "-c", ROOT / "data" / "exp3.ini"]
        for s in sets:
            args += ["--set", s]
        p = run_cmd(args, capture_output=True, text=True)
        assert p.returncode == 0, (name, p.stderr)


def fake_results(verdicts):
    """A Results object from {point: {claim: verdict}} without files."""
    r = ss.Results.__new__(ss.Results)
    r.points = list(verdicts)
    r.verdict = {(p, c): v for p, d in verdicts.items() for c, v in d.items()}
    r.detail = {k: "" for k in r.verdict}
    r.runs = {"default": {"repetitions": "30"}}
    return r


def test_flips_against_the_reference():
    ids = list(ss.CLAIMS)
    base = {c: "undecided" for c in ids}
    law = dict(base, even="agrees")
    a_half = dict(law)                     # same as the constant law: no flip there
    eps = dict(base, converged="disagrees")
    r = fake_results({"default": base, "law_constant": law, "a_half": a_half, "eps_1": eps})
    assert r.flips("law_constant") == ["even"]
    assert r.flips("a_half") == []          # its reference is the constant law
    assert r.flips("eps_1") == ["converged"]
    keep, moved = r.robust()
    assert moved == {"even": ["friction law"], "converged": ["epsilon"]}
    assert set(keep) == set(ids) - {"even", "converged"}
    s = ss.sentence(r)
    assert "3 alternatives" in s and "`even` changes under friction law" in s


def test_committed_report_is_generated(tmp_path):
    """docs/sensitivity.md, the README sentence and docs/choices.md's one-line
    results are what the committed CSVs give."""
    if not (DATA / "claims.csv").is_file():
        pytest.skip("no committed study")
    readme = tmp_path / "README.md"
    readme.write_text((ROOT / "README.md").read_text(encoding="utf-8"), encoding="utf-8")
    choices = tmp_path / "choices.md"
    choices.write_text((ROOT / "docs" / "choices.md").read_text(encoding="utf-8"),
                       encoding="utf-8")
    p = run_cmd([sys.executable, ROOT / "scripts" / "sensitivity_stats.py", "--csv", DATA,
                 "--docs", tmp_path, "--readme", readme], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "sensitivity.md").read_text(encoding="utf-8") == \
        (ROOT / "docs" / "sensitivity.md").read_text(encoding="utf-8")
    assert readme.read_text(encoding="utf-8") == (ROOT / "README.md").read_text(encoding="utf-8")
    assert choices.read_text(encoding="utf-8") == \
        (ROOT / "docs" / "choices.md").read_text(encoding="utf-8")


def test_real_table_sentence():
    """The README's sentence on the slide_roll point names the verdicts that
    change against the default and says whether one reverses."""
    ids = list(ss.CLAIMS)
    base = {c: "undecided" for c in ids}
    slide = dict(base, best="disagrees")
    r = fake_results({"default": base, "law_slide_roll": slide})
    r.runs["law_slide_roll"] = {"repetitions": "20"}
    s = ss.real_table(r)
    assert f"1 of the {len(ids)} Experiment 3 verdicts change against the default" in s, s
    assert "`best` ? → ✗" in s and "none reverses" in s and "20 repetitions" in s, s
    r = fake_results({"default": dict(base, best="agrees"), "law_slide_roll": slide})
    r.runs["law_slide_roll"] = {"repetitions": "20"}
    assert "`best` reverses between agrees and disagrees" in ss.real_table(r)
    r = fake_results({"default": base, "law_slide_roll": dict(base)})
    r.runs["law_slide_roll"] = {"repetitions": "20"}
    assert f"all {len(ids)} Experiment 3 verdicts stay the same" in ss.real_table(r)
