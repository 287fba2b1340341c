"""The report page of `make reproduce` (scripts/reproduce.sh, scripts/report.py,
scripts/claims.py): a static HTML page with every figure and its caption,
the claims table and the Experiment 3 table computed from the run's CSVs,
provenance and timings; it renders in a headless Chromium (skipped when no
browser is installed). Also the claims' rules on made-up results.

Run by `make check` with POOLREPS=<abs path of the binary> and PYTHON=<a
Python with matplotlib>.
"""
import csv
import hashlib
import html.parser
import os
import re
import shutil
import sys

import pytest
from conftest import ROOT, quick_sets, run_cmd

PY = os.environ.get("PYTHON") or "/usr/bin/python3"
SCRIPTS = ROOT / "scripts"
sys.path.insert(0, str(SCRIPTS))
import experiments  # noqa: E402  (the registry, as `poolreps help experiments` prints it)

# the experiments with quick settings; test_every_experiment_has_quick_settings
# holds them to the registry
QUICK = sorted(p.stem for p in (ROOT / "data" / "quick").glob("*.ini"))
STEMS = ["fig7_1_table", "fig7_2_reward", "fig7_3_shots", "fig7_4a_nmin", "fig7_4b_trees",
         "fig7_4c_cuts", "exp1_map", "fig7_5_ghost", "fig7_6", "fig7_7", "fig7_8", "fig7_9",
         "fig7_10", "exp4_curves_query", "exp4_curves_residual", "exp4_final", "exp4_rates",
         "bench_quadratic", "bench_sphere", "bench_rosenbrock"]
VERDICTS = {"agrees", "disagrees", "undecided"}
VOID = {"meta", "img", "br", "hr", "link", "input", "source", "wbr"}


@pytest.fixture
def out(quick_reproduction):
    """The session's quick reproduction (conftest.py)."""
    return quick_reproduction


@pytest.mark.native
def test_quick_reproduction_writes_the_recorded_bytes(out):
    """Every CSV of the quick reproduction equals, byte for byte, the one
    recorded in tests/data/quick_reproduce.sha256 (timings.csv, wall times,
    aside): a change that should not touch any result does not. After a change
    that alters results on purpose, `make quick-sums` records the new bytes.
    Native: valgrind computes GSL's long double sums in double precision, so
    the last digit of a standard error may differ under it."""
    recorded = {}
    for line in (ROOT / "tests" / "data" / "quick_reproduce.sha256").read_text().splitlines():
        digest, name = line.split("  ", 1)
        recorded[name] = digest
    written = {str(p.relative_to(out)): hashlib.sha256(p.read_bytes()).hexdigest()
               for p in out.rglob("*.csv") if p.name != "timings.csv"}
    assert sorted(written) == sorted(recorded), "the set of CSVs changed"
    changed = [n for n in sorted(recorded) if written[n] != recorded[n]]
    assert not changed, f"outputs differ from the recorded bytes: {changed}"


def test_every_experiment_has_quick_settings(poolreps):
    """The registry (`poolreps help experiments`) is the one list: every
    experiment but the figures has data/NAME.ini and data/quick/NAME.ini,
    and no quick file names an experiment it does not hold."""
    reg = experiments.registry(os.environ.get("POOLREPS"))
    assert QUICK == sorted(r["name"] for r in reg if r["kind"] != "figures")
    assert all((ROOT / "data" / f"{r['name']}.ini").exists() for r in reg)


def test_the_registry_listing_is_csv_in_registry_order(poolreps):
    r = poolreps(["help", "experiments"])
    assert r.returncode == 0 and r.stderr == b""
    rows = list(csv.reader(r.stdout.decode().splitlines()))
    assert rows[0] == ["name", "folder", "kind", "summary", "title"]
    assert all(len(x) == 5 and x[2] in ("figures", "experiment", "benchmark") for x in rows[1:])
    assert [x[0] for x in rows[1:]][:2] == ["figures", "exp1"] and ["figures", "sim"] == rows[1][:2]
    bad = poolreps(["help", "experiments", "more"])
    assert bad.returncode == 1 and bad.stdout == b""
    assert bad.stderr.decode() == "poolreps: help: unexpected argument 'more'\n"


