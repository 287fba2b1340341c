/* forest.c — extremely randomized trees (thesis ch. 4, 5.2 and 6.1).
 *
 * Layout. All trees share flat arrays. Nodes are stored in preorder, so an
 * internal node's left child is the node after it and only the right child
 * is recorded; for a leaf the same slot holds its global leaf id. Leaves are
 * numbered left to right, tree after tree. Each tree owns one permutation of
 * the sample indices 0..n-1 in which every leaf's samples form a contiguous
 * slice, in leaf order: global leaf g holds perm[leaf_start[g] ..
 * leaf_start[g + 1]). No input or output values are copied into the forest.
 *
 * Fitting (4.2.1). Depth first from an explicit stack. A node is a range
 * [lo, hi) of one of two buffers that hold its samples contiguously: sample
 * indices, inputs column by column, outputs and weights (every tree's root
 * reads one such copy of the data made once per fit). It is split while
 * it holds more than n_min samples: K tests [x_d < t] are drawn, each scored
 * in one pass over the node's column d (branch-free for one unweighted
 * output), and the best is applied
 * by a stable, branch-free partition into the same range of the other
 * buffer (so pending nodes are never overwritten). A leaf copies its indices
 * into the tree's permutation.
 *
 * For a test the weighted sum of squares within the children falls by
 *     red = S_l^2 / W_l + S_r^2 / W_r - S^2 / W
 * with W the weight sums and S the sums of w * (y - node mean): outputs are
 * centred on the node's weighted mean first, so no squares of raw outputs
 * are subtracted and red is clamped at 0 only against rounding. With one
 * output and no weights (the common case) the same quantity is
 * m / (nl nr) * (S_l - nl mean)^2 from the plain left sum S_l of y, and the
 * node mean comes from the parent's split: no centring pass.
 *
 * Score. Eq. 4.1's score for output k is -(SSE_k - red_k) / W, with SSE_k
 * the node's weighted sum of squares (eq. 6.2-6.3 with weights); SSE_k and W
 * are the same for every test of a node, so maximising
 *     rvr = sum_k red_k
 * picks the test of eq. 6.1 / 6.3 (outputs = sum, the default). With
 * outputs = relative each output counts relative to its own node variance,
 * rvr = sum_k red_k / SSE_k (Geurts et al.'s relative reduction), so units
 * do not matter; with one output the two pick the same test. score = nrvr
 * maximises -rvr exactly (section 7.5.1).
 */
#include <limits.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_rng.h>

#include "poolreps/forest.h"
#include "poolreps/internal.h"

/* One node in 16 bytes, so a descent touches one cache line per level. */
typedef struct {
	double thr;  /* threshold t of [x_dim < t] */
	int dim;     /* test dimension, -1 for a leaf */
	int right;   /* right child, or the global leaf id for a leaf */
} pr_node;

struct pr_forest {
	int M, n, dx, dy;
	int nnodes, nleaves, max_depth;
	int cap_nodes, cap_leaves;
	int *tree_node0;  /* M + 1: first node of each tree */
	int *tree_leaf0;  /* M + 1: first global leaf of each tree */
	pr_node *node;    /* all nodes, preorder within each tree */
	int *leaf_start;  /* nleaves + 1 offsets into perm */
	double *mean;     /* nleaves x dy leaf values (eq. 4.2) */
	int *perm;        /* M x n: one sample permutation per tree */
};

void pr_forest_opts_init(pr_forest_opts *o)
{
	o->trees = 30;
	o->cuts = 10;
	o->n_min = 20;
	o->n_c = 1;
	o->score = PR_SCORE_RVR;
	o->with_replacement = 1;
	o->outputs = PR_OUTPUTS_SUM;
}

int pr_forest_opts_check(const pr_forest_opts *o, const char *prefix, char *err)
{
	const char *p = prefix ? prefix : "", *dot = prefix ? "." : "";

	if (o->trees < 1)
		return pr_err(err, PR_EINVAL, "%s%strees: must be >= 1 (got %d)", p, dot, o->trees);
	if (o->cuts < 1)
		return pr_err(err, PR_EINVAL, "%s%scuts: must be >= 1 (got %d)", p, dot, o->cuts);
	/* the keys' bounds too: a learner's state file holds options unchecked by them */
	if (o->trees > PR_FOREST_MAX_TREES)
		return pr_err(err, PR_EINVAL, "%s%strees: must be <= %d (got %d)", p, dot,
		              PR_FOREST_MAX_TREES, o->trees);
	if (o->cuts > PR_FOREST_MAX_CUTS)
		return pr_err(err, PR_EINVAL, "%s%scuts: must be <= %d (got %d)", p, dot,
		              PR_FOREST_MAX_CUTS, o->cuts);
	if (o->n_min < 1)
		return pr_err(err, PR_EINVAL, "%s%sn_min: must be >= 1 (got %d)", p, dot, o->n_min);
	if (o->n_c < 1)
		return pr_err(err, PR_EINVAL, "%s%sn_c: must be >= 1 (got %d)", p, dot, o->n_c);
	if (o->score != PR_SCORE_RVR && o->score != PR_SCORE_NRVR)
		return pr_err(err, PR_EINVAL, "%s%sscore: must be rvr or nrvr", p, dot);
	if (o->outputs != PR_OUTPUTS_SUM && o->outputs != PR_OUTPUTS_RELATIVE)
		return pr_err(err, PR_EINVAL, "%s%soutputs: must be sum or relative", p, dot);
	if (o->with_replacement != 0 && o->with_replacement != 1)
		return pr_err(err, PR_EINVAL, "%s%swith_replacement: must be 0 or 1 (got %d)",
		              p, dot, o->with_replacement);
	return PR_OK;
}

void pr_forest_free(pr_forest *f)
{
	if (!f)
		return;
	free(f->tree_node0);
	free(f->tree_leaf0);
	free(f->node);
	free(f->leaf_start);
	free(f->mean);
	free(f->perm);
	free(f);
}

/* ---- fitting ---------------------------------------------------------- */

#if defined(__GNUC__)
#define NOINLINE __attribute__((noinline))
#else
#define NOINLINE
#endif

typedef struct {
	int lo, hi, depth;
	int parent;  /* the node whose right child this is, or -1 */
	double sum;  /* unweighted single output: the sum of the node's y */
} span;

/* The samples of the nodes at one depth parity, in node order: a node is a
 * range [lo, hi) of every array. Children are written into the other
 * buffer's copy of the same range, so pending nodes are never overwritten. */
typedef struct {
	int *idx;   /* n sample indices */
	double *x;  /* dx x n inputs, column-major */
	double *y;  /* n x dy outputs */
	double *w;  /* n weights (weighted fits only) */
} nodebuf;

/* Nodes with more values than this (samples x (inputs + 2)) are
 * partitioned column by column; smaller ones in one fused pass. */
#define LARGE_NODE ((size_t)1 << 20)

/* Workspace of one fit, reused by every node of every tree. */
typedef struct {
	const pr_forest_opts *o;
	int n, dx, dy, weighted;
	nodebuf root;         /* every tree's root: the data, inputs by column */
	double *wn;           /* n: the weights scaled by a power of two (weighted fits) */
	double root_sum;      /* unweighted single output: the sum of y */
	nodebuf buf[2];
	int *pos;             /* n: destinations in a large node's partition */
	double *wyc;          /* n x dy: w * (y - node mean) of the current node */
	double *lo, *hi;      /* dx: the node's range of each examined dimension */
	unsigned char *seen;  /* dx: 0 not examined in this node, 1 varies, 2 constant */
	int *cand, *pool;     /* dx: drawable dimensions; without-replacement pool */
	double *sse, *sl, *sr, *ym;  /* dy each */
	span *stk;
	int stk_cap;
	gsl_rng *r;
} builder;

