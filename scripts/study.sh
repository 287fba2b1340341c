#!/bin/sh
# The study behind docs/verdicts.md: Experiment 3 at REPS repetitions in the
# three physics arms of scripts/power.sh (event; stepped at dt 1 ms and
# 0.5 ms), Experiments 1 and 2 at SEEDS seeds in the same three arms (a
# `poolreps sweep` over experiment.seed per arm, one job per seed and
# repetition, `poolreps collect` merges),
# then scripts/study_extract.py writes the compact CSVs the verdicts are
# computed from into DATA.
#   scripts/study.sh OUT REPS SEEDS DATA PYTHON
# OUT/power        the Experiment 3 study (scripts/power.sh, its report in
#                  OUT/power; docs/power.md is scripts/verdicts.py's)
# OUT/seeds/ARM/EXP  the sweep of EXP over the seeds in ARM; merged seed k in point-K/merged
# OUT/sphere/METHOD  the contextual sphere benchmark (the README's sentence on it)
# OUT/timing.csv   wall and CPU seconds per phase
# DATA/*.csv       per-run results and the effective configuration of every unit
# POWER_JOBS jobs at once (default 2), POOLREPS the binary (default ./poolreps);
# STUDY_EXP1, STUDY_EXP2, STUDY_EXP3, STUDY_SPHERE: extra poolreps options for
# that experiment's runs (tests pass tiny settings).
set -e
[ $# -eq 5 ] || { echo "usage: scripts/study.sh OUT REPS SEEDS DATA PYTHON" >&2; exit 1; }
out=$1; reps=$2; seeds=$3; data=$4; py=$5
[ -n "$py" ] || { echo "study: no Python with matplotlib found; install python3-matplotlib or set PYTHON=" >&2; exit 1; }
jobs=${POWER_JOBS:-2}
export POOLREPS="${POOLREPS:-./poolreps}"
here=$(dirname "$0")
. "$here/study_lib.sh"

mkdir -p "$out"
t0=$(now)
# shellcheck disable=SC2086  # the options are plain words
sh "$here/power.sh" "$out/power" "$reps" "$out/power" "$py" $STUDY_EXP3
power=$(since "$t0")

grid=$(seq -s, 1 "$seeds")
rm -rf "$out/seeds"
mkdir -p "$out/seeds"
: > "$out/seeds/jobs.txt"
for a in $ARMS; do
	for e in exp1 exp2; do
		eval "extra=\${STUDY_$(echo $e | tr a-z A-Z):-}"
		# shellcheck disable=SC2046,SC2086,SC2154  # the options are plain words
		sh "$here/jobs.sh" "$here/../data/$e.ini" "$out/seeds/$a/$e" \
			--grid "experiment.seed=$grid" --set experiment.threads=1 $(arm "$a") $extra \
			>> "$out/seeds/jobs.txt"
	done
done
t1=$(now)
parallel -j "$jobs" --halt now,fail=1 --joblog "$out/seeds/joblog.txt" < "$out/seeds/jobs.txt"
for a in $ARMS; do for e in exp1 exp2; do "$POOLREPS" collect -q "$out/seeds/$a/$e"; done; done
exp12=$(since "$t1")
# the contextual sphere benchmark (data/sphere.ini, the bench_sphere figure's
# configuration) with each covariance centre and C-CMA-ES: the README's sentence
t2=$(now)
rm -rf "$out/sphere"
for m in creps_old creps_new ccmaes; do
	case $m in
	creps_old) set -- --set policy.cov_center=old ;;
	creps_new) set -- --set policy.cov_center=new ;;
	ccmaes) set -- --set bench.method=ccmaes ;;
	esac
	# shellcheck disable=SC2086  # the options are plain words
	"$POOLREPS" "$here/../data/sphere.ini" -q -o "$out/sphere/$m" "$@" ${STUDY_SPHERE:-}
done
{
	echo "phase,wall_seconds,jobs"
	echo "exp3,$power,$jobs"
	echo "exp12,$exp12,$jobs"
	echo "sphere,$(since "$t2"),1"
} > "$out/timing.csv"
"$py" "$here/study_extract.py" "$out" "$data"
