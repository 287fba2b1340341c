#!/usr/bin/env python3
"""The ids of the thirteen claims the verdicts judge (data/study/rules.ini's
[claim.ID] sections) and the experiment each is judged on: the one list
scripts/verdicts.py and scripts/sensitivity_stats.py read (standard library
only, so that it imports without numpy)."""

CLAIM_IDS = ("cuts", "trees", "nmin", "map", "short", "single", "rs", "none_better", "best",
             "worst", "even", "fewest", "converged")
# the experiment each claim is judged on: one Holm family per experiment and mode
EXPERIMENT = dict.fromkeys(CLAIM_IDS[:4], "exp1") | dict.fromkeys(CLAIM_IDS[4:7], "exp2") | \
    dict.fromkeys(CLAIM_IDS[7:], "exp3")
EXP3_CLAIMS = tuple(c for c in CLAIM_IDS if EXPERIMENT[c] == "exp3")
