#!/bin/sh
# More Experiment 3 repetitions for the verdict study (docs/verdicts.md):
# repetitions FROM..TO-1 of the study's configuration and seed in its three
# physics arms, one job each (scripts/jobs.sh, GNU Parallel), plus repetition
# 0 of every arm, which must come out as the study has it; then
# scripts/study_extract.py --extend adds them to DATA (exp3_runs.csv,
# exp3_curves.csv, manifest.csv's repetition count, timing.csv).
#   scripts/study_extend.sh OUT FROM TO DATA PYTHON [poolreps options...]
# (options: those the study's Experiment 3 ran with, e.g. STUDY_EXP3's)
# POWER_JOBS jobs at once (default 2), POOLREPS the binary (default ./poolreps).
set -e
[ $# -ge 5 ] || { echo "usage: scripts/study_extend.sh OUT FROM TO DATA PYTHON [poolreps options...]" >&2; exit 1; }
out=$1; from=$2; to=$3; data=$4; py=$5; shift 5
export POOLREPS="${POOLREPS:-./poolreps}"
here=$(dirname "$0")
. "$here/study_lib.sh"
mkdir -p "$out"
: > "$out/jobs.txt"
for a in $ARMS; do
	rm -rf "${out:?}/$a"
	# shellcheck disable=SC2046  # the arm's options are plain words
	sh "$here/jobs.sh" "$here/../data/exp3.ini" "$out/$a" "$@" $(arm "$a") \
		--set "experiment.repetitions=$to" --set experiment.threads=1 |
		awk -v lo="$from" '{ if (match($0, /experiment\.repetition=[0-9]+ /)) {
			k = substr($0, RSTART + 22, RLENGTH - 23) + 0; if (k == 0 || k >= lo) print } }' \
		>> "$out/jobs.txt"
done
t0=$(now)
parallel -j "${POWER_JOBS:-2}" --halt now,fail=1 --joblog "$out/joblog.txt" < "$out/jobs.txt"
{
	echo "phase,wall_seconds,jobs"
	echo "exp3,$(since "$t0"),${POWER_JOBS:-2}"
} > "$out/timing.csv"
"$py" "$here/study_extract.py" --extend "$out" "$data"
