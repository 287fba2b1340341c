/* test_forest.c — extremely randomized trees and their features (thesis ch. 4,
 * 5.2, 6.1): known splits on hand-checkable data, the n_min / n_c rules,
 * weights, several outputs, active leaves and samples (eq. 5.1-5.6), seeds. */
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

#include "poolreps/forest.h"
#include "poolreps/internal.h"
#include "test_util.h"

static pr_forest *fit(const pr_forest_opts *o, const double *X, int n, int dx,
                      const double *Y, int dy, const double *w, unsigned long seed)
{
	char err[PR_ERRLEN];
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	pr_forest *f;

	gsl_rng_set(r, seed);
	f = pr_forest_fit(o, X, n, dx, Y, dy, w, r, err);
	gsl_rng_free(r);
	if (!f)
		fail_msg("fit failed: %s", err);
	return f;
}

static pr_forest_opts opts(int trees, int cuts, int n_min, int n_c)
{
	pr_forest_opts o;

	pr_forest_opts_init(&o);
	o.trees = trees;
	o.cuts = cuts;
	o.n_min = n_min;
	o.n_c = n_c;
	return o;
}

/* Uniform random inputs in [0,1)^dx and a smooth-plus-step target. */
static void random_data(int n, int dx, double *X, double *Y, unsigned long seed)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);

	gsl_rng_set(r, seed);
	for (int i = 0; i < n; i++) {
		for (int d = 0; d < dx; d++)
			X[i * dx + d] = gsl_rng_uniform(r);
		Y[i] = sin(3 * X[i * dx]) + (X[i * dx + dx - 1] > 0.6) + 0.1 * gsl_rng_uniform(r);
	}
	gsl_rng_free(r);
}

/* The leaf tree t sends x to, following the node tests by hand. */
static int descend(const pr_forest *f, int t, const double *x)
{
	int node = pr_forest_tree_node0(f, t), dim, right;
	double thr;

	for (;;) {
		assert_int_equal(pr_forest_node(f, node, &dim, &thr, &right), PR_OK);
		if (dim < 0)
			return right;
		node = x[dim] < thr ? node + 1 : right;
	}
}

static void test_defaults_and_checks(void **state)
{
	pr_forest_opts o;
	char err[PR_ERRLEN];

	(void)state;
	pr_forest_opts_init(&o);
	assert_int_equal(o.trees, 30);
	assert_int_equal(o.cuts, 10);
	assert_int_equal(o.n_min, 20);
	assert_int_equal(o.n_c, 1);
	assert_int_equal(o.score, PR_SCORE_RVR);
	assert_int_equal(o.with_replacement, 1);
	assert_int_equal(pr_forest_opts_check(&o, "forest", err), PR_OK);
	o.cuts = 0;
	assert_int_equal(pr_forest_opts_check(&o, "forest", err), PR_EINVAL);
	assert_string_equal(err, "forest.cuts: must be >= 1 (got 0)");
	o.cuts = 10;
	o.n_min = 0;
	assert_int_equal(pr_forest_opts_check(&o, "value", err), PR_EINVAL);
	assert_string_equal(err, "value.n_min: must be >= 1 (got 0)");
	o.n_min = 20;
	o.n_c = 0;
	assert_int_equal(pr_forest_opts_check(&o, NULL, err), PR_EINVAL);
	assert_string_equal(err, "n_c: must be >= 1 (got 0)");
}

/* x = 0..9, y = [x >= 5]: every tree splits once in (4, 5] (the only test
 * that separates the two values), leaving two leaves of five (<= n_min). */
