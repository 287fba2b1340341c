"""The command line as documented: --help, --version, exit codes, the man page,
`make install`, and progress output on stderr.

Run by `make check` with POOLREPS=<abs path to poolreps>.
"""
import os
import re
import resource
import shutil
import signal
import subprocess
import time

import pytest

from conftest import ROOT, config_keys, keys_missing, poolreps_path, run_cmd, timeout_scale

COMMON_LONG = {"set", "seed", "help", "help-keys", "version", "progress"}
CORE_COMMANDS = {"run", "shoot", "forest", "reps", "policy"}
# a run of a few milliseconds with 30 progress units (3 repetitions x 10 iterations)
QUICK_RUN = [ROOT / "data" / "quadratic.ini", "--set", "experiment.repetitions=3",
             "--set", "bench.iterations=10"]
PROGRESS = re.compile(r"poolreps: (.+): (\d+)/(\d+) \((\d+)%\), \d+\.\d s elapsed, ETA \d+ s")
DONE = re.compile(r"poolreps: done: wall \d+\.\d\d s, cpu \d+\.\d\d s, peak memory \d+\.\d MiB")


def binary():
    b = poolreps_path()
    if b is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    return b


@pytest.fixture(scope="module")
def help_text():
    return run_cmd([binary(), "--help"], capture_output=True, text=True,
                          env=dict(os.environ, LC_ALL="C"), timeout=30).stdout


@pytest.fixture(scope="module")
def keys_text():
    p = run_cmd([binary(), "--help-keys"], capture_output=True, text=True,
                       env=dict(os.environ, LC_ALL="C"), timeout=30)
    assert p.returncode == 0, p.stderr
    return p.stdout


def commands(help_text):
    """Command names, from the usage lines of the Commands section."""
    names = re.findall(r"^  poolreps (\[run\]|[a-z]+) ", help_text, re.M)
    return [n.strip("[]") for n in names]


def usage_part(text):
    """The command-specific part of a help text (before the common options)."""
    return text.split("\nCommon options")[0]


# ---- (a) the man page is generated from --help ----

def test_man_page_matches_help():
    gen = ["sh", str(ROOT / "scripts" / "gen-man.sh"), binary(), "-"]
    first = run_cmd(gen, capture_output=True, cwd=ROOT, timeout=60)
    assert first.returncode == 0, first.stderr
    again = run_cmd(gen, capture_output=True, cwd=ROOT, timeout=60,
                           env=dict(os.environ, LC_ALL="C.UTF-8", LANG="de_DE.UTF-8"))
    assert again.stdout == first.stdout, "scripts/gen-man.sh is not deterministic"
    page = (ROOT / "docs" / "poolreps.1").read_bytes()
    assert page == first.stdout, (
        "docs/poolreps.1 differs from `poolreps --help`: run scripts/gen-man.sh "
        "(from the top folder, after make) and commit docs/poolreps.1")


