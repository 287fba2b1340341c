"""Build hooks for the wheel (the metadata is in pyproject.toml).

The package is pure Python over ctypes but carries libpoolreps.so.0, a
native library for one platform: the wheel is tagged py3-none-<platform>
(any Python 3, no Python ABI, this machine's platform) and installs into
platlib, not purelib. When the package folder holds no copy of the library
(`make python` puts one there) and this file sits in a built checkout, the
checkout's build/rel/libpoolreps.so.0 goes into the wheel.
"""
import shutil
import sysconfig
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.dist import Distribution

try:
    from setuptools.command.bdist_wheel import bdist_wheel
except ImportError:  # setuptools < 70.1
    from wheel.bdist_wheel import bdist_wheel

HERE = Path(__file__).resolve().parent
SONAME = "libpoolreps.so.0"


class BinaryDistribution(Distribution):
    def has_ext_modules(self):
        return True  # a native library inside: platlib and a platform tag


class PlatformWheel(bdist_wheel):
    def get_tag(self):
        return "py3", "none", sysconfig.get_platform().replace("-", "_").replace(".", "_")


class BuildPy(build_py):
    def run(self):
        super().run()
        built = HERE.parent / "build" / "rel" / SONAME
        target = Path(self.build_lib) / "poolreps" / SONAME
        if not (HERE / "poolreps" / SONAME).exists() and built.exists():
            shutil.copy(built.resolve(), target)


setup(distclass=BinaryDistribution, cmdclass={"bdist_wheel": PlatformWheel, "build_py": BuildPy})