static void test_known_split(void **state)
{
	double X[10], Y[10], y;
	pr_forest_opts o = opts(4, 200, 5, 1);
	pr_forest *f;

	(void)state;
	for (int i = 0; i < 10; i++) {
		X[i] = i;
		Y[i] = i >= 5;
	}
	f = fit(&o, X, 10, 1, Y, 1, NULL, 7);
	assert_int_equal(pr_forest_nnodes(f), 3 * 4);
	assert_int_equal(pr_forest_nleaves(f), 2 * 4);
	for (int t = 0; t < 4; t++) {
		int root = pr_forest_tree_node0(f, t), dim, right, l0 = pr_forest_tree_leaf0(f, t);
		const int *idx;
		double thr;

		assert_int_equal(pr_forest_node(f, root, &dim, &thr, &right), PR_OK);
		assert_int_equal(dim, 0);
		assert_true(thr > 4 && thr <= 5);
		assert_int_equal(right, root + 2);
		assert_int_equal(pr_forest_leaf_samples(f, l0, &idx), 5);
		for (int j = 0; j < 5; j++)
			assert_int_equal(idx[j], j);
		assert_int_equal(pr_forest_leaf_samples(f, l0 + 1, &idx), 5);
		for (int j = 0; j < 5; j++)
			assert_int_equal(idx[j], 5 + j);
		assert_true(pr_forest_leaf_mean(f, l0)[0] == 0.0);
		assert_true(pr_forest_leaf_mean(f, l0 + 1)[0] == 1.0);
	}
	y = -1;
	pr_forest_predict(f, (double[]){ 3.5 }, &y);
	assert_true(y == 0.0);
	pr_forest_predict(f, (double[]){ 5.0 }, &y);
	assert_true(y == 1.0);
	pr_forest_free(f);

	/* nrvr picks the least reduction: a one-sample child, t in (0,1] or (8,9] */
	o.score = PR_SCORE_NRVR;
	f = fit(&o, X, 10, 1, Y, 1, NULL, 7);
	for (int t = 0; t < 4; t++) {
		int dim, right;
		double thr;

		pr_forest_node(f, pr_forest_tree_node0(f, t), &dim, &thr, &right);
		assert_true((thr > 0 && thr <= 1) || (thr > 8 && thr <= 9));
	}
	pr_forest_free(f);
}

/* Every leaf holds >= n_c samples, every split node > n_min, the leaves of a
 * tree partition the samples, and each sample sits in the leaf its path
 * reaches. */
static void test_leaf_rules(void **state)
{
	enum { N = 400, DX = 3 };
	static double X[N * DX], Y[N];
	pr_forest_opts o = opts(6, 4, 10, 4);
	pr_forest *f;
	int *seen = calloc(N, sizeof *seen), *cnt;

	(void)state;
	random_data(N, DX, X, Y, 3);
	f = fit(&o, X, N, DX, Y, 1, NULL, 11);
	cnt = calloc((size_t)pr_forest_nnodes(f), sizeof *cnt);
	for (int t = 0; t < pr_forest_ntrees(f); t++) {
		int total = 0;
		memset(seen, 0, N * sizeof *seen);
		for (int l = pr_forest_tree_leaf0(f, t); l < pr_forest_tree_leaf0(f, t + 1); l++) {
			const int *idx;
			int m = pr_forest_leaf_samples(f, l, &idx);
			assert_true(m >= o.n_c);
			total += m;
			for (int j = 0; j < m; j++) {
				assert_int_equal(seen[idx[j]], 0);
				seen[idx[j]] = 1;
				assert_int_equal(descend(f, t, X + idx[j] * DX), l);
			}
		}
		assert_int_equal(total, N);
		/* count the samples through every node */
		for (int i = 0; i < N; i++) {
			int node = pr_forest_tree_node0(f, t), dim, right;
			double thr;
			for (;;) {
				cnt[node]++;
				pr_forest_node(f, node, &dim, &thr, &right);
				if (dim < 0)
					break;
				node = X[i * DX + dim] < thr ? node + 1 : right;
			}
		}
	}
	for (int node = 0; node < pr_forest_nnodes(f); node++) {
		int dim, right;
		double thr;
		pr_forest_node(f, node, &dim, &thr, &right);
		if (dim >= 0)
			assert_true(cnt[node] > o.n_min);
		else
			assert_true(cnt[node] >= o.n_c);
	}
	free(cnt);
	free(seen);
	pr_forest_free(f);
}

/* A dimension constant in a node is never tested; a node whose inputs are
 * all equal is a leaf whatever its size. */
static void test_constant_dimensions(void **state)
{
	enum { N = 60 };
	double X[2 * N], Y[N];
	pr_forest_opts o = opts(5, 1, 4, 1);
	pr_forest *f;

	(void)state;
	for (int i = 0; i < N; i++) {
		X[2 * i] = 5.0;
		X[2 * i + 1] = (i * 37 % N) / (double)N;
		Y[i] = X[2 * i + 1] > 0.5;
	}
	f = fit(&o, X, N, 2, Y, 1, NULL, 5);
	assert_true(pr_forest_nnodes(f) > 5);
	for (int node = 0; node < pr_forest_nnodes(f); node++) {
		int dim, right;
		double thr;
		pr_forest_node(f, node, &dim, &thr, &right);
		assert_true(dim == -1 || dim == 1);
	}
	pr_forest_free(f);
	for (int i = 0; i < N; i++)
		X[2 * i + 1] = 0.25;
	f = fit(&o, X, N, 2, Y, 1, NULL, 5);
	assert_int_equal(pr_forest_nnodes(f), 5);
	assert_int_equal(pr_forest_nleaves(f), 5);
	pr_forest_free(f);
}

