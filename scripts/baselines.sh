#!/bin/sh
# Experiment 5 (docs/baselines.md): standard learners on Experiment 3's task.
#   scripts/baselines.sh venv                 make BASELINES_VENV (default
#       build/baselines/venv): the system's packages plus Stable-Baselines3,
#       cma and gymnasium from PyPI, at the versions and hashes of
#       scripts/baselines-requirements.txt (a venv made from another list is
#       made again). Without network it fails with one line naming the
#       packages and leaves nothing behind.
#   scripts/baselines.sh run OUT SEEDS        every run into OUT (runs/*.csv
#       for the Python learners, reps/VARIANT for poolreps), skipping runs
#       already there; then the committed CSVs (OUT/data) and the report
#   scripts/baselines.sh reps OUT SEEDS       the poolreps learners only
#   scripts/baselines.sh smoke OUT            a tiny version (tests)
#   scripts/baselines.sh one OUT LEARNER SEED BUDGETS   one Python run
# Environment: POOLREPS (default ./poolreps), PYTHON (with matplotlib, for the
# report), BASELINES_JOBS runs at once (default 2), BASELINES_DOCS the folder
# for baselines.md and figures/ (default OUT/docs), BASELINES_SAC_BUDGETS,
# BASELINES_PPO_BUDGETS, BASELINES_BUDGETS
# (defaults below), BASELINES_DATA the folder for the CSVs (default
# OUT/data), BASELINES_README a README.md whose Experiment 5 paragraph to
# rewrite (default none).
set -e
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
venv=${BASELINES_VENV:-$root/build/baselines/venv}
PACKAGES="stable-baselines3 cma gymnasium"
requirements=$here/baselines-requirements.txt
POOLREPS=${POOLREPS:-$root/poolreps}
PYTHON=${PYTHON:-python3}
jobs=${BASELINES_JOBS:-2}
# the long runs give way to other work; the smoke run (a test) does not
NICE="nice -n 10"
# Experiment 3's budget, 10x and 25x for every learner (docs/baselines.md
# gives each one's CPU time per run); the SB3 learners' budgets can be set
# apart
budgets=${BASELINES_BUDGETS:-2200,22000,55000}
ppo_budgets=${BASELINES_PPO_BUDGETS:-2200,22000,55000}
sac_budgets=${BASELINES_SAC_BUDGETS:-2200,22000,55000}
# one over-speed rule for every learner: an action faster than sim.max_speed
# is scaled onto the limit (PocketEnv does so for the Python learners); and
# every learner's mean action on the same 2000 fresh states per seed, every
# 1100 episodes (scripts/baselines.py: EVAL_STARTS, EVAL_SEED, --curve-every)
REPS_SET="--set exp3.truncation=clip --set exp3.mean_eval=2000 --set exp3.mean_eval_seed=1000000"
every=1100

make_venv() {
	[ -x "$venv/bin/python" ] && cmp -s "$requirements" "$venv/requirements.txt" &&
		"$venv/bin/python" -c 'import stable_baselines3, cma, gymnasium' 2>/dev/null && return 0
	tmp="$venv.partial-$$"
	parent=$(dirname "$venv")
	made=
	[ -d "$parent" ] || made=$parent
	mkdir -p "$parent"
	# a failure leaves nothing: the partial venv goes, and the folder made for it
	trap 'rm -rf "$tmp" "$tmp.log"; [ -z "$made" ] || rmdir "$made" 2>/dev/null || :' EXIT
	/usr/bin/python3 -m venv --system-site-packages "$tmp" >/dev/null 2>&1 ||
		{ echo "baselines: cannot make a virtual environment (python3-venv missing?)" >&2; exit 2; }
	if ! "$tmp/bin/pip" install -q --disable-pip-version-check --require-hashes \
		-r "$requirements" > "$tmp.log" 2>&1; then
		why=$(grep -m1 -E 'ERROR|error' "$tmp.log" | cut -c1-160)
		echo "baselines: could not install $PACKAGES from PyPI (no network?): ${why:-pip failed}" >&2
		exit 2
	fi
	rm -f "$tmp.log"
	cp "$requirements" "$tmp/requirements.txt"
	# venv scripts name their folder: a renamed venv needs its paths fixed
	grep -rl "$tmp" "$tmp/bin" | xargs sed -i "s|$tmp|$venv|g"
	rm -rf "$venv"
	mv "$tmp" "$venv"
	trap - EXIT
}

