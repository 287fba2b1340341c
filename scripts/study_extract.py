#!/usr/bin/env python3
"""The compact results of the verdict study, from its run folders.

Usage: study_extract.py [--exp3|--extend] OUT DATA
  --exp3: the holdout, Experiment 3 only (scripts/holdout.sh)
  --extend: more Experiment 3 repetitions added to DATA (scripts/study_extend.sh)

OUT is what scripts/study.sh writes: OUT/power/ARM (merged Experiment 3 arms),
OUT/seeds/ARM/exp1 and OUT/seeds/ARM/exp2 (collected seed sweeps per physics
arm), OUT/timing.csv.
DATA receives only what scripts/verdicts.py needs, each file replaced whole:
  manifest.csv     experiment, unit (arm, or arm/seed), key, value: every
                   unit's effective configuration and the version that ran it
  exp3_runs.csv    one row per (arm, policy, repetition): last episodes' mean
                   and SD of the returns, balls in pockets 2 and 5, median cue
                   speed, mean distance of the balls not in a target pocket
  exp3_curves.csv  mean return of every iteration of every run (Fig. 7.7)
  exp1_mse.csv     arm, seed, forest, sweep, value, test MSE
  exp1_map.csv     per arm and seed: grid positions, pocketed positions (return
                   0), the forests' mean prediction there, RMS error elsewhere
  exp2_returns.csv arm, seed, repetition, size, policy, mode, mean return,
                   pocketed share
  sphere_curves.csv method, repetition, iteration, samples, test return of the
                   contextual sphere benchmark (OUT/sphere/METHOD, the README's
                   sentence on it and the bench_sphere figure's plateau)
  timing.csv       wall and CPU seconds of each phase
Exit codes: 1 usage, 2 missing or malformed input.
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import configparser
import csv
import glob
import math
import os
import sys
from collections import defaultdict

import power_stats as ps

ARMS = ps.ARMS


def fail(msg):
    print(f"study_extract: {msg}", file=sys.stderr)
    sys.exit(2)


def read_rows(path, need):
    try:
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            missing = [c for c in need if c not in (reader.fieldnames or [])]
            if missing:
                fail(f"{path}:1: no column {missing[0]}")
            return list(reader)
    except OSError as e:
        fail(f"{path}: {e.strerror}")


def config_items(folder):
    cfg = configparser.ConfigParser(inline_comment_prefixes=(";",), interpolation=None)
    path = os.path.join(folder, "config.ini")
    if not cfg.read(path, encoding="utf-8"):
        fail(f"{path}: missing or unreadable")
    items = [(f"{s}.{k}", v) for s in cfg.sections() for k, v in cfg.items(s)]
    items.append(("version", ps.provenance(os.path.join(folder, "provenance.txt"))
                  .get("version", "?")))
    return items


def seed_points(sweep):
    """{seed: merged folder} of a collected seed sweep."""
    points = {}
    for d in sorted(glob.glob(os.path.join(sweep, "point-*", "merged"))):
        cfg = configparser.ConfigParser(inline_comment_prefixes=(";",), interpolation=None)
        cfg.read(os.path.join(d, "config.ini"), encoding="utf-8")
        points[cfg.getint("experiment", "seed")] = d
    if not points:
        fail(f"{sweep}: no collected points (point-K/merged)")
    return points


def cpu(folders):
    """CPU seconds summed over run folders' provenance."""
    return sum(float(ps.provenance(os.path.join(f, "provenance.txt")).get("cpu_seconds", "nan"))
               for f in folders)


def g(x):
    return f"{x:.10g}" if isinstance(x, float) else str(x)


def write(path, header, rows):
    tmp = f"{path}.tmp.{os.getpid()}"
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        w.writerows([[g(v) for v in r] for r in rows])
    return tmp, path


def exp3(out):
    runs, curves, manifest, cpu_s = [], [], [], 0.0
    for name in ARMS:
        try:
            a = ps.Arm(name, os.path.join(out, "power", name))
        except ps.Fail as e:
            fail(str(e))
        manifest += [("exp3", name, k, v) for k, v in config_items(a.folder)]
        cpu_s += ps.cpu_seconds(a)
        arm_rows(a, runs, curves)
    return runs, curves, manifest, cpu_s, len(curves[0]) - 3


