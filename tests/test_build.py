"""Building on a machine that lacks packages: make stops before compiling,
with one line that names the missing Debian packages and `make deps`."""
import os

import pytest

from conftest import ROOT, run_cmd


def make(tmp_path, *args, env=None):
    e = dict(os.environ, LC_ALL="C", **(env or {}))
    e.pop("MAKEFLAGS", None)
    return run_cmd(["make", "-C", str(ROOT), f"BUILD={tmp_path / 'b'}", *args],
                          capture_output=True, text=True, env=e, timeout=120)


@pytest.mark.parametrize("args,env,names", [
    (["CC=/nonexistent/cc"], None, "build-essential"),
    ([], {"PKG_CONFIG_LIBDIR": "/nonexistent"}, "libgsl-dev"),
])
def test_missing_build_packages_give_one_line(tmp_path, args, env, names):
    p = make(tmp_path, *args, "all", env=env)
    assert p.returncode != 0
    lines = p.stderr.splitlines()
    assert len(lines) == 1, p.stderr
    assert f"missing Debian packages: {names};" in lines[0] and "make deps" in lines[0]
    # nothing was compiled
    assert not list((tmp_path / "b").glob("*.o"))


def test_missing_test_packages_are_named():
    p = run_cmd(["sh", str(ROOT / "scripts/check-deps.sh"), "check", "/bin/false"],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 1 and p.stdout.count("\n") == 1
    assert "python3-pytest python3-numpy python3-scipy python3-matplotlib" in p.stdout
    ok = run_cmd(["sh", str(ROOT / "scripts/check-deps.sh"), "build"],
                        capture_output=True, text=True, timeout=60)
    assert ok.returncode == 0 and ok.stdout == ""
