#!/bin/sh
# bench_sweep.sh — setting up `poolreps sweep` over one key of 20 000 values
# (400 000 jobs of data/sphere.ini), against the previous version (the
# parent of the commit that dropped the folder per grid point, built from
# git into build/prev-sweep) in the same run: RUNS (3) interleaved runs
# each into a fresh folder, wall, user and system seconds. Both must write
# the same manifest.csv.
# CSV: build/bench/sweep.csv.
set -e
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
${MAKE:-make} -s SAN=0 build/rel/poolreps
REF=${REF:-$(git log --format=%H -1 -S JOBLINE -- src/tool/sweep.c)^}
PREV=build/prev-sweep
. scripts/prev_build.sh
prev_build "$REF" "$PREV"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
values=$(seq -s, 2 20001)
mkdir -p build/bench
out=build/bench/sweep.csv
echo "values,version,run,wall_seconds,user_seconds,system_seconds" > "$out"
# time_setup VERSION BINARY RUN: one sweep set up into a fresh $tmp/VERSION
time_setup() {
	rm -rf "${tmp:?}/$1"
	/usr/bin/time -f "20000,$1,$3,%e,%U,%S" -o "$tmp/t" "$2" sweep data/sphere.ini -q \
		--grid "bench.samples=$values" -o "$tmp/$1"
	tail -n 1 "$tmp/t" | tee -a "$out"
}
for r in $(seq "${RUNS:-3}"); do
	time_setup jobs_table build/rel/poolreps "$r"
	time_setup previous "$PREV/build/rel/poolreps" "$r"
	cmp -s "$tmp/jobs_table/manifest.csv" "$tmp/previous/manifest.csv" ||
		{ echo "bench_sweep.sh: the two versions' manifests differ" >&2; exit 1; }
done
"$PY" - "$out" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
med = {v: statistics.median(float(r["wall_seconds"]) for r in rows if r["version"] == v)
       for v in ("jobs_table", "previous")}
print(f"sweep setup, 20 000 values: median wall {med['jobs_table']:.2f} s, previous "
      f"{med['previous']:.2f} s, ratio {med['previous'] / med['jobs_table']:.1f}x")
PY
