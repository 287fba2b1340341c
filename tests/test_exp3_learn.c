/* test_exp3_learn.c — Experiment 3's learner through its private API
 * (exp3_priv.h), and the experiment registry as the configuration's schema. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_rng.h>

#include "poolreps/config.h"
#include "poolreps/exp.h"
#include "poolreps/forest.h"
#include "exp3_priv.h"

#define ITERS 3

/* A small Experiment 3 configuration. */
static void small_config(pr_config *c)
{
	static const char *const sets[] = {
		"experiment.name=exp3", "exp3.init_samples=30", "exp3.window=30", "exp3.samples=10",
		"exp3.iterations=3", "policy.n_min=20", "exp3.baseline_n_min=100", "value.trees=3",
		"value.n_min=10"
	};
	char err[PR_ERRLEN];
	size_t i;

	pr_config_init(c, pr_exp_config);
	for (i = 0; i < sizeof sets / sizeof sets[0]; ++i)
		assert_int_equal(pr_config_set(c, sets[i], err), PR_OK);
	assert_int_equal(pr_config_validate(c, err), PR_OK);
}

static gsl_rng *rng(unsigned long seed)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);

	assert_non_null(r);
	gsl_rng_set(r, seed);
	return r;
}

/* Every episode and iteration row of a and b, bit for bit. */
static void assert_same(const pr_exp3_episodes *a, const pr_exp3_episodes *b)
{
	size_t n = (size_t)a->n;

	assert_int_equal(a->n, b->n);
	assert_int_equal(a->niter, b->niter);
	assert_memory_equal(a->S, b->S, n * (size_t)a->ds * sizeof *a->S);
	assert_memory_equal(a->A, b->A, 2 * n * sizeof *a->A);
	assert_memory_equal(a->R, b->R, n * sizeof *a->R);
	assert_memory_equal(a->F, b->F, 2 * n * sizeof *a->F);
	assert_memory_equal(a->pocket, b->pocket, n * sizeof *a->pocket);
	assert_memory_equal(a->iter, b->iter, n * sizeof *a->iter);
	assert_memory_equal(a->it, b->it, (size_t)a->niter * sizeof *a->it);
}

static void run_iterations(pr_exp3_learner *L)
{
	char err[PR_ERRLEN];
	int t;

	for (t = 0; t < ITERS; ++t)
		assert_int_equal(pr_exp3_learner_iterate(L, err), PR_OK);
	assert_int_not_equal(pr_exp3_learner_iterate(L, err), PR_OK); /* past exp3.iterations */
}

/* A learner seeded with another's iteration 0 (and the streams where that
 * one's stood after it) continues exactly as the other one does, for every
 * variant: seeded episodes are the learner's own. */
static void test_seeded_learner_continues_the_same(void **state)
{
	pr_config c;
	char err[PR_ERRLEN];
	int v;

	(void)state;
	small_config(&c);
	for (v = 0; v < PR_EXP3_NVAR; ++v) {
		const pr_exp3_opts *e = pr_exp3_opts_of(&c);
		gsl_rng *s1 = rng(11), *i1 = rng(12), *l1 = rng(13), *s2, *i2 = rng(99), *l2;
		pr_exp3_learner *A, *B;
		const pr_exp3_episodes *ea;
		double *logq, mean[2] = {0.0, 0.0}, cov[4] = {0.0, 0.0, 0.0, 0.0};
		int i, n0;

		assert_int_equal(pr_exp3_learner_new(&c, e, v, s1, i1, l1, &A, err), PR_OK);
		assert_int_equal(pr_exp3_learner_start(A, err), PR_OK);
		s2 = gsl_rng_clone(s1);
		l2 = gsl_rng_clone(l1);
		ea = pr_exp3_learner_episodes(A);
		n0 = ea->n;
		assert_int_equal(n0, e->init_samples);
		/* the log-densities under pi_0 = N(0, init_std^2 I), as drawn */
		cov[0] = cov[3] = e->init_std * e->init_std;
		logq = malloc((size_t)n0 * sizeof *logq);
		for (i = 0; i < n0; ++i)
			assert_int_equal(pr_policy_gauss_logpdf(2, mean, cov, ea->A + 2 * i, &logq[i], err), PR_OK);
		assert_int_equal(pr_exp3_learner_new(&c, e, v, s2, i2, l2, &B, err), PR_OK);
		assert_int_equal(pr_exp3_learner_seed(B, n0, ea->S, ea->A, ea->R, ea->F, ea->pocket, ea->hit,
		                                      logq, err), PR_OK);
		assert_int_equal(pr_exp3_learner_start(B, err), PR_OK); /* seeded: nothing to draw */
		run_iterations(A);
		run_iterations(B);
		assert_same(pr_exp3_learner_episodes(A), pr_exp3_learner_episodes(B));
		pr_exp3_learner_free(A);
		pr_exp3_learner_free(B);
		free(logq);
		gsl_rng_free(s1);
		gsl_rng_free(i1);
		gsl_rng_free(l1);
		gsl_rng_free(s2);
		gsl_rng_free(i2);
		gsl_rng_free(l2);
	}
}

