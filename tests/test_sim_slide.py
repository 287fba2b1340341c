"""The sliding-then-rolling friction law (table.friction_law = slide_roll,
docs/sim.md): `poolreps shoot` against the closed form of straight shots
written here from the equations (a stun ball slides 12 v0^2 / (49 mu_s g)
and rolls on at 5/7 v0; a cue ball stopped by a straight hit keeps its roll
and follows at 2/7 of its speed), in event mode to 1e-9 m and in the
thesis's stepped scheme to 2e-3 m; and the bad-input rules of the law's
keys; and an independent numpy reference (tests/ref_sim_slide.py) on
seeded random shots."""
import csv
import io
import os
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import run_cmd

from ref_sim_slide import SlideSim
from test_sim_constant import compare, degenerate_shots, random_shots, refused

ROOT = Path(__file__).resolve().parent.parent
BIN = os.environ.get("POOLREPS", str(ROOT / "poolreps"))
G, R, VS = 9.81, 0.015, 0.002


def shoot(rows, sets, tmp_path):
    text = "x0,y0,x1,y1,vx,vy\n" + "".join(",".join(repr(float(v)) for v in r) + "\n"
                                           for r in rows)
    args = [BIN, "shoot", "--set", "table.friction_law=slide_roll"]
    for kv in sets:
        args += ["--set", kv]
    r = run_cmd(args, input=text, capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert r.returncode == 0, r.stderr
    return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(io.StringIO(r.stdout))]


def slide(v0, ms):
    """Distance a stun ball slides before it rolls (at 5/7 v0)."""
    return 12 * v0 * v0 / (49 * ms * G)


def roll(v1, mr):
    """Distance a rolling ball of speed v1 covers until the stop speed."""
    return (v1 * v1 - VS * VS) / (2 * mr * G)


def speed_after(v0, d, ms, mr):
    """Speed of a stun ball of speed v0 after distance d (d past its slide)."""
    ds = slide(v0, ms)
    assert d > ds
    return ((5 * v0 / 7) ** 2 - 2 * mr * G * (d - ds)) ** 0.5


def head_on(xc, xo, v0, ms, mr):
    """Final x of the cue and object balls of a straight stun shot along y = 0."""
    contact = xo - 2 * R
    vc = speed_after(v0, contact - xc, ms, mr)
    # the object ball: a stun ball of speed vc; the cue ball: at rest with roll vc,
    # pushed forward while it slides (v = mu_s g t) up to 2/7 vc, then rolling
    obj = xo + slide(vc, ms) + roll(5 * vc / 7, mr)
    cue = contact + 2 * vc * vc / (49 * ms * G) + roll(2 * vc / 7, mr)
    return cue, obj


@pytest.mark.parametrize("ms,mr", [(0.2, 0.01), (0.3, 0.02), (0.15, 0.012)])
def test_head_on_stun_shot_event(ms, mr, tmp_path):
    """Cue at (-0.25, 0), object at (0.1, 0), 0.5 m/s: both balls end where
    the closed form says, to 1e-9 m (the follow of the cue ball is the
    2/7 roll of the straight hit)."""
    (r,) = shoot([[-0.25, 0, 0.1, 0, 0.5, 0]], [f"table.mu_slide={ms}", f"table.mu_roll={mr}"],
                 tmp_path)
    cue, obj = head_on(-0.25, 0.1, 0.5, ms, mr)
    assert r["hit"] == 1
    assert abs(r["x0"] - cue) < 1e-9 and abs(r["x1"] - obj) < 1e-9, (r, cue, obj)
    assert r["y0"] == 0 and r["y1"] == 0
    # the follow itself: the cue ball moves on past the contact point
    assert r["x0"] - (0.1 - 2 * R) > 1e-3


def test_head_on_stun_shot_stepped(tmp_path):
    """The same shot in the thesis's stepped scheme at dt = 0.1 ms: within 2e-3 m."""
    (r,) = shoot([[-0.25, 0, 0.1, 0, 0.5, 0]], ["sim.mode=stepped", "sim.dt=0.0001"], tmp_path)
    cue, obj = head_on(-0.25, 0.1, 0.5, 0.2, 0.01)
    assert abs(r["x0"] - cue) < 2e-3 and abs(r["x1"] - obj) < 2e-3, (r, cue, obj)


@pytest.mark.parametrize("v0,ang", [(0.3, 0.0), (0.12, 1.0), (0.05, -2.5), (0.35, 0.4)])
def test_stun_stop_distance(v0, ang, tmp_path):
    """A lone stun ball (the object ball out of its way) stops at
    slide + roll along its line, to 1e-9 m, in any direction."""
    import math
    ux, uy = math.cos(ang), math.sin(ang)
    (r,) = shoot([[0, 0, 0.4, -0.2 if uy > 0 else 0.2, v0 * ux, v0 * uy]], [], tmp_path)
    d = slide(v0, 0.2) + roll(5 * v0 / 7, 0.01)
    assert r["hit"] == 0
    assert abs(r["x0"] - d * ux) < 1e-9 and abs(r["y0"] - d * uy) < 1e-9, (r, d)


