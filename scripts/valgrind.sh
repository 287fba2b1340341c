#!/bin/sh
# valgrind.sh POOLREPS [PYTHON] — run the end-to-end pytest suite with every
# poolreps process under valgrind memcheck, and fail on any report.
#
# POOLREPS must be a build without sanitizers (make's build/rel/poolreps).
# A wrapper script in build/valgrind/ runs
#   valgrind -q --error-exitcode=99 --leak-check=full --errors-for-leak-kinds=definite
# with one log per process; the tests see it as env POOLREPS. Any non-empty
# log (or exit code 99, which fails the test that saw it) fails this script.
#
# Environment: JOBS, pytest workers; VALGRIND_PYTEST_ARGS, passed to pytest; the default,
#   -m "not slow and not native" --ignore=tests/test_exp3.py (and the
#   study tests: test_sensitivity, test_exp4_controls, test_baselines)
# skips tests marked slow, Experiment 3's and the studies' (they run whole
# studies, minutes each under valgrind; make check SAN=1 runs them),
# the run prints its length at the end. E.g.
# VALGRIND_PYTEST_ARGS='-k badinput' runs the bad-input suite alone.
set -u
if [ $# -lt 1 ] || [ -z "$1" ]; then
	echo "usage: valgrind.sh POOLREPS [PYTHON]" >&2
	exit 1
fi
bin=$1
py=${2:-}
[ -n "$py" ] || py=python3
cd "$(dirname "$0")/.." || exit 1
case $bin in
	/*) ;;
	*) bin=$(pwd)/$bin ;;
esac
if [ ! -x "$bin" ]; then
	echo "valgrind.sh: $bin is not an executable" >&2
	exit 1
fi
if ! command -v valgrind >/dev/null 2>&1; then
	echo "valgrind.sh: valgrind not found (Debian: apt-get install valgrind)" >&2
	exit 1
fi
if nm "$bin" 2>/dev/null | grep -q __asan_init; then
	echo "valgrind.sh: $bin is built with AddressSanitizer; use a plain build (make valgrind without SAN=1)" >&2
	exit 1
fi

# --track-origins=yes costs 15-25 % per process (measured on an exp1 run and a
# shot): VALGRIND_EXTRA=--track-origins=yes adds it to trace a report
VALGRIND_EXTRA=${VALGRIND_EXTRA:-}
logs=$(pwd)/build/valgrind
rm -rf "$logs"
mkdir -p "$logs" || exit 1
wrapper=$logs/poolreps
cat >"$wrapper" <<EOF
#!/bin/sh
exec valgrind -q --error-exitcode=99 --leak-check=full --errors-for-leak-kinds=definite \\
	--show-leak-kinds=definite $VALGRIND_EXTRA --log-file="$logs/vg.%p.log" "$bin" "\$@"
EOF
chmod +x "$wrapper" || exit 1

if [ -n "${VALGRIND_PYTEST_ARGS+set}" ]; then
	eval "set -- $VALGRIND_PYTEST_ARGS"
else
	set -- -m "not slow and not native" --ignore=tests/test_exp3.py \
		--ignore=tests/test_sensitivity.py --ignore=tests/test_exp4_controls.py \
		--ignore=tests/test_baselines.py
fi
export LC_ALL=C POOLREPS="$wrapper" POOLREPS_TIMEOUT_SCALE=30 PYTHON="$py"
start=$(date +%s)
# on JOBS pytest workers (pytest-xdist; default: the machine's cores)
"$py" -m pytest -q -p no:cacheprovider -n "${JOBS:-$(nproc 2>/dev/null || echo 2)}" "$@" tests
rc=$?
runs=$(find "$logs" -name 'vg.*.log' | wc -l)
reports=$(find "$logs" -name 'vg.*.log' -size +0c)
echo "valgrind.sh: $runs poolreps runs under valgrind in $(( $(date +%s) - start )) s"
if [ -n "$reports" ]; then
	echo "valgrind.sh: valgrind reported errors:" >&2
	for f in $reports; do
		echo "== $f" >&2
		head -40 "$f" >&2
	done
	exit 1
fi
if [ $rc -ne 0 ]; then
	echo "valgrind.sh: the test suite failed under valgrind (exit $rc)" >&2
	exit 1
fi
echo "valgrind.sh: OK, no reports"
