"""The command line composes: `shoot --keep` copies its input columns in
front of the results, so that its output feeds `forest` and `reps`; the
README's pipeline runs exactly as printed.

Run by `make check` with POOLREPS=<absolute path of the binary>.
"""
import csv
import io
import math
import os
import re

import pytest
from conftest import ROOT, poolreps_path, run_cmd

SCALE = float(os.environ.get("POOLREPS_TIMEOUT_SCALE", "1"))  # valgrind runs are slower

SHOTS = ("x0,y0,x1,y1,vx,vy\n"
         "-0.25,0,0.1,0,0.615,0.03\n"        # into pocket 2
         "-0.45,-0.1,0.3,0.2,0.2,0\n"        # misses the reward ball
         "-0.2,0,0,0,0.1,0\n")               # head-on


def rows(text):
    return list(csv.reader(io.StringIO(text)))


def shoot(poolreps, tmp_path, text, *extra):
    (tmp_path / "in.csv").write_text(text)
    r = poolreps(["shoot", "-i", "in.csv", *extra], cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    return rows(r.stdout.decode())


def test_keep_copies_the_inputs_in_front(poolreps, tmp_path):
    plain = shoot(poolreps, tmp_path, SHOTS)
    kept = shoot(poolreps, tmp_path, SHOTS, "--keep")
    inp = rows(SHOTS)
    assert kept[0] == inp[0] + ["final_" + c for c in plain[0][:4]] + plain[0][4:]
    assert plain[0][:4] == ["x0", "y0", "x1", "y1"]
    assert len(kept) == len(plain) == len(inp)
    for k, p, i in zip(kept[1:], plain[1:], inp[1:]):
        assert [float(v) for v in k[:6]] == [float(v) for v in i]   # the values, exactly
        assert k[6:] == p                                            # the same shot
    assert len(set(kept[0])) == len(kept[0]), "duplicate column names"


def test_keep_follows_the_input_column_order(poolreps, tmp_path):
    text = "vy,x1,y1,vx,x0,y0\n0.03,0.1,0,0.615,-0.25,0\n"
    kept = shoot(poolreps, tmp_path, text, "--keep")
    plain = shoot(poolreps, tmp_path, SHOTS.splitlines()[0] + "\n" + SHOTS.splitlines()[1] + "\n")
    assert kept[0][:6] == ["vy", "x1", "y1", "vx", "x0", "y0"]
    assert kept[1][:6] == ["0.03", "0.1", "0", "0.615", "-0.25", "0"]
    assert kept[1][6:] == plain[1]


def test_keep_with_a_bad_row_writes_nothing(poolreps, tmp_path):
    (tmp_path / "in.csv").write_text("x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.6,0\n-0.25,0,-0.25,0,1,0\n")
    r = poolreps(["shoot", "--keep", "-i", "in.csv", "-o", "out.csv"], cwd=tmp_path)
    assert r.returncode == 1
    err = r.stderr.decode().splitlines()
    assert len(err) == 1 and "in.csv:3" in err[0], err
    assert sorted(os.listdir(tmp_path)) == ["in.csv"]


def test_keep_only_for_shoot(poolreps, tmp_path):
    r = poolreps(["reps", "--keep", "--return", "r"], cwd=tmp_path, input=b"r\n1\n")
    assert r.returncode == 1 and b"--keep does not apply" in r.stderr


def random_shots(n, seed):
    """n shots from Experiment 3's region: cue ball at (-0.25, 0), reward ball
    in [0.05,0.15]x[-0.1,0.1], speed 0.3-0.8 m/s roughly towards the right."""
    import random
    rng = random.Random(seed)
    lines = ["x0,y0,x1,y1,vx,vy"]
    for _ in range(n):
        lines.append(f"-0.25,0,{0.05 + 0.1 * rng.random():.4f},{-0.1 + 0.2 * rng.random():.4f},"
                     f"{0.3 + 0.5 * rng.random():.4f},{-0.2 + 0.4 * rng.random():.4f}")
    return "\n".join(lines) + "\n"


def test_shoot_keep_pipes_into_forest(tmp_path):
    """The composition the README promises: shoot --keep | forest --train - --test ..."""
    binary = poolreps_path()
    if binary is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    (tmp_path / "shots.csv").write_text(random_shots(200, 1))
    (tmp_path / "test_shots.csv").write_text(random_shots(50, 2))
    env = dict(os.environ, LC_ALL="C", P=binary)
    run_cmd(f'"$P" shoot --keep -i test_shots.csv -o test.csv', shell=True, cwd=tmp_path,
                   env=env, check=True, timeout=60 * SCALE)
    p = run_cmd(f'"$P" shoot --keep -i shots.csv | '
                       f'"$P" forest --train - --test test.csv --target reward',
                       shell=True, cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=60 * SCALE)
    assert p.returncode == 0, p.stderr
    out = rows(p.stdout)
    assert out[0] == ["pred_reward"] and len(out) == 51
    assert "test MSE" in p.stderr


def readme_pipeline():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    m = re.search(r"<!-- pipeline:begin -->\n```sh\n(.*?)```\n<!-- pipeline:end -->", text, re.S)
    assert m, "README lacks the pipeline block"
    return m.group(1)


def test_readme_pipeline_runs_as_printed(tmp_path):
    binary = poolreps_path()
    if binary is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    os.symlink(binary, tmp_path / "poolreps")
    script = readme_pipeline()
    for step in ("./poolreps shoot --keep", "./poolreps forest", "--leaves", "./poolreps reps"):
        assert step in script
    p = run_cmd(["sh", "-e", "-c", script], cwd=tmp_path, capture_output=True, text=True,
                       env=dict(os.environ, LC_ALL="C"), timeout=120 * SCALE)
    assert p.returncode == 0, p.stderr
    with open(tmp_path / "episodes.csv", newline="") as f:
        episodes = list(csv.DictReader(f))
    with open(tmp_path / "leaves.csv", newline="") as f:
        leaves = list(csv.DictReader(f))
    with open(tmp_path / "weights.csv", newline="") as f:
        p_w = [float(r["p"]) for r in csv.DictReader(f)]
    with open(tmp_path / "summary.csv", newline="") as f:
        summary = next(csv.DictReader(f))
    n = len(episodes)
    assert n > 100 and len(leaves) == n and len(p_w) == n
    assert list(episodes[0])[:6] == ["x0", "y0", "x1", "y1", "vx", "vy"]
    # REPS weights: a distribution over the episodes, within the KL bound 0.5
    # (tolerances: 1e-12 on the sum of p, 1e-6 on the KL of an active bound)
    assert min(p_w) >= 0 and math.fsum(p_w) == pytest.approx(1, abs=1e-12)
    kl = float(summary["kl"])
    assert kl <= 0.5 + 1e-6
    if summary["bound"] == "1":
        assert kl == pytest.approx(0.5, abs=1e-6)
    # they favour the better episodes: the weighted mean return beats the plain mean
    ret = [float(e["reward"]) for e in episodes]
    assert math.fsum(w * r for w, r in zip(p_w, ret)) > math.fsum(ret) / n
