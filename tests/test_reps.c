/* test_reps.c — REPS dual, solve, checks and importance weights. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include <unistd.h>

#include "poolreps/bench.h"
#include "poolreps/exp.h"
#include "exp_priv.h"
#include "poolreps/csvio.h"
#include "poolreps/reps.h"
#include "test_util.h"

#define N 60
#define D 3

/* A fixed random problem: returns depend on a context feature plus noise. */
static void make_problem(unsigned long seed, double *R, double *q, double *phi)
{
	gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
	int i;

	gsl_rng_set(rng, seed);
	for (i = 0; i < N; i++) {
		double s = gsl_rng_uniform(rng) * 2.0 - 1.0;

		phi[i * D + 0] = s;
		phi[i * D + 1] = s * s;
		phi[i * D + 2] = gsl_rng_uniform(rng);
		R[i] = -2.0 * s * s + s + gsl_ran_gaussian(rng, 0.5);
		if (q)
			q[i] = 0.2 + gsl_rng_uniform(rng);
	}
	gsl_rng_free(rng);
}

static void test_gradient_fd(void **state)
{
	double R[N], q[N], phi[N * D], x[D + 1], g[D + 1], xp[D + 1];
	pr_reps_problem pb = { N, D, R, q, phi, NULL, NULL, NULL };
	double ridges[2] = { 0.0, 0.3 };
	int k, j;

	(void)state;
	make_problem(3, R, q, phi);
	x[0] = log(0.7);
	x[1] = 0.3;
	x[2] = -1.1;
	x[3] = 0.5;
	for (k = 0; k < 2; k++) {
		pr_reps_dual(&pb, 0.5, ridges[k], x, g);
		for (j = 0; j <= D; j++) {
			double h = 1e-5, fp, fm, fd;

			memcpy(xp, x, sizeof x);
			xp[j] += h;
			fp = pr_reps_dual(&pb, 0.5, ridges[k], xp, NULL);
			xp[j] -= 2 * h;
			fm = pr_reps_dual(&pb, 0.5, ridges[k], xp, NULL);
			fd = (fp - fm) / (2 * h);
			assert_near(fd, g[j], 1e-7 * (1.0 + fabs(g[j])));
		}
	}
}

/* Sparse one-hot features (3 "leaves" per sample) against their dense form. */
static void test_sparse_equals_dense(void **state)
{
	enum { NL = 12 };
	double R[N], phi[N * D], dense[N * NL], x[NL + 1], gd[NL + 1], gs[NL + 1];
	int rowptr[N + 1], col[3 * N], i, j;
	pr_reps_problem pd = { N, NL, R, NULL, dense, NULL, NULL, NULL };
	pr_reps_problem ps = { N, NL, R, NULL, NULL, rowptr, col, NULL };
	double fdn, fsp;

	(void)state;
	make_problem(4, R, NULL, phi);
	memset(dense, 0, sizeof dense);
	rowptr[0] = 0;
	for (i = 0; i < N; i++) {
		for (j = 0; j < 3; j++) {
			double u = j == 0 ? 0.5 * (phi[i * D] + 1.0) : phi[i * D + j];
			int leaf = 4 * j + (int)(u * 3.999);

			col[3 * i + j] = leaf;
			dense[i * NL + leaf] = 1.0;
		}
		rowptr[i + 1] = 3 * (i + 1);
	}
	for (j = 0; j <= NL; j++)
		x[j] = 0.1 * j - 0.4;
	fdn = pr_reps_dual(&pd, 0.8, 0.0, x, gd);
	fsp = pr_reps_dual(&ps, 0.8, 0.0, x, gs);
	assert_near(fdn, fsp, 1e-12 * fabs(fdn));
	for (j = 0; j <= NL; j++)
		assert_near(gd[j], gs[j], 1e-12);
}

