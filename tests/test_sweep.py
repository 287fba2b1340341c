"""Research-grade runs: provenance, determinism across processes, sweeps over
parameter grids split by repetition and by variant (`poolreps sweep`, jobs
run through GNU Parallel or sh, `poolreps collect`), missing and killed jobs,
and clean interruption. The same sweeps on a real Slurm cluster and over
real ssh logins are in test_cluster.py.

Run by `make check` with POOLREPS=<abs path to poolreps>.
"""
import csv
import os
import random
import shlex
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

from conftest import ROOT, poolreps_path, run_poolreps, run_cmd, wait_for
from test_commit import shim, shim_env  # noqa: F401  (the fixture)

# tiny settings (each run well under 3 s), 3 repetitions so that order can vary
SWEEPS = {
    "exp3": ("exp3.ini", [
        "experiment.repetitions=3", "experiment.threads=1", "exp3.init_samples=40",
        "exp3.window=40", "exp3.samples=10", "exp3.iterations=3", "exp3.final_episodes=20",
        "policy.n_min=15", "exp3.baseline_n_min=60", "value.n_min=12",
        "exp3.policies=nrvr_rs,baseline,handcrafted"]),
    "quadratic": ("quadratic.ini", ["experiment.repetitions=3", "bench.iterations=10"]),
}
REPS = 3


def set_args(sets):
    return [a for s in sets for a in ("--set", s)]


def csvs(d):
    """{name: bytes} of every CSV in folder d."""
    return {p.name: p.read_bytes() for p in sorted(Path(d).glob("*.csv"))}


def provenance(d):
    lines = (Path(d) / "provenance.txt").read_text().splitlines()
    return dict(line.split(": ", 1) for line in lines)


def run_ok(args, **kw):
    r = run_poolreps(args, **kw)
    assert r.returncode == 0, r.stderr.decode()
    return r


@pytest.fixture(scope="module", params=sorted(SWEEPS))
def single(request, tmp_path_factory):
    """All repetitions of one sweep in one process: (name, config, sets, dir)."""
    ini, sets = SWEEPS[request.param]
    out = tmp_path_factory.mktemp(request.param) / "single"
    run_ok([ROOT / "data" / ini, "-q", "-o", out] + set_args(sets))
    return request.param, ROOT / "data" / ini, sets, out


def raw_repetitions(d):
    """The values of the leading repetition column over d's raw CSVs."""
    reps = set()
    for name, data in csvs(d).items():
        lines = data.decode().splitlines()
        if lines[0].startswith("repetition,"):
            reps |= {x.split(",", 1)[0] for x in lines[1:]}
    return reps


@pytest.mark.slow
def test_repetitions_in_reverse_order_in_separate_processes(single, tmp_path):
    name, config, sets, ref = single
    dirs = []
    for k in reversed(range(REPS)):
        d = tmp_path / f"r{k}"
        run_ok([config, "-q", "-o", d, "--set", f"experiment.repetition={k}"] + set_args(sets))
        dirs.append(d)
    run_ok(["merge", "-q", "-o", tmp_path / "merged"] + dirs)
    assert csvs(tmp_path / "merged") == csvs(ref)
    # a repetition given twice is refused, not merged
    r = run_poolreps(["merge", "-q", "-o", tmp_path / "twice", dirs[0], dirs[0]])
    assert r.returncode == 1 and b"both hold repetition" in r.stderr
    assert not (tmp_path / "twice").exists()


@pytest.mark.slow
def test_same_seed_same_bytes_other_seed_other_bytes(single, tmp_path):
    name, config, sets, ref = single
    run_ok([config, "-q", "-o", tmp_path / "again"] + set_args(sets))
    assert csvs(tmp_path / "again") == csvs(ref)
    run_ok([config, "-q", "-o", tmp_path / "seed2", "--seed", "2"] + set_args(sets))
    other = csvs(tmp_path / "seed2")
    assert other.keys() == csvs(ref).keys()
    # every raw CSV (per-repetition rows); a summary such as exp3_pockets.csv
    # may well come out alike at this size
    raw = [n for n, data in csvs(ref).items() if data.startswith(b"repetition,")]
    assert raw
    for n in raw:
        assert other[n] != csvs(ref)[n], f"{n} does not depend on the seed"