static void assert_same_forest(const pr_forest *a, const pr_forest *b, int trees)
{
	int na = pr_forest_tree_node0(a, trees), la = pr_forest_tree_leaf0(a, trees);

	assert_int_equal(na, pr_forest_tree_node0(b, trees));
	assert_int_equal(la, pr_forest_tree_leaf0(b, trees));
	for (int node = 0; node < na; node++) {
		int d1, d2, r1, r2;
		double t1, t2;
		pr_forest_node(a, node, &d1, &t1, &r1);
		pr_forest_node(b, node, &d2, &t2, &r2);
		assert_int_equal(d1, d2);
		assert_true(t1 == t2);
		assert_int_equal(r1, r2);
	}
	for (int l = 0; l < la; l++) {
		const int *i1, *i2;
		int m = pr_forest_leaf_samples(a, l, &i1);
		assert_int_equal(m, pr_forest_leaf_samples(b, l, &i2));
		assert_memory_equal(i1, i2, (size_t)m * sizeof *i1);
		for (int k = 0; k < pr_forest_dy(a); k++)
			assert_near(pr_forest_leaf_mean(a, l)[k], pr_forest_leaf_mean(b, l)[k], 1e-12 * (1 + fabs(pr_forest_leaf_mean(a, l)[k])));
	}
}

/* Same seed, same forest; tree t depends on (seed, t) only, so a smaller
 * forest is a prefix of a larger one; another seed gives other trees. */
static void test_seeds(void **state)
{
	enum { N = 300, DX = 2 };
	static double X[N * DX], Y[N];
	pr_forest_opts o = opts(5, 3, 8, 1);
	pr_forest *a, *b, *c;

	(void)state;
	random_data(N, DX, X, Y, 9);
	a = fit(&o, X, N, DX, Y, 1, NULL, 42);
	b = fit(&o, X, N, DX, Y, 1, NULL, 42);
	assert_same_forest(a, b, 5);
	o.trees = 3;
	c = fit(&o, X, N, DX, Y, 1, NULL, 42);
	assert_same_forest(a, c, 3);
	pr_forest_free(b);
	pr_forest_free(c);
	b = fit(&o, X, N, DX, Y, 1, NULL, 43);
	for (int t = 0; t < 3; t++) {
		double t1, t2;
		int d, r;
		pr_forest_node(a, pr_forest_tree_node0(a, t), &d, &t1, &r);
		pr_forest_node(b, pr_forest_tree_node0(b, t), &d, &t2, &r);
		assert_true(t1 != t2);
	}
	pr_forest_free(a);
	pr_forest_free(b);
}

/* eq. 6.2-6.3 with unit weights is the unweighted score (eq. 4.1), and the
 * score is invariant to a common weight scale: identical trees (the two go
 * through different code: the unweighted one-output path is specialised). */
static void test_unit_weights(void **state)
{
	enum { N = 300, DX = 3 };
	static double X[N * DX], Y[N], W1[N], W3[N];
	pr_forest_opts o = opts(4, 5, 6, 2);
	pr_forest *a, *b, *c;

	(void)state;
	random_data(N, DX, X, Y, 21);
	for (int i = 0; i < N; i++) {
		W1[i] = 1.0;
		W3[i] = 3.0;
	}
	a = fit(&o, X, N, DX, Y, 1, NULL, 8);
	b = fit(&o, X, N, DX, Y, 1, W1, 8);
	c = fit(&o, X, N, DX, Y, 1, W3, 8);
	assert_same_forest(a, b, 4);
	assert_same_forest(a, c, 4);
	pr_forest_free(a);
	pr_forest_free(b);
	pr_forest_free(c);
	/* constant outputs: every test scores exactly 0 in both paths and the
	 * first drawn is kept (with partly equal outputs, exact ties between
	 * different tests would be broken by rounding, differently per path) */
	for (int i = 0; i < N; i++)
		Y[i] = 0.3;
	a = fit(&o, X, N, DX, Y, 1, NULL, 8);
	b = fit(&o, X, N, DX, Y, 1, W1, 8);
	assert_same_forest(a, b, 4);
	pr_forest_free(a);
	pr_forest_free(b);
}

/* Weighted fits on known data: a zero-weight outlier neither moves the
 * split nor the leaf value; a single leaf holds the weighted mean. */