static double kl_of(const double *p, const double *q, int n)
{
	double sq = 0.0, kl = 0.0;
	int i;

	for (i = 0; i < n; i++)
		sq += q ? q[i] : 1.0;
	for (i = 0; i < n; i++)
		if (p[i] > 0.0)
			kl += p[i] * log(p[i] / ((q ? q[i] : 1.0) / sq));
	return kl;
}

static void test_kl_active(void **state)
{
	double R[N], q[N], phi[N * D];
	double eps[4] = { 0.05, 0.5, 1.0, 2.0 };
	pr_reps_problem pb = { N, D, R, q, phi, NULL, NULL, NULL };
	pr_reps_opts o;
	char err[PR_ERRLEN];
	int k;

	(void)state;
	make_problem(5, R, q, phi);
	pr_reps_opts_init(&o);
	for (k = 0; k < 4; k++) {
		pr_reps_result *r = NULL;
		double sum = 0.0;
		int i;

		o.epsilon = eps[k];
		assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_OK);
		assert_int_equal(r->bound, 1);
		assert_near(r->kl, eps[k], 1e-6);
		/* independent KL from the weights themselves */
		assert_near(kl_of(r->p, q, N), eps[k], 1e-6);
		assert_true(r->residual <= 1e-10);
		for (i = 0; i < N; i++)
			sum += r->p[i];
		assert_near(sum, 1.0, 1e-12);
		assert_true(r->ess > 1.0 && r->ess < N);
		pr_reps_result_free(r);
	}
}

/* Strong duality. For any (eta, theta), with p the weights of eq. 3.7,
 *   g = sum p_i R_i + eta (eps - KL) + theta^T (phi_hat - sum p_i phi_i),
 * so at the optimum (KL = eps, matched features) g = sum p_i R_i. */
static void test_strong_duality(void **state)
{
	double R[N], q[N], phi[N * D];
	pr_reps_problem pb = { N, D, R, q, phi, NULL, NULL, NULL };
	pr_reps_opts o;
	pr_reps_result *r = NULL;
	char err[PR_ERRLEN];
	double pr = 0.0, phihat[D] = { 0 }, ep[D] = { 0 }, sq = 0.0, corr = 0.0;
	int i, j;

	(void)state;
	make_problem(6, R, q, phi);
	pr_reps_opts_init(&o);
	o.epsilon = 0.7;
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_OK);
	for (i = 0; i < N; i++)
		sq += q[i];
	for (i = 0; i < N; i++) {
		pr += r->p[i] * R[i];
		for (j = 0; j < D; j++) {
			phihat[j] += q[i] / sq * phi[i * D + j];
			ep[j] += r->p[i] * phi[i * D + j];
		}
	}
	for (j = 0; j < D; j++)
		corr += r->theta[j] * (phihat[j] - ep[j]);
	/* the identity, to rounding */
	assert_near(r->dual, (pr + r->eta * (o.epsilon - r->kl) + corr), 1e-9);
	/* duality gap at the optimum */
	assert_near(r->dual, pr, 1e-10);
	pr_reps_result_free(r);
}

static void test_affine_invariance(void **state)
{
	double R[N], q[N], phi[N * D], R2[N];
	double scale[4] = { 1e-6, 1e8, 1.0, 3.0 };
	double shift[4] = { 0.0, 0.0, 1e6, -7.0 };
	pr_reps_problem pb = { N, D, R, q, phi, NULL, NULL, NULL };
	pr_reps_opts o;
	pr_reps_result *ref = NULL;
	char err[PR_ERRLEN];
	int k, i, j;

	(void)state;
	make_problem(7, R, q, phi);
	pr_reps_opts_init(&o);
	assert_int_equal(pr_reps_solve(&o, &pb, &ref, err), PR_OK);
	for (k = 0; k < 4; k++) {
		pr_reps_problem p2 = pb;
		pr_reps_result *r = NULL;

		for (i = 0; i < N; i++)
			R2[i] = scale[k] * R[i] + shift[k];
		p2.R = R2;
		assert_int_equal(pr_reps_solve(&o, &p2, &r, err), PR_OK);
		assert_int_equal(r->bound, 1);
		for (i = 0; i < N; i++)
			assert_near(r->p[i], ref->p[i], 1e-9 * ref->p[i]);
		/* eta and theta scale with the returns, the dual is affine */
		assert_near(r->eta, scale[k] * ref->eta, 1e-9 * scale[k] * ref->eta);
		for (j = 0; j < D; j++)
			assert_near(r->theta[j], scale[k] * ref->theta[j], 1e-9 * scale[k] * (fabs(ref->theta[j]) + ref->eta));
		assert_near(r->dual, (scale[k] * ref->dual + shift[k]), 1e-8 * (fabs(shift[k]) + scale[k] * (fabs(ref->dual) + 1.0)));
		pr_reps_result_free(r);
	}
	pr_reps_result_free(ref);
}

