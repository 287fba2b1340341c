#!/usr/bin/env python3
"""forest.replacement = without with K = d against scikit-learn's
ExtraTreesRegressor(max_features=1.0) on inputs that are constant in many
nodes (docs/forest.md, "Constant columns").

  run BIN [PREV_BIN]  (a Python with scikit-learn and numpy, e.g.
      build/bench-venv/bin/python): 20 seeded data sets, n = 2000 training
      and 5000 test rows, d = 6 inputs: x0, x1, x5 uniform on [0, 1), x2 in
      {0, 1}, x3 = 0 everywhere, x4 in {0, 1, 2}; y = [x0 + x1 > 1]
      + 0.5 sin(2 pi x0) + 0.5 x2 + 0.2 x4 + N(0, 0.1^2). M = 30, n_min = 20,
      n_c = 1, K = d without replacement; sklearn with n_estimators = 30,
      min_samples_split = 21, min_samples_leaf = 1, bootstrap = False.
      Writes docs/data/forest_constant_columns.csv (tool, seed, test MSE).
  --write / --check  (numpy only): the forest_constant block of
      docs/forest.md from that CSV.

The rule, stated before computing it: per tool, the mean over the 20 seeds
of test MSE / sklearn's test MSE on the same data set, with a 95 % t
interval over the seeds; the tools agree when the interval holds 1."""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import csv
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CSV = os.path.join(ROOT, "docs", "data", "forest_constant_columns.csv")
DOC = os.path.join(ROOT, "docs", "forest.md")
SEEDS = range(20)
# 97.5 % quantile of Student's t with 19 degrees of freedom
T19 = 2.093


def data(seed, n):
    rng = np.random.default_rng([38, seed, n])
    X = np.c_[rng.uniform(size=(n, 2)), rng.integers(0, 2, n), np.zeros(n),
              rng.integers(0, 3, n), rng.uniform(size=n)]
    y = ((X[:, 0] + X[:, 1] > 1) + 0.5 * np.sin(2 * np.pi * X[:, 0]) + 0.5 * X[:, 2]
         + 0.2 * X[:, 4] + rng.normal(0, 0.1, n))
    return X, y


def write(path, X, y=None):
    cols = [f"x{j}" for j in range(X.shape[1])] + ([] if y is None else ["y"])
    M = X if y is None else np.c_[X, y]
    with open(path, "w") as f:
        f.write(",".join(cols) + "\n")
        for r in M:
            f.write(",".join(repr(float(v)) for v in r) + "\n")


def ours(binary, tmp, seed, yt):
    out = os.path.join(tmp, "pred.csv")
    subprocess.run([binary, "forest", "--train", os.path.join(tmp, "train.csv"), "--test",
                    os.path.join(tmp, "test.csv"), "--target", "y", "-o", out, "-q",
                    "--seed", str(seed), "--set", "forest.trees=30", "--set", "forest.n_min=20",
                    "--set", "forest.n_c=1", "--set", "forest.cuts=6",
                    "--set", "forest.replacement=without"], check=True)
    return float(np.mean((np.loadtxt(out, skiprows=1) - yt) ** 2))


def run(bins):
    from sklearn.ensemble import ExtraTreesRegressor
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in SEEDS:
            X, y = data(seed, 2000)
            Xt, yt = data(seed + 1000, 5000)
            write(os.path.join(tmp, "train.csv"), X, y)
            write(os.path.join(tmp, "test.csv"), Xt)
            for tool, b in bins:
                rows.append((tool, seed, ours(b, tmp, seed, yt)))
            et = ExtraTreesRegressor(n_estimators=30, max_features=1.0, min_samples_split=21,
                                     min_samples_leaf=1, bootstrap=False, n_jobs=1,
                                     random_state=seed).fit(X, y)
            rows.append(("sklearn", seed, float(np.mean((et.predict(Xt) - yt) ** 2))))
    with open(CSV, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["tool", "seed", "mse"])
        for tool, seed, mse in rows:
            w.writerow([tool, seed, repr(mse)])


def block():
    with open(CSV) as f:
        rows = list(csv.DictReader(f))
    mse = {}
    for r in rows:
        mse.setdefault(r["tool"], {})[int(r["seed"])] = float(r["mse"])
    sk = mse.pop("sklearn")
    lines = ["| tool | seeds | mean test MSE | MSE / sklearn's, mean | 95 % interval | agrees |",
             "|---|---:|---:|---:|---|---|"]
    for tool in sorted(mse):
        ratio = np.array([mse[tool][s] / sk[s] for s in sorted(sk)])
        mean, half = ratio.mean(), T19 * ratio.std(ddof=1) / math.sqrt(len(ratio))
        lines.append(f"| {tool} | {len(ratio)} | {np.mean(list(mse[tool].values())):.5f} | "
                     f"{mean:.4f} | {mean - half:.4f} – {mean + half:.4f} | "
                     f"{'yes' if mean - half <= 1 <= mean + half else 'no'} |")
    lines.append(f"| sklearn | {len(sk)} | {np.mean(list(sk.values())):.5f} | 1 | | |")
    return "\n".join(lines) + "\n"


def main():
    if sys.argv[1] == "run":
        bins = [("poolreps", sys.argv[2])]
        if len(sys.argv) > 3:
            bins.append(("poolreps-previous", sys.argv[3]))
        run(bins)
        return
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import doc_block
    doc_block.update([DOC], "forest_constant", block(), sys.argv[1] == "--check",
                     "bench_forest_constant.py", CSV)


if __name__ == "__main__":
    main()