static void builder_free(builder *b)
{
	free(b->root.idx);
	free(b->root.x);
	free(b->wn);
	for (int i = 0; i < 2; i++) {
		free(b->buf[i].idx);
		free(b->buf[i].x);
		free(b->buf[i].y);
		free(b->buf[i].w);
	}
	free(b->wyc);
	free(b->pos);
	free(b->lo);
	free(b->hi);
	free(b->seen);
	free(b->cand);
	free(b->pool);
	free(b->sse);
	free(b->sl);
	free(b->sr);
	free(b->ym);
	free(b->stk);
	gsl_rng_free(b->r);
}

static int builder_alloc(builder *b)
{
	size_t n = (size_t)b->n, dx = (size_t)b->dx, dy = (size_t)b->dy;
	int ok = 1;

	b->root.idx = malloc(n * sizeof *b->root.idx);
	b->root.x = malloc(dx * n * sizeof *b->root.x);
	b->wn = b->weighted ? malloc(n * sizeof *b->wn) : NULL;
	ok = b->root.idx && b->root.x && (b->wn || !b->weighted);
	for (int i = 0; i < 2; i++) {
		nodebuf *nb = b->buf + i;
		nb->idx = malloc(n * sizeof *nb->idx);
		nb->x = malloc(dx * n * sizeof *nb->x);
		nb->y = malloc(n * dy * sizeof *nb->y);
		nb->w = b->weighted ? malloc(n * sizeof *nb->w) : NULL;
		ok = ok && nb->idx && nb->x && nb->y && (nb->w || !b->weighted);
	}
	b->wyc = b->weighted || dy > 1 ? malloc(n * dy * sizeof *b->wyc) : NULL;
	b->pos = malloc(n * sizeof *b->pos);
	b->lo = malloc(dx * sizeof *b->lo);
	b->hi = malloc(dx * sizeof *b->hi);
	b->seen = malloc(dx);
	b->cand = malloc(dx * sizeof *b->cand);
	b->pool = malloc(dx * sizeof *b->pool);
	b->sse = malloc(dy * sizeof(double));
	b->sl = malloc(dy * sizeof(double));
	b->sr = malloc(dy * sizeof(double));
	b->ym = malloc(dy * sizeof(double));
	b->stk_cap = 64;
	b->stk = malloc((size_t)b->stk_cap * sizeof *b->stk);
	b->r = gsl_rng_alloc(gsl_rng_mt19937);
	return ok && (b->wyc || (!b->weighted && dy == 1)) && b->pos && b->lo && b->hi
	       && b->seen && b->cand && b->pool
	       && b->sse && b->sl && b->sr && b->ym && b->stk && b->r;
}

void pr_forest_weights_canonical(double *w, int n)
{
	double wmax = 0;
	int e;

	for (int i = 0; i < n; i++) {
		if (!(w[i] >= 0) || !isfinite(w[i]))
			return;
		wmax = fmax(wmax, w[i]);
	}
	if (!(wmax > 0))
		return;
	for (int i = 0; i < n; i++) {
		double m = frexp(w[i] / wmax, &e);

		w[i] = ldexp(nearbyint(ldexp(m, 24)), e - 24);
	}
}

/* The weights times the power of two that brings the largest into [0.5, 1)
 * (exact): the scores' squares of weighted sums, sl^2 / wl, neither
 * underflow nor overflow whatever the weights' scale, and a power-of-two
 * scale changes no bit of any score or leaf mean. */
static double *scale_weights(const double *w, int n, double *wn)
{
	double wmax = 0;
	int e;

	for (int i = 0; i < n; i++)
		wmax = fmax(wmax, w[i]);
	frexp(wmax, &e);
	for (int i = 0; i < n; i++)
		wn[i] = ldexp(w[i], -e);
	return wn;
}

/* The root node of every tree, built once per fit: sample indices in order,
 * the inputs column by column, the caller's outputs, which are only read (a
 * split writes the children into buf[1]), and the weights scaled. */
static void builder_root(builder *b, const double *X, const double *Y, const double *w)
{
	int n = b->n, dx = b->dx;

	for (int i = 0; i < n; i++) {
		b->root.idx[i] = i;
		for (int d = 0; d < dx; d++)
			b->root.x[(size_t)d * n + i] = X[(size_t)i * dx + d];
	}
	b->root.y = (double *)Y;
	b->root.w = w ? scale_weights(w, n, b->wn) : NULL;
	b->root_sum = 0;
	if (b->dy == 1 && !w)
		for (int i = 0; i < n; i++)
			b->root_sum += Y[i];
}

/* splitmix64: a tree's seed from (forest seed, tree index), independent of
 * the order in which trees are grown. */
static unsigned long tree_seed(uint64_t seed, int t)
{
	uint64_t z = seed + 0x9E3779B97F4A7C15ULL * (uint64_t)(t + 1);

	z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
	z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
	return (unsigned long)(z ^ (z >> 31));
}

/* Four lanes for the vectorisable loops below: gcc -O2 vectorises a loop
 * over k < 4 on such a struct (a constant trip count, a multiple of the
 * vector width) and keeps the struct in registers, while the same code with
 * four scalar variables stays scalar (and longer structs spill). */
typedef struct { double v[4]; } lanes4;

/* The lanes' total, always grouped (0 + 1) + (2 + 3). */
static inline double lanes_total(lanes4 a)
{
	return (a.v[0] + a.v[1]) + (a.v[2] + a.v[3]);
}

/* Four samples of the scans below, lane k taking sample k: a = [x < t] as
 * 0 or 1 is counted into c and a * y summed into s, without a branch. */
static inline void left4(const double *x, const double *y, double t, lanes4 *c, lanes4 *s)
{
	lanes4 a;

	for (int k = 0; k < 4; k++)
		a.v[k] = x[k] < t;
	for (int k = 0; k < 4; k++)
		c->v[k] += a.v[k];
	for (int k = 0; k < 4; k++)
		s->v[k] += a.v[k] * y[k];
}

/* The node's range of dimension d, computed once per node and dimension.
 * Eight independent min/max accumulators (min and max are exact, so the
 * grouping does not matter). */
static void examine(builder *b, const double *x, int m, int d)
{
	lanes4 l0, l1, h0, h1;
	double lo, hi;
	int j;

	for (int k = 0; k < 4; k++)
		l0.v[k] = l1.v[k] = h0.v[k] = h1.v[k] = x[0];
	for (j = 0; j + 8 <= m; j += 8) {
		for (int k = 0; k < 4; k++)
			l0.v[k] = x[j + k] < l0.v[k] ? x[j + k] : l0.v[k];
		for (int k = 0; k < 4; k++)
			l1.v[k] = x[j + k + 4] < l1.v[k] ? x[j + k + 4] : l1.v[k];
		for (int k = 0; k < 4; k++)
			h0.v[k] = x[j + k] > h0.v[k] ? x[j + k] : h0.v[k];
		for (int k = 0; k < 4; k++)
			h1.v[k] = x[j + k + 4] > h1.v[k] ? x[j + k + 4] : h1.v[k];
	}
	lo = l0.v[0];
	hi = h0.v[0];
	for (; j < m; j++) {
		lo = x[j] < lo ? x[j] : lo;
		hi = x[j] > hi ? x[j] : hi;
	}
	for (int k = 0; k < 4; k++) {
		lo = l0.v[k] < lo ? l0.v[k] : lo;
		lo = l1.v[k] < lo ? l1.v[k] : lo;
		hi = h0.v[k] > hi ? h0.v[k] : hi;
		hi = h1.v[k] > hi ? h1.v[k] : hi;
	}
	b->lo[d] = lo;
	b->hi[d] = hi;
	b->seen[d] = hi > lo ? 1 : 2;
}

/* Draw a test dimension uniformly among those not constant in the node
 * (rejection: a constant one leaves the candidates), with replacement or
 * from a pool refilled once exhausted. With replacement a constant one is
 * drawn again at once; without, -2 says one was drawn: as in scikit-learn's
 * max_features, it counts as one of the K draws. -1 if all are constant.
 * xn is the node's first input column; columns are n apart. */
