"""The advice for a missing runtime library names every library that
libpoolreps.so.0 needs: the package's list against the .so's own NEEDED
entries (readelf), the Debian package that holds each (dpkg -S, when dpkg
is there), the message and docs/python.md's install line."""
import re
import shutil
import subprocess
import sys

import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "python"))
from poolreps import _lib  # noqa: E402

# the C library and the loader: every system has them
GLIBC = re.compile(r"^(libc|libm|libpthread|libdl|librt|ld-linux[\w-]*)\.so")


def needed():
    if not shutil.which("readelf"):
        pytest.skip("readelf (binutils) is not installed")
    out = subprocess.run(["readelf", "-d", _lib.LIBRARY_PATH], capture_output=True, text=True,
                         check=True).stdout
    libs = re.findall(r"\(NEEDED\)\s+Shared library: \[([^\]]+)\]", out)
    assert libs, out
    return [x for x in libs if not GLIBC.match(x)]


def test_every_needed_library_is_in_the_advice():
    libs = needed()
    missing = [x for x in libs if x not in _lib.RUNTIME_PACKAGES]
    assert not missing, f"add to RUNTIME_PACKAGES (python/poolreps/_lib.py): {missing}"
    msg = str(_lib.missing_runtime(f"{libs[0]}: cannot open shared object file: No such file"))
    for lib in libs:
        assert _lib.RUNTIME_PACKAGES[lib] in re.findall(r"[\w.+-]+", msg), (lib, msg)
    line = next(x for x in (ROOT / "docs" / "python.md").read_text().splitlines()
                if "apt-get install" in x and "libgsl27" in x)
    assert set(_lib.RUNTIME_PACKAGES.values()) <= set(line.split()), line


def test_the_named_packages_hold_the_libraries():
    if not shutil.which("dpkg") or not shutil.which("ldconfig"):
        pytest.skip("not a Debian system")
    cache = subprocess.run(["ldconfig", "-p"], capture_output=True, text=True).stdout
    for lib in needed():
        m = re.search(rf"^\s*{re.escape(lib)} \(.*\) => (\S+)$", cache, re.M)
        assert m, f"{lib} is not in the loader's cache"
        real = subprocess.run(["readlink", "-f", m.group(1)], capture_output=True,
                              text=True).stdout.strip()
        owner = subprocess.run(["dpkg", "-S", real], capture_output=True, text=True).stdout
        assert owner.split(":")[0] == _lib.RUNTIME_PACKAGES[lib], (lib, owner)
