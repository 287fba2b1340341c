#!/bin/sh
# bench_vector.sh — steps/s of the native vector env (poolreps.vector,
# `gymnasium.make_vec(..., vectorization_mode="vector_entry_point")`)
# against SyncVectorEnv at 256 envs, and the native env at 4096, on two
# action workloads (scripts/bench_vector.py says which). Needs Gymnasium:
# build/venv (`make venv`) or PYTHON_GYM; without it the bench says so and
# is skipped. RUNS (5) alternating rounds of SECONDS (1) each; the ratio is
# the median of the rounds' native / sync ratios. Also poolreps.shoot with
# and without per-row physics parameters (friction, restitution).
# CSV: build/bench/vector.csv (copy it to docs/bench_vector.csv, then
# `scripts/bench_vector_table.py --write` updates docs/python.md).
set -e
cd "$(dirname "$0")/.."
PY=${PYTHON_GYM:-build/venv/bin/python}
${MAKE:-make} -s SAN=0 build/rel/libpoolreps.so.0.1.0
if ! "$PY" -c "import gymnasium" 2>/dev/null; then
	echo "bench_vector: skipped, no Gymnasium for $PY (make venv)"
	exit 0
fi
export POOLREPS_LIB="$PWD/build/rel/libpoolreps.so.0.1.0"
mkdir -p build/bench
out=build/bench/vector.csv
"$PY" scripts/bench_vector.py --rounds "${RUNS:-5}" --seconds "${SECONDS_PER_ROUND:-1}" > "$out"
"$PY" scripts/bench_vector_table.py "$out"
