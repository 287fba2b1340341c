#!/usr/bin/env python3
"""Write OUT/report.html: one static page on a `make reproduce` run.

Usage: report.py OUT [--quick]

OUT is the folder scripts/reproduce.sh fills: OUT/figures/*.png and *.svg,
OUT/<experiment>/ with CSVs and provenance.txt, OUT/timings.csv. The page
holds every figure with a caption, the verdicts on the thesis's claims (the
committed study's, docs/verdicts_report.html from scripts/verdicts.py) and this
run's own measurements of them without verdicts (scripts/claims.py, computed
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
from the CSVs), the Experiment 3 table
(scripts/exp3_table.py), and each experiment's provenance and timing. It has
no scripts and loads nothing from the network: the figures are relative
links into OUT/figures. --quick marks the page as a smoke run at tiny sizes.
Standard library only.
"""
import argparse
import html
import os
import platform
import sys

import claims
import exp3_table
import exp_data
import experiments

# (file stem in OUT/figures, heading, caption)
FIGURES = [
    ("fig7_1_table", "Fig. 7.1 — the table",
     "The simulated table, 1 m by 0.5 m with its origin at the centre, and its six pockets "
     "numbered 0 to 5. The balls are one start state drawn from the start boxes: the white cue "
     "ball, the blue reward ball and red obstacles. The experiments use the cue ball and one "
     "reward ball only; the obstacles show that the simulator takes any number of balls."),
    ("fig7_2_reward", "Fig. 7.2 — return over the actions",
     "The return of every action, the cue ball's initial velocity, on a grid of 201 by 201 "
     "actions, for the cue ball at (−0.25, 0) and the reward ball at (0.1, 0). The return is "
     "minus a distance, in metres. White cells outlined in black sink the ball in a target "
     "pocket and earn the best possible 0; they lie in thin rays, so a small change of the "
     "action loses them. Grey: shots that never touch the reward ball and pay the miss "
     "penalty. Differs from the thesis's figure: misses get their own colour so that the "
     "colour scale spans the hits only (with the penalty on one scale the zero-return set, "
     "the figure's point, fades into specks). The two circles are the actions of Fig. 7.3."),
    ("fig7_3_shots", "Fig. 7.3 — two optimal shots",
     "Two actions of that grid with return 0 and their paths: one sends the reward ball into "
     "the lower target pocket (red), the other into the upper one (yellow). The state is the "
     "same, and the two actions are close, yet they aim at different pockets; averaging them "
     "would pocket nothing, which is why a policy here must be able to hold several solutions."),
    ("fig7_4a_nmin", "Fig. 7.4a — forest error against n_min",
     "Test mean squared error of the forests' predicted return (m²) when n_min, the number of "
     "samples a node needs before it is split, varies and the other parameters keep their "
     "defaults. Top: mean and one standard deviation over the forests, as the thesis draws it; "
     "the spread mostly reflects how hard each forest's own test shots are. Bottom: each "
     "setting minus the default on the same training and test subsets, with its mean and 95 % "
     "interval and every forest as a grey dot: these paired differences show effects the "
     "error bars above hide."),
    ("fig7_4b_trees", "Fig. 7.4b — forest error against the number of trees M",
     "As Fig. 7.4a, varying the number of trees M. One tree is clearly worse; from about ten "
     "trees on the paired differences to the default stay around zero."),
    ("fig7_4c_cuts", "Fig. 7.4c — forest error against the number of cuts K",
     "As Fig. 7.4a, varying K, the number of random tests drawn per node (integer ticks). "
     "K = 1, totally random trees, is worse in every forest; more cuts than the default change "
     "little."),
    ("exp1_map", "Experiment 1 — what the forests learn",
     "The return of the shot aimed straight at the reward ball, by the reward ball's position "
     "(left), the mean prediction of all the forests (middle) and their difference (right). "
     "The bands where the ball drops into a target pocket (return 0) are narrow; the forests "
     "smooth them away and underestimate them by about half a metre (blue on the right), as "
     "the thesis observes."),
    ("fig7_5_ghost", "Fig. 7.5 — the ghost-ball expert",
     "The expert of Experiment 2 for the cue and reward ball of Fig. 7.1. It picks the target "
     "pocket nearest the reward ball and an aim point in it, places the ghost ball (dotted) "
     "touching the reward ball on the far side from the aim point, and sends the cue ball to "
     "the ghost ball's centre with the speed that makes the reward ball arrive at the aim "
     "point slowly. Here the aim point is the pocket's centre (ghost.aim = centre, the "
     "default): in the exact simulator this pockets every reward ball of Experiment 2's "
     "region, and Experiment 2 rests on it. The thesis's caption aims at the centre of the "
     "entry of the pocket corridor instead (ghost.aim = corridor). The corridor is the part of "
     "the pocket's capture disc that a ball centre can reach without touching a cushion; its "
     "entry is the arc of the disc's rim inside that region (orange in the zoom), and the "
     "ring marks the arc's midpoint."),
    ("fig7_6", "Fig. 7.6 — policies learned from the expert",
     "Mean return on the test shots of three tree-based policies trained on the expert's "
     "shots, against the number of training samples: a single node (one global linear-"
     "Gaussian policy) and forests from states to actions or from states to the final "
     "reward-ball position. Left the policies play their mean action, right an action drawn "
     "from them. Bars are two standard errors over the repetitions; the dashed line is the "
     "expert itself."),
    ("fig7_7", "Fig. 7.7 — learning curves of Experiment 3",
     "Average return of each REPS iteration's new episodes, the mean over the repetitions "
     "with a band of ± 1 SD over the repetitions (the band of Experiment 4's curves too), for "
     "the four tree variants (panels a–d: value-forest score nrvr or rvr, policy forest to "
     "reward states or to actions). Every panel repeats the single-node baseline (hatched "
     "band, dashed mean) and the hand-crafted variant, which is not in the thesis; they are "
     "added so that each panel holds its comparison, on one y-scale for all panels."),
    ("fig7_8", "Fig. 7.8 — returns at the end of learning",
     "The returns of each run's last episodes. Top, as the thesis draws it: each run's mean "
     "with ± 1 SD of its returns. Below, the same runs as boxes (quartiles, whiskers at the "
     "5th and 95th percentiles, diamond at the run's mean), which the thesis does not show: "
     "returns never exceed 0, the value of a ball pocketed in a target, and are far from "
     "normal (long tails below −1 m are shots that miss the reward ball), so a mean ± SD bar "
     "can pass 0 and hide the skew. Every policy appears once, the hand-crafted one beyond "
     "the thesis."),
    ("fig7_9", "Fig. 7.9 — where the balls went",
     "Reward balls pocketed in the last episodes of every run, by pocket, numbered as in "
     "Fig. 7.1: the two targets (pocket 2, the lower one, and pocket 5, the upper), the "
     "middle pockets and the far corners, as a share of all those episodes (N per policy in "
     "the title; bars, with the counts) and of each run (dots). Differs from the thesis's "
     "figure: it adds the non-target pockets (the tree policies drop many more balls into the "
     "middle pockets than into the targets) and each run's share, so that the spread behind "
     "\"favoured the lower pocket\" shows."),
    ("fig7_10", "Fig. 7.10 — final distance to the targets",
     "Top: the outcome of each of the last episodes, as shares with every run as a dot: "
     "pocketed in a target, pocketed elsewhere, the reward ball never touched, or hit but "
     "left on the table. Below, per policy on one y-scale: the line is the thesis's "
     "histogram, the final distance of every reward ball to the nearest target pocket (0 "
     "when pocketed in a target, a pocket's centre when pocketed elsewhere); the bars, ours "
     "beside it, count only the balls left on the table after a hit, with the range over the "
     "runs. Added because the thesis's single histogram mixes outcomes: its pile near 0.45 m "
     "is mostly balls that were never hit, resting where they started."),
    ("exp4_curves_query", "Experiment 4 — learning curves, covariance as printed",
     "Beyond the thesis: does starting from imitation rescue the policies of Experiment 3? "
     "Average return of each iteration's new episodes, mean over the repetitions with a band of "
     "one standard deviation, with policy.cov = query (eq. 6.8 as printed). Per policy: the "
     "run from scratch, which is Experiment 3 itself (hatched band, dashed mean); the policy "
     "fitted to the ghost-ball demonstrations and never updated (dotted); and that fit "
     "followed by REPS with the first window holding the demonstrations (blue, starting at "
     "their return) or episodes of the fitted policy (orange). The hand-crafted policy has no "
     "such covariance and is the same in both figures."),
    ("exp4_curves_residual", "Experiment 4 — learning curves, residual covariance",
     "As above with policy.cov = residual (each sample's own fit as the centre of eq. 6.8)."),
    ("exp4_final", "Experiment 4 — returns at the end",
     "The returns of the last episodes of every run of each variant, all runs pooled (boxes: "
     "quartiles, whiskers: 5th to 95th percentile, diamond: mean) with each run's mean as a "
     "dot; top with the covariance as printed, bottom with the residual covariance."),
    ("exp4_rates", "Experiment 4 — pocket and hit rates",
     "For the same episodes: the share that sank the reward ball in a target pocket (dots: "
     "each run) and the share in which the cue ball touched the reward ball."),
    ("bench_quadratic", "REPS on the contextual quadratic",
     "Validation of the REPS implementation on a one-dimensional contextual quadratic: the "
     "negated mean return of the samples, of the policy mean on fixed test contexts, and the "
     "distance of the policy mean to the optimum, against the number of episodes (log "
     "scales; thin lines are single runs, the thick line their median)."),
    ("bench_sphere", "REPS on the contextual sphere",
     "The same curves on the 20-dimensional contextual sphere function, every one of the 20 "
     "seeds drawn, with the plateau (the median over the last tenth of the iterations) "
     "marked and its value in the legend. With 50 samples per iteration REPS converges "
     "early: the weighted maximum-likelihood covariance collapses before the mean reaches "
     "the optimum."),
    ("bench_rosenbrock", "REPS on the contextual Rosenbrock function",
     "The same curves on the contextual Rosenbrock function."),
]

