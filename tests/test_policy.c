/* test_policy.c — fixed, linear and tree-LWR Gaussian policies. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_multifit.h>
#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "poolreps/policy.h"
#include "poolreps/internal.h"
#include "test_util.h"

static gsl_rng *new_rng(unsigned long seed)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);

	gsl_rng_set(r, seed);
	return r;
}

/* The reference weighted linear fit of a on [1, s] (GSL's weighted least
 * squares) for n samples of ds state dimensions. */
typedef struct {
	int n, ds;
	gsl_matrix *X, *C;
	gsl_vector *y, *w, *b;
	gsl_multifit_linear_workspace *mw;
} wfit;

static void wfit_init(wfit *f, int n, int ds, const double *S)
{
	int i, j;

	f->n = n;
	f->ds = ds;
	f->X = gsl_matrix_alloc((size_t)n, (size_t)ds + 1);
	f->C = gsl_matrix_alloc((size_t)ds + 1, (size_t)ds + 1);
	f->y = gsl_vector_alloc((size_t)n);
	f->w = gsl_vector_alloc((size_t)n);
	f->b = gsl_vector_alloc((size_t)ds + 1);
	f->mw = gsl_multifit_linear_alloc((size_t)n, (size_t)ds + 1);
	for (i = 0; i < n; i++) {
		gsl_matrix_set(f->X, (size_t)i, 0, 1.0);
		for (j = 0; j < ds; j++)
			gsl_matrix_set(f->X, (size_t)i, (size_t)j + 1, S[i * ds + j]);
	}
}

/* Fit action column j of A (n x da) with weights w; returns the fit at s. */
static double wfit_at(wfit *f, const double *A, int da, int j, const double *w, const double *s)
{
	double chisq, v;
	int i;

	for (i = 0; i < f->n; i++) {
		gsl_vector_set(f->y, (size_t)i, A[i * da + j]);
		gsl_vector_set(f->w, (size_t)i, w[i]);
	}
	assert_int_equal(gsl_multifit_wlinear(f->X, f->w, f->y, f->b, f->C, &chisq, f->mw), GSL_SUCCESS);
	v = gsl_vector_get(f->b, 0);
	for (i = 0; i < f->ds; i++)
		v += gsl_vector_get(f->b, (size_t)i + 1) * s[i];
	return v;
}

static void wfit_free(wfit *f)
{
	gsl_matrix_free(f->X);
	gsl_matrix_free(f->C);
	gsl_vector_free(f->y);
	gsl_vector_free(f->w);
	gsl_vector_free(f->b);
	gsl_multifit_linear_free(f->mw);
}

static void test_gaussian_logpdf_sample(void **state)
{
	double mu[2] = { 0.3, -0.2 }, cov[4] = { 0.04, 0.012, 0.012, 0.09 };
	double a[2] = { 0.1, 0.05 }, lp, want, s[1] = { 0.0 };
	double *draws, m0 = 0, m1 = 0, c00 = 0, c01 = 0, c11 = 0;
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(1);
	pr_policy *p;
	int k, K = 100000;

	(void)state;
	p = pr_policy_gaussian_new(1, 2, mu, cov, err);
	assert_non_null(p);
	assert_int_equal(pr_policy_logpdf(p, s, a, &lp, NULL, NULL, err), PR_OK);
	want = log(gsl_ran_bivariate_gaussian_pdf(a[0] - mu[0], a[1] - mu[1], 0.2, 0.3,
	                                          0.012 / (0.2 * 0.3)));
	assert_near(lp, want, 1e-12);
	draws = malloc(2 * (size_t)K * sizeof *draws);
	assert_int_equal(pr_policy_sample(p, s, K, rng, draws, NULL, NULL, err), PR_OK);
	for (k = 0; k < K; k++) {
		m0 += draws[2 * k] / K;
		m1 += draws[2 * k + 1] / K;
	}
	for (k = 0; k < K; k++) {
		double d0 = draws[2 * k] - m0, d1 = draws[2 * k + 1] - m1;

		c00 += d0 * d0 / K;
		c01 += d0 * d1 / K;
		c11 += d1 * d1 / K;
	}
	/* standard errors: sd/sqrt(K) ~ 1e-3 for means, ~2e-4 for covariances */
	assert_near(m0, mu[0], 4e-3);
	assert_near(m1, mu[1], 4e-3);
	assert_near(c00, 0.04, 1e-3);
	assert_near(c01, 0.012, 1e-3);
	assert_near(c11, 0.09, 2e-3);
	free(draws);
	cov[1] = 0.5; /* not symmetric */
	assert_null(pr_policy_gaussian_new(1, 2, mu, cov, err));
	cov[1] = cov[2] = 0.5; /* not positive definite */
	assert_null(pr_policy_gaussian_new(1, 2, mu, cov, err));
	pr_policy_free(p);
	gsl_rng_free(rng);
}

