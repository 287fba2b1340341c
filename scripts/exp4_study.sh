#!/bin/sh
# Experiment 4's controls study (docs/exp4.md, "Controls"): data/exp4_controls.ini
# in six arms, as one job list from scripts/jobs.sh (a `poolreps sweep` per
# arm, one job per repetition) run by GNU Parallel, one `poolreps collect`
# per arm (it merges), then scripts/exp4_study.py for the statistics.
#   scripts/exp4_study.sh OUT REPS DOCS PYTHON [poolreps options...]
# Arms: main (reps.epsilon 0.5, policy.min_std 1 mm/s: imitation, policy,
# refit, matched, refit_matched, both covariances); eps0.1, eps0.25 (policy and matched);
# floor3, floor10, floor0 (policy.min_std 3 and 10 mm/s, and 1e-9 m/s, the
# floor practically off; every init but scratch and demo, residual
# covariance). Same seed, so every arm's repetition k shares start states,
# demonstrations and pi_0 with the others (common random numbers).
# OUT/runs/ARM  the arm's sweep folder; OUT/ARM the merged arm
# OUT/timing.csv wall and CPU seconds of the runs and merges, jobs, cores, load
# DOCS/exp4_study/*.csv, DOCS/figures/exp4_controls.{png,svg}, and, when DOCS
#   is this checkout's docs/, the generated parts of docs/exp4.md and README.md
# Options after PYTHON go to every run before the arm's own (tests pass tiny
# settings). STUDY_JOBS jobs at once (default 2), POOLREPS the binary
# (default ./poolreps), NICE the niceness of the runs (default 10).
set -e
[ $# -ge 4 ] || { echo "usage: scripts/exp4_study.sh OUT REPS DOCS PYTHON [poolreps options...]" >&2; exit 1; }
out=$1; reps=$2; docs=$3; py=$4; shift 4
[ -n "$py" ] || { echo "exp4_study: no Python with matplotlib found; install python3-matplotlib or set PYTHON=" >&2; exit 1; }
jobs=${STUDY_JOBS:-2}
export POOLREPS="${POOLREPS:-./poolreps}"
here=$(dirname "$0")
# study_lib.sh first: its ARMS and arm are the physics arms, replaced here
. "$here/study_lib.sh"
ARMS="main eps0.1 eps0.25 floor3 floor10 floor0"


# arm NAME: the arm's own --set options
arm() {
	case $1 in
	main) echo "" ;;
	eps0.1) echo "--set exp4.inits=policy,matched --set reps.epsilon=0.1" ;;
	eps0.25) echo "--set exp4.inits=policy,matched --set reps.epsilon=0.25" ;;
	floor3) echo "--set exp4.inits=imitation,policy,refit,matched,refit_matched --set exp4.covs=residual --set policy.min_std=0.003" ;;
	floor10) echo "--set exp4.inits=imitation,policy,refit,matched,refit_matched --set exp4.covs=residual --set policy.min_std=0.01" ;;
	floor0) echo "--set exp4.inits=imitation,policy,refit,matched,refit_matched --set exp4.covs=residual --set policy.min_std=1e-9" ;;
	esac
}
# cpu FILE: user + system seconds of this shell's finished children, from
# `times` written to FILE by the shell itself (a subshell has its own)
cpu() { awk 'NR == 2 { split($1, u, "m"); split($2, s, "m"); printf "%.1f", u[1] * 60 + u[2] + s[1] * 60 + s[2] }' "$1"; }

mkdir -p "$out"
for a in $ARMS; do rm -rf "$out/runs/$a" "$out/$a"; done
list="$out/runs/jobs.txt"
mkdir -p "$out/runs"
: > "$list"
for a in $ARMS; do
	# shellcheck disable=SC2046  # the arm's options are plain words
	add_jobs "$out" "$reps" "$here/../data/exp4_controls.ini" "$a" "$@" $(arm "$a")
done

load0=$(load)
t0=$(now)
times > "$out/runs/times0"
nice -n "${NICE:-10}" parallel -j "$jobs" --halt now,fail=1 --joblog "$out/runs/joblog.txt" < "$list"
runs=$(since "$t0")
times > "$out/runs/times1"
load1=$(load)
t1=$(now)
for a in $ARMS; do merge_sweep "$out" "$a"; done
times > "$out/runs/times2"
c0=$(cpu "$out/runs/times0"); c1=$(cpu "$out/runs/times1"); c2=$(cpu "$out/runs/times2")
{
	echo "phase,wall_seconds,cpu_seconds,jobs,cores,load_before,load_after"
	echo "runs,$runs,$(awk -v a="$c0" -v b="$c1" 'BEGIN { printf "%.1f", b - a }'),$jobs,$(nproc),$load0,$load1"
	echo "merge,$(since "$t1"),$(awk -v a="$c1" -v b="$c2" 'BEGIN { printf "%.1f", b - a }'),1,$(nproc),$load1,$(load)"
} > "$out/timing.csv"

readme=$(docs_readme "$docs")
"$py" "$here/exp4_study.py" collect "$out" --arms "$ARMS" --out "$docs/exp4_study"
"$py" "$here/exp4_study.py" plot "$docs/exp4_study" --out "$docs/figures"
[ -z "$readme" ] || "$py" "$here/exp4_study.py" docs "$docs/exp4_study" --doc "$docs/exp4.md" --readme "$readme"
