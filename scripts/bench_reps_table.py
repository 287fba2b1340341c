#!/usr/bin/env python3
"""Markdown table of scripts/bench_reps.py's CSV (default docs/bench_reps.csv):
per solver, its seconds on each problem and the ratio scipy / it (numpy's
BLAS), the failed certificates and the largest |p - p_scipy|; then the targets
against each peer and the previous poolreps (when the CSV has it) in words
made from the same numbers, and the rank-k update alone against OpenBLAS
(syrk.csv or bench_syrk.csv beside the CSV, or --syrk).

  bench_reps_table.py [CSV]            print the table and the summary
  bench_reps_table.py --write [CSV]    put them into docs/benchmarks.md,
                                       between the bench_reps markers
  bench_reps_table.py --check [CSV]    exit 1 if it differs"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import csv
import os
import sys

import doc_block

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOCS = [os.path.join(ROOT, "docs", "benchmarks.md")]
# problem: the ratio scipy / poolreps to reach, and the runs it is judged on
TARGETS = {"dense140": (1.0, ["poolreps-newton", "poolreps-newton-threads1"]),
           "dense200": (2.0, ["poolreps-newton-inprocess", "poolreps-newton",
                              "poolreps-newton-threads1"]),
           "onehot80": (100.0, ["poolreps-newton-inprocess"])}
RUN_WORDS = {"poolreps-newton": "whole process", "poolreps-newton-inprocess": "in process",
             "poolreps-newton-threads1": "whole process on 1 thread"}
# the scipy peers: numpy's BLAS in the bench's process, and Debian's
# reference BLAS in a child process
PEERS = ["scipy-trust-exact", "scipy-trust-exact-refblas"]


def targets(peer, sec, blas):
    """The targets as a table: per problem and run, the ratio scipy / poolreps
    Newton against each scipy peer, and whether it meets the target."""
    heads = [f"scipy on {blas[s]} / Newton" for s in PEERS if peer[s]]
    out = ["| target | " + " | ".join(heads) + " |", "|---|" + "---|" * len(heads)]
    for prob, (target, runs) in TARGETS.items():
        for run in runs:
            if (prob, run) not in sec:
                continue
            cells = []
            for s in PEERS:
                if peer[s] and prob in peer[s]:
                    ratio = peer[s][prob] / sec[prob, run]
                    cells.append(f"{ratio:.2f} ({'met' if ratio >= target else 'not met'})")
                elif peer[s]:
                    cells.append("-")
            out.append(f"| {prob} {RUN_WORDS[run]} ≥ {target:g} | " + " | ".join(cells) + " |")
    return out


def syrk_sentence(rows):
    """The rank-k update alone (scripts/bench_reps.sh's build/bench/syrk.csv)."""
    parts = []
    for r in rows:
        one, every = float(r["own_1_gmacs"]), float(r["own_all_gmacs"])
        own = (f"{r['rows']} × {r['cols']}: poolreps' kernel {one:.1f} on one thread and {every:.1f} "
               f"on {r['cpus']}")
        if r.get("openblas", "") == "none" or "openblas_1_gmacs" not in r:
            parts.append(own + " (no OpenBLAS to compare)")
            continue
        b1, ball = float(r["openblas_1_gmacs"]), float(r["openblas_all_gmacs"])
        parts.append(own + f", OpenBLAS's dsyrk ({r['openblas_core']} kernel) {b1:.1f} on one thread "
                     f"({b1 / one:.2f}× the kernel's) and {ball:.1f} on every core ({ball / every:.2f}× "
                     f"the kernel's on {r['cpus']}), the answers {float(r['max_rel_diff']):.2g} of the "
                     f"largest entry apart")
    return ("The Hessian's rank-k update alone (`tests/bench/bench_syrk.c`, median of 11 runs, "
            "G multiply-adds per second): " + "; ".join(parts) + ".")


def render(rows, syrk=None):
    peer = {s: {r["problem"]: float(r["seconds"]) for r in rows if r["solver"] == s} for s in PEERS}
    blas = {r["solver"]: r["blas"] for r in rows if r["solver"] in PEERS}
    sec = {(r["problem"], r["solver"]): float(r["seconds"]) for r in rows}
    probs = list(dict.fromkeys(r["problem"] for r in rows))
    solvers = list(dict.fromkeys(r["solver"] for r in rows))
    first = {p: next(r for r in rows if r["problem"] == p) for p in probs}
    out = ["Problems: " + "; ".join(f"{p} n = {first[p]['n']}, d = {first[p]['d']}, "
                                    f"ε = {float(first[p]['eps']):g}" for p in probs)
           + ". Seconds, and in brackets scipy (numpy's BLAS) / solver; every status, "
           "certificate and evaluation count is in the CSV.", "",
           "| solver | " + " | ".join(probs) + " |", "|---|" + "---:|" * len(probs)]
    for s in solvers:
        cells = [f"{sec[p, s]:.3g} ({peer[PEERS[0]][p] / sec[p, s]:.2f}×)"
                 if (p, s) in sec and p in peer[PEERS[0]] else
                 (f"{sec[p, s]:.3g}" if (p, s) in sec else "-") for p in probs]
        out.append(f"| {s} | " + " | ".join(cells) + " |")
    failed = [f"{r['solver']} on {r['problem']} ({r['status']})" for r in rows
              if r["status"] and r["status"] != "active"]
    diffs = [float(r["max_abs_p_diff"]) for r in rows
             if r["solver"].startswith("poolreps-newton") and r["max_abs_p_diff"]]
    out += ["", ("Certificate failed: " + "; ".join(failed) + ". " if failed else "")
            + (f"Newton's weights are within {max(diffs):.2g} of scipy's." if diffs else "")]
    if any(peer.values()):
        out += [""] + targets(peer, sec, blas)
    sc = peer[PEERS[0]]
    prev = []
    for p in sc:
        pair = [sec[p, old] / sec[p, run] for run, old in
                (("poolreps-newton", "poolreps-newton-previous"),
                 ("poolreps-newton-inprocess", "poolreps-newton-inprocess-previous"))
                if (p, old) in sec and (p, run) in sec]
        if len(pair) == 2:
            prev.append(f"{p} {pair[0]:.2f}× / {pair[1]:.2f}×")
    if prev:
        out += ["", "Speed-up over the previous poolreps in the same run (whole "
                "process / in process): " + "; ".join(prev) + "."]
    if syrk:
        out += ["", syrk_sentence(syrk)]
    return "\n".join(out) + "\n"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv", nargs="?", default=os.path.join(ROOT, "docs", "bench_reps.csv"))
    ap.add_argument("--syrk", help="bench_syrk's CSV (default: syrk.csv or bench_syrk.csv beside CSV)")
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--write", action="store_true")
    mode.add_argument("--check", action="store_true")
    a = ap.parse_args()
    with open(a.csv, newline="") as f:
        rows = list(csv.DictReader(f))
    base = os.path.dirname(os.path.abspath(a.csv))
    syrk = a.syrk or next((os.path.join(base, n) for n in ("syrk.csv", "bench_syrk.csv")
                           if os.path.exists(os.path.join(base, n))), None)
    if syrk:
        with open(syrk, newline="") as f:
            text = render(rows, list(csv.DictReader(f)))
    else:
        text = render(rows)
    if not (a.write or a.check):
        sys.stdout.write(text)
        return 0
    doc_block.update(DOCS, "bench_reps", text, a.check, "bench_reps_table.py", a.csv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
