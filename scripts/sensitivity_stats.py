#!/usr/bin/env python3
"""The sensitivity study's points, verdicts and report (scripts/sensitivity.sh).

Usage:
  sensitivity_stats.py --points                     the point names, one per line
  sensitivity_stats.py --point-options NAME         that point's poolreps --set options
  sensitivity_stats.py --study OUT --csv DIR        verdicts of OUT's merged points -> DIR/*.csv
  sensitivity_stats.py --csv DIR --docs DOCS [--readme README]
                                                    DOCS/sensitivity.md, the README
                                                    sentence and DOCS/choices.md's
                                                    one-line results, from DIR/*.csv alone

Every point is Experiment 3 (data/exp3.ini) with one open choice changed.
Its verdicts on the thesis's claims of section 7.5.2 come from the project's
one verdict generator, scripts/verdicts.py with data/study/rules.ini: the
same claim parts, margins, one-sided and TOST tests, intervals at the Holm
levels and Holm adjustment (here over every test of a point, as verdicts.py does over
every test of a mode), so a verdict here means what it means in
docs/verdicts.md; the per-run quantities come from scripts/power_stats.py's
reader of merged runs. A verdict "flips" when it differs from the reference point's:
the default for every choice, the constant law at its default deceleration
for the deceleration's points. Exit codes: 1 usage, 2 missing or malformed
input, 3 inconsistent data.
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import csv
import glob
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from claim_ids import EXP3_CLAIMS  # noqa: E402  (after the path)


HERE = os.path.dirname(os.path.abspath(__file__))
RULES = os.path.join(HERE, "..", "data", "study", "rules.ini")
# the Experiment 3 claims of the verdict study
CLAIMS = EXP3_CLAIMS


class _Lazy:
    """A module imported on first use, so that --points and --point-options
    start without numpy and scipy."""

    def __init__(self, name):
        self.name = name

    def __getattr__(self, attr):
        import importlib
        return getattr(importlib.import_module(self.name), attr)


ps = _Lazy("power_stats")   # reads merged Experiment 3 runs
vd = _Lazy("verdicts")      # the verdict rules

# name, choice, column label, --set options, reference point
POINTS = [
    ("default", "default", "default", [], None),
    ("law_constant", "friction law", "constant law", ["table.friction_law=constant"], "default"),
    ("law_slide_roll", "friction law", "slide_roll law", ["table.friction_law=slide_roll"],
     "default"),
    ("c_half", "friction c", "c ½×", ["table.friction=0.125"], "default"),
    ("c_double", "friction c", "c 2×", ["table.friction=0.5"], "default"),
    ("a_half", "deceleration a", "a ½×",
     ["table.friction_law=constant", "table.deceleration=0.03125", "sim.max_events=1000000"],
     "law_constant"),
    ("a_double", "deceleration a", "a 2×",
     ["table.friction_law=constant", "table.deceleration=0.125", "sim.max_events=1000000"],
     "law_constant"),
    ("kappa_06", "restitution", "κ 0.6", ["table.restitution=0.6"], "default"),
    ("kappa_09", "restitution", "κ 0.9", ["table.restitution=0.9"], "default"),
    ("eps_01", "epsilon", "ε 0.1", ["reps.epsilon=0.1"], "default"),
    ("eps_025", "epsilon", "ε 0.25", ["reps.epsilon=0.25"], "default"),
    ("eps_1", "epsilon", "ε 1", ["reps.epsilon=1"], "default"),
    ("vmax_5", "max speed", "5 m/s", ["sim.max_speed=5"], "default"),
    ("vmax_20", "max speed", "20 m/s", ["sim.max_speed=20", "sim.max_events=1000000"],
     "default"),
    ("trunc_clip", "truncation", "clip", ["exp3.truncation=clip"], "default"),
    ("trunc_corrected", "truncation", "corrected", ["exp3.truncation=corrected"], "default"),
    ("stop_half", "stop speed", "v_stop ½×", ["table.stop_speed=0.001"], "default"),
    ("stop_double", "stop speed", "v_stop 2×", ["table.stop_speed=0.004"], "default"),
    ("state_full", "state", "4-D state", ["exp3.state=full"], "default"),
]
BY_NAME = {p[0]: p for p in POINTS}
# sim.max_events (a safety bound: a shot past it fails the run, it changes no
# shot that ends within it) is raised where balls roll far: at a ½× a 10 m/s
# shot rolls 1600 m and can meet more than the default 10000 cushions
# what each choice is and what its default is, for the paragraphs
CHOICES = {
    "friction law": "how a ball slows: the thesis's exponential law v' = −c v (default, "
                    "c = 0.25 s⁻¹) against a constant deceleration (rolling resistance) of "
                    "a = 0.0625 m/s², which stops a ball from 0.5 m/s in the same distance, "
                    "and a real table's sliding then rolling ball (slide_roll: μ_s = 0.2, "
                    "μ_r = 0.01, every shot a stun shot)",
    "friction c": "the exponential law's rate c (default 0.25 s⁻¹), halved and doubled",
    "deceleration a": "the constant law's deceleration a (0.0625 m/s²), halved and doubled; "
                      "compared with the constant law at 0.0625 m/s²",
    "restitution": "the cushion restitution κ (default 0.8)",
    "epsilon": "REPS's KL bound ε (default 0.5 nats)",
    "max speed": "sim.max_speed (default 10 m/s), the speed above which an action is not shot",
    "truncation": "what happens to an action drawn faster than sim.max_speed (default: drawn "
                  "again, the importance weights ignoring the truncation): scaled onto the "
                  "limit (clip) or drawn again with truncated densities (corrected)",
    "stop speed": "table.stop_speed (default 0.002 m/s), below which a ball stops",
    "state": "the learner's state: the two varying coordinates (default; the cue ball "
             "always starts at (−0.25, 0)) or both balls' positions, the thesis's 4-D state",
}
SYMBOL = {"agrees": "✓", "disagrees": "✗", "undecided": "?"}  # power_stats's verdicts
FILES = ("claims.csv", "effects.csv", "runs.csv")


class Fail(Exception):
    def __init__(self, msg, code):
        super().__init__(msg)
        self.code = code


def write_csv(path, header, rows):
    tmp = f"{path}.tmp.{os.getpid()}"
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        w.writerows(rows)
    os.replace(tmp, path)


def read_csv(path):
    try:
        with open(path, newline="", encoding="utf-8") as f:
            return list(csv.DictReader(f))
    except OSError as e:
        raise Fail(f"{path}: {e.strerror}", 2) from e


def g(x):
    return "nan" if not math.isfinite(x) else f"{x:.6g}"


def point_runs(a):
    """verdicts.py's per-run records of one merged point (as study_extract.py
    writes them for a mode): {(point, policy, repetition): quantities}."""
    i2, i5 = ps.POCKETS.index(2), ps.POCKETS.index(5)
    runs = {}
    for p in a.policies:
        i = a.row(p)
        for j, r in enumerate(a.reps):
            runs[(a.name, p, r)] = {
                "mean_return": float(a.ret[i, j]), "sd_return": float(a.sd[i, j]),
                "target": float(a.target[i, j]), "pocket2": float(a.counts[i, j, i2]),
                "pocket5": float(a.counts[i, j, i5]), "median_speed": float(a.speed[i, j]),
                "miss_distance": float(a.miss_dist[i, j]), "curve": a.curve[i, j]}
    return runs


def point_verdicts(a, rules):
    """{claim: (verdict, deciding part)} of one point: verdicts.py's parts,
    Holm-adjusted over every test of the point."""
    d = {"exp3": point_runs(a), "reps": len(a.reps), "iterations": a.iterations}
    if a.reps != list(range(len(a.reps))):
        raise Fail(f"{a.folder}: repetitions are not 0..{len(a.reps) - 1}", 3)
    if a.iterations < rules["converged_at"] + 3:
        # runs shorter than the rules' convergence point (QUICK=1, tests): the
        # last three iterations are the window of each run's trend
        rules = dict(rules, converged_at=max(0, a.iterations - 3))
    parts = vd.exp3_parts(d, a.name, vd.margin_values(rules["margins"]), rules)
    # the family of verdicts.py: every test of Experiment 3's claims in one mode
    vd.adjust([parts[cid] for cid in CLAIMS], rules["alpha"])
    out = {}
    for cid in CLAIMS:
        v = vd.claim_verdict(cid, parts[cid], rules)
        out[cid] = (v, vd.deciding(parts[cid], v))
    return out


def study_to_csv(study_dir, out):
    """Verdicts, effects and costs of every merged point of study_dir."""
    arms = [ps.Arm(p[0], os.path.join(study_dir, p[0])) for p in POINTS
            if os.path.isdir(os.path.join(study_dir, p[0]))]
    if not arms or arms[0].name != "default":
        raise Fail(f"{study_dir}: no merged point 'default'", 2)
    for a in arms[1:]:
        if a.reps != arms[0].reps or a.policies != arms[0].policies:
            raise Fail(f"{a.folder}: repetitions or policies differ from the default's", 3)
    rules = vd.read_rules(RULES)
    claims, effects = [], []
    for a in arms:
        for cid, (v, p) in point_verdicts(a, rules).items():
            side = "r" if v == vd.vs.DISAGREES else "s"
            claims.append((a.name, cid, v, f"{p['label']} {vd.ci(p, side)}"))
        b = a.ret[a.row(ps.BASELINE)]
        for q in a.policies:
            x = a.ret[a.row(q)]
            m, lo, hi, _ = ps.paired_t(x)
            e, elo, ehi, _ = ps.paired_t(x - b)
            effects.append((a.name, q, g(m), g(lo), g(hi), g(e), g(elo), g(ehi)))
    write_csv(os.path.join(out, "claims.csv"), ["point", "claim", "verdict", "detail"], claims)
    write_csv(os.path.join(out, "effects.csv"),
              ["point", "policy", "mean_return", "mean_lo", "mean_hi", "effect", "lo", "hi"],
              effects)
    timing = {r["phase"]: dict(r) for r in ps.read_timing(os.path.join(study_dir, "timing.csv"))}
    # a study finished in batches (SENSITIVITY_POINTS): the earlier batches'
    # timing_*.csv add their wall time
    for extra in sorted(glob.glob(os.path.join(study_dir, "timing_*.csv"))):
        for r in ps.read_timing(extra):
            t = timing[r["phase"]]
            t["wall_seconds"] = g(float(t["wall_seconds"]) + float(r["wall_seconds"]))
    rows = [(a.name, len(a.reps), g(ps.cpu_seconds(a)), a.version) for a in arms]
    rows.append(("all", len(arms[0].reps), g(sum(float(r[2]) for r in rows)), arms[0].version))
    write_csv(os.path.join(out, "runs.csv"),
              ["point", "repetitions", "cpu_seconds", "version"], rows)
    write_csv(os.path.join(out, "timing.csv"),
              ["phase", "wall_seconds", "jobs", "cores", "load_before", "load_after"],
              [[timing[k][c] for c in ("phase", "wall_seconds", "jobs", "cores", "load_before",
                                       "load_after")] for k in ("runs", "merge")])


class Results:
    """The committed CSVs, read back."""

    def __init__(self, folder):
        self.folder = folder
        self.verdict, self.detail = {}, {}
        for r in read_csv(os.path.join(folder, "claims.csv")):
            if r.get("verdict") not in SYMBOL:
                raise Fail(f"{folder}/claims.csv: bad verdict {r.get('verdict')!r}", 2)
            self.verdict[(r["point"], r["claim"])] = r["verdict"]
            self.detail[(r["point"], r["claim"])] = r["detail"]
        self.points = [p for p in BY_NAME if (p, CLAIMS[0]) in self.verdict]
        if "default" not in self.points:
            raise Fail(f"{folder}/claims.csv: no point 'default'", 3)
        self.effects = read_csv(os.path.join(folder, "effects.csv"))
        self.runs = {r["point"]: r for r in read_csv(os.path.join(folder, "runs.csv"))}
        self.timing = {r["phase"]: r for r in read_csv(os.path.join(folder, "timing.csv"))}
        if "all" not in self.runs or "runs" not in self.timing:
            raise Fail(f"{folder}: runs.csv or timing.csv incomplete", 2)

    def reference(self, point):
        ref = BY_NAME[point][4]
        return ref if ref in self.points else "default"

    def flips(self, point):
        """Claims whose verdict at point differs from its reference's."""
        ref = self.reference(point)
        return [c for c in CLAIMS if self.verdict[(point, c)] != self.verdict[(ref, c)]]

    def reversals(self):
        """(point, claim) pairs whose verdict goes from agrees to disagrees
        or back against the reference point."""
        opp = {("agrees", "disagrees"), ("disagrees", "agrees")}
        return [(p, c) for p in self.points[1:] for c in self.flips(p)
                if (self.verdict[(self.reference(p), c)], self.verdict[(p, c)]) in opp]

    def robust(self):
        """Claims whose verdict no point changes, and the others with the
        choices that change them."""
        keep, moved = [], {}
        for c in CLAIMS:
            by = [BY_NAME[p][1] for p in self.points[1:] if c in self.flips(p)]
            if by:
                moved[c] = sorted(set(by), key=by.index)
            else:
                keep.append(c)
        return keep, moved


