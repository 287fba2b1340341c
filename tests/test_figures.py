"""The plot scripts and the figures' data: executable scripts that find a
Python with matplotlib, PNG + SVG that a rerun reproduces byte for byte, no
stale figure after a rerun, the ghost-ball expert's aim (ghost.aim), the
obstacles of Fig. 7.1, Fig. 7.10's outcome categories and the t quantiles
the intervals use.

Run by `make check` with POOLREPS=<abs path of the binary> and PYTHON=<a
Python with matplotlib>.
"""
import csv
import math
import os
import shutil
import sys

import pytest
from conftest import ROOT, poolreps_path, run_experiment, run_cmd

SCRIPTS = ROOT / "scripts"
PY = os.environ.get("PYTHON") or "/usr/bin/python3"
ENV = dict(os.environ, LC_ALL="C")
SCALE = float(os.environ.get("POOLREPS_TIMEOUT_SCALE", "1"))  # valgrind runs are slower
EXP2_TINY = ["exp2.sizes=10,20", "exp2.test=50", "experiment.repetitions=2"]
EXP3_TINY = ["exp3.iterations=3", "exp3.init_samples=40", "exp3.window=40", "exp3.samples=10",
             "experiment.repetitions=2", "policy.n_min=20", "exp3.baseline_n_min=100",
             "exp3.final_episodes=20"]


def has_matplotlib(python):
    try:
        return run_cmd([python, "-c", "import matplotlib, numpy"], capture_output=True,
                              timeout=60).returncode == 0
    except OSError:
        return False


needs_mpl = pytest.mark.skipif(not has_matplotlib(PY), reason=f"{PY} lacks matplotlib")


def plot(folder, env=None, script="plot"):
    """scripts/plot (or a plot script) on folder; the CompletedProcess."""
    return run_cmd([str(SCRIPTS / script), str(folder)], capture_output=True, text=True,
                          env=env or dict(ENV, PYTHON=PY), timeout=300)


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "sim"
    run_experiment("figures.ini", out)
    return out


@pytest.fixture(scope="module")
def exp2(tmp_path_factory):
    out = tmp_path_factory.mktemp("exp2") / "exp2"
    run_experiment("exp2.ini", out, EXP2_TINY)
    return out


# ---- the scripts ----

def test_every_script_is_executable():
    scripts = sorted(SCRIPTS.glob("*.py"))
    assert len(scripts) >= 10
    for p in scripts + [SCRIPTS / "plot"]:
        assert os.access(p, os.X_OK), f"{p.name} is not executable"
    for p in scripts:
        first = p.read_text(encoding="utf-8").splitlines()[0]
        assert first == "#!/usr/bin/env python3", f"{p.name}: shebang {first!r}"


@pytest.mark.slow  # the quick reproduction: skipped under valgrind with the others that use it
@needs_mpl
def test_plot_writes_png_and_svg_reproducibly(quick_reproduction, tmp_path):
    """scripts/plot on a copy, elsewhere, of the quick reproduction's sim
    folder, over the figures that run drew there (one made stale): the same
    bytes as the reproduction's, which drew them in one process after other
    figures."""
    src = quick_reproduction / "sim"
    stems = ["fig7_1_table", "fig7_2_reward", "fig7_3_shots", "fig7_5_ghost"]
    before = {p.name: p.read_bytes() for p in src.iterdir() if p.suffix in (".png", ".svg")}
    assert sorted(before) == sorted(f"{s}.{e}" for s in stems for e in ("png", "svg"))
    for stem in stems:
        png, svg = before[f"{stem}.png"], before[f"{stem}.svg"]
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10000, stem
        assert b"<svg" in svg[:1000] and b"<dc:date>" not in svg, stem
    b = tmp_path / "elsewhere" / "b"
    shutil.copytree(src, b)
    (b / "fig7_1_table.png").write_bytes(b"stale")
    p = plot(b)
    assert p.returncode == 0, p.stderr
    assert {p.name: p.read_bytes() for p in b.iterdir() if p.suffix in (".png", ".svg")} == before


@needs_mpl
def test_replot_removes_stale_figures_and_warns_about_others(exp2, tmp_path):
    d = tmp_path / "e2"
    shutil.copytree(exp2, d)
    (d / "fig7_6.pdf").write_bytes(b"%PDF-1.4 from an older run")
    (d / "fig7_6.png").write_bytes(b"old")
    (d / "notes.png").write_bytes(b"the user's own picture")
    p = plot(d)
    assert p.returncode == 0, p.stderr
    assert not (d / "fig7_6.pdf").exists()
    assert (d / "fig7_6.png").read_bytes()[:4] == b"\x89PNG"
    assert (d / "notes.png").read_bytes() == b"the user's own picture"
    assert "removed stale" in p.stderr and "fig7_6.pdf" in p.stderr
    assert "notes.png" in p.stderr and "not drawn by this script" in p.stderr
    assert p.stdout.split() == [str(d / "fig7_6.png"), str(d / "fig7_6.svg")]


