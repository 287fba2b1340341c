#!/usr/bin/env python3
"""Print the README's Experiment 3 table (markdown) from DIR/exp3_episodes.csv.

Usage: exp3_table.py DIR [--last N]
       exp3_table.py --compare DEFAULT ARM [ARM ...] [--label NAME ...] [--last N]

Per policy, over each run's last N episodes (default: exp3.final_episodes
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
from DIR/config.ini, else 500): the mean return of all runs pooled, the
SD of the run means, the paired difference to the baseline's run of the
same repetition (mean and 95 % t interval [lo, hi] over repetitions), reward balls
pocketed in pocket 2 / pocket 5 / any other pocket, the hit rate (cue ball
touched the reward ball) and the median cue speed.

--compare: a sensitivity table of result folders run with the same seed and
repetitions as DEFAULT and one changed setting each (ARM). Per arm and
policy both folders hold: the pooled mean return of the last N episodes in
DEFAULT and in ARM, the paired difference ARM - DEFAULT of the per-repetition
means (mean +- standard error of the mean over repetitions, sd / sqrt(n)),
the pocket rates (percent of the pooled last N episodes whose reward ball
went into pocket 2 or 5, and into another pocket; DEFAULT -> ARM), the
median cue speed, the spread of the actions at the end of learning (per
run, sqrt(var vx + var vy) over the episodes of its last iteration, median
over runs; DEFAULT -> ARM), and the policy's paired difference to
the baseline of its own folder (mean +- standard error; DEFAULT -> ARM),
the thesis's comparison. The arm is
labelled by the keys its config.ini sets differently (or --label). Policies
the arm leaves unchanged (every per-repetition mean and pocket count
identical) are named below the table instead of listed.

As a module (standard library only): load() selects the episodes, summary()
computes these numbers per policy; scripts/plot_exp3.py, scripts/claims.py
and scripts/report.py use them.
"""
import argparse
import math
import os
import statistics
import sys
from collections import defaultdict

import exp_data
from figstats import fmt_ci, paired

TARGETS = ("2", "5")
# the thesis's panel order (Figs. 7.7, 7.8 a-d), then the references
ORDER = ("nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a", "baseline", "handcrafted")
TREE_VARIANTS = ORDER[:4]
NEED = ("repetition", "policy", "iteration", "vx", "vy", "return", "rx", "ry", "pocket", "hit")


def final_episodes(directory):
    """exp3.final_episodes of DIR/config.ini (500 when absent)."""
    return exp_data.config(directory).getint("exp3", "final_episodes", fallback=500)


def load(directory, last=None):
    """({(policy, repetition): [episode rows as dicts]}, last): each run's last
    `last` episodes of DIR/exp3_episodes.csv (default exp3.final_episodes)."""
    if last is None:
        last = final_episodes(directory)
    runs = defaultdict(list)
    for row in exp_data.read_csv(os.path.join(directory, "exp3_episodes.csv"), NEED):
        runs[(row["policy"], int(row["repetition"]))].append(row)
    return {key: rows[-last:] for key, rows in runs.items()}, last


def policies(runs):
    """Policies present, in ORDER (unknown names last, as found)."""
    found = list(dict.fromkeys(p for p, _ in runs))
    return [p for p in ORDER if p in found] + [p for p in found if p not in ORDER]


def last_spread(eps):
    """sqrt(var vx + var vy) (sample variances) of the episodes of the last
    iteration among eps, None under two episodes."""
    last = max(int(e["iteration"]) for e in eps)
    v = [(float(e["vx"]), float(e["vy"])) for e in eps if int(e["iteration"]) == last]
    if len(v) < 2:
        return None
    return math.sqrt(statistics.variance(x for x, _ in v) + statistics.variance(y for _, y in v))


def median_or_none(values):
    """The median of the values that are not None, None if there are none."""
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def summary(runs):
    """{policy: stats} with: reps (sorted), episodes (pooled count), mean
    (pooled mean return), run_means {rep: mean}, std_runs (sample std of the
    run means, 0 with one run), paired (run mean minus the baseline's, per
    repetition, [] without a baseline), pockets {pocket id string: count},
    target, other (counts), hit_rate, median_speed (m/s), spread (m/s: the
    median over runs of the spread of the actions of a run's last iteration,
    sqrt(var vx + var vy) with sample variances; None under two episodes)."""
    out = {}
    for p in policies(runs):
        reps = sorted(r for q, r in runs if q == p)
        eps = [e for r in reps for e in runs[(p, r)]]
        run_means = {r: statistics.fmean(float(e["return"]) for e in runs[(p, r)]) for r in reps}
        pk = defaultdict(int)
        for e in eps:
            pk[e["pocket"]] += 1
        out[p] = {
            "reps": reps,
            "episodes": len(eps),
            "mean": statistics.fmean(float(e["return"]) for e in eps),
            "run_means": run_means,
            "std_runs": statistics.stdev(run_means.values()) if len(reps) > 1 else 0.0,
            "pockets": dict(pk),
            "target": sum(pk[t] for t in TARGETS),
            "other": sum(c for k, c in pk.items() if k not in TARGETS and k != "-1"),
            "hit_rate": sum(int(e["hit"]) for e in eps) / len(eps),
            "median_speed": statistics.median(math.hypot(float(e["vx"]), float(e["vy"]))
                                              for e in eps),
            "spread": median_or_none([last_spread(runs[(p, r)]) for r in reps]),
        }
    base = out.get("baseline")
    for s in out.values():
        s["paired"] = ([s["run_means"][r] - base["run_means"][r] for r in s["reps"]
                        if r in base["run_means"]] if base else [])
    return out


