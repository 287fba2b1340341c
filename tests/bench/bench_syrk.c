/* bench_syrk.c — the dense REPS Hessian's rank-k update, poolreps' own
 * kernel (src/syrk.c) against OpenBLAS's dsyrk on the same rows.
 *
 *   bench_syrk [--rows M] [--cols D] [--runs K] [--openblas LIB]
 *
 * H += Y^T Y for Y of M x D random values (default dense200's shape, 20000 x
 * 200): the kernel as reps.c runs it (blocks of 64 rows, each block in
 * cache), on one thread and on one per online CPU (each thread its run of
 * H's rows, pr_syrk_split, over all the blocks), and cblas_dsyrk
 * (row-major, upper, transposed) of the OpenBLAS loaded at run time from
 * LIB (default libopenblas.so.0; it stays private to this program, so GSL
 * keeps its own CBLAS) on all M rows at once, with
 * openblas_set_num_threads(1) and then on every core. Prints one line of
 * key=value pairs: the median seconds of the runs, the G multiply-adds per
 * second, OpenBLAS's kernel (openblas_get_corename) and the largest
 * difference between the two answers relative to the largest entry.
 * Without OpenBLAS it says so and times the kernel alone. */
#include <dlfcn.h>
#include <getopt.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "syrk_priv.h"
#include "bench_util.h"

#define BLOCK 64

typedef void dsyrk_fn(int, int, int, int, int, double, const double *, int, double, double *,
                      int);
typedef void threads_fn(int);
typedef char *corename_fn(void);

static double median(double *t, int k)
{
	qsort(t, (size_t)k, sizeof *t, bench_cmp);
	return k % 2 ? t[k / 2] : 0.5 * (t[k / 2 - 1] + t[k / 2]);
}

/* One thread's share: rows jlo .. jhi - 1 of H over all of Y, 64 rows of
 * Y at a time, copied into the thread's own block first (reps.c makes each
 * block there from psi). */
typedef struct {
	const double *Y;
	double *H, *B;
	int m, nfp, jlo, jhi;
} part;

static void *own_part(void *arg)
{
	const part *a = arg;
	int i0;

	for (i0 = 0; i0 < a->m; i0 += BLOCK) {
		const int mr = a->m - i0 < BLOCK ? a->m - i0 : BLOCK;

		memcpy(a->B, a->Y + (size_t)i0 * a->nfp, (size_t)mr * a->nfp * sizeof *a->B);
		pr_syrk_acc_rows(a->B, mr, a->nfp, a->H, a->jlo, a->jhi);
	}
	return NULL;
}

/* The kernel as reps.c runs it, on nt threads (nt <= 64). */
static void own(const double *Y, int m, int nfp, double *H, double *B, int nt)
{
	part p[64];
	pthread_t tid[64];
	int t;

	memset(H, 0, (size_t)nfp * nfp * sizeof *H);
	for (t = 0; t < nt; t++) {
		p[t] = (part){ Y, H, B + (size_t)t * BLOCK * nfp, m, nfp, pr_syrk_split(nfp, nt, t),
		               pr_syrk_split(nfp, nt, t + 1) };
		if (t > 0 && pthread_create(&tid[t], NULL, own_part, &p[t]))
			tid[t] = 0, own_part(&p[t]);
	}
	own_part(&p[0]);
	for (t = 1; t < nt; t++)
		if (tid[t])
			pthread_join(tid[t], NULL);
}