@needs_mpl
def test_scripts_find_matplotlib_when_python3_lacks_it(exp2, tmp_path):
    """A python3 first on PATH without matplotlib (a bare virtual environment):
    the scripts run themselves again under a Python that has it."""
    if not has_matplotlib("/usr/bin/python3"):
        pytest.skip("/usr/bin/python3 lacks matplotlib: no fallback to find")
    venv = tmp_path / "venv"
    if run_cmd(["/usr/bin/python3", "-m", "venv", "--without-pip", str(venv)],
                      capture_output=True, timeout=120).returncode:
        pytest.skip("cannot create a virtual environment")
    bare = venv / "bin" / "python3"
    assert not has_matplotlib(str(bare))
    env = {k: v for k, v in ENV.items() if k not in ("PYTHON", "POOLREPS_PLOT_REEXEC")}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    d = tmp_path / "e2"
    shutil.copytree(exp2, d)
    for script in ("plot_exp2.py", "plot"):
        (d / "fig7_6.png").unlink(missing_ok=True)
        p = plot(d, env=env, script=script)
        assert p.returncode == 0, p.stderr
        assert (d / "fig7_6.png").read_bytes()[:4] == b"\x89PNG", script


def test_plot_launcher_refuses_other_folders(tmp_path):
    p = plot(tmp_path)
    assert p.returncode == 1
    assert len(p.stderr.splitlines()) == 1 and "config.ini" in p.stderr


# ---- Fig. 7.1 and the default folder of the figures' data ----

def test_fig7_1_has_obstacles(sim):
    roles = [r["role"] for r in read_csv(sim / "fig7_1_balls.csv")]
    assert roles[:2] == ["cue", "reward"] and roles.count("obstacle") >= 1


def test_figures_data_goes_to_results_sim(tmp_path):
    binary = poolreps_path()
    if binary is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    p = run_cmd([binary, str(ROOT / "data" / "figures.ini"), "-q"], cwd=tmp_path,
                       capture_output=True, text=True, env=ENV, timeout=120 * SCALE)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "results" / "sim" / "fig7_1_balls.csv").is_file()
    assert not (tmp_path / "results" / "figures").exists()


# ---- the ghost-ball expert's aim (Fig. 7.5) ----

def entry_reference(px, py, rp, length, width, radius, steps=200000):
    """Midpoint of the arc of the capture circle around (px, py) that lies in
    the rectangle a ball centre can reach, |x| <= L/2 - R, |y| <= W/2 - R:
    sampled on a fine grid of angles (independent of the C code)."""
    inside = []
    for k in range(steps):
        a = 2 * math.pi * k / steps
        x, y = px + rp * math.cos(a), py + rp * math.sin(a)
        if abs(x) <= length / 2 - radius and abs(y) <= width / 2 - radius:
            inside.append(a)
    # the arc does not wrap around angle 0 for these pockets
    mid = (inside[0] + inside[-1]) / 2
    return px + rp * math.cos(mid), py + rp * math.sin(mid)


