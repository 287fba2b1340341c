#!/bin/sh
# reproduce-timed.sh MAKE JOBS OUT — what `make reproduce` runs after the
# install step: the build (JOBS parallel jobs), then scripts/reproduce.sh
# through `MAKE reproduce-run`, timed end to end: timings.csv gets a
# 'build' row and its 'total' counts from before the build. Then OUT/load.csv
# records how busy the machine was meanwhile: cores, wall seconds, the CPU
# seconds every process of the machine used (/proc/stat) and those this run
# used (its children, `times`). others_share = (machine - own) /
# (cores x wall): what other work took of the machine while it ran;
# tests/test_readme.py trusts a total as an idle-machine figure only when
# others_share < 0.1.
set -e
MAKE_CMD=$1 JOBS=$2 OUT=$3
# MAKE_CMD may hold words of its own (a make with options): it is split on purpose
busy() { awk '/^cpu / { printf "%.2f", ($2 + $3 + $4 + $7 + $8) / 100 }' /proc/stat; }
t0=$(date +%s.%N) b0=$(busy)
$MAKE_CMD -j"$JOBS" all
REPRODUCE_T0=$t0 $MAKE_CMD reproduce-run
t1=$(date +%s.%N) b1=$(busy)
# `times` (in this shell, not a subshell): this shell's own, then its
# children's user and system time
tf=$(mktemp "${TMPDIR:-/tmp}/poolreps-times.XXXXXX")
trap 'rm -f "$tf"' EXIT
times > "$tf"
own=$(awk 'NR == 2 { n = 0; for (i = 1; i <= 2; i++) { split($i, a, "m"); n += a[1] * 60 + a[2] } printf "%.2f", n }' "$tf")
cores=$(nproc 2>/dev/null || echo 1)
awk -v t0="$t0" -v t1="$t1" -v b0="$b0" -v b1="$b1" -v own="$own" -v c="$cores" 'BEGIN {
	w = t1 - t0; m = b1 - b0; o = (m - own) / (c * w); if (o < 0) o = 0
	print "cores,wall_s,machine_cpu_s,own_cpu_s,others_share"
	printf "%d,%.2f,%.2f,%.2f,%.3f\n", c, w, m, own, o }' > "$OUT/load.csv"
echo "reproduce: $(tail -n 1 "$OUT/load.csv" | awk -F, '{ printf "%.0f %% of the %d cores went to other work meanwhile", 100 * $5, $1 }')"