/* An initial policy object equal to N(0, init_std^2 I) gives the default
 * learner's run; a second one, or one after iteration 0, is refused. */
static void test_initial_policy(void **state)
{
	pr_config c;
	char err[PR_ERRLEN];
	const pr_exp3_opts *e;
	pr_exp3_learner *A, *B;
	gsl_rng *r[6];
	double mean[2] = {0.0, 0.0}, cov[4] = {0.0, 0.0, 0.0, 0.0};
	const int *xdim;
	int nx, i;

	(void)state;
	small_config(&c);
	e = pr_exp3_opts_of(&c);
	for (i = 0; i < 6; ++i)
		r[i] = rng(20 + (unsigned long)i % 3);
	assert_int_equal(pr_exp3_learner_new(&c, e, PR_EXP3_NRVR_RS, r[0], r[1], r[2], &A, err), PR_OK);
	assert_int_equal(pr_exp3_learner_new(&c, e, PR_EXP3_NRVR_RS, r[3], r[4], r[5], &B, err), PR_OK);
	nx = pr_exp3_learner_state_dims(B, &xdim);
	assert_int_equal(nx, 2); /* the reward ball's box; the cue ball starts at a point */
	assert_int_equal(xdim[0], 2);
	cov[0] = cov[3] = e->init_std * e->init_std;
	assert_int_equal(pr_exp3_learner_set_policy(B, pr_policy_gaussian_new(nx, 2, mean, cov, err),
	                                            err), PR_OK);
	assert_int_not_equal(pr_exp3_learner_set_policy(B, pr_policy_gaussian_new(nx, 2, mean, cov, err),
	                                                err), PR_OK);
	assert_int_equal(pr_exp3_learner_start(A, err), PR_OK);
	assert_int_equal(pr_exp3_learner_start(B, err), PR_OK);
	run_iterations(A);
	run_iterations(B);
	assert_same(pr_exp3_learner_episodes(A), pr_exp3_learner_episodes(B));
	pr_exp3_learner_free(A);
	pr_exp3_learner_free(B);
	for (i = 0; i < 6; ++i)
		gsl_rng_free(r[i]);
}

/* The policy fitted directly to the first window of L (iteration 0's
 * episodes, learning coordinates, equal weights) with forest n_min, from a
 * fresh copy of the learn stream (seed). */