static void test_constant_returns(void **state)
{
	double R[N], q[N], phi[N * D];
	pr_reps_problem pb = { N, D, R, NULL, phi, NULL, NULL, NULL };
	pr_reps_opts o;
	pr_reps_result *r = NULL;
	char err[PR_ERRLEN];
	double sq = 0.0;
	int i;

	(void)state;
	make_problem(8, R, q, phi);
	for (i = 0; i < N; i++) {
		R[i] = -0.3;
		sq += q[i];
	}
	pr_reps_opts_init(&o);
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_OK);
	assert_int_equal(r->constant, 1);
	assert_int_equal(r->bound, 0);
	for (i = 0; i < N; i++)
		assert_near(r->p[i], 1.0 / N, 1e-13);
	assert_near(r->ess, N, 1e-9);
	assert_near(r->dual, -0.3, 1e-15);
	pr_reps_result_free(r);
	/* with base weights: p = q normalised */
	pb.q = q;
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_OK);
	for (i = 0; i < N; i++)
		assert_near(r->p[i], q[i] / sq, 1e-15);
	pr_reps_result_free(r);
}

/* Without features the optimum is the eta with KL(eta) = eps: find it by
 * bisection here, independently of the library. */
static void test_no_features_known_answer(void **state)
{
	double R[N], phi[N * D], p[N], lo = 1e-6, hi = 1e6;
	pr_reps_problem pb = { N, 0, R, NULL, NULL, NULL, NULL, NULL };
	pr_reps_opts o;
	pr_reps_result *r = NULL;
	char err[PR_ERRLEN];
	int it, i;

	(void)state;
	make_problem(9, R, NULL, phi);
	pr_reps_opts_init(&o);
	o.epsilon = 0.4;
	for (it = 0; it < 200; it++) {
		double eta = sqrt(lo * hi), mx = -HUGE_VAL, z = 0.0;

		for (i = 0; i < N; i++)
			mx = fmax(mx, R[i]);
		for (i = 0; i < N; i++)
			z += p[i] = exp((R[i] - mx) / eta);
		for (i = 0; i < N; i++)
			p[i] /= z;
		if (kl_of(p, NULL, N) > o.epsilon)
			lo = eta;
		else
			hi = eta;
	}
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_OK);
	assert_int_equal(r->bound, 1);
	assert_near(r->eta, lo, 1e-7 * lo);
	for (i = 0; i < N; i++)
		assert_near(r->p[i], p[i], 1e-7 * p[i] + 1e-15);
	pr_reps_result_free(r);
}

/* One leaf per sample: the feature constraint pins p = q, so KL can never
 * reach eps: unreachable, eta = 0, p = q. With a ridge the constraint is
 * relaxed and there is no eta -> 0 limit to certify: a failed certificate,
 * said so in `reason`, never a silent answer. */
