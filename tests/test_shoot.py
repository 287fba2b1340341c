"""End-to-end tests of `poolreps shoot` (docs/sim.md, `poolreps shoot`).

The binary is $POOLREPS (default ./poolreps at the repository root); run
with LC_ALL=C.
"""
import csv
import math
import os
from pathlib import Path

import pytest
from conftest import run_cmd

ROOT = Path(__file__).resolve().parent.parent
BIN = os.environ.get("POOLREPS", str(ROOT / "poolreps"))
C, VS, R = 0.25, 0.002, 0.015


def run(args, tmp_path, text=None):
    env = dict(os.environ, LC_ALL="C")
    return run_cmd([BIN] + args, input=text, capture_output=True, text=True,
                          cwd=tmp_path, env=env, timeout=60)


def write(tmp_path, text, name="in.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def shoot(tmp_path, text, *extra):
    inp = write(tmp_path, text)
    out = tmp_path / "out.csv"
    trace = tmp_path / "trace.csv"
    r = run(["shoot", "-i", str(inp), "-o", str(out), "--trace", str(trace), *extra], tmp_path)
    assert r.returncode == 0, r.stderr
    return read_csv(out), read_csv(trace)


def test_known_answers(tmp_path):
    rows, trace = shoot(tmp_path, "x0,y0,x1,y1,vx,vy\n"
                        "-0.45,-0.1,0.3,0.2,0.2,0\n"      # free flight, reward ball away
                        "-0.2,0,0,0,0.1,0\n"              # head-on: velocities exchange
                        "0.3,0.1,-0.2,-0.1,0.4,0.3\n")    # cue ball into pocket 5
    assert list(rows[0]) == ["x0", "y0", "x1", "y1", "pocket0", "pocket1", "hit", "min_gap",
                             "reward", "t_end", "events"]
    free, head, scratch = rows
    assert float(free["x0"]) == pytest.approx(-0.45 + (0.2 - VS) / C, abs=1e-12)
    assert float(free["t_end"]) == pytest.approx(math.log(0.2 / VS) / C, abs=1e-9)
    assert free["hit"] == "0" and free["events"] == "1"
    vc = 0.1 - C * (0.2 - 2 * R)
    assert float(head["x0"]) == pytest.approx(-2 * R, abs=1e-14)
    assert float(head["x1"]) == pytest.approx((vc - VS) / C, abs=1e-12)
    assert head["hit"] == "1" and float(head["min_gap"]) == 0
    x1 = (vc - VS) / C
    assert float(head["reward"]) == pytest.approx(-math.hypot(0.5 - x1, 0.25), abs=1e-12)
    assert scratch["pocket0"] == "5" and scratch["pocket1"] == "-1"
    assert (float(scratch["x0"]), float(scratch["y0"])) == (0.5, 0.25)
    # trace: shot,t,ball,x,y,vx,vy; each shot starts at t = 0 from the input
    assert list(trace[0]) == ["shot", "t", "ball", "x", "y", "vx", "vy"]
    first = [t for t in trace if t["shot"] == "1" and float(t["t"]) == 0]
    assert [(t["ball"], float(t["x"]), float(t["vx"])) for t in first[:2]] == \
        [("0", -0.2, 0.1), ("1", 0.0, 0.0)]
    assert {t["shot"] for t in trace} == {"0", "1", "2"}


def test_three_balls_and_stepped(tmp_path):
    text = "vx,vy,x0,y0,x1,y1,x2,y2\n0.1,0,-0.2,0,0,0,0.3,0.2\n"   # any column order
    rows, _ = shoot(tmp_path, text)
    assert "x2" in rows[0] and "pocket2" in rows[0]
    assert float(rows[0]["x2"]) == 0.3
    rows, trace = shoot(tmp_path, text, "--set", "sim.mode=stepped", "--set", "sim.dt=0.001")
    ev = float(rows[0]["x1"])
    assert ev == pytest.approx((0.1 - C * (0.2 - 2 * R) - VS) / C, abs=2e-4)
    assert int(rows[0]["events"]) == round(float(rows[0]["t_end"]) / 0.001)
    assert len(trace) > 10


def test_stdin_stdout(tmp_path):
    r = run(["shoot"], tmp_path, "x0,y0,x1,y1,vx,vy\n-0.2,0,0,0,0.1,0\n")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 2 and lines[0].startswith("x0,y0,x1,y1,pocket0")


BAD = [
    ("odd column count", "x0,y0,x1,y1,vx\n-0.25,0,0.1,0,0.5\n", 1),
    ("wrong column set", "x0,y0,x1,y1,vx,vz\n-0.25,0,0.1,0,0.5,0\n", 1),
    ("cue ball only", "x0,y0,vx,vy\n-0.25,0,0.5,0\n", 1),
    ("nan", "x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.5,0\n-0.25,0,nan,0,0.5,0\n", 3),
    ("inf", "x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.5,0\n-0.25,0,0.1,0,inf,0\n", 3),
    ("not a number", "x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.5,0\n-0.25,0,abc,0,0.5,0\n", 3),
    ("short row", "x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.5,0\n-0.25,0,0.1,0,0.5\n", 3),
    ("overlap", "x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.5,0\n-0.25,0,-0.23,0,0.5,0\n", 3),
    ("off the table", "x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.5,0\n-0.25,0,0.1,0.24,0.5,0\n", 3),
    ("in a pocket", "x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.5,0\n-0.25,0,0.0,0.225,0.5,0\n", 3),
    ("too fast", "x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.5,0\n-0.25,0,0.1,0,10,1\n", 3),
]


@pytest.mark.parametrize("what,text,line", BAD, ids=[b[0] for b in BAD])
def test_bad_input(tmp_path, what, text, line):
    inp = write(tmp_path, text)
    out = tmp_path / "out.csv"
    trace = tmp_path / "trace.csv"
    r = run(["shoot", "-i", str(inp), "-o", str(out), "--trace", str(trace)], tmp_path)
    assert r.returncode != 0, what
    err = r.stderr.strip()
    assert len(err.splitlines()) == 1, r.stderr
    assert f"in.csv:{line}:" in err, err
    assert not out.exists() and not trace.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.csv"]


def test_event_limit_fails_cleanly(tmp_path):
    inp = write(tmp_path, "x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.5,0\n-0.25,0,0.1,0.2,1.5,0.1\n")
    out = tmp_path / "out.csv"
    r = run(["shoot", "-i", str(inp), "-o", str(out), "--set", "sim.max_events=6"], tmp_path)
    assert r.returncode == 3
    assert "in.csv:3:" in r.stderr and "max_events" in r.stderr
    assert not out.exists()


def test_a_ball_radius_that_squares_to_zero_is_refused(tmp_path):
    """Contact times solve |d|^2 = (2R)^2: at R = 1e-200, (2R)^2 is 0 and a
    head-on shot passed through the object ball (hit 0), exit 0. The
    smallest radius is 1e-100 (which still hits), whether set by --set or
    per row; below it one line names the key (and the row), exit 1."""
    head = "x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.615,0\n"
    rows, _ = shoot(tmp_path, head, "--set", "table.ball_radius=1e-100")
    assert rows[0]["hit"] == "1"
    for args, text, want in [
            (["--set", "table.ball_radius=1e-200"], head,
             "poolreps: --set: table.ball_radius: 1e-200 out of range: must be >= 1e-100 and <= 1\n"),
            ([], "x0,y0,x1,y1,vx,vy,table.ball_radius\n-0.25,0,0.1,0,0.615,0,1e-200\n",
             "poolreps: in.csv:2: table.ball_radius: 1e-200 out of range: must be >= 1e-100 and <= 1\n")]:
        write(tmp_path, text)
        r = run(["shoot", "-i", "in.csv", "-o", "no.csv", *args], tmp_path)
        assert r.returncode == 1 and r.stderr == want, r.stderr
        assert not (tmp_path / "no.csv").exists()
