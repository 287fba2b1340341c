#!/bin/sh
# Print the job list of an experiment, one self-contained command per job:
# a thin wrapper over `poolreps sweep`, which also writes SWEEP_DIR/slurm.sbatch
# and SWEEP_DIR/parallel.sh to run them (docs/cluster.md).
#   scripts/jobs.sh CONFIG SWEEP_DIR [poolreps sweep options...] > jobs.txt
#   parallel -j2 < jobs.txt                      # or: sh SWEEP_DIR/parallel.sh -j2
#   ./poolreps collect SWEEP_DIR                 # merged: SWEEP_DIR/point-0/merged
# POOLREPS names the binary (default ./poolreps).
set -e
[ $# -ge 2 ] || { echo "usage: scripts/jobs.sh CONFIG SWEEP_DIR [poolreps sweep options...]" >&2; exit 1; }
config=$1; out=$2; shift 2
"${POOLREPS:-./poolreps}" sweep "$config" -q -o "$out" "$@"
cat "$out/jobs.txt"
