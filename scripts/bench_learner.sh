#!/bin/sh
# bench_learner.sh — the ask/tell learner from Python (scripts/bench_learner.py):
# Experiment 3's nrvr_a run through poolreps.Learner against the same run
# inside Experiment 3 (target: within 1.2x), and the binding's overhead per
# ask + tell at 100 episodes (target: below 0.2 ms) beside pycma's ask/tell
# (build/venv: `make venv` installs pycma).
# CSV=docs/data/bench_learner.csv records the medians for the docs'
# table (scripts/bench_learner_table.py --write).
set -e
cd "$(dirname "$0")/.."
${MAKE:-make} -s SAN=0 build/rel/poolreps build/rel/libpoolreps.so.0.1.0
export POOLREPS_LIB="$PWD/build/rel/libpoolreps.so.0.1.0"
PY=${PYTHON:-python3}
[ -x build/venv/bin/python ] && PY=build/venv/bin/python
"$PY" scripts/bench_learner.py --poolreps build/rel/poolreps --rounds "${ROUNDS:-3}" ${CSV:+--csv "$CSV"}
echo
echo "$(nproc) CPU(s); wall clock, runs alternating so both sides see the same load."
