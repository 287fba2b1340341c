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


# ---- a check across keys names the key the user set ----

@pytest.mark.parametrize("sets,needle", [
    (["table.length=0.1"], "--set: table.length: start.cue_box: box reaches beyond"),
    (["table.width=0.05"], "--set: table.width: start.reward_box: box reaches beyond"),
    (["start.cue_box=0,9,0,0.1"], "--set: start.cue_box: box reaches beyond"),
    (["table.length=0.1", "start.cue_box=0,0.01,0,0.01"], "--set: table.length: start.reward_box"),
    (["sim.mode=stepped", "sim.max_time=1e-5"], "--set: sim.max_time: sim.dt: must be smaller"),
    (["table.balls=2", "table.reward_balls=1", "table.obstacle_balls=0"], None),
])
def test_cross_key_error_names_the_key_set(sets, needle, tmp_path):
    args = ["config"]
    for s in sets:
        args += ["--set", s]
    r = run(args, tmp_path)
    if needle is None:
        return
    assert r.returncode == 1, r.stderr
    assert needle in one_line(r)


def test_cross_key_error_names_the_file_line(tmp_path):
    (tmp_path / "t.ini").write_text("[table]\nlength = 0.1\n")
    r = run(["config", "-c", "t.ini"], tmp_path)
    assert r.returncode == 1 and "t.ini:2: table.length: start.cue_box" in one_line(r)


# ---- sweeps: Slurm's #SBATCH parser, long grids ----

def slurm_words(line):
    """An #SBATCH line's words as Slurm's parser splits them: blanks
    separate, quotes group, a backslash escapes the next character (also
    inside quotes)."""
    words, cur, quote, esc, started = [], [], None, False, False
    for ch in line:
        if esc:
            cur.append(ch)
            esc = False
        elif ch == "\\":
            esc = started = True
        elif quote:
            if ch == quote:
                quote = None
            else:
                cur.append(ch)
        elif ch in "'\"":
            quote, started = ch, True
        elif ch in " \t":
            if started or cur:
                words.append("".join(cur))
            cur, started = [], False
        else:
            cur.append(ch)
    if started or cur:
        words.append("".join(cur))
    return words


@pytest.mark.parametrize("name", ["back\\slash", "it's", "a b\\\\c", "p%j\\"])
def test_slurm_output_path_survives_its_parser(name, tmp_path):
    r = run(["sweep", Q, "--grid", "bench.samples=20,30", "-o", name] + QUICK, tmp_path)
    assert r.returncode == 0, r.stderr
    line = next(ln for ln in (tmp_path / name / "slurm.sbatch").read_text().splitlines()
                if ln.startswith("#SBATCH --output="))
    words = slurm_words(line[len("#SBATCH "):])
    assert words == [f"--output={tmp_path}/{name.replace('%', '%%')}/logs/%A_%a.out"], line


def test_long_grid_bad_last_value_refused_before_any_point(tmp_path):
    values = ",".join(str(v) for v in range(2, 20002))
    before = snapshot(tmp_path)
    r = run(["sweep", Q, "-q", "-o", "sw", "--grid", f"bench.samples={values},20000000000"], tmp_path)
    assert r.returncode == 1 and "20000000000 out of range" in one_line(r)
    assert changed(before, snapshot(tmp_path)) == set()
    r = run(["sweep", Q, "-q", "-o", "sw", "--grid", f"bench.samples={values}, 1.9999e4"], tmp_path)
    assert r.returncode == 1
    assert "value ' 1.9999e4' listed twice (as '19999')" in one_line(r)
    assert changed(before, snapshot(tmp_path)) == set()


# ---- scripts: one line, no traceback, on bad data ----

SCRIPTS = ROOT / "scripts"


def test_every_script_reports_bad_data_in_one_line():
    """Each runnable script installs the one-line handler (scripts/bad_data.py)."""
    import glob
    missing = [p for p in glob.glob(str(SCRIPTS / "*.py"))
               if "__main__" in open(p).read() and "import bad_data" not in open(p).read()]
    assert missing == []


