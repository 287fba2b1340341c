#!/bin/sh
# bench_exp3.sh — the full Experiment 3 (issue 5): all six policies, five
# repetitions, thesis settings (data/exp3.ini), run once with
# experiment.threads=1 and once with 2; wall time, CPU time and episodes per
# second as a markdown table. Also checks that both runs wrote the same bytes.
# Run from anywhere: sh scripts/bench_exp3.sh   (target: under 60 s)
set -e
cd "$(dirname "$0")/.."
[ -x ./poolreps ] || make -s all
TMP=$(mktemp -d "${TMPDIR:-/tmp}/bench_exp3.XXXXXX")
trap 'rm -rf "$TMP"' EXIT INT TERM

now() { date +%s.%N; }

echo "| threads | wall s | CPU s | episodes | episodes/s | peak MiB |"
echo "|---:|---:|---:|---:|---:|---:|"
for t in 1 2; do
	t0=$(now)
	./poolreps data/exp3.ini -q -o "$TMP/t$t" --set experiment.threads=$t
	t1=$(now)
	eps=$(($(wc -l < "$TMP/t$t/exp3_episodes.csv") - 1))
	cpu=$(sed -n 's/^cpu_seconds: //p' "$TMP/t$t/provenance.txt")
	mem=$(sed -n 's/^peak_memory_mib: //p' "$TMP/t$t/provenance.txt")
	awk -v t="$t" -v a="$t0" -v b="$t1" -v n="$eps" -v c="$cpu" -v m="$mem" \
		'BEGIN { w = b - a; printf "| %d | %.1f | %.1f | %d | %.0f | %s |\n", t, w, c, n, n / w, m }'
done
for f in "$TMP"/t1/exp3_*.csv; do
	cmp -s "$f" "$TMP/t2/$(basename "$f")" || { echo "bench_exp3: $(basename "$f") differs between 1 and 2 threads" >&2; exit 1; }
done
echo
echo "Full Experiment 3: 6 policies x 5 repetitions x (200 + 100 x 20) episodes, with"
echo "REPS, forests and policy fits every iteration; $(nproc) CPU(s). Both runs wrote identical CSVs."
