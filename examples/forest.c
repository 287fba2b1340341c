/* forest.c — fit extremely randomized trees and read their leaves.
 *
 * Learns y = sin(3 x0) + x1^2 on n random points of [-1,1]^2, prints the
 * forest's size, the leaves of tree 0 (their training samples and value),
 * and the mean squared error on fresh points against the noise-free truth.
 *
 *   cc forest.c $(pkg-config --cflags --libs poolreps) -o forest && ./forest
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_rng.h>

#include "poolreps/forest.h"

#define N 2000
#define NTEST 1000

static double truth(const double *x)
{
	return sin(3 * x[0]) + x[1] * x[1];
}

int main(void)
{
	static double X[2 * N], y[N], Xt[2 * NTEST], pred[NTEST];
	char err[PR_ERRLEN];
	pr_forest_opts opts;
	pr_forest *f;
	gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
	double mse = 0;
	int i, leaf, first, last;

	gsl_set_error_handler_off();
	if (!rng)
		return 1;
	gsl_rng_set(rng, 7);
	for (i = 0; i < 2 * N; i++)
		X[i] = 2 * gsl_rng_uniform(rng) - 1;
	for (i = 0; i < N; i++)
		y[i] = truth(X + 2 * i) + 0.1 * (gsl_rng_uniform(rng) - 0.5);

	pr_forest_opts_init(&opts); /* M = 30, K = 10, n_min = 20 */
	opts.trees = 10;
	opts.n_min = 100;
	/* X is n x dx row-major, Y n x dy; no weights; one draw of rng seeds it */
	if (!(f = pr_forest_fit(&opts, X, N, 2, y, 1, NULL, rng, err))) {
		fprintf(stderr, "forest: %s\n", err);
		return 1;
	}
	printf("trees %d leaves %d samples %d\n", pr_forest_ntrees(f), pr_forest_nleaves(f),
	       pr_forest_nsamples(f));

	/* tree t owns the global leaf ids [leaf0(t), leaf0(t + 1)) */
	first = pr_forest_tree_leaf0(f, 0);
	last = pr_forest_tree_leaf0(f, 1);
	printf("leaf,samples,value\n");
	for (leaf = first; leaf < last; leaf++) {
		const int *idx; /* the training rows in this leaf, owned by the forest */
		int count = pr_forest_leaf_samples(f, leaf, &idx);
		printf("%d,%d,%.6f\n", leaf - first, count, pr_forest_leaf_mean(f, leaf)[0]);
	}

	for (i = 0; i < 2 * NTEST; i++)
		Xt[i] = 2 * gsl_rng_uniform(rng) - 1;
	pr_forest_predict_many(f, Xt, NTEST, pred); /* eq. 4.2-4.3, all rows at once */
	for (i = 0; i < NTEST; i++)
		mse += pow(pred[i] - truth(Xt + 2 * i), 2) / NTEST;
	printf("test_mse %.6f\n", mse);

	pr_forest_free(f);
	gsl_rng_free(rng);
	return 0;
}
