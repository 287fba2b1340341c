/* test_learner.c — the ask/tell learner (learner.h): a saved learner goes
 * on with the same draws, a failed tell changes nothing, bad states are
 * refused, the first refit is ordinary least squares, and it learns a
 * contextual task. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_rng.h>

#include "poolreps/learner.h"
#include "poolreps/internal.h"

enum { DX = 2, DA = 2, B = 15 };

static gsl_rng *new_rng(unsigned long seed)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);

	gsl_rng_set(r, seed);
	return r;
}

/* The task: contexts uniform in [-1, 1]^2, return -|a - a*(s)|^2 with
 * a*(s) = (0.5 + s0 - s1, -0.3 + 0.8 s1). */
static void contexts(gsl_rng *r, double *X, int n)
{
	int i;

	for (i = 0; i < n * DX; ++i)
		X[i] = 2 * gsl_rng_uniform(r) - 1;
}

static double best(const double *s, int j)
{
	return j == 0 ? 0.5 + s[0] - s[1] : -0.3 + 0.8 * s[1];
}

static void returns(const double *X, const double *A, double *R, int n)
{
	int i, j;

	for (i = 0; i < n; ++i)
		for (R[i] = 0, j = 0; j < DA; ++j)
			R[i] -= pow(A[i * DA + j] - best(X + i * DX, j), 2);
}

/* One iteration: ask B actions at fresh contexts (from ctx), tell them. */
static void step(pr_learner *L, gsl_rng *ctx, double *A)
{
	double X[B * DX], R[B];
	char err[PR_ERRLEN];

	contexts(ctx, X, B);
	assert_int_equal(pr_learner_ask(L, B, X, A, err), PR_OK);
	returns(X, A, R, B);
	assert_int_equal(pr_learner_tell(L, B, X, A, R, NULL, 0, err), PR_OK);
}

/* The defaults with the learner's value and policy kinds, which every test
 * names. */
static void opts_of(pr_learner_opts *o, int value, int policy)
{
	pr_learner_opts_init(o);
	o->value = value;
	o->policy_type = policy;
}

static pr_learner *small(int value, int policy, gsl_rng *r)
{
	pr_learner_opts o;
	char err[PR_ERRLEN];
	pr_learner *L;

	opts_of(&o, value, policy);
	o.window = 45;
	o.init_std = 1.0;
	o.value_forest.n_min = 10;
	o.policy.forest.n_min = 15;
	L = pr_learner_new(&o, DX, DA, r, err);
	assert_non_null(L);
	return L;
}

/* A learner saved with an ask pending, loaded onto another stream, goes on
 * with the same draws and the same state, for each kind of learner. */
static void test_save_load_continues(void **state)
{
	const int kinds[][2] = {{PR_LEARNER_VALUE_NRVR, PR_LEARNER_POLICY_TREE},
	                        {PR_LEARNER_VALUE_LINEAR, PR_LEARNER_POLICY_LINEAR},
	                        {PR_LEARNER_VALUE_QUADRATIC, PR_LEARNER_POLICY_TREE}};
	int k;

	(void)state;
	for (k = 0; k < 3; ++k) {
		gsl_rng *r1 = new_rng(5), *r2 = new_rng(999), *c1 = new_rng(7), *c2;
		pr_learner *L1 = small(kinds[k][0], kinds[k][1], r1), *L2;
		double A1[B * DA], A2[B * DA], X[B * DX], R[B];
		unsigned char *s1, *s2;
		size_t n1, n2;
		char err[PR_ERRLEN];
		int t;

		for (t = 0; t < 4; ++t)
			step(L1, c1, A1);
		contexts(c1, X, B);
		assert_int_equal(pr_learner_ask(L1, B, X, A1, err), PR_OK);
		assert_int_equal(pr_learner_save(L1, &s1, &n1, err), PR_OK);
		L2 = pr_learner_load(s1, n1, "state", r2, err);
		if (!L2)
			print_message("%s\n", err);
		assert_non_null(L2);
		assert_int_equal(pr_learner_iteration(L2), 4);
		returns(X, A1, R, B);
		assert_int_equal(pr_learner_tell(L1, B, X, A1, R, NULL, 0, err), PR_OK);
		assert_int_equal(pr_learner_tell(L2, B, X, A1, R, NULL, 0, err), PR_OK);
		c2 = gsl_rng_clone(c1);
		for (t = 0; t < 3; ++t) {
			step(L1, c1, A1);
			step(L2, c2, A2);
			assert_memory_equal(A1, A2, sizeof A1);
		}
		free(s1);
		assert_int_equal(pr_learner_save(L1, &s1, &n1, err), PR_OK);
		assert_int_equal(pr_learner_save(L2, &s2, &n2, err), PR_OK);
		assert_int_equal(n1, n2);
		assert_memory_equal(s1, s2, n1);
		free(s1);
		free(s2);
		pr_learner_free(L1);
		pr_learner_free(L2);
		gsl_rng_free(r1);
		gsl_rng_free(r2);
		gsl_rng_free(c1);
		gsl_rng_free(c2);
	}
}

