#!/bin/sh
# bench_sim.sh — simulator throughput: 2-ball shots from Experiment 3's
# start region, single thread, under both friction laws (table.friction_law)
# in the same run: 5 rounds, each timing the exponential law and then the
# constant law once, so both see the same machine; per law the median
# shots/s over the rounds, and the median of the rounds' constant /
# exponential ratios. Prints a markdown table; with --write FILE it also
# replaces the text between FILE's bench_sim markers with it. Run from
# anywhere: sh scripts/bench_sim.sh [--write docs/benchmarks.md]
set -e
cd "$(dirname "$0")/.."
BIN=build/rel/bench_sim
ROUNDS=${ROUNDS:-5}
${MAKE:-make} -s SAN=0 "$BIN"

field() { printf '%s\n' "$1" | tr ' ' '\n' | sed -n "s/^$2=//p"; }
median() { tr ' ' '\n' | grep . | sort -g | awk '{v[NR] = $1} END {print v[int((NR + 1) / 2)]}'; }

table() {
	verdict=""
	echo "| mode | actions | shots per run | exponential: median shots/s | constant: median shots/s | constant / exponential | events or steps per shot (exp. / const.) |"
	echo "|---|---|---:|---:|---:|---:|---:|"
	for cfg in "event gauss 1000000 1000000" "event uniform 1000000 1000000" \
	           "stepped gauss 10000 2000" "stepped uniform 10000 2000"; do
		set -- $cfg
		re="" rc="" ratio="" ee="" ec=""
		for r in $(seq $ROUNDS); do
			le=$("$BIN" --mode "$1" --law exponential --actions "$2" --shots "$3" --runs 1 --dt 0.001)
			lc=$("$BIN" --mode "$1" --law constant --actions "$2" --shots "$4" --runs 1 --dt 0.001)
			e=$(field "$le" median_shots_per_s) c=$(field "$lc" median_shots_per_s)
			re="$re $e" rc="$rc $c"
			ratio="$ratio $(awk -v c="$c" -v e="$e" 'BEGIN {printf "%.3f", c / e}')"
			ee=$(field "$le" events_per_shot) ec=$(field "$lc" events_per_shot)
		done
		label=$1
		[ "$1" = stepped ] && label="stepped, dt = 1 ms"
		shots=$3
		[ "$3" != "$4" ] && shots="$3 / $4"
		echo "| $label | $2 | $shots | $(echo "$re" | median) | $(echo "$rc" | median) |" \
		     "$(echo "$ratio" | median) | $ee / $ec |"
		target=1000000
		[ "$1" = stepped ] && target=20000
		verdict="$verdict; $1 $2: $(echo "$re" | median | awk -v t=$target '{print ($1 >= t ? "met" : "not met")}') / $(echo "$rc" | median | awk -v t=$target '{print ($1 >= t ? "met" : "not met")}')"
	done
	echo
	echo "Targets (event >= 1,000,000 shots/s, stepped >= 20,000), exponential / constant:${verdict#;}."
	echo
	echo "gauss: actions N(0, 0.1^2 I) (Experiment 3's initial policy); uniform: direction uniform,"
	echo "speed uniform in [0, 1.5] m/s. Reward ball uniform in [0.05,0.15]x[-0.1,0.1], cue (-0.25, 0)."
	echo "constant: table.deceleration = 0.0625 m/s^2; stepped mode under it runs every step's tests."
	echo "Load average over the last minute at the end: $(cut -d' ' -f1 /proc/loadavg) (2 cores)."
}

out=$(table)
printf '%s\n' "$out"
if [ "$1" = --write ]; then
	f=$2
	awk -v repl="$out" '
		/<!-- bench_sim:begin -->/ {print; print repl; skip = 1; next}
		/<!-- bench_sim:end -->/ {skip = 0}
		!skip {print}' "$f" > "$f.tmp"
	mv "$f.tmp" "$f"
fi
