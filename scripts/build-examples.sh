#!/bin/sh
# build-examples.sh STAGE LIBDIR OUTDIR [CC] [FLAGS] — build examples/*.c the
# way a user does, against the tree `make install DESTDIR=STAGE` wrote
# (LIBDIR: the install's library folder, without STAGE), through pkg-config:
# each example once against libpoolreps.so and once against libpoolreps.a.
# Checks the shared library's SONAME and that the shared builds need it.
set -e
stage=$1 libdir=$2 out=$3 cc=${4:-cc} flags=${5:-}
cd "$(dirname "$0")/.."
export PKG_CONFIG_PATH="$stage$libdir/pkgconfig" PKG_CONFIG_SYSROOT_DIR="$stage"
cflags=$(pkg-config --cflags poolreps)
libs=$(pkg-config --libs poolreps)
# static: the archive in place of -lpoolreps, plus its private dependencies
static=$(pkg-config --static --libs poolreps | sed "s|-lpoolreps|$stage$libdir/libpoolreps.a|")
soname=$(readelf -d "$stage$libdir/libpoolreps.so" | sed -n 's/.*(SONAME).*\[\(.*\)\]/\1/p')
[ "$soname" = libpoolreps.so.0 ] || { echo "build-examples: SONAME is '$soname'" >&2; exit 1; }
# strict C11, as the project compiles: the public headers need no feature macro
std="-std=c11 -pedantic"
mkdir -p "$out"
for src in examples/*.c; do
	name=$(basename "$src" .c)
	# shellcheck disable=SC2086 # word splitting of the flag lists is intended
	$cc $std -Wall -Wextra -Werror $flags $cflags "$src" $libs -o "$out/$name"
	readelf -d "$out/$name" | grep -q 'NEEDED.*\[libpoolreps.so.0\]' ||
		{ echo "build-examples: $out/$name does not link libpoolreps.so.0" >&2; exit 1; }
	# shellcheck disable=SC2086
	$cc $std -Wall -Wextra -Werror $flags $cflags "$src" $static -o "$out/$name-static"
done
echo "build-examples: $(ls examples/*.c | wc -l) examples built against $stage$libdir (shared and static)"
