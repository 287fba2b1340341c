#!/bin/sh
# bench_sim_instructions.sh — instructions per event-mode shot under each
# friction law, counted by callgrind (independent of the machine's load):
# the difference between runs of N and 2N shots over N, so the setup (the
# pool of states and actions) cancels. Run from anywhere; needs valgrind.
#   sh scripts/bench_sim_instructions.sh [N]   (default 40000)
set -e
cd "$(dirname "$0")/.."
BIN=build/rel/bench_sim
N=${1:-40000}
${MAKE:-make} -s SAN=0 "$BIN"
count() {
	valgrind --tool=callgrind --callgrind-out-file=/dev/null "$BIN" --mode event --runs 1 "$@" 2>&1 >/dev/null |
		sed -n 's/.*Collected : //p'
}
echo "| friction law | actions | instructions per shot |"
echo "|---|---|---:|"
for law in exponential constant slide_roll; do
	for a in gauss uniform; do
		c1=$(count --law "$law" --actions "$a" --shots "$N")
		c2=$(count --law "$law" --actions "$a" --shots $((2 * N)))
		echo "| $law | $a | $(( (c2 - c1) / N )) |"
	done
done
