#!/usr/bin/env python3
"""Readers of poolreps result folders, shared by the plot scripts,
scripts/claims.py and scripts/report.py (standard library only; Experiment 3's
episodes: scripts/exp3_table.py).

    rows = read_csv(path, need=("a", "b"))  # list of dicts, one-line error if unreadable
    cfg = config(DIR)                       # DIR/config.ini
    geo = table_geometry(cfg)               # table size, pockets, targets, cue position
    by_sweep, by_setting = exp1_mse(DIR)    # exp1_mse.csv, per forest (repetition)
    ref, src = exp1_reference("cuts", by_sweep["cuts"], by_setting, exp1_default(cfg))
    ret = exp2_returns(DIR)                 # exp2_returns.csv, per repetition
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import configparser
import csv
import os
import sys
from collections import defaultdict

SWEEP_INDEX = {"n_min": 0, "trees": 1, "cuts": 2}
# a log-scale figure's floor, and the stem of the study's seed-spread figure:
# the text generators use them without importing matplotlib
TINY = 1e-300
STUDY_SEEDS_STEM = "study_seeds"


def read_csv(path, need=()):
    """Rows of a CSV with a header, as dicts; stop with one line naming the
    file if it cannot be read or lacks a column of need."""
    prog = os.path.basename(sys.argv[0] or "poolreps")
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            missing = [c for c in need if c not in (reader.fieldnames or [])]
            if missing:
                sys.exit(f"{prog}: {path}: missing column {missing[0]!r}")
            return list(reader)
    except OSError as e:
        sys.exit(f"{prog}: {path}: {e.strerror}")


def config(directory):
    """DIR/config.ini as a ConfigParser (empty when missing)."""
    c = configparser.ConfigParser(inline_comment_prefixes=(";",))
    c.read(os.path.join(directory, "config.ini"))
    return c


def table_geometry(cfg):
    """Table geometry from a config: dict length, width, ball_radius,
    pocket_radius, targets (ids), pockets {id: (x, y)}, cue (the centre of
    start.cue_box)."""
    L = cfg.getfloat("table", "length", fallback=1.0)
    W = cfg.getfloat("table", "width", fallback=0.5)
    box = [float(v) for v in cfg.get("start", "cue_box", fallback="-0.25,-0.25,0,0").split(",")]
    return {
        "cue": ((box[0] + box[1]) / 2, (box[2] + box[3]) / 2),
        "length": L, "width": W,
        "ball_radius": cfg.getfloat("table", "ball_radius", fallback=0.015),
        "pocket_radius": cfg.getfloat("table", "pocket_radius", fallback=0.03),
        "targets": [int(x) for x in cfg.get("reward", "targets", fallback="2,5").split(",")],
        # ids 0,1,2 along y = -W/2, 3,4,5 along y = +W/2; x = -L/2, 0, +L/2
        "pockets": {i: ((i % 3 - 1) * L / 2, (-1 if i < 3 else 1) * W / 2) for i in range(6)},
    }


def exp1_default(cfg):
    """The default forest setting (n_min, trees, cuts) of an Experiment 1 run."""
    return (cfg.getint("forest", "n_min", fallback=20), cfg.getint("forest", "trees", fallback=30),
            cfg.getint("forest", "cuts", fallback=10))


def exp1_mse(directory):
    """From DIR/exp1_mse.csv: {sweep: {value: {repetition: mse}}} and
    {(sweep, (n_min, trees, cuts)): {repetition: mse}}. Repetition k is forest
    k: the same training and test subsets in every sweep."""
    by_sweep = defaultdict(lambda: defaultdict(dict))
    by_setting = defaultdict(dict)
    for r in read_csv(os.path.join(directory, "exp1_mse.csv"),
                   ("repetition", "sweep", "n_min", "trees", "cuts", "mse")):
        rep, mse = int(r["repetition"]), float(r["mse"])
        setting = (int(r["n_min"]), int(r["trees"]), int(r["cuts"]))
        by_sweep[r["sweep"]][setting[SWEEP_INDEX[r["sweep"]]]][rep] = mse
        by_setting[(r["sweep"], setting)][rep] = mse
    return by_sweep, by_setting


def exp1_reference(sweep, values, by_setting, default):
    """({repetition: mse}, source) of the default setting for sweep's paired
    differences: this sweep's own forests when it ran the default value
    (source = sweep), else those of the first other sweep that ran the default
    setting (same subsets, other forest draws; source = that sweep), else
    (None, None)."""
    dv = default[SWEEP_INDEX[sweep]]
    if dv in values:
        return values[dv], sweep
    for (other, setting), mse in sorted(by_setting.items()):
        if setting == default:
            return mse, other
    return None, None


def exp1_map(directory):
    """Rows of DIR/exp1_map.csv: repetition, x1, y1, reward, pred."""
    return read_csv(os.path.join(directory, "exp1_map.csv"),
                    ("repetition", "x1", "y1", "reward", "pred"))


def exp2_returns(directory):
    """From DIR/exp2_returns.csv: {(size, policy, mode): {repetition:
    (mean_return, pocketed)}}; the expert is (0, "expert", "mean")."""
    out = defaultdict(dict)
    for r in read_csv(os.path.join(directory, "exp2_returns.csv"),
                   ("repetition", "size", "policy", "mode", "mean_return", "pocketed")):
        out[(int(r["size"]), r["policy"], r["mode"])][int(r["repetition"])] = \
            (float(r["mean_return"]), float(r["pocketed"]))
    return out


if __name__ == "__main__":
    print(__doc__)


def plateau(series):
    """The plateau a benchmark figure marks: per iteration the median over the
    runs (cut to the shortest run), then the median of that curve's last tenth
    of iterations. Returns (plateau, median curve). README text uses it too."""
    import numpy as np  # here: the plot scripts import this module before figstyle
    n = min(len(y) for y in series)
    med = np.median(np.array([np.asarray(y)[:n] for y in series]), axis=0)
    return float(np.median(med[-max(1, n // 10):])), med
