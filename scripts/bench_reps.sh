#!/bin/sh
# bench_reps.sh — poolreps reps (whole process, and in-process through the
# Python binding) against scipy.optimize.minimize(method='trust-exact') on
# the same REPS dual in the same run (scripts/bench_reps.py), next to the
# previous poolreps built from git in this run (BENCH_BASE, default the
# last commit before the AVX2 tile shape and --threads;
# BENCH_BASE=none skips it), whole process and in-process: built by
# scripts/prev_build.sh in a temporary folder, removed afterwards. Table by
# scripts/bench_reps_table.py. CSV: build/bench/reps.csv (copy it to
# docs/bench_reps.csv, then `scripts/bench_reps_table.py --write` updates
# docs/benchmarks.md).
set -e
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
BASE=${BENCH_BASE:-3c70b8d459c5305283862cf23f218db5c37c71a7}
${MAKE:-make} -s SAN=0 build/rel/poolreps build/rel/libpoolreps.so.0.1.0
TMP=$(mktemp -d "${TMPDIR:-/tmp}/bench_reps.XXXXXX")
trap 'rm -rf "$TMP"' EXIT INT TERM
PREV=
if [ "$BASE" != none ]; then
	. scripts/prev_build.sh
	prev_build "$BASE" "$TMP/previous" build/rel/libpoolreps.so.0.1.0
	PREV="--previous $TMP/previous"
fi
"$PY" scripts/bench_reps.py --runs "${RUNS:-3}" --csv build/bench/reps.csv $PREV
"$PY" scripts/bench_reps_table.py build/bench/reps.csv