# jobs OUT SEEDS: one line per Python run (learner, seed, budgets)
job_list() {
	s=0
	while [ "$s" -lt "$2" ]; do
		echo "cma_linear $s $budgets"
		echo "ppo $s $ppo_budgets"
		echo "sac $s $sac_budgets"
		s=$((s + 1))
	done
}

# one_run OUT LEARNER SEED BUDGETS [extra]: skip a finished run
one_run() {
	f="$1/runs/$2_s$3_b$(echo "$4" | tr , _).csv"
	[ -f "$f" ] && return 0
	$NICE "$venv/bin/python" "$here/baselines.py" run "$2" "$3" "$f" --budgets "$4" $5 \
		> "$f.log" 2>&1 || { echo "baselines: $2 seed $3 failed: $(tail -n1 "$f.log")" >&2; return 1; }
}

# reps OUT SEEDS ITERATIONS [options]: our learners through poolreps
# (Experiment 3, longer), one run each so that each has its own timing
reps_runs() {
	for v in creps:handcrafted creps:nrvr_a ccmaes:handcrafted; do
		m=${v%%:*} pol=${v#*:}
		d="$1/reps/${m}_$pol"
		[ -f "$d/provenance.txt" ] && continue
		/usr/bin/time -f "wall %e cpu %U %S" -o "$d.time" $NICE "$POOLREPS" \
			"$root/data/exp3.ini" -q -o "$d" --set "exp3.iterations=$3" \
			--set "experiment.repetitions=$2" --set "exp3.policies=$pol" \
			--set "exp3.handcrafted_method=$m" $REPS_SET \
			--set "exp3.mean_eval_every=$every" $4
	done
}

# report OUT: the CSVs into BASELINES_DATA (default OUT/data), the report
# into BASELINES_DOCS (default OUT/docs)
report() {
	data=${BASELINES_DATA:-$1/data}
	"$PYTHON" "$here/baselines_report.py" collect "$1" "$data"
	"$PYTHON" "$here/baselines_report.py" report "$data" "${BASELINES_DOCS:-$1/docs}" $BASELINES_README
}

case $1 in
venv) make_venv ;;
run)
	[ $# -eq 3 ] || { echo "usage: scripts/baselines.sh run OUT SEEDS" >&2; exit 1; }
	make_venv
	mkdir -p "$2/runs" "$2/reps"
	last=$(echo "$budgets" | tr , '\n' | tail -n1)
	reps_runs "$2" "$3" $(( (last - 200) / 20 ))
	export POOLREPS_LIB="${POOLREPS_LIB:-$root/build/rel/libpoolreps.so.0}"
	echo "$budgets" > "$2/budgets.txt"
	job_list "$2" "$3" | while read -r l s b; do echo "$2 $l $s $b"; done |
		xargs -P "$jobs" -L 1 sh "$0" one
	report "$2"
	;;
one) one_run "$2" "$3" "$4" "$5" ;;
reps)
	[ $# -eq 3 ] || { echo "usage: scripts/baselines.sh reps OUT SEEDS" >&2; exit 1; }
	mkdir -p "$2/reps"
	last=$(echo "$budgets" | tr , '\n' | tail -n1)
	reps_runs "$2" "$3" $(( (last - 200) / 20 ))
	;;
smoke)
	[ $# -eq 2 ] || { echo "usage: scripts/baselines.sh smoke OUT" >&2; exit 1; }
	mkdir -p "$2/runs" "$2/reps"
	echo 300,600 > "$2/budgets.txt"
	NICE=
	export POOLREPS_LIB="${POOLREPS_LIB:-$root/build/rel/libpoolreps.so.0}"
	for s in 0 1; do one_run "$2" cma_linear "$s" 300,600 "--curve-every 300"; done
	one_run "$2" sac 0 300 "--curve-every 300"
	one_run "$2" ppo 0 300,600 "--curve-every 300"
	every=300
	reps_runs "$2" 2 20
	report "$2"
	;;
*) echo "usage: scripts/baselines.sh venv | run OUT SEEDS | reps OUT SEEDS | smoke OUT" >&2; exit 1 ;;
esac