static void test_rich_features_inactive(void **state)
{
	double R[N], phi[N * D];
	int rowptr[N + 1], col[N], i;
	pr_reps_problem pb = { N, N, R, NULL, NULL, rowptr, col, NULL };
	pr_reps_opts o;
	pr_reps_result *r = NULL;
	char err[PR_ERRLEN];

	(void)state;
	make_problem(10, R, NULL, phi);
	for (i = 0; i < N; i++) {
		rowptr[i] = i;
		col[i] = i;
	}
	rowptr[N] = N;
	pr_reps_opts_init(&o);
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_OK);
	assert_int_equal(r->status, PR_REPS_UNREACHABLE);
	assert_int_equal(r->bound, 0);
	assert_true(r->kl < o.epsilon && r->eta == 0.0);
	/* the leaf masses are matched exactly: p = q */
	for (i = 0; i < N; i++)
		assert_near(r->p[i], 1.0 / N, 1e-13);
	assert_true(r->residual <= 1e-13 && isfinite(r->dual));
	pr_reps_result_free(r);
	o.ridge = 1e-3;
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_OK);
	assert_int_equal(r->status, PR_REPS_FAILED);
	assert_int_equal(r->bound, 0);
	assert_non_null(strstr(r->reason, "ridge"));
	assert_string_equal(pr_reps_status_name(r->status), "failed");
	pr_reps_result_free(r);
}

/* One-hot leaves of `trees` random partitions of n states in [0,1]^2 with
 * continuous thresholds (each tree splits its largest cell at a uniform
 * threshold until it has `leaves` cells), in CSR form with one entry per
 * tree: the block layout of a forest's active leaves. Returns d. */
static int forest_features(gsl_rng *rng, int n, int trees, int leaves, const double *S,
                           int *rowptr, int *col)
{
	int *cell = malloc((size_t)n * sizeof *cell), *cnt = malloc((size_t)leaves * sizeof *cnt);
	int t, i, k, d = 0;

	for (i = 0; i <= n; i++)
		rowptr[i] = i * trees;
	for (t = 0; t < trees; t++) {
		for (i = 0; i < n; i++)
			cell[i] = 0;
		for (k = 1; k < leaves; k++) {
			int big = 0, dim = (int)gsl_rng_uniform_int(rng, 2), c;
			double lo = HUGE_VAL, hi = -HUGE_VAL, thr;

			for (c = 0; c < k; c++)
				cnt[c] = 0;
			for (i = 0; i < n; i++)
				cnt[cell[i]]++;
			for (c = 1; c < k; c++)
				if (cnt[c] > cnt[big])
					big = c;
			for (i = 0; i < n; i++)
				if (cell[i] == big) {
					lo = fmin(lo, S[2 * i + dim]);
					hi = fmax(hi, S[2 * i + dim]);
				}
			thr = lo + gsl_rng_uniform(rng) * (hi - lo);
			for (i = 0; i < n; i++)
				if (cell[i] == big && S[2 * i + dim] > thr)
					cell[i] = k;
		}
		for (i = 0; i < n; i++)
			col[i * trees + t] = d + cell[i];
		d += leaves;
	}
	free(cell);
	free(cnt);
	return d;
}

static double sum_pr(const pr_reps_result *r, const double *R)
{
	double s = 0.0;
	int i;

	for (i = 0; i < r->n; i++)
		s += r->p[i] * R[i];
	return s;
}

/* The certificate's invariants, whatever the status. */
static void assert_certified(const pr_reps_result *r, double eps)
{
	double s = 0.0;
	int i;

	for (i = 0; i < r->n; i++) {
		assert_true(r->p[i] >= 0.0);
		s += r->p[i];
	}
	assert_near(s, 1.0, 1e-13);
	assert_true(r->residual_rel <= PR_REPS_TOL);
	assert_near(r->kl_gap, fabs(r->kl - eps), 1e-15);
	if (r->status == PR_REPS_ACTIVE) {
		assert_int_equal(r->bound, 1);
		assert_true(r->kl_gap <= PR_REPS_TOL && r->eta > 0.0);
	} else {
		assert_int_equal(r->status, PR_REPS_UNREACHABLE);
		assert_int_equal(r->bound, 0);
		assert_true(r->eta == 0.0 && r->kl < eps);
	}
}