@pytest.mark.parametrize("name", QUICK)
def test_quick_settings_are_valid(name, poolreps):
    """data/quick/NAME.ini sets keys poolreps knows, to values it accepts, on
    top of data/NAME.ini."""
    sets = quick_sets(name)
    assert sets and any(s.startswith("experiment.repetitions=") for s in sets)
    args = ["config", "-c", ROOT / "data" / f"{name}.ini"]
    for s in sets:
        args += ["--set", s]
    r = poolreps(args)
    assert r.returncode == 0, r.stderr
    ini = r.stdout.decode()
    for s in sets:
        key, value = s.split("=", 1)
        section, k = key.split(".")
        block = ini[ini.index(f"[{section}]"):]
        assert re.search(rf"^{k} = {re.escape(value)}$", block, re.M), s


class Page(html.parser.HTMLParser):
    """Collects the structure of the page and every problem with it."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.stack, self.problems = [], []
        self.tags, self.imgs, self.links, self.ids = [], [], [], []
        self.figures = []            # [figure id, caption text]
        self.tables = []             # [[row cells]]
        self.doctype = False
        self._cell = None

    def handle_decl(self, decl):
        self.doctype = decl.lower() == "doctype html"

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append(tag)
        for k, v in attrs:
            if v and ("://" in v or v.startswith("//")) and k in ("src", "href", "action"):
                self.problems.append(f"<{tag} {k}={v}> leaves the page")
            if k.startswith("on"):
                self.problems.append(f"<{tag} {k}=...>: an event handler")
        if "id" in a:
            self.ids.append(a["id"])
        if tag == "img":
            self.imgs.append(a)
        if tag == "a" and "href" in a:
            self.links.append(a["href"])
        if tag == "figure":
            self.figures.append([a.get("id"), ""])
        if tag == "table":
            self.tables.append([])
        if tag == "tr":
            self.tables[-1].append([])
        if tag in ("td", "th"):
            self._cell = ""
        if tag not in VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag):
        if tag in VOID:
            return
        if not self.stack or self.stack[-1] != tag:
            self.problems.append(f"</{tag}> closes <{self.stack[-1] if self.stack else None}>")
            return
        self.stack.pop()
        if tag in ("td", "th"):
            self.tables[-1][-1].append(self._cell.strip())
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data
        if "figcaption" in self.stack and self.figures:
            self.figures[-1][1] += data


def parse(path):
    page = Page()
    page.feed(path.read_text(encoding="utf-8"))
    page.close()
    return page


@pytest.mark.slow
def test_report_html_structure(out):
    page = parse(out / "report.html")
    assert page.doctype and not page.problems and not page.stack, (page.problems, page.stack)
    assert "script" not in page.tags and "iframe" not in page.tags
    assert page.tags.count("html") == 1 and page.tags.count("style") == 1
    assert {"claims", "exp3", "exp4", "figures", "provenance"} <= set(page.ids)
    # every figure once, as its PNG with a link to its SVG, with a caption of some words
    assert [f[0] for f in page.figures] == STEMS
    for stem, caption in page.figures:
        assert len(caption.split()) >= 15, stem
    srcs = [i["src"] for i in page.imgs]
    assert srcs == [f"figures/{s}.png" for s in STEMS]
    for i in page.imgs:
        assert (out / i["src"]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and i.get("alt")
    for s in STEMS:
        assert f"figures/{s}.svg" in page.links
        assert (out / "figures" / f"{s}.svg").stat().st_size > 1000
    for href in page.links:
        assert href.startswith("#") or (out / href).is_file(), href
    # the tables: the study's verdicts (13 rows, one per mode and one over them), this
    # run's sample (13 rows, no verdicts), Experiments 3 and 4, provenance, timings
    study, sample, exp3, exp4, prov, cmds, timing = page.tables
    assert study[0][:2] == ["thesis", "claim"] and study[0][-1] == "verdict" and len(study) == 14
    assert all(r[-1] in VERDICTS for r in study[1:])
    assert sample[0] == ["thesis", "claim", "this run"] and len(sample) == 14
    assert not any(w in r[2] for r in sample[1:] for w in VERDICTS)
    assert "-repetition sample, no verdicts" in (out / "report.html").read_text(encoding="utf-8")
    assert [r[0] for r in exp3[1:]] == ["nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a", "baseline",
                                        "handcrafted"]
    # Experiment 4: 6 policies x 4 inits x 2 covariances, the hand-crafted one once
    assert len(exp4) == 1 + 5 * 8 + 4
    assert exp4[1][0] == "nrvr_rs.scratch.query" and exp4[-1][0] == "handcrafted.policy.none"
    assert [r[0] for r in prov[1:]] == [r["folder"] for r in experiments.registry()]
    assert all("poolreps" in r[1] for r in cmds[1:])
    assert timing[-1][0] == "total" and float(timing[-1][1]) > 0
    assert "smoke run" in (out / "report.html").read_text(encoding="utf-8")


# each experiment's folder and the figures its plot script draws there
# (scripts/plot_all.py's dispatch on experiment.name, as `scripts/plot` runs it)
FOLDER_STEMS = {"sim": ["fig7_1_table", "fig7_2_reward", "fig7_3_shots", "fig7_5_ghost"],
                "exp1": ["fig7_4a_nmin", "fig7_4b_trees", "fig7_4c_cuts", "exp1_map"],
                "exp2": ["fig7_6"], "exp3": ["fig7_7", "fig7_8", "fig7_9", "fig7_10"],
                "exp4": ["exp4_curves_query", "exp4_curves_residual", "exp4_final", "exp4_rates"]}


@pytest.mark.slow
def test_reproduce_writes_every_figure_and_clears_old_ones(out):
    """Every figure, as PNG and SVG, in its experiment's folder (drawn there
    by that experiment's plot script) and copied to OUT/figures; nothing else
    there, the earlier run's figure gone."""
    names = sorted(p.name for p in (out / "figures").iterdir())
    assert names == sorted(f"{s}.{e}" for s in STEMS for e in ("png", "svg"))
    assert sorted(sum(FOLDER_STEMS.values(), [])) == sorted(s for s in STEMS
                                                            if not s.startswith("bench_"))
    reg = experiments.registry()
    assert sorted(FOLDER_STEMS) == sorted(r["folder"] for r in reg if r["kind"] != "benchmark")
    assert [s for s in STEMS if s.startswith("bench_")] == \
        [f"bench_{r['name']}" for r in reg if r["kind"] == "benchmark"]
    for folder, stems in FOLDER_STEMS.items():
        for stem in stems:
            png, svg = (out / folder / f"{stem}.png").read_bytes(), (out / folder / f"{stem}.svg").read_bytes()
            assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10000, (folder, stem)
            assert b"<svg" in svg[:1000] and len(svg) > 10000, (folder, stem)
            assert (out / "figures" / f"{stem}.png").read_bytes() == png, stem
            assert (out / "figures" / f"{stem}.svg").read_bytes() == svg, stem
    with open(out / "timings.csv", newline="") as f:
        steps = [r["step"] for r in csv.DictReader(f)]
    assert "exp3: run" in steps and "exp3: figures" in steps and steps[-1] == "total"