static int draw_dim(builder *b, const double *xn, int m, int *nc, int *np)
{
	for (;;) {
		int d, u;

		if (*nc == 0)
			return -1;
		if (b->o->with_replacement) {
			d = b->cand[gsl_rng_uniform_int(b->r, (unsigned long)*nc)];
		} else {
			if (*np == 0) {
				memcpy(b->pool, b->cand, (size_t)*nc * sizeof *b->pool);
				*np = *nc;
			}
			u = (int)gsl_rng_uniform_int(b->r, (unsigned long)*np);
			d = b->pool[u];
			b->pool[u] = b->pool[--*np];
		}
		if (!b->seen[d])
			examine(b, xn + (size_t)d * b->n, m, d);
		if (b->seen[d] == 1)
			return d;
		for (u = 0; b->cand[u] != d; u++)
			;
		b->cand[u] = b->cand[--*nc];
		if (!b->o->with_replacement)
			return -2;
	}
}

/* Unweighted single output: count and sum of y left of t. The
 * comparison is used as a 0/1 factor, with four independent accumulators
 * (lane k sums the samples j = k mod 4 in order, then (0 + 1) + (2 + 3)), so
 * the loop has no branches and is vectorised (two lanes per SSE2 register).
 * The counts are exact whatever the grouping. */
static int scan_u1(const double *x, const double *y, int m, double t, double *sl)
{
	lanes4 s = { { 0 } }, c0 = { { 0 } }, c1 = { { 0 } };
	int j;

	for (j = 0; j + 8 <= m; j += 8) {
		left4(x + j, y + j, t, &c0, &s);
		left4(x + j + 4, y + j + 4, t, &c1, &s);
	}
	for (; j + 4 <= m; j += 4)
		left4(x + j, y + j, t, &c0, &s);
	for (; j < m; j++) {
		double a = x[j] < t;
		c0.v[0] += a;
		s.v[0] += a * y[j];
	}
	*sl = lanes_total(s);
	return (int)(lanes_total(c0) + lanes_total(c1));
}

/* scan_u1 for two tests at once (one pass over y): the same sums in the same
 * order for each, but the two tests' addition chains interleave, so the loop
 * is not bound by the latency of one chain. */
static void scan_u1x2(const double *xa, double ta, const double *xb, double tb,
                      const double *y, int m, int *nl, double *sl)
{
	lanes4 sa = { { 0 } }, sb = { { 0 } }, ca = { { 0 } }, cb = { { 0 } };
	int j;

	for (j = 0; j + 4 <= m; j += 4) {
		left4(xa + j, y + j, ta, &ca, &sa);
		left4(xb + j, y + j, tb, &cb, &sb);
	}
	for (; j < m; j++) {
		double a = xa[j] < ta, c = xb[j] < tb;
		ca.v[0] += a;
		sa.v[0] += a * y[j];
		cb.v[0] += c;
		sb.v[0] += c * y[j];
	}
	sl[0] = lanes_total(sa);
	sl[1] = lanes_total(sb);
	nl[0] = (int)lanes_total(ca);
	nl[1] = (int)lanes_total(cb);
}

/* Whether y varies in the node: stops at the first differing value, so it
 * costs a few reads except in the (cheap) constant case. */
static int varies(const double *y, int m)
{
	for (int j = 1; j < m; j++)
		if (y[j] != y[0])
			return 1;
	return 0;
}

/* x if the mask is all ones, else +0.0. Added to a sum that starts at +0.0
 * it changes nothing: such a sum is never -0.0 (only -0.0 + -0.0 is), and
 * s + 0.0 == s for every other s, so a sum of picked terms is bit for bit
 * the sum of its own terms in order. */
static inline double pick(double x, uint64_t mask)
{
	uint64_t u;

	memcpy(&u, &x, sizeof u);
	u &= mask;
	memcpy(&x, &u, sizeof x);
	return x;
}

/* One pass of scan_gen over the kw (a constant when inlined) outputs from
 * column k0 of wyc (rows dy apart), into sl[k0..], sr[k0..]. Branch-free,
 * with the sums in registers: the side of x[j] < t mispredicts half the
 * time on a random test, and sums behind b->sl might alias wyc. */
static inline int scan_gen_w(const double *restrict wyc, int dy, int k0, int kw,
                             const double *restrict x, const double *restrict w, int m,
                             double t, double *sl, double *sr, double *wl, double *wr)
{
	lanes4 l = { { 0 } }, r = { { 0 } };
	double a = 0, c = 0;
	int nl = 0;

	for (int j = 0; j < m; j++) {
		const double *v = wyc + (size_t)j * dy + k0;
		const int left = x[j] < t;
		const uint64_t mk = -(uint64_t)left;
		const double wj = w ? w[j] : 1.0;

		nl += left;
		a += pick(wj, mk);
		c += pick(wj, ~mk);
		for (int k = 0; k < kw; k++) {
			l.v[k] += pick(v[k], mk);
			r.v[k] += pick(v[k], ~mk);
		}
	}
	for (int k = 0; k < kw; k++) {
		sl[k0 + k] = l.v[k];
		sr[k0 + k] = r.v[k];
	}
	*wl = a;
	*wr = c;
	return nl;
}

/* General case: left and right weight sums and sums of w * (y - mean), both
 * accumulated, so a light child's sums carry no cancellation error. Outputs
 * four at a time (each pass gives the same counts and weight sums). */
static int scan_gen(builder *b, const double *x, const double *w, int m, double t,
                    double *wl, double *wr)
{
	const int dy = b->dy;
	int nl = 0;

	for (int k0 = 0; k0 < dy; k0 += 4) {
		switch (dy - k0) {
		case 1: nl = scan_gen_w(b->wyc, dy, k0, 1, x, w, m, t, b->sl, b->sr, wl, wr); break;
		case 2: nl = scan_gen_w(b->wyc, dy, k0, 2, x, w, m, t, b->sl, b->sr, wl, wr); break;
		case 3: nl = scan_gen_w(b->wyc, dy, k0, 3, x, w, m, t, b->sl, b->sr, wl, wr); break;
		default: nl = scan_gen_w(b->wyc, dy, k0, 4, x, w, m, t, b->sl, b->sr, wl, wr); break;
		}
	}
	return nl;
}

/* Fall of the weighted sum of squares from parent to children. */
static double reduction(double sl, double sr, double wl, double wr)
{
	double s = sl + sr, red;

	if (wl <= 0 || wr <= 0)
		return 0;
	red = sl * sl / wl + sr * sr / wr - s * s / (wl + wr);
	return red > 0 ? red : 0;
}

/* Centre the node's outputs on their weighted mean, into wyc (times w), with
 * the weighted SSE per output. The mean is taken relative to the first
 * sample, so an output constant in the node gets SSE exactly 0 and takes no
 * part in the score. */
static void centre(builder *b, const double *y, const double *w, int m)
{
	int dy = b->dy;
	double W = 0;

	for (int k = 0; k < dy; k++)
		b->ym[k] = b->sse[k] = 0;
	for (int j = 0; j < m; j++) {
		double wj = w ? w[j] : 1.0;
		W += wj;
		for (int k = 0; k < dy; k++)
			b->ym[k] += wj * (y[(size_t)j * dy + k] - y[k]);
	}
	for (int k = 0; k < dy; k++)
		b->ym[k] = y[k] + (W > 0 ? b->ym[k] / W : 0);
	for (int j = 0; j < m; j++) {
		double *v = b->wyc + (size_t)j * dy, wj = w ? w[j] : 1.0;
		for (int k = 0; k < dy; k++) {
			double e = y[(size_t)j * dy + k] - b->ym[k];
			v[k] = wj * e;
			b->sse[k] += v[k] * e;
		}
	}
}