def claim_short(cid):
    return vd.read_rules(RULES)["claims"][cid]["short"]


def render(res):
    pts = res.points
    reps = res.runs["default"]["repetitions"]
    cpu = float(res.runs["all"]["cpu_seconds"])
    wall = float(res.timing["runs"]["wall_seconds"]) + float(res.timing["merge"]["wall_seconds"])
    t = res.timing["runs"]
    lines = [
        "# Sensitivity of the Experiment 3 verdicts to the open choices",
        "",
        "Generated by `make sensitivity` (scripts/sensitivity.sh, scripts/sensitivity_stats.py)"
        " from the CSVs in [data/sensitivity/](data/sensitivity/); do not edit by hand.",
        "",
        f"Each point is Experiment 3 (`data/exp3.ini`) at {reps} repetitions with one choice "
        "the thesis leaves open changed; everything else is the default (event mode). Each "
        "verdict comes from scripts/verdicts.py with data/study/rules.ini and its current "
        "rules: the same claim parts, margins and tests, Holm-adjusted over every test of the "
        "point, the family verdicts.md uses for Experiment 3 in a mode. ✓ agrees, ✗ disagrees, "
        "? undecided ([verdicts.md](verdicts.md)). A **bold** verdict differs from its "
        "reference point's (the default; for the deceleration's points the constant law at "
        "its default deceleration). Every point's deciding part per claim (estimate and "
        "interval at its Holm level): [`claims.csv`](data/sensitivity/claims.csv); each "
        "policy's mean return and paired effect against the baseline (95 % t intervals): "
        "[`effects.csv`](data/sensitivity/effects.csv).",
        "",
        f"Cost: {cpu:.0f} CPU seconds over all points ({len(pts)} points, "
        f"{reps} repetitions of 6 policies each), {wall:.0f} s wall with {t['jobs']} jobs on "
        f"{t['cores']} cores (load {t['load_before']} before, {t['load_after']} after; the "
        f"machine was shared). Versions: " + "; ".join(
            f"{v} ({', '.join(BY_NAME[p][2] for p in pts if res.runs[p]['version'] == v)})"
            for v in sorted({res.runs[p]["version"] for p in pts})) + ".",
        "",
        "## Claims × choices",
        "",
    ]
    head = ["claim"] + [BY_NAME[p][2] for p in pts]
    lines.append("| " + " | ".join(head) + " |")
    lines.append("|" + "---|" * len(head))
    for cid in CLAIMS:
        cells = [f"`{cid}`"]
        for p in pts:
            v = SYMBOL[res.verdict[(p, cid)]]
            cells.append(f"**{v}**" if p != "default" and cid in res.flips(p) else v)
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "The claims (data/study/rules.ini):", ""]
    lines += [f"- `{cid}`: {claim_short(cid)}" for cid in CLAIMS]
    lines += ["", "## Choice by choice", ""]
    for choice, what in CHOICES.items():
        mine = [p for p in pts if BY_NAME[p][1] == choice]
        if not mine:
            continue
        text = [f"**{choice[0].upper() + choice[1:]}** — {what}."]
        for p in mine:
            fl = res.flips(p)
            ref = BY_NAME[res.reference(p)][2]
            if not fl:
                text.append(f"At {BY_NAME[p][2]} no verdict changes (against {ref}).")
                continue
            parts = [f"`{c}` {res.verdict[(res.reference(p), c)]} → {res.verdict[(p, c)]}"
                     for c in fl]
            text.append(f"At {BY_NAME[p][2]} {len(fl)} of {len(CLAIMS)} verdicts change "
                        f"against {ref}: " + "; ".join(parts) + ".")
        lines += [" ".join(text), ""]
    return "\n".join(lines)


