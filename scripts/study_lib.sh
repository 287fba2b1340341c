# study_lib.sh — the clock and load helpers the study scripts share
# (power.sh, study.sh, sensitivity.sh, exp4_study.sh source it).
# now: seconds since the epoch; since T: seconds since T (one decimal);
# load: the 1-minute load average (nan where /proc has none).
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }
load() { cut -d' ' -f1 /proc/loadavg 2>/dev/null || echo nan; }
