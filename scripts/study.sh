#!/bin/sh
# The study behind docs/verdicts.md: Experiment 3 at REPS repetitions in the
# three physics arms of scripts/power.sh (event; stepped at dt 1 ms and
# 0.5 ms), Experiments 1 and 2 at SEEDS seeds (a `poolreps sweep` over
# experiment.seed, one job per seed and repetition, `poolreps collect` merges),
# then scripts/study_extract.py writes the compact CSVs the verdicts are
# computed from into DATA.
#   scripts/study.sh OUT REPS SEEDS DATA DOCS PYTHON
# OUT/power        the Experiment 3 study (scripts/power.sh; DOCS/power.md)
# OUT/seeds/EXP    the sweep of EXP over the seeds; merged seed k in point-K/merged
# OUT/timing.csv   wall and CPU seconds per phase
# DATA/*.csv       per-run results and the effective configuration of every unit
# POWER_JOBS jobs at once (default 2), POOLREPS the binary (default ./poolreps);
# STUDY_EXP1, STUDY_EXP2, STUDY_EXP3: extra poolreps options for that
# experiment's runs (tests pass tiny settings).
set -e
[ $# -eq 6 ] || { echo "usage: scripts/study.sh OUT REPS SEEDS DATA DOCS PYTHON" >&2; exit 1; }
out=$1; reps=$2; seeds=$3; data=$4; docs=$5; py=$6
[ -n "$py" ] || { echo "study: no Python with matplotlib found; install python3-matplotlib or set PYTHON=" >&2; exit 1; }
jobs=${POWER_JOBS:-2}
export POOLREPS="${POOLREPS:-./poolreps}"
here=$(dirname "$0")
. "$here/study_lib.sh"

mkdir -p "$out"
t0=$(now)
# shellcheck disable=SC2086  # the options are plain words
sh "$here/power.sh" "$out/power" "$reps" "$docs" "$py" $STUDY_EXP3
power=$(since "$t0")

grid=$(seq -s, 1 "$seeds")
rm -rf "$out/seeds"
mkdir -p "$out/seeds"
: > "$out/seeds/jobs.txt"
for e in exp1 exp2; do
	eval "extra=\${STUDY_$(echo $e | tr a-z A-Z):-}"
	# shellcheck disable=SC2086,SC2154
	sh "$here/jobs.sh" "$here/../data/$e.ini" "$out/seeds/$e" --grid "experiment.seed=$grid" \
		--set experiment.threads=1 $extra >> "$out/seeds/jobs.txt"
done
t1=$(now)
parallel -j "$jobs" --halt now,fail=1 --joblog "$out/seeds/joblog.txt" < "$out/seeds/jobs.txt"
for e in exp1 exp2; do "$POOLREPS" collect -q "$out/seeds/$e"; done
{
	echo "phase,wall_seconds,jobs"
	echo "exp3,$power,$jobs"
	echo "exp12,$(since "$t1"),$jobs"
} > "$out/timing.csv"
"$py" "$here/study_extract.py" "$out" "$data"
