#!/bin/sh
# Run every experiment, draw every figure (thesis Fig. 7.1-7.10, the REPS
# benchmarks) and write the report page, all into one results folder.
#   scripts/reproduce.sh OUT PYTHON [QUICK]
# OUT/<name>/: each experiment's CSVs, figures and provenance (the simulator
# figures' data in OUT/sim); OUT/figures/: every figure as PNG and SVG;
# OUT/timings.csv: wall seconds per step; OUT/report.html: the report page.
# QUICK=1: a smoke run at tiny sizes (CI), same code paths and scripts.
# POOLREPS=path picks the binary (default ./poolreps).
set -e
OUT=${1:-results}
PY=${2:-}
QUICK=${3:-}
BIN=${POOLREPS:-./poolreps}
[ -x "$BIN" ] || { echo "reproduce: build ./poolreps first (make)" >&2; exit 1; }
[ -n "$PY" ] || { echo "reproduce: no Python with matplotlib found; install python3-matplotlib or set PYTHON=" >&2; exit 1; }
export PYTHON="$PY"
mkdir -p "$OUT/figures"
# the figures of an earlier run must not outlive it
rm -f "$OUT/figures"/*.png "$OUT/figures"/*.svg "$OUT/figures"/*.pdf "$OUT/report.html"
echo "step,seconds" > "$OUT/timings.csv"
start=$(date +%s.%N)

timed() { # step name, then the command; appends its wall time to timings.csv
	step=$1; shift
	t0=$(date +%s.%N)
	"$@"
	t=$(echo "$t0 $(date +%s.%N)" | awk '{ printf "%.2f", $2 - $1 }')
	echo "$step,$t" >> "$OUT/timings.csv"
	echo "reproduce: $step took $t s"
}

run() { # name, then the --set options of the QUICK run
	name=$1; shift
	dir=$name; [ "$name" = figures ] && dir=sim
	if [ "$QUICK" = 1 ]; then
		timed "$name: run" "$BIN" "data/$name.ini" -o "$OUT/$dir" "$@"
	else
		timed "$name: run" "$BIN" "data/$name.ini" -o "$OUT/$dir"
	fi
	timed "$name: figures" sh scripts/plot "$OUT/$dir"
}

run figures
run exp1 --set exp1.train=200 --set exp1.test=200 --set exp1.subset=100 \
	--set exp1.test_subset=100 --set experiment.repetitions=2 \
	--set exp1.n_min_list=5,20,100 --set exp1.trees_list=1,10 --set exp1.cuts_list=1,10 \
	--set exp1.map_grid=11
run exp2 --set exp2.sizes=10,50,100 --set exp2.test=100 --set experiment.repetitions=2
run exp3 --set exp3.iterations=5 --set exp3.init_samples=60 --set exp3.window=60 \
	--set exp3.samples=10 --set experiment.repetitions=2 --set policy.n_min=20 \
	--set exp3.baseline_n_min=100 --set exp3.final_episodes=30
for b in quadratic sphere rosenbrock; do
	run $b --set experiment.repetitions=2 --set bench.iterations=10
done
for d in sim exp1 exp2 exp3; do
	cp "$OUT/$d"/*.png "$OUT/$d"/*.svg "$OUT/figures/"
done
for b in quadratic sphere rosenbrock; do
	for ext in png svg; do
		cp "$OUT/$b/bench_curve.$ext" "$OUT/figures/bench_$b.$ext"
	done
done
total=$(echo "$start $(date +%s.%N)" | awk '{ printf "%.2f", $2 - $1 }')
echo "total,$total" >> "$OUT/timings.csv"
quick=; [ "$QUICK" = 1 ] && quick=--quick
"$PY" scripts/report.py "$OUT" $quick
echo "reproduce: done in $total s; figures in $OUT/figures, report $OUT/report.html:"
ls "$OUT/figures"