/* Bad told data are refused with the argument and row named, and the
 * learner's state (stream included) is as before. */
static void test_failed_tell_changes_nothing(void **state)
{
	gsl_rng *r = new_rng(3), *c = new_rng(4);
	pr_learner *L = small(PR_LEARNER_VALUE_RVR, PR_LEARNER_POLICY_TREE, r);
	double A[B * DA], X[B * DX], R[B], G[B];
	unsigned char *s0, *s1;
	size_t n0, n1;
	char err[PR_ERRLEN];
	int t;

	(void)state;
	for (t = 0; t < 3; ++t)
		step(L, c, A);
	contexts(c, X, B);
	assert_int_equal(pr_learner_ask(L, B, X, A, err), PR_OK);
	returns(X, A, R, B);
	assert_int_equal(pr_learner_save(L, &s0, &n0, err), PR_OK);
	R[3] = NAN;
	assert_int_equal(pr_learner_tell(L, B, X, A, R, NULL, 0, err), PR_EINVAL);
	assert_non_null(strstr(err, "returns: row 3"));
	R[3] = 0;
	X[2 * DX + 1] = INFINITY;
	assert_int_equal(pr_learner_tell(L, B, X, A, R, NULL, 0, err), PR_EINVAL);
	assert_non_null(strstr(err, "contexts: row 2, column 1"));
	X[2 * DX + 1] = 0;
	memset(G, 0, sizeof G);
	assert_int_equal(pr_learner_tell(L, B, X, A, R, G, 1, err), PR_EINVAL);
	assert_int_equal(pr_learner_tell(L, 0, X, A, R, NULL, 0, err), PR_EINVAL);
	/* a forest that cannot be grown: n_c above the window fails inside tell */
	{
		pr_learner_opts o = *pr_learner_options(L);
		o.value_forest.n_c = o.value_forest.n_min = 1000;
		assert_int_not_equal(pr_learner_set_options(L, &o, err), PR_OK); /* after the first tell */
	}
	assert_int_equal(pr_learner_save(L, &s1, &n1, err), PR_OK);
	assert_int_equal(n0, n1);
	assert_memory_equal(s0, s1, n0);
	free(s0);
	free(s1);
	pr_learner_free(L);
	gsl_rng_free(r);
	gsl_rng_free(c);
}

/* Every truncation of a state, another version, another generator and
 * trailing bytes are refused. */
static void test_load_refuses(void **state)
{
	gsl_rng *r = new_rng(3), *c = new_rng(4), *o = new_rng(1);
	gsl_rng *other = gsl_rng_alloc(gsl_rng_ranlxd2);
	pr_learner *L = small(PR_LEARNER_VALUE_LINEAR, PR_LEARNER_POLICY_LINEAR, r), *M;
	double A[B * DA];
	unsigned char *s, *big;
	size_t n, k;
	char err[PR_ERRLEN];

	(void)state;
	step(L, c, A);
	step(L, c, A);
	assert_int_equal(pr_learner_save(L, &s, &n, err), PR_OK);
	for (k = 0; k < n; k += 1 + k / 50) {
		assert_null(pr_learner_load(s, k, "f", o, err));
		assert_non_null(strstr(err, "f: "));
	}
	s[17] ^= 2; /* the version */
	assert_null(pr_learner_load(s, n, "f", o, err));
	assert_non_null(strstr(err, "version"));
	s[17] ^= 2;
	s[0] = 'x';
	assert_null(pr_learner_load(s, n, "f", o, err));
	assert_non_null(strstr(err, "not a poolreps learner"));
	s[0] = 'p';
	assert_null(pr_learner_load(s, n, "f", other, err));
	assert_non_null(strstr(err, "generator"));
	big = malloc(n + 1);
	memcpy(big, s, n);
	big[n] = 0;
	assert_null(pr_learner_load(big, n + 1, "f", o, err));
	M = pr_learner_load(s, n, "f", o, err);
	assert_non_null(M);
	pr_learner_free(M);
	free(big);
	free(s);
	pr_learner_free(L);
	gsl_rng_free(r);
	gsl_rng_free(c);
	gsl_rng_free(o);
	gsl_rng_free(other);
}

/* The first tell with refit: p = q is uniform (one drawing policy), so the
 * linear policy's mean is the ordinary least-squares line, computed here
 * from the normal equations of one context and one action dimension. */
