#!/bin/sh
# Generate docs/parameters.md from `poolreps --help-keys`, so that the page
# and the program cannot drift apart (tests/test_readme.py checks that they
# agree).
#   scripts/gen-params.sh [POOLREPS [OUT]]    defaults: ./poolreps, docs/parameters.md
# OUT - writes to stdout. The page depends on the key list alone (C locale).
set -e
bin=${1:-./poolreps}
out=${2:-docs/parameters.md}
export LC_ALL=C
# fails here, before the page is touched, if the binary cannot run
keys=$("$bin" --help-keys)

page() {
	cat <<'HEAD'
# Parameters

Which keys there are, with default, unit and range. Parameter files are INI
(`data/*.ini`; `poolreps config` writes the effective one); `--set section.key=value`
overrides a key after the file; a command's `--help` lists the keys it reads. Some
defaults follow `experiment.name` (the meaning says so), until the key is set.
Why each default: [choices.md](choices.md).

Generated from `poolreps --help-keys` by `make man` (`scripts/gen-params.sh`); a test
fails when they differ. Lines read `section.key = default [unit] range: meaning`; a
range in parentheses excludes that bound, braces list the choices.

```
HEAD
	# one blank before '=': the page lists keys, it need not align them
	printf '%s\n' "$keys" | sed 's/^\(  [a-z0-9_.]*\)  *= /\1 = /'
	printf '```\n'
}

if [ "$out" = - ]; then
	page
else
	# write beside the target and rename, so a failure leaves the old page
	page > "$out.tmp"
	mv "$out.tmp" "$out"
fi