# (target pockets, reward-ball box, the target the expert picks): a corner,
# then reward balls next to a middle pocket (Fig. 7.3 needs targets 2 and 5)
@pytest.mark.slow
@pytest.mark.parametrize("targets,box,pocket", [
    ("2,5", None, "5"),
    ("2,4,5", "-0.05,0.05,0.08,0.15", "4"),
    ("1,2,5", "-0.05,0.05,-0.15,-0.08", "1"),
])
def test_ghost_aim_corridor_aims_at_the_entry_centre(tmp_path, targets, box, pocket):
    out = {}
    for aim in ("centre", "corridor"):
        sets = [f"ghost.aim={aim}", f"reward.targets={targets}"]
        run_experiment("figures.ini", tmp_path / aim,
                       sets + ([f"start.reward_box={box}"] if box else []))
        out[aim] = read_csv(tmp_path / aim / "fig7_5_ghost.csv")[0]
    g, c = out["corridor"], out["centre"]
    assert g["target"] == c["target"] == pocket
    assert float(g["reward"]) == 0 and float(c["reward"]) == 0
    t = read_csv(tmp_path / "corridor" / "fig7_table.csv")[0]
    pk = {r["pocket"]: r for r in read_csv(tmp_path / "corridor" / "fig7_1_pockets.csv")}
    p = pk[g["target"]]
    px, py, rp = float(p["x"]), float(p["y"]), float(t["pocket_radius"])
    ex, ey = entry_reference(px, py, rp, float(t["length"]), float(t["width"]),
                             float(t["ball_radius"]))
    # tolerance: the reference samples angles every 2 pi / 200000 rad
    assert float(g["entry_x"]) == pytest.approx(ex, abs=1e-6)
    assert float(g["entry_y"]) == pytest.approx(ey, abs=1e-6)
    assert (g["aim_x"], g["aim_y"]) == (g["entry_x"], g["entry_y"])
    assert (float(c["aim_x"]), float(c["aim_y"])) == (px, py)
    assert (c["entry_x"], c["entry_y"]) == (g["entry_x"], g["entry_y"])
    assert math.hypot(float(g["entry_x"]) - px, float(g["entry_y"]) - py) == \
        pytest.approx(rp, abs=1e-15)


def test_ghost_aim_corridor_expert_pockets_every_ball(tmp_path):
    run_experiment("exp2.ini", tmp_path / "e2", ["ghost.aim=corridor", "exp2.sizes=10",
                                                 "exp2.test=400", "experiment.repetitions=1"])
    expert = [r for r in read_csv(tmp_path / "e2" / "exp2_returns.csv") if r["policy"] == "expert"]
    assert expert and all(float(r["pocketed"]) == 1 and float(r["mean_return"]) == 0
                          for r in expert)


def test_ghost_aim_corridor_refuses_an_empty_corridor(tmp_path):
    p = run_experiment("exp2.ini", tmp_path / "e2", ["ghost.aim=corridor", "exp2.sizes=10",
                                                     "table.pocket_radius=0.02"], check=False)
    assert p.returncode == 1
    assert len(p.stderr.splitlines()) == 1 and "corridor is empty" in p.stderr
    assert not (tmp_path / "e2").exists()


def test_ghost_aim_is_a_documented_key(poolreps):
    out = poolreps(["--help-keys"]).stdout.decode()
    assert "ghost.aim" in out and "centre|corridor" in out
    bad = poolreps(["config", "--set", "ghost.aim=pocket"])
    assert bad.returncode == 1 and b"ghost.aim" in bad.stderr


# ---- Fig. 7.10's categories and the intervals ----

def test_outcome_categories_and_shares():
    pytest.importorskip("matplotlib")
    sys.path.insert(0, str(SCRIPTS))
    try:
        import plot_exp3
    finally:
        sys.path.remove(str(SCRIPTS))
    ep = lambda pocket, hit: {"pocket": pocket, "hit": hit}  # noqa: E731
    targets = {"2", "5"}
    assert [plot_exp3.outcome(ep(p, h), targets) for p, h in
            [("2", "1"), ("5", "1"), ("1", "1"), ("3", "1"), ("-1", "0"), ("-1", "1")]] == \
        ["target", "target", "elsewhere", "elsewhere", "missed", "table"]
    runs = {("a", 0): [ep("2", "1"), ep("-1", "0"), ep("-1", "0"), ep("-1", "1")],
            ("a", 1): [ep("4", "1"), ep("-1", "1")], ("b", 0): [ep("5", "1")]}
    sh, n = plot_exp3.shares(runs, "a", lambda e: plot_exp3.outcome(e, targets))
    assert n == 6
    assert sh["target"] == (1 / 6, [0.25, 0.0])
    assert sh["missed"] == (2 / 6, [0.5, 0.0])
    assert sh["elsewhere"] == (1 / 6, [0.0, 0.5])
    assert sh["table"] == (2 / 6, [0.25, 0.5])


def test_mean_ci():
    sys.path.insert(0, str(SCRIPTS))
    try:
        import figstats
    finally:
        sys.path.remove(str(SCRIPTS))
    # the published two-sided 95 % t value for df 4
    m, lo, hi = figstats.mean_ci([1.0, 2.0, 3.0, 4.0, 5.0])
    assert (m, hi - m) == pytest.approx((3.0, 2.7764451051977987 * math.sqrt(2.5 / 5)), abs=1e-9)
    assert figstats.mean_ci([2.0])[1:] == (None, None)
    assert figstats.paired({0: 3.0, 1: 5.0, 2: 1.0}, {1: 4.0, 0: 1.0}) == [2.0, 1.0]
