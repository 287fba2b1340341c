#!/bin/sh
# quick-sets.sh FILE.ini — the keys of a quick-settings file (data/quick/*.ini)
# as command-line words "--set section.key=value", one per line, in file
# order; scripts/reproduce.sh adds them to the experiment's own parameter
# file. Values hold no blanks.
awk '
	/^[ \t]*([;#].*)?$/ { next }
	/^\[/ { sub(/^\[[ \t]*/, ""); sub(/[ \t]*\].*$/, ""); section = $0; next }
	{
		key = $0; sub(/[ \t]*=.*$/, "", key); sub(/^[ \t]*/, "", key)
		value = $0; sub(/^[^=]*=[ \t]*/, "", value); sub(/[ \t\r]*$/, "", value)
		printf "--set\n%s.%s=%s\n", section, key, value
	}' "$1"