/* The regimes that used to be silently wrong: 200 samples, 30 trees of 8
 * leaves (rank about 170): the feature-matching limit has KL < 0.5, so the
 * bound is unreachable, p must match the features (it used to miss them by
 * 0.3); with a smaller eps the bound is met. */
static void test_rich_forest_unreachable(void **state)
{
	enum { NS = 200, T = 30, L = 8 };
	double R[NS], S[2 * NS], pr_u, pr_a;
	int rowptr[NS + 1], col[NS * T], i, d;
	gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
	pr_reps_problem pb = { NS, 0, R, NULL, NULL, rowptr, col, NULL };
	pr_reps_opts o;
	pr_reps_result *r = NULL, *a = NULL;
	char err[PR_ERRLEN];

	(void)state;
	gsl_rng_set(rng, 1);
	for (i = 0; i < NS; i++) {
		S[2 * i] = gsl_rng_uniform(rng);
		S[2 * i + 1] = gsl_rng_uniform(rng);
		R[i] = -fabs(S[2 * i] - 0.5) + gsl_ran_gaussian(rng, 0.3);
	}
	d = forest_features(rng, NS, T, L, S, rowptr, col);
	pb.d = d;
	pr_reps_opts_init(&o);
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_OK);
	assert_int_equal(r->status, PR_REPS_UNREACHABLE);
	assert_certified(r, o.epsilon);
	/* the limit is the most rewarding matched p: a feasible p with a KL
	 * bound just below it earns no more */
	o.epsilon = 0.5 * r->kl;
	assert_int_equal(pr_reps_solve(&o, &pb, &a, err), PR_OK);
	assert_int_equal(a->status, PR_REPS_ACTIVE);
	assert_certified(a, o.epsilon);
	pr_u = sum_pr(r, R);
	pr_a = sum_pr(a, R);
	assert_true(pr_a <= pr_u + 1e-12);
	/* and the dual's value at eta = 0 is the limit's sum p R */
	assert_near(r->dual, pr_u, 1e-12);
	pr_reps_result_free(r);
	pr_reps_result_free(a);
	gsl_rng_free(rng);
}

/* d = 25 generic features, n = 20: the only matched p is q. d = 3 with eps
 * beyond the reachable KL: unreachable, and no other matched p with KL <=
 * eps earns more (checked against a slightly tighter active solve). */
static void test_generic_unreachable(void **state)
{
	enum { NW = 20, DW = 25 };
	double R[NW], phi[NW * DW], q[NW], R3[N], q3[N], phi3[N * D];
	pr_reps_problem pb = { NW, DW, R, q, phi, NULL, NULL, NULL };
	pr_reps_problem p3 = { N, D, R3, q3, phi3, NULL, NULL, NULL };
	gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
	pr_reps_opts o;
	pr_reps_result *r = NULL, *a = NULL;
	char err[PR_ERRLEN];
	double sq = 0.0;
	int i;

	(void)state;
	gsl_rng_set(rng, 2);
	for (i = 0; i < NW * DW; i++)
		phi[i] = gsl_ran_gaussian(rng, 1.0);
	for (i = 0; i < NW; i++) {
		R[i] = gsl_ran_gaussian(rng, 1.0);
		sq += q[i] = 0.5 + gsl_rng_uniform(rng);
	}
	pr_reps_opts_init(&o);
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_OK);
	assert_int_equal(r->status, PR_REPS_UNREACHABLE);
	assert_certified(r, o.epsilon);
	for (i = 0; i < NW; i++)
		assert_near(r->p[i], q[i] / sq, 1e-13);
	pr_reps_result_free(r);
	make_problem(13, R3, q3, phi3);
	o.epsilon = 5.0;
	assert_int_equal(pr_reps_solve(&o, &p3, &r, err), PR_OK);
	assert_int_equal(r->status, PR_REPS_UNREACHABLE);
	assert_certified(r, o.epsilon);
	o.epsilon = r->kl * (1.0 - 1e-6);
	assert_int_equal(pr_reps_solve(&o, &p3, &a, err), PR_OK);
	assert_int_equal(a->status, PR_REPS_ACTIVE);
	assert_true(sum_pr(a, R3) <= sum_pr(r, R3) + 1e-12);
	/* close to the limit, the active answer is close to it too */
	for (i = 0; i < N; i++)
		assert_near(a->p[i], r->p[i], 1e-3);
	pr_reps_result_free(r);
	pr_reps_result_free(a);
	gsl_rng_free(rng);
}

