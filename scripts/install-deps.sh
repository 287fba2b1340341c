#!/bin/sh
# install-deps.sh [--extras] — install the Debian 12 packages poolreps needs
# to build and to run `make check`; with --extras also those of CI's extra
# stages, `make bench` and the tests that skip without them (fuzzers,
# valgrind, GNU Parallel, venv for pip, Slurm and sshd, chromium).
# As root it runs apt-get; otherwise it prints the exact command and stops
# if anything is missing.
set -e
PKGS="build-essential pkg-config git libgsl-dev libglpk-dev libcsv-dev libinih-dev \
libcmocka-dev python3 python3-numpy python3-scipy python3-matplotlib python3-pytest"
# tests that need these skip without them
EXTRAS="python3-venv python3-wheel parallel valgrind clang libclang-rt-14-dev \
slurm-wlm munge openssh-server chromium"
[ "${1:-}" = --extras ] && PKGS="$PKGS $EXTRAS"
missing=""
for p in $PKGS; do
	dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
[ -z "$missing" ] && { echo "install-deps: all Debian packages present"; exit 0; }
if [ "$(id -u)" = 0 ]; then
	export DEBIAN_FRONTEND=noninteractive
	apt-get update -qq
	apt-get install -y -qq --no-install-recommends $missing
else
	echo "install-deps: missing Debian packages:$missing" >&2
	echo "install-deps: run as root:  apt-get update && apt-get install -y$missing" >&2
	exit 1
fi
