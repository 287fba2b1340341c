#!/usr/bin/env python3
"""Markdown tables of Experiment 4 from exp4_verdict.csv (docs/exp4.md).

    exp4_table.py verdict DIR          one row per variant: mean return of the
                                       last episodes ± its standard error, the
                                       paired difference to scratch ± its
                                       standard error, pocket and hit rates,
                                       median cue speed
    exp4_table.py sensitivity NAME=DIR...
                                       one row per folder: per init and
                                       covariance, the mean over the four tree
                                       policies and the baseline of their mean
                                       return, and the hand-crafted policy's

Standard library only (exp_data.read_csv).
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import os
import sys

import exp_data

NEED = ("variant", "policy", "init", "cov", "mean_return", "se_return", "diff_scratch",
        "se_diff", "pocket_rate", "hit_rate", "median_speed")


def rows_of(d):
    return exp_data.read_csv(os.path.join(d, "exp4_verdict.csv"), NEED)


def verdict(d):
    print("| variant (policy.init.cov) | return [m] | vs scratch [m] | pocketed [%] | "
          "hit [%] | median speed [m/s] |")
    print("|---|---:|---:|---:|---:|---:|")
    for r in rows_of(d):
        diff = (f"{float(r['diff_scratch']):+.3f} ± {float(r['se_diff']):.3f}"
                if r["init"] != "scratch" and r["diff_scratch"] else "–")
        print(f"| {r['variant']} | {float(r['mean_return']):.3f} ± {float(r['se_return']):.3f} "
              f"| {diff} | {100 * float(r['pocket_rate']):.1f} | "
              f"{100 * float(r['hit_rate']):.1f} | {float(r['median_speed']):.3f} |")


def sensitivity(pairs):
    cols = [(i, c) for c in ("query", "residual")
            for i in ("scratch", "imitation", "demo", "policy")]
    print("| setting | " + " | ".join(f"{i}, {c}" for i, c in cols) +
          " | hand-crafted imitation | hand-crafted demo | hand-crafted policy |")
    print("|---|" + "---:|" * (len(cols) + 3))
    for name, d in pairs:
        rs = rows_of(d)
        cells = []
        for i, c in cols:
            v = [float(r["mean_return"]) for r in rs if (r["init"], r["cov"]) == (i, c)]
            cells.append(f"{sum(v) / len(v):.3f}" if v else "–")
        for i in ("imitation", "demo", "policy"):
            v = [float(r["mean_return"]) for r in rs
                 if r["policy"] == "handcrafted" and r["init"] == i]
            cells.append(f"{v[0]:.3f}" if v else "–")
        print(f"| {name} | " + " | ".join(cells) + " |")


def main():
    if len(sys.argv) >= 3 and sys.argv[1] == "verdict":
        verdict(sys.argv[2])
    elif len(sys.argv) >= 3 and sys.argv[1] == "sensitivity":
        sensitivity([a.split("=", 1) for a in sys.argv[2:]])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