def sentence(res):
    keep, moved = res.robust()
    alts = len(res.points) - 1
    # a verdict undecided at every point never changes because it is never decided
    never = [c for c in keep if all(res.verdict[(p, c)] == "undecided" for p in res.points)]
    keep = [c for c in keep if c not in never]
    s = (f"against {alts} alternatives to the open choices ([docs/sensitivity.md]"
         f"(docs/sensitivity.md), {res.runs['default']['repetitions']} repetitions each, event "
         f"mode), {len(keep)} of the {len(CLAIMS)} Experiment 3 verdicts never "
         f"{'changes' if len(keep) == 1 else 'change'}")
    s += (" (" + ", ".join(f"`{c}`" for c in keep) + ")") if keep else ""
    s += ("; undecided at every point: " + ", ".join(f"`{c}`" for c in never)) if never else ""
    if moved:
        s += "; " + "; ".join(f"`{c}` changes under {', '.join(by)}" for c, by in moved.items())
    rev = res.reversals()
    s += (". No verdict reverses between agrees and disagrees" if not rev else
          ". Reversals between agrees and disagrees: " + ", ".join(
              f"`{c}` at {BY_NAME[p][2]}" for p, c in rev))
    return s + "."


def slug(choice):
    return choice.replace(" ", "_")