def test_man_page_renders_cleanly():
    if shutil.which("groff") is None:
        pytest.skip("groff not installed")
    r = run_cmd(["groff", "-man", "-ww", "-z", str(ROOT / "docs" / "poolreps.1")],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stderr == "", r.stderr


def test_gen_man_keeps_old_page_when_binary_fails(tmp_path):
    out = tmp_path / "poolreps.1"
    out.write_text("old\n")
    r = run_cmd(["sh", str(ROOT / "scripts" / "gen-man.sh"), str(tmp_path / "nobin"),
                        str(out)], capture_output=True, cwd=ROOT, timeout=60)
    assert r.returncode != 0
    assert out.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["poolreps.1"]


# ---- (b) --version ----

@pytest.mark.parametrize("args", [["--version"], ["shoot", "--version"]])
def test_version(poolreps, args):
    r = poolreps(args)
    assert r.returncode == 0
    assert re.fullmatch(rb"poolreps [0-9A-Za-z][0-9A-Za-z.+_-]*\n", r.stdout), r.stdout
    assert r.stderr == b""


# ---- (c) every parameter key is documented with its default ----

def test_every_key_in_help_with_its_default(poolreps, keys_text):
    r = poolreps(["config"])
    assert r.returncode == 0, r.stderr
    keys, commented, other = config_keys(r.stdout.decode())
    # the friction laws not chosen: their keys are written as comments
    assert set(commented) <= {"table.deceleration", "table.mu_slide", "table.mu_roll"}, commented
    assert not other, other
    assert len(keys) > 50
    missing, listed = keys_missing(keys, keys_text)
    assert not missing, f"not in --help-keys with their defaults: {missing}"
    assert listed == set(keys)


@pytest.mark.parametrize("key,unit", [("table.length", "m"), ("table.friction", "1/s"),
                                      ("sim.dt", "s"), ("sim.max_speed", "m/s"),
                                      ("reps.epsilon", "nats"), ("exp3.init_std", "m/s")])
def test_units_in_help(keys_text, key, unit):
    assert re.search(rf"^  {re.escape(key)} += \S+ {re.escape(unit)}  ", keys_text, re.M), key


# ---- (d) commands, options and exit codes ----

def test_help_lists_the_commands(help_text):
    assert CORE_COMMANDS <= set(commands(help_text))
    assert {"config", "merge"} <= set(commands(help_text))


def test_every_command_help(poolreps, help_text):
    """poolreps CMD --help and poolreps help CMD: that command's usage, its
    options, the keys its --set reads (or where to find them all); short."""
    assert "--help-keys" in help_text and "Parameter keys (" not in help_text
    for cmd in commands(help_text):
        r = poolreps([cmd, "--help"])
        assert r.returncode == 0, (cmd, r.stderr)
        text = r.stdout.decode()
        assert poolreps(["help", cmd]).stdout.decode() == text, cmd
        assert text.startswith(f"Usage: poolreps {'[run]' if cmd == 'run' else cmd} "), text[:80]
        for part in ("Common options", "Accepts:", "--version", "Exit codes:"):
            assert part in text, (cmd, part)
        # shoot's is the longest: every table.* key, with all three friction laws'
        assert len(text.splitlines()) < 49, (cmd, "help too long")
        keys = re.findall(r"^  ([a-z0-9_]+\.[a-z0-9_]+) += (\S+)", text, re.M)
        if cmd in ("run", "config", "sweep"):
            assert "every parameter key (poolreps --help-keys)" in text, cmd
        elif cmd in ("merge", "collect"):
            assert not keys, cmd
        else:
            assert keys, cmd
            # the listed keys are those its --set accepts (the command then
            # stops for want of its input, not for the key), and no other
            for key, default in keys + [("exp3.window", "200")]:
                r = poolreps([cmd, "--set", f"{key}={default}"], input=b"")
                refused = b"does not apply" in r.stderr
                assert refused == (key == "exp3.window"), (cmd, key, r.stderr)
    assert poolreps(["help"]).stdout.decode() == help_text
    r = poolreps(["help", "nosuch"])
    assert r.returncode == 1 and b"unknown command 'nosuch'" in r.stderr


FLAGS = {"keep", "allow-versions"}  # command options that take no value


def test_help_lists_exactly_the_options_a_command_takes(help_text, tmp_path):
    """An option is refused with "does not apply" exactly when the command's
    --help does not list it. About a hundred runs: without POOLREPS_WRAPPER,
    which would make them minutes under valgrind."""
    binary_only = binary()

    def call(args, **kw):
        return run_cmd([binary_only] + [str(a) for a in args], capture_output=True,
                              env=dict(os.environ, LC_ALL="C"), timeout=60, **kw)

    specific = set(re.findall(r"--([a-z]+(?:-[a-z]+)*)", help_text)) - COMMON_LONG
    assert {"trace", "train", "test", "target", "weight", "leaves", "return", "features",
            "base", "epsilon", "summary", "state", "action", "sample"} <= specific
    for cmd in commands(help_text):
        usage = usage_part(call([cmd, "--help"]).stdout.decode())
        for opt in sorted(specific):
            args = [cmd, f"--{opt}"] + ([] if opt in FLAGS else ["1"])
            if cmd == "run":
                args += [ROOT / "data" / "figures.ini", "-q", "-o", tmp_path / "run"]
            r = call(args, input=b"", cwd=tmp_path)
            refused = b"does not apply" in r.stderr
            listed = re.search(rf"--{opt}(?![-a-z])", usage) is not None
            assert refused != listed, (cmd, opt, r.returncode, r.stderr)
            if refused:
                assert r.returncode == 1


def test_exit_codes_documented(help_text):
    text = " ".join(help_text.split())
    for code in ("0 ok", "1 bad usage or parameter", "2 I/O or malformed CSV",
                 "3 numerical failure", "4 out of memory", "128 + N stopped by signal N",
                 "130 SIGINT", "143 SIGTERM", "141 SIGPIPE", "153 SIGXFSZ"):
        assert code in text


SHOT = b"x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0,2,0.3\n"


@pytest.mark.parametrize("args,stdin,code,msg", [
    (["--help"], None, 0, b""),
    ([], None, 1, b"Usage:"),
    (["--bogus"], None, 1, b"unknown option --bogus"),
    (["config", "--set", "table.nosuch=1"], None, 1, b"table.nosuch"),
    (["config", "--set", "reps.epsilon=-1"], None, 1, b"reps.epsilon"),
    (["shoot", "-i", "missing.csv"], None, 2, b"missing.csv"),
    (["shoot", "-q"], b"x0,y0\n1,2,3\n", 2, b""),
    (["shoot", "-q", "--set", "sim.max_events=2"], SHOT, 3, b"sim.max_events"),
    (["shoot", "-q", "--set", "sim.max_events=200"], SHOT, 0, b""),
])
def test_exit_codes(poolreps, tmp_path, args, stdin, code, msg):
    r = poolreps(args, input=stdin, cwd=tmp_path)
    assert r.returncode == code, r.stderr
    assert msg in r.stderr


def _limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (200 << 20, 200 << 20))


