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

Parameter files are INI (`data/*.ini`); `poolreps config` writes the effective
configuration in the same form. Every key has a default and, where they apply, a
range and a unit. `--set section.key=value` overrides any key after the file, and
a command's `--help` lists the keys it reads. Errors name `file:line:
section.key`.

A parameter file that sets only `experiment.name` runs that experiment's setup:
some defaults depend on the experiment (the help text names them, e.g. `value.trees`
is 10 for exp3), until the key is set in the file or with `--set`.

This page is generated from `poolreps --help-keys` by `make man`
(`scripts/gen-params.sh`); a test fails when they differ. Lines read
`section.key = default [unit] range: meaning`; a range in parentheses excludes
that bound, braces list the choices.

```
HEAD
	printf '%s\n' "$keys"
	printf '```\n'
}

if [ "$out" = - ]; then
	page
else
	# write beside the target and rename, so a failure leaves the old page
	page > "$out.tmp"
	mv "$out.tmp" "$out"
fi