@pytest.mark.slow
def test_report_tables_come_from_the_csvs(out, tmp_path):
    """Change the run's CSV and the report's numbers follow."""
    o = tmp_path / "out"
    shutil.copytree(out, o)
    path = o / "exp3" / "exp3_episodes.csv"
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        if r["policy"] == "baseline":
            r["return"] = "-0.125"
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    p = run_cmd([PY, str(SCRIPTS / "report.py"), str(o)], capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 0, p.stderr
    before = dict((r[0], r) for r in parse(out / "report.html").tables[2][1:])
    after = dict((r[0], r) for r in parse(o / "report.html").tables[2][1:])
    assert after["baseline"][1] == "-0.125" and before["baseline"][1] != "-0.125"
    assert after["baseline"][2] == "0.000"
    assert after["nrvr_rs"][1] == before["nrvr_rs"][1]
    assert after["nrvr_rs"][3] != before["nrvr_rs"][3]     # paired against the new baseline
    assert "smoke run" not in (o / "report.html").read_text(encoding="utf-8")


def chromium():
    return shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.slow
@pytest.mark.skipif(chromium() is None, reason="no chromium installed")
def test_report_renders_in_chromium(out, tmp_path):
    shot = tmp_path / "report.png"
    p = run_cmd([chromium(), "--headless", "--no-sandbox", "--disable-gpu",
                        "--disable-background-networking", "--disable-component-update",
                        "--disable-sync", "--no-first-run", f"--user-data-dir={tmp_path / 'profile'}",
                        "--hide-scrollbars", "--window-size=1200,9000", f"--screenshot={shot}",
                        (out / "report.html").as_uri()],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0 and shot.is_file(), p.stderr[-2000:]
    image = pytest.importorskip("matplotlib.image")
    px = (image.imread(str(shot))[:, :, :3] * 255).round().astype(int)
    assert px.shape[:2] == (9000, 1200)
    colours = {tuple(c) for c in px[::7, ::5].reshape(-1, 3)}
    assert len(colours) > 500, "the page looks blank"
    # the table felt of Fig. 7.1 (#2f7d4f) shows that the figures were loaded
    felt = int(((px[:, :, 0] == 0x2f) & (px[:, :, 1] == 0x7d) & (px[:, :, 2] == 0x4f)).sum())
    assert felt > 2000, f"{felt} felt pixels: the figures did not load"


# ---- the claims' rules on made-up results ----

def write_exp1(d, mse):
    """exp1_mse.csv and config.ini from {(sweep, value): [mse of forest 0, 1, ...]}."""
    d.mkdir(parents=True, exist_ok=True)
    (d / "config.ini").write_text("[forest]\nn_min = 20\ntrees = 30\ncuts = 10\n")
    with open(d / "exp1_mse.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["repetition", "sweep", "n_min", "trees", "cuts", "mse"])
        for (sweep, value), vals in mse.items():
            setting = {"n_min": 20, "trees": 30, "cuts": 10, sweep: value}
            for rep, v in enumerate(vals):
                w.writerow([rep, sweep, setting["n_min"], setting["trees"], setting["cuts"], v])


def claims_module():
    sys.path.insert(0, str(SCRIPTS))
    try:
        import claims
    finally:
        sys.path.remove(str(SCRIPTS))
    return claims


BASE = [0.030, 0.041, 0.025, 0.036, 0.033]   # five forests of very different difficulty


def test_claim_cuts_measures_without_a_verdict(tmp_path):
    claims = claims_module()
    jitter = [0.0004, -0.0003, 0.0002, -0.0004, 0.0001]
    write_exp1(tmp_path / "exp1", {
        ("cuts", 10): BASE,
        ("cuts", 1): [b + 0.002 + j / 4 for b, j in zip(BASE, jitter)],
        ("cuts", 20): [b + 0.0001 + j for b, j in zip(BASE, jitter)],
    })
    here = claims.claim_cuts(str(tmp_path / "exp1"))
    assert f"MSE {sum(BASE) / 5:.4f}" in here and "worse in 5 of 5 forests" in here
    assert "K 1 − K 10: +0.0020 [" in here
    assert not any(w in here for w in ("agree", "partly", "undecided"))


def test_claims_without_the_settings_are_not_tested(tmp_path):
    claims = claims_module()
    write_exp1(tmp_path / "exp1", {("cuts", 1): BASE, ("cuts", 10): BASE})
    rows = claims.evaluate(str(tmp_path))
    by_fn = {fn.__name__: r for (_, _, _, fn), r in zip(claims.CLAIMS, rows)}
    assert by_fn["claim_cuts"]["here"].startswith("not measured: ")
    assert "above 10" in by_fn["claim_cuts"]["here"]
