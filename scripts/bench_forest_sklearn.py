#!/usr/bin/env python3
"""Benchmark helper for scripts/bench_forest.sh: data, scikit-learn runs, table.

  gen   --n N --d D --seed S --out FILE   write N rows x0..x{D-1},y
  fit   TRAIN TEST --trees M --n-min N --n-c C --cuts K --seed S
        fit sklearn's ExtraTreesRegressor, print one key=value line
  table RESULTS.csv                        print the markdown tables

Target (the same as tests/bench/bench_forest.c --gen): inputs uniform on
[0,1)^D, y = [x0 + x1 > 1] + 0.5 sin(2 pi x0) + 0.2 x_{D-1} + N(0, 0.1^2):
a step across the diagonal, a smooth part and noise.

Mapping of the thesis's parameters onto ExtraTreesRegressor:
  M      -> n_estimators = M; bootstrap=False, n_jobs=1 (one core, all data)
  n_min  -> min_samples_split = n_min + 1 (ours: split while a node holds
            more than n_min samples; sklearn: split if it holds at least
            min_samples_split)
  n_c    -> min_samples_leaf = n_c (both drop a cut leaving a smaller child)
  K      -> max_features = min(K, D) / D. Not the same draw: ours takes K
            (dimension, threshold) pairs, dimensions with replacement by
            default; sklearn takes min(K, D) distinct dimensions with one
            threshold each. Our forest.replacement=without with K = D is the
            same draw as max_features = 1.0.
  score  -> criterion="squared_error" (variance reduction, eq. 4.1)
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import csv
import math
import resource
import statistics
import sys
import time
from collections import defaultdict


def peak_kb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def gen(args):
    import numpy as np
    rng = np.random.default_rng(args.seed)
    x = rng.random((args.n, args.d))
    y = ((x[:, 0] + x[:, 1 % args.d] > 1.0).astype(float) + 0.5 * np.sin(2 * math.pi * x[:, 0])
         + 0.2 * x[:, args.d - 1] + rng.normal(0.0, 0.1, args.n))
    head = ",".join([f"x{j}" for j in range(args.d)] + ["y"])
    np.savetxt(args.out, np.column_stack([x, y]), fmt="%.17g", delimiter=",", header=head,
               comments="")


def fit(args):
    import numpy as np
    from sklearn.ensemble import ExtraTreesRegressor
    base = peak_kb()
    tr = np.loadtxt(args.train, delimiter=",", skiprows=1)
    te = np.loadtxt(args.test, delimiter=",", skiprows=1)
    X, y, Xt, yt = tr[:, :-1], tr[:, -1], te[:, :-1], te[:, -1]
    d = X.shape[1]
    m = ExtraTreesRegressor(n_estimators=args.trees, min_samples_split=args.n_min + 1,
                            min_samples_leaf=args.n_c, max_features=min(args.cuts, d) / d,
                            bootstrap=False, n_jobs=1, random_state=args.seed)
    t0, c0 = time.perf_counter(), time.process_time()
    m.fit(X, y)
    tfit, cfit = time.perf_counter() - t0, time.process_time() - c0
    t0 = time.perf_counter()
    p = m.predict(Xt)
    tpred = time.perf_counter() - t0
    leaves = sum(e.tree_.n_leaves for e in m.estimators_)
    mse = float(np.mean((p - yt) ** 2))
    print(f"fit={tfit:.6f} fit_cpu={cfit:.6f} predict={tpred:.6f} mse={mse:.8g} "
          f"leaves={leaves} maxrss_kb={peak_kb()} base_kb={base} n={len(y)} d={d}")


def fmt(v, digits=3):
    return f"{v:.{digits}g}"


def mean_sd(v, digits=3):
    if len(v) == 1:
        return fmt(v[0], digits)
    return f"{fmt(statistics.mean(v), digits)} ± {fmt(statistics.stdev(v), 2)}"


def table(args):
    runs = defaultdict(list)
    with open(args.results, newline="") as f:
        for r in csv.DictReader(f):
            runs[(int(r["n"]), int(r["d"]), r["tool"])].append(r)
    tools = ["ours_K10", "ours_Kd", "sklearn"]
    keys = sorted({(n, d) for n, d, _ in runs})

    def col(n, d, tool, field):
        return [float(r[field]) for r in runs.get((n, d, tool), [])]

    print("Fit time: CPU seconds of the fitting call (process time; wall times are in the "
          "raw CSV), mean ± std over seeds; speed-up = sklearn / ours. Predict: wall "
          "seconds for the 10000 test rows.\n")
    print("| n | d | seeds | fit ours K=10 | fit ours K=d w/o repl. | fit sklearn "
          "| speed-up K=10 | speed-up K=d | predict ours | predict sklearn |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for n, d in keys:
        f = {t: col(n, d, t, "fit_cpu") for t in tools}
        if not all(f.values()):
            continue
        sk = statistics.mean(f["sklearn"])
        print(f"| {n} | {d} | {len(f['sklearn'])} | {mean_sd(f['ours_K10'])} "
              f"| {mean_sd(f['ours_Kd'])} | {mean_sd(f['sklearn'])} "
              f"| {sk / statistics.mean(f['ours_K10']):.1f}x "
              f"| {sk / statistics.mean(f['ours_Kd']):.1f}x "
              f"| {mean_sd(col(n, d, 'ours_K10', 'predict'))} "
              f"| {mean_sd(col(n, d, 'sklearn', 'predict'))} |")
    print("\nTest MSE (10000 test rows; mean ± std over seeds) and peak resident memory "
          "(MiB; sklearn also after subtracting the interpreter and imports).\n")
    print("| n | d | MSE ours K=10 | MSE ours K=d | MSE sklearn | peak ours K=10 "
          "| peak ours K=d | peak sklearn | sklearn above imports |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n, d in keys:
        mse = {t: col(n, d, t, "mse") for t in tools}
        rss = {t: col(n, d, t, "maxrss_kb") for t in tools}
        if not all(mse.values()):
            continue
        above = [a - b for a, b in zip(rss["sklearn"], col(n, d, "sklearn", "base_kb"))]
        print(f"| {n} | {d} | {mean_sd(mse['ours_K10'], 4)} | {mean_sd(mse['ours_Kd'], 4)} "
              f"| {mean_sd(mse['sklearn'], 4)} | {max(rss['ours_K10']) / 1024:.0f} "
              f"| {max(rss['ours_Kd']) / 1024:.0f} | {max(rss['sklearn']) / 1024:.0f} "
              f"| {max(above) / 1024:.0f} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("gen")
    g.add_argument("--n", type=int, required=True)
    g.add_argument("--d", type=int, required=True)
    g.add_argument("--seed", type=int, required=True)
    g.add_argument("--out", required=True)
    f = sub.add_parser("fit")
    f.add_argument("train")
    f.add_argument("test")
    f.add_argument("--trees", type=int, default=30)
    f.add_argument("--n-min", type=int, default=20)
    f.add_argument("--n-c", type=int, default=1)
    f.add_argument("--cuts", type=int, default=10)
    f.add_argument("--seed", type=int, default=1)
    t = sub.add_parser("table")
    t.add_argument("results")
    args = ap.parse_args()
    {"gen": gen, "fit": fit, "table": table}[args.cmd](args)


if __name__ == "__main__":
    sys.exit(main())
