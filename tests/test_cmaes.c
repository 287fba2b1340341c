/* test_cmaes.c — the two covariance centres of the linear weighted-ML fit
 * and contextual CMA-ES. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "poolreps/cmaes.h"
#include "poolreps/policy.h"
#include "poolreps/internal.h"
#include "test_util.h"

static gsl_rng *new_rng(unsigned long seed)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);

	gsl_rng_set(r, seed);
	return r;
}

/* On a 2-D contextual quadratic, samples from an old linear policy
 * N(W_old [1, s], 0.3^2 I), weighted by exp(R / 0.2): the mean update does not
 * depend on the centre, and with old means linear in the same features the
 * normal equations kill the cross terms, so
 *   Sigma_old - Sigma_new = sum_i w_i delta_i delta_i^T,
 *   delta_i = (W_new - W_old) [1, s_i]. */
static void test_cov_center_shift(void **state)
{
	enum { N = 60, DS = 2, DA = 2, NF = 3 };
	const double Wold[DA * NF] = { 0.5, -0.2, 0.1, -0.4, 0.3, 0.8 };
	double S[N * DS], A[N * DA], M[N * DA], w[N], sw = 0.0;
	double Wn[DA * NF], Wo[DA * NF], Cn[DA * DA], Co[DA * DA], D[DA * DA] = { 0 };
	pr_policy_data d = { N, DS, DA, 0, S, A, NULL, w, M };
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(11);
	pr_policy *pn, *po;
	int i, j, l, fn = 0, fo = 0;

	(void)state;
	for (i = 0; i < N; i++) {
		double r = 0.0;

		for (j = 0; j < DS; j++)
			S[i * DS + j] = gsl_ran_flat(rng, -1.0, 1.0);
		for (j = 0; j < DA; j++) {
			/* optimum a*(s) = (s_1, -s_0) */
			double opt = j == 0 ? S[i * DS + 1] : -S[i * DS];

			M[i * DA + j] = Wold[j * NF] + Wold[j * NF + 1] * S[i * DS] +
			                Wold[j * NF + 2] * S[i * DS + 1];
			A[i * DA + j] = M[i * DA + j] + gsl_ran_gaussian(rng, 0.3);
			r -= (A[i * DA + j] - opt) * (A[i * DA + j] - opt);
		}
		w[i] = exp(r / 0.2);
		sw += w[i];
	}
	pn = pr_policy_linear_fit(PR_FEATURES_AFFINE, &d, 0.0, 1e-12, PR_COV_CENTER_NEW, &fn, err);
	po = pr_policy_linear_fit(PR_FEATURES_AFFINE, &d, 0.0, 1e-12, PR_COV_CENTER_OLD, &fo, err);
	assert_non_null(pn);
	assert_non_null(po);
	assert_int_equal(fn, 0);
	assert_int_equal(fo, 0);
	assert_int_equal(pr_policy_linear_params(pn, Wn, Cn, err), PR_OK);
	assert_int_equal(pr_policy_linear_params(po, Wo, Co, err), PR_OK);
	/* the same mean solve: identical bits */
	assert_memory_equal(Wn, Wo, sizeof Wn);
	for (i = 0; i < N; i++) {
		double delta[DA];

		for (j = 0; j < DA; j++)
			delta[j] = Wn[j * NF] + Wn[j * NF + 1] * S[i * DS] + Wn[j * NF + 2] * S[i * DS + 1] -
			           M[i * DA + j];
		for (j = 0; j < DA; j++)
			for (l = 0; l < DA; l++)
				D[j * DA + l] += w[i] / sw * delta[j] * delta[l];
	}
	/* the shift term is not small here (measured: trace 0.084 against 0.098),
	 * so the check has teeth */
	assert_true(D[0] + D[3] > 0.1 * (Cn[0] + Cn[3]));
	/* tolerance: round-off of sums of 60 terms and two eigen round trips */
	for (j = 0; j < DA * DA; j++)
		assert_near(Co[j] - Cn[j], D[j], 1e-12 * (Co[0] + Co[3]));
	/* old without the sampling means is refused */
	d.M = NULL;
	assert_null(pr_policy_linear_fit(PR_FEATURES_AFFINE, &d, 0.0, 1e-12, PR_COV_CENTER_OLD, NULL,
	                                 err));
	assert_non_null(strstr(err, "policy.cov_center"));
	pr_policy_free(pn);
	pr_policy_free(po);
	gsl_rng_free(rng);
}

/* Problems for C-CMA-ES: ds-dimensional contexts U[-1, 1], returns of x. */
enum { F_SLOPE, F_SPHERE, F_CQUAD };