static pr_policy *direct_fit(const pr_config *c, const pr_exp3_learner *L, int n_min,
                             unsigned long seed)
{
	const pr_exp3_episodes *o = pr_exp3_learner_episodes(L);
	const int *xdim;
	int nx = pr_exp3_learner_state_dims(L, &xdim), n = pr_exp3_opts_of(c)->init_samples, i, j;
	double *X = malloc((size_t)n * nx * sizeof *X), *w = malloc((size_t)n * sizeof *w);
	pr_policy_opts po = c->policy;
	pr_policy_data d;
	gsl_rng *r = rng(seed);
	char err[PR_ERRLEN];
	pr_policy *p;

	assert_non_null(X);
	assert_non_null(w);
	for (i = 0; i < n; ++i) {
		for (j = 0; j < nx; ++j)
			X[(size_t)i * nx + j] = o->S[(size_t)i * o->ds + xdim[j]];
		w[i] = 1.0 / n; /* equal weights, normalised as REPS's and q are */
	}
	memset(&d, 0, sizeof d);
	d.n = n;
	d.ds = nx;
	d.da = 2;
	d.dy = 2;
	d.S = X;
	d.A = o->A;
	d.Y = o->F;
	d.w = w;
	po.target = PR_TARGET_ACTION;
	po.forest.n_min = n_min;
	p = pr_policy_tree_fit(&po, &d, r, err);
	assert_non_null(p);
	free(X);
	free(w);
	gsl_rng_free(r);
	return p;
}

/* a and b give the same mean and covariance, bit for bit, on a grid over
 * the reward ball's box, and their forests have as many leaves. */
static void assert_same_policy(const pr_policy *a, const pr_policy *b)
{
	double x[2], ma[2], mb[2], ca[4], cb[4];
	char err[PR_ERRLEN];
	int i, j;

	assert_int_equal(pr_forest_nleaves(pr_policy_forest(a)), pr_forest_nleaves(pr_policy_forest(b)));
	for (i = 0; i <= 10; ++i)
		for (j = 0; j <= 10; ++j) {
			x[0] = 0.05 + 0.01 * i;
			x[1] = -0.1 + 0.02 * j;
			assert_int_equal(pr_policy_eval(a, x, ma, ca, NULL, NULL, err), PR_OK);
			assert_int_equal(pr_policy_eval(b, x, mb, cb, NULL, NULL, err), PR_OK);
			assert_memory_equal(ma, mb, sizeof ma);
			assert_memory_equal(ca, cb, sizeof ca);
		}
}

/* Experiment 4's controls: the refit control's pi_1 (no REPS: the weights
 * q, all 1 when pi_0 drew the whole window) is the direct fit of that window
 * with equal weights, bit for bit, at policy.n_min or at the n_min the
 * control sets; the two n_min give different leaf counts. Refused after
 * iteration 1 and for the baseline. */
static void test_controls_refit_and_n_min(void **state)
{
	static const int n_mins[2] = {0, 4};
	pr_config c;
	char err[PR_ERRLEN];
	const pr_exp3_opts *e;
	int k, leaves[2];

	(void)state;
	small_config(&c);
	e = pr_exp3_opts_of(&c);
	for (k = 0; k < 2; ++k) {
		gsl_rng *s = rng(31), *i0 = rng(32), *l = rng(33);
		pr_exp3_learner *L;
		pr_policy *p;
		assert_int_equal(pr_exp3_learner_new(&c, e, PR_EXP3_NRVR_A, s, i0, l, &L, err), PR_OK);
		assert_int_equal(pr_exp3_learner_start(L, err), PR_OK);
		assert_int_equal(pr_exp3_learner_set_control(L, 1, n_mins[k], err), PR_OK);
		assert_int_equal(pr_exp3_learner_iterate(L, err), PR_OK);
		p = direct_fit(&c, L, n_mins[k] ? n_mins[k] : c.policy.forest.n_min, 33);
		assert_same_policy(pr_exp3_learner_policy(L), p);
		leaves[k] = pr_forest_nleaves(pr_policy_forest(p));
		/* no dual was solved: the row's ess is the importance weights' */
		assert_true(pr_exp3_learner_episodes(L)->it[0].eta == 0.0);
		assert_true(pr_exp3_learner_episodes(L)->it[0].ess == pr_exp3_learner_episodes(L)->it[0].q_ess);
		assert_int_not_equal(pr_exp3_learner_set_control(L, 0, 0, err), PR_OK);
		pr_policy_free(p);
		pr_exp3_learner_free(L);
		gsl_rng_free(s);
		gsl_rng_free(i0);
		gsl_rng_free(l);
	}
	assert_true(leaves[1] > leaves[0]);
	{
		gsl_rng *s = rng(1), *i0 = rng(2), *l = rng(3);
		pr_exp3_learner *L;
		assert_int_equal(pr_exp3_learner_new(&c, e, PR_EXP3_BASELINE, s, i0, l, &L, err), PR_OK);
		assert_int_not_equal(pr_exp3_learner_set_control(L, 0, 4, err), PR_OK);
		pr_exp3_learner_free(L);
		gsl_rng_free(s);
		gsl_rng_free(i0);
		gsl_rng_free(l);
	}
}