def test_provenance_records_the_command_as_typed(poolreps, tmp_path):
    out = tmp_path / "fig 1"
    args = ["data/figures.ini", "--set", "sim.mode=event", "-o", str(out), "-q",
            "--seed", "7", "--set", "reward.miss_penalty=10"]
    r = poolreps(args, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in out.iterdir() if not p.name.endswith(".csv")) == [
        "config.ini", "provenance.txt"]
    prov = provenance(out)
    # argv before getopt reordered it, read back by a shell word for word
    assert shlex.split(prov["command"])[1:] == args
    version = poolreps(["--version"]).stdout.decode().split()[1]
    assert prov["version"] == version
    assert prov["seed"] == "7"
    assert prov["experiment"] == "figures"
    assert prov["repetition"] == "-1"
    assert prov["parameter_file"] == "data/figures.ini"
    assert prov["host"].strip()
    assert len(prov["finished"]) == 20 and prov["finished"].endswith("Z")
    for k in ("wall_seconds", "cpu_seconds", "peak_memory_mib"):
        assert float(prov[k]) >= 0
    # config.ini is the effective configuration: it reproduces the run's parameters
    direct = poolreps(["config", "-c", "data/figures.ini", "--seed", "7", "--set",
                       "sim.mode=event", "--set", "reward.miss_penalty=10"], cwd=ROOT)
    saved = poolreps(["config", "-c", out / "config.ini"])
    assert saved.returncode == 0 and saved.stdout == direct.stdout


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["TERM", "INT"])
@pytest.mark.parametrize("existing", [False, True], ids=["new", "existing"])
def test_interrupted_run_leaves_no_partial_output(tmp_path, sig, existing):
    binary = poolreps_path()
    if binary is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    out = tmp_path / "out"
    before = {}
    if existing:
        # a complete earlier run into the same folder must survive untouched
        run_ok([ROOT / "data" / "quadratic.ini", "-q", "-o", out] +
               set_args(SWEEPS["quadratic"][1]))
        before = {p.name: p.read_bytes() for p in out.iterdir()}
    # Experiment 3 as shipped runs for minutes
    p = subprocess.Popen([binary, ROOT / "data" / "exp3.ini", "-o", out,
                          "--set", "experiment.threads=1"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         env=dict(os.environ, LC_ALL="C"))
    try:
        started = wait_for(lambda: out.is_dir() and any(out.glob(".partial-*")), 30)
        time.sleep(0.5)  # well into the episodes
        assert p.poll() is None, "the run ended before the signal"
        p.send_signal(sig)
        _, err = p.communicate(timeout=60)
    finally:
        p.kill()
        p.wait()
    err = err.decode()
    assert started, err
    assert p.returncode == 128 + sig, err
    last = err.splitlines()[-1]
    assert last.startswith("poolreps: interrupted: no output written"), err
    assert str(out) in last
    if existing:
        assert {q.name: q.read_bytes() for q in out.iterdir()} == before
        assert "left as it was" in last
    else:
        assert not out.exists()
        assert "removed" in last
    assert list(tmp_path.glob("**/.partial-*")) == []
    assert [q for q in tmp_path.rglob("*") if ".tmp" in q.name] == []


# ---- sweeps: poolreps sweep, jobs anywhere, poolreps collect ----

EXP1_TINY = ["exp1.train=100", "exp1.test=100", "exp1.subset=50", "exp1.test_subset=50",
             "experiment.repetitions=2", "experiment.threads=1", "exp1.n_min_list=2,20,50",
             "exp1.trees_list=1,10", "exp1.cuts_list=1,10", "exp1.map_grid=5"]
EXP3_TINY = SWEEPS["exp3"][1]
EXP3_POLICIES = ["nrvr_rs", "baseline", "handcrafted"]
EXP1_VARIANTS = ["n_min=2", "n_min=20", "n_min=50", "trees=1", "trees=10", "cuts=1", "cuts=10",
                 "map"]
SUMMARY = {"exp1": "exp1_summary.csv", "exp3": "exp3_final.csv", "quadratic": "bench_summary.csv"}


def make_sweep(config, out, sets=(), grid=(), split=None):
    """`poolreps sweep`; returns (manifest rows as dicts, job lines)."""
    args = ["sweep", config, "-q", "-o", out] + set_args(sets)
    for g in grid:
        args += ["--grid", g]
    if split:
        args += ["--split", split]
    run_ok(args)
    man = list(csv.DictReader(open(Path(out) / "manifest.csv", newline="")))
    jobs = (Path(out) / "jobs.txt").read_text().splitlines()
    assert len(jobs) == len(man)
    return man, jobs


def run_jobs(lines, order=None):
    """Run job lines one by one through sh, in the given order of indices."""
    for j in (order if order is not None else range(len(lines))):
        r = run_cmd(["sh", "-c", lines[j]], capture_output=True, text=True, timeout=300,
                           env=dict(os.environ, LC_ALL="C"))
        assert r.returncode == 0, (lines[j], r.stderr)


def points(sweep):
    return sorted(p for p in Path(sweep).iterdir() if p.name.startswith("point-"))


def point_sets(sweep):
    """{point folder name: the --set options of its grid values} (manifest.csv)."""
    with open(Path(sweep) / "manifest.csv", newline="") as f:
        rows = list(csv.reader(f))
    keys = rows[0][2:-4]
    width = len(str(int(rows[-1][1])))
    return {f"point-{int(r[1]):0{width}d}": set_args(f"{k}={v}" for k, v in zip(keys, r[2:-4]))
            for r in rows[1:]}


def assert_points_match_single_process(sweep, tmp_path):
    """Every grid point's merged folder holds the bytes one process writes
    from the sweep's config.ini with that point's values (all CSVs and
    config.ini)."""
    sets = point_sets(sweep)
    assert sorted(sets) == [p.name for p in points(sweep)]
    for p in points(sweep):
        ref = tmp_path / f"ref-{p.name}"
        run_ok(["run", Path(sweep) / "config.ini", "-q", "-o", ref] + sets[p.name])
        assert csvs(ref), "the run wrote no CSV"
        assert csvs(p / "merged") == csvs(ref), p.name
        assert (p / "merged" / "config.ini").read_bytes() == (ref / "config.ini").read_bytes()


def assert_summary_is_the_points_summaries(sweep, keys, summary):
    """sweep_summary.csv: the grid values, then each point's summary rows."""
    man = list(csv.DictReader(open(Path(sweep) / "manifest.csv", newline="")))
    rows = list(csv.reader(open(Path(sweep) / "sweep_summary.csv", newline="")))
    expect_header = None
    expect = []
    for p in points(sweep):
        values = next([m[k] for k in keys] for m in man if m["output"].startswith(p.name + "/"))
        head, *body = list(csv.reader(open(p / "merged" / summary, newline="")))
        expect_header = keys + head
        expect += [values + r for r in body]
    assert rows[0] == expect_header
    assert rows[1:] == expect


@pytest.mark.slow
def test_sweep_through_parallel_matches_single_process(single, tmp_path):
    """One grid point, jobs through GNU Parallel (parallel.sh) in any order,
    split as finely as the experiment allows; a path with a space and a quote."""
    name, config, sets, ref = single
    if shutil.which("parallel") is None:
        pytest.skip("GNU parallel not installed")
    out = tmp_path / "sweep out's"
    split = "both" if name == "exp3" else "repetition"
    man, jobs = make_sweep(config, out, sets, split=split)
    nvar = len(EXP3_POLICIES) if name == "exp3" else 1
    assert len(jobs) == REPS * nvar
    for j, (m, line) in enumerate(zip(man, jobs)):
        words = shlex.split(line)
        assert Path(words[0]).is_absolute() and words[1] == "run"
        assert int(m["job"]) == j and m["point"] == "0"
        assert f"experiment.repetition={m['repetition']}" in words
        assert (f"experiment.variant={m['variant']}" in words) == (m["variant"] != "-1")
        assert words[-2:] == ["-o", str(out / m["output"])]
    par = run_cmd(["sh", out / "parallel.sh", "-j2", "--halt", "now,fail=1"],
                         capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, LC_ALL="C"))
    assert par.returncode == 0, par.stdout + par.stderr
    for m in man:
        d = out / m["output"]
        assert raw_repetitions(d) == {m["repetition"]}
        assert provenance(d)["repetition"] == m["repetition"]
    run_ok(["collect", "-q", out])
    assert csvs(out / "point-0" / "merged") == csvs(ref)
    assert (out / "point-0" / "merged" / "config.ini").read_bytes() == \
        (ref / "config.ini").read_bytes()
    # one grid point, no grid keys: the table is the experiment's summary itself
    assert (out / "sweep_summary.csv").read_bytes() == (ref / SUMMARY[name]).read_bytes()
    assert not list(out.glob(".collect-*")) and not list(out.glob(".partial-*"))


