#!/bin/sh
# Run every experiment, draw every figure (thesis Fig. 7.1-7.10, the REPS
# benchmarks) and write the report page, all into one results folder.
#   scripts/reproduce.sh OUT PYTHON [QUICK]
# OUT/<name>/: each experiment's CSVs, figures and provenance (the simulator
# figures' data in OUT/sim); OUT/figures/: every figure as PNG and SVG;
# OUT/timings.csv: wall seconds per step; OUT/report.html: the report page.
# QUICK=1: a smoke run at tiny sizes (CI), same code paths and scripts: the
# keys of data/quick/<name>.ini on top of data/<name>.ini.
# POOLREPS=path picks the binary (default ./poolreps).
# Experiment 4, the longest, runs in the background beside the others. The
# figures are drawn by ONE Python process (scripts/plot_all.py) that takes
# each folder as soon as its experiment has finished, so drawing overlaps
# the runs; timings.csv lists each run as it ends, then each folder's
# drawing time.
# All or nothing: everything is made in a staging folder OUT/.reproduce-stage.*
# and published only when complete, by renames (the folders and files above
# replace theirs whole; anything else in OUT stays); interrupted, the
# previous results stay complete. OUT/.reproduce-files records what was
# published: a file a user put into a result folder since is refused before
# any work, as its folder would be replaced. A second reproduction into the same OUT
# while one runs is refused (a lock on OUT).
set -e
OUT=${1:-results}
PY=${2:-}
QUICK=${3:-}
BIN=${POOLREPS:-./poolreps}
[ -x "$BIN" ] || { echo "reproduce: build ./poolreps first (make)" >&2; exit 1; }
[ -n "$PY" ] || { echo "reproduce: no Python with matplotlib found; install python3-matplotlib or set PYTHON=" >&2; exit 1; }
export PYTHON="$PY"
# the experiments, their folders and kinds: the library's registry, the one
# list (plot_all.py and report.py read it through the same binary)
export POOLREPS="$BIN"
reg=$("$BIN" help experiments | tail -n +2 | cut -d, -f1-3)
[ -n "$reg" ] || { echo "reproduce: $BIN help experiments listed nothing" >&2; exit 1; }
FINAL=$OUT
mkdir -p "$FINAL"
# one reproduction per OUT: the lock lasts as long as this shell (fd 9)
exec 9< "$FINAL"
flock -n 9 || { echo "reproduce: $FINAL: another reproduction is writing into it; wait for it to end" >&2; exit 1; }
# what is published, each replaced whole; the record of their paths
ENTRIES="$(echo "$reg" | cut -d, -f2 | sort -u | tr '\n' ' ')figures timings.csv report.html"
RECORD=.reproduce-files
if [ -f "$FINAL/$RECORD" ]; then
	for e in $ENTRIES; do
		[ -d "$FINAL/$e" ] && [ ! -L "$FINAL/$e" ] || continue
		mine=$(cd "$FINAL" && find "$e" | LC_ALL=C sort | LC_ALL=C comm -23 - "$RECORD" | head -n 1)
		[ -z "$mine" ] || { echo "reproduce: $FINAL/$mine: not written by a reproduction; move it out of $FINAL/$e, which is replaced whole" >&2; exit 1; }
	done
fi
# a staging folder left by a killed run: no live run holds it (the lock)
rm -rf "$FINAL"/.reproduce-stage.*
OUT=$(mktemp -d "$FINAL/.reproduce-stage.XXXXXX")
mkdir "$OUT/figures"
echo "step,seconds" > "$OUT/timings.csv"
start=$(date +%s.%N)
# through `make reproduce` the clock started before the build
if [ -n "${REPRODUCE_T0:-}" ]; then
	echo "build,$(echo "$REPRODUCE_T0 $start" | awk '{ printf "%.2f", $2 - $1 }')" >> "$OUT/timings.csv"
	start=$REPRODUCE_T0
fi

timed() { # step name, then the command; appends its wall time to timings.csv
	step=$1; shift
	t0=$(date +%s.%N)
	# in a background run (run_bg) the command is waited for, so that the
	# TERM trap can pass the signal on to it
	if [ -n "$bg_run" ]; then
		"$@" &
		child=$!
		wait "$child"
		child=
	else
		"$@"
	fi
	t=$(echo "$t0 $(date +%s.%N)" | awk '{ printf "%.2f", $2 - $1 }')
	echo "$step,$t" >> "$OUT/timings.csv"
	echo "reproduce: $step took $t s"
}

