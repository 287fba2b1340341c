"""Research-grade runs: provenance, determinism across processes, sweeps
through scripts/jobs.sh and GNU Parallel, and clean interruption.

Run by `make check` with POOLREPS=<abs path to poolreps>.
"""
import os
import shlex
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

from conftest import ROOT, poolreps_path, run_poolreps

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
def test_sweep_through_jobs_and_parallel_matches_single_process(single, tmp_path):
    name, config, sets, ref = single
    if shutil.which("parallel") is None:
        pytest.skip("GNU parallel not installed")
    binary = poolreps_path()
    # a space and a quote in the path: every job line must survive sh
    out = tmp_path / "sweep out's"
    jobs = subprocess.run(["sh", ROOT / "scripts" / "jobs.sh", config, out] + set_args(sets),
                          capture_output=True, text=True, timeout=60,
                          env=dict(os.environ, POOLREPS=binary, LC_ALL="C"))
    assert jobs.returncode == 0, jobs.stderr
    lines = jobs.stdout.splitlines()
    assert len(lines) == REPS
    for k, line in enumerate(lines):
        assert f"experiment.repetition={k}" in shlex.split(line)
    par = subprocess.run(["parallel", "-j2", "--halt", "now,fail=1"], input=jobs.stdout,
                         capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, LC_ALL="C"))
    assert par.returncode == 0, par.stdout + par.stderr
    dirs = [out / f"rep-{k}" for k in range(REPS)]
    for k, d in enumerate(dirs):
        assert raw_repetitions(d) == {str(k)}
        assert provenance(d)["repetition"] == str(k)
        assert (d / "config.ini").is_file()
    merged = tmp_path / "merged"
    run_ok(["merge", "-q", "-o", merged] + dirs[::-1])
    assert csvs(ref), "the sweep wrote no CSV"
    assert csvs(merged) == csvs(ref)
    prov = provenance(merged)
    assert shlex.split(prov["command"])[1:] == ["merge", "-q", "-o", str(merged)] + [
        str(d) for d in dirs[::-1]]
    assert prov["repetition"] == "-1"
    assert (merged / "config.ini").read_bytes() == (ref / "config.ini").read_bytes()


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


def wait_for(pred, timeout):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(0.05)
    return False


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
