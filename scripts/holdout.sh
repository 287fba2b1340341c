#!/bin/sh
# The holdout of the verdicts (docs/verdicts.md, "Holdout"): Experiment 3 at
# REPS repetitions in the study's three physics arms with a seed no study
# used before (the rules in data/study/rules.ini were committed first), run
# by scripts/power.sh (one job per repetition, GNU Parallel, collect), then
# scripts/study_extract.py --exp3 writes DATA/{manifest,exp3_runs,
# exp3_curves,timing}.csv.
#   scripts/holdout.sh OUT REPS SEED DATA PYTHON [poolreps options...]
# POWER_JOBS jobs at once (default 2), POOLREPS the binary (default ./poolreps).
set -e
[ $# -ge 5 ] || { echo "usage: scripts/holdout.sh OUT REPS SEED DATA PYTHON [poolreps options...]" >&2; exit 1; }
out=$1; reps=$2; seed=$3; data=$4; py=$5; shift 5
here=$(dirname "$0")
. "$here/study_lib.sh"
mkdir -p "$out/power-docs"
t0=$(now)
sh "$here/power.sh" "$out/power" "$reps" "$out/power-docs" "$py" --set "experiment.seed=$seed" "$@"
{
	echo "phase,wall_seconds,jobs"
	echo "exp3,$(since "$t0"),${POWER_JOBS:-2}"
} > "$out/timing.csv"
"$py" "$here/study_extract.py" --exp3 "$out" "$data"