static void test_weighted_known(void **state)
{
	double X[11], Y[11], W[11], y;
	double X4[4] = { 0, 1, 2, 3 }, Y4[4] = { 0, 0, 1, 1 }, W4[4] = { 3, 1, 1, 1 };
	pr_forest_opts o = opts(3, 200, 6, 1);
	pr_forest *f;

	(void)state;
	for (int i = 0; i < 10; i++) {
		X[i] = i;
		Y[i] = i >= 5;
		W[i] = 1 + i % 3;
	}
	X[10] = 2.5;
	Y[10] = 100;
	W[10] = 0;
	f = fit(&o, X, 11, 1, Y, 1, W, 3);
	for (int t = 0; t < 3; t++) {
		int dim, right;
		double thr;
		pr_forest_node(f, pr_forest_tree_node0(f, t), &dim, &thr, &right);
		assert_true(thr > 4 && thr <= 5);
		assert_int_equal(pr_forest_tree_leaf0(f, t + 1) - pr_forest_tree_leaf0(f, t), 2);
	}
	pr_forest_predict(f, (double[]){ 2.5 }, &y);
	assert_true(y == 0.0);
	pr_forest_predict(f, (double[]){ 8 }, &y);
	assert_true(y == 1.0);
	pr_forest_free(f);

	o.n_min = 10;
	f = fit(&o, X4, 4, 1, Y4, 1, W4, 3);
	assert_int_equal(pr_forest_nleaves(f), 3);
	pr_forest_predict(f, (double[]){ 1.5 }, &y);
	assert_near(y, 2.0 / 6.0, 1e-15);
	pr_forest_free(f);
}

/* Two outputs on a 10 x 10 grid: y1 = [x0 >= .5], y2 = 1000 x1, with
 * outputs = relative: both outputs take part, each relative to its own node
 * variance:
 * the root splits x0 at .5 (y1 fully explained: rvr 1 + 0, against 0 + 0.75
 * for x1 at .5), each half then x1 at .5 for y2, so the leaves are the four
 * quadrants: y1 exact, y2 the quadrant mean 200 or 700. An unnormalised sum
 * would keep cutting x1 for y2's scale and leave y1 mixed. The same with
 * weights (eq. 6.3), which depend on x0 only: the quadrant means stay. */
static void test_multi_output(void **state)
{
	double X[200], Y[200], W[100], p[2];
	pr_forest_opts o = opts(5, 500, 25, 1);

	(void)state;
	o.outputs = PR_OUTPUTS_RELATIVE;
	for (int i = 0; i < 100; i++) {
		X[2 * i] = (i % 10) / 10.0;
		X[2 * i + 1] = (i / 10) / 10.0;
		Y[2 * i] = X[2 * i] >= 0.5;
		Y[2 * i + 1] = 1000.0 * X[2 * i + 1];
		W[i] = 1.0 + (i % 10 == 3);
	}
	for (int weighted = 0; weighted < 2; weighted++) {
		pr_forest *f = fit(&o, X, 100, 2, Y, 2, weighted ? W : NULL, 13);
		assert_int_equal(pr_forest_dy(f), 2);
		assert_int_equal(pr_forest_nleaves(f), 4 * 5);
		for (int i = 0; i < 100; i++) {
			pr_forest_predict(f, X + 2 * i, p);
			assert_true(p[0] == Y[2 * i]);
			assert_near(p[1], (X[2 * i + 1] < 0.5 ? 200.0 : 700.0), 1e-9);
		}
		pr_forest_free(f);
	}
}

/* eq. 4.2-4.3: the prediction is the average over trees of the active leaf's
 * mean, each leaf mean that of its samples' outputs; predict_many agrees. */
static void test_predict_is_average(void **state)
{
	enum { N = 250, DX = 2, Q = 40 };
	static double X[N * DX], Y[N], Xq[Q * DX], Yq[Q];
	pr_forest_opts o = opts(7, 4, 10, 1);
	pr_forest *f;
	int leaves[7];

	(void)state;
	random_data(N, DX, X, Y, 4);
	random_data(Q, DX, Xq, Yq, 5);
	f = fit(&o, X, N, DX, Y, 1, NULL, 2);
	for (int l = 0; l < pr_forest_nleaves(f); l++) {
		const int *idx;
		int m = pr_forest_leaf_samples(f, l, &idx);
		double s = 0;
		for (int j = 0; j < m; j++)
			s += Y[idx[j]];
		assert_near(pr_forest_leaf_mean(f, l)[0], s / m, 1e-12);
	}
	pr_forest_predict_many(f, Xq, Q, Yq);
	for (int q = 0; q < Q; q++) {
		double y, s = 0;
		assert_int_equal(pr_forest_active(f, Xq + q * DX, DX, leaves, 7), 7);
		for (int t = 0; t < 7; t++)
			s += pr_forest_leaf_mean(f, leaves[t])[0];
		pr_forest_predict(f, Xq + q * DX, &y);
		assert_near(y, s / 7, 1e-12);
		assert_near(Yq[q], y, 1e-12);
	}
	pr_forest_free(f);
}

