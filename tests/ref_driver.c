/* ref_driver.c — exposes the linear weighted-ML fit and one contextual
 * CMA-ES run to tests/test_ref_cov.py, which checks them against a numpy
 * reference written from the equations. Reads whitespace-separated numbers
 * from stdin, writes %.17g numbers to stdout, one matrix per line:
 *
 *   fit FEATURES COV_CENTER LAMBDA MIN_STD N DS DA
 *       then N rows: s[DS] a[DA] w m[DA]
 *     -> W (DA x NF, row-major), then the covariance (DA x DA)
 *   cmaes DS DA NB SIGMA0 LAMBDA GENS N
 *       then W0 (DA x NF), then per generation N rows: s[DS] x[DA] R b[NB]
 *     -> per generation: sigma, W, C
 * FEATURES and COV_CENTER are the PR_FEATURES_* and PR_COV_CENTER_* codes.
 * Exit status 1 on bad input, 3 when the library refuses (message on stderr).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "poolreps/cmaes.h"
#include "poolreps/policy.h"
#include "poolreps/internal.h"

static int read_n(double *v, size_t n)
{
	size_t i;

	for (i = 0; i < n; i++)
		if (scanf("%lf", &v[i]) != 1)
			return 0;
	return 1;
}

static void print_row(const double *v, size_t n)
{
	size_t i;

	for (i = 0; i < n; i++)
		printf(i ? " %.17g" : "%.17g", v[i]);
	printf("\n");
}

static int fit(void)
{
	int features, center, n, ds, da, nf, i, flags, rc = 3;
	double lambda, min_std, *S, *A, *w, *M, *W, *C;
	char err[PR_ERRLEN];
	pr_policy_data d;
	pr_policy *p;

	if (scanf("%d %d %lf %lf %d %d %d", &features, &center, &lambda, &min_std, &n, &ds, &da) != 7 ||
	    n < 1 || ds < 1 || da < 1 || (nf = pr_policy_features_count(features, ds)) < 1)
		return 1;
	S = malloc((size_t)n * ds * sizeof *S);
	A = malloc((size_t)n * da * sizeof *A);
	w = malloc((size_t)n * sizeof *w);
	M = malloc((size_t)n * da * sizeof *M);
	W = malloc((size_t)da * nf * sizeof *W);
	C = malloc((size_t)da * da * sizeof *C);
	if (!S || !A || !w || !M || !W || !C)
		return 1;
	for (i = 0; i < n; i++)
		if (!read_n(S + (size_t)i * ds, (size_t)ds) || !read_n(A + (size_t)i * da, (size_t)da) ||
		    !read_n(w + i, 1) || !read_n(M + (size_t)i * da, (size_t)da))
			return 1;
	memset(&d, 0, sizeof d);
	d.n = n;
	d.ds = ds;
	d.da = da;
	d.S = S;
	d.A = A;
	d.w = w;
	d.M = M;
	p = pr_policy_linear_fit(features, &d, lambda, min_std, center, &flags, err);
	if (p && pr_policy_linear_params(p, W, C, err) == PR_OK) {
		print_row(W, (size_t)da * nf);
		print_row(C, (size_t)da * da);
		rc = 0;
	} else {
		fprintf(stderr, "%s\n", err);
	}
	pr_policy_free(p);
	free(S);
	free(A);
	free(w);
	free(M);
	free(W);
	free(C);
	return rc;
}

static int cmaes(void)
{
	int ds, da, nb, gens, n, nf, g, i, rc = 0;
	double sigma0, lambda, *W, *C, *S, *X, *R, *B;
	char err[PR_ERRLEN];
	pr_cmaes *c;
	pr_cmaes_batch b;

	if (scanf("%d %d %d %lf %lf %d %d", &ds, &da, &nb, &sigma0, &lambda, &gens, &n) != 7 ||
	    ds < 1 || da < 1 || nb < 1 || n < 1 || gens < 1)
		return 1;
	nf = pr_policy_features_count(PR_FEATURES_AFFINE, ds);
	W = malloc((size_t)da * nf * sizeof *W);
	C = malloc((size_t)da * da * sizeof *C);
	S = malloc((size_t)n * ds * sizeof *S);
	X = malloc((size_t)n * da * sizeof *X);
	R = malloc((size_t)n * sizeof *R);
	B = malloc((size_t)n * nb * sizeof *B);
	if (!W || !C || !S || !X || !R || !B || !read_n(W, (size_t)da * nf))
		return 1;
	if (!(c = pr_cmaes_new(PR_FEATURES_AFFINE, ds, da, W, sigma0, lambda, err))) {
		fprintf(stderr, "%s\n", err);
		return 3;
	}
	b.n = n;
	b.nb = nb;
	b.S = S;
	b.X = X;
	b.R = R;
	b.B = B;
	for (g = 0; g < gens && !rc; g++) {
		double sigma;

		for (i = 0; i < n; i++)
			if (!read_n(S + (size_t)i * ds, (size_t)ds) || !read_n(X + (size_t)i * da, (size_t)da) ||
			    !read_n(R + i, 1) || !read_n(B + (size_t)i * nb, (size_t)nb))
				rc = 1;
		if (!rc && pr_cmaes_update(c, &b, NULL, err) != PR_OK) {
			fprintf(stderr, "%s\n", err);
			rc = 3;
		}
		if (rc)
			break;
		sigma = pr_cmaes_sigma(c);
		pr_cmaes_state(c, W, C);
		print_row(&sigma, 1);
		print_row(W, (size_t)da * nf);
		print_row(C, (size_t)da * da);
	}
	pr_cmaes_free(c);
	free(W);
	free(C);
	free(S);
	free(X);
	free(R);
	free(B);
	return rc;
}

int main(void)
{
	char mode[16];

	if (scanf("%15s", mode) != 1)
		return 1;
	if (strcmp(mode, "fit") == 0)
		return fit();
	if (strcmp(mode, "cmaes") == 0)
		return cmaes();
	return 1;
}
