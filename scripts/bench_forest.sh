#!/bin/sh
# bench_forest.sh — our extra trees against scikit-learn's ExtraTreesRegressor
# (docs/benchmarks.md). Both tools fit the same CSVs (written once with fixed
# seeds), each run in its own process, one core each (n_jobs=1):
# n in {200, 2000, 20000, 200000}, d in {2, 4, 10}, M = 30, n_min = 20,
# n_c = 1, 10000 test rows. Ours runs twice: K = 10 with replacement (the
# thesis's defaults) and K = d without replacement (sklearn's draw with
# max_features = 1.0). Five seeds up to n = 20000, one at n = 200000.
# Prints two markdown tables; raw runs in build/bench/forest_results.csv.
#
# scikit-learn and numpy are installed into build/bench-venv by pip. Usage:
#   sh scripts/bench_forest.sh [QUICK]   (QUICK=1: n up to 20000 only)
set -eu
ROOT=$(cd "$(dirname "$0")/.." && pwd)
cd "$ROOT"
QUICK=${1:-0}
OUT=build/bench
VENV=build/bench-venv
mkdir -p "$OUT/data"

BIN=build/rel/bench_forest
${MAKE:-make} -s SAN=0 "$BIN"

if ! "$VENV/bin/python" -c 'import sklearn, numpy' 2>/dev/null; then
	echo "bench_forest: installing scikit-learn and numpy into $VENV" >&2
	python3 -m venv "$VENV"
	"$VENV/bin/pip" install -q scikit-learn numpy >&2
fi
PY=$VENV/bin/python
HELPER=scripts/bench_forest_sklearn.py
"$PY" -c 'import sklearn, numpy, platform
print("scikit-learn", sklearn.__version__, "numpy", numpy.__version__,
      "python", platform.python_version())' >&2

# glibc raises its mmap threshold after large frees, so the buffers freed
# after parsing a CSV stay resident and inflate the peak of whatever runs
# next; a fixed threshold measures what each tool itself holds. It applies to
# both tools (scikit-learn's peak does not change with it; ours falls from
# about 135 to 106 MiB at n = 200000, d = 10).
export MALLOC_MMAP_THRESHOLD_=131072

NS="200 2000 20000 200000"
[ "$QUICK" = 1 ] && NS="200 2000 20000"
RES=$OUT/forest_results.csv
echo "tool,n,d,seed,fit,fit_cpu,predict,mse,leaves,maxrss_kb,base_kb" > "$RES"

# key=value line -> CSV fields
fields() {
	tr ' ' '\n' | awk -F= '
		$1=="fit"{f=$2} $1=="fit_cpu"{c=$2} $1=="predict"{p=$2} $1=="mse"{m=$2}
		$1=="leaves"{l=$2} $1=="maxrss_kb"{r=$2} $1=="base_kb"{b=$2}
		END{printf "%s,%s,%s,%s,%s,%s,%s\n", f, c, p, m, l, r, b}'
}

for d in 2 4 10; do
	TEST=$OUT/data/test_d$d.csv
	[ -f "$TEST" ] || "$PY" $HELPER gen --n 10000 --d $d --seed 999 --out "$TEST"
	for n in $NS; do
		TRAIN=$OUT/data/train_n${n}_d$d.csv
		[ -f "$TRAIN" ] || "$PY" $HELPER gen --n $n --d $d --seed $((n + d)) --out "$TRAIN"
		SEEDS="1 2 3 4 5"
		[ "$n" -ge 200000 ] && SEEDS="1"
		for s in $SEEDS; do
			r=$("$BIN" --seed $s --cuts 10 "$TRAIN" "$TEST" | fields)
			echo "ours_K10,$n,$d,$s,$r" >> "$RES"
			r=$("$BIN" --seed $s --cuts $d --without-replacement "$TRAIN" "$TEST" | fields)
			echo "ours_Kd,$n,$d,$s,$r" >> "$RES"
			r=$("$PY" $HELPER fit "$TRAIN" "$TEST" --seed $s --cuts 10 | fields)
			echo "sklearn,$n,$d,$s,$r" >> "$RES"
			echo "bench_forest: n=$n d=$d seed=$s done" >&2
		done
	done
done
"$PY" $HELPER table "$RES"