/* Draw K tests for the node [lo, lo + m) of buffer nb and pick the best
 * scoring one whose children both hold at least n_c samples (ties, e.g. all
 * 0 when the outputs are constant in the node: the first drawn). Returns 0
 * for a leaf. Tests are drawn two at a time and then scored: scoring draws
 * no random numbers, so the draws and the choice are those of one test at a
 * time, and in the common case one pass over y scores both. */
static int choose_split(builder *b, const nodebuf *nb, int lo, int m, double sum, int *bd,
                        double *bt, int *bnl, double *bsl)
{
	const pr_forest_opts *o = b->o;
	const double *xn = nb->x + lo, *w = nb->w ? nb->w + lo : NULL;
	const double *y = nb->y + (size_t)lo * b->dy;
	double best = -INFINITY, mean = sum / m;
	int nc = b->dx, np = 0, found = 0, fast = !w && b->dy == 1, vary = 1, nt;

	if (fast)
		vary = varies(y, m);
	else
		centre(b, y, w, m);
	for (int d = 0; d < b->dx; d++) {
		b->cand[d] = d;
		b->seen[d] = 0;
	}
	/* skip: constant dimensions drawn without replacement, which count as
	 * draws (draw_dim); beyond K only until one dimension varies */
	for (int k = 0, skip = 0; k + skip < o->cuts || k == 0; k += nt) {
		int dd[2], nn[2];
		double tt[2], ss[2] = { 0, 0 };

		for (nt = 0; nt < 2 && (k + nt + skip < o->cuts || k + nt == 0);) {
			int d = draw_dim(b, xn, m, &nc, &np);
			if (d == -2) {
				skip++;
				continue;
			}
			if (d < 0)
				break;
			dd[nt] = d;
			tt[nt++] = b->lo[d] + (b->hi[d] - b->lo[d]) * gsl_rng_uniform(b->r);
		}
		if (nt == 0)
			break;
		if (fast && nt == 2)
			scan_u1x2(xn + (size_t)dd[0] * b->n, tt[0], xn + (size_t)dd[1] * b->n, tt[1], y,
			          m, nn, ss);
		else if (fast)
			nn[0] = scan_u1(xn + (size_t)dd[0] * b->n, y, m, tt[0], ss);
		for (int i = 0; i < nt; i++) {
			int nl = nn[i];
			double sc = 0, wl, wr;

			if (fast) {
				/* One output, no weights: the node SSE is a positive
				 * constant factor of rvr, so the reduction itself ranks
				 * the tests. It is m/(nl nr) (S_l - nl mean)^2, from the
				 * left sum of raw y: the one subtraction loses only
				 * eps |mean| nl against S_l - nl mean. A constant output
				 * scores 0 exactly, as in the general path. */
				double dl = ss[i] - nl * mean;
				if (vary && nl > 0 && nl < m)
					sc = dl * dl * ((double)m / ((double)nl * (m - nl)));
			} else {
				nl = scan_gen(b, xn + (size_t)dd[i] * b->n, w, m, tt[i], &wl, &wr);
				for (int q = 0; q < b->dy; q++)
					if (b->sse[q] > 0)
						sc += reduction(b->sl[q], b->sr[q], wl, wr) /
						      (o->outputs == PR_OUTPUTS_RELATIVE ? b->sse[q] : 1.0);
			}
			if (nl < o->n_c || m - nl < o->n_c)
				continue;
			if (o->score == PR_SCORE_NRVR)
				sc = -sc;
			if (!found || sc > best) {
				found = 1;
				best = sc;
				*bd = dd[i];
				*bt = tt[i];
				*bnl = nl;
				*bsl = ss[i];
			}
		}
		if (nt < 2 && (k + nt + skip < o->cuts || k + nt == 0))
			break;  /* every dimension is constant in the node */
	}
	return found;
}

/* The one-pass partition loop over idx, y (dy = 1, no weights) and the
 * first dx columns. Called with constant dx so that, inlined, each case is
 * a straight loop with no per-element loop over columns. The destination is
 * cl or cr selected by mask arithmetic, in pointer-sized integers (no sign
 * extension per element). */
static inline void part_u1(int m, const double *restrict x, double thr, int nl,
                           const int *restrict si, const double *restrict sy,
                           const double *restrict sx, int *restrict ti, double *restrict ty,
                           double *restrict tx, size_t n, int dx)
{
	ptrdiff_t cl = 0, cr = nl;

	for (ptrdiff_t j = 0; j < m; j++) {
		ptrdiff_t a = x[j] < thr, p = cr ^ ((cl ^ cr) & -a);
		cl += a;
		cr += 1 - a;
		ti[p] = si[j];
		ty[p] = sy[j];
		for (int c = 0; c < dx; c++)
			tx[c * n + p] = sx[c * n + j];
	}
}

/* Stable partition of the node [lo, lo + m) from buffer s into the same range
 * of buffer t: samples with x_d < thr first (nl of them), then the others.
 * Branch-free, one pass: each sample's destination is selected by mask
 * arithmetic (compilers turn ?: into branches, which mispredict half the
 * time on a random split). Children that will be leaves need no inputs.
 * Kept out of line: inlined into the fitting loop, its loops ran short of
 * registers and reloaded pointers from the stack on every element. */
NOINLINE static void partition(builder *b, const nodebuf *s, nodebuf *t, int lo, int m, int d,
                      double thr, int nl)
{
	size_t n = (size_t)b->n;
	int dx = b->dx, dy = b->dy, cl = 0, cr = nl;
	const double *x = s->x + d * n + lo, *sx = s->x + lo, *sy = s->y + (size_t)lo * dy;
	const int *si = s->idx + lo;
	double *tx = t->x + lo, *ty = t->y + (size_t)lo * dy;
	int *ti = t->idx + lo;

	if (nl <= b->o->n_min && m - nl <= b->o->n_min)
		dx = 0;
	if (dy == 1 && !s->w && (size_t)m * (dx + 2) > LARGE_NODE) {
		/* a large node: too many streams at once thrash the caches and
		 * TLB, so record destinations and move one column at a time */
		int *pos = b->pos;
		for (int j = 0; j < m; j++) {
			int a = x[j] < thr, msk = -a, p = (cl & msk) | (cr & ~msk);
			cl += a;
			cr += 1 - a;
			pos[j] = p;
			ti[p] = si[j];
			ty[p] = sy[j];
		}
		for (int c = 0; c < dx; c++) {
			const double *sc = sx + c * n;
			double *tc = tx + c * n;
			for (int j = 0; j < m; j++)
				tc[pos[j]] = sc[j];
		}
		return;
	}
	if (dy == 1 && !s->w) {
		switch (dx) {
		case 0: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, 0); return;
		case 1: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, 1); return;
		case 2: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, 2); return;
		case 3: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, 3); return;
		case 4: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, 4); return;
		case 5: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, 5); return;
		case 6: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, 6); return;
		case 7: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, 7); return;
		case 8: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, 8); return;
		case 9: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, 9); return;
		case 10: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, 10); return;
		case 11: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, 11); return;
		case 12: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, 12); return;
		default: part_u1(m, x, thr, nl, si, sy, sx, ti, ty, tx, n, dx); return;
		}
	}
	for (int j = 0; j < m; j++) {
		int a = x[j] < thr, msk = -a, p = (cl & msk) | (cr & ~msk);
		cl += a;
		cr += 1 - a;
		ti[p] = si[j];
		for (int k = 0; k < dy; k++)
			ty[(size_t)p * dy + k] = sy[(size_t)j * dy + k];
		for (int c = 0; c < dx; c++)
			tx[c * n + p] = sx[c * n + j];
		if (s->w)
			t->w[lo + p] = s->w[lo + j];
	}
}

