#!/usr/bin/env python3
"""The generated blocks of the docs: text between <!-- NAME:begin --> and
<!-- NAME:end --> that a table script writes (--write) or compares
(--check) with what it makes of a committed CSV."""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import os
import sys


def update(paths, name, text, check, script, source):
    """Put text into every path's NAME block, or with check exit 1 naming
    the first file whose block differs."""
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    for path in paths:
        doc = open(path, encoding="utf-8").read()
        i, j = doc.find(begin), doc.find(end)
        if i < 0 or j < i:
            sys.exit(f"{script}: {path}: no {begin} ... {end} block")
        new = doc[:i + len(begin)] + "\n" + text + doc[j:]
        if check and new != doc:
            sys.exit(f"{script}: {path}: the {name} block differs from {source} "
                     f"(run scripts/{script} --write)")
        if not check:
            with open(path + ".tmp", "w", encoding="utf-8") as f:
                f.write(new)
            os.replace(path + ".tmp", path)


def table_main(render, name, script, default_csv, docs):
    """The command line of a table script: render(rows of the CSV) printed,
    or with --write put into, or with --check compared with, the NAME block
    of every path in docs."""
    import argparse
    import csv
    ap = argparse.ArgumentParser()
    ap.add_argument("csv", nargs="?", default=default_csv)
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--write", action="store_true")
    mode.add_argument("--check", action="store_true")
    a = ap.parse_args()
    with open(a.csv, newline="") as f:
        text = render(list(csv.DictReader(f)))
    if not (a.write or a.check):
        sys.stdout.write(text)
        return 0
    update(docs, name, text, a.check, script, a.csv)
    return 0


if __name__ == "__main__":
    print(__doc__)