/* eq. 5.1-5.4: a state forest's feature vector has exactly M ones, one in
 * each tree's block, at the leaf the tree's path reaches. */
static void test_state_features(void **state)
{
	enum { N = 300, DX = 2, M = 9 };
	static double X[N * DX], Y[N];
	pr_forest_opts o = opts(M, 3, 12, 1);
	pr_forest *f;
	int leaves[M], *phi;

	(void)state;
	random_data(N, DX, X, Y, 6);
	f = fit(&o, X, N, DX, Y, 1, NULL, 6);
	phi = malloc((size_t)pr_forest_nleaves(f) * sizeof *phi);
	for (int q = 0; q < 50; q++) {
		const double *x = X + q * DX;
		int ones = 0;
		assert_int_equal(pr_forest_active(f, x, DX, leaves, M), M);
		memset(phi, 0, (size_t)pr_forest_nleaves(f) * sizeof *phi);
		for (int t = 0; t < M; t++) {
			assert_true(leaves[t] >= pr_forest_tree_leaf0(f, t));
			assert_true(leaves[t] < pr_forest_tree_leaf0(f, t + 1));
			assert_int_equal(leaves[t], descend(f, t, x));
			phi[leaves[t]] = 1;
		}
		for (int l = 0; l < pr_forest_nleaves(f); l++)
			ones += phi[l];
		assert_int_equal(ones, M);
	}
	assert_int_equal(pr_forest_active(f, X, DX, leaves, M - 1), PR_EINVAL);
	assert_int_equal(pr_forest_active(f, X, DX + 1, leaves, M), PR_EINVAL);
	free(phi);
	pr_forest_free(f);
}

/* Hand-worked state-action case: s = i, a = i % 2, y = a + 10 [s >= 8],
 * i = 0..15, n_min = 4. Each tree splits s in (7, 8], then a in (0, 1]:
 * leaves {0,2,4,6}, {1,3,5,7}, {8,..,14}, {9,..,15}. A state-only query
 * s = 3 goes down both a-branches (5.2.1): 2M leaves, and by eq. 5.6 every
 * sample with s < 8 is active in every tree; the full query (3, 0) only
 * the even ones. */
static void test_active_samples_hand(void **state)
{
	enum { N = 16, M = 3 };
	double X[2 * N], Y[N], phi[N];
	pr_forest_opts o = opts(M, 200, 4, 1);
	pr_forest *f;
	int leaves[4 * M];

	(void)state;
	for (int i = 0; i < N; i++) {
		X[2 * i] = i;
		X[2 * i + 1] = i % 2;
		Y[i] = i % 2 + 10.0 * (i >= 8);
	}
	f = fit(&o, X, N, 2, Y, 1, NULL, 17);
	assert_int_equal(pr_forest_nleaves(f), 4 * M);
	assert_int_equal(pr_forest_active(f, (double[]){ 3, 0 }, 1, leaves, 4 * M), 2 * M);
	assert_int_equal(pr_forest_active_samples(f, (double[]){ 3, 0 }, 1, phi), PR_OK);
	for (int i = 0; i < N; i++)
		assert_true(phi[i] == (i < 8 ? 1.0 : 0.0));
	assert_int_equal(pr_forest_active_samples(f, (double[]){ 3, 0 }, 2, phi), PR_OK);
	for (int i = 0; i < N; i++)
		assert_near(phi[i], (i < 8 && i % 2 == 0 ? 1.0 : 0.0), 1e-15);
	assert_int_equal(pr_forest_active(f, NULL, 0, leaves, 4 * M), 4 * M);
	pr_forest_free(f);
}

/* On random state-action data: the state-only query activates exactly the
 * leaves whose path tests on state dimensions the state passes (>= M of
 * them), and active samples equal Phi^T phi(s) / M with Phi built from the
 * training inputs' own active leaves (eq. 5.5-5.6). */