/* Weighted ML on data from a known linear-Gaussian policy recovers it, with
 * weights that do not depend on the actions (so they do not bias it). */
static void test_linear_ml_recovers(void **state)
{
	enum { N = 20000 };
	const double W[2][3] = { { 0.1, 1.0, -0.5 }, { -0.3, 0.2, 0.7 } };
	const double Lc[2][2] = { { 0.2, 0.0 }, { 0.1, 0.15 } };
	double *S = malloc(2 * N * sizeof *S), *A = malloc(2 * N * sizeof *A), *w = malloc(N * sizeof *w);
	double mean[2], cov[4], s[2] = { 0.4, -0.6 };
	pr_policy_data d = { N, 2, 2, 0, S, A, NULL, w, NULL };
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(2);
	pr_policy *p;
	int i, flags;

	(void)state;
	for (i = 0; i < N; i++) {
		double z0 = gsl_ran_gaussian(rng, 1.0), z1 = gsl_ran_gaussian(rng, 1.0);

		S[2 * i] = gsl_rng_uniform(rng) * 2 - 1;
		S[2 * i + 1] = gsl_rng_uniform(rng) * 2 - 1;
		A[2 * i] = W[0][0] + W[0][1] * S[2 * i] + W[0][2] * S[2 * i + 1] + Lc[0][0] * z0;
		A[2 * i + 1] = W[1][0] + W[1][1] * S[2 * i] + W[1][2] * S[2 * i + 1] +
		               Lc[1][0] * z0 + Lc[1][1] * z1;
		w[i] = 0.1 + S[2 * i] * S[2 * i]; /* depends on the state only */
	}
	p = pr_policy_linear_fit(PR_FEATURES_AFFINE, &d, 1e-10, 1e-6, PR_COV_CENTER_NEW, &flags, err);
	assert_non_null(p);
	assert_int_equal(flags, 0);
	assert_int_equal(pr_policy_eval(p, s, mean, cov, NULL, NULL, err), PR_OK);
	assert_near(mean[0], (0.1 + 0.4 + 0.3), 0.01);
	assert_near(mean[1], (-0.3 + 0.08 - 0.42), 0.01);
	assert_near(cov[0], 0.04, 0.002);
	assert_near(cov[1], 0.02, 0.002);
	assert_true(cov[1] == cov[2]);
	assert_near(cov[3], (0.01 + 0.0225), 0.002);
	pr_policy_free(p);
	/* quadratic features contain the affine ones: same answer */
	p = pr_policy_linear_fit(PR_FEATURES_QUADRATIC, &d, 1e-10, 1e-6, PR_COV_CENTER_NEW, &flags, err);
	assert_non_null(p);
	assert_int_equal(pr_policy_eval(p, s, mean, cov, NULL, NULL, err), PR_OK);
	assert_near(mean[0], 0.8, 0.01);
	assert_near(cov[0], 0.04, 0.002);
	pr_policy_free(p);
	free(S);
	free(A);
	free(w);
	gsl_rng_free(rng);
}

static void test_quadratic_features(void **state)
{
	double s[3] = { 2.0, -1.0, 0.5 }, psi[10];
	double want[10] = { 1, 2, -1, 0.5, 4, -2, 1, 1, -0.5, 0.25 };
	int j;

	(void)state;
	assert_int_equal(pr_policy_features_count(PR_FEATURES_QUADRATIC, 3), 10);
	assert_int_equal(pr_policy_features_count(PR_FEATURES_AFFINE, 3), 4);
	pr_policy_features_quadratic(s, 3, psi);
	for (j = 0; j < 10; j++)
		assert_true(psi[j] == want[j]);
}

/* A forest whose n_min exceeds n has one node per tree: the tree-LWR mean
 * is the global weighted linear regression (gsl_multifit_wlinear here), and
 * the covariance is eq. 6.8-6.9 with the global weights. */