def test_sweep_setup_writes_no_folder_per_point(tmp_path):
    """Setting up a sweep writes the same few files whatever the grid's size:
    each job carries its point's values as --set options (shell-quoted) and
    creates its own point-P/runs/NAME; collect rebuilds each point's
    configuration from config.ini and the manifest."""
    out = tmp_path / "s"
    values = [str(v) for v in range(20, 420, 2)] + [" 1000 "]
    man, jobs = make_sweep(ROOT / "data" / "quadratic.ini", out,
                           ["experiment.repetitions=1", "bench.iterations=3"],
                           grid=["bench.samples=" + ",".join(values)])
    assert sorted(p.name for p in out.iterdir()) == [
        "config.ini", "jobs.txt", "logs", "manifest.csv", "parallel.sh",
        "provenance.txt", "slurm.sbatch"]
    assert len(jobs) == len(values) == len(man)
    for m, line, v in zip(man, jobs, values):
        words = shlex.split(line)
        assert words[2:4] == ["-q", str(out / "config.ini")]
        assert words[4:6] == ["--set", f"bench.samples={v}"]
        assert m["bench.samples"] == v and m["output"] == f"point-{int(m['point']):03d}/runs/rep-0"
    run_jobs(jobs, order=[len(jobs) - 1, 0] + list(range(1, len(jobs) - 1)))
    run_ok(["collect", "-q", out])
    assert (out / "point-200" / "merged" / "config.ini").read_text().count("samples = 1000\n") == 1
    summary = [r["bench.samples"] for r in csv.DictReader(open(out / "sweep_summary.csv",
                                                                newline=""))]
    firsts = [r for i, r in enumerate(summary) if i == 0 or r != summary[i - 1]]
    assert firsts == values


