#!/bin/sh
# gen-readme-keys.sh [POOLREPS [README]] — replace the parameter list between
# <!-- keys:begin --> and <!-- keys:end --> in the README with the
# "Parameter keys" part of `poolreps --help` (tests/test_readme.py checks it).
set -eu
bin=${1:-./poolreps}
readme=${2:-README.md}
keys=$(mktemp)
trap 'rm -f "$keys" "$readme.tmp"' EXIT
LC_ALL=C "$bin" --help | sed -n '/^Parameter keys/,$p' | sed -e :a -e '/^\n*$/{$d;N;ba' -e '}' >"$keys"
[ -s "$keys" ] || { echo "gen-readme-keys: no parameter list from $bin --help" >&2; exit 1; }
awk -v keys="$keys" '
	/<!-- keys:begin -->/ { print; print "```"; while ((getline l < keys) > 0) print l; print "```"; skip = 1; next }
	/<!-- keys:end -->/ { skip = 0 }
	!skip' "$readme" >"$readme.tmp"
mv "$readme.tmp" "$readme"