/* Returns of spread 1e-161 (their squares underflow) and of magnitude 1e154
 * (theirs overflow) solve like returns of order 1: REPS is invariant to
 * R -> a R + b, and so is the standardisation. */
static void test_extreme_scales(void **state)
{
	double R[N], q[N], phi[N * D], R2[N], scales[4] = { 1e-161, 1e154, 1e-300, 1e300 };
	pr_reps_problem pb = { N, D, R, q, phi, NULL, NULL, NULL };
	pr_reps_opts o;
	pr_reps_result *ref = NULL;
	char err[PR_ERRLEN];
	int k, i;

	(void)state;
	make_problem(14, R, q, phi);
	pr_reps_opts_init(&o);
	assert_int_equal(pr_reps_solve(&o, &pb, &ref, err), PR_OK);
	assert_int_equal(ref->status, PR_REPS_ACTIVE);
	for (k = 0; k < 4; k++) {
		pr_reps_problem p2 = pb;
		pr_reps_result *r = NULL;

		for (i = 0; i < N; i++)
			R2[i] = scales[k] * R[i];
		p2.R = R2;
		assert_int_equal(pr_reps_solve(&o, &p2, &r, err), PR_OK);
		assert_int_equal(r->status, PR_REPS_ACTIVE);
		assert_certified(r, o.epsilon);
		for (i = 0; i < N; i++)
			assert_near(r->p[i], ref->p[i], 1e-12);
		assert_near(r->eta / scales[k], ref->eta, 1e-12 * ref->eta);
		pr_reps_result_free(r);
	}
	pr_reps_result_free(ref);
}

/* A leaf holding one sample of base weight 1e-11 pins its weight to that
 * mass; the eta -> 0 limit must keep it (not round it to 0). */
static void test_pinned_tiny_mass(void **state)
{
	enum { NS = 60, T = 4 };
	double R[NS], S[2 * NS], q[NS], sq = 0.0;
	int rowptr[NS + 1], col[NS * T], i;
	gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
	pr_reps_problem pb = { NS, 0, R, q, NULL, rowptr, col, NULL };
	pr_reps_opts o;
	pr_reps_result *r = NULL;
	char err[PR_ERRLEN];

	(void)state;
	gsl_rng_set(rng, 3);
	for (i = 0; i < NS; i++) {
		S[2 * i] = gsl_rng_uniform(rng);
		S[2 * i + 1] = gsl_rng_uniform(rng);
		R[i] = S[2 * i] + gsl_ran_gaussian(rng, 0.1);
		q[i] = i == 0 ? 1e-11 : 0.5 + gsl_rng_uniform(rng);
		sq += q[i];
	}
	pb.d = forest_features(rng, NS, T, 6, S, rowptr, col);
	/* sample 0 alone in a leaf of its own (tree 0) */
	for (i = 0; i < NS; i++)
		if (col[i * T] == col[0] && i != 0)
			col[i * T] = (col[0] + 1) % 6;
	pr_reps_opts_init(&o);
	o.epsilon = 10.0;
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_OK);
	assert_int_equal(r->status, PR_REPS_UNREACHABLE);
	assert_certified(r, o.epsilon);
	assert_near(r->p[0], q[0] / sq, 1e-9 * q[0] / sq);
	pr_reps_result_free(r);
	gsl_rng_free(rng);
}