static double objective(int f, const double *x, const double *s, int da)
{
	double r = 0.0;
	int j;

	for (j = 0; j < da; j++) {
		if (f == F_SLOPE)
			r += (j + 1.0) * x[j];
		else if (f == F_SPHERE)
			r -= x[j] * x[j];
		else
			r -= (x[j] - s[0]) * (x[j] - s[0]);
	}
	return r;
}

/* Run `gens` generations of n samples; sig[g] = sigma before generation g
 * (gens + 1 values). */
static pr_cmaes *run(int f, int da, int n, int gens, const double *W0, double sigma0,
                     unsigned long seed, double *sig)
{
	const int ds = 1, nb = 3;
	double *S = malloc((size_t)n * ds * sizeof *S), *X = malloc((size_t)n * da * sizeof *X);
	double *R = malloc((size_t)n * sizeof *R), *B = malloc((size_t)n * nb * sizeof *B);
	pr_cmaes_batch b = { n, nb, S, X, R, B };
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(seed);
	pr_cmaes *c = pr_cmaes_new(PR_FEATURES_AFFINE, ds, da, W0, sigma0, 1e-10, err);
	int g, i;

	assert_non_null(c);
	sig[0] = pr_cmaes_sigma(c);
	for (g = 0; g < gens; g++) {
		pr_policy *p = pr_cmaes_policy(c, 1e-300, NULL, err);

		assert_non_null(p);
		for (i = 0; i < n; i++) {
			S[i] = gsl_ran_flat(rng, -1.0, 1.0);
			assert_int_equal(pr_policy_sample(p, S + i, 1, rng, X + (size_t)i * da, NULL, NULL, err),
			                 PR_OK);
			R[i] = objective(f, X + (size_t)i * da, S + i, da);
			pr_policy_features_quadratic(S + i, ds, B + (size_t)i * nb);
		}
		pr_policy_free(p);
		assert_int_equal(pr_cmaes_update(c, &b, NULL, err), PR_OK);
		sig[g + 1] = pr_cmaes_sigma(c);
	}
	free(S);
	free(X);
	free(R);
	free(B);
	gsl_rng_free(rng);
	return c;
}

/* Step-size control: on a linear slope the steps keep their direction and
 * sigma grows; with the mean at the optimum of a sphere it shrinks. */
static void test_cmaes_step_size(void **state)
{
	enum { DA = 5, G = 60 };
	double W0[DA * 2] = { 0 }, sig[G + 1];
	unsigned long seed;

	(void)state;
	for (seed = 1; seed <= 5; seed++) {
		/* measured: sigma grows about 1.4x per generation (2e4 after 30) */
		pr_cmaes_free(run(F_SLOPE, DA, 20, 30, W0, 1.0, seed, sig));
		assert_true(sig[30] > 100.0 * sig[0]);
		assert_true(sig[10] > sig[0] && sig[20] > sig[10] && sig[30] > sig[20]);
		/* measured: about 0.94x per generation (0.018 after 60) */
		pr_cmaes_free(run(F_SPHERE, DA, 20, G, W0, 1.0, seed, sig));
		assert_true(sig[G] < 0.1 * sig[0]);
		assert_true(sig[20] < sig[0] && sig[40] < sig[20] && sig[60] < sig[40]);
	}
}

/* The 1-D contextual quadratic -(x - s)^2: the mean W [1, s] reaches
 * x*(s) = s, i.e. W = (0, 1), within 1e-8 (the ridge 1e-10 biases W by about
 * 1e-10), and the search std sigma sqrt(C) falls below 1e-6 (sigma itself
 * stays near 0.1-1 here: C does the shrinking). */
static void test_cmaes_contextual_quadratic(void **state)
{
	enum { G = 200 };
	double W0[2] = { 0.7, -0.4 }, W[2], C[1], sig[G + 1];
	pr_cmaes *c;

	(void)state;
	c = run(F_CQUAD, 1, 50, G, W0, 1.0, 3, sig);
	pr_cmaes_state(c, W, C);
	assert_near(W[0], 0.0, 1e-8);
	assert_near(W[1], 1.0, 1e-8);
	assert_true(sig[G] * sqrt(C[0]) < 1e-6);
	pr_cmaes_free(c);
}

/* One update is rank based: a positive affine map of the returns and a
 * permutation of the samples give the same state (up to round-off in the
 * regressions); bad input is refused and leaves the state alone. */
