#!/bin/sh
# Run every experiment and draw every figure (thesis Fig. 7.1-7.10, the REPS
# benchmarks) into one results folder.
#   scripts/reproduce.sh OUT PYTHON [QUICK]
# QUICK=1: a smoke run at tiny sizes (CI), same code paths and scripts.
set -e
OUT=${1:-results}
PY=${2:-}
QUICK=${3:-}
BIN=./poolreps
[ -x "$BIN" ] || { echo "reproduce: build ./poolreps first (make)" >&2; exit 1; }
[ -n "$PY" ] || { echo "reproduce: no Python with matplotlib found; install python3-matplotlib or set PYTHON=" >&2; exit 1; }
mkdir -p "$OUT/figures"
start=$(date +%s)

run() { # name, then the --set options of the QUICK run
	name=$1; shift
	dir=$name; [ "$name" = figures ] && dir=sim
	t0=$(date +%s)
	if [ "$QUICK" = 1 ]; then
		"$BIN" "data/$name.ini" -o "$OUT/$dir" "$@"
	else
		"$BIN" "data/$name.ini" -o "$OUT/$dir"
	fi
	echo "reproduce: $name took $(( $(date +%s) - t0 )) s"
}

run figures
"$PY" scripts/plot_sim_figures.py "$OUT/sim"
run exp1 --set exp1.train=200 --set exp1.test=200 --set exp1.subset=100 \
	--set exp1.test_subset=100 --set experiment.repetitions=2 \
	--set exp1.n_min_list=5,20,100 --set exp1.trees_list=1,10 --set exp1.cuts_list=1,10 \
	--set exp1.map_grid=11
"$PY" scripts/plot_exp1.py "$OUT/exp1"
run exp2 --set exp2.sizes=10,50,100 --set exp2.test=100 --set experiment.repetitions=2
"$PY" scripts/plot_exp2.py "$OUT/exp2"
run exp3 --set exp3.iterations=5 --set exp3.init_samples=60 --set exp3.window=60 \
	--set exp3.samples=10 --set experiment.repetitions=2 --set policy.n_min=20 \
	--set exp3.baseline_n_min=100 --set exp3.final_episodes=30
"$PY" scripts/plot_exp3.py "$OUT/exp3"
for b in quadratic sphere rosenbrock; do
	run $b --set experiment.repetitions=2 --set bench.iterations=10
	"$PY" scripts/plot_benchmarks.py "$OUT/$b"
done
for d in sim exp1 exp2 exp3; do
	cp "$OUT/$d"/*.png "$OUT/figures/"
done
for b in quadratic sphere rosenbrock; do
	cp "$OUT/$b/bench_curve.png" "$OUT/figures/bench_$b.png"
done
echo "reproduce: done in $(( $(date +%s) - start )) s; figures in $OUT/figures:"
ls "$OUT/figures"
