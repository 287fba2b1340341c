#!/bin/sh
# bench_exp3.sh — the full Experiment 3: all six policies, five repetitions,
# thesis settings (data/exp3.ini).
#  1. This build with experiment.threads=1 and 2: wall time, CPU time,
#     episodes per second, peak memory; both runs must write the same bytes.
#  2. The same run next to the previous solver (L-BFGS REPS, uncentred
#     LWR), built from git in this run: a temporary git worktree at
#     BENCH_BASE (default: the last commit before the certified solver),
#     built in a temporary folder and removed afterwards. One thread, full
#     experiment and one repetition, wall and CPU time and the ratio.
#     BENCH_CALLGRIND=1 also counts instructions (valgrind --tool=callgrind)
#     for one repetition of each: a ratio that does not depend on the load.
# Run from anywhere: sh scripts/bench_exp3.sh   (target: one thread <= 10 s)
set -e
cd "$(dirname "$0")/.."
[ -x ./poolreps ] || make -s all
BASE=${BENCH_BASE:-69b070f0a1ad273120b5335944c16596a5934601}
TMP=$(mktemp -d "${TMPDIR:-/tmp}/bench_exp3.XXXXXX")
OLD="$TMP/previous"
cleanup() {
	if [ -d "$OLD" ]; then git worktree remove --force "$OLD" 2>/dev/null || rm -rf "$OLD"; fi
	git worktree prune 2>/dev/null || true
	rm -rf "$TMP"
}
trap cleanup EXIT INT TERM

now() { date +%s.%N; }

# run NAME BINARY THREADS [--set ...]: one timed run into $TMP/NAME; prints
# "wall cpu episodes mib"
run() {
	name=$1; bin=$2; t=$3; shift 3
	t0=$(now)
	"$bin" data/exp3.ini -q -o "$TMP/$name" --set experiment.threads="$t" "$@"
	t1=$(now)
	eps=$(($(wc -l < "$TMP/$name/exp3_episodes.csv") - 1))
	cpu=$(sed -n 's/^cpu_seconds: //p' "$TMP/$name/provenance.txt")
	mem=$(sed -n 's/^peak_memory_mib: //p' "$TMP/$name/provenance.txt")
	awk -v a="$t0" -v b="$t1" -v c="$cpu" -v n="$eps" -v m="$mem" 'BEGIN { printf "%.2f %s %d %s\n", b - a, c, n, m }'
}

echo "| threads | wall s | CPU s | episodes | episodes/s | peak MiB |"
echo "|---:|---:|---:|---:|---:|---:|"
for t in 1 2; do
	set -- $(run "t$t" ./poolreps "$t")
	awk -v t="$t" -v w="$1" -v c="$2" -v n="$3" -v m="$4" \
		'BEGIN { printf "| %d | %.1f | %.1f | %d | %.0f | %s |\n", t, w, c, n, n / w, m }'
done
for f in "$TMP"/t1/exp3_*.csv; do
	cmp -s "$f" "$TMP/t2/$(basename "$f")" || { echo "bench_exp3: $(basename "$f") differs between 1 and 2 threads" >&2; exit 1; }
done
echo
echo "Full Experiment 3: 6 policies x 5 repetitions x (200 + 100 x 20) episodes, with"
echo "REPS, forests and policy fits every iteration; $(nproc) CPU(s). Both runs wrote identical CSVs."

# the previous solver, from git
echo
git worktree add --detach -q "$OLD" "$BASE"
make -s -C "$OLD" -j2 all > "$TMP/build.log" 2>&1 || { cat "$TMP/build.log" >&2; exit 1; }
echo "Against the previous solver (git $(git rev-parse --short "$BASE"), built in this run), one thread:"
echo
echo "| run | this build: wall s | CPU s | previous: wall s | CPU s | CPU ratio (previous / this) |"
echo "|---|---:|---:|---:|---:|---:|"
for what in full one; do
	extra=""
	[ "$what" = one ] && extra="--set experiment.repetitions=1"
	set -- $(run "new_$what" ./poolreps 1 $extra)
	nw=$1 nc=$2
	set -- $(run "old_$what" "$OLD/poolreps" 1 $extra)
	awk -v r="$what" -v nw="$nw" -v nc="$nc" -v ow="$1" -v oc="$2" 'BEGIN {
		printf "| %s | %.1f | %.1f | %.1f | %.1f | %.1fx |\n",
		       r == "full" ? "full (5 repetitions)" : "one repetition", nw, nc, ow, oc, oc / nc }'
done
if [ "${BENCH_CALLGRIND:-0}" = 1 ]; then
	for v in new old; do
		bin=./poolreps
		[ "$v" = old ] && bin="$OLD/poolreps"
		valgrind --tool=callgrind --callgrind-out-file="$TMP/cg.$v" "$bin" data/exp3.ini -q \
			-o "$TMP/cg_$v" --set experiment.threads=1 --set experiment.repetitions=1 \
			> "$TMP/cg_$v.log" 2>&1
	done
	ir() { sed -n 's/^summary: //p' "$1"; }
	awk -v n="$(ir "$TMP/cg.new")" -v o="$(ir "$TMP/cg.old")" 'BEGIN {
		printf "\nInstructions (callgrind, one repetition): this build %.3g, previous %.3g, ratio %.1fx\n",
		       n, o, o / n }'
fi
echo
echo "The results differ between the two solvers (the weights now match the features and"
echo "KL to 1e-9, so the policies, and the episodes after them, take other paths)."
