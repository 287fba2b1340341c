#!/bin/sh
# bench_csv_read.sh — the CSV reader's speed machinery against the plain way,
# on a user's workload: `poolreps reps` on a 1e6-row input (a return and 6
# features, 17 significant digits, 137 MB), whole process, in one run.
#   scripts/bench_csv_read.sh [ROUNDS] [PYTHON]       (default 5 rounds)
# Three builds of this checkout (git archive HEAD into build/bench_csv/):
#   plain     libcsv + strtod: the decimal parser compiled out
#             (-U__SIZEOF_INT128__ takes decimal.c's strtod branch) and
#             every line through libcsv
#   decimal   libcsv + the exact decimal parser (src/decimal.c)
#   bypass    + plain lines split without libcsv, numbers read in place
#             (this checkout as it is)
# Two pieces measured by the earlier version of this script are gone: the
# input read in parts on every core, and the thread stacks pr_run_parts
# mapped by hand (their rows in docs/bench_csv_read.csv, until a new run).
# The rounds interleave the builds; every build's weights must be the same
# bytes. Raw times to docs/bench_csv_read.csv; scripts/bench_csv_read.py
# --write puts the medians into docs/benchmarks.md.
set -e
ROUNDS=${1:-5}
PY=${2:-${PYTHON:-/usr/bin/python3}}
here=$(cd "$(dirname "$0")/.." && pwd)
b=$here/build/bench_csv
rm -rf "$b"
mkdir -p "$b"
for v in plain decimal bypass; do
	mkdir -p "$b/$v"
	(cd "$here" && git archive HEAD) | tar -x -C "$b/$v"
done
# the one place the bypass is decided: libcsv between records
for v in plain decimal; do
	sed -i 's|int direct = !(r->flags \& PR_CSV_LIBCSV_ONLY) \&\& r->idle;|int direct = 0 \&\& r->idle;|' "$b/$v/src/csvio.c"
	grep -q 'int direct = 0 &&' "$b/$v/src/csvio.c" || { echo "bench_csv_read: cannot switch the bypass off" >&2; exit 1; }
done
for v in plain decimal bypass; do
	x=; [ "$v" = plain ] && x=-U__SIZEOF_INT128__
	(cd "$b/$v" && make -j2 build/rel/poolreps CFLAGS="-O2 -g $x" > build.log 2>&1) ||
		{ echo "bench_csv_read: the $v build failed ($b/$v/build.log)" >&2; exit 1; }
done
"$PY" - "$b/reps1e6.csv" <<'PYEOF'
import sys
import numpy as np
rng = np.random.default_rng(1)
n, d = 1_000_000, 6
rows = np.column_stack([rng.normal(size=n), rng.normal(size=(n, d))])
with open(sys.argv[1], "w") as f:
    f.write("R," + ",".join(f"f{j}" for j in range(d)) + "\n")
    for r in rows:
        f.write(",".join(repr(float(x)) for x in r) + "\n")
PYEOF
out=$here/docs/bench_csv_read.csv
load0=$(cut -d' ' -f1 /proc/loadavg)
echo "round,build,threads,wall_s,cpu_s,load_avg" > "$out.tmp"
for r in $(seq "$ROUNDS"); do
	for spec in plain:1 decimal:1 bypass:1; do
		v=${spec%:*}; t=${spec#*:}
		/usr/bin/time -f "%e %U %S" -o "$b/t" "$b/$v/build/rel/poolreps" reps --return R \
			--features 'f*' --threads "$t" -i "$b/reps1e6.csv" -o "$b/w_$v.csv"
		read -r wall user sys < "$b/t"
		echo "$r,$v,$t,$wall,$(echo "$user $sys" | awk '{ printf "%.2f", $1 + $2 }'),$(cut -d' ' -f1 /proc/loadavg)" >> "$out.tmp"
	done
done
for v in plain decimal; do
	cmp -s "$b/w_$v.csv" "$b/w_bypass.csv" || { echo "bench_csv_read: $v's weights differ" >&2; exit 1; }
done
mv "$out.tmp" "$out"
echo "bench_csv_read: $ROUNDS rounds into $out (load average $load0 at the start)"
"$PY" "$here/scripts/bench_csv_read.py" --write
