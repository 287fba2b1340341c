#!/usr/bin/env python3
"""Markdown table of scripts/bench_reps.py's CSV (default docs/bench_reps.csv):
per problem, each solver's seconds, the ratio scipy / it, its status and
certificate, and max |p - p_scipy|."""
import csv
import sys

path = sys.argv[1] if len(sys.argv) > 1 else "docs/bench_reps.csv"
rows = list(csv.DictReader(open(path)))
print("| problem | n | d | eps | solver | seconds | scipy / solver | status | kl_gap | residual_rel "
      "| max abs p - p_scipy |")
print("|---|---:|---:|---:|---|---:|---:|---|---:|---:|---:|")
for r in rows:
    sc = next(float(x["seconds"]) for x in rows
              if x["problem"] == r["problem"] and x["solver"] == "scipy-trust-exact")
    ratio = sc / float(r["seconds"])
    print(f"| {r['problem']} | {r['n']} | {r['d']} | {float(r['eps']):g} | {r['solver']} | "
          f"{float(r['seconds']):.3g} | {ratio:.2f} | {r['status'] or '-'} | {r['kl_gap'] or '-'} | "
          f"{r['residual_rel'] or '-'} | {r['max_abs_p_diff'] or '-'} |")