static void test_single_node_is_global(void **state)
{
	enum { N = 40, DS = 2, DA = 2 };
	double S[N * DS], A[N * DA], w[N], s[DS] = { 0.2, -0.1 }, mean[DA], cov[DA * DA];
	double want_cov[DA * DA] = { 0 }, sw = 0, sw2 = 0, mu[DA];
	pr_policy_data d = { N, DS, DA, 0, S, A, NULL, w, NULL };
	pr_policy_opts o;
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(3);
	wfit f;
	pr_policy *p;
	int i, j, l, flags;

	(void)state;
	for (i = 0; i < N; i++) {
		S[i * DS] = gsl_rng_uniform(rng);
		S[i * DS + 1] = gsl_rng_uniform(rng) - 0.5;
		A[i * DA] = sin(3 * S[i * DS]) + S[i * DS + 1] + 0.1 * gsl_ran_gaussian(rng, 1);
		A[i * DA + 1] = S[i * DS] * S[i * DS + 1] + 0.1 * gsl_ran_gaussian(rng, 1);
		w[i] = gsl_rng_uniform(rng);
		sw += w[i];
		sw2 += w[i] * w[i];
	}
	pr_policy_opts_init(&o);
	o.forest.n_min = N + 1;
	o.forest.trees = 3;
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(p);
	assert_int_equal(pr_forest_nleaves(pr_policy_forest(p)), 3);
	assert_int_equal(pr_policy_eval(p, s, mean, cov, &flags, NULL, err), PR_OK);
	assert_int_equal(flags, 0);
	wfit_init(&f, N, DS, S);
	for (j = 0; j < DA; j++) {
		mu[j] = wfit_at(&f, A, DA, j, w, s);
		assert_near(mean[j], mu[j], 1e-8);
	}
	wfit_free(&f);
	/* eq. 6.8-6.9 with unnormalised weights, centred on mu(s_hat) */
	for (i = 0; i < N; i++)
		for (j = 0; j < DA; j++)
			for (l = 0; l < DA; l++)
				want_cov[j * DA + l] += w[i] * (A[i * DA + j] - mu[j]) * (A[i * DA + l] - mu[l]);
	for (j = 0; j < DA * DA; j++)
		assert_near(cov[j], want_cov[j] / ((sw * sw - sw2) / sw), 1e-9);
	pr_policy_free(p);
	gsl_rng_free(rng);
}

/* Hand-checked eq. 6.6-6.9: s = 0, 1, 2; a = 0, 1, 3; w = 1, 1, 2; query 1.
 * Weighted LS: alpha = -2/11, beta = 17/11, mu(1) = 15/11.
 * sum w (a - mu)^2 = (225 + 16 + 648)/121 = 889/121; Z = (16 - 6)/4 = 2.5;
 * Sigma = 889/302.5. Residual centring: (4 + 16 + 2)/121 / 2.5 = 22/302.5.
 * Centred on sampling means m = 1/2 (cov_center old, either policy.cov):
 * (1/4 + 1/4 + 2 * 25/4) / 2.5 = 5.2; the mean is unchanged. */
static void test_covariance_hand(void **state)
{
	double S[3] = { 0, 1, 2 }, A[3] = { 0, 1, 3 }, w[3] = { 1, 1, 2 }, s = 1.0, mean, cov;
	double M[3] = { 0.5, 0.5, 0.5 };
	pr_policy_data d = { 3, 1, 1, 0, S, A, NULL, w, NULL };
	pr_policy_opts o;
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(4);
	pr_policy *p;
	int flags;

	(void)state;
	pr_policy_opts_init(&o);
	o.forest.n_min = 10;
	o.min_std = 1e-9;
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(p);
	assert_int_equal(pr_policy_eval(p, &s, &mean, &cov, &flags, NULL, err), PR_OK);
	assert_int_equal(flags, 0);
	assert_near(mean, 15.0 / 11.0, 1e-9);
	assert_near(cov, 889.0 / 302.5, 1e-9);
	pr_policy_free(p);
	o.cov = PR_COV_RESIDUAL;
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(p);
	assert_int_equal(pr_policy_eval(p, &s, &mean, &cov, &flags, NULL, err), PR_OK);
	assert_near(mean, 15.0 / 11.0, 1e-9);
	assert_near(cov, 22.0 / 302.5, 1e-9);
	pr_policy_free(p);
	o.cov_center = PR_COV_CENTER_OLD;
	d.M = M;
	for (o.cov = PR_COV_QUERY; o.cov <= PR_COV_RESIDUAL; o.cov++) {
		p = pr_policy_tree_fit(&o, &d, rng, err);
		assert_non_null(p);
		assert_int_equal(pr_policy_eval(p, &s, &mean, &cov, &flags, NULL, err), PR_OK);
		assert_int_equal(flags, 0);
		assert_near(mean, 15.0 / 11.0, 1e-9);
		assert_near(cov, 5.2, 1e-12);
		pr_policy_free(p);
	}
	gsl_rng_free(rng);
}

/* Tree-LWR eq. 6.8 centred on the sampling means m_i (cov_center old)
 * against the residual centre, on a forest: when the drawing policy's mean
 * is affine in the state, m_i = c + G s_i, the local weighted normal
 * equations (lambda = 0) remove the cross terms and
 *   Sigma_old(s) = Sigma_res(s) + sum_i w^_i d_i d_i^T / Z,
 *   d_i = l(s_i) - m_i,
 * l the query's local weighted linear fit (here from gsl_multifit_wlinear
 * with the eq. 6.4 weights w^ read off the forest's leaves), Z of eq. 6.9.
 * The means agree bit for bit. Tolerance: 1e-10 of the largest variance. */
