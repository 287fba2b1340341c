#!/bin/sh
# bench_header.sh — a CSV header of 100 000 columns (the documented limit,
# one data row) read by `poolreps shoot`, which checks every name for
# duplicates and then refuses the ball count, against the previous version
# (the parent of the commit that made the duplicate check a hash set, built
# from git into build/prev-header) in the same run: RUNS (3) interleaved
# runs each, wall seconds. Both must give the same exit code and message.
# CSV: build/bench/header.csv (copy it to docs/bench_header.csv, then
# `scripts/bench_stream_table.py --write` updates docs/benchmarks.md).
set -e
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
${MAKE:-make} -s SAN=0 build/rel/poolreps
REF=${REF:-$(git log --format=%H -1 -S name_hash -- src/csvio.c)^}
PREV=build/prev-header
. scripts/prev_build.sh
prev_build "$REF" "$PREV"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$PY" -c "
n = 100000
print(','.join('c%d' % j for j in range(n)))
print(','.join('0' for j in range(n)))" > "$tmp/wide.csv"
mkdir -p build/bench
out=build/bench/header.csv
echo "columns,version,run,seconds" > "$out"
for r in $(seq "${RUNS:-3}"); do
	for v in hash_set previous; do
		b=build/rel/poolreps
		[ "$v" = previous ] && b=$PREV/build/rel/poolreps
		/usr/bin/time -f "%e" -o "$tmp/t" "$b" shoot -i "$tmp/wide.csv" -o /dev/null 2> "$tmp/$v.err" &&
			{ echo "bench_header.sh: $v accepted the 100 000-column shoot input" >&2; exit 1; }
		echo "100000,$v,$r,$(tail -n 1 "$tmp/t")" >> "$out"
		tail -n 1 "$out"
	done
	cmp -s "$tmp/hash_set.err" "$tmp/previous.err" ||
		{ echo "bench_header.sh: the two versions' messages differ:" >&2; cat "$tmp"/*.err >&2; exit 1; }
done
"$PY" scripts/bench_stream_table.py --header "$out"