static void test_cmaes_invariance_and_errors(void **state)
{
	enum { N = 30, DS = 2, DA = 3, NF = 3, NB = 6 };
	double S[N * DS], X[N * DA], R[N], B[N * NB], R2[N], S3[N * DS], X3[N * DA], R3[N], B3[N * NB];
	double W0[DA * NF] = { 0.2, 0.0, 0.0, -0.1, 0.0, 0.0, 0.4, 0.0, 0.0 };
	double Wa[DA * NF], Wb[DA * NF], Ca[DA * DA], Cb[DA * DA];
	pr_cmaes_batch b = { N, NB, S, X, R, B };
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(5);
	pr_cmaes *c1 = pr_cmaes_new(PR_FEATURES_AFFINE, DS, DA, W0, 0.5, 1e-10, err);
	pr_cmaes *c2 = pr_cmaes_new(PR_FEATURES_AFFINE, DS, DA, W0, 0.5, 1e-10, err);
	pr_cmaes *c3 = pr_cmaes_new(PR_FEATURES_AFFINE, DS, DA, W0, 0.5, 1e-10, err);
	int i, j;

	(void)state;
	for (i = 0; i < N; i++) {
		for (j = 0; j < DS; j++)
			S[i * DS + j] = gsl_ran_flat(rng, 1.0, 2.0);
		R[i] = 0.0;
		for (j = 0; j < DA; j++) {
			X[i * DA + j] = W0[j * NF] + 0.5 * gsl_ran_gaussian(rng, 1.0);
			R[i] -= (X[i * DA + j] + S[i * DS + j % DS]) * (X[i * DA + j] + S[i * DS + j % DS]);
		}
		R2[i] = 1e3 * R[i] - 5e4;
		pr_policy_features_quadratic(S + i * DS, DS, B + i * NB);
	}
	/* permutation: reversed order */
	for (i = 0; i < N; i++) {
		memcpy(S3 + i * DS, S + (N - 1 - i) * DS, DS * sizeof *S);
		memcpy(X3 + i * DA, X + (N - 1 - i) * DA, DA * sizeof *X);
		memcpy(B3 + i * NB, B + (N - 1 - i) * NB, NB * sizeof *B);
		R3[i] = R[N - 1 - i];
	}
	assert_int_equal(pr_cmaes_update(c1, &b, NULL, err), PR_OK);
	b.R = R2;
	assert_int_equal(pr_cmaes_update(c2, &b, NULL, err), PR_OK);
	pr_cmaes_state(c1, Wa, Ca);
	pr_cmaes_state(c2, Wb, Cb);
	/* the same ranking: identical arithmetic afterwards */
	assert_memory_equal(Wa, Wb, sizeof Wa);
	assert_memory_equal(Ca, Cb, sizeof Ca);
	assert_true(pr_cmaes_sigma(c1) == pr_cmaes_sigma(c2));
	b.S = S3;
	b.X = X3;
	b.R = R3;
	b.B = B3;
	assert_int_equal(pr_cmaes_update(c3, &b, NULL, err), PR_OK);
	pr_cmaes_state(c3, Wb, Cb);
	/* tolerance: round-off of the reordered regression sums */
	for (j = 0; j < DA * NF; j++)
		assert_near(Wa[j], Wb[j], 1e-12);
	for (j = 0; j < DA * DA; j++)
		assert_near(Ca[j], Cb[j], 1e-12);
	assert_near(pr_cmaes_sigma(c1), pr_cmaes_sigma(c3), 1e-12);
	/* errors */
	R3[4] = NAN;
	assert_int_equal(pr_cmaes_update(c3, &b, NULL, err), PR_EINVAL);
	assert_non_null(strstr(err, "sample 4"));
	b.n = 1;
	assert_int_equal(pr_cmaes_update(c3, &b, NULL, err), PR_EINVAL);
	pr_cmaes_state(c3, Wa, Ca);
	assert_memory_equal(Wa, Wb, sizeof Wa);
	assert_memory_equal(Ca, Cb, sizeof Ca);
	assert_null(pr_cmaes_new(PR_FEATURES_AFFINE, DS, DA, W0, 0.0, 1e-10, err));
	assert_null(pr_cmaes_policy(c3, 0.0, NULL, err));
	pr_cmaes_free(c1);
	pr_cmaes_free(c2);
	pr_cmaes_free(c3);
	pr_cmaes_free(NULL);
	gsl_rng_free(rng);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_cov_center_shift),
		cmocka_unit_test(test_cmaes_step_size),
		cmocka_unit_test(test_cmaes_contextual_quadratic),
		cmocka_unit_test(test_cmaes_invariance_and_errors),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