static int grow_nodes(pr_forest *f)
{
	int cap = f->cap_nodes ? 2 * f->cap_nodes : 1024;
	pr_node *p = realloc(f->node, (size_t)cap * sizeof *p);

	if (!p)
		return PR_ENOMEM;
	f->node = p;
	f->cap_nodes = cap;
	return PR_OK;
}

static int grow_leaves(pr_forest *f)
{
	int cap = f->cap_leaves ? 2 * f->cap_leaves : 512;
	int *s = realloc(f->leaf_start, ((size_t)cap + 1) * sizeof *s);
	double *m;

	if (!s)
		return PR_ENOMEM;
	f->leaf_start = s;
	m = realloc(f->mean, (size_t)cap * f->dy * sizeof *m);
	if (!m)
		return PR_ENOMEM;
	f->mean = m;
	f->cap_leaves = cap;
	return PR_OK;
}

/* Leaf value, eq. 4.2: the mean of the leaf's outputs, weighted when the
 * forest is fitted with weights (the centre the weighted score of eq. 6.3
 * measures spread around); the plain mean if the leaf's weights are all 0. */
static void leaf_mean(int dy, const double *y, const double *w, int m, double *out)
{
	double W = 0;

	if (w)
		for (int j = 0; j < m; j++)
			W += w[j];
	for (int k = 0; k < dy; k++) {
		double s = 0;
		for (int j = 0; j < m; j++)
			s += (W > 0 ? w[j] : 1.0) * y[(size_t)j * dy + k];
		out[k] = s / (W > 0 ? W : m);
	}
}

/* Grow tree t depth first from an explicit stack (right child pushed first,
 * so nodes come out in preorder and leaves left to right). */
static int grow_tree(pr_forest *f, builder *b, int t)
{
	int n = b->n, dy = b->dy, sp = 0;
	int *perm = f->perm + (size_t)t * n;

	f->tree_node0[t] = f->nnodes;
	f->tree_leaf0[t] = f->nleaves;
	b->stk[sp++] = (span){ 0, n, 0, -1, b->root_sum };
	while (sp > 0) {
		span s = b->stk[--sp];
		const nodebuf *nb = s.depth ? b->buf + (s.depth & 1) : &b->root;
		int id = f->nnodes, m = s.hi - s.lo, d = 0, nl = 0;
		double thr = 0, suml = 0;
		pr_node *nd;

		if (pr_interrupted) /* a tree on many samples takes a while: poll per node */
			return PR_EINTR;
		if (id == f->cap_nodes && grow_nodes(f))
			return PR_ENOMEM;
		f->nnodes++;
		nd = f->node + id;
		if (s.parent >= 0)
			f->node[s.parent].right = id;
		if (s.depth > f->max_depth)
			f->max_depth = s.depth;
		if (m > b->o->n_min && choose_split(b, nb, s.lo, m, s.sum, &d, &thr, &nl, &suml)) {
			partition(b, nb, b->buf + !(s.depth & 1), s.lo, m, d, thr, nl);
			if (sp + 2 > b->stk_cap) {
				span *ns = realloc(b->stk, 2 * (size_t)b->stk_cap * sizeof *ns);
				if (!ns)
					return PR_ENOMEM;
				b->stk = ns;
				b->stk_cap *= 2;
			}
			nd->dim = d;
			nd->thr = thr;
			/* the children's sums of y (fast path): the left one is the
			 * chosen test's S_l; drift in the right one moves only the
			 * centring of S_l - nl mean, never a leaf value */
			b->stk[sp++] = (span){ s.lo + nl, s.hi, s.depth + 1, id, s.sum - suml };
			b->stk[sp++] = (span){ s.lo, s.lo + nl, s.depth + 1, -1, suml };
		} else {
			int leaf = f->nleaves;
			if (leaf == f->cap_leaves && grow_leaves(f))
				return PR_ENOMEM;
			nd->dim = -1;
			nd->thr = 0;
			nd->right = leaf;
			f->leaf_start[leaf] = t * n + s.lo;
			memcpy(perm + s.lo, nb->idx + s.lo, (size_t)m * sizeof *perm);
			leaf_mean(dy, nb->y + (size_t)s.lo * dy, nb->w ? nb->w + s.lo : NULL, m,
			          f->mean + (size_t)leaf * dy);
			f->nleaves++;
		}
	}
	return PR_OK;
}

static int check_data(const double *X, int n, int dx, const double *Y, int dy,
                      const double *w, char *err)
{
	double W = 0;

	for (size_t i = 0; i < (size_t)n * dx; i++)
		if (!isfinite(X[i]))
			return pr_err(err, PR_EINVAL, "forest: input row %zu column %zu is not finite",
			              i / dx, i % dx);
	for (size_t i = 0; i < (size_t)n * dy; i++)
		if (!isfinite(Y[i]))
			return pr_err(err, PR_EINVAL, "forest: output row %zu column %zu is not finite",
			              i / dy, i % dy);
	if (!w)
		return PR_OK;
	for (int i = 0; i < n; i++) {
		if (!isfinite(w[i]) || w[i] < 0)
			return pr_err(err, PR_EINVAL, "forest: weight %d must be finite and >= 0 (got %g)",
			              i, w[i]);
		W += w[i];
	}
	if (!(W > 0))
		return pr_err(err, PR_EINVAL, "forest: the weights sum to 0");
	return PR_OK;
}

pr_forest *pr_forest_fit(const pr_forest_opts *o, const double *X, int n, int dx,
                         const double *Y, int dy, const double *w, gsl_rng *rng,
                         char *err)
{
	builder b = { 0 };
	pr_forest *f;
	uint64_t seed;
	int st = PR_ENOMEM;

	if (!o || !X || !Y || !rng) {
		pr_err(err, PR_EINVAL, "forest: missing options, data or generator");
		return NULL;
	}
	if (pr_forest_opts_check(o, NULL, err))
		return NULL;
	if (n < 1 || dx < 1 || dy < 1) {
		pr_err(err, PR_EINVAL, "forest: need n, dx, dy >= 1 (got %d, %d, %d)", n, dx, dy);
		return NULL;
	}
	if (n < o->n_c) {
		pr_err(err, PR_EINVAL, "forest: %d samples, fewer than n_c = %d", n, o->n_c);
		return NULL;
	}
	if ((long long)n * o->trees >= INT_MAX) {
		pr_err(err, PR_EINVAL, "forest: trees x samples = %lld is too large",
		       (long long)n * o->trees);
		return NULL;
	}
	if (check_data(X, n, dx, Y, dy, w, err))
		return NULL;
	f = calloc(1, sizeof *f);
	if (!f) {
		pr_err(err, PR_ENOMEM, "forest: out of memory");
		return NULL;
	}
	f->M = o->trees;
	f->n = n;
	f->dx = dx;
	f->dy = dy;
	f->tree_node0 = malloc(((size_t)f->M + 1) * sizeof *f->tree_node0);
	f->tree_leaf0 = malloc(((size_t)f->M + 1) * sizeof *f->tree_leaf0);
	f->perm = malloc((size_t)f->M * n * sizeof *f->perm);
	b.o = o;
	b.n = n;
	b.dx = dx;
	b.dy = dy;
	b.weighted = w != NULL;
	if (!f->tree_node0 || !f->tree_leaf0 || !f->perm || !builder_alloc(&b)
	    || grow_nodes(f) || grow_leaves(f))
		goto fail;
	builder_root(&b, X, Y, w);
	seed = gsl_rng_get(rng) - gsl_rng_min(rng);
	for (int t = 0; t < f->M; t++) {
		if (pr_interrupted) {
			st = PR_EINTR;
			goto fail;
		}
		gsl_rng_set(b.r, tree_seed(seed, t));
		st = grow_tree(f, &b, t);
		if (st)
			goto fail;
	}
	f->tree_node0[f->M] = f->nnodes;
	f->tree_leaf0[f->M] = f->nleaves;
	f->leaf_start[f->nleaves] = f->M * n;
	builder_free(&b);
	return f;
fail:
	builder_free(&b);
	pr_forest_free(f);
	if (st == PR_EINTR)
		pr_err(err, st, "forest: interrupted");
	else
		pr_err(err, PR_ENOMEM, "forest: out of memory");
	return NULL;
}

