#!/bin/sh
# bench_reps_wide.sh — REPS at thousands of features: poolreps against
# scipy's trust-exact in the same run (scripts/bench_reps_wide.py), n in
# {200, 2000, 20000} x d in {1000, 5151, 20000} where they fit. CSV:
# build/bench/reps_wide.csv (copy it to docs/bench_reps_wide.csv).
# BENCH_WIDE_MAX_CELLS (default 2e7) bounds n x d.
# BENCH_WIDE_BASE (default the last commit before the span path and
# LAPACK; none skips it): the previous poolreps, built from git by
# scripts/prev_build.sh in a temporary folder, removed afterwards.
set -e
cd "$(dirname "$0")/.."
BASE=${BENCH_WIDE_BASE:-619731f81dbb065e0d9f44a9480136adb6db32a2}
${MAKE:-make} -s SAN=0 build/rel/libpoolreps.so.0.1.0
TMP=$(mktemp -d "${TMPDIR:-/tmp}/bench_reps_wide.XXXXXX")
trap 'rm -rf "$TMP"' EXIT INT TERM
. scripts/prev_build.sh
PREV=$(prev_option "$BASE" "$TMP")
"${PYTHON:-python3}" scripts/bench_reps_wide.py --csv build/bench/reps_wide.csv \
	--max-cells "${BENCH_WIDE_MAX_CELLS:-2e7}" $PREV
