#!/bin/sh
# Experiment 3's exploration sensitivity (docs/exp3.md): data/exp3.ini at REPS
# repetitions (its seed) as shipped, and once per arm with one exploration
# setting changed; then scripts/exp3_table.py --compare prints the paired
# differences of every arm against the default.
#   scripts/exp3_explore.sh OUT REPS DOC [poolreps options...]
# OUT/ARM         each arm's result folder: default, and the arms of
#                 EXPLORE_ARMS (default both): cov_center_old
#                 (policy.cov_center = old) and ccmaes
#                 (exp3.handcrafted_method = ccmaes)
# OUT/compare.md  the table
# DOC             a markdown file whose lines between "<!-- explore-REPS:begin -->"
#                 and "<!-- explore-REPS:end -->" become the table; - for none
# Options after DOC go to every run (tests pass tiny settings). POOLREPS the
# binary (default ./poolreps), PYTHON the interpreter (default python3).
set -e
[ $# -ge 3 ] || { echo "usage: scripts/exp3_explore.sh OUT REPS DOC [poolreps options...]" >&2; exit 1; }
out=$1; reps=$2; doc=$3; shift 3
bin=${POOLREPS:-./poolreps}
py=${PYTHON:-python3}
here=$(dirname "$0")
ARMS=${EXPLORE_ARMS:-cov_center_old ccmaes}

# arm NAME: the arm's own --set options
arm() {
	case $1 in
	default) ;;
	cov_center_old) echo "--set policy.cov_center=old" ;;
	ccmaes) echo "--set exp3.handcrafted_method=ccmaes" ;;
	*) echo "exp3_explore: unknown arm '$1'" >&2; exit 1 ;;
	esac
}
# its label in the table: the setting
label() { arm "$1" | sed 's/^--set //; s/=/ = /'; }
for a in $ARMS; do arm "$a" > /dev/null; done

mkdir -p "$out"
# a failed step leaves no temporary file behind
tmp=
trap '[ -z "$tmp" ] || rm -f "$tmp"' EXIT
for a in default $ARMS; do
	# shellcheck disable=SC2046  # the arm's options are plain words
	"$bin" "$here/../data/exp3.ini" -o "$out/$a" -q "$@" $(arm "$a") \
		--set "experiment.repetitions=$reps"
done
set -- "$out/default"
for a in $ARMS; do set -- "$@" "$out/$a"; done
set -- "$@" --label
for a in $ARMS; do set -- "$@" "$(label "$a")"; done
tmp="$out/compare.md.tmp"
"$py" "$here/exp3_table.py" --compare "$@" > "$out/compare.md.tmp"
mv "$out/compare.md.tmp" "$out/compare.md"
cat "$out/compare.md"
[ "$doc" = - ] && exit 0
begin="<!-- explore-$reps:begin -->"
end="<!-- explore-$reps:end -->"
grep -qxF "$begin" "$doc" && grep -qxF "$end" "$doc" ||
	{ echo "exp3_explore: $doc: no lines '$begin' and '$end'" >&2; exit 1; }
tmp="$doc.tmp"
awk -v b="$begin" -v e="$end" -v t="$out/compare.md" '
	$0 == b { print; while ((getline l < t) > 0) print l; skip = 1; next }
	$0 == e { skip = 0 }
	!skip' "$doc" > "$doc.tmp"
mv "$doc.tmp" "$doc"
