#!/bin/sh
# bench_sim.sh — simulator throughput: 2-ball shots from
# Experiment 3's start region, single thread, median of 5 runs, as a
# markdown table, under both friction laws (table.friction_law). Run from
# anywhere: sh scripts/bench_sim.sh
set -e
cd "$(dirname "$0")/.."
BIN=build/rel/bench_sim
${MAKE:-make} -s SAN=0 "$BIN"

field() { printf '%s\n' "$1" | tr ' ' '\n' | sed -n "s/^$2=//p"; }

echo "| mode | friction law | actions | shots per run | median shots/s | min | max | events or steps per shot |"
echo "|---|---|---|---:|---:|---:|---:|---:|"
for cfg in "event exponential gauss 1000000" "event exponential uniform 1000000" \
           "event constant gauss 1000000" "event constant uniform 1000000" \
           "stepped exponential gauss 10000" "stepped exponential uniform 10000" \
           "stepped constant gauss 2000" "stepped constant uniform 2000"; do
	set -- $cfg
	line=$("$BIN" --mode "$1" --law "$2" --actions "$3" --shots "$4" --runs 5 --dt 0.001)
	label=$1
	[ "$1" = stepped ] && label="stepped, dt = 1 ms"
	echo "| $label | $2 | $3 | $4 | $(field "$line" median_shots_per_s) | $(field "$line" min) |" \
	     "$(field "$line" max) | $(field "$line" events_per_shot) |"
done
echo
echo "gauss: actions N(0, 0.1^2 I) (Experiment 3's initial policy); uniform: direction uniform,"
echo "speed uniform in [0, 1.5] m/s. Reward ball uniform in [0.05,0.15]x[-0.1,0.1], cue (-0.25, 0)."
echo "constant: table.deceleration = 0.0625 m/s^2; stepped mode under it runs every step's tests."
