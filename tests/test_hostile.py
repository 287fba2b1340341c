"""Hostile inputs of several kinds, each a property (docs/hardening.md):
a failed command exits with its documented code, prints one line and
changes nothing; the file system is compared before and after."""
import pytest

from conftest import ROOT
from test_safety import IO, QUICK, changed, one_line, run, snapshot

Q = ROOT / "data" / "quadratic.ini"


# ---- a run never overwrites a file it did not write ----

@pytest.mark.parametrize("name", ["config.ini", "provenance.txt", "bench_curve.csv"])
def test_run_never_replaces_a_file_it_did_not_write(name, tmp_path):
    """`run my/config.ini -o my`: the user's commented parameter file (or a
    file of theirs of any name the run writes) stays, the run is refused."""
    my = tmp_path / "my"
    my.mkdir()
    user = b"# my notes on this setting\n" + Q.read_bytes()
    (my / "params.ini").write_bytes(user)
    (my / name).write_bytes(user if name == "config.ini" else b"mine\n")
    cfg = my / ("config.ini" if name == "config.ini" else "params.ini")
    before = snapshot(tmp_path)
    r = run([cfg, "-o", my] + QUICK, tmp_path)
    assert r.returncode == IO, r.stderr
    line = one_line(r)
    assert f"my/{name}: exists, and no earlier poolreps run" in line, line
    assert changed(before, snapshot(tmp_path)) == set()


def test_run_replaces_what_its_earlier_run_wrote(tmp_path):
    r = run([Q, "-o", "out"] + QUICK, tmp_path)
    assert r.returncode == 0, r.stderr
    (tmp_path / "out" / "notes.txt").write_text("mine\n")
    r = run(["out/config.ini", "-o", "out", "--set", "bench.samples=30"] + QUICK, tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "out" / "notes.txt").read_text() == "mine\n"
    assert "samples = 30" in (tmp_path / "out" / "config.ini").read_text()


# ---- options apply in the order given ----

@pytest.mark.parametrize("args,seed", [
    (["--seed", "5", "--set", "experiment.seed=6"], "6"),
    (["--set", "experiment.seed=6", "--seed", "5"], "5"),
    (["--set", "experiment.seed=6", "--seed", "5", "--set", "experiment.seed=7"], "7"),
    (["-c", "s.ini", "--seed", "5"], "5"),
])
def test_options_apply_in_order(args, seed, tmp_path):
    (tmp_path / "s.ini").write_text("[experiment]\nseed = 9\n")
    r = run(["config"] + args, tmp_path)
    assert r.returncode == 0, r.stderr
    assert f"\nseed = {seed}\n" in r.stdout.decode()
