#!/bin/sh
# bench_python.sh — poolreps.shoot from Python against the C simulator bench
# (tests/bench/bench_sim.c) on the same workload: 2-ball shots from
# Experiment 3's start region, actions N(0, 0.1^2 I), 1,000,000 shots per
# run, one thread. Wall clock: runs alternate C, Python, C, ... so that both
# see the same machine load; the ratio is the median of the pairs' ratios.
# Instructions (when valgrind is installed): callgrind's count per extra
# shot (runs of 100,000 and 200,000 shots), which load does not disturb.
set -e
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
RUNS=${RUNS:-5}
SHOTS=${SHOTS:-1000000}
make -s build/rel/bench_sim build/rel/libpoolreps.so.0.1.0
export POOLREPS_LIB="$PWD/build/rel/libpoolreps.so.0.1.0"
field() { printf '%s\n' "$1" | tr ' ' '\n' | sed -n "s/^$2=//p"; }
crun() { build/rel/bench_sim --mode event --actions gauss --shots "$1" --runs 1; }
prun() { "$PY" scripts/bench_python.py --shots "$1" --runs 1; }
median() { printf '%s\n' $1 | sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }

c="" p="" r=""
i=0
while [ $i -lt "$RUNS" ]; do
	cs=$(field "$(crun "$SHOTS")" median_shots_per_s)
	line=$(prun "$SHOTS")
	ps=$(field "$line" median_shots_per_s)
	c="$c $cs" p="$p $ps" r="$r $(awk -v a="$ps" -v b="$cs" 'BEGIN { printf "%.3f", a / b }')"
	i=$((i + 1))
done
echo "| simulator call | runs | shots per run | median shots/s | all runs |"
echo "|---|---:|---:|---:|---|"
echo "| C: pr_sim_shoot loop (tests/bench/bench_sim.c) | $RUNS | $SHOTS | $(median "$c") |$c |"
echo "| Python: poolreps.shoot (scripts/bench_python.py) | $RUNS | $SHOTS | $(median "$p") |$p |"
echo
echo "Python / C, median of the $RUNS pairs: $(median "$r") (pairs:$r); events per shot $(field "$line" events_per_shot)"
if command -v valgrind >/dev/null 2>&1; then
	count() { valgrind --tool=callgrind --callgrind-out-file=/dev/null "$@" 2>&1 >/dev/null |
		sed -n 's/.*Collected : //p'; }
	c1=$(count build/rel/bench_sim --shots 100000 --runs 1)
	c2=$(count build/rel/bench_sim --shots 200000 --runs 1)
	p1=$(count "$PY" scripts/bench_python.py --shots 100000 --runs 1)
	p2=$(count "$PY" scripts/bench_python.py --shots 200000 --runs 1)
	awk -v c1="$c1" -v c2="$c2" -v p1="$p1" -v p2="$p2" 'BEGIN {
		c = (c2 - c1) / 100000; p = (p2 - p1) / 100000
		printf "Instructions per shot (callgrind): C %.0f, Python %.0f, Python / C = %.3f\n", c, p, p / c }'
fi
