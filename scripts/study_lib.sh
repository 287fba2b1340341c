# study_lib.sh — the clock and load helpers the study scripts share
# (power.sh, study.sh, sensitivity.sh, exp4_study.sh source it).
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
