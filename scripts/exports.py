#!/usr/bin/env python3
"""The shared library's export list and the public headers, kept equal.

    scripts/exports.py            print the linker version script (src/libpoolreps.map)
    scripts/exports.py --check    fail unless src/libpoolreps.map is what the headers declare
    scripts/exports.py --nm LIB   fail unless `nm -D --defined-only LIB` exports exactly
                                  the functions and variables the headers declare

A name is exported when include/poolreps/*.h declares it: a function
prototype or an `extern` variable (prefix pr_). Comments, macros and type
definitions are not declarations."""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
MAP = ROOT / "src" / "libpoolreps.map"


def strip(text):
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    # preprocessor lines (with continuations) declare nothing
    return re.sub(r"^[ \t]*#(?:[^\n]*\\\n)*[^\n]*", " ", text, flags=re.M)


def declared(headers=None):
    """{name: header} of every pr_ function and extern variable the headers declare."""
    return {n: h for n, (h, _) in declarations(headers).items()}


def variables(headers=None):
    """The extern variables among them (the rest are functions)."""
    return {n for n, (_, kind) in declarations(headers).items() if kind == "variable"}


def declarations(headers=None):
    """{name: (header, "function" or "variable")}."""
    names = {}
    for h in headers or sorted((ROOT / "include" / "poolreps").glob("*.h")):
        text = strip(h.read_text())
        depth = 0
        stmt = []
        # split the file into top-level statements (outside braces)
        for ch in text:
            if ch == "{":
                depth += 1
            elif ch == "}":
                depth -= 1
                if depth == 0:
                    stmt = []  # a struct/enum body: its fields declare nothing
                continue
            if depth:
                continue
            if ch == ";":
                s = " ".join("".join(stmt).split())
                stmt = []
                if s.startswith("typedef"):
                    continue
                m = re.match(r"^extern\b.*?\b(pr_\w+)\s*(\[[^\]]*\])?$", s)
                if m:
                    names[m.group(1)] = (h.name, "variable")
                    continue
                m = re.search(r"\b(pr_\w+)\s*\(", s)
                if m and not s.startswith("extern"):
                    names[m.group(1)] = (h.name, "function")
            else:
                stmt.append(ch)
    return names


def version_script(names):
    lines = ["/* libpoolreps.map — what libpoolreps.so exports: every function and",
             " * variable include/poolreps/*.h declares, nothing else (scripts/exports.py",
             " * writes and checks it; tests/test_exports.py compares it with nm -D). */",
             "{", "global:"]
    lines += [f"\t{n};" for n in sorted(names)]
    lines += ["local:", "\t*;", "};"]
    return "\n".join(lines) + "\n"


def exported(lib):
    out = subprocess.run(["nm", "-D", "--defined-only", str(lib)], check=True,
                         capture_output=True, text=True).stdout
    syms = set()
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[1] in "TDBRVWGSiu":
            syms.add(parts[2].split("@")[0])
    return syms


def main(argv):
    names = declared()
    if len(argv) == 1:
        sys.stdout.write(version_script(names))
        return 0
    if argv[1] == "--check":
        if MAP.read_text() != version_script(names):
            print("exports: src/libpoolreps.map differs from what include/poolreps/*.h declare "
                  "(rerun scripts/exports.py > src/libpoolreps.map)", file=sys.stderr)
            return 1
        return 0
    if argv[1] == "--nm" and len(argv) == 3:
        syms = exported(argv[2])
        extra = sorted(syms - set(names))
        missing = sorted(set(names) - syms)
        for n in extra:
            print(f"exports: {n}: exported, but no public header declares it", file=sys.stderr)
        for n in missing:
            print(f"exports: {n}: declared in {names[n]}, but not exported", file=sys.stderr)
        return 1 if extra or missing else 0
    print(__doc__, file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