def test_job_line_too_long_for_sweep_missing_is_refused(tmp_path):
    """Grid values travel in the job lines, which `sweep --missing` reads
    into a fixed buffer: a line longer than it is refused at setup, one
    line, nothing written."""
    long = "0" * 3000
    grid = [f"bench.samples={long}20", f"bench.iterations={long}20", f"bench.dims={long}1",
            f"bench.context_dims={long}1", f"bench.init_std={long}1"]
    out = tmp_path / "s"
    r = run_poolreps(["sweep", ROOT / "data" / "quadratic.ini", "-o", out] +
                     [a for g in grid for a in ("--grid", g)])
    assert r.returncode == 1
    assert r.stderr.decode() == ("poolreps: sweep: job 0: its line of jobs.txt is longer than "
                                 "12286 bytes (grid values or paths too long)\n")
    assert list(tmp_path.iterdir()) == []


def test_jobs_sh_prints_the_sweep_jobs(tmp_path):
    config = ROOT / "data" / "quadratic.ini"
    r = run_cmd(["sh", ROOT / "scripts" / "jobs.sh", config, tmp_path / "s",
                        "--set", "experiment.repetitions=3"], capture_output=True, text=True,
                       timeout=60, env=dict(os.environ, POOLREPS=poolreps_path(), LC_ALL="C"))
    assert r.returncode == 0, r.stderr
    assert r.stdout == (tmp_path / "s" / "jobs.txt").read_text()
    assert len(r.stdout.splitlines()) == 3


