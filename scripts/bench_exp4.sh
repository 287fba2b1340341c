#!/bin/sh
# bench_exp4.sh — Experiment 4 at full settings (data/exp4.ini, one thread,
# the longest step of `make reproduce`), this build against the previous
# poolreps built from git in the same run (BENCH_BASE, default the last
# commit before the split scan and the residual covariance's own sums;
# built by scripts/prev_build.sh in a temporary folder, removed
# afterwards), RUNS times each (default 2), interleaved so that a change in
# the machine's load falls on both. Each run's user + system CPU seconds and
# wall seconds, and the sha256 of its CSVs, go to build/bench/exp4.csv (copy
# it to docs/bench_exp4.csv, then `scripts/bench_exp4_table.py --write`
# updates docs/benchmarks.md).
set -e
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
BASE=${BENCH_BASE:-a5faee2ec862494f454e3460e597429c1ea2936f}
RUNS=${RUNS:-2}
${MAKE:-make} -s SAN=0 build/rel/poolreps
TMP=$(mktemp -d "${TMPDIR:-/tmp}/bench_exp4.XXXXXX")
trap 'rm -rf "$TMP"' EXIT INT TERM
. scripts/prev_build.sh
prev_build "$BASE" "$TMP/previous"
mkdir -p build/bench
out=build/bench/exp4.csv
echo "version,run,cpu_s,wall_s,csv_sha256" > "$out.tmp"
i=1
while [ "$i" -le "$RUNS" ]; do
	for v in previous current; do
		bin=$PWD/build/rel/poolreps
		[ "$v" = current ] || bin=$TMP/previous/build/rel/poolreps
		/usr/bin/time -f "%U %S %e" -o "$TMP/time" \
			"$bin" data/exp4.ini -q -o "$TMP/run-$v-$i" --set experiment.threads=1
		sum=$(cd "$TMP/run-$v-$i" && cat ./*.csv | sha256sum | cut -d' ' -f1)
		awk -v v="$v" -v i="$i" -v s="$sum" '{printf "%s,%d,%.2f,%.2f,%s\n", v, i, $1 + $2, $3, s}' \
			"$TMP/time" >> "$out.tmp"
		rm -rf "$TMP/run-$v-$i"
	done
	i=$((i + 1))
done
mv "$out.tmp" "$out"
"$PY" scripts/bench_exp4_table.py "$out"
