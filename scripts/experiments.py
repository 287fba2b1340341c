#!/usr/bin/env python3
"""The experiment registry as the pipeline scripts read it: the rows of
`poolreps help experiments` (name, folder, kind, summary, title), in the
registry's order. The list lives in the library (src/exp.c) and nowhere else.

    scripts/experiments.py [FIELD]    print one field of every experiment, one a line

The binary is $POOLREPS, else ./poolreps or build/rel/poolreps of this
tree, else poolreps on PATH (an installed copy)."""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import csv
import io
import os
import pathlib
import shutil
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIELDS = ("name", "folder", "kind", "summary", "title")


def binary():
    for b in (os.environ.get("POOLREPS"), ROOT / "poolreps", ROOT / "build" / "rel" / "poolreps",
              shutil.which("poolreps")):
        if b and os.access(str(b), os.X_OK) and os.path.isfile(str(b)):
            return str(b)
    sys.exit("experiments: no poolreps binary (build it with make, or set POOLREPS)")


def registry(poolreps=None):
    """[{name, folder, kind, summary, title}] of every registered experiment."""
    p = subprocess.run([poolreps or binary(), "help", "experiments"], capture_output=True,
                       text=True, env=dict(os.environ, LC_ALL="C"))
    if p.returncode != 0:
        sys.exit(f"experiments: poolreps help experiments failed: {p.stderr.strip()}")
    rows = list(csv.DictReader(io.StringIO(p.stdout)))
    if not rows or tuple(rows[0]) != FIELDS:
        sys.exit("experiments: poolreps help experiments: unexpected output")
    return rows


def main(argv):
    field = argv[1] if len(argv) > 1 else "name"
    if field not in FIELDS or len(argv) > 2:
        sys.exit(__doc__)
    for r in registry():
        print(r[field])


if __name__ == "__main__":
    main(sys.argv)