static void test_state_action_features(void **state)
{
	enum { N = 200, DX = 4, DS = 2, M = 6 };
	static double X[N * DX], Y[N], phi[N];
	pr_forest_opts o = opts(M, 3, 8, 1);
	pr_forest *f;
	int *act, *Phi, *compat, nf, own[M];

	(void)state;
	random_data(N, DX, X, Y, 12);
	for (int i = 0; i < N; i++)
		Y[i] += 2 * X[i * DX + 3];
	f = fit(&o, X, N, DX, Y, 1, NULL, 12);
	nf = pr_forest_nleaves(f);
	act = malloc((size_t)nf * sizeof *act);
	compat = malloc((size_t)nf * sizeof *compat);
	Phi = calloc((size_t)nf * N, sizeof *Phi);
	for (int i = 0; i < N; i++) {
		assert_int_equal(pr_forest_active(f, X + i * DX, DX, own, M), M);
		for (int t = 0; t < M; t++)
			Phi[(size_t)own[t] * N + i] = 1;
	}
	for (int q = 0; q < 30; q++) {
		const double *s = X + (q * 7 % N) * DX;
		int c = pr_forest_active(f, s, DS, act, nf), ncompat = 0;
		assert_true(c >= M);
		/* compatible leaves: walk every node, following only state tests */
		memset(compat, 0, (size_t)nf * sizeof *compat);
		for (int t = 0; t < M; t++) {
			int stack[256], sp = 0;
			stack[sp++] = pr_forest_tree_node0(f, t);
			while (sp > 0) {
				int node = stack[--sp], dim, right;
				double thr;
				pr_forest_node(f, node, &dim, &thr, &right);
				if (dim < 0) {
					compat[right] = 1;
				} else if (dim >= DS) {
					stack[sp++] = right;
					stack[sp++] = node + 1;
				} else {
					stack[sp++] = s[dim] < thr ? node + 1 : right;
				}
				assert_true(sp < 255);
			}
		}
		for (int l = 0; l < nf; l++)
			ncompat += compat[l];
		assert_int_equal(c, ncompat);
		for (int k = 0; k < c; k++)
			assert_int_equal(compat[act[k]], 1);
		assert_int_equal(pr_forest_active_samples(f, s, DS, phi), PR_OK);
		for (int i = 0; i < N; i++) {
			double v = 0;
			for (int k = 0; k < c; k++)
				v += Phi[(size_t)act[k] * N + i];
			assert_near(phi[i], v / M, 1e-12);
		}
	}
	free(act);
	free(compat);
	free(Phi);
	pr_forest_free(f);
}

/* Without replacement, K = dx = 2 tests one cut on each dimension at every
 * node; with replacement both cuts fall on the useless x0 a quarter of the
 * time. y = [x1 >= .5]: count the roots that split x1. */
static void test_without_replacement(void **state)
{
	enum { N = 200, M = 200 };
	static double X[2 * N], Y[N];
	pr_forest_opts o = opts(M, 2, 20, 1);
	int on_x1[2];

	(void)state;
	random_data(N, 2, X, Y, 30);
	for (int i = 0; i < N; i++)
		Y[i] = X[2 * i + 1] >= 0.5;
	for (int wr = 0; wr < 2; wr++) {
		pr_forest *f;
		o.with_replacement = wr;
		f = fit(&o, X, N, 2, Y, 1, NULL, 31);
		on_x1[wr] = 0;
		for (int t = 0; t < M; t++) {
			int dim, right;
			double thr;
			pr_forest_node(f, pr_forest_tree_node0(f, t), &dim, &thr, &right);
			on_x1[wr] += dim == 1;
		}
		pr_forest_free(f);
	}
	/* expected about 0.97 M without, 0.75 x 0.97 M with replacement */
	assert_true(on_x1[0] >= 180);
	assert_true(on_x1[1] <= 170);
}

static void test_bad_input(void **state)
{
	double X[6] = { 0, 1, 2, 3, 4, 5 }, Y[6] = { 0, 1, 0, 1, 0, 1 };
	double W[6] = { 1, 1, -1, 1, 1, 1 }, Z[6] = { 0 };
	pr_forest_opts o = opts(2, 1, 2, 1);
	char err[PR_ERRLEN];
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);

	(void)state;
	o.cuts = 0;
	assert_null(pr_forest_fit(&o, X, 6, 1, Y, 1, NULL, r, err));
	assert_string_equal(err, "cuts: must be >= 1 (got 0)");
	o.cuts = 1;
	o.n_c = 7;
	assert_null(pr_forest_fit(&o, X, 6, 1, Y, 1, NULL, r, err));
	assert_non_null(strstr(err, "fewer than n_c"));
	o.n_c = 1;
	assert_null(pr_forest_fit(&o, X, 6, 1, Y, 1, W, r, err));
	assert_non_null(strstr(err, "weight 2"));
	assert_null(pr_forest_fit(&o, X, 6, 1, Y, 1, Z, r, err));
	assert_non_null(strstr(err, "sum to 0"));
	X[3] = NAN;
	assert_null(pr_forest_fit(&o, X, 6, 1, Y, 1, NULL, r, err));
	assert_non_null(strstr(err, "not finite"));
	assert_null(pr_forest_fit(&o, X, 0, 1, Y, 1, NULL, r, err));
	gsl_rng_free(r);
	pr_forest_free(NULL);
}