/* ---- queries ---------------------------------------------------------- */

int pr_forest_ntrees(const pr_forest *f) { return f->M; }
int pr_forest_nleaves(const pr_forest *f) { return f->nleaves; }
int pr_forest_nsamples(const pr_forest *f) { return f->n; }
int pr_forest_dx(const pr_forest *f) { return f->dx; }
int pr_forest_dy(const pr_forest *f) { return f->dy; }
int pr_forest_nnodes(const pr_forest *f) { return f->nnodes; }

int pr_forest_tree_leaf0(const pr_forest *f, int t)
{
	return t >= 0 && t <= f->M ? f->tree_leaf0[t] : PR_EINVAL;
}

int pr_forest_tree_node0(const pr_forest *f, int t)
{
	return t >= 0 && t <= f->M ? f->tree_node0[t] : PR_EINVAL;
}

const double *pr_forest_leaf_mean(const pr_forest *f, int leaf)
{
	return leaf >= 0 && leaf < f->nleaves ? f->mean + (size_t)leaf * f->dy : NULL;
}

int pr_forest_node(const pr_forest *f, int node, int *dim, double *thr, int *right)
{
	if (node < 0 || node >= f->nnodes)
		return PR_EINVAL;
	if (dim)
		*dim = f->node[node].dim;
	if (thr)
		*thr = f->node[node].thr;
	if (right)
		*right = f->node[node].right;
	return PR_OK;
}

/* eq. 4.2-4.3 */
void pr_forest_predict(const pr_forest *f, const double *x, double *y)
{
	int dy = f->dy;

	for (int k = 0; k < dy; k++)
		y[k] = 0;
	for (int t = 0; t < f->M; t++) {
		const pr_node *nd = f->node + f->tree_node0[t];
		const double *v;

		while (nd->dim >= 0)
			nd = x[nd->dim] < nd->thr ? nd + 1 : f->node + nd->right;
		v = f->mean + (size_t)nd->right * dy;
		for (int k = 0; k < dy; k++)
			y[k] += v[k];
	}
	for (int k = 0; k < dy; k++)
		y[k] /= f->M;
}

/* Tree by tree over all queries, so one tree's nodes stay in cache. Eight
 * queries descend together with branch-free steps: their loads overlap
 * instead of waiting on each other, and random tests cannot mispredict. */
void pr_forest_predict_many(const pr_forest *f, const double *X, int nq, double *Y)
{
	enum { G = 8 };
	int dx = f->dx, dy = f->dy;

	for (size_t i = 0; i < (size_t)nq * dy; i++)
		Y[i] = 0;
	for (int t = 0; t < f->M; t++) {
		int root = f->tree_node0[t];
		for (int i0 = 0; i0 < nq; i0 += G) {
			int g = nq - i0 < G ? nq - i0 : G, cur[G], live = g;
			for (int q = 0; q < g; q++)
				cur[q] = root;
			while (live > 0) {
				live = 0;
				for (int q = 0; q < g; q++) {
					const pr_node *nd = f->node + cur[q];
					int in = nd->dim >= 0, dim = in ? nd->dim : 0;
					int a = X[(size_t)(i0 + q) * dx + dim] < nd->thr, msk = -(a & in);
					int next = ((cur[q] + 1) & msk) | (nd->right & ~msk);
					cur[q] = in ? next : cur[q];
					live += in;
				}
			}
			for (int q = 0; q < g; q++) {
				const double *v = f->mean + (size_t)f->node[cur[q]].right * dy;
				for (int k = 0; k < dy; k++)
					Y[(size_t)(i0 + q) * dy + k] += v[k];
			}
		}
	}
	for (size_t i = 0; i < (size_t)nq * dy; i++)
		Y[i] /= f->M;
}

typedef int (*leaf_fn)(const pr_forest *f, int leaf, void *ctx);

/* Visit every leaf active for x, tree by tree, left to right. A test on a
 * dimension >= dq (an action, for a state-only query) sends x down both
 * branches (section 5.2.1). Pending right children are at most one per level,
 * so a stack of max_depth + 1 entries suffices. */
static int walk(const pr_forest *f, const double *x, int dq, leaf_fn fn, void *ctx)
{
	int local[64], *stk = local, st = PR_OK;

	if (f->max_depth + 1 > 64) {
		stk = malloc(((size_t)f->max_depth + 1) * sizeof *stk);
		if (!stk)
			return PR_ENOMEM;
	}
	for (int t = 0; t < f->M && st == PR_OK; t++) {
		int sp = 0;
		stk[sp++] = f->tree_node0[t];
		while (sp > 0 && st == PR_OK) {
			int node = stk[--sp];
			for (;;) {
				const pr_node *nd = f->node + node;
				if (nd->dim < 0)
					break;
				if (nd->dim >= dq) {
					stk[sp++] = nd->right;
					node++;
				} else {
					node = x[nd->dim] < nd->thr ? node + 1 : nd->right;
				}
			}
			st = fn(f, f->node[node].right, ctx);
		}
	}
	if (stk != local)
		free(stk);
	return st;
}

typedef struct {
	int *leaves;
	int cap, count;
} leaf_list;

static int add_leaf(const pr_forest *f, int leaf, void *ctx)
{
	leaf_list *l = ctx;

	(void)f;
	if (l->count >= l->cap)
		return PR_EINVAL;
	l->leaves[l->count++] = leaf;
	return PR_OK;
}

int pr_forest_active(const pr_forest *f, const double *x, int dq, int *leaves, int cap)
{
	leaf_list l = { leaves, cap, 0 };
	int st;

	if (dq < 0 || dq > f->dx || (dq > 0 && !x) || cap < 0)
		return PR_EINVAL;
	st = walk(f, x, dq, add_leaf, &l);
	return st ? st : l.count;
}

int pr_forest_leaf_samples(const pr_forest *f, int leaf, const int **idx)
{
	if (leaf < 0 || leaf >= f->nleaves)
		return PR_EINVAL;
	*idx = f->perm + f->leaf_start[leaf];
	return f->leaf_start[leaf + 1] - f->leaf_start[leaf];
}

static int add_samples(const pr_forest *f, int leaf, void *ctx)
{
	double *phi = ctx, inc = 1.0 / f->M;

	for (int j = f->leaf_start[leaf]; j < f->leaf_start[leaf + 1]; j++)
		phi[f->perm[j]] += inc;
	return PR_OK;
}

/* eq. 5.5-5.6: row i of Phi^T phi(x) counts the active leaves holding sample i. */
int pr_forest_active_samples(const pr_forest *f, const double *x, int dq, double *phi)
{
	if (dq < 0 || dq > f->dx || (dq > 0 && !x) || !phi)
		return PR_EINVAL;
	for (int i = 0; i < f->n; i++)
		phi[i] = 0;
	return walk(f, x, dq, add_samples, phi);
}

/* ---- saving and loading (docs/forest.md, "File format") ---------------- */

/* A name fits a line of the format: non-empty, no line break. */
static int name_ok(const char *s)
{
	return s && *s && !strpbrk(s, "\r\n");
}

