"""`poolreps learner new|ask|tell|mean STATE`: the ask/tell learner across
processes. The loop learns; a failed command changes no file and leaves no
temporary file; bad input gets one line naming file, line and column; a
truncated, foreign or other-version state is refused."""
import csv
import os
import subprocess

import numpy as np
import pytest
from conftest import run_poolreps

pytestmark = pytest.mark.usefixtures("poolreps")

SETS = ["learner.window=40", "policy.n_min=15", "value.n_min=10"]


def best(x):
    return np.stack([0.5 + x[:, 0] - x[:, 1], -0.3 + 0.8 * x[:, 1]], axis=1)


def write_contexts(path, x):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["x", "y"])
        w.writerows([[repr(v) for v in row] for row in x])


def read(path):
    with open(path, newline="") as f:
        r = csv.reader(f)
        head = next(r)
        return head, np.array([[float(v) for v in row] for row in r])


def new(tmp_path, *extra):
    st = tmp_path / "st"
    r = run_poolreps(["learner", "new", st, "--context", "x,y", "--action", "a,b",
                      "--seed", "3"] + [a for s in SETS for a in ("--set", s)] + list(extra))
    assert r.returncode == 0, r.stderr
    return st


def one_round(tmp_path, st, rng, n=15):
    """ask at n contexts, return the episodes file told back."""
    write_contexts(tmp_path / "c.csv", rng.uniform(-1, 1, (n, 2)))
    r = run_poolreps(["learner", "ask", st, "-i", tmp_path / "c.csv", "-o", tmp_path / "a.csv"])
    assert r.returncode == 0, r.stderr
    head, m = read(tmp_path / "a.csv")
    assert head == ["x", "y", "a", "b"]
    ret = -((m[:, 2:] - best(m[:, :2])) ** 2).sum(axis=1)
    with open(tmp_path / "a.csv") as f, open(tmp_path / "e.csv", "w") as g:
        rows = f.read().splitlines()
        g.write(rows[0] + ",ret\n")
        for line, v in zip(rows[1:], ret):
            g.write(f"{line},{v!r}\n")
    return tmp_path / "e.csv"


def mean_distance(tmp_path, st, x):
    write_contexts(tmp_path / "m.csv", x)
    r = run_poolreps(["learner", "mean", st, "-i", tmp_path / "m.csv"])
    assert r.returncode == 0, r.stderr
    rows = r.stdout.decode().splitlines()
    assert rows[0] == "x,y,a,b"
    m = np.array([[float(v) for v in line.split(",")] for line in rows[1:]])
    assert np.array_equal(m[:, :2], x)
    return ((m[:, 2:] - best(x)) ** 2).sum(axis=1).mean()


def test_the_loop_learns(tmp_path):
    st = new(tmp_path, "--set", "learner.policy=linear", "--set", "learner.value=linear")
    rng = np.random.default_rng(1)
    x = rng.uniform(-1, 1, (50, 2))
    d0 = mean_distance(tmp_path, st, x)
    for _ in range(25):
        e = one_round(tmp_path, st, rng)
        r = run_poolreps(["learner", "tell", st, "--return", "ret", "-i", e])
        assert r.returncode == 0, r.stderr
    d1 = mean_distance(tmp_path, st, x)
    assert d1 * 5 < d0, (d0, d1)


def snapshot(folder):
    return {p.name: p.read_bytes() for p in folder.iterdir()}


@pytest.mark.parametrize("case", ["missing_return", "bad_number", "missing_action", "no_rows",
                                  "features_not_given", "return_is_an_action",
                                  "return_is_a_feature", "targets_not_read"])
