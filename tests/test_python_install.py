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
