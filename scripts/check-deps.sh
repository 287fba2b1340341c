#!/bin/sh
# check-deps.sh build|check [PYTHON] — probe the Debian packages that
# building (build) or testing (check) needs, without installing anything.
# Prints nothing when all are present; otherwise ONE line naming the missing
# packages and how to install them. The Makefile calls it before compiling.
mode=${1:-build}
py=${2:-}
CC=${CC:-cc}
missing=""
need() { missing="$missing $1"; }

cc_ok=1
command -v "$CC" >/dev/null 2>&1 || { cc_ok=0; need build-essential; }
# without a compiler the header probes below cannot tell anything
has_header() { [ $cc_ok = 0 ] || printf '#include <%s>\n' "$1" | $CC -E -x c - >/dev/null 2>&1; }
command -v pkg-config >/dev/null 2>&1 || need pkg-config
if command -v pkg-config >/dev/null 2>&1; then
	pkg-config --exists gsl || need libgsl-dev
else
	has_header gsl/gsl_rng.h || need libgsl-dev
fi
has_header csv.h || need libcsv-dev
has_header ini.h || need libinih-dev
has_header glpk.h || need libglpk-dev
has_header nlopt.h || need libnlopt-dev
{ PATH="$PATH:/sbin:/usr/sbin" ldconfig -p 2>/dev/null | grep -q 'libopenblas\.so\.0 '; } || need libopenblas0
if [ "$mode" = check ]; then
	# cmocka.h needs these headers first
	[ $cc_ok = 0 ] || printf '#include <stdarg.h>\n#include <stddef.h>\n#include <stdint.h>\n#include <setjmp.h>\n#include <cmocka.h>\n' |
		$CC -E -x c - >/dev/null 2>&1 || need libcmocka-dev
	[ -n "$py" ] || py=python3
	if command -v "$py" >/dev/null 2>&1; then
		for m in pytest:python3-pytest numpy:python3-numpy scipy:python3-scipy matplotlib:python3-matplotlib xdist:python3-pytest-xdist; do
			"$py" -c "import importlib.util as u, sys; sys.exit(u.find_spec('${m%%:*}') is None)" \
				2>/dev/null || need "${m#*:}"
		done
	else
		need "python3 python3-pytest python3-numpy python3-scipy python3-matplotlib python3-pytest-xdist"
	fi
fi
[ -z "$missing" ] && exit 0
echo "poolreps: missing Debian packages:$missing; install them with 'make deps' as root (or: apt-get update && apt-get install -y --no-install-recommends$missing)"
exit 1
