#!/bin/sh
# bench_reps.sh — poolreps reps (whole process, and in-process through the
# Python binding) against scipy.optimize.minimize(method='trust-exact') on
# the same REPS dual in the same run (scripts/bench_reps.py); table by
# scripts/bench_reps_table.py. CSV: build/bench/reps.csv (copy it to
# docs/bench_reps.csv to update docs/benchmarks.md).
set -e
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
${MAKE:-make} -s SAN=0 build/rel/poolreps build/rel/libpoolreps.so.0.1.0
"$PY" scripts/bench_reps.py --runs "${RUNS:-3}" --csv build/bench/reps.csv
"$PY" scripts/bench_reps_table.py build/bench/reps.csv
