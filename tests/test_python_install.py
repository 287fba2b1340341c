"""`pip install ./python` into a throwaway virtual environment (with the
system's site packages, for numpy) outside the repository: the installed
package imports and runs, finding the library next to itself (what `make
python` puts there) or, without that copy, through an installed poolreps.pc."""
import ctypes.util
import os
import shutil
import sys
from pathlib import Path

import pytest

from conftest import ROOT, run_cmd

LIB = Path(os.environ.get("POOLREPS_LIB") or ROOT / "build/rel/libpoolreps.so.0")
STAGE = os.environ.get("POOLREPS_STAGE")

PROBE = """
import numpy as np, poolreps
r = poolreps.shoot([[-0.25, 0, 0.1, 0]], [[0.615, 0.03]])
print(poolreps.library_path())
print(r["hit"][0], r["pocket"][0, 1])
"""


def have_build_tools():
    try:
        import setuptools, wheel  # noqa: F401
        import venv  # noqa: F401
    except ImportError:
        return False
    return True


pytestmark = pytest.mark.skipif(not have_build_tools(),
                                reason="needs python3-venv, python3-setuptools and python3-wheel")


def source_tree(dest, with_library):
    """A copy of python/ (no build products), as `make python` leaves it or not."""
    shutil.copytree(ROOT / "python", dest,
                    ignore=shutil.ignore_patterns("__pycache__", "*.egg-info", "build",
                                                  "libpoolreps.so*"))
    if with_library:
        shutil.copy(LIB, dest / "poolreps" / "libpoolreps.so.0")
    return dest


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    d = tmp_path_factory.mktemp("venv")
    run_cmd([sys.executable, "-m", "venv", "--system-site-packages", str(d / "env")],
                   check=True, capture_output=True, timeout=300)
    return d


def pip_install(venv, src):
    p = run_cmd([str(venv / "env/bin/pip"), "install", "-q", "--no-build-isolation",
                        "--no-deps", "--no-index", "--force-reinstall", str(src)],
                       capture_output=True, text=True, cwd=venv, timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr


def run_installed(venv, extra_env=None):
    env = {k: v for k, v in os.environ.items()
           if k not in ("POOLREPS_LIB", "PYTHONPATH", "PKG_CONFIG_PATH", "PKG_CONFIG_SYSROOT_DIR")}
    env.update(extra_env or {})
    p = run_cmd([str(venv / "env/bin/python"), "-c", PROBE], capture_output=True,
                       text=True, cwd=venv, env=env, timeout=120)
    assert p.returncode == 0, p.stderr
    return p.stdout.split("\n")


def test_pip_install_carries_the_library(venv):
    assert LIB.exists(), "build the library first (make)"
    pip_install(venv, source_tree(venv / "src1", with_library=True))
    path, result, _ = run_installed(venv)
    site = venv / "env/lib"
    assert Path(path).resolve().is_relative_to(site.resolve()), path
    assert result == "True 2"


def test_pip_install_finds_an_installed_library_through_pkg_config(venv):
    if not STAGE:
        pytest.skip("run through `make check` (needs POOLREPS_STAGE, the staged install)")
    pip_install(venv, source_tree(venv / "src2", with_library=False))
    libdir = Path(STAGE) / "usr/local/lib"
    path, result, _ = run_installed(venv, {"PKG_CONFIG_PATH": str(libdir / "pkgconfig"),
                                           "PKG_CONFIG_SYSROOT_DIR": STAGE})
    assert Path(path) == libdir / "libpoolreps.so.0"
    assert result == "True 2"
    # and with no library anywhere it says where it looked, as an OSError
    if ctypes.util.find_library("poolreps"):
        return  # a system-wide install would be found: nothing to test here
    p = run_cmd([str(venv / "env/bin/python"), "-c", "import poolreps"],
                       capture_output=True, text=True, cwd=venv,
                       env={"PATH": os.environ["PATH"], "PKG_CONFIG_PATH": str(venv)},
                       timeout=120)
    assert p.returncode != 0 and "OSError: poolreps: libpoolreps.so.0 not found" in p.stderr


def build_wheel(venv, src, out):
    """pip wheel of src with the venv's pip, into the empty folder out."""
    p = run_cmd([str(venv / "env/bin/pip"), "wheel", "-q", "--no-build-isolation", "--no-deps",
                 "--no-index", "-w", str(out), str(src)],
                capture_output=True, text=True, cwd=venv, timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr
    wheels = list(out.glob("*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


def test_the_wheel_is_platform_tagged_and_runs_in_a_fresh_venv(venv, tmp_path):
    import sysconfig
    import zipfile
    assert LIB.exists(), "build the library first (make)"
    # built with the module's venv (what it has installed does not enter a
    # wheel built from a source tree), installed into a fresh one
    whl = build_wheel(venv, source_tree(tmp_path / "src", with_library=True), tmp_path / "w")
    plat = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    assert whl.name == f"poolreps-0.1.0-py3-none-{plat}.whl"
    with zipfile.ZipFile(whl) as z:
        wheel = z.read("poolreps-0.1.0.dist-info/WHEEL").decode()
        assert "Root-Is-Purelib: false" in wheel and f"Tag: py3-none-{plat}" in wheel
        assert {"poolreps/libpoolreps.so.0", "poolreps/py.typed"} <= set(z.namelist())
    # a fresh venv: numpy from the system (a runtime dependency), nothing else
    fresh = tmp_path / "f"
    run_cmd([sys.executable, "-m", "venv", "--system-site-packages", str(fresh / "env")],
            check=True, capture_output=True, timeout=300)
    pip_install(fresh, whl)
    path, result, _ = run_installed(fresh)
    assert Path(path).resolve().is_relative_to((fresh / "env/lib").resolve()), path
    assert result == "True 2"


def test_a_missing_runtime_library_is_named_at_import(tmp_path):
    # the same library with one dependency renamed (same length) in its
    # dynamic string table: the loader cannot find it
    data = LIB.read_bytes()
    assert data.count(b"libcsv.so.3\0") >= 1
    bad = tmp_path / "libpoolreps.so.0"
    bad.write_bytes(data.replace(b"libcsv.so.3\0", b"libcsX.so.3\0"))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(POOLREPS_LIB=str(bad), PYTHONPATH=str(ROOT / "python"))
    p = run_cmd([sys.executable, "-c", "import poolreps"], capture_output=True, text=True,
                env=env, timeout=120)
    assert p.returncode != 0
    last = p.stderr.strip().splitlines()[-1]
    assert last.startswith("OSError: poolreps: libcsX.so.3 is missing, which libpoolreps.so.0 "
                           "needs: install the runtime libraries (Debian 12: apt-get install "
                           "libgsl27 libgslcblas0 libglpk40 libcsv3 libinih1"), last


def test_pip_wheel_of_the_checkout_leaves_it_clean(venv, tmp_path):
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")

    def status():
        return run_cmd(["git", "-C", str(ROOT), "status", "--porcelain", "--", "python"],
                       capture_output=True, text=True, timeout=60).stdout

    before = status()
    build_wheel(venv, ROOT / "python", tmp_path / "w")
    assert status() == before
