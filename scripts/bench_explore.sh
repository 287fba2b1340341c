#!/bin/sh
# bench_explore.sh — C-REPS with policy.cov_center = new and old against
# contextual CMA-ES on the contextual sphere (200 generations) and Rosenbrock
# (850 generations) functions of Abdolmaleki et al. (IJCAI 2017, §6.1): 20
# repetitions of 50 episodes per generation, 20 parameters, epsilon = 1.
# Writes build/bench/explore/PROBLEM-METHOD/ (bench_curve.csv, ...), then
# bench_compare.png and bench_compare.csv there, and prints the table.
#   sh scripts/bench_explore.sh [QUICK]   (QUICK=1: 2 repetitions, 20 generations)
set -eu
ROOT=$(cd "$(dirname "$0")/.." && pwd)
cd "$ROOT"
QUICK=${1:-0}
PY=${PYTHON:-python3}
OUT=build/bench/explore
make -s all
mkdir -p "$OUT"
for p in sphere rosenbrock; do
	gens=200
	[ "$p" = rosenbrock ] && gens=850
	reps=20
	[ "$QUICK" = 1 ] && { gens=20; reps=2; }
	for m in creps_new creps_old ccmaes; do
		case $m in
		creps_new) set -- --set bench.method=creps --set policy.cov_center=new ;;
		creps_old) set -- --set bench.method=creps --set policy.cov_center=old ;;
		ccmaes) set -- --set bench.method=ccmaes ;;
		esac
		./poolreps "data/$p.ini" -q -o "$OUT/$p-$m" --set experiment.repetitions=$reps \
			--set experiment.threads=2 --set bench.iterations=$gens "$@"
	done
done
"$PY" scripts/plot_bench_compare.py "$OUT"
