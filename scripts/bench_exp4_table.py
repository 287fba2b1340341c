#!/usr/bin/env python3
"""Sentence on scripts/bench_exp4.sh's CSV (default docs/bench_exp4.csv):
Experiment 4's CPU seconds, this poolreps against the previous one in the
same run (median of the runs of each), their ratio, and whether the CSVs
are byte-identical.

  bench_exp4_table.py [CSV]            print it
  bench_exp4_table.py --write [CSV]    put it into docs/benchmarks.md,
                                       between the bench_exp4 markers
  bench_exp4_table.py --check [CSV]    exit 1 if it differs"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import os
import statistics
import sys

import doc_block

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOCS = [os.path.join(ROOT, "docs", "benchmarks.md")]


def render(rows):
    cpu = {v: [float(r["cpu_s"]) for r in rows if r["version"] == v] for v in ("previous", "current")}
    if not cpu["previous"] or not cpu["current"]:
        sys.exit("bench_exp4_table.py: the CSV needs runs of both versions")
    old, new = statistics.median(cpu["previous"]), statistics.median(cpu["current"])
    sums = {r["csv_sha256"] for r in rows}
    same = "byte-identical" if len(sums) == 1 else "NOT byte-identical"
    change = f"{(new / old - 1) * 100:+.0f} %".replace("-", "−")
    return (f"Experiment 4 at full settings, one thread, median of {len(cpu['current'])} runs each "
            f"in the same run (`scripts/bench_exp4.sh`): the previous poolreps {old:.1f} CPU s, "
            f"this one {new:.1f} CPU s ({change}); the CSVs of every run are {same}.\n")


if __name__ == "__main__":
    sys.exit(doc_block.table_main(render, "bench_exp4", "bench_exp4_table.py",
                                  os.path.join(ROOT, "docs", "bench_exp4.csv"), DOCS))