@pytest.mark.parametrize("name", ["exp1", "exp3"])
def test_a_variant_alone_draws_what_it_draws_in_the_full_run(name, tmp_path):
    """Each variant run alone writes exactly its rows of the full run (its own
    streams; common start states and data), and merging the variants in any
    order gives the full run's bytes."""
    if name == "exp1":
        config, sets, names = ROOT / "data" / "exp1.ini", EXP1_TINY, EXP1_VARIANTS
    else:
        config, sets, names = ROOT / "data" / "exp3.ini", EXP3_TINY, EXP3_POLICIES
    full = tmp_path / "full"
    run_ok([config, "-q", "-o", full] + set_args(sets))
    dirs = []
    for v in range(len(names)):
        d = tmp_path / f"v{v}"
        run_ok([config, "-q", "-o", d, "--set", f"experiment.variant={v}"] + set_args(sets))
        dirs.append(d)
        for f, data in csvs(d).items():
            if not data.startswith(b"repetition,"):
                continue
            head, *mine = data.decode().splitlines()
            _, *all_rows = (full / f).read_text().splitlines()
            if name == "exp3":
                keep = [r for r in all_rows if r.split(",")[1] == names[v]]
            elif f == "exp1_map.csv":
                keep = all_rows if names[v] == "map" else []
            else:
                sweep, value = names[v].split("=") if "=" in names[v] else ("map", "")
                col = {"n_min": 2, "trees": 3, "cuts": 4}.get(sweep)
                keep = [r for r in all_rows
                        if r.split(",")[1] == sweep and r.split(",")[col] == value]
            assert mine == keep and (mine or names[v] == "map" or f == "exp1_map.csv"), (f, v)
    merged = tmp_path / "merged"
    run_ok(["merge", "-q", "-o", merged] + dirs[::-1])
    assert csvs(merged) == csvs(full)
    assert (merged / "config.ini").read_bytes() == (full / "config.ini").read_bytes()
    # a variant given twice, or besides a run of all variants, is refused
    for pair in ([dirs[0], dirs[0]], [dirs[1], full]):
        r = run_poolreps(["merge", "-q", "-o", tmp_path / "twice"] + pair)
        assert r.returncode == 1 and b"both hold repetition" in r.stderr
        assert not (tmp_path / "twice").exists()
    r = run_poolreps([config, "-q", "-o", tmp_path / "bad", "--set",
                      f"experiment.variant={len(names)}"] + set_args(sets))
    assert r.returncode == 1, r.stderr
    assert r.stderr.decode() == (f"poolreps: --set: experiment.variant: {len(names)}, but {name} "
                                 f"has {len(names)} variants (0..{len(names) - 1})\n")
    assert not (tmp_path / "bad").exists()


