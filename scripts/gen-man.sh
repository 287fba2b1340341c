#!/bin/sh
# Generate the man page from `poolreps --help` and `poolreps --help-keys`, so
# that the man page and the help text cannot drift apart (tests/test_cli.py
# checks that they agree, tests/test_cli_options.py that both hold every
# option's help line). The help text is printed from the commands'
# option tables (src/cli/opts.c), the same tables the parser reads, and the
# keys from the configuration's key tables: one source for all three.
#   scripts/gen-man.sh [POOLREPS [OUT]]    defaults: ./poolreps, docs/poolreps.1
# OUT - writes to stdout. The page depends on the help text alone (no date,
# no version, C locale), so the same binary always gives the same bytes.
# Help layout: a line at column 0 ending in ':' becomes a subsection, a line
# "  section.key = ..." a tagged paragraph, any other text is kept verbatim.
set -e
bin=${1:-./poolreps}
out=${2:-docs/poolreps.1}
export LC_ALL=C
# fails here, not halfway through the page, if the binary cannot run
help=$("$bin" --help && echo && "$bin" --help-keys)

page() {
	cat <<'HEAD'
.TH POOLREPS 1 "" "poolreps" "User Commands"
.SH NAME
poolreps \- feature extraction for policy search: pool simulator, extra trees, REPS
.SH SYNOPSIS
.B poolreps
.I CONFIG
.br
.B poolreps
.I COMMAND
[\fIoptions\fR]
.SH DESCRIPTION
Reproduces and extends the thesis "Feature Extraction for Policy Search": an exact
event-driven and a time-stepped 2-D pool simulator, extremely randomized trees and
their features, episodic contextual REPS and a tree-based locally weighted regression
Gaussian policy, and the thesis's three experiments. Parameter files are INI; all
data in and out is CSV with a header row.
.PP
The sections below are the output of
.B "poolreps \-\-help"
and
.BR "poolreps \-\-help\-keys" .
.SH USAGE
HEAD
	printf '%s\n' "$help" | awk '
	# roff: a backslash is \e, a minus \- (an ASCII "-" when rendered, so that
	# options can be copied and searched), and no line may start with . or '\''
	function esc(s,   i, c, r) {
		r = ""
		for (i = 1; i <= length(s); i++) {
			c = substr(s, i, 1)
			if (c == "\\")
				c = "\\e"
			else if (c == "-")
				c = "\\-"
			r = r c
		}
		return r ~ /^[.'\'']/ ? "\\&" r : r
	}
	function fill() { if (nofill) { print ".fi"; nofill = 0 } gap = 0 }
	/^[A-Za-z].*:$/ { fill(); print ".SS " esc(substr($0, 1, length($0) - 1)); next }
	/^  [a-z0-9_]+\.[a-z0-9_]+ += / {
		fill()
		key = $1
		sub(/^ *[^ ]+ +/, "")
		print ".TP"
		print ".B " esc(key)
		print esc($0)
		next
	}
	# a blank line stays one only inside verbatim text
	/^$/ { gap = nofill; next }
	{
		if (!nofill) { print ".nf"; nofill = 1 } else if (gap) print ""
		gap = 0
		print esc($0)
	}
	END { fill() }'
	cat <<'TAIL'
.SH FILES
Parameter files for every experiment are installed under share/poolreps/data,
the helper scripts (job lists for GNU Parallel and Slurm, plots) under
share/poolreps/scripts.
.SH SEE ALSO
.BR parallel (1),
README.md of the poolreps source tree.
TAIL
}

if [ "$out" = - ]; then
	page
else
	# write beside the target and rename, so a failure leaves the old page
	page > "$out.tmp"
	mv "$out.tmp" "$out"
fi
