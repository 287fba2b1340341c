"""The C examples (examples/*.c), built by `make examples` against an installed
tree through pkg-config, each linked once against libpoolreps.so and once
against libpoolreps.a: they run, print what they say, and agree with the CLI.

`make check` sets POOLREPS_EXAMPLES (the folder of the binaries) and
POOLREPS_STAGE (the DESTDIR they were installed into)."""
import csv
import io
import os
from pathlib import Path

import pytest

from conftest import run_poolreps, run_cmd

EXAMPLES = os.environ.get("POOLREPS_EXAMPLES")
STAGE = os.environ.get("POOLREPS_STAGE")
pytestmark = pytest.mark.skipif(not EXAMPLES or not STAGE,
                                reason="run through `make check` (needs POOLREPS_EXAMPLES)")


def run(name, *args):
    """Output of the shared build, after checking the static build prints the same."""
    env = dict(os.environ, LD_LIBRARY_PATH=f"{STAGE}/usr/local/lib", LC_ALL="C")
    outs = []
    for exe in (name, name + "-static"):
        p = run_cmd([str(Path(EXAMPLES) / exe), *map(str, args)], capture_output=True,
                           text=True, env=env, timeout=60)
        assert p.returncode == 0, p.stderr
        assert p.stderr == ""
        outs.append(p.stdout)
    assert outs[0] == outs[1]
    return outs[0]


def test_shoot_example_matches_the_cli():
    rows = list(csv.DictReader(io.StringIO(run("shoot", 200))))
    assert len(rows) == 200
    inp = "x0,y0,x1,y1,vx,vy\n" + "".join(
        ",".join(r[k] for k in ("x0", "y0", "x1", "y1", "vx", "vy")) + "\n" for r in rows)
    p = run_poolreps(["shoot"], input=inp.encode())
    assert p.returncode == 0, p.stderr
    cli = list(csv.DictReader(io.StringIO(p.stdout.decode())))
    for mine, ref in zip(rows, cli):
        assert float(mine["x0"]) == -0.25 and float(mine["y0"]) == 0.0
        assert 0.05 <= float(mine["x1"]) <= 0.15 and -0.1 <= float(mine["y1"]) <= 0.1
        assert int(mine["pocket1"]) == int(ref["pocket1"])
        assert int(mine["hit"]) == int(ref["hit"])
        assert float(mine["reward"]) == float(ref["reward"])
    rewards = [float(r["reward"]) for r in rows]
    assert all(r <= 0 for r in rewards) and min(rewards) < -0.1
    assert 0 < sum(int(r["hit"]) for r in rows) < 200


def test_forest_example_reads_its_leaves_and_learns():
    lines = run("forest").splitlines()
    trees, leaves, samples = (int(x) for x in lines[0].split()[1::2])
    assert (trees, samples) == (10, 2000)
    assert lines[1] == "leaf,samples,value"
    table = [tuple(map(float, l.split(","))) for l in lines[2:-1]]
    # tree 0's leaves partition the 2000 samples (no bootstrap), n_min = 100
    assert [int(t[0]) for t in table] == list(range(len(table)))
    assert sum(t[1] for t in table) == 2000
    assert all(1 <= t[1] <= 100 for t in table)
    assert trees * 10 < leaves < trees * 2000
    # leaf values are means of y = sin(3 x0) + x1^2 + noise in [-1.05, 2.05]
    assert all(-1.05 <= t[2] <= 2.05 for t in table)
    name, mse = lines[-1].split()
    # the target's variance is about 0.6; a forest that learned nothing scores that
    assert name == "test_mse" and 0 < float(mse) < 0.02


def test_reps_policy_example_moves_the_policy_toward_the_context():
    lines = run("reps_policy").splitlines()
    head = dict(zip(lines[0].split()[0::2], map(float, lines[0].split()[1::2])))
    assert abs(head["kl"] - head["epsilon"]) <= 1e-6 and head["bound"] == 1
    assert 1 < head["ess"] < 400
    assert lines[1] == "s,mean,std"
    q = [tuple(map(float, l.split(","))) for l in lines[2:]]
    assert [s for s, _, _ in q] == [-0.8, 0.0, 0.8]
    means = [m for _, m, _ in q]
    # the old policy's mean is 0 everywhere; the weighted one follows a = s
    assert means[0] < means[1] < means[2] and means[2] - means[0] > 0.4
    # and it is narrower than the old N(0, 0.5^2)
    assert all(0 < sd < 0.5 for _, _, sd in q)