def test_exit_code_out_of_memory(tmp_path):
    """Exit 4: a run far larger than the address space allowed."""
    b = binary()
    with open(b, "rb") as f:
        if f.read(4) != b"\x7fELF":
            pytest.skip("POOLREPS is a wrapper (valgrind): the limit would apply to the wrapper")
    probe = run_cmd([b, "--help"], capture_output=True, preexec_fn=_limit_memory,
                           timeout=30)
    if probe.returncode != 0:
        pytest.skip("this build cannot start with 200 MiB of address space (sanitizers?)")
    r = run_cmd([b, ROOT / "data" / "exp1.ini", "-q", "-o", tmp_path / "out",
                        "--set", "exp1.train=10000000"], capture_output=True,
                       preexec_fn=_limit_memory, timeout=60)
    assert r.returncode == 4, r.stderr
    assert b"out of memory" in r.stderr
    assert not (tmp_path / "out").exists()


def test_exit_code_interrupted_component_command(tmp_path):
    """Exit 130: SIGINT while shoot waits for its input."""
    p = subprocess.Popen([binary(), "shoot", "-o", tmp_path / "out.csv"],
                         stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        # time to install the handlers: a process under valgrind (scale 30)
        # starts slower than 0.5 s, more so on busy workers
        time.sleep(0.5 * min(timeout_scale(), 10))
        p.send_signal(signal.SIGINT)
        _, err = p.communicate(timeout=30 * timeout_scale())
    finally:
        p.kill()
        p.stdin.close()
    assert p.returncode == 130, err
    assert b"interrupted" in err
    assert list(tmp_path.iterdir()) == []


# ---- (e) make install ----

def test_make_install(tmp_path):
    make = shutil.which("make")
    if make is None:
        pytest.skip("make not installed")
    # a fresh make: not the jobserver of a `make check` that may run this test
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL")}
    dest = tmp_path / "dest"
    r = run_cmd([make, "-s", "install", "PREFIX=/usr", f"DESTDIR={dest}"], cwd=ROOT,
                       capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    usr = dest / "usr"
    exe = usr / "bin" / "poolreps"
    assert os.access(exe, os.X_OK)
    v = run_cmd([exe, "--version"], capture_output=True, text=True, timeout=30)
    assert v.returncode == 0 and v.stdout.startswith("poolreps ")
    assert (usr / "share" / "man" / "man1" / "poolreps.1").read_bytes() == \
        (ROOT / "docs" / "poolreps.1").read_bytes()
    share = usr / "share" / "poolreps"
    for ini in (ROOT / "data").glob("*.ini"):
        assert (share / "data" / ini.name).read_bytes() == ini.read_bytes(), ini.name
    for script in ("jobs.sh", "gen-man.sh", "reproduce.sh", "plot_exp3.py"):
        assert (share / "scripts" / script).is_file(), script


# ---- progress on stderr ----

def test_no_progress_lines_unless_asked(poolreps, tmp_path):
    """Without a terminal and without --progress a run's stderr is its
    summary line; a failed run's is its error line alone."""
    r = poolreps(QUICK_RUN + ["-o", tmp_path / "out"])
    assert r.returncode == 0, r.stderr
    assert [DONE.fullmatch(x) is not None for x in r.stderr.decode().splitlines()] == [True]
    (tmp_path / "blocker").write_text("a file\n")
    r = poolreps(QUICK_RUN + ["-o", tmp_path / "blocker" / "out"])
    assert r.returncode == 2 and r.stderr.count(b"\n") == 1, r.stderr


def test_progress_plain_lines_when_not_a_terminal(poolreps, tmp_path):
    r = poolreps(QUICK_RUN + ["--progress", "-o", tmp_path / "out"])
    assert r.returncode == 0, r.stderr
    assert r.stdout == b""
    lines = r.stderr.decode().splitlines()
    assert DONE.fullmatch(lines[-1]), lines[-1]
    progress = [PROGRESS.fullmatch(x) for x in lines[:-1]]
    assert all(progress), lines
    assert "\r" not in r.stderr.decode()
    # at most one line per tenth, in order, ending at 100 %
    assert 2 <= len(progress) <= 11
    done = [int(m.group(2)) for m in progress]
    assert done == sorted(done)
    assert {m.group(3) for m in progress} == {"30"}
    assert progress[-1].group(2) == "30" and progress[-1].group(4) == "100"
    assert [int(m.group(4)) // 10 for m in progress] == sorted({int(m.group(4)) // 10
                                                                for m in progress})


def test_quiet_is_silent(poolreps, tmp_path):
    r = poolreps(QUICK_RUN + ["-q", "-o", tmp_path / "out"])
    assert r.returncode == 0
    assert (r.stdout, r.stderr) == (b"", b"")
    assert (tmp_path / "out" / "bench_curve.csv").is_file()
    # errors still get their one line
    r = poolreps(QUICK_RUN + ["-q", "-o", tmp_path / "bad", "--set", "bench.dims=0"])
    assert r.returncode == 1
    assert r.stderr.decode().count("\n") == 1 and b"bench.dims" in r.stderr


def test_no_summary_line_for_component_commands(poolreps):
    r = poolreps(["shoot", "--set", "sim.max_events=200"], input=SHOT)
    assert r.returncode == 0 and r.stderr == b""


def run_on_terminal(args, interrupt_when=None):
    """Run poolreps with stderr on a pseudo-terminal; (exit code, stderr text
    with the terminal's \r\n turned back into \n). interrupt_when: a regex;
    SIGINT goes to the command once its output matches it (however slowly
    it runs, e.g. under valgrind)."""
    pty = pytest.importorskip("pty")
    master, slave = pty.openpty()
    try:
        p = subprocess.Popen([binary()] + args, stdout=subprocess.PIPE, stderr=slave,
                             env=dict(os.environ, LC_ALL="C"))
    finally:
        os.close(slave)
    out = b""
    try:
        while True:
            try:
                chunk = os.read(master, 4096)
            except OSError:  # EIO: the child closed the terminal
                break
            if not chunk:
                break
            out += chunk
            if interrupt_when and re.search(interrupt_when, out.decode(errors="replace")):
                p.send_signal(signal.SIGINT)
                interrupt_when = None
    finally:
        os.close(master)
        p.stdout.close()
    return p.wait(timeout=60), out.decode().replace("\r\n", "\n")


def test_progress_bar_on_a_terminal(tmp_path):
    rc, text = run_on_terminal(QUICK_RUN + ["-o", tmp_path / "out"])
    assert rc == 0
    assert re.search(r"\r\[#{30}\] 100% quadratic, \d+ s, ETA 0 s *\n", text), repr(text)
    assert not PROGRESS.search(text), repr(text)
    assert DONE.fullmatch(text.rsplit("\n", 2)[-2]), repr(text)


def test_message_after_an_unfinished_bar_starts_a_line(tmp_path):
    rc, text = run_on_terminal([ROOT / "data" / "exp3.ini", "-o", tmp_path / "out",
                                "--set", "experiment.threads=1"],
                                interrupt_when=r"\r\[[# ]{30}\] +\d+% exp3 episodes, ")
    assert rc == 130, repr(text)
    assert re.search(r"\r\[[# ]{30}\] +\d+% exp3 episodes, ", text), repr(text)
    # the bar is erased (carriage return, erase line): the message is one line
    assert re.search(r"\r\x1b\[Kpoolreps: interrupted: [^\r\n]*\n$", text), repr(text)
    assert "  poolreps: interrupted" not in text


# ---- a listing cut short by its reader ----

@pytest.mark.parametrize("args", [["--help-keys"], ["--help"], ["--version"], ["help", "run"]])
def test_a_listing_into_a_closed_pipe_ends_silently_like_any_filter(args, tmp_path):
    """`poolreps --help-keys | head -5` writes no file: a reader that has gone
    ends it by SIGPIPE (the shell's 141) with nothing on stderr, never with
    the run's "partial output files removed"; the folder stays empty."""
    r, w = os.pipe()
    os.close(r)  # the reader is gone before the first write
    p = subprocess.run([binary()] + args, stdout=w, stderr=subprocess.PIPE, cwd=tmp_path,
                       timeout=30 * timeout_scale(), env=dict(os.environ, LC_ALL="C"))
    os.close(w)
    assert p.stderr == b""
    assert p.returncode in (0, -signal.SIGPIPE)
    assert list(tmp_path.iterdir()) == []