static void test_tree_old_shift(void **state)
{
	enum { N = 300, DS = 2, DA = 2, NQ = 12 };
	double S[N * DS], A[N * DA], M[N * DA], w[N], wh[N], s[DS];
	double mo[DA], co[DA * DA], mr[DA], cr[DA * DA], want[DA * DA], l[N * DA];
	const double c[DA] = { 0.3, -0.2 }, G[DA * DS] = { 0.5, -1.0, 0.25, 0.8 };
	pr_policy_data d = { N, DS, DA, 0, S, A, NULL, w, M };
	pr_policy_opts o;
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(21);
	wfit f;
	pr_policy *po, *pn;
	int i, j, k, q, t, fo, fr, lv[8], lq[8], nt, compared = 0;

	(void)state;
	for (i = 0; i < N; i++) {
		S[i * DS] = gsl_rng_uniform(rng) * 2 - 1;
		S[i * DS + 1] = gsl_rng_uniform(rng) * 2 - 1;
		for (j = 0; j < DA; j++) {
			M[i * DA + j] = c[j] + G[j * DS] * S[i * DS] + G[j * DS + 1] * S[i * DS + 1];
			A[i * DA + j] = (j ? S[i * DS] * S[i * DS + 1] : sin(2 * S[i * DS])) +
			                0.1 * gsl_ran_gaussian(rng, 1);
		}
		w[i] = gsl_rng_uniform(rng) < 0.2 ? 0.0 : gsl_ran_exponential(rng, 1.0);
	}
	wfit_init(&f, N, DS, S);
	pr_policy_opts_init(&o);
	o.forest.trees = 5;
	o.forest.n_min = 40;
	o.lambda = 0.0;
	o.min_std = 1e-150;
	o.cov = PR_COV_RESIDUAL;
	gsl_rng_set(rng, 22);
	pn = pr_policy_tree_fit(&o, &d, rng, err);
	o.cov_center = PR_COV_CENTER_OLD;
	gsl_rng_set(rng, 22); /* the same forest */
	po = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(pn);
	assert_non_null(po);
	nt = pr_forest_ntrees(pr_policy_forest(po));
	assert_int_equal(nt, 5);
	for (q = 0; q < NQ; q++) {
		double tot = 0.0, tot2 = 0.0, Z, big;

		s[0] = gsl_rng_uniform(rng) * 2 - 1;
		s[1] = gsl_rng_uniform(rng) * 2 - 1;
		assert_int_equal(pr_policy_eval(po, s, mo, co, &fo, NULL, err), PR_OK);
		assert_int_equal(pr_policy_eval(pn, s, mr, cr, &fr, NULL, err), PR_OK);
		assert_int_equal(fo, fr);
		assert_memory_equal(mo, mr, sizeof mo);
		if (fo)
			continue;
		/* eq. 6.4 weights from the leaves */
		assert_int_equal(pr_forest_active(pr_policy_forest(po), s, DS, lq, 8), nt);
		for (i = 0; i < N; i++) {
			int shared = 0;

			assert_int_equal(pr_forest_active(pr_policy_forest(po), S + i * DS, DS, lv, 8), nt);
			for (t = 0; t < nt; t++)
				shared += lv[t] == lq[t];
			wh[i] = w[i] / nt * shared;
			tot += wh[i];
			tot2 += wh[i] * wh[i];
		}
		Z = (tot * tot - tot2) / tot;
		for (j = 0; j < DA; j++) {
			assert_near(mr[j], wfit_at(&f, A, DA, j, wh, s), 1e-9);
			for (i = 0; i < N; i++)
				l[i * DA + j] = gsl_vector_get(f.b, 0) + gsl_vector_get(f.b, 1) * S[i * DS] +
				                gsl_vector_get(f.b, 2) * S[i * DS + 1] - M[i * DA + j];
		}
		for (j = 0; j < DA; j++)
			for (k = 0; k < DA; k++) {
				want[j * DA + k] = cr[j * DA + k];
				for (i = 0; i < N; i++)
					want[j * DA + k] += wh[i] * l[i * DA + j] * l[i * DA + k] / Z;
			}
		big = fmax(want[0], want[3]);
		for (j = 0; j < DA * DA; j++)
			assert_near(co[j], want[j], 1e-10 * big);
		/* and the shift matters: the centres differ by far more than that */
		assert_true(fabs(co[0] - cr[0]) > 1e-3 * big);
		compared++;
	}
	assert_true(compared >= NQ / 2);
	pr_policy_free(po);
	pr_policy_free(pn);
	wfit_free(&f);
	gsl_rng_free(rng);
}

