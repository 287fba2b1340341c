# prev_build.sh — sourced by the benches that measure a previous version:
# prev_build REF DIR [TARGET...] builds poolreps (and the make TARGETs, as
# paths under DIR) at git revision REF into DIR/build/rel from `git
# archive`, unless DIR already holds that revision's build of them (DIR/.ref).
prev_build() {
	ref=$1 dir=$2
	shift 2
	set -- build/rel/poolreps "$@"
	have=1
	for t in "$@"; do [ -e "$dir/$t" ] || have=; done
	if [ -z "$have" ] || [ "$(cat "$dir/.ref" 2>/dev/null)" != "$(git rev-parse "$ref")" ]; then
		rm -rf "$dir" && mkdir -p "$dir"
		git archive "$ref" | tar -x -C "$dir"
		(cd "$dir" && ${MAKE:-make} -s -j2 "$@" >/dev/null)
		git rev-parse "$ref" > "$dir/.ref"
	fi
}

# prev_option REF TMP: prev_build of REF's library into TMP/previous, then
# the --previous option naming it on stdout; nothing when REF is none.
prev_option() {
	[ "$1" = none ] && return 0
	prev_build "$1" "$2/previous" build/rel/libpoolreps.so.0.1.0 >&2
	echo "--previous $2/previous"
}
