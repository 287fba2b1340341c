#!/usr/bin/env python3
"""The ask/tell learner's row of docs/benchmarks.md from
docs/data/bench_learner.csv (scripts/bench_learner.sh with CSV=...):
its per-iteration cost called from Python against the same update inside
Experiment 3 (target: at most 1.2 times), and the binding's overhead per
ask + tell at 100 episodes (target: below 0.2 ms) beside pycma's ask/tell.

  bench_learner_table.py [CSV]      print the block
  bench_learner_table.py --write    put it between the bench_learner markers
  bench_learner_table.py --check    exit 1 if the page differs"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import os
import sys

import doc_block

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def render(rows):
    ms = {r["measurement"]: float(r["median_ms"]) for r in rows}
    rounds, load = rows[0]["rounds"], max(float(r["load"]) for r in rows)
    ratio = ms["exp3_python_iteration"] / ms["exp3_cli_iteration"]
    over = ms["ask_tell_learner"] - ms["ask_tell_bare"]
    out = ["| measurement | ms |", "|---|---:|",
           f"| Experiment 3 (nrvr_a), one iteration inside `poolreps` | {ms['exp3_cli_iteration']:.2f} |",
           f"| the same loop through `poolreps.Learner` | {ms['exp3_python_iteration']:.2f} |",
           f"| ask + tell at 100 episodes through `poolreps.Learner` | {ms['ask_tell_learner']:.3f} |",
           f"| the same C calls through bare ctypes | {ms['ask_tell_bare']:.3f} |"]
    if "pycma_ask_tell" in ms:
        out.append(f"| pycma `ask()` + `tell()`, population 100, 2-D | {ms['pycma_ask_tell']:.3f} |")
    out += ["", f"Medians of {rounds} alternating rounds on the shared 2-core machine at a load "
            f"average of up to {load:.0f} (contended: re-measure idle). From Python an iteration "
            f"takes {ratio:.2f} times as long ({'within' if ratio <= 1.2 else 'above'} 1.2); the "
            f"binding adds {over:.3f} ms per ask + tell ({'below' if over < 0.2 else 'above'} "
            "0.2 ms)."]
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    sys.exit(doc_block.table_main(render, "bench_learner", "bench_learner_table.py",
                                  os.path.join(ROOT, "docs", "data", "bench_learner.csv"),
                                  [os.path.join(ROOT, "docs", "benchmarks.md")]))
