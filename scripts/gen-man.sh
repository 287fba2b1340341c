#!/bin/sh
# Generate docs/poolreps.1 from `poolreps --help`, so the man page and the
# help text cannot drift apart (tests/test_cli.py checks they agree).
#   scripts/gen-man.sh ./poolreps > docs/poolreps.1
set -e
bin=${1:-./poolreps}
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
.SH USAGE
.nf
HEAD
"$bin" --help | sed -e 's/\\/\\\\/g' -e 's/^\./\\\&./' -e "s/^'/\\\\\&'/"
cat <<'TAIL'
.fi
.SH FILES
Parameter files for every experiment are installed under share/poolreps/data.
.SH SEE ALSO
README.md of the poolreps source tree.
TAIL
