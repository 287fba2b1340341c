#!/bin/sh
# bench_stream.sh — `poolreps shoot` streaming against the previous
# all-in-memory version (the parent of the commit that added src/shoot.c,
# built from git into build/prev), in the same run: wall seconds and peak
# RSS (/usr/bin/time -v) at 100 k, 2 M and 10 M rows of 4 balls + 2 actions
# (scripts/shoot_rows.py, written to a temporary folder and removed), and
# the ratios. CSV: build/bench/stream.csv. SIZES overrides the row counts.
set -e
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
${MAKE:-make} -s SAN=0 build/rel/poolreps
REF=${REF:-$(git log --format=%H -1 --diff-filter=A -- src/shoot.c)^}
PREV=build/prev
if [ ! -x "$PREV/build/rel/poolreps" ] || [ "$(cat "$PREV/.ref" 2>/dev/null)" != "$(git rev-parse "$REF")" ]; then
	rm -rf "$PREV" && mkdir -p "$PREV"
	git archive "$REF" | tar -x -C "$PREV"
	(cd "$PREV" && ${MAKE:-make} -s -j2 build/rel/poolreps >/dev/null)
	git rev-parse "$REF" > "$PREV/.ref"
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p build/bench
out=build/bench/stream.csv
echo "rows,version,seconds,peak_kib" > "$out"
for n in ${SIZES:-100000 2000000 10000000}; do
	"$PY" scripts/shoot_rows.py "$n" 1 > "$tmp/in.csv"
	for v in streaming previous; do
		b=build/rel/poolreps
		[ "$v" = previous ] && b=$PREV/build/rel/poolreps
		/usr/bin/time -f "%e %M" -o "$tmp/t" "$b" shoot -i "$tmp/in.csv" -o /dev/null
		set -- $(cat "$tmp/t")
		echo "$n,$v,$1,$2" >> "$out"
	done
	rm -f "$tmp/in.csv"
done
"$PY" - "$out" <<'PYEOF'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
print("| rows | streaming s | previous s | previous / streaming | streaming peak MiB | previous peak MiB | previous / streaming |")
print("|---:|---:|---:|---:|---:|---:|---:|")
for n in dict.fromkeys(r["rows"] for r in rows):
    s = next(r for r in rows if r["rows"] == n and r["version"] == "streaming")
    p = next(r for r in rows if r["rows"] == n and r["version"] == "previous")
    print(f"| {n} | {float(s['seconds']):.2f} | {float(p['seconds']):.2f} | "
          f"{float(p['seconds']) / float(s['seconds']):.2f} | {int(s['peak_kib']) / 1024:.1f} | "
          f"{int(p['peak_kib']) / 1024:.1f} | {int(p['peak_kib']) / int(s['peak_kib']):.2f} |")
PYEOF