def fmt_se(values):
    """'+0.105 ± 0.081' (mean ± standard error sd / sqrt(n)), '+0.105' for one
    value, '–' for none."""
    if not values:
        return "–"
    if len(values) < 2:
        return f"{values[0]:+.3f}"
    return f"{statistics.mean(values):+.3f} ± {statistics.stdev(values) / math.sqrt(len(values)):.3f}"


def fmt_opt(x):
    """'0.37' or '–' for None."""
    return "–" if x is None else f"{x:.2f}"


def rate(stats, key):
    """stats[key] (a pocket count) in percent of stats['episodes'], '4.4'."""
    return f"{100.0 * stats[key] / stats['episodes']:.1f}"


def config_diff(base, arm, ignore=("experiment.threads",)):
    """'section.key=value' for every key whose value in ARM/config.ini differs
    from BASE/config.ini (missing counts as different), sorted."""
    a, b = exp_data.config(base), exp_data.config(arm)
    out = []
    for sec in sorted(set(a.sections()) | set(b.sections())):
        keys = set(a[sec] if a.has_section(sec) else ()) | set(b[sec] if b.has_section(sec) else ())
        for k in sorted(keys):
            va, vb = a.get(sec, k, fallback=None), b.get(sec, k, fallback=None)
            if va != vb and f"{sec}.{k}" not in ignore:
                out.append(f"{sec}.{k}={vb}")
    return out


def compare_rows(base, arms, labels=None, last=None):
    """(rows, unchanged): the sensitivity table (header first) of ARM folders
    against BASE, and {label: [policies the arm left unchanged]}; stops with
    one line if an arm's seed or repetitions differ from BASE's."""
    prog = os.path.basename(sys.argv[0] or "exp3_table.py")
    bruns, last = load(base, last)
    bstats = summary(bruns)
    rows = [["arm", "policy", "mean return (default → arm)", "paired arm − default",
             "pocket 2 or 5, % (default → arm)", "other pocket, % (default → arm)",
             "median speed, m/s (default → arm)", "spread at the end, m/s (default → arm)",
             "vs baseline (default → arm)"]]
    unchanged = {}
    for j, arm in enumerate(arms):
        seeds = [exp_data.config(d).get("experiment", "seed", fallback=None) for d in (base, arm)]
        if seeds[0] != seeds[1]:
            sys.exit(f"{prog}: {arm}: seed {seeds[1]} differs from {base}'s {seeds[0]}")
        astats = summary(load(arm, last)[0])
        label = labels[j] if labels and j < len(labels) else ", ".join(config_diff(base, arm)) or arm
        for p, s in astats.items():
            if p not in bstats:
                continue
            b = bstats[p]
            if s["reps"] != b["reps"]:
                sys.exit(f"{prog}: {arm}: policy {p}: repetitions {s['reps']} differ from "
                         f"{base}'s {b['reps']}")
            if s["run_means"] == b["run_means"] and s["pockets"] == b["pockets"]:
                unchanged.setdefault(label, []).append(p)
                continue
            base_vs = "–" if p == "baseline" or not b["paired"] else fmt_se(b["paired"])
            arm_vs = "–" if p == "baseline" or not s["paired"] else fmt_se(s["paired"])
            rows.append([label, p, f"{b['mean']:.3f} → {s['mean']:.3f}",
                         fmt_se(paired(s["run_means"], b["run_means"])),
                         f"{rate(b, 'target')} → {rate(s, 'target')}",
                         f"{rate(b, 'other')} → {rate(s, 'other')}",
                         f"{b['median_speed']:.2f} → {s['median_speed']:.2f}",
                         f"{fmt_opt(b['spread'])} → {fmt_opt(s['spread'])}", f"{base_vs} → {arm_vs}"])
    return rows, unchanged


def table_rows(stats):
    """The table as lists of cell strings, header first."""
    rows = [["policy", "mean return", "SD over runs", "paired vs baseline [95 %]",
             "pocketed 2 / 5 / other", "hit rate", "median speed"]]
    for p, s in stats.items():
        rows.append([p, f"{s['mean']:.3f}", f"{s['std_runs']:.3f}",
                     "0" if p == "baseline" else fmt_ci(s["paired"]) if s["paired"] else "–",
                     f"{s['pockets'].get('2', 0)} / {s['pockets'].get('5', 0)} / {s['other']}",
                     f"{100 * s['hit_rate']:.0f} %", f"{s['median_speed']:.2f} m/s"])
    return rows


def print_table(rows, align):
    print("| " + " | ".join(rows[0]) + " |")
    print("|" + "|".join(align) + "|")
    for r in rows[1:]:
        print("| " + " | ".join(r) + " |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", nargs="?")
    ap.add_argument("--last", type=int, default=None)
    ap.add_argument("--compare", nargs="+", metavar="DIR",
                    help="DEFAULT ARM [ARM ...]: paired differences of each arm against DEFAULT")
    ap.add_argument("--label", nargs="+", default=None, help="a name per arm")
    args = ap.parse_args()
    if args.compare:
        if args.dir or len(args.compare) < 2:
            ap.error("--compare takes DEFAULT and at least one ARM, and no DIR")
        rows, unchanged = compare_rows(args.compare[0], args.compare[1:], args.label, args.last)
        print_table(rows, ["---", "---"] + ["---:"] * 7)
        if unchanged:
            print("\nUnchanged by the arm (identical per-repetition means and pocket counts), "
                  "not listed: " + "; ".join(f"{k}: {', '.join(v)}" for k, v in unchanged.items()) + ".")
        return
    if not args.dir:
        ap.error("DIR or --compare is required")
    runs, _ = load(args.dir, args.last)
    print_table(table_rows(summary(runs)), ["---", "---:", "---:", "---:", "---", "---:", "---:"])


if __name__ == "__main__":
    main()
