#!/usr/bin/env python3
"""Markdown of scripts/bench_stream.sh's CSV (docs/bench_stream.csv): per
command at its largest row count, wall seconds, peak RSS and the seconds to the first
result row of the streaming and the previous all-in-memory version, the
peak ratio, and one sentence on the streaming peak at the largest row
count against 1.5 times the smallest one's; and of scripts/bench_header.sh's
(docs/bench_header.csv): the median seconds of both versions and their ratio.

  bench_stream_table.py [--header CSV] [CSV]    print both
  bench_stream_table.py --write                 put them into docs/benchmarks.md,
                                                between the bench_stream and
                                                bench_header markers
  bench_stream_table.py --check                 exit 1 if any differs"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import csv
import os
import statistics
import sys

import doc_block

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOCS = [os.path.join(ROOT, "docs", "benchmarks.md")]
NAMES = {"shoot": "`shoot`", "forest": "`forest --test`", "policy": "`policy -i`"}


def render(rows):
    get = {(r["command"], int(r["rows"]), r["version"]): r for r in rows}
    out = ["| command | rows | seconds | previous s | peak MiB | previous peak MiB | "
           "previous / streaming peak | first row s | previous first row s |",
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    words = []
    for cmd in dict.fromkeys(r["command"] for r in rows):
        sizes = sorted({int(r["rows"]) for r in rows if r["command"] == cmd})
        for n in sizes[-1:]:   # the largest input; every size is in the CSV
            s, p = get[cmd, n, "streaming"], get[cmd, n, "previous"]
            sk, pk = int(s["peak_kib"]), int(p["peak_kib"])
            out.append(f"| {NAMES[cmd]} | {n:,} | {float(s['seconds']):.2f} | {float(p['seconds']):.2f} | "
                       f"{sk / 1024:.1f} | {pk / 1024:.1f} | {pk / sk:.1f} | "
                       f"{float(s['first_row_s']):.3f} | {float(p['first_row_s']):.2f} |")
        lo, hi = int(get[cmd, sizes[0], "streaming"]["peak_kib"]), int(get[cmd, sizes[-1], "streaming"]["peak_kib"])
        words.append(f"{NAMES[cmd]} {hi / lo:.2f} ({'within' if hi <= 1.5 * lo else 'above'} 1.5)")
    out += ["", f"Streaming peak at {sizes[-1]:,} rows over the peak at {sizes[0]:,} rows: " +
            "; ".join(words) + ". Every row count: the CSV."]
    return "\n".join(out) + "\n"


def render_header(rows):
    sec = {v: statistics.median(float(r["seconds"]) for r in rows if r["version"] == v)
           for v in ("hash_set", "previous")}
    runs = sum(r["version"] == "previous" for r in rows)
    return (f"A header of {int(rows[0]['columns']):,} columns (`shoot -i`, which refuses the "
            f"ball count after the header's checks), median of {runs} interleaved runs: "
            f"{sec['hash_set']:.2f} s with the hash set, {sec['previous']:.1f} s with the previous "
            f"pairwise comparison, {sec['previous'] / sec['hash_set']:.0f} times as long.\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv", nargs="?", default=os.path.join(ROOT, "docs", "bench_stream.csv"))
    ap.add_argument("--header", default=os.path.join(ROOT, "docs", "bench_header.csv"))
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--write", action="store_true")
    mode.add_argument("--check", action="store_true")
    a = ap.parse_args()
    blocks = []
    for name, path, fn, docs in (("bench_stream", a.csv, render, DOCS),
                                 ("bench_header", a.header, render_header, DOCS)):
        if os.path.exists(path) or a.write or a.check:
            with open(path, newline="") as f:
                blocks.append((name, path, fn(list(csv.DictReader(f))), docs))
    if not (a.write or a.check):
        sys.stdout.write("\n".join(text for _, _, text, _ in blocks))
        return 0
    for name, path, text, docs in blocks:
        doc_block.update(docs, name, text, a.check, "bench_stream_table.py", path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
