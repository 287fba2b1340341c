#!/bin/sh
# Record the SHA-256 of every CSV that the quick reproduction writes, so that
# tests/test_report.py can prove a change leaves every output byte alone.
#   scripts/gen-quick-sums.sh [POOLREPS [PYTHON [OUT]]]
# defaults: ./poolreps, python3, tests/data/quick_reproduce.sha256 (- for
# stdout). timings.csv holds wall times and is left out. Rerun (`make
# quick-sums`) only when an output is meant to change, and say why in the
# commit.
set -e
bin=${1:-./poolreps}
py=${2:-python3}
out=${3:-tests/data/quick_reproduce.sha256}
export LC_ALL=C
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
POOLREPS=$bin sh scripts/reproduce.sh "$tmp/out" "$py" 1 > "$tmp/log" 2>&1 ||
	{ tail -20 "$tmp/log" >&2; exit 1; }
sums() { (cd "$tmp/out" && find . -name '*.csv' ! -name timings.csv | sed 's|^\./||' | sort |
	xargs sha256sum); }
if [ "$out" = - ]; then
	sums
else
	sums > "$out.tmp"
	mv "$out.tmp" "$out"
fi
