#!/bin/sh
# bench_sim.sh — simulator throughput: 2-ball shots from Experiment 3's
# start region, single thread, under the three friction laws
# (table.friction_law) in the same run: 5 rounds, each timing the
# exponential, the constant and the slide_roll law once, so all see the same
# machine; per law the median shots/s over the rounds, and the median of the
# rounds' ratios to the exponential law. Prints a markdown table; with --write FILE it also
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
	echo "| mode | actions | shots per run | exponential: median shots/s | constant: median shots/s | slide_roll: median shots/s | constant / exponential | slide_roll / exponential | events or steps per shot (exp. / const. / slide_roll) |"
	echo "|---|---|---:|---:|---:|---:|---:|---:|---:|"
	for cfg in "event gauss 1000000 1000000" "event uniform 1000000 1000000" \
	           "stepped gauss 10000 2000" "stepped uniform 10000 2000"; do
		set -- $cfg
		re="" rc="" rs="" ratio="" ratios="" ee="" ec="" es=""
		for r in $(seq $ROUNDS); do
			le=$("$BIN" --mode "$1" --law exponential --actions "$2" --shots "$3" --runs 1 --dt 0.001)
			lc=$("$BIN" --mode "$1" --law constant --actions "$2" --shots "$4" --runs 1 --dt 0.001)
			ls=$("$BIN" --mode "$1" --law slide_roll --actions "$2" --shots "$4" --runs 1 --dt 0.001)
			e=$(field "$le" median_shots_per_s) c=$(field "$lc" median_shots_per_s)
			sr=$(field "$ls" median_shots_per_s)
			re="$re $e" rc="$rc $c" rs="$rs $sr"
			ratio="$ratio $(awk -v c="$c" -v e="$e" 'BEGIN {printf "%.3f", c / e}')"
			ratios="$ratios $(awk -v c="$sr" -v e="$e" 'BEGIN {printf "%.3f", c / e}')"
			ee=$(field "$le" events_per_shot) ec=$(field "$lc" events_per_shot)
			es=$(field "$ls" events_per_shot)
		done
		label=$1
		[ "$1" = stepped ] && label="stepped, dt = 1 ms"
		shots=$3
		[ "$3" != "$4" ] && shots="$3 / $4"
		echo "| $label | $2 | $shots | $(echo "$re" | median) | $(echo "$rc" | median) |" \
		     "$(echo "$rs" | median) | $(echo "$ratio" | median) | $(echo "$ratios" | median) |" \
		     "$ee / $ec / $es |"
		target=1000000
		[ "$1" = stepped ] && target=20000
		met() { median | awk -v t=$target '{print ($1 >= t ? "met" : "not met")}'; }
		verdict="$verdict; $1 $2: $(echo "$re" | met) / $(echo "$rc" | met) / $(echo "$rs" | met)"
	done
	echo
	echo "Targets (event >= 1,000,000 shots/s, stepped >= 20,000), exponential / constant / slide_roll:${verdict#;}."
	echo
	echo "gauss: actions N(0, 0.1^2 I) (Experiment 3's initial policy); uniform: direction uniform,"
	echo "speed uniform in [0, 1.5] m/s. Reward ball uniform in [0.05,0.15]x[-0.1,0.1], cue (-0.25, 0)."
	echo "constant: table.deceleration = 0.0625 m/s^2; slide_roll: mu_s = 0.2, mu_r = 0.01; stepped mode"
	echo "under either runs every step's tests."
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
