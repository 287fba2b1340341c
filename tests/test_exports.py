"""The shared library exports its public API and nothing else.

`make check` sets POOLREPS_LIB (the libpoolreps.so it built) and
POOLREPS_STAGE (the tree `make install-lib` staged); without them the tests
skip. The export list src/libpoolreps.map is what include/poolreps/*.h
declare (scripts/exports.py); nm -D must show exactly those names, none of
the command line's (pr_cmd_), and every name the Python package and the
examples call."""
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "scripts"))
import exports  # noqa: E402

LIB = os.environ.get("POOLREPS_LIB")
STAGE = os.environ.get("POOLREPS_STAGE")
needs_lib = pytest.mark.skipif(not LIB, reason="POOLREPS_LIB not set (make check sets it)")


def test_the_export_list_is_what_the_headers_declare():
    p = subprocess.run([sys.executable, str(ROOT / "scripts/exports.py"), "--check"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr


def test_the_header_parser_finds_functions_and_variables_only(tmp_path):
    h = tmp_path / "x.h"
    h.write_text("/* pr_in_comment(void); */\n#define PR_X(a) pr_macro(a)\n"
                 "typedef struct { int (*pr_field)(void); } pr_t;\n"
                 "typedef int (*pr_fn_type)(int);\n"
                 "int pr_one(int a,\n  int b);\nextern const int pr_table[];\n"
                 "extern volatile int pr_flag;\nstruct pr_s { int pr_member; };\n")
    assert exports.declared([h]) == {"pr_one": "x.h", "pr_table": "x.h", "pr_flag": "x.h"}


@needs_lib
def test_nm_shows_exactly_the_public_api():
    p = subprocess.run([sys.executable, str(ROOT / "scripts/exports.py"), "--nm", LIB],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    syms = exports.exported(LIB)
    assert syms == set(exports.declared())
    assert not [s for s in syms if s.startswith("pr_cmd_")]
    # the library's internals stay inside it, and the tool's calls (run
    # folders, sweeps, CSV plumbing) are no part of it
    assert "pr_outdir_run" not in syms and "pr_csv_scan" not in syms
    assert not [s for s in syms if s.startswith(("pr_rundir_", "pr_csv", "pr_outset_",
                                                 "pr_query_", "pr_outdir_"))]


def test_the_public_api_is_small():
    """At most 110 exported functions (room for the learner's below it)."""
    names = exports.declared()
    funcs = [n for n in names if n not in exports.variables()]
    assert 0 < len(funcs) <= 110, len(funcs)


@needs_lib
def test_every_symbol_the_python_package_and_examples_use_is_exported():
    syms = exports.exported(LIB)
    used = set()
    for f in sorted((ROOT / "python" / "poolreps").glob("*.py")):
        used |= set(re.findall(r"\blib\.(pr_\w+)", f.read_text()))
        used |= set(re.findall(r"[\"'](pr_\w+)[\"']\s*:", f.read_text()))
    for f in sorted((ROOT / "examples").glob("*.c")):
        used |= set(re.findall(r"\b(pr_\w+)\s*\(", f.read_text()))
    assert used, "no library call found in python/poolreps or examples"
    assert sorted(used - syms) == []


@pytest.mark.skipif(not STAGE, reason="POOLREPS_STAGE not set (make check sets it)")
def test_the_installed_headers_are_the_public_ones_without_the_command_line():
    inc = Path(STAGE) / "usr/local/include/poolreps"
    installed = sorted(p.name for p in inc.glob("*.h"))
    assert installed == sorted(p.name for p in (ROOT / "include/poolreps").glob("*.h"))
    assert "cmd.h" not in installed
    assert not {"rundir.h", "csvio.h", "query.h", "internal.h"} & set(installed)
    text = "".join((inc / n).read_text() for n in installed)
    assert "pr_cmd_" not in text


def test_every_export_is_used_by_python_an_example_or_documented():
    """An exported name earns its place: the Python package or an example
    calls it, or docs/library.md names it for C users."""
    texts = [f.read_text() for f in sorted((ROOT / "python" / "poolreps").glob("*.py"))]
    texts += [f.read_text() for f in sorted((ROOT / "examples").glob("*.c"))]
    texts.append((ROOT / "docs" / "library.md").read_text())
    used = set()
    for t in texts:
        used |= set(re.findall(r"\b(pr_\w+)\b", t))
    assert sorted(set(exports.declared()) - used) == []


def test_the_configuration_is_opaque_to_public_users(tmp_path):
    """pr_config's layout is private: a program of the public headers
    cannot take its size, so its limits may change under the same SONAME."""
    src = tmp_path / "size.c"
    src.write_text('#include "poolreps/config.h"\nunsigned long n = sizeof(pr_config);\n'
                   'int main(void) { pr_config *c = pr_config_new(); pr_config_free(c); '
                   'return (int)(n & 1); }\n')
    cc = ["cc", "-std=c11", "-fsyntax-only", f"-I{ROOT / 'include'}", str(src)]
    gsl = subprocess.run(["pkg-config", "--cflags", "gsl"], capture_output=True, text=True)
    p = subprocess.run(cc + gsl.stdout.split(), capture_output=True, text=True)
    assert p.returncode != 0 and "incomplete" in p.stderr, p.stderr
    src.write_text(src.read_text().replace("sizeof(pr_config)", "sizeof(pr_config *)"))
    p = subprocess.run(cc + gsl.stdout.split(), capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