/* n uniform states in the unit square and the noiseless actions
 * a = (s0, -s1): the degenerate cases' data. */
static void mirror_data(gsl_rng *rng, int n, double *S, double *A)
{
	int i;

	for (i = 0; i < n; i++) {
		S[2 * i] = gsl_rng_uniform(rng);
		S[2 * i + 1] = gsl_rng_uniform(rng);
		A[2 * i] = S[2 * i];
		A[2 * i + 1] = -S[2 * i + 1];
	}
}

/* cov_center old on degenerate data: no sampling means or a non-finite one
 * is refused (naming the key or the sample); one weighted neighbour (Z = 0)
 * falls back to the global weights, centred on the sampling means too;
 * residuals that are all 0 give min_std^2 I. */
static void test_tree_old_degenerate(void **state)
{
	enum { N = 30 };
	double S[N * 2], A[N * 2], M[N * 2], w[N], mean[2], cov[4], want[4] = { 0 };
	double tot = 0.0, tot2 = 0.0, Z;
	pr_policy_data d = { N, 2, 2, 0, S, A, NULL, w, NULL };
	pr_policy_opts o;
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(23);
	pr_policy *p;
	int i, j, k, flags;

	(void)state;
	mirror_data(rng, N, S, A);
	for (i = 0; i < N; i++) {
		M[2 * i] = A[2 * i] + 0.1 * gsl_ran_gaussian(rng, 1);
		M[2 * i + 1] = A[2 * i + 1] - 0.2;
		w[i] = 1.0 + i % 3;
		tot += w[i];
		tot2 += w[i] * w[i];
	}
	pr_policy_opts_init(&o);
	o.cov_center = PR_COV_CENTER_OLD;
	assert_null(pr_policy_tree_fit(&o, &d, rng, err));
	assert_non_null(strstr(err, "policy.cov_center"));
	d.M = M;
	M[5] = NAN;
	assert_null(pr_policy_tree_fit(&o, &d, rng, err));
	assert_non_null(strstr(err, "sample 2: sampling mean 1 is not finite"));
	M[5] = A[5] - 0.2;
	/* leaves of one sample, one tree: Z = 0 at a training state -> the
	 * global weights' covariance about the sampling means */
	o.forest.trees = 1;
	o.forest.n_min = 1;
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(p);
	assert_int_equal(pr_policy_eval(p, S + 10, mean, cov, &flags, NULL, err), PR_OK);
	assert_true((flags & PR_POLICY_MEANONLY) && (flags & PR_POLICY_COVFALL));
	Z = (tot * tot - tot2) / tot;
	for (i = 0; i < N; i++)
		for (j = 0; j < 2; j++)
			for (k = 0; k < 2; k++)
				want[j * 2 + k] += w[i] * (A[2 * i + j] - M[2 * i + j]) * (A[2 * i + k] - M[2 * i + k]) / Z;
	for (j = 0; j < 4; j++)
		assert_near(cov[j], want[j], 1e-12 * want[0]);
	pr_policy_free(p);
	/* m = a: no residual at all -> the floor */
	memcpy(M, A, sizeof M);
	o.forest.n_min = N + 1;
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(p);
	assert_int_equal(pr_policy_eval(p, S, mean, cov, &flags, NULL, err), PR_OK);
	assert_true(flags & PR_POLICY_FLOOR);
	assert_near(cov[0], o.min_std * o.min_std, 1e-18);
	assert_near(cov[1], 0.0, 1e-18);
	assert_near(cov[3], o.min_std * o.min_std, 1e-18);
	pr_policy_free(p);
	gsl_rng_free(rng);
}

