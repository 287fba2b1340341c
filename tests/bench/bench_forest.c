/* bench_forest.c — time pr_forest_fit and pr_forest_predict.
 *
 *   bench_forest [options] TRAIN.csv TEST.csv   data from CSV, target column "y"
 *   bench_forest [options] --gen N,D            generated data (see gen_row)
 *
 * Options: --trees M --cuts K --n-min N --n-c N --without-replacement
 * --seed S. Prints one line of key=value pairs: fit seconds (wall and CPU),
 * predict seconds,
 * test MSE, leaves, peak resident memory (getrusage, kB: the data as read
 * plus the forest) and the resident memory at start (base_kb). The
 * generated data use GSL draws, not the CSVs of scripts/bench_forest.sh. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "poolreps/csvio.h"
#include "poolreps/forest.h"

/* A non-negative integer option, or -1. */
static long number(const char *s)
{
	char *end;
	long v;

	errno = 0;
	v = strtol(s, &end, 10);
	return errno || end == s || *end || v < 0 ? -1 : v;
}

static double clock_s(clockid_t id)
{
	struct timespec ts;

	clock_gettime(id, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The benchmark target, also written by scripts/bench_forest_sklearn.py:
 * a step across the diagonal of (x0, x1), a smooth part and noise. */
static double gen_row(gsl_rng *r, double *x, int d)
{
	for (int j = 0; j < d; j++)
		x[j] = gsl_rng_uniform(r);
	return (x[0] + x[1 % d] > 1.0 ? 1.0 : 0.0) + 0.5 * sin(6.283185307179586 * x[0])
	       + 0.2 * x[d - 1] + gsl_ran_gaussian(r, 0.1);
}

/* Inputs (every column but "y") and the target of a CSV table. */
static int split_table(const pr_csv *t, double **X, double **Y, int *d, char *err)
{
	long n = pr_csv_nrows(t);
	int c = pr_csv_ncols(t), yc = pr_csv_find(t, "y");

	if (yc < 0)
		return pr_err(err, PR_EINVAL, "%s: no column 'y'", pr_csv_path(t));
	*d = c - 1;
	*X = malloc((size_t)n * *d * sizeof **X);
	*Y = malloc((size_t)n * sizeof **Y);
	if (!*X || !*Y)
		return pr_err(err, PR_ENOMEM, "out of memory");
	for (long i = 0; i < n; i++) {
		const double *row = pr_csv_row(t, i);
		int k = 0;
		for (int j = 0; j < c; j++)
			if (j != yc)
				(*X)[i * *d + k++] = row[j];
		(*Y)[i] = row[yc];
	}
	return PR_OK;
}

int main(int argc, char **argv)
{
	static const struct option lo[] = {
		{ "trees", required_argument, 0, 'M' },
		{ "cuts", required_argument, 0, 'K' },
		{ "n-min", required_argument, 0, 'm' },
		{ "n-c", required_argument, 0, 'c' },
		{ "without-replacement", no_argument, 0, 'w' },
		{ "seed", required_argument, 0, 's' },
		{ "gen", required_argument, 0, 'g' },
		{ 0, 0, 0, 0 }
	};
	pr_forest_opts o;
	char err[PR_ERRLEN];
	unsigned long seed = 1;
	long gen_n = 0, v = 0;
	int gen_d = 0, ch, d = 0, dt = 0;
	long n = 0, nt = 0;
	double *X = NULL, *Y = NULL, *Xt = NULL, *Yt = NULL, *P = NULL;
	gsl_rng *r;
	pr_forest *f;
	double t0, c0, tfit, cfit, tpred, sse = 0;
	struct rusage ru;
	long base_kb;

	getrusage(RUSAGE_SELF, &ru);
	base_kb = ru.ru_maxrss;
	gsl_set_error_handler_off();
	pr_forest_opts_init(&o);
	while ((ch = getopt_long(argc, argv, "", lo, NULL)) != -1) {
		if (ch != 'w' && ch != 'g' && (v = number(optarg)) < 0) {
			fprintf(stderr, "bench_forest: bad number '%s'\n", optarg);
			return 1;
		}
		switch (ch) {
		case 'M': o.trees = (int)v; break;
		case 'K': o.cuts = (int)v; break;
		case 'm': o.n_min = (int)v; break;
		case 'c': o.n_c = (int)v; break;
		case 'w': o.with_replacement = 0; break;
		case 's': seed = (unsigned long)v; break;
		case 'g':
			if (sscanf(optarg, "%ld,%d", &gen_n, &gen_d) != 2 || gen_n < 1 || gen_d < 1) {
				fprintf(stderr, "bench_forest: --gen N,D\n");
				return 1;
			}
			break;
		default: return 1;
		}
	}
	r = gsl_rng_alloc(gsl_rng_mt19937);
	if (!r)
		return 4;
	if (gen_n > 0) {
		n = gen_n;
		nt = 10000;
		d = dt = gen_d;
		X = malloc((size_t)n * d * sizeof *X);
		Y = malloc((size_t)n * sizeof *Y);
		Xt = malloc((size_t)nt * d * sizeof *Xt);
		Yt = malloc((size_t)nt * sizeof *Yt);
		if (!X || !Y || !Xt || !Yt)
			return 4;
		gsl_rng_set(r, 12345);
		for (long i = 0; i < n; i++)
			Y[i] = gen_row(r, X + i * d, d);
		for (long i = 0; i < nt; i++)
			Yt[i] = gen_row(r, Xt + i * d, d);
	} else if (optind + 2 == argc) {
		pr_csv *tr = NULL, *te = NULL;
		if (pr_csv_read(argv[optind], &tr, err) || pr_csv_read(argv[optind + 1], &te, err)
		    || split_table(tr, &X, &Y, &d, err) || split_table(te, &Xt, &Yt, &dt, err)) {
			fprintf(stderr, "bench_forest: %s\n", err);
			return 2;
		}
		n = pr_csv_nrows(tr);
		nt = pr_csv_nrows(te);
		pr_csv_free(tr);
		pr_csv_free(te);
		if (d != dt) {
			fprintf(stderr, "bench_forest: train has %d inputs, test %d\n", d, dt);
			return 2;
		}
	} else {
		fprintf(stderr, "usage: bench_forest [options] (TRAIN.csv TEST.csv | --gen N,D)\n");
		return 1;
	}
	gsl_rng_set(r, seed);
	t0 = clock_s(CLOCK_MONOTONIC);
	c0 = clock_s(CLOCK_PROCESS_CPUTIME_ID);
	f = pr_forest_fit(&o, X, (int)n, d, Y, 1, NULL, r, err);
	tfit = clock_s(CLOCK_MONOTONIC) - t0;
	cfit = clock_s(CLOCK_PROCESS_CPUTIME_ID) - c0;
	if (!f) {
		fprintf(stderr, "bench_forest: %s\n", err);
		return 1;
	}
	P = malloc((size_t)nt * sizeof *P);
	if (!P)
		return 4;
	t0 = clock_s(CLOCK_MONOTONIC);
	pr_forest_predict_many(f, Xt, (int)nt, P);
	tpred = clock_s(CLOCK_MONOTONIC) - t0;
	for (long i = 0; i < nt; i++)
		sse += (P[i] - Yt[i]) * (P[i] - Yt[i]);
	getrusage(RUSAGE_SELF, &ru);
	printf("fit=%.6f fit_cpu=%.6f predict=%.6f mse=%.8g leaves=%d maxrss_kb=%ld base_kb=%ld "
	       "n=%ld d=%d K=%d repl=%d\n", tfit, cfit, tpred, sse / (double)nt,
	       pr_forest_nleaves(f), ru.ru_maxrss, base_kb, n, d, o.cuts, o.with_replacement);
	pr_forest_free(f);
	gsl_rng_free(r);
	free(X);
	free(Y);
	free(Xt);
	free(Yt);
	free(P);
	return 0;
}