/* Two outputs on very different scales: y0 = 10 [x0 < 0.5] + N(0, 5^2)
 * noise, y1 = 0.01 [x1 < 0.5]. Eq. 6.1 adds the reductions as they are
 * (outputs = sum), so the root cuts x0, which removes far more variance;
 * relative to each output's own variance the clean step in y1 wins. */
static void test_outputs_sum_and_relative(void **state)
{
	enum { N = 400, M = 20 };
	static double X[N * 2], Y[N * 2];
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	pr_forest_opts o = opts(M, 300, N - 1, 1);
	int mode, t, dim, right, on_x0[2] = {0, 0};
	double thr;

	(void)state;
	gsl_rng_set(r, 3);
	for (int i = 0; i < N; i++) {
		X[2 * i] = gsl_rng_uniform(r);
		X[2 * i + 1] = gsl_rng_uniform(r);
		Y[2 * i] = 10.0 * (X[2 * i] < 0.5) + gsl_ran_gaussian(r, 5.0);
		Y[2 * i + 1] = 0.01 * (X[2 * i + 1] < 0.5);
	}
	gsl_rng_free(r);
	for (mode = 0; mode < 2; mode++) {
		pr_forest *f;

		o.outputs = mode ? PR_OUTPUTS_RELATIVE : PR_OUTPUTS_SUM;
		f = fit(&o, X, N, 2, Y, 2, NULL, 1);
		for (t = 0; t < M; t++) {
			assert_int_equal(pr_forest_node(f, pr_forest_tree_node0(f, t), &dim, &thr, &right), 0);
			on_x0[mode] += dim == 0;
		}
		pr_forest_free(f);
	}
	assert_int_equal(on_x0[PR_OUTPUTS_SUM], M);
	assert_int_equal(on_x0[PR_OUTPUTS_RELATIVE], 0);
}

/* pr_forest_save / pr_forest_load: a loaded forest has the same nodes,
 * leaf values and samples, so it predicts bit for bit; saving it again gives
 * the same bytes; every prefix of the text and a wrong version are refused
 * with a message (and never read out of bounds: the SAN build checks). */
static char *save_text(const pr_forest *f, size_t *len)
{
	char err[PR_ERRLEN], *text = NULL;
	FILE *fp = open_memstream(&text, len);

	assert_non_null(fp);
	assert_int_equal(pr_forest_save(f, fp, NULL, err), PR_OK);
	assert_int_equal(fclose(fp), 0);
	return text;
}

static void test_save_load(void **state)
{
	double X[3 * 300], Y[2 * 300], W[300], p[2], q[2];
	char err[PR_ERRLEN], **names = NULL;
	pr_forest_opts o = opts(6, 5, 8, 2);

	(void)state;
	random_data(300, 3, X, Y, 21);
	for (int i = 0; i < 300; i++) {
		Y[300 + i] = X[3 * i + 1];
		W[i] = 0.5 + (i % 7);
	}
	for (int dy = 1; dy <= 2; dy++) {
		pr_forest *f = fit(&o, X, 300, 3, Y, dy, dy == 2 ? W : NULL, 5), *g;
		size_t len, len2;
		char *text = save_text(f, &len), *again;

		g = pr_forest_load(text, len, "t", &names, err);
		assert_non_null(g);
		assert_string_equal(names[0], "x0");
		assert_string_equal(names[3], "y0");
		free(names);
		assert_int_equal(pr_forest_nnodes(g), pr_forest_nnodes(f));
		for (int k = 0; k < pr_forest_nleaves(f); k++) {
			const int *a, *b;
			int na = pr_forest_leaf_samples(f, k, &a), nb = pr_forest_leaf_samples(g, k, &b);

			assert_int_equal(na, nb);
			assert_memory_equal(a, b, (size_t)na * sizeof *a);
		}
		for (int i = 0; i < 300; i++) {
			double x[3] = { X[3 * i] * 1.3 - 0.1, X[3 * i + 1], X[3 * i + 2] };

			pr_forest_predict(f, x, p);
			pr_forest_predict(g, x, q);
			assert_memory_equal(p, q, (size_t)dy * sizeof *p);
		}
		again = save_text(g, &len2);
		assert_int_equal(len, len2);
		assert_memory_equal(text, again, len);
		for (size_t cut = 0; cut < len; cut += 1 + cut / 50)
			assert_null(pr_forest_load(text, cut, "t", NULL, err));
		memcpy(text + strlen("poolreps-forest "), "2", 1);
		assert_null(pr_forest_load(text, len, "t", NULL, err));
		assert_string_equal(err, "t: forest format version 2, this library reads version 1");
		free(text);
		free(again);
		pr_forest_free(f);
		pr_forest_free(g);
	}
}