/* A step in the actions: tree-LWR follows it, the global policy cannot. */
static void test_tree_is_local(void **state)
{
	enum { N = 400 };
	double S[N], A[N], mean, cov, lo = -0.6, hi = 0.6, lp;
	pr_policy_data d = { N, 1, 1, 0, S, A, NULL, NULL, NULL };
	pr_policy_opts o;
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(5);
	pr_policy *p;
	pr_policy_work *ws;
	int i, flags;

	(void)state;
	for (i = 0; i < N; i++) {
		S[i] = gsl_rng_uniform(rng) * 2 - 1;
		A[i] = (S[i] < 0 ? 1.0 : -1.0) + 0.05 * gsl_ran_gaussian(rng, 1);
	}
	pr_policy_opts_init(&o);
	o.forest.trees = 10;
	o.forest.n_min = 40;
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(p);
	ws = pr_policy_work_new(p, err);
	assert_non_null(ws);
	assert_int_equal(pr_policy_eval(p, &lo, &mean, &cov, &flags, ws, err), PR_OK);
	assert_near(mean, 1.0, 0.05);
	assert_true(cov < 0.01);
	assert_int_equal(pr_policy_eval(p, &hi, &mean, &cov, &flags, ws, err), PR_OK);
	assert_near(mean, -1.0, 0.05);
	assert_true(cov < 0.01);
	/* log-density agrees with the Gaussian of eval */
	assert_int_equal(pr_policy_logpdf(p, &hi, &mean, &lp, NULL, ws, err), PR_OK);
	assert_near(lp, -(0.5 * log(2 * 3.14159265358979323846 * cov)), 1e-9);
	pr_policy_work_free(ws);
	pr_policy_free(p);
	/* the global linear fit has slope about -1.5: mean(-0.1) about 0.15 */
	o.forest.n_min = N;
	lo = -0.1;
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_int_equal(pr_policy_eval(p, &lo, &mean, &cov, &flags, NULL, err), PR_OK);
	assert_near(mean, 0.15, 0.1);
	assert_true(cov > 0.2);
	pr_policy_free(p);
	gsl_rng_free(rng);
}

static int finite_all(const double *x, int n)
{
	int i;

	for (i = 0; i < n; i++)
		if (!isfinite(x[i]))
			return 0;
	return 1;
}

static void test_degenerate(void **state)
{
	enum { N = 30 };
	double S[N * 2], A[N * 2], w[N], mean[2], cov[4], s[2], Y[N * 2];
	pr_policy_data d = { N, 2, 2, 0, S, A, NULL, w, NULL };
	pr_policy_opts o;
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(6);
	pr_policy *p;
	int i, flags;

	(void)state;
	mirror_data(rng, N, S, A);
	for (i = 0; i < N; i++)
		w[i] = 1.0;
	pr_policy_opts_init(&o);
	/* leaves of one sample, one tree: a training state has a single weighted
	 * neighbour -> mean only, Z = 0 -> global covariance */
	o.forest.trees = 1;
	o.forest.n_min = 1;
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(p);
	assert_int_equal(pr_policy_eval(p, S + 10, mean, cov, &flags, NULL, err), PR_OK);
	assert_true(flags & PR_POLICY_MEANONLY);
	assert_true(flags & PR_POLICY_COVFALL);
	assert_near(mean[0], A[10], 1e-12);
	assert_near(mean[1], A[11], 1e-12);
	assert_true(finite_all(cov, 4) && cov[0] > 0 && cov[3] > 0);
	pr_policy_free(p);

	/* zero REPS weight on the half x < 0.5; with leaves of one sample, a
	 * query at such a sample has no weight around it and falls back to the
	 * global weighted fit */
	for (i = 0; i < N; i++)
		w[i] = S[2 * i] < 0.5 ? 0.0 : 1.0;
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(p);
	for (i = 0; w[i] > 0.0; i++)
		;
	s[0] = S[2 * i];
	s[1] = S[2 * i + 1];
	assert_int_equal(pr_policy_eval(p, s, mean, cov, &flags, NULL, err), PR_OK);
	assert_true(flags & PR_POLICY_GLOBAL);
	/* the weighted samples have a = (s0, -s1) exactly */
	assert_near(mean[0], s[0], 1e-8);
	assert_near(mean[1], -(s[1]), 1e-8);
	assert_true(finite_all(cov, 4));
	pr_policy_free(p);

	/* every weight on one sample: Z = 0 everywhere -> min_std^2 I */
	memset(w, 0, sizeof w);
	w[7] = 1.0;
	o.forest.n_min = N + 1;
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(p);
	assert_int_equal(pr_policy_eval(p, S, mean, cov, &flags, NULL, err), PR_OK);
	assert_true((flags & PR_POLICY_COVFALL) && (flags & PR_POLICY_FLOOR));
	assert_near(mean[0], A[14], 1e-12);
	assert_near(cov[0], o.min_std * o.min_std, 1e-18);
	assert_near(cov[1], 0.0, 1e-18);
	pr_policy_free(p);

	/* identical states and no ridge: singular design -> pseudo-inverse */
	for (i = 0; i < N; i++) {
		S[2 * i] = 0.3;
		S[2 * i + 1] = 0.7;
		w[i] = 1.0;
	}
	o.lambda = 0.0;
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(p);
	assert_int_equal(pr_policy_eval(p, S, mean, cov, &flags, NULL, err), PR_OK);
	assert_true(flags & PR_POLICY_PINV);
	assert_true(finite_all(mean, 2) && finite_all(cov, 4));
	pr_policy_free(p);

	/* bad data */
	memset(w, 0, sizeof w);
	assert_null(pr_policy_tree_fit(&o, &d, rng, err));
	w[0] = -1.0;
	assert_null(pr_policy_tree_fit(&o, &d, rng, err));
	w[0] = 1.0;
	o.target = PR_TARGET_REWARD_STATE;
	assert_null(pr_policy_tree_fit(&o, &d, rng, err));
	for (i = 0; i < 2 * N; i++)
		Y[i] = A[i] * 2;
	d.Y = Y;
	d.dy = 2;
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(p);
	pr_policy_free(p);
	gsl_rng_free(rng);
}