int pr_forest_save(const pr_forest *f, FILE *fp, const char *const *names, char *err)
{
	const int nn = f->dx + f->dy;

	for (int j = 0; names && j < nn; j++)
		if (!name_ok(names[j]))
			return pr_err(err, PR_EINVAL, "forest: column name %d is empty or holds a line break", j);
	fprintf(fp, "poolreps-forest %d\ntrees %d samples %d inputs %d outputs %d nodes %d leaves %d\n",
	        PR_FOREST_FORMAT, f->M, f->n, f->dx, f->dy, f->nnodes, f->nleaves);
	for (int j = 0; j < nn; j++) {
		if (names)
			fprintf(fp, "%s %s\n", j < f->dx ? "input" : "output", names[j]);
		else
			fprintf(fp, "%s %c%d\n", j < f->dx ? "input" : "output", j < f->dx ? 'x' : 'y',
			        j < f->dx ? j : j - f->dx);
	}
	for (int t = 0; t < f->M; t++) {
		fprintf(fp, "tree %d\n", t);
		for (int k = f->tree_node0[t]; k < f->tree_node0[t + 1]; k++) {
			const pr_node *nd = f->node + k;
			const int g = nd->right;

			if (nd->dim >= 0) {
				fprintf(fp, "split %d %a\n", nd->dim, nd->thr);
				continue;
			}
			fprintf(fp, "leaf %d", f->leaf_start[g + 1] - f->leaf_start[g]);
			for (int i = 0; i < f->dy; i++)
				fprintf(fp, " %a", f->mean[(size_t)g * f->dy + i]);
			for (int i = f->leaf_start[g]; i < f->leaf_start[g + 1]; i++)
				fprintf(fp, " %d", f->perm[i]);
			fputc('\n', fp);
		}
	}
	fputs("end\n", fp);
	return ferror(fp) ? pr_err(err, PR_EIO, "forest: write error") : PR_OK;
}

int pr_forest_to_text(const pr_forest *f, const char *const *names, char **text, size_t *len,
                      char *err)
{
	FILE *fp = open_memstream(text, len);
	int rc;

	if (!fp)
		return pr_err(err, PR_ENOMEM, "forest: out of memory");
	rc = pr_forest_save(f, fp, names, err);
	if (fclose(fp) && !rc)
		rc = pr_err(err, PR_ENOMEM, "forest: out of memory");
	if (rc) {
		free(*text);
		*text = NULL;
	}
	return rc;
}

/* The loader's cursor over a NUL-terminated copy of the text. */
typedef struct {
	char *p;          /* the next character */
	size_t len;       /* of the whole text */
	int line;         /* of p, from 1 */
	const char *what; /* file name or "forest" for messages */
	char *err;
} reader;

static int bad(reader *r, const char *why)
{
	return pr_err(r->err, PR_EIO, "%s:%d: %s", r->what, r->line, why);
}

/* The next line's keyword must be kw; p moves past it and one blank. */
static int keyword(reader *r, const char *kw)
{
	size_t n = strlen(kw);

	if (strncmp(r->p, kw, n) || (r->p[n] != ' ' && r->p[n] != '\n'))
		return pr_err(r->err, PR_EIO, "%s:%d: expected '%s'", r->what, r->line, kw);
	r->p += n + (r->p[n] == ' ');
	return PR_OK;
}

static int int_in(reader *r, long lo, long hi, int *out)
{
	char *end;
	long v;

	if (*r->p == ' ')
		++r->p;
	if (!(*r->p >= '0' && *r->p <= '9') && *r->p != '-')
		return bad(r, "expected an integer");
	v = strtol(r->p, &end, 10);
	if (end == r->p || (*end != ' ' && *end != '\n'))
		return bad(r, "expected an integer");
	if (v < lo || v > hi)
		return pr_err(r->err, PR_EIO, "%s:%d: %ld out of range %ld..%ld", r->what, r->line, v, lo, hi);
	r->p = end;
	*out = (int)v;
	return PR_OK;
}

static int num(reader *r, double *out)
{
	char *end;

	if (*r->p == ' ')
		++r->p;
	if (*r->p == ' ' || *r->p == '\n' || !*r->p)
		return bad(r, "expected a number");
	*out = strtod(r->p, &end);
	if (end == r->p || (*end != ' ' && *end != '\n') || !isfinite(*out))
		return bad(r, "expected a finite number");
	r->p = end;
	return PR_OK;
}

static int eol(reader *r)
{
	if (*r->p != '\n')
		return bad(r, "unexpected text at the end of the line");
	++r->p;
	++r->line;
	return PR_OK;
}

/* The header's counts against the shortest text that can hold them, so
 * that what read_head allocates is a small multiple of the file's size:
 * a sample index takes at least 2 bytes in each tree (" 0"), a node line 9
 * ("leaf 0 0\n"), a leaf value 2, a column line 8, a tree line 7. */
static int sizes_fit(const reader *r, const pr_forest *f)
{
	const long long len = (long long)r->len;

	return 2LL * f->M * f->n <= len && 9LL * f->nnodes <= len &&
	       2LL * f->nleaves * f->dy <= len && 8LL * (f->dx + f->dy) <= len && 7LL * f->M <= len;
}

/* "poolreps-forest V" and the sizes line; allocates f's arrays. */
static int read_head(reader *r, pr_forest *f)
{
	int v, rc;

	if (keyword(r, "poolreps-forest"))
		return bad(r, "not a poolreps forest file");
	if ((rc = int_in(r, 0, INT_MAX, &v)))
		return rc;
	if (v != PR_FOREST_FORMAT)
		return pr_err(r->err, PR_EINVAL, "%s: forest format version %d, this library reads "
		              "version %d", r->what, v, PR_FOREST_FORMAT);
	if ((rc = eol(r)) || (rc = keyword(r, "trees")) || (rc = int_in(r, 1, 100000000, &f->M)) ||
	    (rc = keyword(r, " samples")) || (rc = int_in(r, 1, INT_MAX, &f->n)) ||
	    (rc = keyword(r, " inputs")) || (rc = int_in(r, 1, 100000, &f->dx)) ||
	    (rc = keyword(r, " outputs")) || (rc = int_in(r, 1, 100000, &f->dy)) ||
	    (rc = keyword(r, " nodes")) || (rc = int_in(r, 1, INT_MAX, &f->nnodes)) ||
	    (rc = keyword(r, " leaves")) || (rc = int_in(r, 1, INT_MAX, &f->nleaves)) || (rc = eol(r)))
		return rc;
	if ((long long)f->M * f->n >= INT_MAX || f->nleaves > (long long)f->M * f->n ||
	    f->nnodes != 2LL * f->nleaves - f->M)
		return pr_err(r->err, PR_EIO, "%s:2: inconsistent sizes", r->what);
	if (!sizes_fit(r, f))
		return pr_err(r->err, PR_EIO, "%s:2: the sizes claim more than the file holds", r->what);
	f->tree_node0 = malloc(((size_t)f->M + 1) * sizeof *f->tree_node0);
	f->tree_leaf0 = malloc(((size_t)f->M + 1) * sizeof *f->tree_leaf0);
	f->node = malloc((size_t)f->nnodes * sizeof *f->node);
	f->leaf_start = malloc(((size_t)f->nleaves + 1) * sizeof *f->leaf_start);
	f->mean = malloc((size_t)f->nleaves * f->dy * sizeof *f->mean);
	f->perm = malloc((size_t)f->M * f->n * sizeof *f->perm);
	if (!f->tree_node0 || !f->tree_leaf0 || !f->node || !f->leaf_start || !f->mean || !f->perm)
		return pr_err(r->err, PR_ENOMEM, "forest: out of memory");
	return PR_OK;
}

/* A column name as a CSV header holds it (the test CSV is read by these
 * names and the predictions are named after them): no control character,
 * no trailing blank (a CSV reader trims it). */
static const char *name_fault(const char *s, size_t len)
{
	for (size_t i = 0; i < len; i++)
		if ((unsigned char)s[i] < 0x20 || s[i] == 0x7f)
			return "a column name holds a control character";
	return s[len - 1] == ' ' ? "a column name ends in a blank" : NULL;
}

