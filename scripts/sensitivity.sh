#!/bin/sh
# The sensitivity study (docs/sensitivity.md): Experiment 3's verdicts
# rerun with one open choice changed at a time around the defaults. Every
# point is a `poolreps sweep` (one job per repetition, scripts/jobs.sh), all
# jobs of all points one list run by GNU Parallel (or sent to Slurm: each
# sweep folder also holds slurm.sbatch), one `poolreps collect` per point,
# then scripts/sensitivity_stats.py: the verdicts with the rules of the power
# study (scripts/power_stats.py) into compact CSVs, and from those CSVs the
# report.
#   scripts/sensitivity.sh OUT REPS DOCS PYTHON [poolreps options...]
# OUT/runs/POINT   the point's sweep folder;  OUT/POINT  its merged run
# OUT/timing.csv   wall time, jobs, cores, load
# DOCS/data/sensitivity/*.csv and DOCS/sensitivity.md  the results and the
#                  report; when DOCS is this checkout's docs/, README.md's
#                  sentence between <!-- sensitivity --> marks is rewritten
# Options after PYTHON go to every run before the point's own (QUICK=1 and
# the tests pass tiny Experiment 3 settings). SENSITIVITY_JOBS jobs at once
# (default 2), POOLREPS the binary (default ./poolreps), SENSITIVITY_POINTS
# the points to run (default all; the others' merged folders in OUT are kept,
# to finish a study that stopped). The points' folders are replaced.
set -e
[ $# -ge 4 ] || { echo "usage: scripts/sensitivity.sh OUT REPS DOCS PYTHON [poolreps options...]" >&2; exit 1; }
out=$1; reps=$2; docs=$3; py=$4; shift 4
[ -n "$py" ] || { echo "sensitivity: no Python with matplotlib found; set PYTHON=" >&2; exit 1; }
jobs=${SENSITIVITY_JOBS:-2}
export POOLREPS="${POOLREPS:-./poolreps}"
here=$(dirname "$0")
POINTS=${SENSITIVITY_POINTS:-$("$py" "$here/sensitivity_stats.py" --points)}

. "$here/study_lib.sh"

mkdir -p "$out/runs"
: > "$out/runs/jobs.txt"
for p in $POINTS; do
	rm -rf "${out:?}/runs/$p" "${out:?}/$p"
	# shellcheck disable=SC2046  # the point's options are plain words
	add_jobs "$out" "$reps" "$here/../data/exp3.ini" "$p" "$@" \
		$("$py" "$here/sensitivity_stats.py" --point-options "$p")
done
run_sweeps "$out" "$jobs" "$POINTS"

readme=$(docs_readme "$docs")
mkdir -p "$docs/data/sensitivity"
"$py" "$here/sensitivity_stats.py" --study "$out" --csv "$docs/data/sensitivity"
"$py" "$here/sensitivity_stats.py" --csv "$docs/data/sensitivity" --docs "$docs" ${readme:+--readme "$readme"}
