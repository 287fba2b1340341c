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


if __name__ == "__main__":
    print(__doc__)
