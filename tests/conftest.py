"""Shared pytest helpers for the end-to-end tests.

`make check` sets POOLREPS to the absolute path of the binary. Tests may keep
reading os.environ["POOLREPS"] directly; the `poolreps` fixture below adds:
  - LC_ALL=C for every run,
  - an optional wrapper from env POOLREPS_WRAPPER (a command line, e.g.
    "valgrind -q --error-exitcode=99"), prepended to the binary,
  - a timeout, so that a hang fails the test instead of stalling the suite
    (multiplied by env POOLREPS_TIMEOUT_SCALE, which scripts/valgrind.sh sets).
Mark long experiment tests @pytest.mark.slow: scripts/valgrind.sh skips them.
"""
import csv
import os
import shlex
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: long-running; skipped by scripts/valgrind.sh")


def poolreps_path():
    """The binary under test: env POOLREPS, else ./poolreps at the top level."""
    path = os.environ.get("POOLREPS") or str(ROOT / "poolreps")
    return path if os.access(path, os.X_OK) else None


def run_poolreps(args, *, input=None, cwd=None, timeout=120, env=None):
    """Run poolreps with args (each turned into str); returns CompletedProcess
    with bytes stdout and stderr."""
    binary = poolreps_path()
    if binary is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    full_env = dict(os.environ if env is None else env)
    full_env["LC_ALL"] = "C"
    wrapper = shlex.split(os.environ.get("POOLREPS_WRAPPER", ""))
    scale = float(os.environ.get("POOLREPS_TIMEOUT_SCALE", "1"))
    return subprocess.run(wrapper + [binary] + [str(a) for a in args], input=input,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=cwd,
                          env=full_env, timeout=timeout * scale)


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
    p = subprocess.run(cmd, capture_output=True, text=True, env=dict(os.environ, LC_ALL="C"),
                       timeout=120 * float(os.environ.get("POOLREPS_TIMEOUT_SCALE", "1")))
    if check:
        assert p.returncode == 0, p.stderr
    return p


def csv_rows(path):
    """(header, rows as dicts) of a CSV file."""
    with open(path, newline="") as f:
        r = csv.reader(f)
        header = next(r)
        return header, [dict(zip(header, x)) for x in r]
