#!/usr/bin/env python3
"""Markdown table of scripts/bench_stream.sh's CSV (default
docs/bench_stream.csv): per command and row count, wall seconds, peak RSS
and the seconds to the first result row of the streaming and the previous
all-in-memory version, their ratios, and one sentence on the streaming
peak at the largest row count against 1.5 times the smallest one's.

  bench_stream_table.py [CSV]            print the table
  bench_stream_table.py --write [CSV]    put it into docs/benchmarks.md and
                                         docs/hardening.md, between the
                                         bench_stream markers
  bench_stream_table.py --check [CSV]    exit 1 if either differs"""
import argparse
import csv
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOCS = [os.path.join(ROOT, "docs", n) for n in ("benchmarks.md", "hardening.md")]
BEGIN, END = "<!-- bench_stream:begin -->", "<!-- bench_stream:end -->"
NAMES = {"shoot": "`shoot`", "forest": "`forest --test`", "policy": "`policy -i`"}


def render(rows):
    get = {(r["command"], int(r["rows"]), r["version"]): r for r in rows}
    out = ["| command | rows | seconds | previous s | peak MiB | previous peak MiB | "
           "previous / streaming peak | first row s | previous first row s |",
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    words = []
    for cmd in dict.fromkeys(r["command"] for r in rows):
        sizes = sorted({int(r["rows"]) for r in rows if r["command"] == cmd})
        for n in sizes:
            s, p = get[cmd, n, "streaming"], get[cmd, n, "previous"]
            sk, pk = int(s["peak_kib"]), int(p["peak_kib"])
            out.append(f"| {NAMES[cmd]} | {n:,} | {float(s['seconds']):.2f} | {float(p['seconds']):.2f} | "
                       f"{sk / 1024:.1f} | {pk / 1024:.1f} | {pk / sk:.1f} | "
                       f"{float(s['first_row_s']):.3f} | {float(p['first_row_s']):.2f} |")
        lo, hi = int(get[cmd, sizes[0], "streaming"]["peak_kib"]), int(get[cmd, sizes[-1], "streaming"]["peak_kib"])
        words.append(f"{NAMES[cmd]} {hi / lo:.2f} ({'within' if hi <= 1.5 * lo else 'above'} 1.5)")
    out += ["", f"Streaming peak at {sizes[-1]:,} rows over the peak at {sizes[0]:,} rows: " +
            "; ".join(words) + "."]
    return "\n".join(out) + "\n"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv", nargs="?", default=os.path.join(ROOT, "docs", "bench_stream.csv"))
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--write", action="store_true")
    mode.add_argument("--check", action="store_true")
    a = ap.parse_args()
    with open(a.csv, newline="") as f:
        text = render(list(csv.DictReader(f)))
    if not (a.write or a.check):
        sys.stdout.write(text)
        return 0
    for path in DOCS:
        doc = open(path, encoding="utf-8").read()
        i, j = doc.find(BEGIN), doc.find(END)
        if i < 0 or j < i:
            sys.exit(f"bench_stream_table.py: {path}: no {BEGIN} ... {END} block")
        new = doc[:i + len(BEGIN)] + "\n" + text + doc[j:]
        if a.check and new != doc:
            sys.exit(f"bench_stream_table.py: {path}: the streaming table differs from {a.csv} "
                     "(run scripts/bench_stream_table.py --write)")
        if a.write:
            with open(path + ".tmp", "w", encoding="utf-8") as f:
                f.write(new)
            os.replace(path + ".tmp", path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
