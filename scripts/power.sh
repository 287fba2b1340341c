#!/bin/sh
# A standalone Experiment 3 power study (make power; report in DOCS): REPS
# variant in three physics arms (event; stepped with dt 1 ms; stepped with
# dt 0.5 ms), as one job list from scripts/jobs.sh (a `poolreps sweep` per
# arm) run by GNU Parallel, one `poolreps collect` per arm (it merges), then
# scripts/power_stats.py for the statistics.
#   scripts/power.sh OUT REPS DOCS PYTHON [poolreps options...]
# OUT/runs/ARM       the arm's sweep folder: one job per repetition (one thread)
# OUT/ARM             the merged arm, as one process would have written it
# OUT/timing.csv      wall time of the runs and merges, jobs, cores, load
# OUT/*.csv           the statistics (power_stats.py)
# DOCS/power.md, DOCS/figures/power_effects.{png,svg}  the report (the
#                     verdicts: scripts/study.sh, scripts/verdicts.py)
# Options after PYTHON go to every run before the arm's own (tests pass tiny
# Experiment 3 settings). POWER_JOBS jobs at once (default 2), POOLREPS the
# binary (default ./poolreps). OUT/runs and OUT/ARM are replaced.
set -e
[ $# -ge 4 ] || { echo "usage: scripts/power.sh OUT REPS DOCS PYTHON [poolreps options...]" >&2; exit 1; }
out=$1; reps=$2; docs=$3; py=$4; shift 4
[ -n "$py" ] || { echo "power: no Python with matplotlib found; install python3-matplotlib or set PYTHON=" >&2; exit 1; }
jobs=${POWER_JOBS:-2}
export POOLREPS="${POOLREPS:-./poolreps}"
here=$(dirname "$0")
. "$here/study_lib.sh"   # ARMS, arm, now, since, load
# merge_arm NAME: collect the sweep OUT/runs/NAME, its one grid point into OUT/NAME
merge_arm() {
	"$POOLREPS" collect -q "$out/runs/$1"
	mv "$out/runs/$1/point-0/merged" "$out/$1"
}

mkdir -p "$out"
for a in $ARMS; do rm -rf "$out/runs/$a" "$out/$a"; done
list="$out/runs/jobs.txt"
mkdir -p "$out/runs"
: > "$list"
for a in $ARMS; do
	# shellcheck disable=SC2046  # the arm's options are plain words
	sh "$here/jobs.sh" "$here/../data/exp3.ini" "$out/runs/$a" "$@" $(arm "$a") \
		--set "experiment.repetitions=$reps" --set experiment.threads=1 >> "$list"
done

load0=$(load)
t0=$(now)
parallel -j "$jobs" --halt now,fail=1 --joblog "$out/runs/joblog.txt" < "$list"
runs=$(since "$t0")
load1=$(load)
t1=$(now)
for a in $ARMS; do merge_arm "$a"; done
{
	echo "phase,wall_seconds,jobs,cores,load_before,load_after"
	echo "runs,$runs,$jobs,$(nproc),$load0,$load1"
	echo "merge,$(since "$t1"),1,$(nproc),$load1,$(load)"
} > "$out/timing.csv"

"$py" "$here/power_stats.py" "$out" --docs "$docs"