def arm_rows(a, runs, curves):
    """Append an arm's per-run rows to runs and curves."""
    i2, i5 = ps.POCKETS.index(2), ps.POCKETS.index(5)
    for p in a.policies:
        i = a.row(p)
        for j, r in enumerate(a.reps):
            runs.append([a.name, p, r, float(a.ret[i, j]), float(a.sd[i, j]),
                         int(a.target[i, j]), int(a.counts[i, j, i2]),
                         int(a.counts[i, j, i5]), float(a.speed[i, j]),
                         float(a.miss_dist[i, j])])
            curves.append([a.name, p, r] + [float(x) for x in a.curve[i, j]])


def arm_points(out, exp):
    """[(arm, seed, merged folder)] of an experiment's seed sweeps, arm by arm."""
    return [(a, seed, d) for a in ARMS
            for seed, d in sorted(seed_points(os.path.join(out, "seeds", a, exp)).items())]


def exp1(out):
    points = arm_points(out, "exp1")
    mse, maps, manifest = [], [], []
    for arm, seed, d in points:
        manifest += [("exp1", f"{arm}/{seed}", k, v) for k, v in config_items(d)]
        for r in read_rows(os.path.join(d, "exp1_mse.csv"),
                           ("repetition", "sweep", "n_min", "trees", "cuts", "mse")):
            col = {"n_min": "n_min", "trees": "trees", "cuts": "cuts"}[r["sweep"]]
            mse.append([arm, seed, int(r["repetition"]), r["sweep"], int(r[col]), float(r["mse"])])
        pred, reward = defaultdict(list), {}
        for r in read_rows(os.path.join(d, "exp1_map.csv"), ("x1", "y1", "reward", "pred")):
            pred[(r["x1"], r["y1"])].append(float(r["pred"]))
            reward[(r["x1"], r["y1"])] = float(r["reward"])
        mean = {k: sum(v) / len(v) for k, v in pred.items()}
        pocketed = [k for k in mean if reward[k] == 0]
        rest = [k for k in mean if reward[k] != 0]
        if not pocketed or not rest:
            fail(f"{d}/exp1_map.csv: no pocketed (or no other) grid positions")
        under = sum(mean[k] for k in pocketed) / len(pocketed)
        rms = math.sqrt(sum((mean[k] - reward[k]) ** 2 for k in rest) / len(rest))
        maps.append([arm, seed, len(mean), len(pocketed), under, rms])
    return mse, maps, manifest, points


def exp2(out):
    points = arm_points(out, "exp2")
    rows, manifest = [], []
    for arm, seed, d in points:
        manifest += [("exp2", f"{arm}/{seed}", k, v) for k, v in config_items(d)]
        for r in read_rows(os.path.join(d, "exp2_returns.csv"),
                           ("repetition", "size", "policy", "mode", "mean_return", "pocketed")):
            rows.append([arm, seed, int(r["repetition"]), int(r["size"]), r["policy"], r["mode"],
                         float(r["mean_return"]), float(r["pocketed"])])
    return rows, manifest, points


SPHERE = ("creps_old", "creps_new", "ccmaes")


def sphere(out):
    rows, manifest = [], []
    for method in SPHERE:
        d = os.path.join(out, "sphere", method)
        manifest += [("sphere", method, k, v) for k, v in config_items(d)]
        for r in read_rows(os.path.join(d, "bench_curve.csv"),
                           ("repetition", "iteration", "samples", "test_return")):
            rows.append([method, int(r["repetition"]), int(r["iteration"]), int(r["samples"]),
                         float(r["test_return"])])
    return rows, manifest


def seed_cpu(points):
    return cpu(f for _, _, d in points
               for f in glob.glob(os.path.join(os.path.dirname(d), "runs", "rep-*")))


def exp3_files(data, runs, curves, iters):
    """The staged Experiment 3 files: exp3_runs.csv and exp3_curves.csv."""
    return [
        write(os.path.join(data, "exp3_runs.csv"),
              ["arm", "policy", "repetition", "mean_return", "sd_return", "target", "pocket2",
               "pocket5", "median_speed", "miss_distance"], runs),
        write(os.path.join(data, "exp3_curves.csv"),
              ["arm", "policy", "repetition"] + [f"i{k}" for k in range(1, iters + 1)], curves),
    ]


