#!/usr/bin/env python3
"""Table and sentence on scripts/bench_vector.sh's CSV (default
docs/bench_vector.csv): steps/s of the native vector env against
SyncVectorEnv, and the cost of per-row physics parameters in
poolreps.shoot. Each ratio is the median over the rounds of that round's
ratio (both measured in the same round, so under the same load).

  bench_vector_table.py [CSV]            print it
  bench_vector_table.py --write [CSV]    put it into docs/python.md, between
                                         the bench_vector markers
  bench_vector_table.py --check [CSV]    exit 1 if it differs"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import os
import statistics
import sys

import doc_block

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOCS = [os.path.join(ROOT, "docs", "python.md")]
NAMES = {"native": "native (`vector_entry_point`)", "native1": "native, `threads=1`",
         "sync": "`SyncVectorEnv`",
         "plain": "`shoot`", "params": "`shoot(params=...)`, 2 keys per row"}


def render(rows):
    rate = {(r["workload"], int(r["envs"]), r["kind"], int(r["round"])): float(r["steps_per_s"])
            for r in rows}
    load = [float(r["load1"]) for r in rows]
    groups = sorted({k[:3] for k in rate}, key=lambda k: (k[0] == "shoot", k[0], k[1], k[2]))
    rounds = {g: sorted(k[3] for k in rate if k[:3] == g) for g in groups}
    out = ["| workload | envs (rows) | what | median steps/s | ratio, median of rounds |",
           "|---|---:|---|---:|---:|"]
    ratios = {}
    for w, n, kind in groups:
        other = {"native": "sync", "native1": "sync", "params": "plain"}.get(kind)
        med = statistics.median(rate[(w, n, kind, r)] for r in rounds[(w, n, kind)])
        cell = ""
        if other and (w, n, other) in rounds:
            both = [r for r in rounds[(w, n, kind)] if (w, n, other, r) in rate]
            q = [rate[(w, n, kind, r)] / rate[(w, n, other, r)] for r in both]
            ratios[(w, n, kind)] = statistics.median(q)
            cell = f"{ratios[(w, n, kind)]:.3g} × {NAMES[other]}"
        out.append(f"| {w} | {n:,} | {NAMES[kind]} | {med:,.0f} | {cell} |")
    n_rounds = max(len(v) for v in rounds.values())
    cpus = max(int(r.get("threads") or 1) for r in rows)  # the native env's threads=0
    text = "\n".join(out) + "\n\n"
    text += (f"{n_rounds} rounds of `scripts/bench_vector.sh`, 1-minute load average "
             f"{min(load):.1f} to {max(load):.1f} on {cpus} CPUs during the run.")
    g = ratios.get(("gauss", 256, "native"))
    if g is not None:
        threads = {int(r.get("threads") or 1) for r in rows if r["kind"] == "native"}
        text += (f" At 256 envs the native vector env ({'/'.join(map(str, sorted(threads)))} "
                 f"threads) steps {g:.0f} times as fast as `SyncVectorEnv` on the gauss "
                 f"workload, {ratios[('uniform', 256, 'native')]:.0f} times on the uniform one "
                 f"(its faster shots spend more of each step in the simulator).")
        one = ratios.get(("uniform", 256, "native1"))
        if one is not None:
            text += f" With one thread the uniform workload's ratio is {one:.0f}."
    p = ratios.get(("shoot", max(k[1] for k in ratios if k[0] == "shoot"), "params")) \
        if any(k[0] == "shoot" for k in ratios) else None
    if p is not None:
        text += (f" Per-row friction and restitution make `shoot` {1 / p:.2f} times as slow "
                 f"as the plain batch.")
    return text + "\n"


if __name__ == "__main__":
    sys.exit(doc_block.table_main(render, "bench_vector", "bench_vector_table.py",
                                  os.path.join(ROOT, "docs", "bench_vector.csv"), DOCS))
