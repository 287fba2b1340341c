#!/bin/sh
# Print one poolreps command per repetition of an experiment: a job list for
# GNU Parallel or a Slurm array (scripts/slurm.sbatch).
#   scripts/jobs.sh CONFIG OUTDIR [poolreps options...] > jobs.txt
#   parallel -j2 < jobs.txt                       # this machine, 2 jobs at once
#   parallel --sshlogin 8/host1,8/host2 --workdir . < jobs.txt   # several machines
#   ./poolreps merge -o OUTDIR/merged OUTDIR/rep-*
# POOLREPS names the binary (default ./poolreps). Both runners hand each line
# to sh, so every word is quoted for sh where it needs it.
set -e
[ $# -ge 2 ] || { echo "usage: scripts/jobs.sh CONFIG OUTDIR [poolreps options...]" >&2; exit 1; }
config=$1; out=$2; shift 2
bin=${POOLREPS:-./poolreps}

# q WORD: WORD as sh reads it back, in single quotes unless it is plain
q() {
	case $1 in
	'' | *[!A-Za-z0-9_@%+=:,./-]*) printf "'%s'" "$(printf '%s' "$1" | sed "s/'/'\\\\''/g")" ;;
	*) printf '%s' "$1" ;;
	esac
}

# a bad CONFIG or option fails here, with poolreps's own message
effective=$("$bin" config -c "$config" "$@")
reps=$(printf '%s\n' "$effective" |
	awk '/^\[/{s=($0=="[experiment]")} s&&$1=="repetitions"{print $3; exit}')
[ -n "$reps" ] || { echo "jobs.sh: cannot read experiment.repetitions" >&2; exit 1; }
k=0
while [ "$k" -lt "$reps" ]; do
	printf '%s %s -q' "$(q "$bin")" "$(q "$config")"
	for a in "$@"; do printf ' %s' "$(q "$a")"; done
	printf ' --set experiment.repetition=%d -o %s\n' "$k" "$(q "$out/rep-$k")"
	k=$((k + 1))
done