@pytest.mark.slow
def test_grid_points_are_the_direct_runs_in_any_job_order(tmp_path):
    """A 2 x 2 grid over Experiment 1 split by variant and repetition, the
    jobs run in a shuffled order: every point equals `poolreps CONFIG --set
    KEY=VALUE...` run directly, and sweep_summary.csv tabulates them."""
    config = ROOT / "data" / "exp1.ini"
    keys = ["forest.n_c", "exp1.aim_speed"]
    grid = ["forest.n_c=1,3", "exp1.aim_speed=0.4,0.8"]
    man, jobs = make_sweep(config, tmp_path / "s", EXP1_TINY, grid, split="both")
    assert len(jobs) == 4 * 2 * len(EXP1_VARIANTS)
    assert [m["variant_name"] for m in man[:len(EXP1_VARIANTS)]] == EXP1_VARIANTS
    assert [(m["forest.n_c"], m["exp1.aim_speed"]) for m in man[::2 * len(EXP1_VARIANTS)]] == [
        ("1", "0.4"), ("1", "0.8"), ("3", "0.4"), ("3", "0.8")]
    run_jobs(jobs, random.Random(3).sample(range(len(jobs)), len(jobs)))
    run_ok(["collect", "-q", tmp_path / "s"])
    for p, (nc, speed) in zip(points(tmp_path / "s"), [("1", "0.4"), ("1", "0.8"), ("3", "0.4"),
                                                       ("3", "0.8")]):
        direct = tmp_path / f"direct-{p.name}"
        run_ok([config, "-q", "-o", direct, "--set", f"forest.n_c={nc}", "--set",
                f"exp1.aim_speed={speed}"] + set_args(EXP1_TINY))
        assert csvs(p / "merged") == csvs(direct), p.name
        assert (p / "merged" / "config.ini").read_bytes() == (direct / "config.ini").read_bytes()
    assert_summary_is_the_points_summaries(tmp_path / "s", keys, "exp1_summary.csv")


def kill_while_held(line, shim, tmp):
    """Run one job held in its work by the rename shim (after its first
    rename, inside its staging folder: the run has begun writing but has
    published nothing) and SIGKILL it there."""
    mark, go = tmp / "held", tmp / "never-released"
    p = subprocess.Popen(shlex.split(line), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         env=shim_env(shim, LC_ALL="C", RENAME_MARK=mark, RENAME_HOLD=go,
                                      RENAME_MARK_FIRST=1))
    try:
        held = wait_for(lambda: p.poll() is not None or mark.exists(), 60) and p.poll() is None
        p.send_signal(signal.SIGKILL)
    finally:
        p.kill()
        p.wait()
    assert held, "the job ended before its first rename"


@pytest.mark.slow
def test_collect_names_killed_and_missing_jobs_and_missing_resubmits_them(tmp_path, shim):
    """One job killed on purpose (SIGKILL: its partial folder stays), one
    never run: collect refuses, naming both; --missing prints exactly their
    lines; after running those, the result is complete and identical."""
    sweep = tmp_path / "s"
    man, jobs = make_sweep(ROOT / "data" / "exp3.ini", sweep, EXP3_TINY,
                           ["value.n_min=12,20"], split="both")
    # nrvr_rs jobs (the slowest): repetition 1 of point 0, repetition 0 of point 1
    killed, never = (next(j for j, m in enumerate(man) if (m["point"], m["repetition"],
                                                           m["variant_name"]) == key)
                     for key in (("0", "1", "nrvr_rs"), ("1", "0", "nrvr_rs")))
    run_jobs(jobs, [j for j in range(len(jobs)) if j not in (killed, never)])
    out = sweep / man[killed]["output"]
    kill_while_held(jobs[killed], shim, tmp_path)
    assert out.is_dir() and not (out / "provenance.txt").exists()
    before = {p: p.read_bytes() for p in sweep.rglob("*") if p.is_file()}
    r = run_poolreps(["collect", sweep])
    assert r.returncode == 2
    err = r.stderr.decode()
    assert err.count("\n") == 1, err
    m1, m2 = man[killed], man[never]
    assert f"2 of {len(jobs)} jobs not done" in err
    assert (f"job {killed} (point {m1['point']}, repetition {m1['repetition']}, variant nrvr_rs) "
            f"failed: incomplete folder {m1['output']}") in err
    assert f"job {never} (point {m2['point']}, repetition {m2['repetition']}, variant nrvr_rs) " \
           f"missing" in err
    # a failed collect changes nothing
    assert {p: p.read_bytes() for p in sweep.rglob("*") if p.is_file()} == before
    assert not (sweep / "sweep_summary.csv").exists() and not list(sweep.glob("*/merged"))
    missing = run_ok(["sweep", "--missing", sweep]).stdout.decode().splitlines()
    assert missing == [jobs[killed], jobs[never]]
    run_jobs(missing)
    assert run_ok(["sweep", "--missing", sweep]).stdout == b""
    run_ok(["collect", "-q", sweep])
    assert_points_match_single_process(sweep, tmp_path)
    assert_summary_is_the_points_summaries(sweep, ["value.n_min"], "exp3_final.csv")
    # collecting again replaces the merged folders with the same bytes
    first = {p: p.read_bytes() for p in sweep.glob("point-*/merged/*.csv")}
    run_ok(["collect", "-q", sweep])
    assert {p: p.read_bytes() for p in sweep.glob("point-*/merged/*.csv")} == first