static int name_cmp(const void *a, const void *b)
{
	const char *const *x = a, *const *y = b;
	size_t nx = strcspn(*x, "\n"), ny = strcspn(*y, "\n");
	int c = memcmp(*x, *y, nx < ny ? nx : ny);

	return c ? c : (nx > ny) - (nx < ny);
}

/* No name twice among inputs and outputs: sorted copies of the pointers
 * (each name ends at its line break), equal neighbours. */
static int names_unique(reader *r, char **at, int nn, int first_line)
{
	char **s = malloc((size_t)nn * sizeof *s);
	int rc = PR_OK;

	if (!s)
		return pr_err(r->err, PR_ENOMEM, "forest: out of memory");
	memcpy(s, at, (size_t)nn * sizeof *s);
	qsort(s, (size_t)nn, sizeof *s, name_cmp);
	for (int j = 1; j < nn && !rc; j++)
		if (!name_cmp(s + j - 1, s + j)) {
			int k = 0, len = (int)strcspn(s[j], "\n");

			while (name_cmp(at + k, s + j)) /* the first, then the second */
				k++;
			while (name_cmp(at + ++k, s + j))
				;
			rc = pr_err(r->err, PR_EIO, "%s:%d: column name '%.*s' appears twice", r->what,
			            first_line + k, len > 64 ? 64 : len, s[j]);
		}
	free(s);
	return rc;
}

/* The dx + dy "input NAME" / "output NAME" lines, into one allocation
 * (pointers, then the strings) when names is not NULL. */
static int read_names(reader *r, const pr_forest *f, char ***names)
{
	const int nn = f->dx + f->dy, line0 = r->line;
	char *start = r->p, **out, *s, **at = malloc((size_t)nn * sizeof *at);
	int rc = PR_OK;

	if (!at)
		return pr_err(r->err, PR_ENOMEM, "forest: out of memory");
	for (int j = 0; j < nn && !rc; j++) {
		const char *why;
		size_t len;

		if ((rc = keyword(r, j < f->dx ? "input" : "output")))
			break;
		at[j] = r->p;
		len = strcspn(r->p, "\n");
		if (!len)
			rc = bad(r, "empty column name");
		else if ((why = name_fault(r->p, len)))
			rc = bad(r, why);
		else {
			r->p += len;
			rc = eol(r);
		}
	}
	if (!rc)
		rc = names_unique(r, at, nn, line0);
	free(at);
	if (rc || !names)
		return rc;
	if (!(out = malloc((size_t)nn * sizeof *out + (size_t)(r->p - start))))
		return pr_err(r->err, PR_ENOMEM, "forest: out of memory");
	s = (char *)(out + nn);
	for (int j = 0; j < nn; j++) {
		size_t len;

		start = strchr(start, ' ') + 1;
		len = strcspn(start, "\n");
		out[j] = memcpy(s, start, len);
		s[len] = '\0';
		s += len + 1;
		start += len + 1;
	}
	*names = out;
	return PR_OK;
}

/* One leaf line after "leaf": its count, dy values and sample indices,
 * each sample once per tree (seen marks them). */
static int read_leaf(reader *r, pr_forest *f, int g, int *used, unsigned char *seen)
{
	int c, rc;

	if ((rc = int_in(r, 0, f->n - *used, &c)))
		return rc;
	for (int i = 0; i < f->dy; i++)
		if ((rc = num(r, f->mean + (size_t)g * f->dy + i)))
			return rc;
	for (int i = 0; i < c; i++) {
		int *at = f->perm + f->leaf_start[g] + i;

		if ((rc = int_in(r, 0, f->n - 1, at)))
			return rc;
		if (seen[*at])
			return bad(r, "a sample appears twice in one tree");
		seen[*at] = 1;
	}
	*used += c;
	f->leaf_start[g + 1] = f->leaf_start[g] + c;
	return eol(r);
}

/* Tree t's nodes in preorder. A pending internal node waits for its right
 * child, which is the node after the leaf that completes its left subtree. */
static int read_tree(reader *r, pr_forest *f, int t, int *stk, unsigned char *seen)
{
	int k = f->tree_node0[t], g = f->tree_leaf0[t], sp = 0, depth = 0, used = 0, rc, v;

	if ((rc = keyword(r, "tree")) || (rc = int_in(r, t, t, &v)) || (rc = eol(r)))
		return rc;
	memset(seen, 0, (size_t)f->n);
	for (;; k++) {
		pr_node *nd = f->node + k;

		if (k >= f->nnodes || g >= f->nleaves)
			return bad(r, "more nodes than the header says");
		if (depth > f->max_depth)
			f->max_depth = depth;
		if (!strncmp(r->p, "split ", 6)) {
			r->p += 6;
			if ((rc = int_in(r, 0, f->dx - 1, &nd->dim)) || (rc = num(r, &nd->thr)) || (rc = eol(r)))
				return rc;
			stk[sp++] = k;
			stk[sp++] = ++depth;
			continue;
		}
		if ((rc = keyword(r, "leaf")))
			return bad(r, "expected 'split' or 'leaf'");
		nd->dim = -1;
		nd->thr = 0;
		nd->right = g;
		if ((rc = read_leaf(r, f, g++, &used, seen)))
			return rc;
		if (sp == 0)
			break;
		depth = stk[--sp];
		f->node[stk[--sp]].right = k + 1;
	}
	if (used != f->n)
		return bad(r, "the tree's leaves do not hold every sample once");
	f->tree_node0[t + 1] = k + 1;
	f->tree_leaf0[t + 1] = g;
	return PR_OK;
}

pr_forest *pr_forest_load(const char *text, size_t len, const char *what, char ***names, char *err)
{
	static const char magic[] = "poolreps-forest ";
	reader r = { .len = len, .line = 1, .what = what ? what : "forest", .err = err };
	pr_forest *f = NULL;
	char *buf = NULL;
	int *stk = NULL, rc;
	unsigned char *seen = NULL;

	if (names)
		*names = NULL;
	/* another file given by mistake is refused before it is copied */
	if (len < sizeof magic - 1 || memcmp(text, magic, sizeof magic - 1)) {
		pr_err(err, PR_EIO, "%s:1: not a poolreps forest file", r.what);
		return NULL;
	}
	f = calloc(1, sizeof *f);
	buf = malloc(len + 1);
	if (!f || !buf) {
		rc = pr_err(err, PR_ENOMEM, "forest: out of memory");
		goto done;
	}
	memcpy(buf, text, len);
	buf[len] = '\0';
	r.p = buf;
	if (strlen(buf) != len) {
		rc = bad(&r, "NUL byte in the file");
		goto done;
	}
	if ((rc = read_head(&r, f)) || (rc = read_names(&r, f, names)))
		goto done;
	/* a pending node holds two ints; at most one per level below the root */
	stk = malloc(2 * ((size_t)f->nnodes + 1) * sizeof *stk);
	seen = malloc((size_t)f->n);
	if (!stk || !seen) {
		rc = pr_err(err, PR_ENOMEM, "forest: out of memory");
		goto done;
	}
	f->tree_node0[0] = f->tree_leaf0[0] = f->leaf_start[0] = 0;
	for (int t = 0; t < f->M && !rc; t++) {
		f->leaf_start[f->tree_leaf0[t]] = t * f->n;
		rc = read_tree(&r, f, t, stk, seen);
	}
	if (!rc && (f->tree_node0[f->M] != f->nnodes || f->tree_leaf0[f->M] != f->nleaves))
		rc = bad(&r, "fewer nodes than the header says");
	if (!rc && (rc = keyword(&r, "end")) == PR_OK)
		rc = *r.p == '\n' && !r.p[1] ? PR_OK : bad(&r, "text after 'end'");
	f->cap_nodes = f->nnodes;
	f->cap_leaves = f->nleaves;
done:
	free(buf);
	free(stk);
	free(seen);
	if (rc) {
		pr_forest_free(f);
		if (names) {
			free(*names);
			*names = NULL;
		}
		return NULL;
	}
	return f;
}
