# study_lib.sh — the clock and load helpers the study scripts share
# (power.sh, study.sh, sensitivity.sh, exp4_study.sh source it), and the
# steps of a study of sweeps (the caller sets here, its scripts folder).
# now: seconds since the epoch; since T: seconds since T (one decimal);
# load: the 1-minute load average (nan where /proc has none).
# ARMS, arm NAME: the three physics arms of the studies and an arm's own
# --set options (event; stepped with dt 1 ms; stepped with dt 0.5 ms).
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }
load() { cut -d' ' -f1 /proc/loadavg 2>/dev/null || echo nan; }
ARMS="event stepped stepped05"
arm() {
	case $1 in
	event) echo "--set sim.mode=event" ;;
	stepped) echo "--set sim.mode=stepped --set sim.dt=0.001" ;;
	stepped05) echo "--set sim.mode=stepped --set sim.dt=0.0005" ;;
	esac
}
# add_jobs OUT REPS INI NAME [options...]: the jobs of a sweep of INI into
# OUT/runs/NAME (scripts/jobs.sh), one a repetition of REPS on one thread,
# onto OUT/runs/jobs.txt.
add_jobs() {
	_out=$1 _reps=$2 _ini=$3 _name=$4
	shift 4
	sh "$here/jobs.sh" "$_ini" "$_out/runs/$_name" "$@" --set "experiment.repetitions=$_reps" \
		--set experiment.threads=1 >> "$_out/runs/jobs.txt"
}
# merge_sweep OUT NAME: the sweep OUT/runs/NAME, one grid point, merged
# into OUT/NAME as one process would have written it.
merge_sweep() {
	"$POOLREPS" collect -q "$1/runs/$2"
	mv "$1/runs/$2/point-0/merged" "$1/$2"
}
# run_sweeps OUT JOBS NAMES: OUT/runs/jobs.txt by GNU Parallel, JOBS at
# once, each name's sweep merged, and OUT/timing.csv: each phase's wall
# seconds, jobs, cores and the load before and after.
run_sweeps() {
	_load0=$(load)
	_t0=$(now)
	parallel -j "$2" --halt now,fail=1 --joblog "$1/runs/joblog.txt" < "$1/runs/jobs.txt"
	_runs=$(since "$_t0")
	_load1=$(load)
	_t1=$(now)
	for _n in $3; do merge_sweep "$1" "$_n"; done
	{
		echo "phase,wall_seconds,jobs,cores,load_before,load_after"
		echo "runs,$_runs,$2,$(nproc),$_load0,$_load1"
		echo "merge,$(since "$_t1"),1,$(nproc),$_load1,$(load)"
	} > "$1/timing.csv"
}
# docs_readme DOCS: this checkout's README.md when DOCS is its docs/ (a
# study then rewrites README's generated block too), else nothing.
docs_readme() {
	if [ -d "$1" ] && [ "$(cd "$1" && pwd -P)" = "$(cd "$here/.." && pwd -P)/docs" ]; then
		echo "$here/../README.md"
	fi
}
