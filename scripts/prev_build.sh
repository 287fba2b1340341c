# prev_build.sh — sourced by the benches that measure a previous version:
# prev_build REF DIR builds poolreps at git revision REF into
# DIR/build/rel/poolreps from `git archive`, unless DIR already holds that
# revision's build (DIR/.ref).
prev_build() {
	if [ ! -x "$2/build/rel/poolreps" ] || [ "$(cat "$2/.ref" 2>/dev/null)" != "$(git rev-parse "$1")" ]; then
		rm -rf "$2" && mkdir -p "$2"
		git archive "$1" | tar -x -C "$2"
		(cd "$2" && ${MAKE:-make} -s -j2 build/rel/poolreps >/dev/null)
		git rev-parse "$1" > "$2/.ref"
	fi
}