def test_collect_refuses_jobs_run_with_another_configuration(tmp_path):
    sweep = tmp_path / "s"
    _, jobs = make_sweep(ROOT / "data" / "quadratic.ini", sweep, SWEEPS["quadratic"][1])
    run_jobs(jobs)
    cfg = sweep / "config.ini"
    cfg.write_text(cfg.read_text().replace("test_contexts = 100", "test_contexts = 99"))
    r = run_poolreps(["collect", sweep])
    assert r.returncode == 1
    assert r.stderr.decode() == (f"poolreps: {cfg}: differs from the configuration the jobs "
                                 f"of point 0 ran with (bench.test_contexts = 99, jobs: 100)\n")
    assert not (sweep / "sweep_summary.csv").exists()
    assert not list(sweep.glob(".partial-*")) and not (sweep / "point-0" / "merged").exists()


@pytest.mark.parametrize("args,code,msg", [
    (["--grid", "value.n_min=0,20"], 1,
     "--grid value.n_min: 0 out of range: must be >= 1 and <= 100000000"),
    (["--grid", "value.n_mn=2"], 1, "--grid value.n_mn: unknown key"),
    (["--grid", "value.n_min=2,,3"], 1, "--grid value.n_min=2,,3: empty value"),
    (["--grid", "value.n_min=2,3,2"], 1, "--grid value.n_min: value '2' listed twice"),
    (["--grid", "reps.epsilon=1", "--grid", "reps.epsilon=2"], 1,
     "--grid reps.epsilon: key given twice"),
    (["--grid", "experiment.repetition=0,1"], 1, "--grid experiment.repetition: a sweep keeps"),
    (["--grid", "nokey"], 1, "--grid nokey: expected section.key=value1,value2,..."),
    (["--split", "policy"], 1, "--split policy: must be repetition, variant or both"),
    (["--set", "experiment.repetition=1"], 1, "experiment.repetition: must be -1"),
    (["--set", "exp3.policies=nrvr_rs,bogus"], 1, "exp3.policies: 'bogus' is not one of"),
])
def test_sweep_bad_arguments_fail_cleanly(tmp_path, args, code, msg):
    out = tmp_path / "s"
    r = run_poolreps(["sweep", ROOT / "data" / "exp3.ini", "-o", out] + args)
    err = r.stderr.decode()
    assert r.returncode == code, err
    assert err.count("\n") == 1 and msg in err, err
    assert not out.exists()


def test_sweep_refusals_outside_the_grid(tmp_path):
    out = tmp_path / "s"
    cases = [
        (["sweep", ROOT / "data" / "exp2.ini", "--split", "variant", "-o", out], 1,
         "--split variant: exp2 has no variants (exp1, exp3 and exp4 have)"),
        (["sweep", ROOT / "data" / "figures.ini", "-o", out], 1,
         "experiment.name: figures has no summary table to sweep"),
        (["sweep", ROOT / "data" / "exp3.ini"], 1, "sweep: -o SWEEP_DIR is required"),
        (["sweep", "-o", out], 1, "sweep: no parameter file given"),
        (["sweep", "--missing", out], 2, f"{out}/manifest.csv: cannot open"),
        (["collect", out], 2, f"{out}/manifest.csv: cannot open"),
        (["collect"], 1, "collect: give exactly one sweep folder"),
    ]
    for args, code, msg in cases:
        r = run_poolreps(args)
        err = r.stderr.decode()
        assert r.returncode == code and err.count("\n") == 1 and msg in err, (args, err)
        assert not out.exists()
    # an existing folder must be empty, and is left as it was
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    r = run_poolreps(["sweep", ROOT / "data" / "quadratic.ini", "-o", out])
    assert r.returncode == 2 and b"folder is not empty (it holds keep.txt)" in r.stderr
    assert [p.name for p in out.iterdir()] == ["keep.txt"]
    # an empty one is used
    (out / "keep.txt").unlink()
    man, _ = make_sweep(ROOT / "data" / "quadratic.ini", out, ["experiment.repetitions=2"])
    assert len(man) == 2
    assert sorted(p.name for p in out.iterdir()) == [
        "config.ini", "jobs.txt", "logs", "manifest.csv", "parallel.sh",
        "provenance.txt", "slurm.sbatch"]