/* One tree with one leaf is the global weighted linear fit; with states
 * 1000 +- 1 and a = 2 (s - 1000) the mean must follow the slope (an
 * uncentred eq. 6.6 lost it: -0.018 at every query), and offsets and scales
 * of states and actions must not change the answer (1e-9 relative). */
static void test_offset_states(void **state)
{
	enum { NS = 200 };
	double S[NS], A[NS], S2[NS], A2[NS], mean, cov, mean2, cov2;
	double q[3] = { -0.5, 0.0, 0.5 }, off[3] = { 1000.0, 1e6, -3e5 }, sc[3] = { 1e-6, 1e6, 3.0 };
	pr_policy_data d = { NS, 1, 1, 0, S, A, NULL, NULL, NULL };
	pr_policy_opts o;
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(11);
	pr_policy *p, *p2;
	int i, k, j, flags;

	(void)state;
	for (i = 0; i < NS; i++) {
		S[i] = gsl_rng_uniform(rng) * 2 - 1;
		A[i] = 2 * S[i] + 0.01 * gsl_ran_gaussian(rng, 1);
	}
	pr_policy_opts_init(&o);
	o.forest.trees = 1;
	o.forest.n_min = NS + 1;
	o.min_std = 1e-150; /* the scaled actions' spread is 1e-6: no floor */
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(p);
	for (k = 0; k < 3; k++) {
		pr_policy_data d2 = { NS, 1, 1, 0, S2, A2, NULL, NULL, NULL };

		for (i = 0; i < NS; i++) {
			S2[i] = S[i] * sc[k] + off[k] * sc[k];
			A2[i] = A[i] / sc[k];
		}
		p2 = pr_policy_tree_fit(&o, &d2, rng, err);
		assert_non_null(p2);
		for (j = 0; j < 3; j++) {
			double s2 = q[j] * sc[k] + off[k] * sc[k];

			assert_int_equal(pr_policy_eval(p, &q[j], &mean, &cov, &flags, NULL, err), PR_OK);
			assert_int_equal(flags, 0);
			assert_near(mean, 2 * q[j], 0.01);
			assert_int_equal(pr_policy_eval(p2, &s2, &mean2, &cov2, &flags, NULL, err), PR_OK);
			assert_int_equal(flags, 0);
			/* the states carry round-off of |off| eps relative to their spread */
			assert_near(mean2 * sc[k], mean, 1e-9);
			assert_near(cov2 * sc[k] * sc[k], cov, 1e-9 * cov);
		}
		pr_policy_free(p2);
	}
	pr_policy_free(p);
	gsl_rng_free(rng);
}

/* The linear-Gaussian fit with quadratic features: offsets of 1e6 would
 * swamp s^2 in uncentred features; the fit takes them about the weighted
 * mean state, so the mean at a query does not move. */
