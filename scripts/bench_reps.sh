#!/bin/sh
# bench_reps.sh — poolreps reps (whole process, and in-process through the
# Python binding) against scipy.optimize.minimize(method='trust-exact') on
# the same REPS dual in the same run (scripts/bench_reps.py), next to the
# previous poolreps built from git in this run (BENCH_BASE, default the
# last commit before the CSV input was read in parts on several threads
# and its numbers in place, 8 digits at a time;
# BENCH_BASE=none skips it), whole process and in-process: built by
# scripts/prev_build.sh in a temporary folder, removed afterwards. Table by
# scripts/bench_reps_table.py. CSV: build/bench/reps.csv (copy it to
# docs/bench_reps.csv, then `scripts/bench_reps_table.py --write` updates
# docs/benchmarks.md). Then the Hessian's rank-k update alone, poolreps'
# kernel against OpenBLAS's dsyrk (tests/bench/bench_syrk.c) on dense200's
# and dense140's shapes: build/bench/syrk.csv (docs/bench_syrk.csv).
set -e
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
BASE=${BENCH_BASE:-b65e7967daf272532ff0762ea311401f5cb10acf}
${MAKE:-make} -s SAN=0 build/rel/poolreps build/rel/libpoolreps.so.0.1.0 build/rel/bench_syrk
TMP=$(mktemp -d "${TMPDIR:-/tmp}/bench_reps.XXXXXX")
trap 'rm -rf "$TMP"' EXIT INT TERM
. scripts/prev_build.sh
PREV=$(prev_option "$BASE" "$TMP")
"$PY" scripts/bench_reps.py --runs "${RUNS:-3}" --csv build/bench/reps.csv $PREV
# key=value lines into CSV rows (the keys of the first line as the header)
for shape in "20000 200" "2000 140"; do
	set -- $shape
	build/rel/bench_syrk --rows "$1" --cols "$2" --runs 11
done | awk '{ for (i = 1; i <= NF; i++) { split($i, kv, "="); k[i] = kv[1]; v[i] = kv[2] }
	if (NR == 1) { for (i = 1; i <= NF; i++) printf "%s%s", k[i], i < NF ? "," : "\n" }
	for (i = 1; i <= NF; i++) printf "%s%s", v[i], i < NF ? "," : "\n" }' > build/bench/syrk.csv
cat build/bench/syrk.csv
"$PY" scripts/bench_reps_table.py build/bench/reps.csv