int main(int argc, char **argv)
{
	static const struct option lo[] = { { "rows", 1, 0, 'm' }, { "cols", 1, 0, 'd' },
		                             { "runs", 1, 0, 'r' }, { "openblas", 1, 0, 'o' },
		                             { 0, 0, 0, 0 } };
	const char *lib = "libopenblas.so.0";
	int m = 20000, d = 200, runs = 5, c, nfp, r, j, k, nt, cpus;
	double *Y, *H, *Hb, *B, *t, macs, med, diff = 0.0, big = 0.0;
	void *h;
	dsyrk_fn *dsyrk = NULL;
	threads_fn *set_threads = NULL;
	corename_fn *corename = NULL;

	while ((c = getopt_long(argc, argv, "", lo, NULL)) != -1) {
		if (c == 'm')
			m = atoi(optarg);
		else if (c == 'd')
			d = atoi(optarg);
		else if (c == 'r')
			runs = atoi(optarg);
		else if (c == 'o')
			lib = optarg;
		else
			return 1;
	}
	if (m < 1 || d < 1 || runs < 1) {
		fprintf(stderr, "bench_syrk: --rows, --cols and --runs must be >= 1\n");
		return 1;
	}
	nfp = (d + PR_SYRK_W - 1) / PR_SYRK_W * PR_SYRK_W;
	cpus = (int)sysconf(_SC_NPROCESSORS_ONLN);
	cpus = cpus < 1 ? 1 : cpus > 64 ? 64 : cpus;
	Y = calloc((size_t)m * nfp, sizeof *Y);
	B = malloc((size_t)cpus * BLOCK * nfp * sizeof *B);
	H = malloc((size_t)nfp * nfp * sizeof *H);
	Hb = malloc((size_t)nfp * nfp * sizeof *Hb);
	t = malloc((size_t)runs * sizeof *t);
	if (!Y || !H || !Hb || !B || !t) {
		fprintf(stderr, "bench_syrk: out of memory\n");
		return 4;
	}
	srand(1);
	for (r = 0; r < m; r++)
		for (j = 0; j < d; j++)
			Y[(size_t)r * nfp + j] = rand() / (double)RAND_MAX - 0.5;
	macs = (double)m * d * (d + 1) / 2;
	printf("rows=%d cols=%d cpus=%d", m, d, cpus);
	/* on every CPU, then on one (H keeps the one thread's answer) */
	for (k = 0; k < 2; k++) {
		nt = k ? 1 : cpus;
		for (r = 0; r < runs; r++) {
			double t0 = bench_now();

			own(Y, m, nfp, H, B, nt);
			t[r] = bench_now() - t0;
		}
		med = median(t, runs);
		printf(" own_%s_s=%.6f own_%s_gmacs=%.2f", k ? "1" : "all", med, k ? "1" : "all",
		       macs / med * 1e-9);
	}
	if ((h = dlopen(lib, RTLD_NOW | RTLD_LOCAL))) {
		*(void **)&dsyrk = dlsym(h, "cblas_dsyrk");
		*(void **)&set_threads = dlsym(h, "openblas_set_num_threads");
		*(void **)&corename = dlsym(h, "openblas_get_corename");
	}
	if (!dsyrk || !set_threads) {
		printf(" openblas=none\n");
		return 0;
	}
	for (nt = 1; nt >= 0; nt--) {
		/* 0: OpenBLAS's own default, every core */
		set_threads(nt ? 1 : 0);
		for (r = 0; r < runs; r++) {
			double t0 = bench_now();

			dsyrk(101, 121, 112, d, m, 1.0, Y, nfp, 0.0, Hb, nfp); /* row-major, upper, Y^T Y */
			t[r] = bench_now() - t0;
		}
		med = median(t, runs);
		printf(" openblas_%s_s=%.6f openblas_%s_gmacs=%.2f", nt ? "1" : "all", med,
		       nt ? "1" : "all", macs / med * 1e-9);
	}
	for (j = 0; j < d; j++)
		for (k = j; k < d; k++) {
			diff = fmax(diff, fabs(H[(size_t)j * nfp + k] - Hb[(size_t)j * nfp + k]));
			big = fmax(big, fabs(H[(size_t)j * nfp + k]));
		}
	printf(" openblas_core=%s max_rel_diff=%.3g\n", corename ? corename() : "unknown", diff / big);
	return 0;
}
