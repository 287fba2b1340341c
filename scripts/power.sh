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
. "$here/study_lib.sh"   # ARMS, arm, add_jobs, run_sweeps

mkdir -p "$out"
for a in $ARMS; do rm -rf "$out/runs/$a" "$out/$a"; done
mkdir -p "$out/runs"
: > "$out/runs/jobs.txt"
for a in $ARMS; do
	# shellcheck disable=SC2046  # the arm's options are plain words
	add_jobs "$out" "$reps" "$here/../data/exp3.ini" "$a" "$@" $(arm "$a")
done
run_sweeps "$out" "$jobs" "$ARMS"

"$py" "$here/power_stats.py" "$out" --docs "$docs"