static void test_first_refit_is_least_squares(void **state)
{
	enum { N = 30 };
	gsl_rng *r = new_rng(11);
	pr_learner_opts o;
	pr_learner *L;
	double X[N], A[N], R[N], m, sx = 0, sa = 0, sxx = 0, sxa = 0, slope, icpt;
	char err[PR_ERRLEN];
	int i;

	(void)state;
	opts_of(&o, PR_LEARNER_VALUE_LINEAR, PR_LEARNER_POLICY_LINEAR);
	o.refit = 1;
	o.policy.lambda = 0;
	L = pr_learner_new(&o, 1, 1, r, err);
	assert_non_null(L);
	for (i = 0; i < N; ++i) {
		X[i] = 100 + 3 * gsl_rng_uniform(r);
		R[i] = gsl_rng_uniform(r);
	}
	assert_int_equal(pr_learner_ask(L, N, X, A, err), PR_OK);
	assert_int_equal(pr_learner_tell(L, N, X, A, R, NULL, 0, err), PR_OK);
	for (i = 0; i < N; ++i) {
		sx += X[i];
		sa += A[i];
	}
	for (i = 0; i < N; ++i) {
		sxx += (X[i] - sx / N) * (X[i] - sx / N);
		sxa += (X[i] - sx / N) * (A[i] - sa / N);
	}
	slope = sxa / sxx;
	icpt = sa / N - slope * sx / N;
	for (i = 0; i < 5; ++i) {
		double s = 99 + i;
		assert_int_equal(pr_learner_mean(L, 1, &s, &m, err), PR_OK);
		assert_true(fabs(m - (icpt + slope * s)) < 1e-9 * (1 + fabs(m)));
	}
	assert_int_equal(pr_learner_last(L)->iteration, 1);
	assert_true(fabs(pr_learner_last(L)->q_ess - N) < 1e-9);
	pr_learner_free(L);
	gsl_rng_free(r);
}

/* On the contextual linear task the mean action comes at least 5x closer
 * to the optimum within 60 iterations of 15 episodes, for tree and linear
 * value features. */
static void test_learns(void **state)
{
	const int value[2] = {PR_LEARNER_VALUE_NRVR, PR_LEARNER_VALUE_LINEAR};
	int k;

	(void)state;
	for (k = 0; k < 2; ++k) {
		gsl_rng *r = new_rng(21), *c = new_rng(22), *e = new_rng(23);
		pr_learner *L = small(value[k], PR_LEARNER_POLICY_LINEAR, r);
		double A[B * DA], X[100 * DX], M[100 * DA], R[100], d0 = 0, d1 = 0;
		char err[PR_ERRLEN];
		int t, i;

		contexts(e, X, 100);
		assert_int_equal(pr_learner_mean(L, 100, X, M, err), PR_OK);
		returns(X, M, R, 100);
		for (i = 0; i < 100; ++i)
			d0 -= R[i];
		for (t = 0; t < 60; ++t)
			step(L, c, A);
		assert_int_equal(pr_learner_mean(L, 100, X, M, err), PR_OK);
		returns(X, M, R, 100);
		for (i = 0; i < 100; ++i)
			d1 -= R[i];
		print_message("value %d: mean squared distance %.4f -> %.4f\n", value[k], d0 / 100, d1 / 100);
		assert_true(d1 * 5 < d0);
		pr_learner_free(L);
		gsl_rng_free(r);
		gsl_rng_free(c);
		gsl_rng_free(e);
	}
}

/* window 0: each tell's episodes alone, with uniform base weights; window
 * 1 is refused. Column names default to s0 .., a0 .., and a repeated name
 * is refused without touching them. */
static void test_window_zero_and_names(void **state)
{
	const char *dup[DX + DA] = {"x", "y", "a", "x"};
	const char *const *nm;
	gsl_rng *r = new_rng(31), *c = new_rng(32);
	pr_learner_opts o;
	pr_learner *L;
	double A[B * DA];
	char err[PR_ERRLEN];
	int t;

	(void)state;
	opts_of(&o, PR_LEARNER_VALUE_LINEAR, PR_LEARNER_POLICY_LINEAR);
	o.window = 1;
	assert_null(pr_learner_new(&o, DX, DA, r, err));
	assert_non_null(strstr(err, "learner.window"));
	o.window = 0;
	L = pr_learner_new(&o, DX, DA, r, err);
	assert_non_null(L);
	for (t = 0; t < 3; ++t) {
		step(L, c, A);
		assert_int_equal(pr_learner_last(L)->n, B);
		assert_true(fabs(pr_learner_last(L)->q_ess - B) < 1e-9);
	}
	nm = pr_learner_names(L);
	assert_string_equal(nm[0], "s0");
	assert_string_equal(nm[1], "s1");
	assert_string_equal(nm[2], "a0");
	assert_string_equal(nm[3], "a1");
	assert_int_equal(pr_learner_set_names(L, dup, err), PR_EINVAL);
	assert_non_null(strstr(err, "action name 1 'x' is also context name 0"));
	assert_string_equal(pr_learner_names(L)[3], "a1");
	pr_learner_free(L);
	gsl_rng_free(r);
	gsl_rng_free(c);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_save_load_continues),
		cmocka_unit_test(test_failed_tell_changes_nothing),
		cmocka_unit_test(test_load_refuses),
		cmocka_unit_test(test_first_refit_is_least_squares),
		cmocka_unit_test(test_learns),
		cmocka_unit_test(test_window_zero_and_names),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