/* Iterations without REPS (Experiment 4's imitation reference): `samples`
 * new episodes of pi_0 each, numbered by their iteration; repeats and REPS
 * iterations are never mixed, and none runs before iteration 0 or past
 * exp3.iterations. */
static void test_repeat_draws_from_pi0(void **state)
{
	pr_config c;
	char err[PR_ERRLEN];
	const pr_exp3_opts *e;
	const pr_exp3_episodes *o;
	pr_exp3_learner *A, *B;
	gsl_rng *r[6];
	/* pi_0 = N(m, s^2 I) with a small s: every action within 6 s of m */
	const double m[2] = {0.3, -0.05}, s = 1e-3;
	double cov[4] = {s * s, 0.0, 0.0, s * s};
	int i, t;

	(void)state;
	small_config(&c);
	e = pr_exp3_opts_of(&c);
	for (i = 0; i < 6; ++i)
		r[i] = rng(40 + (unsigned long)i);
	assert_int_equal(pr_exp3_learner_new(&c, e, PR_EXP3_RVR_A, r[0], r[1], r[2], &A, err), PR_OK);
	assert_int_equal(pr_exp3_learner_set_policy(A, pr_policy_gaussian_new(2, 2, m, cov, err),
	                                            err), PR_OK);
	assert_int_not_equal(pr_exp3_learner_repeat(A, err), PR_OK); /* before iteration 0 */
	assert_int_equal(pr_exp3_learner_start(A, err), PR_OK);
	for (t = 0; t < ITERS; ++t)
		assert_int_equal(pr_exp3_learner_repeat(A, err), PR_OK);
	assert_int_not_equal(pr_exp3_learner_repeat(A, err), PR_OK);  /* past exp3.iterations */
	o = pr_exp3_learner_episodes(A);
	assert_int_equal(o->n, e->init_samples + ITERS * e->samples);
	assert_int_equal(o->niter, ITERS);
	for (i = 0; i < o->n; ++i) {
		assert_int_equal(o->iter[i], i < e->init_samples ? 0 : 1 + (i - e->init_samples) / e->samples);
		assert_true(fabs(o->A[2 * i] - m[0]) < 6 * s && fabs(o->A[2 * i + 1] - m[1]) < 6 * s);
	}
	/* a learner that ran a REPS iteration does not repeat, and vice versa */
	assert_int_equal(pr_exp3_learner_new(&c, e, PR_EXP3_RVR_A, r[3], r[4], r[5], &B, err), PR_OK);
	assert_int_equal(pr_exp3_learner_start(B, err), PR_OK);
	assert_int_equal(pr_exp3_learner_iterate(B, err), PR_OK);
	assert_int_not_equal(pr_exp3_learner_repeat(B, err), PR_OK);
	pr_exp3_learner_free(B);
	assert_int_equal(pr_exp3_learner_new(&c, e, PR_EXP3_RVR_A, r[3], r[4], r[5], &B, err), PR_OK);
	assert_int_equal(pr_exp3_learner_start(B, err), PR_OK);
	assert_int_equal(pr_exp3_learner_repeat(B, err), PR_OK);
	assert_int_not_equal(pr_exp3_learner_iterate(B, err), PR_OK);
	pr_exp3_learner_free(A);
	pr_exp3_learner_free(B);
	for (i = 0; i < 6; ++i)
		gsl_rng_free(r[i]);
}

/* Every registered experiment's defaults are valid keys and values, and
 * every block fits into a pr_config. */
/* log P(|a| <= V), a ~ N(mean, cov), by a midpoint rule on a polar grid of
 * the disc itself (the method of pr_learner_disc_logmass integrates over the
 * Gaussian's directions instead). */