def holdout(out, data):
    """--exp3: the holdout's files (scripts/holdout.sh), Experiment 3 only."""
    runs, curves, m3, cpu3, iters = exp3(out)
    wall = {r["phase"]: r for r in read_rows(os.path.join(out, "timing.csv"),
                                             ("phase", "wall_seconds", "jobs"))}
    os.makedirs(data, exist_ok=True)
    staged = exp3_files(data, runs, curves, iters) + [
        write(os.path.join(data, "manifest.csv"), ["experiment", "unit", "key", "value"], m3),
        write(os.path.join(data, "timing.csv"), ["phase", "wall_seconds", "cpu_seconds", "jobs"],
              [["exp3", float(wall["exp3"]["wall_seconds"]), cpu3, wall["exp3"]["jobs"]]])]
    for tmp, path in staged:
        os.replace(tmp, path)
    return 0


SAME_BUT = ("experiment.repetitions", "experiment.repetition", "version")
EXT_COLS = ("from", "to", "version", "cpu_seconds")


def extend(out, data):
    """--extend: more repetitions of the study's Experiment 3 (same seed and
    configuration), one job folder each (OUT/ARM/point-0/runs/rep-K), added to
    DATA's exp3_runs.csv and exp3_curves.csv. A repetition DATA already has
    must come out identical (the check that the binary still gives the
    study's runs); the repetitions must end up 0..N-1 in every arm. A key
    added to poolreps after the study ran (none of its runs has it) is taken
    at the one value every new run of the arm has, when repetition 0 of
    every policy comes out identical (so the key changed nothing), and is
    recorded in the manifest."""
    p = lambda name: os.path.join(data, name)  # noqa: E731
    runs = read_rows(p("exp3_runs.csv"), ("arm", "policy", "repetition"))
    curves = read_rows(p("exp3_curves.csv"), ("arm", "policy", "repetition"))
    manifest = read_rows(p("manifest.csv"), ("experiment", "unit", "key", "value"))
    unit = {(r["unit"], r["key"]): r["value"] for r in manifest if r["experiment"] == "exp3"}
    have = {(r["arm"], r["policy"], r["repetition"]): [r[c] for c in r] for r in runs}
    new_runs, new_curves, cpu_s, versions = [], [], 0.0, set()
    added, checked = {}, set()
    for name in ARMS:
        folders = sorted(glob.glob(os.path.join(out, name, "point-0", "runs", "rep-*")))
        if not folders:
            fail(f"{os.path.join(out, name)}: no job folders point-0/runs/rep-K")
        for f in folders:
            for k, v in config_items(f):
                if (name, k) not in unit and k not in SAME_BUT:
                    if added.setdefault((name, k), v) != v:
                        fail(f"{f}/config.ini: {k} = {v}, other new runs have "
                             f"{added[(name, k)]}")
                elif k not in SAME_BUT and unit.get((name, k)) != v:
                    fail(f"{f}/config.ini: {k} = {v}, the study has {unit.get((name, k))}")
                if k == "version":
                    versions.add(v)
            try:
                a = ps.Arm(name, f, min_reps=1)
            except ps.Fail as e:
                fail(str(e))
            cpu_s += cpu([f])
            rs, cs = [], []
            arm_rows(a, rs, cs)
            for r, c in zip(rs, cs):
                key = (name, r[1], str(r[2]))
                if key in have:
                    if [g(v) for v in r] != have[key]:
                        fail(f"{f}: repetition {r[2]} of {r[1]} differs from the study's")
                    checked.add(key)
                    continue
                new_runs.append(r)
                new_curves.append(c)
    reps = {(r["arm"], r["policy"]) for r in runs}
    if added and not {(a, q, "0") for a, q in reps} <= checked:
        fail(f"{out}: keys the study lacks ({', '.join(sorted({k for _, k in added}))}) "
             "need repetition 0 of every policy rerun, to show they change nothing")
    count = {k: sum(1 for r in runs if (r["arm"], r["policy"]) == k) for k in reps}
    for r in new_runs:
        count[(r[0], r[1])] += 1
    total = set(count.values())
    if len(total) != 1:
        fail(f"{out}: the arms would have different repetition counts {sorted(total)}")
    n = total.pop()
    got = {(r["arm"], r["policy"], int(r["repetition"])) for r in runs} | \
        {(r[0], r[1], r[2]) for r in new_runs}
    if got != {(a, q, k) for a, q in reps for k in range(n)}:
        fail(f"{out}: the repetitions would not be 0..{n - 1} in every arm")
    old = {v for (u, k), v in unit.items() if k == "version"}
    version = "; ".join(sorted(old | versions))
    rows_m = [[r["experiment"], r["unit"], r["key"],
               str(n) if r["experiment"] == "exp3" and r["key"] == "experiment.repetitions"
               else version if r["experiment"] == "exp3" and r["key"] == "version"
               else r["value"]] for r in manifest]
    for (u, k), v in sorted(added.items(), reverse=True):  # after the unit's last key
        at = max(i for i, r in enumerate(rows_m) if r[:2] == ["exp3", u])
        rows_m.insert(at + 1, ["exp3", u, k, v])
    wall = {r["phase"]: r for r in read_rows(os.path.join(out, "timing.csv"),
                                             ("phase", "wall_seconds"))}
    timing = [[r["phase"], r["wall_seconds"], r["cpu_seconds"], r["jobs"]]
              for r in read_rows(p("timing.csv"), ("phase", "wall_seconds", "cpu_seconds"))]
    for t in timing:
        if t[0] == "exp3":
            t[1] = float(t[1]) + float(wall["exp3"]["wall_seconds"])
            t[2] = float(t[2]) + cpu_s
    # the record of each extension: verdicts.py judges the last one's repetitions
    # alone, a sample whose size, not whose data, the earlier look chose
    ext = [[r["from"], r["to"], r["version"], r["cpu_seconds"]]
           for r in (read_rows(p("extensions.csv"), EXT_COLS)
                     if os.path.exists(p("extensions.csv")) else [])]
    ext.append([1 + max(int(r["repetition"]) for r in runs), n, "; ".join(sorted(versions)),
                cpu_s])
    staged = [
        write(p("exp3_runs.csv"), list(runs[0]), [list(r.values()) for r in runs] + new_runs),
        write(p("exp3_curves.csv"), list(curves[0]),
              [list(r.values()) for r in curves] + new_curves),
        write(p("manifest.csv"), ["experiment", "unit", "key", "value"], rows_m),
        write(p("timing.csv"), ["phase", "wall_seconds", "cpu_seconds", "jobs"], timing),
        write(p("extensions.csv"), EXT_COLS, ext)]
    for tmp, path in staged:
        os.replace(tmp, path)
    return 0


