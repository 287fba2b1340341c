#!/bin/sh
# bench_vector.sh — steps/s of the native vector env (poolreps.vector,
# `gymnasium.make_vec(..., vectorization_mode="vector_entry_point")`)
# against SyncVectorEnv at 256 envs, and the native env at 4096, on two
# action workloads (scripts/bench_vector.py says which). Needs Gymnasium:
# build/venv (`make venv`) or PYTHON_GYM; without it the bench says so and
# is skipped. RUNS (5) alternating rounds of SECONDS (1) each; the ratio is
# the median of the rounds' native / sync ratios.
# CSV: build/bench/vector.csv.
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
"$PY" - "$out" <<'PYEOF'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
rate = {(r["workload"], int(r["envs"]), r["kind"], int(r["round"])): float(r["steps_per_s"])
        for r in rows}
print("| workload | envs | vector env | median steps/s | native / sync (median of rounds) |")
print("|---|---:|---|---:|---:|")
for w, n, kind in sorted({k[:3] for k in rate}):
    rounds = sorted(k[3] for k in rate if k[:3] == (w, n, kind))
    med = statistics.median(rate[(w, n, kind, r)] for r in rounds)
    ratio = ""
    if kind == "native" and all((w, n, "sync", r) in rate for r in rounds):
        ratio = f"{statistics.median(rate[(w, n, kind, r)] / rate[(w, n, 'sync', r)] for r in rounds):.0f}x"
    print(f"| {w} | {n} | {kind} | {med:.0f} | {ratio} |")
PYEOF