# the plotting process reads finished folders from a FIFO in a private
# folder that is removed however this script ends
tmp=$(mktemp -d "${TMPDIR:-/tmp}/poolreps-reproduce.XXXXXX") || { rm -rf "$OUT"; exit 1; }
plotter= bg= bg_run= child=
cleanup() {
	# nothing in here may end it early (a process already gone, under set -e)
	set +e
	exec 3>&-
	# (a killed process's status must not end the trap under set -e before
	# the folder is removed, nor replace the script's own)
	[ -z "$bg" ] || { kill "$bg" 2>/dev/null; wait "$bg" 2>/dev/null || :; }
	[ -z "$plotter" ] || { kill "$plotter" 2>/dev/null; wait "$plotter" 2>/dev/null || :; }
	rm -rf "$tmp" "$OUT"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
mkfifo "$tmp/queue"
"$PY" "$(dirname "$0")/plot_all.py" --stdin --timings "$tmp/figure-times" < "$tmp/queue" &
plotter=$!
exec 3> "$tmp/queue"

run() { # name: data/NAME.ini; QUICK=1 adds the keys of data/quick/NAME.ini
	name=$1
	dir=$(echo "$reg" | awk -F, -v n="$name" '$1 == n { print $2 }')
	quick=
	if [ "$QUICK" = 1 ] && [ -f "data/quick/$name.ini" ]; then
		quick=$(sh scripts/quick-sets.sh "data/quick/$name.ini")
	fi
	# shellcheck disable=SC2086 # the quick --set words are meant to split
	timed "$name: run" "$BIN" "data/$name.ini" -o "$OUT/$dir" $quick
	kill -0 "$plotter" 2>/dev/null ||
		{ echo "reproduce: drawing the figures stopped (see its message above)" >&2; exit 1; }
	echo "$OUT/$dir" >&3
}

# run NAME in the background (its subshell's pid in bg), its stderr into
# tmp/NAME.err (shown when it ends: no progress lines mixed with the
# foreground run's). An asynchronous command ignores INT, so cleanup stops
# it with TERM, which the subshell passes on to the running poolreps.
run_bg() {
	(
		trap '[ -z "$child" ] || { kill "$child" 2>/dev/null; wait "$child"; }; exit 143' TERM
		bg_run=1
		run "$1"
	) 2> "$tmp/$1.err" &
	bg=$!
}

# The long Experiment 4 first, in the background: its threads share the
# cores with the other runs and with the drawing of their figures, so that
# both cores stay busy until the end (the output does not depend on how the
# threads are scheduled)
run_bg exp4
for name in $(echo "$reg" | awk -F, '$1 != "exp4" { print $1 }'); do
	run "$name"
done
st=0; wait "$bg" || st=$?
bg=
cat "$tmp/exp4.err" >&2
[ $st = 0 ] || { echo "reproduce: exp4 failed (exit $st, see its message above)" >&2; exit 1; }
exec 3>&-
st=0; wait "$plotter" || st=$?
plotter=
[ $st = 0 ] || { echo "reproduce: drawing the figures failed (exit $st, see its message above)" >&2; exit 1; }
cat "$tmp/figure-times" >> "$OUT/timings.csv"
echo "$reg" | while IFS=, read -r name dir kind; do
	if [ "$kind" = benchmark ]; then
		for ext in png svg; do
			cp "$OUT/$dir/bench_curve.$ext" "$OUT/figures/bench_$name.$ext"
		done
	else
		cp "$OUT/$dir"/*.png "$OUT/$dir"/*.svg "$OUT/figures/"
	fi
done
total=$(echo "$start $(date +%s.%N)" | awk '{ printf "%.2f", $2 - $1 }')
echo "total,$total" >> "$OUT/timings.csv"
quick=; [ "$QUICK" = 1 ] && quick=--quick
"$PY" scripts/report.py "$OUT" $quick
# shellcheck disable=SC2086 # the entries are meant to split
(cd "$OUT" && find $ENTRIES | LC_ALL=C sort) > "$OUT/$RECORD"
ENTRIES="$ENTRIES $RECORD"
# publish: each earlier entry is moved aside into the staging folder, the new
# one renamed into place; a failed rename puts every earlier entry back. The
# signals wait until all are in place (a dozen renames).
put_back() { # an entry no longer staged was published: it goes, the earlier one returns
	for e in $ENTRIES; do
		[ -e "$OUT/$e" ] || rm -rf "$FINAL/$e"
		[ ! -e "$OUT/.previous/$e" ] || mv -T "$OUT/.previous/$e" "$FINAL/$e"
	done
}
trap '' INT TERM HUP
mkdir "$OUT/.previous"
for e in $ENTRIES; do
	if { [ -e "$FINAL/$e" ] || [ -L "$FINAL/$e" ]; } && ! mv -T "$FINAL/$e" "$OUT/.previous/$e"; then
		put_back
		echo "reproduce: $FINAL/$e: cannot move aside; the earlier results left as they were" >&2
		exit 1
	fi
	mv -T "$OUT/$e" "$FINAL/$e" || {
		put_back
		echo "reproduce: $FINAL/$e: cannot move into place; the earlier results left as they were" >&2
		exit 1
	}
done
trap 'exit 130' INT
trap 'exit 143' TERM
trap - HUP
echo "reproduce: done in $total s; figures in $FINAL/figures, report $FINAL/report.html:"
ls "$FINAL/figures"
