#!/usr/bin/env python3
"""The csv_read block of docs/benchmarks.md from docs/bench_csv_read.csv
(scripts/bench_csv_read.sh): per build the median whole-process wall and CPU
seconds of `poolreps reps` on the 1e6-row input, and each piece of speed
machinery's gain over the build without it. The rule stated before the
numbers: a piece stays if it makes the whole command at least 1.3 times as
fast (CPU seconds for the one-thread pieces, wall seconds for the threads).
A build the CSV lacks (machinery removed since) has no row.

    scripts/bench_csv_read.py --write | --check"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import csv
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import doc_block  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
CSV = os.path.join(ROOT, "docs", "bench_csv_read.csv")
DOC = os.path.join(ROOT, "docs", "benchmarks.md")
KEEP = 1.3
STEPS = [("decimal", "plain", "cpu_s", "the exact decimal parser (src/decimal.c) instead of strtod"),
         ("bypass", "decimal", "cpu_s", "plain lines split without libcsv, numbers read in place"),
         ("threads", "bypass", "wall_s", "the input read in parts on every core (--threads)"),
         ("threads", "pthread", "wall_s", "thread stacks mapped by hand (src/common.c) instead of "
          "pthread's own")]
BUILDS = ("plain", "decimal", "bypass", "threads", "pthread")


def text():
    with open(CSV, newline="") as f:
        rows = list(csv.DictReader(f))
    med = {}
    for b in [b for b in BUILDS if any(r["build"] == b for r in rows)]:
        rs = [r for r in rows if r["build"] == b]
        med[b] = {k: statistics.median(float(r[k]) for r in rs) for k in ("wall_s", "cpu_s")}
    loads = [float(r["load_avg"]) for r in rows]
    n = len({r["round"] for r in rows})
    lines = [f"`poolreps reps` on a 1e6-row input (a return and 6 features, 17 significant digits, "
             f"137 MB), whole process, median of {n} interleaved rounds "
             f"(`scripts/bench_csv_read.sh`, load average {min(loads):.1f} to {max(loads):.1f} "
             f"on 2 cores: a shared machine); the rule, stated first: a piece stays if it makes "
             f"the command at least {KEEP}× as fast.", "",
             "| build | wall s | CPU s |", "|---|---:|---:|"]
    for b in med:
        lines.append(f"| {b} | {med[b]['wall_s']:.2f} | {med[b]['cpu_s']:.2f} |")
    lines.append("")
    for new, old, key, what in [s for s in STEPS if s[0] in med and s[1] in med]:
        g = med[old][key] / med[new][key]
        verdict = "stays" if g >= KEEP else "goes"
        lines.append(f"- {what}: {g:.2f}× ({key.split('_')[0]}), {verdict}.")
    return "\n".join(lines) + "\n"


def main(argv):
    if len(argv) != 2 or argv[1] not in ("--write", "--check"):
        sys.exit(__doc__)
    doc_block.update([DOC], "csv_read", text(), argv[1] == "--check", "bench_csv_read.py",
                     "docs/bench_csv_read.csv")


if __name__ == "__main__":
    main(sys.argv)