CSS = """
body { font: 15px/1.45 "DejaVu Sans", sans-serif; max-width: 70rem; margin: 1.5rem auto;
       padding: 0 1rem; color: #111; }
h1 { font-size: 1.6rem; } h2 { margin-top: 2.2rem; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.8rem 0; font-size: 0.88rem; }
th, td { border: 1px solid #bbb; padding: 0.25rem 0.45rem; vertical-align: top; text-align: left; }
th { background: #eee; } td.num { text-align: right; white-space: nowrap; }
td.agrees { background: #d8eedd; } td.partly { background: #fbf0c8; }
td.disagrees { background: #f6d5cc; } td.untested { background: #e6e6e6; }
figure { margin: 1.6rem 0; } figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { max-width: 60rem; } .note { background: #fbf0c8; padding: 0.5rem 0.8rem; }
.missing { color: #a00; font-weight: bold; } code { font-size: 0.9em; }
"""
# the verdicts of the study, written by scripts/verdicts.py (make verdicts)
VERDICTS_HTML = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "docs",
                             "verdicts_report.html")


def esc(text):
    return html.escape(str(text), quote=True)


def table(header, rows, num=()):
    """An HTML table; columns whose index is in num are right-aligned."""
    out = ["<table>", "<tr>" + "".join(f"<th>{esc(h)}</th>" for h in header) + "</tr>"]
    for r in rows:
        cells = []
        for i, c in enumerate(r):
            cells.append(f'<td class="num">{esc(c)}</td>' if i in num else f"<td>{esc(c)}</td>")
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</table>")
    return "\n".join(out)