def test_a_failed_tell_changes_nothing(tmp_path, case):
    st = new(tmp_path, *(["--set", "learner.value=given"] if case == "return_is_a_feature" else []))
    rng = np.random.default_rng(2)
    e = one_round(tmp_path, st, rng)
    text = e.read_text().splitlines()
    args = ["--return", "ret"]
    if case == "missing_return":
        args = ["--return", "nope"]
        want = "e.csv:1: missing column 'nope'"
    elif case == "bad_number":
        text[3] = text[3].rsplit(",", 1)[0] + ",zz"
        want = "e.csv:4: column 'ret': not a finite number: 'zz'"
    elif case == "missing_action":
        text = [",".join(c for i, c in enumerate(line.split(",")) if i != 3) for line in text]
        want = "e.csv:1: missing column 'b'"
    elif case == "return_is_an_action":  # a slip: reps refuses a feature that is the return
        args = ["--return", "b"]
        want = "e.csv: column 'b' is both an action column of the learner and --return"
    elif case == "return_is_a_feature":  # REPS would be handed its answer; reps refuses it too
        args += ["--features", "x,ret"]
        want = "e.csv: column 'ret' is both a feature and the return"
    elif case == "targets_not_read":  # policy.target = action: kept, then ignored
        args += ["--target", "x,y"]
        want = "targets: given, but only the tree policy with policy.target = reward_state reads them"
    elif case == "no_rows":
        text = text[:1]
        want = "e.csv"
    else:
        args += ["--features", "x"]
        want = "features"
    e.write_text("\n".join(text) + "\n")
    before = snapshot(tmp_path)
    r = run_poolreps(["learner", "tell", st, "-i", e] + args)
    assert r.returncode in (1, 2)
    lines = r.stderr.decode().splitlines()
    assert len(lines) == 1 and lines[0].startswith("poolreps: ") and want in lines[0], lines
    assert snapshot(tmp_path) == before


