#!/usr/bin/env python3
"""Line coverage of src/ from the gcov data of a COV=1 build.

    scripts/coverage.py [BUILD]          print the table (BUILD: default build/cov)
    scripts/coverage.py BUILD --write    also record it: docs/data/coverage.csv and
                                         the coverage block of docs/testing.md
    scripts/coverage.py --check          fail unless the block is what the CSV gives

`make check COV=1` builds every object with --coverage into build/cov, runs
the whole suite (the C tests, pytest, the examples, the Python package over
libpoolreps.so) and then prints this table: for every .c file of src/ (the
library, src/tool and src/cli) gcov's count of executable lines and of
lines run, lowest first, then the total. A file compiled but never run
counts as 0 %. Exit 1 when no file has data (nothing ran)."""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import csv
import os
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
import doc_block  # noqa: E402

FLOOR = 70.0  # docs/testing.md: the aim, no file of src/ below this
CSV = ROOT / "docs" / "data" / "coverage.csv"
DOC = ROOT / "docs" / "testing.md"


def file_lines(src, objdir):
    """(lines run, executable lines) of src from gcov -n; None when it was
    not built with coverage, "stale" when its object was rebuilt after its
    data were written (their stamps differ: the run says nothing of it),
    (0, 0) when it has no executable line."""
    if not (objdir / (src.stem + ".gcno")).exists():
        return None
    p = subprocess.run(["gcov", "-n", "-o", str(objdir / (src.stem + ".o")), str(src)],
                       capture_output=True, text=True, cwd=ROOT)
    if "stamp mismatch" in p.stderr:
        return "stale"
    m = re.search(r"File '" + re.escape(str(src)) + r"'\nLines executed:([0-9.]+)% of (\d+)",
                  p.stdout)
    if not m:
        return (0, 0) if "No executable lines" in p.stdout else None
    total = int(m.group(2))
    return round(float(m.group(1)) * total / 100), total


def measure(build):
    rows, unbuilt = [], []
    for src in sorted((ROOT / "src").rglob("*.c")):
        rel = src.relative_to(ROOT)
        got = file_lines(rel, build / src.parent.relative_to(ROOT / "src"))
        if got is None:
            unbuilt.append(str(rel))
        elif got == "stale":
            rows.append({"file": str(rel), "lines_run": "", "lines": ""})
        elif got[1]:
            rows.append({"file": str(rel), "lines_run": got[0], "lines": got[1]})
    return rows, unbuilt


def block(rows):
    stale = [r["file"] for r in rows if r["lines"] == ""]
    rows = [r for r in rows if r["lines"] != ""]
    run, total = sum(r["lines_run"] for r in rows), sum(r["lines"] for r in rows)
    low = sorted((r for r in rows if 100 * r["lines_run"] < FLOOR * r["lines"]),
                 key=lambda r: r["lines_run"] / r["lines"])
    text = (f"Line coverage of src/ over the whole suite (`make check COV=1`, gcov): "
            f"**{100 * run / total:.1f} %** of {total} executable lines in {len(rows)} files; "
            f"{len(low)} file{'' if len(low) == 1 else 's'} below {FLOOR:.0f} %")
    if low:
        text += ": " + ", ".join(f"`{r['file']}` {100 * r['lines_run'] / r['lines']:.0f} %"
                                 for r in low)
    if stale:
        text += ("; no data for " + ", ".join(f"`{f}`" for f in stale) +
                 " (rebuilt while the suite ran: run it again)")
    return text + ". Per file: `docs/data/coverage.csv`.\n"


def read_csv():
    with open(CSV, newline="") as f:
        return [{"file": r["file"], "lines_run": int(r["lines_run"] or 0) if r["lines"] else "",
                 "lines": int(r["lines"]) if r["lines"] else ""} for r in csv.DictReader(f)]


def main(argv):
    if argv[1:] == ["--check"]:
        doc_block.update([str(DOC)], "coverage", block(read_csv()), True, "coverage.py",
                         "docs/data/coverage.csv")
        return 0
    args = [a for a in argv[1:] if a != "--write"]
    build = ROOT / (args[0] if args else "build/cov")
    rows, unbuilt = measure(build)
    if not any(r["lines_run"] for r in rows if r["lines"] != ""):
        print(f"coverage: no gcov data under {build} (build and run with COV=1)", file=sys.stderr)
        return 1
    print("line coverage of src/ (gcov):")
    for r in sorted((r for r in rows if r["lines"] != ""), key=lambda r: r["lines_run"] / r["lines"]):
        pct = 100 * r["lines_run"] / r["lines"]
        mark = f"  below {FLOOR:.0f} %" if pct < FLOOR else ""
        print(f"  {pct:5.1f} %  {r['lines_run']:6d} / {r['lines']:6d}  {r['file']}{mark}")
    for r in rows:
        if r["lines"] == "":
            print(f"      ?    no data: rebuilt while the suite ran  {r['file']}")
    for name in unbuilt:
        print(f"      ?    not built with coverage  {name}")
    print(block(rows), end="")
    if "--write" in argv:
        with open(str(CSV) + ".tmp", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=["file", "lines_run", "lines"], lineterminator="\n")
            w.writeheader()
            w.writerows(rows)
        os.replace(str(CSV) + ".tmp", CSV)
        doc_block.update([str(DOC)], "coverage", block(rows), False, "coverage.py",
                         "docs/data/coverage.csv")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
