#!/bin/sh
# bench_stream.sh — the row filters that stream (`shoot`, `forest --test`,
# `policy -i`) against the previous all-in-memory version (the parent of
# the commit that added src/shoot.c, built from git into build/prev), in
# the same run, interleaved: wall seconds and peak RSS (/usr/bin/time) at
# 100 k, 2 M and 10 M rows of 4 balls + 2 actions (scripts/shoot_rows.py,
# written to a temporary folder and removed), and the seconds until the
# first result row reached the pipe the output goes to
# (scripts/first_row.py). forest and policy are fitted on 500 other rows
# (forest: targets vx,vy; policy: state x0,y0, action vx,vy). CSV:
# build/bench/stream.csv (copy it to docs/bench_stream.csv, then
# `scripts/bench_stream_table.py --write` updates docs/benchmarks.md).
# SIZES overrides the row counts, CMDS the commands,
# VERSIONS the versions (one of them: no table) and OUT the CSV, so that
# parts can run side by side on a busy machine and be concatenated.
set -e
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
${MAKE:-make} -s SAN=0 build/rel/poolreps
REF=${REF:-$(git log --format=%H -1 --diff-filter=A -- src/shoot.c)^}
PREV=build/prev
. scripts/prev_build.sh
prev_build "$REF" "$PREV"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p build/bench
out=${OUT:-build/bench/stream.csv}
echo "command,rows,version,seconds,peak_kib,first_row_s" > "$out"
"$PY" scripts/shoot_rows.py 500 2 > "$tmp/tr.csv"
for n in ${SIZES:-100000 2000000 10000000}; do
	"$PY" scripts/shoot_rows.py "$n" 1 > "$tmp/in.csv"
	for c in ${CMDS:-shoot forest policy}; do
		case $c in
		shoot) set -- shoot -i "$tmp/in.csv" ;;
		forest) set -- forest --train "$tmp/tr.csv" --test "$tmp/in.csv" --target vx,vy -q ;;
		policy) set -- policy --train "$tmp/tr.csv" --state x0,y0 --action vx,vy -i "$tmp/in.csv" -q ;;
		esac
		for v in ${VERSIONS:-streaming previous}; do
			b=build/rel/poolreps
			[ "$v" = previous ] && b=$PREV/build/rel/poolreps
			first=$("$PY" scripts/first_row.py /usr/bin/time -f "%e %M" -o "$tmp/t" "$b" "$@")
			echo "$c,$n,$v,$(tr ' ' , < "$tmp/t"),$first" >> "$out"
			tail -n 1 "$out"
		done
	done
	rm -f "$tmp/in.csv"
done
[ -n "$VERSIONS" ] || "$PY" scripts/bench_stream_table.py "$out"