def test_states_that_are_not_ours_are_refused(tmp_path):
    st = new(tmp_path)
    good = st.read_bytes()
    write_contexts(tmp_path / "c.csv", np.zeros((3, 2)))
    for name, data, code, want in [
            ("trunc", good[:len(good) // 2], 2, "truncated"),
            ("text", b"x,y\n1,2\n", 2, "not a poolreps learner state"),
            ("version", good[:17] + b"\x09" + good[18:], 1, "version 9"),
            ("tail", good + b"\0", 2, "bytes after the end")]:
        p = tmp_path / name
        p.write_bytes(data)
        before = snapshot(tmp_path)
        r = run_poolreps(["learner", "ask", p, "-i", tmp_path / "c.csv", "-o", tmp_path / "o.csv"])
        assert r.returncode == code, (name, r.stderr)
        assert want in r.stderr.decode(), (name, r.stderr)
        assert snapshot(tmp_path) == before, name


def forged(good, case):
    """good (a new learner's state; context x,y, action a,b for "names")
    with counts or names a hostile file might claim."""
    import struct
    at = 189  # magic, version, the options: then dx, da, dy, dg, niter, pbase, npol
    name = good.index(b"mt19937", at)
    pol0 = name + 7 + 4 + struct.unpack_from("<i", good, name + 7)[0]
    s = bytearray(good)
    if case == "episodes":  # the window: 10^7 episodes in a file of a few kB
        struct.pack_into("<i", s, pol0 + 12, 10_000_000)
    elif case == "policies":  # 2^31 - 1 policies
        struct.pack_into("<ii", s, at + 16, 2**31 - 2, 0)
        struct.pack_into("<i", s, at + 24, 2**31 - 1)
    else:  # the second context column named as the first
        tail = b"\x01\x00\x00\x00y\x01\x00\x00\x00a"
        assert s.endswith(tail + b"\x01\x00\x00\x00b")
        s[-len(tail) - 5:-5] = tail.replace(b"y", b"x")
    return bytes(s)


@pytest.mark.parametrize("case", ["episodes", "policies", "names"])
def test_a_forged_state_is_refused_as_a_bad_file(tmp_path, case):
    """Counts are believed only as far as the file has bytes for them (no
    allocation beyond the file's size, no out-of-memory exit), and loaded
    names are checked as learner new checks them."""
    st = new(tmp_path)
    if case == "episodes":  # 10^7 x 3000 contexts: more memory than any machine's
        cols = ",".join(f"c{j}" for j in range(3000))
        assert run_poolreps(["learner", "new", st, "--context", cols, "--action", "a"]).returncode == 0
    st.write_bytes(forged(st.read_bytes(), case))
    write_contexts(tmp_path / "c.csv", np.zeros((3, 2)))
    before = snapshot(tmp_path)
    r = run_poolreps(["learner", "ask", st, "-i", tmp_path / "c.csv", "-o", tmp_path / "o.csv"])
    lines = r.stderr.decode().splitlines()
    assert r.returncode == 2 and len(lines) == 1, lines
    assert "not a valid learner state" in lines[0], lines
    assert snapshot(tmp_path) == before


def test_the_exit_code_does_not_depend_on_the_state_name(tmp_path):
    """A truncated state is a bad file (2) even when its path says "version"."""
    good = new(tmp_path).read_bytes()
    write_contexts(tmp_path / "c.csv", np.zeros((3, 2)))
    for name in ("st", "version", "learner format version 2"):
        (tmp_path / name).write_bytes(good[:100])
        r = run_poolreps(["learner", "mean", tmp_path / name, "-i", tmp_path / "c.csv"])
        assert r.returncode == 2 and b"truncated" in r.stderr, (name, r.stderr)


def test_a_state_that_is_no_regular_file_or_too_big_is_refused_unread(tmp_path):
    """A directory, a FIFO (no writer: not waited on) and a sparse 1 TB file
    of zeros: one line, exit 2, at once and without reading the file."""
    write_contexts(tmp_path / "c.csv", np.zeros((3, 2)))
    (tmp_path / "dir").mkdir()
    os.mkfifo(tmp_path / "fifo")
    with open(tmp_path / "huge", "wb") as f:
        f.truncate(2**40)
    before = snapshot(tmp_path / "dir")
    for name, want in [("dir", "not a regular file"), ("fifo", "not a regular file"),
                       ("huge", "not a poolreps learner state")]:
        r = run_poolreps(["learner", "mean", tmp_path / name, "-i", tmp_path / "c.csv"],
                         timeout=20)
        lines = r.stderr.decode().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and want in lines[0], (name, lines)
    assert snapshot(tmp_path / "dir") == before


def test_usage_errors(tmp_path):
    st = new(tmp_path)
    for args, want in [(["learner", "fly", st], "usage"),
                       (["learner", "ask", st, "--set", "learner.window=5"], "belong to learner new"),
                       (["learner", "new", tmp_path / "s2", "--context", "x,x", "--action", "a"],
                        "column 'x' twice"),
                       (["learner", "new", tmp_path / "s2", "--context", "x"], "--action"),
                       (["learner", "new", tmp_path / "s2", "--context", "x", "--action", "a",
                         "--set", "learner.window=1"], "learner.window")]:
        r = run_poolreps(args)
        assert r.returncode == 1, (args, r.stderr)
        assert want in r.stderr.decode(), (args, r.stderr)
    assert not (tmp_path / "s2").exists()
    assert sorted(os.listdir(tmp_path)) == ["st"]


def test_an_uncertified_solve_exits_3_and_changes_nothing(tmp_path):
    """reps.max_iter = 1 (from a parameter file: -c sets any key) cannot
    certify the first solve: exit 3, one line, STATE as before."""
    ini = tmp_path / "r.ini"
    ini.write_text("[reps]\nmax_iter = 1\n")
    st = new(tmp_path, "-c", ini)
    e = one_round(tmp_path, st, np.random.default_rng(4))
    before = snapshot(tmp_path)
    r = run_poolreps(["learner", "tell", st, "--return", "ret", "-i", e])
    assert r.returncode == 3, r.stderr
    lines = r.stderr.decode().splitlines()
    assert len(lines) == 1 and "REPS answer not certified" in lines[0], lines
    assert snapshot(tmp_path) == before


def test_two_tells_at_once_both_count(tmp_path):
    """Two tells of one state started together (two jobs of an array): the
    second waits for the first's rename and builds on its state, so the
    result is the two tells one after the other, in either order, no
    episodes dropped. The test holds STATE's lock while both start, so
    that both are under way at once."""
    import fcntl
    import time
    from conftest import poolreps_path
    st = tmp_path / "st"  # default forests on 500 episodes: tells long enough to overlap
    assert run_poolreps(["learner", "new", st, "--context", "x,y", "--action", "a,b", "--set",
                         "learner.window=4000"]).returncode == 0
    rng = np.random.default_rng(5)
    eps = [one_round(tmp_path, st, rng, n=500).read_bytes() for _ in range(2)]
    for k, e in enumerate(eps):
        (tmp_path / f"e{k}.csv").write_bytes(e)
    start = st.read_bytes()
    with open(st, "rb") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        procs = [subprocess.Popen([poolreps_path(), "learner", "tell", str(st), "--return", "ret",
                                   "-i", str(tmp_path / f"e{k}.csv")], stderr=subprocess.PIPE,
                                  env=dict(os.environ, LC_ALL="C")) for k in range(2)]
        time.sleep(0.5)  # both have read their episodes (and, unlocked, STATE)
    for p in procs:
        _, err = p.communicate(timeout=120)
        assert p.returncode == 0, err
    both = st.read_bytes()
    orders = []
    for order in ((0, 1), (1, 0)):
        st.write_bytes(start)
        for k in order:
            r = run_poolreps(["learner", "tell", st, "--return", "ret", "-i", tmp_path / f"e{k}.csv"])
            assert r.returncode == 0, r.stderr
        orders.append(st.read_bytes())
    assert both in orders


def test_a_row_the_policy_fails_at_is_named(tmp_path):
    """A context far beyond the fitted ones (1e200) makes the tree policy's
    covariance overflow: ask, mean and tell name the file, line and
    context column (exit 3), as `poolreps policy` does, and change nothing."""
    st = new(tmp_path)
    e = one_round(tmp_path, st, np.random.default_rng(6))
    assert run_poolreps(["learner", "tell", st, "--return", "ret", "-i", e]).returncode == 0
    (tmp_path / "far.csv").write_text("x,y\n0.1,0.2\n0.5,-1e200\n")
    rows = e.read_text().splitlines()
    rows[2] = "0.5,-1e200," + rows[2].split(",", 2)[2]
    e.write_text("\n".join(rows) + "\n")
    want = (": context y = -9.9999999999999997e+199: contexts: row 1: policy: covariance "
            "eigen-decomposition failed")
    for args, line in [(["ask", st, "-i", tmp_path / "far.csv", "-o", tmp_path / "o.csv"], "far.csv:3"),
                       (["mean", st, "-i", tmp_path / "far.csv"], "far.csv:3"),
                       (["tell", st, "--return", "ret", "-i", e], "e.csv:3")]:
        before = snapshot(tmp_path)
        r = run_poolreps(["learner"] + args)
        lines = r.stderr.decode().splitlines()
        assert r.returncode == 3 and len(lines) == 1, (args[0], lines)
        assert lines[0].endswith(line + want), lines
        assert snapshot(tmp_path) == before


def test_an_init_std_whose_square_underflows_is_refused_by_name(tmp_path):
    """learner.init_std = 1e-200 squares to 0: refused as out of range
    (exit 1, naming the key), not 'covariance is not positive definite'."""
    for v in ("1e-200", "5e-324"):
        r = run_poolreps(["learner", "new", tmp_path / "st", "--context", "x", "--action", "a",
                          "--set", f"learner.init_std={v}"])
        lines = r.stderr.decode().splitlines()
        assert r.returncode == 1 and len(lines) == 1, lines
        assert f"learner.init_std: {v} out of range" in lines[0], lines
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("name", ["x ", "x\ty", "x\x01", "x\x7f"])
def test_a_name_no_csv_header_can_hold_is_refused(tmp_path, name):
    """The CSV reader trims a header name's trailing blanks and refuses
    control characters, so no ask or tell could ever name such a column:
    learner new refuses it (exit 1, one line) and writes nothing."""
    r = run_poolreps(["learner", "new", tmp_path / "st", "--context", f"{name},z", "--action", "a"])
    lines = r.stderr.decode().splitlines()
    assert r.returncode == 1 and len(lines) == 1, lines
    assert "context name 0 must be 1 .. 255 bytes without a control character" in lines[0], lines
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("out", ["st", "./st", "link"])
def test_mean_does_not_write_its_means_over_the_state(tmp_path, out):
    """learner mean -o STATE (by another name or through a link) would
    replace the learner by a CSV of its means: refused, exit 1, as ask
    refuses its -o naming STATE."""
    st = new(tmp_path)
    (tmp_path / "link").symlink_to("st")
    write_contexts(tmp_path / "c.csv", np.zeros((2, 2)))
    before = snapshot(tmp_path)
    r = run_poolreps(["learner", "mean", "st", "-i", "c.csv", "-o", out], cwd=tmp_path)
    lines = r.stderr.decode().splitlines()
    assert r.returncode == 1 and len(lines) == 1, lines
    assert lines[0] == f"poolreps: learner mean: -o {out} is STATE: the means would replace the learner"
    assert snapshot(tmp_path) == before and st.read_bytes()[:17] == b"poolreps-learner\n"


def test_a_context_whose_square_overflows_is_named(tmp_path):
    """learner.value = quadratic: a context of 1e200 squares to infinity.
    The tell names the file, line and context (exit 1), not a REPS feature
    of a sample the caller never numbered."""
    st = new(tmp_path, "--set", "learner.value=quadratic")
    e = one_round(tmp_path, st, np.random.default_rng(7))
    rows = e.read_text().splitlines()
    rows[3] = "0.5,-1e200," + rows[3].split(",", 2)[2]
    e.write_text("\n".join(rows) + "\n")
    before = snapshot(tmp_path)
    r = run_poolreps(["learner", "tell", st, "--return", "ret", "-i", e])
    lines = r.stderr.decode().splitlines()
    assert r.returncode == 1 and len(lines) == 1, lines
    assert lines[0].endswith("e.csv:4: context y = -9.9999999999999997e+199: contexts: row 2: "
                             "learner.value = quadratic: feature 5 overflows"), lines
    assert snapshot(tmp_path) == before


def test_ask_piped_into_tell_runs_one_after_the_other(tmp_path):
    """`learner ask S | play | learner tell S`: the tell reads its episodes
    whole before it takes STATE, so it waits for the ask to finish and
    reads the state the ask left: the same state as the steps through
    files. (With STATE locked first the two deadlocked; read first without
    a lock, the tell read the state before the ask's, dropped the ask's
    draws and drew them again.) 20,000 contexts keep the ask busy."""
    from conftest import poolreps_path
    keys = ["--set", "learner.policy=linear", "--set", "learner.value=linear"]
    piped, files = new(tmp_path, *keys), tmp_path / "files"
    files.write_bytes(piped.read_bytes())
    write_contexts(tmp_path / "c.csv", np.random.default_rng(3).uniform(-1, 1, (20000, 2)))
    play = "awk -F, 'NR == 1 {print $0 \",ret\"} NR > 1 {print $0 \",\" (-$3 * $3)}'"
    bin_ = poolreps_path()
    for _ in range(2):
        r = subprocess.run(f"'{bin_}' learner ask st -i c.csv | {play} | '{bin_}' learner tell st "
                           "--return ret", shell=True, cwd=tmp_path, capture_output=True,
                           timeout=120, env=dict(os.environ, LC_ALL="C"))
        assert r.returncode == 0 and r.stderr == b"", r.stderr
        assert run_poolreps(["learner", "ask", files, "-i", tmp_path / "c.csv", "-o",
                             tmp_path / "a.csv"]).returncode == 0
        subprocess.run(f"{play} a.csv > e.csv", shell=True, cwd=tmp_path, timeout=60, check=True)
        assert run_poolreps(["learner", "tell", files, "--return", "ret", "-i",
                             tmp_path / "e.csv"]).returncode == 0
    assert piped.read_bytes() == files.read_bytes()
