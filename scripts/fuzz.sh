#!/bin/sh
# fuzz.sh SECONDS — build the libFuzzer harnesses of tests/fuzz/ with clang
# (ASan + UBSan; `make FUZZ=1 fuzz-bin`, so the flags are the Makefile's),
# run each for SECONDS from its seed corpus, then run every kept regression
# input once. Exits non-zero if a harness does not build, finds a crash, a
# leak, a timeout or an out-of-memory, or if a regression input fails.
# SECONDS = 0 runs the regression inputs only.
#
#   build/fuzz/fuzz_<name>          the harness binaries (the instrumented
#                                   library and its objects next to them)
#   build/fuzz/corpus/<name>/       the growing corpus (seeds stay untouched)
#   build/fuzz/crash-<name>-*       what libFuzzer found (crash-, leak-,
#                                   timeout-, oom-), to keep as a regression case
#   build/fuzz/<name>.log           the libFuzzer log
#
# Environment: FUZZ_CC (default clang), FUZZ_TIMEOUT (s per input, default 10),
# FUZZ_HARNESSES (default "config csv shoot provenance"), TMPDIR for the harnesses'
# scratch files (default /dev/shm when writable: on a disk, creating a file per
# input can cut the speed tenfold).
set -u
secs=${1:-20}
case $secs in
	''|*[!0-9]*) echo "fuzz.sh: SECONDS must be a whole number, got '$secs'" >&2; exit 1 ;;
esac
cd "$(dirname "$0")/.." || exit 1
cc=${FUZZ_CC:-clang}
timeout=${FUZZ_TIMEOUT:-10}
harnesses=${FUZZ_HARNESSES:-config csv shoot provenance}
out=build/fuzz

if ! command -v "$cc" >/dev/null 2>&1; then
	echo "fuzz.sh: $cc not found (Debian: apt-get install clang libclang-rt-14-dev)" >&2
	exit 1
fi
# shellcheck disable=SC2086
${MAKE:-make} -s FUZZ=1 FUZZ_CC="$cc" fuzz-bin || { echo "fuzz.sh: the harnesses do not build" >&2; exit 1; }
for h in $harnesses; do
	[ -x "$out/fuzz_$h" ] || { echo "fuzz.sh: no harness tests/fuzz/fuzz_$h.c" >&2; exit 1; }
done

if [ -z "${TMPDIR:-}" ] && [ -d /dev/shm ] && [ -w /dev/shm ]; then
	export TMPDIR=/dev/shm
fi
# libFuzzer's own leak check is on; UBSan must stop at the first report.
export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
fail=0
if [ "$secs" -gt 0 ]; then
	for h in $harnesses; do
		mkdir -p "$out/corpus/$h"
		dict=""
		[ -f "tests/fuzz/$h.dict" ] && dict="-dict=tests/fuzz/$h.dict"
		echo "fuzz.sh: fuzzing $h for $secs s (log: $out/$h.log)"
		# shellcheck disable=SC2086
		if "$out/fuzz_$h" -max_total_time="$secs" -timeout="$timeout" -rss_limit_mb=2048 \
			-max_len=20000 -print_final_stats=1 $dict -artifact_prefix="$out/crash-$h-" \
			"$out/corpus/$h" "tests/fuzz/corpus/$h" >"$out/$h.log" 2>&1; then
			grep -E '^(stat::number_of_executed_units|stat::peak_rss_mb)' "$out/$h.log" | sed "s/^/fuzz.sh: $h: /"
		else
			echo "fuzz.sh: $h FOUND A PROBLEM; tail of $out/$h.log:" >&2
			grep -E 'ERROR|SUMMARY|runtime error|fuzz harness|Test unit written' "$out/$h.log" | tail -8 >&2
			fail=1
		fi
	done
fi

# Every kept regression input, once, through its harness.
for h in $harnesses; do
	[ -d "tests/fuzz/regress/$h" ] || continue
	n=0
	for f in tests/fuzz/regress/"$h"/*; do
		[ -f "$f" ] || continue
		n=$((n + 1))
		if ! "$out/fuzz_$h" -timeout="$timeout" -rss_limit_mb=2048 "$f" >"$out/regress.log" 2>&1; then
			echo "fuzz.sh: regression input $f fails again:" >&2
			grep -E 'ERROR|SUMMARY|runtime error|fuzz harness' "$out/regress.log" | tail -5 >&2
			fail=1
		fi
	done
	echo "fuzz.sh: $h: $n regression inputs run"
done

if [ $fail -ne 0 ]; then
	echo "fuzz.sh: FAILED (inputs in $out/crash-*)" >&2
	exit 1
fi
echo "fuzz.sh: OK"