def test_slurm_script_runs_the_line_of_its_task(tmp_path):
    """slurm.sbatch outside Slurm: task i (+ POOLREPS_OFFSET) runs line i + 1
    of jobs.txt or of the file given; a task past the end fails, naming it.
    (test_cluster.py submits it to a real Slurm.)"""
    sweep = tmp_path / "s"
    man, jobs = make_sweep(ROOT / "data" / "quadratic.ini", sweep, ["experiment.repetitions=4",
                                                                     "bench.iterations=5"])

    def task(i, *args, offset=None):
        env = dict(os.environ, LC_ALL="C", SLURM_ARRAY_TASK_ID=str(i))
        if offset is not None:
            env["POOLREPS_OFFSET"] = str(offset)
        return run_cmd(["sh", sweep / "slurm.sbatch", *args], capture_output=True,
                              text=True, env=env, timeout=60)

    assert task(1, offset=2).returncode == 0
    assert [m["output"] for m in man if (sweep / m["output"]).is_dir()] == [man[3]["output"]]
    retry = tmp_path / "retry.txt"
    retry.write_text(jobs[0] + "\n")
    assert task(0, retry).returncode == 0
    assert (sweep / man[0]["output"] / "provenance.txt").is_file()
    r = task(4)
    assert r.returncode == 1 and r.stderr == f"slurm.sbatch: no job 4 in {sweep}/jobs.txt\n"
    head = (sweep / "slurm.sbatch").read_text()
    assert "#SBATCH --array=0-3\n" in head and "#SBATCH --cpus-per-task=1\n" in head
    assert f"#SBATCH --output={sweep}/logs/%A_%a.out\n" in head


@pytest.mark.slow
def test_plot_sweep_draws_the_summary_against_the_grid(tmp_path):
    """scripts/plot_sweep.py on a collected 2 x 2 grid: a PNG, the same bytes
    twice; a summary without defaults needs -y, and a bad column is named."""
    py = os.environ.get("PYTHON") or "/usr/bin/python3"
    sweep = tmp_path / "s"
    _, jobs = make_sweep(ROOT / "data" / "quadratic.ini", sweep,
                         ["experiment.repetitions=2", "bench.iterations=5"],
                         ["bench.init_std=0.5,1", "reps.epsilon=0.5,1"])
    run_jobs(jobs)
    run_ok(["collect", "-q", sweep])

    def plot(*args):
        return run_cmd([py, ROOT / "scripts" / "plot_sweep.py", sweep, *args],
                              capture_output=True, text=True, timeout=120)

    pngs = []
    for name in ("a.png", "b.png"):
        r = plot("-y", "test_return_mean", "--where", "iteration=4", "-o", tmp_path / name)
        assert r.returncode == 0, r.stderr
        pngs.append((tmp_path / name).read_bytes())
    assert pngs[0][:8] == b"\x89PNG\r\n\x1a\n" and len(pngs[0]) > 10000
    assert pngs[0] == pngs[1]
    r = plot()
    assert r.returncode == 2 and "give -y COLUMN" in r.stderr
    r = plot("-y", "nope")
    assert r.returncode == 2 and "-y nope: no such column" in r.stderr