def provenance(out, name):
    """{key: value} of OUT/name/provenance.txt, {} when absent."""
    path = os.path.join(out, name, "provenance.txt")
    if not os.path.exists(path):
        return {}
    with open(path, encoding="utf-8") as f:
        return dict(line.rstrip("\n").split(": ", 1) for line in f if ": " in line)


def claims_section(out):
    """The study's verdicts (generated by make verdicts), then this run's own
    measurements as a sample without verdicts."""
    try:
        with open(VERDICTS_HTML, encoding="utf-8") as f:
            study = f.read()
    except OSError:
        study = ("<p class=\"missing\">The study's verdicts (docs/verdicts_report.html, "
                 "written by <code>make verdicts</code>) are not installed here.</p>\n")
    rows = claims.evaluate(out)
    reps = {exp_data.config(os.path.join(out, e)).get("experiment", "repetitions", fallback="?")
            for e in ("exp1", "exp2", "exp3")}
    n = reps.pop() if len(reps) == 1 else "few"
    sample = table(["thesis", "claim", "this run"],
                   [[r["section"], r["claim"], r["here"]] for r in rows])
    return (study + f"<h3>This run: a {n}-repetition sample, no verdicts</h3>\n"
            f"<p>What this run measures on the same {len(rows)} claims, computed from its CSVs "
            f"by <code>scripts/claims.py</code>: a sample of {n} repetitions per experiment, "
            "too few to decide the claims, so no verdict is drawn from it. Intervals are 95 % Student-t "
            "intervals of paired differences over the repetitions, written [lo, hi].</p>\n"
            + sample)


