"""Shared pytest helpers for the end-to-end tests.

`make check` sets POOLREPS to the absolute path of the binary. Every command
a test starts goes through run_cmd (subprocess.run with LC_ALL=C unless the
test's env sets a locale, and a timeout, so that a hang fails the test instead
of stalling the suite, multiplied by env POOLREPS_TIMEOUT_SCALE, which
scripts/valgrind.sh sets). The binary itself goes through run_poolreps (the
`poolreps` fixture), which adds an optional wrapper from env POOLREPS_WRAPPER
(a command line, e.g. "valgrind -q --error-exitcode=99"), or run_experiment
(no wrapper: an experiment takes minutes under valgrind).
Tests that must start a process and act on it while it runs (signals, a
terminal) use subprocess.Popen with timeout_scale().
Mark long experiment tests @pytest.mark.slow, and tests that need the bare
process (peak memory, an allocation-failure shim, another user) @pytest.mark.native:
scripts/valgrind.sh skips both.
"""
import configparser
import csv
import os
import re
import shlex
import subprocess
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: long-running; skipped by scripts/valgrind.sh")
    config.addinivalue_line("markers", "native: measures or replaces the process's allocator, "
                            "or runs it as another user; skipped by scripts/valgrind.sh")


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Under pytest-xdist (`make check` runs --dist loadgroup) the tests of a
    module that share a module- or class-scoped fixture run on one worker,
    so that the fixture (a quick reproduction, a venv, ...) is built once
    rather than once per worker that happens to draw one of them. Those
    groups and the tests marked slow are handed out first, so that the
    workers share the many short tests at the end instead of one worker
    starting a long one when the other has little left."""
    for item in items:
        info = getattr(item, "_fixtureinfo", None)
        names = info.name2fixturedefs if info else {}
        shared = sorted(SHARED & set(names))
        if shared:
            # a session fixture several modules use: one group for all of them
            item.add_marker(pytest.mark.xdist_group(shared[0]))
        elif any(d and d[-1].scope in ("module", "class") for d in names.values()):
            item.add_marker(pytest.mark.xdist_group(item.module.__name__))
    items.sort(key=lambda item: not (item.get_closest_marker("slow") or
                                     item.get_closest_marker("xdist_group")))


def poolreps_path():
    """The binary under test: env POOLREPS, else ./poolreps at the top level."""
    path = os.environ.get("POOLREPS") or str(ROOT / "poolreps")
    return path if os.access(path, os.X_OK) else None


def timeout_scale():
    """How much slower than usual the commands run (valgrind: POOLREPS_TIMEOUT_SCALE)."""
    return float(os.environ.get("POOLREPS_TIMEOUT_SCALE", "1"))


def run_cmd(args, *, timeout=120, env=None, **kw):
    """subprocess.run(args, **kw) for any command of a test: C locale unless
    env sets LC_ALL, a timeout of `timeout` seconds times timeout_scale(),
    list arguments turned into str."""
    full_env = dict(os.environ if env is None else env)
    full_env.setdefault("LC_ALL", "C")
    if isinstance(args, (list, tuple)):
        args = [a if isinstance(a, bytes) else str(a) for a in args]
    return subprocess.run(args, env=full_env, timeout=timeout * timeout_scale(), **kw)


def run_poolreps(args, *, input=None, cwd=None, timeout=120, env=None):
    """Run poolreps with args (each turned into str); returns CompletedProcess
    with bytes stdout and stderr."""
    binary = poolreps_path()
    if binary is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    full_env = dict(os.environ if env is None else env)
    full_env["LC_ALL"] = "C"
    wrapper = shlex.split(os.environ.get("POOLREPS_WRAPPER", ""))
    return run_cmd(wrapper + [binary] + list(args), input=input, stdout=subprocess.PIPE,
                   stderr=subprocess.PIPE, cwd=cwd, env=full_env, timeout=timeout)


@pytest.fixture
def poolreps():
    """Call as poolreps([args...], input=b"...", cwd=path)."""
    return run_poolreps


def run_experiment(ini, out, sets=(), check=True, extra=()):
    """Run `poolreps data/INI -q -o OUT --set S...` with text output; with
    check, assert success (showing stderr)."""
    binary = poolreps_path()
    if binary is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    cmd = [binary, str(ROOT / "data" / ini), "-q", "-o", str(out)]
    for s in sets:
        cmd += ["--set", s]
    cmd += list(extra)
    p = run_cmd(cmd, capture_output=True, text=True)
    if check:
        assert p.returncode == 0, p.stderr
    return p


# session fixtures that tests of several modules share (their group, above)
SHARED = {"quick_reproduction"}


@pytest.fixture(scope="session")
def quick_reproduction(tmp_path_factory):
    """A QUICK reproduction, as `make reproduce QUICK=1` runs it, over a
    figures folder that holds a figure of an earlier run: its folder."""
    binary = poolreps_path()
    if binary is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    py = os.environ.get("PYTHON") or "/usr/bin/python3"
    try:
        if run_cmd([py, "-c", "import matplotlib"], capture_output=True, timeout=60).returncode:
            pytest.skip(f"{py} lacks matplotlib")
    except OSError:
        pytest.skip(f"no {py}")
    o = tmp_path_factory.mktemp("reproduce") / "out"
    (o / "figures").mkdir(parents=True)
    (o / "figures" / "fig7_99_old.png").write_bytes(b"from an earlier run")
    p = run_cmd(["sh", "scripts/reproduce.sh", str(o), py, "1"], cwd=ROOT,
                capture_output=True, text=True, timeout=1800,
                env=dict(os.environ, LC_ALL="C", POOLREPS=binary))
    assert p.returncode == 0, p.stderr[-3000:]
    return o


def quick_sets(name):
    """The keys of data/quick/NAME.ini (the quick settings that `make
    reproduce QUICK=1` adds to data/NAME.ini) as "section.key=value"."""
    ini = configparser.ConfigParser(inline_comment_prefixes=None, comment_prefixes=(";", "#"))
    ini.read(ROOT / "data" / "quick" / f"{name}.ini")
    return [f"{section}.{key}={value}" for section in ini.sections()
            for key, value in ini[section].items()]


def config_keys(text):
    """`poolreps config`'s output: {section.key: default}, with the keys of the
    friction laws not chosen (written as comments, listed in commented), and
    the lines that are no key, section, comment or blank."""
    keys, commented, other, section = {}, [], [], None
    for line in text.splitlines():
        if line.startswith("["):
            section = line.strip("[]")
        elif " = " in line:
            k, v = line.removeprefix("; ").split(" = ", 1)
            keys[f"{section}.{k}"] = v
            if line.startswith("; "):
                commented.append(f"{section}.{k}")
        elif line and not line.startswith(";"):
            other.append(line)
    return keys, commented, other


def keys_missing(keys, text):
    """The keys of {key: default} that text in the --help-keys layout
    ("  section.key = default ...") does not list with that default, and the
    set of keys it lists."""
    missing = [k for k, v in keys.items()
               if not re.search(rf"^  {re.escape(k)} += {re.escape(v)}(?=[ :]|$)", text, re.M)]
    return missing, set(re.findall(r"^  ([a-z0-9_]+\.[a-z0-9_]+) += ", text, re.M))


def csv_rows(path):
    """(header, rows as dicts) of a CSV file."""
    with open(path, newline="") as f:
        r = csv.reader(f)
        header = next(r)
        return header, [dict(zip(header, x)) for x in r]


def owner_tag(pid):
    """The owner tag poolreps names a staging folder or temporary file by
    (docs/hardening.md, guarantee 5): PID-START-NS-BOOT as process pid of
    this machine and PID namespace has or, once gone, had it (start 1)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        start = int(stat[stat.rindex(")") + 2:].split()[19])
    except OSError:
        start = 1
    ns = os.stat("/proc/self/ns/pid").st_ino
    boot = Path("/proc/sys/kernel/random/boot_id").read_text().replace("-", "").strip()[:12]
    return f"{pid}-{start}-{ns}-{boot}"


def wait_for(pred, timeout, step=0.02):
    """Poll pred every step seconds until it holds (True) or timeout
    seconds have passed (False)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(step)
    return False