/* An output constant in every node has SSE 0 and takes no part in the score
 * (nor in the other outputs' leaf means): six outputs of which only 1 and 4
 * vary (one in each block of four the weighted scan takes at a time) grow
 * exactly the forest of those two alone, weighted or not, sum or relative. */
static void test_constant_outputs_drop_out(void **state)
{
	enum { N = 150, DX = 3 };
	static double X[N * DX], Y1[N], Y6[N * 6], Y2[N * 2], W[N];
	const double c[6] = { 0.25, 0, -3, 7, 0, 1e3 };

	(void)state;
	random_data(N, DX, X, Y1, 31);
	for (int i = 0; i < N; i++) {
		for (int k = 0; k < 6; k++)
			Y6[6 * i + k] = c[k];
		Y6[6 * i + 1] = Y2[2 * i] = Y1[i];
		Y6[6 * i + 4] = Y2[2 * i + 1] = cos(5 * X[DX * i + 1]) * (1 + i % 3);
		W[i] = 0.25 + (i * 7 % 11);
	}
	for (int v = 0; v < 4; v++) {
		pr_forest_opts o = opts(4, 6, 12, 2);
		const double *w = v & 1 ? W : NULL;
		pr_forest *f, *g;

		o.outputs = v & 2 ? PR_OUTPUTS_RELATIVE : PR_OUTPUTS_SUM;
		f = fit(&o, X, N, DX, Y6, 6, w, 9);
		g = fit(&o, X, N, DX, Y2, 2, w, 9);
		assert_int_equal(pr_forest_nnodes(f), pr_forest_nnodes(g));
		assert_int_equal(pr_forest_nleaves(f), pr_forest_nleaves(g));
		assert_true(pr_forest_nleaves(f) > 4 * 4);
		for (int k = 0; k < pr_forest_nnodes(f); k++) {
			int df, dg, rf, rg;
			double tf, tg;

			assert_int_equal(pr_forest_node(f, k, &df, &tf, &rf), PR_OK);
			assert_int_equal(pr_forest_node(g, k, &dg, &tg, &rg), PR_OK);
			assert_int_equal(df, dg);
			assert_int_equal(rf, rg);
			assert_true(tf == tg);
		}
		for (int l = 0; l < pr_forest_nleaves(f); l++) {
			const double *mf = pr_forest_leaf_mean(f, l), *mg = pr_forest_leaf_mean(g, l);

			assert_true(mf[1] == mg[0] && mf[4] == mg[1]);
			assert_true(mf[0] == c[0]);  /* 0.25 w sums exactly */
		}
		pr_forest_free(f);
		pr_forest_free(g);
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_defaults_and_checks),
		cmocka_unit_test(test_known_split),
		cmocka_unit_test(test_leaf_rules),
		cmocka_unit_test(test_constant_dimensions),
		cmocka_unit_test(test_seeds),
		cmocka_unit_test(test_unit_weights),
		cmocka_unit_test(test_weighted_known),
		cmocka_unit_test(test_multi_output),
		cmocka_unit_test(test_predict_is_average),
		cmocka_unit_test(test_state_features),
		cmocka_unit_test(test_active_samples_hand),
		cmocka_unit_test(test_state_action_features),
		cmocka_unit_test(test_without_replacement),
		cmocka_unit_test(test_outputs_sum_and_relative),
		cmocka_unit_test(test_bad_input),
		cmocka_unit_test(test_save_load),
		cmocka_unit_test(test_constant_outputs_drop_out),
	};

	gsl_set_error_handler_off();
	return cmocka_run_group_tests(tests, NULL, NULL);
}
