#!/bin/sh
# bench_python.sh — poolreps.shoot from Python against the C simulator bench
# (tests/bench/bench_sim.c: a pr_sim_shoot loop) and against the C call that
# poolreps.shoot makes (tests/bench/bench_bind.c: pr_bind_shoot, which also
# computes the reward and writes the output arrays), on the same workload:
# 2-ball shots from Experiment 3's start region, actions N(0, 0.1^2 I),
# 1,000,000 shots per run, one thread. Wall clock: runs alternate C, C bind,
# Python, Python with per-row parameters, ... so that all see the same
# machine load; each ratio is the median of the rounds' ratios.
# Instructions (when valgrind is installed): callgrind's count per extra
# shot (runs of 100,000 and 200,000 shots), which load does not disturb.
set -e
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
RUNS=${RUNS:-5}
SHOTS=${SHOTS:-1000000}
${MAKE:-make} -s SAN=0 build/rel/bench_sim build/rel/bench_bind build/rel/libpoolreps.so.0.1.0
export POOLREPS_LIB="$PWD/build/rel/libpoolreps.so.0.1.0"
field() { printf '%s\n' "$1" | tr ' ' '\n' | sed -n "s/^$2=//p"; }
crun() { build/rel/bench_sim --mode event --actions gauss --shots "$1" --runs 1; }
brun() { build/rel/bench_bind --shots "$1" --runs 1; }
prun() { "$PY" scripts/bench_python.py --shots "$1" --runs 1; }
qrun() { "$PY" scripts/bench_python.py --shots "$1" --runs 1 --params; }
median() { printf '%s\n' $1 | sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }

ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.3f", a / b }'; }
c="" b="" p="" q="" r="" rb="" rq=""
i=0
while [ $i -lt "$RUNS" ]; do
	cs=$(field "$(crun "$SHOTS")" median_shots_per_s)
	bs=$(field "$(brun "$SHOTS")" median_shots_per_s)
	line=$(prun "$SHOTS")
	ps=$(field "$line" median_shots_per_s)
	qs=$(field "$(qrun "$SHOTS")" median_shots_per_s)
	q="$q $qs" rq="$rq $(ratio "$ps" "$qs")"
	c="$c $cs" b="$b $bs" p="$p $ps" r="$r $(ratio "$ps" "$cs")" rb="$rb $(ratio "$ps" "$bs")"
	i=$((i + 1))
done
echo "| simulator call | runs | shots per run | median shots/s | all runs |"
echo "|---|---:|---:|---:|---|"
echo "| C: pr_sim_shoot loop (tests/bench/bench_sim.c) | $RUNS | $SHOTS | $(median "$c") |$c |"
echo "| C: pr_bind_shoot, with rewards and outputs (tests/bench/bench_bind.c) | $RUNS | $SHOTS | $(median "$b") |$b |"
echo "| Python: poolreps.shoot (scripts/bench_python.py) | $RUNS | $SHOTS | $(median "$p") |$p |"
echo "| Python: poolreps.shoot, friction and restitution per row (--params) | $RUNS | $SHOTS | $(median "$q") |$q |"
echo
echo "Python / C bench, median of the $RUNS rounds: $(median "$r") (rounds:$r)"
echo "Python / C pr_bind_shoot, median of the $RUNS rounds: $(median "$rb") (rounds:$rb)"
echo "Cost of per-row parameters (plain / --params shots/s), median of the $RUNS rounds: $(median "$rq") (rounds:$rq)"
echo "Events per shot: $(field "$line" events_per_shot)"
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