static double disc_logmass_grid(const double m[2], const double c[4], double V)
{
	const int nr = 1500, nt = 1500;
	const double det = c[0] * c[3] - c[1] * c[2];
	double z = 0;
	int i, j;

	for (i = 0; i < nr; ++i) {
		double r = V * (i + 0.5) / nr;
		for (j = 0; j < nt; ++j) {
			double th = 2 * acos(-1.0) * (j + 0.5) / nt, dx = r * cos(th) - m[0], dy = r * sin(th) - m[1];
			double q = (c[3] * dx * dx - 2 * c[1] * dx * dy + c[0] * dy * dy) / det;
			z += exp(-0.5 * q) * r;
		}
	}
	return log(z * (V / nr) * (2 * acos(-1.0) / nt) / (2 * acos(-1.0) * sqrt(det)));
}

/* exp3.truncation = corrected: the Gaussian's mass inside the speed limit,
 * against the closed form of a centred isotropic Gaussian and a quadrature
 * over the disc, for means inside, on and outside the limit. */
static void test_disc_logmass(void **state)
{
	const double cases[][7] = {
		/* mean x, y, cov 00, 01, 11, V */
		{0.5, 0.2, 0.04, 0.01, 0.09, 1.0, 0},
		{0.9, 0.0, 0.01, 0.0, 0.01, 1.0, 0},
		{1.0, 0.3, 0.02, -0.012, 0.03, 1.0, 0},
		{1.3, -0.4, 0.05, 0.02, 0.02, 1.0, 0},
		{0.0, 0.0, 4.0, 1.0, 1.0, 2.0, 0},
	};
	double m[2] = {0, 0}, c[4] = {0.25, 0, 0, 0.25};
	size_t k;

	(void)state;
	/* centred, isotropic: P = 1 - exp(-V^2 / 2 sigma^2) */
	assert_true(fabs(pr_learner_disc_logmass(m, c, 1.0) - log(-expm1(-0.5 / 0.25))) < 1e-12);
	/* far inside: exactly 0 */
	c[0] = c[3] = 1e-4;
	m[0] = 0.3;
	assert_true(pr_learner_disc_logmass(m, c, 10.0) == 0);
	for (k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
		const double *q = cases[k];
		double mm[2] = {q[0], q[1]}, cc[4] = {q[2], q[3], q[3], q[4]};
		double got = pr_learner_disc_logmass(mm, cc, q[5]), ref = disc_logmass_grid(mm, cc, q[5]);
		print_message("disc mass case %zu: %.8f (grid %.8f)\n", k, got, ref);
		assert_true(fabs(got - ref) < 1e-4);
	}
}

static void test_registry_schema(void **state)
{
	pr_config c;
	pr_config_exp x;
	char err[PR_ERRLEN], set[64];
	int i;

	(void)state;
	for (i = 0; pr_exp_config(i, &x); ++i) {
		pr_config_init(&c, pr_exp_config);
		assert_int_equal(c.dropped, 0);
		snprintf(set, sizeof set, "experiment.name=%s", x.name);
		assert_int_equal(pr_config_set(&c, set, err), PR_OK);
		assert_int_equal(pr_config_validate(&c, err), PR_OK);
		assert_non_null(pr_exp_find(x.name));
		if (x.block)
			assert_non_null(pr_config_opts(&c, x.block));
	}
	assert_true(i >= 7);
	/* a schema without experiments: the modules' keys alone, and no name */
	pr_config_init(&c, NULL);
	assert_int_equal(pr_config_set(&c, "reps.epsilon=0.3", err), PR_OK);
	assert_int_equal(pr_config_set(&c, "exp3.window=10", err), PR_EINVAL);
	assert_int_equal(pr_config_set(&c, "experiment.name=exp3", err), PR_EINVAL);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_seeded_learner_continues_the_same),
		cmocka_unit_test(test_disc_logmass),
		cmocka_unit_test(test_initial_policy),
		cmocka_unit_test(test_repeat_draws_from_pi0),
		cmocka_unit_test(test_controls_refit_and_n_min),
		cmocka_unit_test(test_registry_schema),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
