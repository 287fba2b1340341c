#!/bin/sh
# bench_sim.sh — simulator throughput: 2-ball shots from
# Experiment 3's start region, single thread, median of 5 runs, as a
# markdown table. Run from anywhere: sh scripts/bench_sim.sh
set -e
cd "$(dirname "$0")/.."
BIN=build/rel/bench_sim
${MAKE:-make} -s SAN=0 "$BIN"

field() { printf '%s\n' "$1" | tr ' ' '\n' | sed -n "s/^$2=//p"; }

echo "| mode | actions | shots per run | median shots/s | min | max | events or steps per shot |"
echo "|---|---|---:|---:|---:|---:|---:|"
for cfg in "event gauss 1000000" "event uniform 1000000" "stepped gauss 10000" "stepped uniform 10000"; do
	set -- $cfg
	line=$("$BIN" --mode "$1" --actions "$2" --shots "$3" --runs 5 --dt 0.001)
	label=$1
	[ "$1" = stepped ] && label="stepped, dt = 1 ms"
	echo "| $label | $2 | $3 | $(field "$line" median_shots_per_s) | $(field "$line" min) |" \
	     "$(field "$line" max) | $(field "$line" events_per_shot) |"
done
echo
echo "gauss: actions N(0, 0.1^2 I) (Experiment 3's initial policy); uniform: direction uniform,"
echo "speed uniform in [0, 1.5] m/s. Reward ball uniform in [0.05,0.15]x[-0.1,0.1], cue (-0.25, 0)."