def main():
    if len(sys.argv) == 4 and sys.argv[1] == "--exp3":
        return holdout(*sys.argv[2:])
    if len(sys.argv) == 4 and sys.argv[1] == "--extend":
        return extend(*sys.argv[2:])
    if len(sys.argv) != 3:
        print("usage: study_extract.py [--exp3|--extend] OUT DATA", file=sys.stderr)
        return 1
    out, data = sys.argv[1:]
    runs, curves, m3, cpu3, iters = exp3(out)
    mse, maps, m1, p1 = exp1(out)
    ret2, m2, p2 = exp2(out)
    sph, ms = sphere(out)
    wall = {r["phase"]: r for r in read_rows(os.path.join(out, "timing.csv"),
                                             ("phase", "wall_seconds", "jobs"))}
    timing = [["exp3", float(wall["exp3"]["wall_seconds"]), cpu3, wall["exp3"]["jobs"]],
              ["exp12", float(wall["exp12"]["wall_seconds"]), seed_cpu(p1) + seed_cpu(p2),
               wall["exp12"]["jobs"]],
              ["sphere", float(wall["sphere"]["wall_seconds"]),
               cpu(os.path.join(out, "sphere", m) for m in SPHERE), wall["sphere"]["jobs"]]]
    os.makedirs(data, exist_ok=True)
    staged = exp3_files(data, runs, curves, iters) + [
        write(os.path.join(data, "manifest.csv"), ["experiment", "unit", "key", "value"],
              m3 + m1 + m2 + ms),
        write(os.path.join(data, "exp1_mse.csv"), ["arm", "seed", "forest", "sweep", "value", "mse"],
              mse),
        write(os.path.join(data, "exp1_map.csv"),
              ["arm", "seed", "positions", "pocketed", "pred_pocketed", "rms_rest"], maps),
        write(os.path.join(data, "exp2_returns.csv"),
              ["arm", "seed", "repetition", "size", "policy", "mode", "mean_return",
               "pocketed"], ret2),
        write(os.path.join(data, "sphere_curves.csv"),
              ["method", "repetition", "iteration", "samples", "test_return"], sph),
        write(os.path.join(data, "timing.csv"), ["phase", "wall_seconds", "cpu_seconds", "jobs"],
              timing),
    ]
    for tmp, path in staged:
        os.replace(tmp, path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