def choice_line(res, choice):
    """One line on a choice's points: which verdicts change where."""
    mine = [p for p in res.points if BY_NAME[p][1] == choice]
    if not mine:
        return "not varied"
    parts, calm = [], []
    for p in mine:
        fl = res.flips(p)
        if fl:
            parts.append(f"at {BY_NAME[p][2]} " + ", ".join(
                f"`{c}` {SYMBOL[res.verdict[(res.reference(p), c)]]} → "
                f"{SYMBOL[res.verdict[(p, c)]]}" for c in fl))
        else:
            calm.append(BY_NAME[p][2])
    text = "; ".join(parts) if parts else "no verdict changes"
    if parts and calm:
        text += f"; none at {', '.join(calm)}"
    elif not parts:
        text += f" at {', '.join(calm)}"
    return text + f" ({res.runs['default']['repetitions']} repetitions, [sensitivity.md](sensitivity.md))"


def real_table(res):
    """The README's sentence on the slide_roll point: which verdicts change
    against the default and whether any reverses."""
    p = "law_slide_roll"
    if p not in res.points:
        return "not run in this study"
    fl = res.flips(p)
    rev = [c for q, c in res.reversals() if q == p]
    if fl:
        head = (f"{len(fl)} of the {len(CLAIMS)} Experiment 3 verdicts change against the "
                "default (" + ", ".join(f"`{c}` {SYMBOL[res.verdict[('default', c)]]} → "
                                        f"{SYMBOL[res.verdict[(p, c)]]}" for c in fl) + ")")
    else:
        head = f"all {len(CLAIMS)} Experiment 3 verdicts stay the same"
    tail = ("; none reverses between agrees and disagrees" if not rev else
            "; " + ", ".join(f"`{c}`" for c in rev) + " reverses between agrees and disagrees")
    return (f"with a real table's balls, which slide and then roll (`table.friction_law = "
            f"slide_roll`, {res.runs[p]['repetitions']} repetitions, "
            f"[docs/sensitivity.md](docs/sensitivity.md)), {head}{tail}.")