def test_cushion_leaves_the_spin(tmp_path):
    """A rolling ball sent straight into a cushion comes back sliding: its
    spin still drives it towards the cushion, so it ends nearer to it than
    a ball that rebounds rolling would, where the closed form says: after
    the bounce v = -kappa v_in, w = v_in, and it rolls at (5 v + 2 w) / 7."""
    ms, mr, kappa = 0.2, 0.01, 0.8
    hx = 0.5 - R
    x0, v0 = 0.0, 1.2
    (r,) = shoot([[x0, 0, -0.4, 0.2, v0, 0]], [], tmp_path)
    vin = speed_after(v0, hx - x0, ms, mr)
    vout = -kappa * vin
    vroll = (5 * vout + 2 * vin) / 7  # still away from the cushion
    # sliding: the slip -(1 + kappa) vin shrinks at 7/2 mu_s g, v' = +mu_s g
    t = (1 + kappa) * vin / (3.5 * ms * G)
    xs = hx + vout * t + 0.5 * ms * G * t * t
    want = xs - roll(-vroll, mr)
    assert abs(r["x0"] - want) < 1e-9, (r, want)


BAD = [
    (["table.mu_slide=0"], "table.mu_slide: 0 out of range"),
    (["table.mu_slide=1.5"], "table.mu_slide: 1.5 out of range"),
    (["table.mu_roll=-0.01"], "table.mu_roll: -0.01 out of range"),
    (["table.mu_roll=nan"], "table.mu_roll: not a finite number"),
    (["table.mu_roll=0.3"], "table.mu_roll: must be below table.mu_slide (got 0.3 >= 0.2)"),
    (["table.friction=0.3"], "table.friction: not used with table.friction_law = slide_roll"),
    (["table.deceleration=0.1"], "table.deceleration: not used with table.friction_law = slide_roll"),
]


@pytest.mark.parametrize("sets,msg", BAD)
def test_bad_slide_keys(sets, msg, tmp_path):
    refused("slide_roll", sets, msg, tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == []


@pytest.mark.parametrize("law", ["exponential", "constant"])
def test_slide_keys_under_another_law(law, tmp_path):
    """The slide_roll law's keys with another law chosen explicitly, in a
    file: refused with the file's line, as keys of another law are."""
    ini = tmp_path / "p.ini"
    ini.write_text(f"[table]\nfriction_law = {law}\nmu_roll = 0.02\n")
    inp = "x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.5,0\n"
    r = run_cmd([BIN, "shoot", "-c", str(ini)], input=inp, capture_output=True, text=True,
                cwd=tmp_path)
    assert r.returncode == 1
    assert r.stderr == (f"poolreps: {ini}:3: table.mu_roll: not used with "
                        f"table.friction_law = {law}\n")


SLIDE_TABLES = [
    ([], {}),
    (["table.mu_slide=0.3", "table.mu_roll=0.03", "table.restitution=0.6",
      "table.stop_speed=0.01"], {"ms": 0.3, "mr": 0.03, "kappa": 0.6, "v_stop": 0.01}),
]


@pytest.mark.parametrize("table", range(len(SLIDE_TABLES)))
def test_reference_random_shots(table, tmp_path):
    """Seeded random two- and three-ball shots (speeds up to 2 m/s, half
    aimed near a ball) and the degenerate ones against the independent
    reference tests/ref_sim_slide.py: the same events, pockets and hits,
    final positions within 1e-9 m."""
    sets, params = SLIDE_TABLES[table]
    rng = np.random.default_rng(21 + table)
    sim = SlideSim(**params)
    worst = compare(random_shots(rng, 300, 2, sim, 2.0) + degenerate_shots(sim), 2, sets, params,
                    1e-9, tmp_path, law="slide_roll", make=SlideSim)
    worst = max(worst, compare(random_shots(rng, 100, 3, sim, 2.0), 3, sets, params, 1e-9,
                               tmp_path, law="slide_roll", make=SlideSim))
    print(f"slide_roll vs reference: worst final-position difference {worst:.2e} m")


def test_pooltool_block_is_generated(tmp_path):
    """docs/sim.md's pooltool table is what scripts/pooltool_table.py makes of
    docs/data/pooltool_slide_roll.csv, and a changed outcome in the data is
    seen by --check."""
    script = str(ROOT / "scripts" / "pooltool_table.py")
    src = ROOT / "docs" / "data" / "pooltool_slide_roll.csv"
    p = run_cmd([sys.executable, script, "--check"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    rows = list(csv.DictReader(io.StringIO(src.read_text())))
    ghost = next(r for r in rows if r["family"] == "ghost")
    ghost["pt_pocket1"] = "0"
    bad = tmp_path / "bad.csv"
    with open(bad, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    p = run_cmd([sys.executable, script, "--check", "--csv", str(bad)],
                capture_output=True, text=True)
    assert p.returncode == 1 and "pooltool_slide_roll block differs" in p.stderr, p.stderr


def test_config_refuses_the_mu_a_shot_refuses(tmp_path):
    """`config` refuses what a run would (docs/hardening.md, 10), blaming
    the key the user set: mu_slide below the default mu_roll, by --set or
    in a file, was written out as a valid configuration (exit 0)."""
    ini = tmp_path / "p.ini"
    ini.write_text("[table]\nfriction_law = slide_roll\nmu_slide = 0.005\n")
    why = "table.mu_roll: must be below table.mu_slide (got 0.01 >= 0.005)"
    for args, where in [(["-c", str(ini)], f"{ini}:3"),
                        (["--set", "table.friction_law=slide_roll", "--set", "table.mu_slide=0.005"],
                         "--set")]:
        for cmd in (["config", "-o", str(tmp_path / "out.ini")], ["shoot"]):
            r = run_cmd([BIN] + cmd + args, input="x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,0.5,0\n",
                        capture_output=True, text=True, cwd=tmp_path)
            assert r.returncode == 1, (cmd, r.stderr)
            assert r.stderr == f"poolreps: {where}: table.mu_slide: {why}\n", (cmd, r.stderr)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.ini"]