def exp3_section(out):
    d = os.path.join(out, "exp3")
    if not os.path.exists(os.path.join(d, "exp3_episodes.csv")):
        return '<p class="missing">Experiment 3 did not run.</p>'
    runs, last = exp3_table.load(d)
    rows = exp3_table.table_rows(exp3_table.summary(runs))
    nreps = len({r for _, r in runs})
    return (f"<p>Per policy, over the last {last} episodes of each of the {nreps} runs: the "
            "pooled mean return, the standard deviation of the run means, the paired "
            "difference to the baseline run of the same repetition (mean ± standard "
            "deviation over the repetitions), the reward balls pocketed in pocket 2, pocket 5 "
            "and elsewhere, the share of shots that touched the reward ball and the median cue "
            "speed. Returns in metres.</p>\n" + table(rows[0], rows[1:], num={1, 2, 3, 5, 6}))


EXP4_COLUMNS = ("variant", "repetitions", "mean_return", "se_return", "diff_scratch", "se_diff",
                "pocket_rate", "hit_rate", "median_speed")


def exp4_section(out):
    path = os.path.join(out, "exp4", "exp4_verdict.csv")
    if not os.path.exists(path):
        return '<p class="missing">Experiment 4 did not run.</p>'
    rows = []
    for r in exp_data.read_csv(path, EXP4_COLUMNS):
        diff = (f"{float(r['diff_scratch']):+.3f} ± {float(r['se_diff']):.3f}"
                if r["diff_scratch"] else "–")
        rows.append([r["variant"], f"{float(r['mean_return']):.3f} ± {float(r['se_return']):.3f}",
                     diff, f"{100 * float(r['pocket_rate']):.1f}",
                     f"{100 * float(r['hit_rate']):.1f}", f"{float(r['median_speed']):.3f}"])
    return ("<p>Beyond the thesis: each policy of Experiment 3 fitted to ghost-ball "
            "demonstrations, alone (imitation) or followed by REPS (demo, policy: the first "
            "window), against the same policy and covariance from scratch (Experiment 3 "
            "itself). Per variant, over the last episodes of each run: the mean return ± its "
            "standard error over the repetitions, the paired difference to scratch ± its "
            "standard error, the pocket and hit rates and the median cue speed "
            "(<code>exp4_verdict.csv</code>).</p>\n" +
            table(["variant (policy.init.cov)", "return m", "vs scratch m", "pocketed %",
                   "hit %", "median speed m/s"], rows, num={1, 2, 3, 4, 5}))


def figures_section(out):
    parts, missing = [], []
    for stem, heading, caption in FIGURES:
        png = os.path.join(out, "figures", stem + ".png")
        if not os.path.exists(png):
            missing.append(stem)
            continue
        vector = next((stem + e for e in (".svg", ".pdf")
                       if os.path.exists(os.path.join(out, "figures", stem + e))), None)
        img = f'<img src="figures/{esc(stem)}.png" alt="{esc(heading)}">'
        if vector:
            img = f'<a href="figures/{esc(vector)}">{img}</a>'
            caption += f" (Vector version: {vector}.)"
        parts.append(f'<figure id="{esc(stem)}">\n{img}\n<figcaption><strong>{esc(heading)}'
                     f"</strong>. {esc(caption)}</figcaption>\n</figure>")
    if missing:
        parts.insert(0, f'<p class="missing">Missing figures: {esc(", ".join(missing))}</p>')
    return "\n".join(parts), missing


