#!/bin/sh
# CI stages beyond the README's two commands and `make check SAN=1`: every
# figure of the quick reproduction that `make reproduce QUICK=1` wrote into
# RESULTS (default results/) as PNG and SVG, shown by the report page; each
# fuzz harness for 60 s plus the kept regression inputs; the end-to-end tests
# under valgrind.
set -e
R=${RESULTS:-results}
[ -s "$R/report.html" ] || { echo "ci-extra: no quick reproduction in $R (run make reproduce QUICK=1 first)" >&2; exit 1; }
for f in fig7_1_table fig7_2_reward fig7_3_shots fig7_4a_nmin fig7_4b_trees fig7_4c_cuts \
	exp1_map fig7_5_ghost fig7_6 fig7_7 fig7_8 fig7_9 fig7_10 \
	exp4_curves_query exp4_curves_residual exp4_final exp4_rates \
	bench_quadratic bench_sphere bench_rosenbrock; do
	for ext in png svg; do
		[ -s "$R/figures/$f.$ext" ] || { echo "ci-extra: figure $f.$ext missing" >&2; exit 1; }
	done
	grep -q "src=\"figures/$f.png\"" $R/report.html ||
		{ echo "ci-extra: report.html does not show $f" >&2; exit 1; }
done
make fuzz FUZZ_SECONDS=60
make valgrind
