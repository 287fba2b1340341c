"""The README stays true: it opens with the two set-up commands, links the
parameter page, which is poolreps --help-keys's and documents every key, and
every picture it shows exists."""
import re

import pytest
from conftest import ROOT, config_keys, keys_missing, poolreps_path, run_cmd

README = (ROOT / "README.md").read_text(encoding="utf-8")
PARAMETERS = (ROOT / "docs" / "parameters.md").read_text(encoding="utf-8")


def test_opens_with_the_two_commands():
    block = re.search(r"```sh\n(.*?)```", README, re.S)
    assert block and README.index(block.group(0)) < README.index("\n## ")
    commands = [line.split("#")[0].strip() for line in block.group(1).splitlines()]
    assert commands == ["make reproduce", "make check"]


def test_parameter_page_is_the_help_text():
    """docs/parameters.md is what scripts/gen-params.sh makes of --help-keys."""
    binary = poolreps_path()
    if binary is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    gen = run_cmd(["sh", str(ROOT / "scripts" / "gen-params.sh"), binary, "-"],
                         capture_output=True, cwd=ROOT, timeout=60)
    assert gen.returncode == 0, gen.stderr
    assert b"Parameter keys (section.key" in gen.stdout
    assert PARAMETERS.encode() == gen.stdout, (
        "docs/parameters.md differs from `poolreps --help-keys`: run make man and commit it")
    assert "(docs/parameters.md)" in README, "README does not link the parameter page"


def test_every_key_documented(poolreps):
    """Every key `poolreps config` writes is on the parameter page with the
    default it writes, and the page lists no other key."""
    r = poolreps(["config"])
    assert r.returncode == 0, r.stderr
    keys = config_keys(r.stdout.decode())[0]
    assert len(keys) > 50
    missing, listed = keys_missing(keys, PARAMETERS)
    assert not missing, f"keys missing from docs/parameters.md: {missing}"
    assert listed == set(keys)


def test_pictures_exist_and_no_placeholders():
    pictures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", README)
    assert len(pictures) >= 14
    for p in pictures:
        assert (ROOT / p).is_file(), p
    assert "BENCH_" not in README


# ---- the time figures ----

def test_time_figures_are_the_recorded_measurements():
    """The README's and docs/benchmarks.md's time figures are what
    scripts/gen_timings.py makes of docs/data/timing_*.csv."""
    p = run_cmd(["/usr/bin/env", "python3", str(ROOT / "scripts" / "gen_timings.py"), "--check"],
                capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr


def test_reps_benchmark_text_is_the_recorded_measurement():
    """docs/benchmarks.md's REPS table, target verdicts and comparison with
    the previous poolreps are what scripts/bench_reps_table.py makes of
    docs/bench_reps.csv."""
    p = run_cmd(["/usr/bin/env", "python3", str(ROOT / "scripts" / "bench_reps_table.py"),
                 "--check"], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr


def test_exp4_benchmark_text_is_the_recorded_measurement():
    """docs/benchmarks.md's Experiment 4 CPU sentence (this poolreps against
    the previous one) is what scripts/bench_exp4_table.py makes of
    docs/bench_exp4.csv."""
    p = run_cmd(["/usr/bin/env", "python3", str(ROOT / "scripts" / "bench_exp4_table.py"),
                 "--check"], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr


def test_stream_benchmark_text_is_the_recorded_measurement():
    """docs/benchmarks.md's streaming table and the
    100 000-column header sentence are what scripts/bench_stream_table.py
    makes of docs/bench_stream.csv and docs/bench_header.csv."""
    p = run_cmd(["/usr/bin/env", "python3", str(ROOT / "scripts" / "bench_stream_table.py"),
                 "--check"], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr


def test_csv_reader_benchmark_text_is_the_recorded_measurement():
    """docs/benchmarks.md's csv_read block (each piece of the reader's speed
    machinery against libcsv and strtod) is what scripts/bench_csv_read.py
    makes of docs/bench_csv_read.csv."""
    p = run_cmd(["/usr/bin/env", "python3", str(ROOT / "scripts" / "bench_csv_read.py"),
                 "--check"], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr


def test_coverage_figure_is_the_recorded_measurement():
    """docs/testing.md's coverage sentence is what scripts/coverage.py makes
    of docs/data/coverage.csv (written by `make check COV=1` and
    `scripts/coverage.py build/cov --write`)."""
    p = run_cmd(["/usr/bin/env", "python3", str(ROOT / "scripts" / "coverage.py"), "--check"],
                capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr


def readme_reproduce_seconds():
    m = re.search(r"<!-- timing:reproduce -->in (\d+) s", README)
    assert m, "README has no generated reproduce time"
    return float(m.group(1))


def test_a_full_reproduction_here_takes_at_most_twice_the_readme_figure():
    """When results/ holds a full `make reproduce` (timings.csv with a build
    row and load.csv) that ran on an idle machine (other work under 10 % of
    the cores, from /proc/stat over the run), its total is at most twice the
    README's figure. Skipped when there is no such run, or it ran under load."""
    res = ROOT / "results"
    if not (res / "load.csv").is_file() or not (res / "timings.csv").is_file():
        pytest.skip("no full `make reproduce` in results/ to compare")
    if "smoke run" in (res / "report.html").read_text(encoding="utf-8", errors="replace"):
        pytest.skip("results/ holds a QUICK=1 run")
    load = (res / "load.csv").read_text().splitlines()[1].split(",")
    if float(load[4]) >= 0.1:
        pytest.skip(f"results/ ran on a busy machine (other work took {float(load[4]):.0%})")
    steps = dict(line.split(",") for line in (res / "timings.csv").read_text().splitlines()[1:])
    if "build" not in steps:
        pytest.skip("results/ was not written by `make reproduce`")
    assert float(load[1]) <= 2 * readme_reproduce_seconds()   # wall_s: end to end