static void test_linear_fit_offsets(void **state)
{
	enum { NS = 100 };
	double S[2 * NS], A[2 * NS], S2[2 * NS], w[NS], s[2], s2[2], m1[2], m2[2], c1[4], c2[4];
	pr_policy_data d = { NS, 2, 2, 0, S, A, NULL, w, NULL };
	pr_policy_data e = { NS, 2, 2, 0, S2, A, NULL, w, NULL };
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(12);
	pr_policy *p, *p2;
	int i, j, flags;

	(void)state;
	for (i = 0; i < NS; i++) {
		S[2 * i] = gsl_rng_uniform(rng);
		S[2 * i + 1] = gsl_rng_uniform(rng);
		A[2 * i] = S[2 * i] * S[2 * i] - S[2 * i + 1] + 0.01 * gsl_ran_gaussian(rng, 1);
		A[2 * i + 1] = S[2 * i] * S[2 * i + 1] + 0.01 * gsl_ran_gaussian(rng, 1);
		w[i] = gsl_rng_uniform(rng);
		S2[2 * i] = S[2 * i] + 1e6;
		S2[2 * i + 1] = S[2 * i + 1] - 1e6;
	}
	p = pr_policy_linear_fit(PR_FEATURES_QUADRATIC, &d, 1e-10, 1e-6, PR_COV_CENTER_NEW, &flags, err);
	p2 = pr_policy_linear_fit(PR_FEATURES_QUADRATIC, &e, 1e-10, 1e-6, PR_COV_CENTER_NEW, &flags, err);
	assert_non_null(p);
	assert_non_null(p2);
	assert_int_equal(flags, 0);
	for (j = 0; j < 5; j++) {
		s[0] = 0.2 * j;
		s[1] = 1.0 - 0.2 * j;
		s2[0] = s[0] + 1e6;
		s2[1] = s[1] - 1e6;
		assert_int_equal(pr_policy_eval(p, s, m1, c1, NULL, NULL, err), PR_OK);
		assert_int_equal(pr_policy_eval(p2, s2, m2, c2, NULL, NULL, err), PR_OK);
		/* the quadratic model fits a0 = s0^2 - s1 */
		assert_near(m1[0], (s[0] * s[0] - s[1]), 0.02);
		/* states rounded at 1e6 eps = 1e-10 of their unit spread */
		assert_near(m1[0], m2[0], 1e-8);
		assert_near(m1[1], m2[1], 1e-8);
		for (i = 0; i < 4; i++)
			assert_near(c1[i], c2[i], 1e-8 * c1[0]);
	}
	/* pr_policy_linear_params expands W psi(s - c) to W' psi(s): rebuilt with
	 * pr_policy_linear_new it gives the same means */
	{
		double W[2 * 6], C[4];
		pr_policy *p3;

		assert_int_equal(pr_policy_linear_params(p, W, C, err), PR_OK);
		p3 = pr_policy_linear_new(PR_FEATURES_QUADRATIC, 2, 2, W, C, err);
		assert_non_null(p3);
		for (j = 0; j < 5; j++) {
			s[0] = 0.3 * j - 0.2;
			s[1] = 0.1 * j;
			assert_int_equal(pr_policy_eval(p, s, m1, c1, NULL, NULL, err), PR_OK);
			assert_int_equal(pr_policy_eval(p3, s, m2, c2, NULL, NULL, err), PR_OK);
			for (i = 0; i < 2; i++)
				assert_near(m1[i], m2[i], 1e-12 * (1.0 + fabs(m1[i])));
			for (i = 0; i < 4; i++)
				assert_true(c1[i] == c2[i]);
		}
		pr_policy_free(p3);
	}
	pr_policy_free(p);
	pr_policy_free(p2);
	gsl_rng_free(rng);
}

/* Collinear states (s1 = 2 s0 exactly) make the standardised design rank 1:
 * PR_POLICY_PINV, with the slope fitted along the line the data span, so
 * queries on that line are right. */
static void test_collinear_states(void **state)
{
	enum { NS = 80 };
	double S[2 * NS], A[NS], s[2], mean, cov;
	pr_policy_data d = { NS, 2, 1, 0, S, A, NULL, NULL, NULL };
	pr_policy_opts o;
	char err[PR_ERRLEN];
	gsl_rng *rng = new_rng(13);
	pr_policy *p;
	int i, flags;

	(void)state;
	for (i = 0; i < NS; i++) {
		S[2 * i] = gsl_rng_uniform(rng);
		S[2 * i + 1] = 2 * S[2 * i];
		A[i] = 3 * S[2 * i] + 1;
	}
	pr_policy_opts_init(&o);
	o.lambda = 0.0;
	o.forest.trees = 2;
	o.forest.n_min = NS + 1;
	p = pr_policy_tree_fit(&o, &d, rng, err);
	assert_non_null(p);
	s[0] = 0.3;
	s[1] = 0.6;
	assert_int_equal(pr_policy_eval(p, s, &mean, &cov, &flags, NULL, err), PR_OK);
	assert_true(flags & PR_POLICY_PINV);
	assert_near(mean, 1.9, 1e-9);
	pr_policy_free(p);
	gsl_rng_free(rng);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_gaussian_logpdf_sample),
		cmocka_unit_test(test_linear_ml_recovers),
		cmocka_unit_test(test_quadratic_features),
		cmocka_unit_test(test_single_node_is_global),
		cmocka_unit_test(test_covariance_hand),
		cmocka_unit_test(test_tree_old_shift),
		cmocka_unit_test(test_tree_old_degenerate),
		cmocka_unit_test(test_tree_is_local),
		cmocka_unit_test(test_degenerate),
		cmocka_unit_test(test_offset_states),
		cmocka_unit_test(test_linear_fit_offsets),
		cmocka_unit_test(test_collinear_states),
	};

	gsl_set_error_handler_off();
	return cmocka_run_group_tests(tests, NULL, NULL);
}