static void test_bad_input(void **state)
{
	double R[N], q[N], phi[N * D];
	pr_reps_problem pb = { N, D, R, q, phi, NULL, NULL, NULL };
	pr_reps_opts o;
	pr_reps_result *r = NULL;
	char err[PR_ERRLEN];
	int i;

	(void)state;
	make_problem(11, R, q, phi);
	pr_reps_opts_init(&o);
	o.epsilon = 0.0;
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_EINVAL);
	assert_non_null(strstr(err, "epsilon"));
	o.epsilon = -1.0;
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_EINVAL);
	pr_reps_opts_init(&o);
	q[5] = -0.1;
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_EINVAL);
	assert_non_null(strstr(err, "sample 5"));
	for (i = 0; i < N; i++)
		q[i] = 0.0;
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_EINVAL);
	assert_non_null(strstr(err, "all zero"));
	make_problem(11, R, q, phi);
	R[3] = NAN;
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_EINVAL);
	assert_null(r);
	make_problem(11, R, q, phi);
	phi[2] = INFINITY;
	assert_int_equal(pr_reps_solve(&o, &pb, &r, err), PR_EINVAL);
	assert_null(r);
}

/* Zero base weights drop samples: same answer as leaving them out. */
static void test_zero_base_weights(void **state)
{
	double R[N], q[N], phi[N * D], R2[N], q2[N], phi2[N * D];
	pr_reps_problem pb = { N, D, R, q, phi, NULL, NULL, NULL };
	pr_reps_problem p2 = { 0, D, R2, q2, phi2, NULL, NULL, NULL };
	pr_reps_opts o;
	pr_reps_result *a = NULL, *b = NULL;
	char err[PR_ERRLEN];
	int i, k = 0;

	(void)state;
	make_problem(12, R, q, phi);
	for (i = 0; i < N; i += 3)
		q[i] = 0.0;
	for (i = 0; i < N; i++) {
		if (q[i] == 0.0)
			continue;
		R2[k] = R[i];
		q2[k] = q[i];
		memcpy(phi2 + k * D, phi + i * D, D * sizeof *phi);
		k++;
	}
	p2.n = k;
	pr_reps_opts_init(&o);
	assert_int_equal(pr_reps_solve(&o, &pb, &a, err), PR_OK);
	assert_int_equal(pr_reps_solve(&o, &p2, &b, err), PR_OK);
	for (i = 0, k = 0; i < N; i++) {
		if (q[i] == 0.0) {
			assert_true(a->p[i] == 0.0);
			continue;
		}
		assert_near(a->p[i], b->p[k], 1e-7 * b->p[k]);
		k++;
	}
	pr_reps_result_free(a);
	pr_reps_result_free(b);
}

static void test_importance_single_policy(void **state)
{
	double logpi[N], q[N], lr[N], ess;
	int counts[1] = { N }, i;
	char err[PR_ERRLEN];

	(void)state;
	for (i = 0; i < N; i++)
		logpi[i] = -0.5 * i + 3.0 * sin(i);
	assert_int_equal(pr_reps_importance(1, N, logpi, counts, logpi, q, lr, &ess, err), PR_OK);
	for (i = 0; i < N; i++) {
		assert_true(lr[i] == 0.0);
		assert_near(q[i], 1.0 / N, 1e-15);
	}
	assert_near(ess, N, 1e-9);
}

/* Two drawing policies (Gaussians N(0,1), N(1,1) on a 1-D action), current
 * N(0.5, 0.5^2): ratios by hand. */
