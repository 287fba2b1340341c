#!/bin/sh
# install-deps.sh [--extras] [--probe] — install the Debian 12 packages
# poolreps needs to build, reproduce and run `make check`; with --extras also
# those of CI's extra stages, `make bench` and the tests that skip without
# them (fuzzers, valgrind, GNU Parallel, venv for pip, Slurm and sshd,
# chromium).
# As root it runs apt-get. Otherwise, or with --probe, it installs nothing:
# when a package is missing it prints ONE line with the exact apt-get command
# and exits 2. A failing apt-get keeps its own messages and adds one line
# naming the step that failed (exit 1); nothing in the checkout is touched.
set -e
PKGS="build-essential pkg-config git libgsl-dev libglpk-dev libcsv-dev libinih-dev \
libnlopt-dev libcmocka-dev python3 python3-numpy python3-scipy python3-matplotlib \
python3-pytest python3-pytest-xdist"
# the 60-digit REPS reference (tests/ref_reps_mp.py)
PKGS="$PKGS python3-mpmath"
# LAPACK on OpenBLAS (loaded when first needed): wide REPS problems
PKGS="$PKGS libopenblas0"
# tests that need these skip without them
EXTRAS="python3-venv python3-wheel parallel valgrind clang libclang-rt-14-dev \
slurm-wlm munge openssh-server chromium time"
probe=0
for a in "$@"; do
	case $a in
	--extras) PKGS="$PKGS $EXTRAS" ;;
	--probe) probe=1 ;;
	*) echo "install-deps: unknown option '$a'" >&2; exit 2 ;;
	esac
done
missing=""
for p in $PKGS; do
	dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -z "$missing" ]; then
	[ $probe = 1 ] || echo "install-deps: all Debian packages present"
	exit 0
fi
if [ $probe = 1 ] || [ "$(id -u)" != 0 ]; then
	echo "poolreps: missing Debian packages:$missing; install them with 'make deps' as root (or: apt-get update && apt-get install -y --no-install-recommends$missing)" >&2
	exit 2
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq ||
	{ echo "install-deps: step 'apt-get update' failed (see apt's message above); nothing was installed" >&2; exit 1; }
apt-get install -y -qq --no-install-recommends $missing ||
	{ echo "install-deps: step 'apt-get install$missing' failed (see apt's message above)" >&2; exit 1; }