@pytest.mark.parametrize("script,folder", [("report.py", "."), ("plot_exp1.py", "exp1")])
def test_script_on_a_non_number_prints_one_line(script, folder, quick_reproduction, tmp_path):
    import os
    import shutil
    import subprocess
    out = tmp_path / "out"
    shutil.copytree(quick_reproduction, out)
    d = out / folder if folder != "." else out / "exp1"
    csv = sorted(d.glob("*.csv"))[0]
    lines = csv.read_text().split("\n")
    cells = lines[1].split(",")
    cells[-1] = "abc"
    lines[1] = ",".join(cells)
    csv.write_text("\n".join(lines))
    py = os.environ.get("PYTHON") or "/usr/bin/python3"
    target = out if folder == "." else out / folder
    r = subprocess.run([py, str(SCRIPTS / script), str(target)], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode != 0
    assert "Traceback" not in r.stderr, r.stderr
    assert r.stderr.count("\n") == 1 and r.stderr.startswith(script), r.stderr
    assert f"{csv.name}:2: bad input: " in r.stderr, r.stderr


@pytest.mark.parametrize("read", [
    "rows = list(csv.DictReader(open(path, newline='')))\ntotal = sum(float(r['b']) for r in rows)",
    "r = csv.reader(open(path, newline=''))\nnext(r)\nm = [[float(v) for v in row] for row in r]",
    "for row in csv.DictReader(open(path, newline='')):\n    x = int(row['b'])"])
def test_bad_data_names_the_file_and_line(read, tmp_path):
    """The row a script was working on when a value failed names its file
    and line, however the rows were read and kept."""
    import subprocess
    import os
    (tmp_path / "t.csv").write_text("a,b\n1,2\n3,4\n5,x\n6,7\n")
    (tmp_path / "s.py").write_text(f"import sys\nsys.path.insert(0, {str(SCRIPTS)!r})\n"
                                   f"import bad_data  # noqa\nimport csv\npath = 't.csv'\n{read}\n")
    py = os.environ.get("PYTHON") or "/usr/bin/python3"
    r = subprocess.run([py, "s.py"], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert r.returncode == 2
    assert r.stderr.startswith("s.py: t.csv:4: bad input: ") and r.stderr.count("\n") == 1, r.stderr
    assert "'x'" in r.stderr, r.stderr


# ---- a replaced output keeps its extended attributes ----

def test_shoot_o_keeps_extended_attributes(tmp_path):
    import os
    from test_safety import SHOTS
    (tmp_path / "s.csv").write_bytes(SHOTS)
    old = tmp_path / "old.csv"
    old.write_text("old\n")
    try:
        os.setxattr(old, "user.note", b"checked by hand")
    except OSError:
        pytest.skip("no user extended attributes on this file system")
    r = run(["shoot", "-i", "s.csv", "-o", "old.csv"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert old.read_bytes().startswith(b"x0,y0,x1,y1,pocket0")
    assert os.getxattr(old, "user.note") == b"checked by hand"
    assert [p.name for p in tmp_path.iterdir()] != [] and not list(tmp_path.glob(".poolreps-tmp*"))


def test_run_folder_files_keep_extended_attributes(tmp_path):
    """A run into its earlier folder replaces its files: each keeps its
    extended attributes, as a replaced single output does."""
    import os
    r = run([Q, "-o", "out"] + QUICK, tmp_path)
    assert r.returncode == 0, r.stderr
    curve = tmp_path / "out" / "bench_curve.csv"
    try:
        os.setxattr(curve, "user.note", b"checked by hand")
    except OSError:
        pytest.skip("no user extended attributes on this file system")
    r = run([Q, "-o", "out", "--seed", "9"] + QUICK, tmp_path)
    assert r.returncode == 0, r.stderr
    assert "seed: 9" in (tmp_path / "out" / "provenance.txt").read_text()
    assert os.getxattr(curve, "user.note") == b"checked by hand"
    assert not [p for p in (tmp_path / "out").iterdir() if p.name.startswith(".")]
