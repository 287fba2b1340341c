#!/usr/bin/env python3
"""Markdown table of scripts/bench_reps.py's CSV (default docs/bench_reps.csv):
per problem, each solver's seconds, the ratio scipy / it, its status and
certificate, max |p - p_scipy| and the dual's evaluations; then the targets and the previous
poolreps (when the CSV has it) in words made from the same numbers.

  bench_reps_table.py [CSV]            print the table and the summary
  bench_reps_table.py --write [CSV]    put them into docs/benchmarks.md and
                                       docs/choices.md, between the bench_reps
                                       markers
  bench_reps_table.py --check [CSV]    exit 1 if either differs"""
import argparse
import csv
import os
import sys

import doc_block

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOCS = [os.path.join(ROOT, "docs", n) for n in ("benchmarks.md", "choices.md")]
# problem: the ratio scipy / poolreps to reach, and the runs it is judged on
TARGETS = {"dense140": (1.0, ["poolreps-newton", "poolreps-newton-threads2"]),
           "dense200": (2.0, ["poolreps-newton-inprocess", "poolreps-newton",
                              "poolreps-newton-threads2"]),
           "onehot80": (100.0, ["poolreps-newton-inprocess"])}
RUN_WORDS = {"poolreps-newton": "whole process", "poolreps-newton-inprocess": "in process",
             "poolreps-newton-threads2": "whole process on 2 threads"}


def render(rows):
    sc = {r["problem"]: float(r["seconds"]) for r in rows if r["solver"] == "scipy-trust-exact"}
    sec = {(r["problem"], r["solver"]): float(r["seconds"]) for r in rows}
    out = ["| problem | n | d | eps | solver | seconds | scipy / solver | status | kl_gap | "
           "residual_rel | max abs p - p_scipy | evaluations |",
           "|---|---:|---:|---:|---|---:|---:|---|---:|---:|---:|---:|"]
    for r in rows:
        ratio = sc[r["problem"]] / float(r["seconds"])
        out.append(f"| {r['problem']} | {r['n']} | {r['d']} | {float(r['eps']):g} | {r['solver']} | "
                   f"{float(r['seconds']):.3g} | {ratio:.2f} | {r['status'] or '-'} | "
                   f"{r['kl_gap'] or '-'} | {r['residual_rel'] or '-'} | {r['max_abs_p_diff'] or '-'} | "
                   f"{r.get('evaluations') or '-'} |")
    goals = []
    for prob, (target, runs) in TARGETS.items():
        for run in runs:
            if (prob, run) in sec:
                ratio = sc[prob] / sec[prob, run]
                goals.append(f"{prob} {RUN_WORDS[run]} {ratio:.2f} (target {target:g}: "
                             f"{'met' if ratio >= target else 'not met'})")
    out += ["", "Against the targets (scipy / poolreps Newton): " + "; ".join(goals) + "."]
    for run, words in (("poolreps-newton", "Whole process"), ("poolreps-newton-inprocess", "In process")):
        old = "poolreps-newton-inprocess-previous" if run.endswith("inprocess") else "poolreps-newton-previous"
        prev = [f"{p} {sec[p, old]:.3g} s → {sec[p, run]:.3g} s ({sec[p, old] / sec[p, run]:.2f}× as fast)"
                for p in sc if (p, old) in sec and (p, run) in sec]
        if prev:
            out += ["", f"{words} against the previous poolreps in the same run: " + "; ".join(prev) + "."]
    return "\n".join(out) + "\n"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv", nargs="?", default=os.path.join(ROOT, "docs", "bench_reps.csv"))
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--write", action="store_true")
    mode.add_argument("--check", action="store_true")
    a = ap.parse_args()
    with open(a.csv, newline="") as f:
        text = render(list(csv.DictReader(f)))
    if not (a.write or a.check):
        sys.stdout.write(text)
        return 0
    doc_block.update(DOCS, "bench_reps", text, a.check, "bench_reps_table.py", a.csv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