def folders():
    """The experiments' folders in OUT, in the registry's order."""
    return [r["folder"] for r in experiments.registry()]


def provenance_section(out, names):
    keys = ["version", "seed", "parameter_file", "finished", "wall_seconds", "cpu_seconds",
            "peak_memory_mib"]
    rows = []
    for name in names:
        p = provenance(out, name)
        if p:
            rows.append([name] + [p.get(k, "–") for k in keys])
    host = next((provenance(out, n).get("host") for n in names if provenance(out, n)), "–")
    text = [f"<p>Host: {esc(host)}. Each experiment's folder holds its full effective "
            "configuration (<code>config.ini</code>) and <code>provenance.txt</code>; the "
            "command lines are below.</p>",
            table(["folder", "version", "seed", "parameter file", "finished (UTC)", "wall s",
                   "CPU s", "peak MiB"], rows, num={5, 6, 7})]
    cmds = [[n, provenance(out, n).get("command", "–")] for n in names if provenance(out, n)]
    text.append(table(["folder", "command"], cmds))
    tpath = os.path.join(out, "timings.csv")
    if os.path.exists(tpath):
        t = exp_data.read_csv(tpath, ("step", "seconds"))
        text.append("<p>Wall time of each step of <code>scripts/reproduce.sh</code> (running "
                    "each experiment, then drawing each folder's figures in one process that "
                    "overlaps the next run), measured with the machine as it was, possibly "
                    "shared:</p>")
        text.append(table(["step", "wall s"], [[r["step"], r["seconds"]] for r in t], num={1}))
    try:
        import matplotlib
        mpl = matplotlib.__version__
    except ImportError:
        mpl = "not installed"
    text.append(f"<p>Report written by Python {esc(platform.python_version())} (matplotlib "
                f"{esc(mpl)}).</p>")
    return "\n".join(text)


def write(out, quick):
    figs, missing = figures_section(out)
    names = folders()
    version = next((provenance(out, n).get("version") for n in names
                    if provenance(out, n)), "unknown")
    note = ('<p class="note">This is a smoke run at tiny sizes (<code>make reproduce '
            'QUICK=1</code>): the numbers of this run below show that the pipeline works, '
            "not what the experiments find.</p>") if quick else ""
    page = f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>poolreps: reproduction report</title>
<style>{CSS}</style>
</head>
<body>
<header>
<h1>Feature extraction for policy search, reproduced: report of one run</h1>
<p>poolreps {esc(version)}, seed and settings as recorded under Provenance. The thesis is
<em>Feature Extraction for Policy Search</em>; its chapter 7 is what this run reproduces.</p>
{note}
<nav><a href="#claims">Claims</a> · <a href="#exp3">Experiment 3 table</a> ·
<a href="#exp4">Experiment 4 table</a> ·
<a href="#figures">Figures</a> · <a href="#provenance">Provenance and timings</a></nav>
</header>
<main>
<section id="claims">
<h2>The thesis's claims</h2>
{claims_section(out)}
</section>
<section id="exp3">
<h2>Experiment 3 results</h2>
{exp3_section(out)}
</section>
<section id="exp4">
<h2>Experiment 4 results (beyond the thesis)</h2>
{exp4_section(out)}
</section>
<section id="figures">
<h2>Figures</h2>
{figs}
</section>
<section id="provenance">
<h2>Provenance and timings</h2>
{provenance_section(out, names)}
</section>
</main>
</body>
</html>
"""
    path = os.path.join(out, "report.html")
    tmp = path + f".tmp.{os.getpid()}"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(page)
    os.replace(tmp, path)
    return path, missing


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--quick", action="store_true", help="mark the page as a QUICK smoke run")
    a = ap.parse_args()
    path, missing = write(a.out, a.quick)
    print(path)
    if missing:
        sys.exit(f"report.py: missing figures in {a.out}/figures: {', '.join(missing)}")


if __name__ == "__main__":
    main()