def update_marks(path, cells):
    """Rewrite the text between <!-- sensitivity:ID --> and the next
    <!-- /sensitivity --> for every ID of cells that path holds; the README's
    ID is 'robust'. Missing marks are an error only for the README."""
    with open(path, encoding="utf-8") as f:
        src = f.read()
    for key, text in cells.items():
        a, b = f"<!-- sensitivity:{key} -->", "<!-- /sensitivity -->"
        i = src.find(a)
        j = src.find(b, i + 1)
        if i < 0 or j < 0:
            if key == "robust":
                raise Fail(f"{path}: no {a} ... {b} marks", 2)
            continue
        src = src[:i + len(a)] + text + src[j:]
    tmp = f"{path}.tmp.{os.getpid()}"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(src)
    os.replace(tmp, path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", action="store_true")
    ap.add_argument("--point-options")
    ap.add_argument("--study")
    ap.add_argument("--csv")
    ap.add_argument("--docs")
    ap.add_argument("--readme")
    args = ap.parse_args()
    try:
        if args.points:
            print("\n".join(p[0] for p in POINTS))
        elif args.point_options:
            if args.point_options not in BY_NAME:
                raise Fail(f"unknown point {args.point_options}", 1)
            print(" ".join(f"--set {s}" for s in BY_NAME[args.point_options][3]))
        elif args.study and args.csv:
            study_to_csv(args.study, args.csv)
        elif args.csv and args.docs:
            res = Results(args.csv)
            path = os.path.join(args.docs, "sensitivity.md")
            tmp = f"{path}.tmp.{os.getpid()}"
            with open(tmp, "w", encoding="utf-8") as f:
                f.write(render(res) + "\n")
            os.replace(tmp, path)
            if args.readme:
                update_marks(args.readme, {"robust": sentence(res), "real_table": real_table(res)})
            choices = os.path.join(args.docs, "choices.md")
            if os.path.isfile(choices):
                update_marks(choices, {slug(c): choice_line(res, c) for c in CHOICES})
        else:
            ap.error("give --points, --point-options, --study with --csv, or --csv with --docs")
    except Fail as e:
        print(f"sensitivity_stats: {e}", file=sys.stderr)
        return e.code
    except OSError as e:
        print(f"sensitivity_stats: {e.filename}: {e.strerror}", file=sys.stderr)
        return 2
    except Exception as e:  # power_stats.Fail: its message and exit code
        if type(e).__name__ != "Fail":
            raise
        print(f"sensitivity_stats: {e}", file=sys.stderr)
        return e.code
    return 0


if __name__ == "__main__":
    sys.exit(main())
