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


def stub_bin(tmp_path, **tools):
    """A folder of stand-in commands (name -> shell body) put first on PATH."""
    b = tmp_path / "stub"
    b.mkdir()
    for name, body in tools.items():
        p = b / name
        p.write_text("#!/bin/sh\n" + body + "\n")
        p.chmod(0o755)
    return b


def tree_state(*dirs):
    """Every path under dirs with its kind, mode and bytes (links as links)."""
    out = {}
    for d in dirs:
        for p in sorted(d.rglob("*")) if d.exists() else []:
            st = p.lstat()
            data = os.readlink(p) if p.is_symlink() else (p.read_bytes() if p.is_file() else None)
            out[str(p)] = (st.st_mode, data)
    return out


def git_status():
    return run_cmd(["git", "-C", str(ROOT), "status", "--porcelain", "--ignored"],
                   capture_output=True, text=True, timeout=60).stdout


# dpkg-query answers "not installed" for every package
NO_PACKAGES = "exit 1"


@pytest.mark.parametrize("goal", ["reproduce", "deps"])
def test_install_goals_without_root_print_the_apt_line_and_change_nothing(tmp_path, goal):
    """Without root and without the packages, the goals that would install
    them print ONE line with the exact apt-get command and exit 2; nothing is
    built or written."""
    stub = stub_bin(tmp_path, **{"dpkg-query": NO_PACKAGES, "id": 'echo 1000'})
    before, status = tree_state(tmp_path), git_status()
    env = dict(os.environ, PATH=f"{stub}:{os.environ['PATH']}", LC_ALL="C")
    env.pop("MAKEFLAGS", None)
    p = run_cmd(["make", "-C", str(ROOT), f"BUILD={tmp_path / 'b'}", f"OUT={tmp_path / 'out'}",
                 goal], capture_output=True, text=True, env=env, timeout=120)
    assert p.returncode == 2, p.stderr
    lines = p.stderr.splitlines()
    assert len(lines) == 1, p.stderr
    assert "missing Debian packages: build-essential pkg-config" in lines[0]
    assert "apt-get update && apt-get install -y --no-install-recommends build-essential" \
        in lines[0]
    assert tree_state(tmp_path) == before and git_status() == status
    assert not (tmp_path / "b").exists() and not (tmp_path / "out").exists()


@pytest.mark.parametrize("failing", ["update", "install"])
def test_a_failing_apt_get_stops_reproduce_with_its_message_and_ours(tmp_path, failing):
    """As root, when apt-get fails (no network, a locked dpkg), make
    reproduce stops with apt's own message plus one line naming the step, and
    changes nothing in the checkout."""
    apt = (f'[ "$1" = {failing} ] && {{ echo "E: Could not get lock /var/lib/dpkg/lock-frontend" >&2; '
           'exit 100; }; exit 0')
    stub = stub_bin(tmp_path, **{"dpkg-query": NO_PACKAGES, "id": "echo 0", "apt-get": apt})
    status = git_status()
    env = dict(os.environ, PATH=f"{stub}:{os.environ['PATH']}", LC_ALL="C")
    env.pop("MAKEFLAGS", None)
    p = run_cmd(["make", "-s", "-C", str(ROOT), f"BUILD={tmp_path / 'b'}",
                 f"OUT={tmp_path / 'out'}", "reproduce"],
                capture_output=True, text=True, env=env, timeout=120)
    assert p.returncode != 0
    lines = [ln for ln in p.stderr.splitlines() if not ln.startswith("make")]
    assert lines[0].startswith("E: Could not get lock"), p.stderr
    assert len(lines) == 2 and f"step 'apt-get {failing}" in lines[1], p.stderr
    assert git_status() == status
    assert not (tmp_path / "b").exists() and not (tmp_path / "out").exists()


def test_reproduce_goes_to_the_install_step_first(tmp_path):
    """`make -n reproduce` with no usable compiler: the first command is the
    install step, not a compiler call or a dependency error."""
    e = dict(os.environ, LC_ALL="C")
    e.pop("MAKEFLAGS", None)
    p = run_cmd(["make", "-n", "-C", str(ROOT), f"BUILD={tmp_path / 'b'}", "CC=/nonexistent/cc",
                 "reproduce"], capture_output=True, text=True, env=e, timeout=120)
    first = [ln for ln in p.stdout.splitlines() if not ln.startswith("make")][0]
    assert first.startswith("sh scripts/install-deps.sh"), p.stdout


@pytest.mark.parametrize("goal", ["all", "check"])
def test_a_bare_machine_gets_every_missing_package_at_once(tmp_path, goal):
    """No compiler and no packages (dpkg says so): `make` and `make check`
    name every missing package in one line, not just the compiler (whose
    absence hides the header probes)."""
    stub = stub_bin(tmp_path, **{"dpkg-query": NO_PACKAGES})
    env = dict(os.environ, PATH=f"{stub}:{os.environ['PATH']}", LC_ALL="C")
    env.pop("MAKEFLAGS", None)
    p = run_cmd(["make", "-C", str(ROOT), f"BUILD={tmp_path / 'b'}", "CC=/nonexistent/cc", goal],
                capture_output=True, text=True, env=env, timeout=120)
    assert p.returncode == 2
    lines = p.stderr.splitlines()
    assert len(lines) == 1, p.stderr
    for pkg in ("build-essential", "libgsl-dev", "libcsv-dev", "libinih-dev", "libglpk-dev",
                "libnlopt-dev", "libopenblas0", "libcmocka-dev",
                "python3-matplotlib", "python3-pytest-xdist"):
        assert pkg in lines[0], pkg
    assert "make deps" in lines[0] and "apt-get update && apt-get install -y" in lines[0]
    assert not (tmp_path / "b").exists()