static void test_importance_mixture(void **state)
{
	enum { M = 5 };
	double a[M] = { -1.0, 0.0, 0.4, 1.2, 2.5 };
	double logpi[2 * M], cur[M], q[M], lr[M], ess, want[M], sw = 0.0, s2 = 0.0;
	int counts[2] = { 3, 2 }, i;
	char err[PR_ERRLEN];

	(void)state;
	for (i = 0; i < M; i++) {
		double p0 = gsl_ran_gaussian_pdf(a[i], 1.0);
		double p1 = gsl_ran_gaussian_pdf(a[i] - 1.0, 1.0);
		double pc = gsl_ran_gaussian_pdf(a[i] - 0.5, 0.5);

		logpi[i] = log(p0);
		logpi[M + i] = log(p1);
		cur[i] = log(pc);
		want[i] = pc / (0.6 * p0 + 0.4 * p1);
		sw += want[i];
	}
	assert_int_equal(pr_reps_importance(2, M, logpi, counts, cur, q, lr, &ess, err), PR_OK);
	for (i = 0; i < M; i++) {
		assert_near(exp(lr[i]), want[i], 1e-12 * want[i]);
		assert_near(q[i], want[i] / sw, 1e-12);
		s2 += q[i] * q[i];
	}
	assert_near(ess, 1.0 / s2, 1e-12);
	counts[1] = 1;
	assert_int_equal(pr_reps_importance(2, M, logpi, counts, cur, q, lr, &ess, err), PR_EINVAL);
}

/* The 1-D contextual quadratic, small: REPS with value features c, c^2 and
 * an affine linear-Gaussian policy must drive the policy mean to x = c. */
static void test_quadratic_benchmark(void **state)
{
	char dir[] = "/tmp/poolreps_bench_XXXXXX", path[256], err[PR_ERRLEN];
	pr_config cfg;
	pr_bench_opts b;
	pr_csv *t = NULL;
	long last;

	(void)state;
	assert_non_null(mkdtemp(dir));
	pr_config_init(&cfg, pr_exp_config);
	assert_int_equal(pr_config_set(&cfg, "experiment.name=quadratic", err), PR_OK);
	cfg.run.repetitions = 2;
	cfg.run.threads = 1;
	b = *(const pr_bench_opts *)pr_config_opts(&cfg, &pr_bench_keys);
	b.iterations = 25;
	b.samples = 40;
	b.test_contexts = 20;
	assert_int_equal(pr_bench_run(&cfg, &b, dir, NULL, err), PR_OK);
	assert_int_equal(pr_exp_benchmark_summarize(&cfg, dir, err), PR_OK);
	snprintf(path, sizeof path, "%s/bench_summary.csv", dir);
	assert_int_equal(pr_csv_read(path, &t, err), PR_OK);
	last = pr_csv_nrows(t) - 1;
	assert_int_equal(last, 24);
	/* initial error about 0.6; KL-bounded steps shrink it geometrically */
	assert_true(pr_csv_get(t, 0, pr_csv_find(t, "test_error_mean")) > 0.1);
	assert_true(pr_csv_get(t, last, pr_csv_find(t, "test_error_mean")) < 1e-5);
	assert_true(pr_csv_get(t, last, pr_csv_find(t, "mean_return_mean")) > -1e-8);
	assert_true(pr_csv_get(t, last, pr_csv_find(t, "bound_frac")) == 1.0);
	pr_csv_free(t);
	remove(path);
	snprintf(path, sizeof path, "%s/bench_curve.csv", dir);
	remove(path);
	rmdir(dir);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_gradient_fd),
		cmocka_unit_test(test_sparse_equals_dense),
		cmocka_unit_test(test_kl_active),
		cmocka_unit_test(test_strong_duality),
		cmocka_unit_test(test_affine_invariance),
		cmocka_unit_test(test_constant_returns),
		cmocka_unit_test(test_no_features_known_answer),
		cmocka_unit_test(test_rich_features_inactive),
		cmocka_unit_test(test_rich_forest_unreachable),
		cmocka_unit_test(test_generic_unreachable),
		cmocka_unit_test(test_extreme_scales),
		cmocka_unit_test(test_pinned_tiny_mass),
		cmocka_unit_test(test_bad_input),
		cmocka_unit_test(test_zero_base_weights),
		cmocka_unit_test(test_importance_single_policy),
		cmocka_unit_test(test_importance_mixture),
		cmocka_unit_test(test_quadratic_benchmark),
	};

	gsl_set_error_handler_off();
	return cmocka_run_group_tests(tests, NULL, NULL);
}
