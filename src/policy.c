/* policy.c — Gaussian policies: fixed, linear on hand-made features
 * (weighted ML, eq. 3.10), and tree-based locally weighted regression
 * (eq. 6.4-6.9).
 *
 * Both regressions run in centred, standardised coordinates, so offsets
 * and scales of states and actions do not reach the arithmetic: the
 * intercept comes from weighted means, the slopes from the standardised
 * design (its SVD for the linear fit; for tree-LWR the eigen-decomposition
 * of its correlation matrix, built per query from per-leaf moments: eq.
 * 6.4's weights make every weighted sum a sum over the query's active
 * leaves, and leaf records merge exactly by the pairwise update, so a
 * query costs O(M) instead of O(n)). */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_eigen.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_linalg.h>
#include <gsl/gsl_matrix.h>
#include <gsl/gsl_randist.h>

#include "poolreps/policy.h"
#include "poolreps/internal.h"

/* Singular values of the standardised design below these fractions of the
 * largest are dropped (a pseudo-inverse): the SVD of the design itself
 * resolves them to round-off; from the moments (eigenvalues of the
 * correlation matrix, sig^2) only down to about sqrt(eps). */
#define RCOND_DESIGN 1e-12
#define RCOND_MOMENTS 1e-7
/* Z of eq. 6.9 for weights normalised to sum 1 is 1 - sum w^2 = 1 - 1/ESS;
 * below this there is effectively one sample and no spread to estimate. */
#define ZMIN 1e-12
#define LOG_2PI 1.8378770664093454836

void pr_policy_opts_init(pr_policy_opts *o)
{
	o->target = PR_TARGET_ACTION;
	o->lambda = 1e-10;
	o->min_std = 1e-3;
	pr_forest_opts_init(&o->forest);
	o->forest.trees = 10;
	o->forest.cuts = 20;
	o->forest.n_min = 75;
	o->forest.score = PR_SCORE_RVR;
	o->cov = PR_COV_QUERY;
	o->cov_center = PR_COV_CENTER_NEW;
}

int pr_policy_opts_check(const pr_policy_opts *o, char *err)
{
	if (o->target != PR_TARGET_ACTION && o->target != PR_TARGET_REWARD_STATE)
		return pr_err(err, PR_EINVAL, "policy.target: must be action or reward_state");
	if (!(o->lambda >= 0.0) || !isfinite(o->lambda))
		return pr_err(err, PR_EINVAL, "policy.lambda: must be >= 0 (got %g)", o->lambda);
	if (!(o->min_std > 0.0) || !isfinite(o->min_std))
		return pr_err(err, PR_EINVAL, "policy.min_std: must be > 0 (got %g)", o->min_std);
	if (o->cov != PR_COV_QUERY && o->cov != PR_COV_RESIDUAL)
		return pr_err(err, PR_EINVAL, "policy.cov: must be query or residual");
	if (o->cov_center != PR_COV_CENTER_NEW && o->cov_center != PR_COV_CENTER_OLD)
		return pr_err(err, PR_EINVAL, "policy.cov_center: must be new or old");
	return pr_forest_opts_check(&o->forest, "policy", err);
}

int pr_policy_features_count(int kind, int ds)
{
	switch (kind) {
	case PR_FEATURES_CONST: return 1;
	case PR_FEATURES_AFFINE: return 1 + ds;
	case PR_FEATURES_QUADRATIC: return 1 + ds + ds * (ds + 1) / 2;
	default: return -1;
	}
}

void pr_policy_features_quadratic(const double *s, int ds, double *psi)
{
	int j, k, m = 1 + ds;

	psi[0] = 1.0;
	for (j = 0; j < ds; j++)
		psi[1 + j] = s[j];
	for (j = 0; j < ds; j++)
		for (k = j; k < ds; k++)
			psi[m++] = s[j] * s[k];
}

void pr_policy_features(int kind, const double *s, int ds, double *psi)
{
	int j;

	if (kind == PR_FEATURES_QUADRATIC) {
		pr_policy_features_quadratic(s, ds, psi);
		return;
	}
	psi[0] = 1.0;
	if (kind == PR_FEATURES_AFFINE)
		for (j = 0; j < ds; j++)
			psi[1 + j] = s[j];
}

struct pr_policy {
	int kind, ds, da;
	/* gaussian and linear: mean = W psi(s - xc), fixed covariance */
	int features, nf;
	double *W;          /* da x nf */
	double *xc;         /* ds: the centre the linear features are taken about */
	double *cov;        /* da x da */
	double *V, *lam;    /* cov = V diag(lam) V^T, lam > 0 (floored) */
	double logdet;      /* sum log lam */
	/* tree */
	pr_forest *forest;
	int n, M, cap, nl;
	double *X, *A;      /* n x ds, n x da: states and actions minus zref */
	double *zref;       /* ds + da: the weighted means of the states and actions */
	double *w;          /* n REPS weights */
	double *lm;         /* nl moment records (mom_*): each leaf's samples */
	double *gm;         /* one moment record: all samples */
	double *D;          /* n x da: a_i - m_i, m_i the mean of the policy that
	                       drew sample i (cov_center old), else NULL */
	double *ld, *gd;    /* moment records of D per leaf and overall, or NULL */
	double *w2;         /* nl x nl: sum of w^2 over the samples two leaves
	                       share (a leaf with itself: its own), or NULL when
	                       too large (then sums walk the samples) */
	double gw2;         /* sum of w^2 over all samples */
	int *lpos, gpos;    /* samples with w > 0 per leaf, and overall */
	double lambda, min_std;
	int covmode, center;
};

/* Linear algebra scratch of one size. */
typedef struct {
	int k;
	gsl_matrix *M, *V;
	gsl_vector *ev;
	gsl_eigen_symmv_workspace *ws;
} eig;

static void eig_free(eig *e)
{
	gsl_matrix_free(e->M);
	gsl_matrix_free(e->V);
	gsl_vector_free(e->ev);
	gsl_eigen_symmv_free(e->ws);
}

static int eig_alloc(eig *e, int k)
{
	e->k = k;
	e->M = gsl_matrix_alloc((size_t)k, (size_t)k);
	e->V = gsl_matrix_alloc((size_t)k, (size_t)k);
	e->ev = gsl_vector_alloc((size_t)k);
	e->ws = gsl_eigen_symmv_alloc((size_t)k);
	if (!e->M || !e->V || !e->ev || !e->ws) {
		eig_free(e);
		memset(e, 0, sizeof *e);
		return PR_ENOMEM;
	}
	return PR_OK;
}

struct pr_policy_work {
	int n, ds, da, cap;
	double *what;     /* n: eq. 6.4 weights (residual covariance, no pair table) */
	int *touched;     /* n: the samples with what > 0 */
	int *leaves;      /* cap active leaves */
	double *mom;      /* one moment record */
	double *dmom;     /* one moment record of a - m (cov_center old) */
	double *B;        /* ds x da slopes */
	double *mean, *cov, *cov2, *z, *lam;
	double *sw;       /* ds + ds x da + ds x da: slope-solve scratch */
	eig ek;           /* ds */
	eig ea;           /* da: after a query, the eigenvectors and floored
	                     eigenvalues of ws->cov */
};

void pr_policy_work_free(pr_policy_work *w)
{
	if (!w)
		return;
	free(w->what);
	free(w->touched);
	free(w->leaves);
	free(w->mom);
	free(w->dmom);
	free(w->B);
	free(w->mean);
	free(w->cov);
	free(w->cov2);
	free(w->z);
	free(w->lam);
	free(w->sw);
	eig_free(&w->ek);
	eig_free(&w->ea);
	free(w);
}

/* Doubles in one moment record of ds + da values (states and actions, or
 * da differences and 0): see mom_*. */
static size_t mom_size(int ds, int da)
{
	size_t dz = (size_t)ds + (size_t)da;

	return 1 + dz + dz * dz;
}

static pr_policy_work *work_new(int n, int ds, int da, int cap, char *err)
{
	pr_policy_work *w = calloc(1, sizeof *w);
	size_t k = (size_t)ds, a = (size_t)da;

	if (!w) {
		pr_err(err, PR_ENOMEM, "policy: out of memory");
		return NULL;
	}
	w->n = n;
	w->ds = ds;
	w->da = da;
	w->cap = cap;
	w->what = calloc((size_t)(n > 0 ? n : 1), sizeof *w->what);
	w->touched = calloc((size_t)(n > 0 ? n : 1), sizeof *w->touched);
	w->leaves = calloc((size_t)(cap > 0 ? cap : 1), sizeof *w->leaves);
	w->mom = calloc(mom_size(ds, da) + k + a, sizeof *w->mom); /* + mom_merge's scratch */
	w->dmom = calloc(mom_size(da, 0) + a, sizeof *w->dmom);
	w->B = calloc(k * a + 1, sizeof *w->B);
	w->mean = calloc(a, sizeof *w->mean);
	w->cov = calloc(a * a, sizeof *w->cov);
	w->cov2 = calloc(a * a, sizeof *w->cov2);
	w->z = calloc(a, sizeof *w->z);
	w->lam = calloc(a, sizeof *w->lam);
	w->sw = calloc(k + 2 * k * a + 1, sizeof *w->sw);
	if (!w->what || !w->touched || !w->leaves || !w->mom || !w->dmom || !w->B || !w->mean || !w->cov ||
	    !w->cov2 || !w->z || !w->lam || !w->sw || (ds > 0 && eig_alloc(&w->ek, ds)) ||
	    eig_alloc(&w->ea, da)) {
		pr_policy_work_free(w);
		pr_err(err, PR_ENOMEM, "policy: out of memory");
		return NULL;
	}
	return w;
}

pr_policy_work *pr_policy_work_new(const pr_policy *p, char *err)
{
	return work_new(p->n, p->ds, p->da, p->cap, err);
}

/* The ridge solve shared by both fits, in standardised coordinates: given
 * the SVD of the k-column standardised weighted design, X~ = U diag(sig) V^T,
 * and U^T Y~ (k x da), the slopes b~ = V diag(sig / (sig^2 + lambda)) U^T Y~
 * minimise |X~ b - Y~|^2 + lambda |b|^2. Singular values below rcond times
 * the largest are dropped (a rank-deficient design: minimum-norm slopes,
 * PR_POLICY_PINV). V is k x k row-major (column l is the l-th vector).
 * Returns the flags. */
static int ridge_filter(int k, int da, const double *V, const double *sig, const double *UtY,
                        double lambda, double rcond, double *b)
{
	double smax = 0.0;
	int j, l, m, flags = 0;

	for (l = 0; l < k; l++)
		smax = fmax(smax, sig[l]);
	memset(b, 0, (size_t)k * da * sizeof *b);
	for (l = 0; l < k; l++) {
		double f;

		if (!(sig[l] > rcond * smax)) {
			flags |= PR_POLICY_PINV;
			continue;
		}
		f = sig[l] / (sig[l] * sig[l] + lambda);
		for (m = 0; m < da; m++)
			for (j = 0; j < k; j++)
				b[j * da + m] += V[j * k + l] * f * UtY[l * da + m];
	}
	return flags;
}

/* Slopes B (k x da) of the weighted regression of a on x from centred second
 * moments per unit weight: Cxx (k x k, row stride ldz) and Cxa (k x da, row
 * stride ldz), ridge lambda on the slopes in standardised units (x_j / sd_j).
 * Dimensions with no spread get slope 0 (PR_POLICY_PINV); if none has any,
 * PR_POLICY_MEANONLY. The standardised correlation matrix is X~^T X~ of the
 * standardised design, so its eigen-decomposition is that design's SVD
 * (V, sig^2). sw: k + 2 k da scratch. Returns the flags or PR_ENUM. */
static int slope_solve(int k, int da, const double *Cxx, const double *Cxa, int ldz,
                       double lambda, eig *e, double *sw, double *B)
{
	double *sd = sw, *UtY = sw + k, *bs = UtY + (size_t)k * da;
	int j, l, m, flags = 0, live = 0;

	for (j = 0; j < k; j++) {
		sd[j] = Cxx[j * ldz + j] > 0.0 ? sqrt(Cxx[j * ldz + j]) : 0.0;
		live += sd[j] > 0.0;
	}
	memset(B, 0, (size_t)k * da * sizeof *B);
	if (live < k)
		flags |= PR_POLICY_PINV;
	if (live == 0)
		return flags | PR_POLICY_MEANONLY;
	for (j = 0; j < k; j++)
		for (l = 0; l < k; l++)
			gsl_matrix_set(e->M, (size_t)j, (size_t)l,
			               sd[j] > 0.0 && sd[l] > 0.0 ? Cxx[j * ldz + l] / (sd[j] * sd[l]) : 0.0);
	if (gsl_eigen_symmv(e->M, e->ev, e->V, e->ws) != GSL_SUCCESS)
		return PR_ENUM;
	/* sig_l = sqrt(ev_l); U^T Y~ = diag(1/sig) V^T (standardised Cxa) */
	for (l = 0; l < k; l++) {
		double ev = gsl_vector_get(e->ev, (size_t)l);

		bs[l] = ev > 0.0 ? sqrt(ev) : 0.0;
		for (m = 0; m < da; m++) {
			double t = 0.0;

			for (j = 0; j < k; j++)
				if (sd[j] > 0.0)
					t += gsl_matrix_get(e->V, (size_t)j, (size_t)l) * Cxa[j * ldz + m] / sd[j];
			UtY[l * da + m] = bs[l] > 0.0 ? t / bs[l] : 0.0;
		}
	}
	for (j = 0; j < k; j++)
		for (l = 0; l < k; l++)
			gsl_matrix_set(e->M, (size_t)j, (size_t)l, gsl_matrix_get(e->V, (size_t)j, (size_t)l));
	flags |= ridge_filter(k, da, e->M->data, bs, UtY, lambda, RCOND_MOMENTS, B);
	for (j = 0; j < k; j++)
		for (m = 0; m < da; m++)
			B[j * da + m] = sd[j] > 0.0 ? B[j * da + m] / sd[j] : 0.0;
	return flags;
}

/* Symmetrise C (da x da) and raise its eigenvalues to at least min_std^2,
 * so every direction keeps that much spread and C is positive definite.
 * The eigenvectors and floored eigenvalues stay in e->V and e->ev: sampling
 * and densities use them directly, so no Cholesky factorisation of a badly
 * conditioned C is ever needed. min_std = 0 only lifts eigenvalues to
 * 1e-300 (helpers on a caller's covariance). */
static int sym_eig(int da, const double *C, eig *e)
{
	int j, l;

	for (j = 0; j < da; j++)
		for (l = 0; l < da; l++) {
			if (!isfinite(C[j * da + l]))
				return PR_ENUM;
			gsl_matrix_set(e->M, (size_t)j, (size_t)l, 0.5 * (C[j * da + l] + C[l * da + j]));
		}
	return gsl_eigen_symmv(e->M, e->ev, e->V, e->ws) == GSL_SUCCESS ? PR_OK : PR_ENUM;
}

static int cov_floor(int da, double *C, double min_std, eig *e, int *flags)
{
	double f2 = min_std * min_std, lmax = 0.0;
	int j, l, m;

	if (sym_eig(da, C, e) != PR_OK)
		return PR_ENUM;
	for (m = 0; m < da; m++)
		lmax = fmax(lmax, gsl_vector_get(e->ev, (size_t)m));
	if (!(f2 > 0.0))
		f2 = 1e-300;
	for (m = 0; m < da; m++)
		if (gsl_vector_get(e->ev, (size_t)m) < f2) {
			gsl_vector_set(e->ev, (size_t)m, f2);
			if (flags && min_std > 0.0)
				*flags |= PR_POLICY_FLOOR;
		}
	for (j = 0; j < da; j++)
		for (l = j; l < da; l++) {
			double c = 0.0;

			for (m = 0; m < da; m++)
				c += gsl_matrix_get(e->V, (size_t)j, (size_t)m) * gsl_vector_get(e->ev, (size_t)m) *
				     gsl_matrix_get(e->V, (size_t)l, (size_t)m);
			C[j * da + l] = C[l * da + j] = c;
		}
	return PR_OK;
}

/* Keep the decomposition cov_floor left in e. */
static void keep_eig(int da, const eig *e, double *V, double *lam, double *logdet)
{
	int j, m;

	*logdet = 0.0;
	for (m = 0; m < da; m++) {
		lam[m] = gsl_vector_get(e->ev, (size_t)m);
		*logdet += log(lam[m]);
		for (j = 0; j < da; j++)
			V[j * da + m] = gsl_matrix_get(e->V, (size_t)j, (size_t)m);
	}
}

static pr_policy *policy_alloc(int kind, int ds, int da)
{
	pr_policy *p = calloc(1, sizeof *p);

	if (!p)
		return NULL;
	p->kind = kind;
	p->ds = ds;
	p->da = da;
	p->cov = calloc((size_t)da * da, sizeof *p->cov);
	p->V = calloc((size_t)da * da, sizeof *p->V);
	p->lam = calloc((size_t)da, sizeof *p->lam);
	if (!p->cov || !p->V || !p->lam) {
		pr_policy_free(p);
		return NULL;
	}
	return p;
}

void pr_policy_free(pr_policy *p)
{
	if (!p)
		return;
	free(p->W);
	free(p->cov);
	free(p->V);
	free(p->lam);
	pr_forest_free(p->forest);
	free(p->xc);
	free(p->X);
	free(p->A);
	free(p->zref);
	free(p->w);
	free(p->lm);
	free(p->gm);
	free(p->D);
	free(p->ld);
	free(p->gd);
	free(p->w2);
	free(p->lpos);
	free(p);
}

int pr_policy_ds(const pr_policy *p) { return p->ds; }
int pr_policy_da(const pr_policy *p) { return p->da; }
const pr_forest *pr_policy_forest(const pr_policy *p) { return p->forest; }

/* A fixed-covariance policy of kind GAUSSIAN or LINEAR: mean W psi(s) with
 * W (da x nf) and cov (da x da) checked and copied. */
static pr_policy *fixed_new(int kind, int features, int ds, int da, const double *W,
                            const double *cov, char *err)
{
	pr_policy *p;
	eig e = { 0 };
	int nf = pr_policy_features_count(features, ds), j, l, st;

	if (ds < 0 || da < 1 || nf < 1) {
		pr_err(err, PR_EINVAL, "policy: need da >= 1, ds >= 0 and known features (got %d, %d, %d)",
		       da, ds, features);
		return NULL;
	}
	for (j = 0; j < da * nf; j++)
		if (!isfinite(W[j])) {
			pr_err(err, PR_EINVAL, "policy: mean %d is not finite", j);
			return NULL;
		}
	for (j = 0; j < da; j++)
		for (l = 0; l < da; l++)
			if (!isfinite(cov[j * da + l]) || cov[j * da + l] != cov[l * da + j]) {
				pr_err(err, PR_EINVAL, "policy: covariance is not finite and symmetric");
				return NULL;
			}
	p = policy_alloc(kind, ds, da);
	if (!p || !(p->W = malloc((size_t)da * nf * sizeof *p->W)) ||
	    !(p->xc = calloc((size_t)ds + 1, sizeof *p->xc)) || eig_alloc(&e, da)) {
		pr_policy_free(p);
		pr_err(err, PR_ENOMEM, "policy: out of memory");
		return NULL;
	}
	p->features = features;
	p->nf = nf;
	memcpy(p->W, W, (size_t)da * nf * sizeof *W);
	memcpy(p->cov, cov, (size_t)da * da * sizeof *cov);
	st = sym_eig(da, cov, &e);
	for (j = 0; st == PR_OK && j < da; j++)
		if (!(gsl_vector_get(e.ev, (size_t)j) > 0.0))
			st = PR_EINVAL;
	if (st != PR_OK) {
		eig_free(&e);
		pr_policy_free(p);
		pr_err(err, PR_ENUM, "policy: covariance is not positive definite");
		return NULL;
	}
	keep_eig(da, &e, p->V, p->lam, &p->logdet);
	eig_free(&e);
	return p;
}

pr_policy *pr_policy_gaussian_new(int ds, int da, const double *mean, const double *cov,
                                  char *err)
{
	return fixed_new(PR_POLICY_GAUSSIAN, PR_FEATURES_CONST, ds, da, mean, cov, err);
}

pr_policy *pr_policy_linear_new(int features, int ds, int da, const double *W,
                                const double *cov, char *err)
{
	return fixed_new(PR_POLICY_LINEAR, features, ds, da, W, cov, err);
}

/* W of a linear policy in the features of s itself: the fit keeps
 * W psi(s - xc) (xc its weighted mean state); expanding psi(s - xc) gives
 * the same mean as W' psi(s) (exact in exact arithmetic; evaluated far from
 * xc, W' psi(s) cancels where W psi(s - xc) does not). */
static void uncentre(const pr_policy *p, double *W)
{
	int j, k, c, m, nf = p->nf, ds = p->ds;
	const double *x = p->xc;

	memcpy(W, p->W, (size_t)p->da * nf * sizeof *W);
	if (nf == 1 || !x)
		return;
	for (c = 0; c < p->da; c++) {
		double *w = W + (size_t)c * nf;
		const double *v = p->W + (size_t)c * nf;

		/* [1, u]: w_0 - sum_j w_j x_j */
		for (j = 0; j < ds; j++)
			w[0] -= v[1 + j] * x[j];
		if (p->features != PR_FEATURES_QUADRATIC)
			continue;
		/* u_j u_k = s_j s_k - x_k s_j - x_j s_k + x_j x_k */
		m = 1 + ds;
		for (j = 0; j < ds; j++)
			for (k = j; k < ds; k++, m++) {
				w[1 + j] -= v[m] * x[k];
				w[1 + k] -= v[m] * x[j];
				w[0] += v[m] * x[j] * x[k];
			}
	}
}

int pr_policy_linear_params(const pr_policy *p, double *W, double *cov, char *err)
{
	if (p->kind == PR_POLICY_TREE)
		return pr_err(err, PR_EINVAL, "policy: a tree policy has no fixed parameters");
	if (W)
		uncentre(p, W);
	if (cov)
		memcpy(cov, p->cov, (size_t)p->da * p->da * sizeof *cov);
	return PR_OK;
}

/* Weights whose largest lies outside [2^-100, 2^100] are multiplied by
 * *unit, a power of two with an even exponent that brings it into
 * [2^-2, 2), before anything squares them (sums of w^2 would under- or
 * overflow at 1e-170 or 1e160). Powers of two scale exactly and square
 * roots of even powers are exact, so a fit on the scaled weights is the
 * fit on the raw ones; weights inside the range are used as they are. */
#define WEIGHT_RANGE 100

/* Shared checks of fitting data; returns the sum of the weights times
 * *unit via *sw (see WEIGHT_RANGE). */
static int check_data(const pr_policy_data *d, int need_y, double *sw, double *unit, char *err)
{
	double wmax = 0.0;
	size_t i;
	int e;

	if (d->n < 1 || d->ds < 1 || d->da < 1)
		return pr_err(err, PR_EINVAL, "policy: need n, ds, da >= 1 (got %d, %d, %d)",
		              d->n, d->ds, d->da);
	if (!d->S || !d->A)
		return pr_err(err, PR_EINVAL, "policy: missing states or actions");
	if (need_y && (!d->Y || d->dy < 1))
		return pr_err(err, PR_EINVAL, "policy: target reward_state needs reward-ball positions");
	for (i = 0; i < (size_t)d->n * d->ds; i++)
		if (!isfinite(d->S[i]))
			return pr_err(err, PR_EINVAL, "policy: sample %zu: state %zu is not finite",
			              i / d->ds, i % d->ds);
	for (i = 0; i < (size_t)d->n * d->da; i++)
		if (!isfinite(d->A[i]))
			return pr_err(err, PR_EINVAL, "policy: sample %zu: action %zu is not finite",
			              i / d->da, i % d->da);
	if (need_y)
		for (i = 0; i < (size_t)d->n * d->dy; i++)
			if (!isfinite(d->Y[i]))
				return pr_err(err, PR_EINVAL,
				              "policy: sample %zu: reward state %zu is not finite",
				              i / d->dy, i % d->dy);
	*sw = 0.0;
	for (i = 0; i < (size_t)d->n; i++) {
		double wi = d->w ? d->w[i] : 1.0;

		if (!isfinite(wi) || wi < 0.0)
			return pr_err(err, PR_EINVAL, "policy: sample %zu: weight must be finite and >= 0 (got %g)",
			              i, wi);
		wmax = fmax(wmax, wi);
	}
	*unit = 1.0;
	frexp(wmax, &e);
	if (wmax > 0.0 && (e > WEIGHT_RANGE || e < -WEIGHT_RANGE))
		*unit = ldexp(1.0, -2 * (e / 2));
	for (i = 0; i < (size_t)d->n; i++)
		*sw += (d->w ? d->w[i] : 1.0) * *unit;
	if (!(*sw > 0.0) || !isfinite(*sw))
		return pr_err(err, PR_EINVAL, "policy: the weights sum to 0");
	return PR_OK;
}

/* B (nf x da) of a = B^T psi with psi_0 = 1, by weighted least squares with
 * weights w (sum 1) in centred, standardised coordinates: the other columns
 * are centred on their weighted means and divided by their weighted
 * standard deviations, the SVD of the weighted design (one-sided Jacobi)
 * gives ridge_filter's slopes, and the intercept follows from the means, so
 * it is not penalised. Returns the flags or a negative status. */
static int design_solve(int n, int nf, int da, const double *X, const double *w,
                        const double *A, double lambda, double *B)
{
	const int k = nf - 1;
	const size_t kk = (size_t)(k > 0 ? k : 1);
	int i, j, l, c, m = 0, r = 0, rows, live = 0, flags = 0, st;
	double *mean = calloc((size_t)nf + (size_t)da + kk * (1 + 2 * (size_t)da), sizeof *mean);
	double *abar, *sd, *UtY, *bs;
	gsl_matrix *D = NULL, *Y = NULL, *V = NULL;
	gsl_vector *sig = NULL;

	for (i = 0; i < n; i++)
		m += w[i] > 0.0;
	rows = m > k ? m : k;
	if (k > 0) {
		D = gsl_matrix_calloc((size_t)rows, (size_t)k);
		Y = gsl_matrix_calloc((size_t)rows, (size_t)da);
		V = gsl_matrix_alloc((size_t)k, (size_t)k);
		sig = gsl_vector_alloc((size_t)k);
	}
	if (!mean || (k > 0 && (!D || !Y || !V || !sig))) {
		st = PR_ENOMEM;
		goto done;
	}
	abar = mean + nf;
	sd = abar + da;
	UtY = sd + kk;
	bs = UtY + kk * (size_t)da;
	/* weighted means of psi_1.. and a, twice (the second pass takes out the
	 * first's round-off), and the standard deviations of psi_1.. */
	for (j = 1; j < nf + da; j++) {
		double mu = 0.0, cr = 0.0;

		for (i = 0; i < n; i++)
			mu += w[i] * (j < nf ? X[(size_t)i * nf + j] : A[(size_t)i * da + j - nf]);
		for (i = 0; i < n; i++)
			cr += w[i] * ((j < nf ? X[(size_t)i * nf + j] : A[(size_t)i * da + j - nf]) - mu);
		*(j < nf ? &mean[j] : &abar[j - nf]) = mu + cr;
	}
	for (j = 0; j < k; j++) {
		double v = 0.0;

		for (i = 0; i < n; i++)
			v += w[i] * (X[(size_t)i * nf + 1 + j] - mean[1 + j]) * (X[(size_t)i * nf + 1 + j] - mean[1 + j]);
		sd[j] = v > 0.0 ? sqrt(v) : 0.0;
		live += sd[j] > 0.0;
	}
	memset(B, 0, (size_t)nf * da * sizeof *B);
	if (live < k)
		flags |= PR_POLICY_PINV;
	if (k > 0 && live == 0)
		flags |= PR_POLICY_MEANONLY;
	if (live > 0) {
		for (i = 0; i < n; i++) {
			double sq = sqrt(w[i]);

			if (!(w[i] > 0.0))
				continue;
			for (j = 0; j < k; j++)
				gsl_matrix_set(D, (size_t)r, (size_t)j, sd[j] > 0.0 ?
				               sq * (X[(size_t)i * nf + 1 + j] - mean[1 + j]) / sd[j] : 0.0);
			for (j = 0; j < da; j++)
				gsl_matrix_set(Y, (size_t)r, (size_t)j, sq * (A[(size_t)i * da + j] - abar[j]));
			r++;
		}
		if (gsl_linalg_SV_decomp_jacobi(D, V, sig) != GSL_SUCCESS) {
			st = PR_ENUM;
			goto done;
		}
		/* D now holds U */
		for (l = 0; l < k; l++)
			for (c = 0; c < da; c++) {
				double t = 0.0;

				for (i = 0; i < rows; i++)
					t += gsl_matrix_get(D, (size_t)i, (size_t)l) * gsl_matrix_get(Y, (size_t)i, (size_t)c);
				UtY[l * da + c] = t;
			}
		flags |= ridge_filter(k, da, V->data, sig->data, UtY, lambda, RCOND_DESIGN, bs);
		for (j = 0; j < k; j++)
			for (c = 0; c < da; c++)
				B[(1 + j) * da + c] = sd[j] > 0.0 ? bs[j * da + c] / sd[j] : 0.0;
	}
	for (c = 0; c < da; c++) {
		B[c] = abar[c];
		for (l = 1; l < nf; l++)
			B[c] -= B[l * da + c] * mean[l];
	}
	st = flags;
done:
	free(mean);
	gsl_matrix_free(D);
	gsl_matrix_free(Y);
	gsl_matrix_free(V);
	gsl_vector_free(sig);
	return st;
}

/* The covariance centre: PR_COV_CENTER_OLD needs finite sampling means. */
static int check_centres(const pr_policy_data *d, int cov_center, char *err)
{
	size_t i;

	if (cov_center != PR_COV_CENTER_NEW && cov_center != PR_COV_CENTER_OLD)
		return pr_err(err, PR_EINVAL, "policy.cov_center: must be new or old");
	if (cov_center == PR_COV_CENTER_NEW)
		return PR_OK;
	if (!d->M)
		return pr_err(err, PR_EINVAL, "policy.cov_center: old needs the sampling means");
	for (i = 0; i < (size_t)d->n * d->da; i++)
		if (!isfinite(d->M[i]))
			return pr_err(err, PR_EINVAL, "policy: sample %zu: sampling mean %zu is not finite",
			              i / d->da, i % d->da);
	return PR_OK;
}

/* Weighted ML (eq. 3.10) of a linear-Gaussian policy: with w normalised to
 * sum 1, the weighted least-squares W (design_solve, features of the states
 * taken about their weighted mean xc) maximises
 * sum w_i log N(a_i | W psi_i, Sigma) for any Sigma, and then
 * Sigma = sum w_i r_i r_i^T, r_i = a_i - c_i with the centre c_i = W psi_i
 * (PR_COV_CENTER_NEW) or the sampling mean M_i (PR_COV_CENTER_OLD). */
pr_policy *pr_policy_linear_fit(int features, const pr_policy_data *d, double lambda,
                                double min_std, int cov_center, int *flags, char *err)
{
	pr_policy *p = NULL, *fit = NULL;
	double *X = NULL, *wn = NULL, *rhs = NULL, *B = NULL, *u = NULL, sw, unit, *r;
	eig ea = { 0 };
	int nf, i, j, l, f = 0, st;

	if (flags)
		*flags = 0;
	nf = pr_policy_features_count(features, d->ds);
	if (nf < 0) {
		pr_err(err, PR_EINVAL, "policy: unknown feature kind %d", features);
		return NULL;
	}
	if (!(lambda >= 0.0) || !isfinite(lambda) || !(min_std >= 0.0) || !isfinite(min_std)) {
		pr_err(err, PR_EINVAL, "policy: lambda and min_std must be finite and >= 0");
		return NULL;
	}
	if (check_data(d, 0, &sw, &unit, err) != PR_OK || check_centres(d, cov_center, err) != PR_OK)
		return NULL;
	p = policy_alloc(PR_POLICY_LINEAR, d->ds, d->da);
	X = malloc((size_t)d->n * nf * sizeof *X);
	wn = malloc((size_t)d->n * sizeof *wn);
	rhs = malloc((size_t)nf * d->da * sizeof *rhs);
	B = malloc((size_t)nf * d->da * sizeof *B);
	u = malloc((size_t)d->ds * sizeof *u);
	if (!p || !X || !wn || !rhs || !B || !u || eig_alloc(&ea, d->da) ||
	    !(p->W = malloc((size_t)d->da * nf * sizeof *p->W)) ||
	    !(p->xc = calloc((size_t)d->ds + 1, sizeof *p->xc))) {
		pr_err(err, PR_ENOMEM, "policy: out of memory");
		goto fail;
	}
	p->features = features;
	p->nf = nf;
	for (i = 0; i < d->n; i++)
		wn[i] = (d->w ? d->w[i] : 1.0) * unit / sw;
	for (i = 0; i < d->n; i++)
		for (j = 0; j < d->ds; j++)
			p->xc[j] += wn[i] * d->S[(size_t)i * d->ds + j];
	for (i = 0; i < d->n; i++) {
		/* psi(s - xc): the same model, but the features do not depend on
		 * where the states sit (offsets would swamp the quadratic terms) */
		for (j = 0; j < d->ds; j++)
			u[j] = d->S[(size_t)i * d->ds + j] - p->xc[j];
		pr_policy_features(features, u, d->ds, X + (size_t)i * nf);
	}
	st = design_solve(d->n, nf, d->da, X, wn, d->A, lambda, B);
	if (st < 0) {
		pr_err(err, st, st == PR_ENOMEM ? "policy: out of memory" : "policy: weighted regression failed");
		goto fail;
	}
	f |= st;
	for (j = 0; j < d->da; j++)
		for (l = 0; l < nf; l++)
			p->W[j * nf + l] = B[l * d->da + j];
	/* ML covariance of the residuals, weights summing to 1, around the new
	 * fit or around the sampling means (cov_center) */
	r = rhs; /* da scratch */
	for (i = 0; i < d->n; i++) {
		if (!(wn[i] > 0.0))
			continue;
		for (j = 0; j < d->da; j++) {
			r[j] = d->A[(size_t)i * d->da + j];
			if (cov_center == PR_COV_CENTER_OLD)
				r[j] -= d->M[(size_t)i * d->da + j];
			else
				for (l = 0; l < nf; l++)
					r[j] -= p->W[j * nf + l] * X[(size_t)i * nf + l];
		}
		for (j = 0; j < d->da; j++)
			for (l = 0; l < d->da; l++)
				p->cov[j * d->da + l] += wn[i] * r[j] * r[l];
	}
	if (cov_floor(d->da, p->cov, min_std, &ea, &f) != PR_OK) {
		pr_err(err, PR_ENUM, "policy: covariance eigen-decomposition failed");
		goto fail;
	}
	keep_eig(d->da, &ea, p->V, p->lam, &p->logdet);
	if (flags)
		*flags = f;
	fit = p; /* the scratch goes on either path; a failed fit with it */
	p = NULL;
fail:
	free(X);
	free(wn);
	free(rhs);
	free(B);
	free(u);
	eig_free(&ea);
	pr_policy_free(p);
	return fit;
}

/* ---- moment records ----
 * One record summarises weighted samples z = (x, a) (dz = ds + da values,
 * relative to p->zref; or z = a - m, the residuals about the sampling
 * means, with ds = da and no second block): rec[0] = sum w, rec[1..dz] =
 * the weighted mean, then the dz x dz centred sums
 * sum w (z - mean)(z - mean)^T. */

/* The record of samples idx (count k) with weights w: z_i is row i of X
 * (ds values) followed by row i of A (da values). */
static void mom_of(const double *w, const int *idx, int k, const double *X, int ds,
                   const double *A, int da, double *rec)
{
	const int dz = ds + da;
	double *mu = rec + 1, *S = rec + 1 + dz;
	int i, j, l, pass;

	memset(rec, 0, mom_size(ds, da) * sizeof *rec);
	for (i = 0; i < k; i++)
		rec[0] += w[idx[i]];
	if (!(rec[0] > 0.0))
		return;
	/* the mean twice: the second pass takes out the first's round-off */
	for (pass = 0; pass < 2; pass++) {
		double c[64], *cc = dz <= 64 ? c : S; /* S is free scratch until the end */

		memset(cc, 0, (size_t)dz * sizeof *cc);
		for (i = 0; i < k; i++) {
			const double wi = w[idx[i]], *x = X + (size_t)idx[i] * ds,
			             *a = A + (size_t)idx[i] * da;

			for (j = 0; j < dz; j++)
				cc[j] += wi * ((j < ds ? x[j] : a[j - ds]) - mu[j]);
		}
		for (j = 0; j < dz; j++)
			mu[j] += cc[j] / rec[0];
	}
	memset(S, 0, (size_t)dz * dz * sizeof *S);
	for (i = 0; i < k; i++) {
		const double wi = w[idx[i]], *x = X + (size_t)idx[i] * ds, *a = A + (size_t)idx[i] * da;

		for (j = 0; j < dz; j++) {
			double dj = wi * ((j < ds ? x[j] : a[j - ds]) - mu[j]);

			for (l = j; l < dz; l++)
				S[j * dz + l] += dj * ((l < ds ? x[l] : a[l - ds]) - mu[l]);
		}
	}
	for (j = 0; j < dz; j++)
		for (l = 0; l < j; l++)
			S[j * dz + l] = S[l * dz + j];
}

/* acc <- acc and r pooled (the pairwise update of Chan, Golub and LeVeque:
 * no sums of squares about zero, so nothing cancels). */
static void mom_merge(int dz, double *acc, const double *r)
{
	double Wa = acc[0], Wb = r[0], W = Wa + Wb, f, *d;
	int j, l;

	if (!(Wb > 0.0))
		return;
	if (!(Wa > 0.0)) {
		memcpy(acc, r, (1 + (size_t)dz + (size_t)dz * dz) * sizeof *acc);
		return;
	}
	f = Wa * Wb / W;
	d = acc + 1 + dz + (size_t)dz * dz; /* dz scratch after the record */
	for (j = 0; j < dz; j++)
		d[j] = r[1 + j] - acc[1 + j];
	for (j = 0; j < dz; j++) {
		acc[1 + j] += d[j] * (Wb / W);
		for (l = 0; l < dz; l++)
			acc[1 + dz + j * dz + l] += r[1 + dz + j * dz + l] + f * d[j] * d[l];
	}
	acc[0] = W;
}

/* The samples as the fit keeps them: weights w-hat = w unit, states and
 * actions relative to their weighted means (what the regressions see no
 * longer depends on offsets), and with cov_center old each sample's
 * residual about its own sampling mean; all[i] = i. PR_ENOMEM or PR_OK. */
static int centred_samples(pr_policy *p, const pr_policy_data *d, double sw, double unit, int old,
                           int *all)
{
	const int ds = d->ds, da = d->da;
	int i, j;

	p->X = malloc((size_t)d->n * ds * sizeof *p->X);
	p->A = malloc((size_t)d->n * da * sizeof *p->A);
	p->zref = calloc((size_t)(ds + da), sizeof *p->zref);
	p->w = malloc((size_t)d->n * sizeof *p->w);
	if (old)
		p->D = malloc((size_t)d->n * da * sizeof *p->D);
	if (!p->X || !p->A || !p->zref || !p->w || !all || (old && !p->D))
		return PR_ENOMEM;
	for (i = 0; i < d->n; i++) {
		p->w[i] = (d->w ? d->w[i] : 1.0) * unit;
		all[i] = i;
	}
	for (i = 0; i < d->n; i++)
		for (j = 0; j < ds + da; j++)
			p->zref[j] += p->w[i] / sw * (j < ds ? d->S[(size_t)i * ds + j] : d->A[(size_t)i * da + j - ds]);
	for (i = 0; i < d->n; i++) {
		for (j = 0; j < ds; j++)
			p->X[(size_t)i * ds + j] = d->S[(size_t)i * ds + j] - p->zref[j];
		for (j = 0; j < da; j++)
			p->A[(size_t)i * da + j] = d->A[(size_t)i * da + j] - p->zref[ds + j];
	}
	for (i = 0; old && i < d->n * da; i++)
		p->D[i] = d->A[i] - d->M[i];
	return PR_OK;
}

/* Per leaf and overall the moment records (and with cov_center old those
 * of the residuals), the count of positive weights and sum w-hat^2 (eq. 6.9). */
static int leaf_moments(pr_policy *p, const pr_policy_data *d, int old, const int *all)
{
	const int ds = d->ds, da = d->da;
	const size_t LM = mom_size(ds, da), LD = mom_size(da, 0);
	int i, l;

	p->lm = malloc((size_t)p->nl * LM * sizeof *p->lm);
	p->gm = malloc((LM + (size_t)(ds + da)) * sizeof *p->gm);
	p->lpos = calloc((size_t)p->nl, sizeof *p->lpos);
	if ((size_t)p->nl * (size_t)p->nl <= 4u << 20)
		p->w2 = calloc((size_t)p->nl * (size_t)p->nl, sizeof *p->w2);
	if (old) {
		p->ld = malloc((size_t)p->nl * LD * sizeof *p->ld);
		p->gd = malloc(LD * sizeof *p->gd);
	}
	if (!p->lm || !p->gm || !p->lpos || ((size_t)p->nl * (size_t)p->nl <= 4u << 20 && !p->w2) ||
	    (old && (!p->ld || !p->gd)))
		return PR_ENOMEM;
	for (l = 0; l < p->nl; l++) {
		const int *idx;
		int k = pr_forest_leaf_samples(p->forest, l, &idx);

		mom_of(p->w, idx, k, p->X, ds, p->A, da, p->lm + (size_t)l * LM);
		if (old)
			mom_of(p->w, idx, k, p->D, da, p->D, 0, p->ld + (size_t)l * LD);
		for (i = 0; i < k; i++)
			p->lpos[l] += p->w[idx[i]] > 0.0;
	}
	mom_of(p->w, all, d->n, p->X, ds, p->A, da, p->gm);
	if (old)
		mom_of(p->w, all, d->n, p->D, da, p->D, 0, p->gd);
	p->gw2 = 0.0;
	p->gpos = 0;
	for (i = 0; i < d->n; i++) {
		p->gw2 += p->w[i] * p->w[i];
		p->gpos += p->w[i] > 0.0;
	}
	return PR_OK;
}

/* Per pair of leaves, the sum of w-hat^2 over the samples they share
 * (eq. 6.9), when the table fits (p->w2). */
static int shared_weights(pr_policy *p, const pr_policy_data *d, char *err)
{
	int *lv, i, u, v;

	if (!p->w2)
		return PR_OK;
	if (!(lv = malloc((size_t)p->M * sizeof *lv)))
		return pr_err(err, PR_ENOMEM, "policy: out of memory");
	for (i = 0; i < d->n; i++) {
		double w2 = p->w[i] * p->w[i];

		if (pr_forest_active(p->forest, d->S + (size_t)i * d->ds, d->ds, lv, p->M) != p->M) {
			free(lv);
			return pr_err(err, PR_ENUM, "policy: forest query failed");
		}
		for (u = 0; u < p->M; u++)
			for (v = 0; v < p->M; v++)
				p->w2[(size_t)lv[u] * p->nl + lv[v]] += w2;
	}
	free(lv);
	return PR_OK;
}

pr_policy *pr_policy_tree_fit(const pr_policy_opts *o, const pr_policy_data *d,
                              gsl_rng *rng, char *err)
{
	pr_policy *p;
	const int reward = o->target == PR_TARGET_REWARD_STATE, ds = d->ds, da = d->da;
	const int old = o->cov_center == PR_COV_CENTER_OLD;
	double sw, unit;
	int *all = NULL, rc;

	if (pr_policy_opts_check(o, err) != PR_OK || check_data(d, reward, &sw, &unit, err) != PR_OK ||
	    check_centres(d, o->cov_center, err) != PR_OK)
		return NULL;
	p = policy_alloc(PR_POLICY_TREE, ds, da);
	if (!p) {
		pr_err(err, PR_ENOMEM, "policy: out of memory");
		return NULL;
	}
	p->n = d->n;
	/* lambda acts on the raw weights (eq. 6.6): lambda / sum w-hat is
	 * lambda unit / (unit sum w-hat), exactly */
	p->lambda = o->lambda * unit;
	p->min_std = o->min_std;
	p->covmode = o->cov;
	p->center = o->cov_center;
	all = malloc((size_t)d->n * sizeof *all);
	if (centred_samples(p, d, sw, unit, old, all) != PR_OK) {
		free(all);
		pr_policy_free(p);
		pr_err(err, PR_ENOMEM, "policy: out of memory");
		return NULL;
	}
	/* eq. 6.3: the weighted score uses the REPS weights */
	p->forest = pr_forest_fit(&o->forest, d->S, d->n, ds, reward ? d->Y : d->A,
	                          reward ? d->dy : da, p->w, rng, err);
	if (!p->forest) {
		free(all);
		pr_policy_free(p);
		return NULL;
	}
	p->M = pr_forest_ntrees(p->forest);
	p->cap = p->M;
	p->nl = pr_forest_nleaves(p->forest);
	if ((rc = leaf_moments(p, d, old, all)) != PR_OK)
		pr_err(err, PR_ENOMEM, "policy: out of memory");
	else
		rc = shared_weights(p, d, err);
	free(all);
	if (rc != PR_OK) {
		pr_policy_free(p);
		return NULL;
	}
	return p;
}

/* eq. 6.4 weights w-hat (ws->what, the nonzero ones listed in ws->touched)
 * by walking the samples of the active leaves; returns their count. */
static int walk_weights(const pr_policy *p, const int *leaves, int nl, pr_policy_work *ws)
{
	int t, i, nt = 0;

	for (t = 0; t < nl; t++) {
		const int *idx;
		int m = pr_forest_leaf_samples(p->forest, leaves[t], &idx);

		/* w_i/M times the number of active leaves shared with s */
		for (i = 0; i < m; i++) {
			if (ws->what[idx[i]] == 0.0 && p->w[idx[i]] > 0.0)
				ws->touched[nt++] = idx[i];
			ws->what[idx[i]] += p->w[idx[i]] / p->M;
		}
	}
	return nt;
}

static void unwalk(pr_policy_work *ws, int nt)
{
	int k;

	for (k = 0; k < nt; k++)
		ws->what[ws->touched[k]] = 0.0;
}

/* The residual covariance's sums: sum w and (upper triangle) sum w r r^T
 * into C over the n samples ix[k] (k when ix is NULL) with w = wv[ix[k]] >
 * 0, r = a - mu_a - B^T (x - mu_x). Inlined with constant ds and da (the
 * learning tasks' 2 and 2) on local C and r, the sums stay in registers:
 * none of the pointers alias. */
static inline double resid_sums(int ds, int da, int n, const int *restrict ix,
                                const double *restrict wv, const double *restrict X,
                                const double *restrict A, const double *restrict mu,
                                const double *restrict B, double *restrict r,
                                double *restrict C)
{
	double wt = 0.0;
	int i, j, k, l;

	for (k = 0; k < n; k++) {
		const int ii = ix ? ix[k] : k;
		const double wi = wv[ii];
		const double *x = X + (size_t)ii * ds, *a = A + (size_t)ii * da;

		if (!(wi > 0.0))
			continue;
		wt += wi;
		for (j = 0; j < da; j++) {
			r[j] = a[j] - mu[ds + j];
			for (i = 0; i < ds; i++)
				r[j] -= B[i * da + j] * (x[i] - mu[i]);
		}
		for (j = 0; j < da; j++)
			for (l = j; l < da; l++)
				C[j * da + l] += wi * r[j] * r[l];
	}
	return wt;
}

/* Locally weighted regression eq. 6.6-6.9 at state s from the pooled
 * moments rec of the weights w-hat (tot = sum w-hat, s2n = sum w-hat^2 /
 * tot^2), in centred, standardised coordinates:
 *   mu(s) = a_bar + B^T (s - s_bar), B from slope_solve with ridge
 *   lambda / tot (eq. 6.6's lambda on the raw weights),
 *   Sigma = sum w-hat (a - mu)(a - mu)^T / Z, Z = tot (1 - s2n) (eq. 6.8-6.9):
 *   about mu(s) this is tot [C_aa + (a_bar - mu)(a_bar - mu)^T]; about each
 *   sample's own fit (residual covariance) the samples are walked: the nt
 *   weights in ws->what / ws->touched, or every sample with w when global;
 *   about each sample's sampling mean m_i (cov_center old) it is
 *   tot [C_dd + d_bar d_bar^T] from drec, the pooled record of d = a - m.
 * few: fewer weighted samples than ds + 1, too few to fit a slope: the
 * weighted mean (PR_POLICY_MEANONLY).
 * Mean and (unfloored) covariance into ws->mean, ws->cov. Returns the
 * flags, PR_POLICY_COVFALL when Z <= ZMIN tot (mean still valid), or a
 * negative status. */
static int lwr(const pr_policy *p, const double *rec, const double *drec, double tot, double s2n,
               int global, int nt, int few, const double *s, pr_policy_work *ws)
{
	const int ds = p->ds, da = p->da, dz = ds + da;
	const double *mu = rec + 1, *S = rec + 1 + dz;
	double *C = ws->cov, *B = ws->B, *r = ws->z;
	int j, l, flags;

	/* slope_solve takes the centred sums: the factor 1/W of the moments per
	 * unit weight cancels in the standardised solve */
	if (few) {
		memset(B, 0, (size_t)ds * da * sizeof *B);
		flags = PR_POLICY_MEANONLY;
	} else if ((flags = slope_solve(ds, da, S, S + ds, dz, p->lambda / tot, &ws->ek, ws->sw, B)) < 0) {
		return flags;
	}
	for (j = 0; j < da; j++) {
		ws->mean[j] = mu[ds + j] + p->zref[ds + j];
		for (l = 0; l < ds; l++)
			ws->mean[j] += B[l * da + j] * (s[l] - p->zref[l] - mu[l]);
	}
	memset(C, 0, (size_t)da * da * sizeof *C);
	if (!(1.0 - s2n > ZMIN))
		return flags | PR_POLICY_COVFALL;
	if (p->center == PR_COV_CENTER_OLD) {
		/* about the sampling means: whatever the fit, the spread the old
		 * policies saw (the query's mean plays no part) */
		const double *dbar = drec + 1, *Sd = drec + 1 + da;

		for (j = 0; j < da; j++)
			for (l = j; l < da; l++)
				C[j * da + l] = Sd[j * da + l] / drec[0] + dbar[j] * dbar[l];
	} else if (p->covmode == PR_COV_RESIDUAL && !(flags & PR_POLICY_MEANONLY)) {
		const int *ix = global ? NULL : ws->touched;
		const double *wv = global ? p->w : ws->what;
		const int n = global ? p->n : nt;
		double wt;

		if (ds == 2 && da == 2) {
			/* local sums: scalarised into registers once inlined */
			double c4[4] = { 0 }, r2[2];

			wt = resid_sums(2, 2, n, ix, wv, p->X, p->A, mu, B, r2, c4);
			memcpy(C, c4, sizeof c4);
		} else {
			wt = resid_sums(ds, da, n, ix, wv, p->X, p->A, mu, B, r, C);
		}
		for (j = 0; j < da; j++)
			for (l = j; l < da; l++)
				C[j * da + l] /= wt;
	} else {
		/* eq. 6.8 about mu(s): the spread about a_bar plus the shift */
		for (j = 0; j < da; j++)
			for (l = j; l < da; l++)
				C[j * da + l] = S[(ds + j) * dz + ds + l] / rec[0] +
				                (mu[ds + j] + p->zref[ds + j] - ws->mean[j]) *
				                (mu[ds + l] + p->zref[ds + l] - ws->mean[l]);
	}
	/* divided by Z / tot = 1 - s2n (eq. 6.9) */
	for (j = 0; j < da; j++)
		for (l = j; l < da; l++)
			C[l * da + j] = C[j * da + l] /= 1.0 - s2n;
	return flags;
}

/* The records of all samples (the global weights) into rec and drec. */
static void global_records(const pr_policy *p, double *rec, double *drec)
{
	memcpy(rec, p->gm, mom_size(p->ds, p->da) * sizeof *rec);
	if (drec)
		memcpy(drec, p->gd, mom_size(p->da, 0) * sizeof *drec);
}

/* The tree policy at s: eq. 6.4's weights pooled leaf by leaf (sum w-hat f =
 * (1/M) sum over the active leaves of sum w f), then lwr(), with the
 * fallbacks of PR_POLICY_*. */
static int tree_eval(const pr_policy *p, const double *s, int *flags, pr_policy_work *ws,
                     char *err)
{
	const size_t LM = mom_size(p->ds, p->da), LD = mom_size(p->da, 0);
	const int dz = p->ds + p->da;
	double *rec = ws->mom, *drec = p->D ? ws->dmom : NULL, s2 = 0.0, tot, s2n;
	int nl, t, u, f = 0, st, nt = 0, walk, maxpos = 0;

	nl = pr_forest_active(p->forest, s, p->ds, ws->leaves, ws->cap);
	if (nl < 0)
		return pr_err(err, PR_ENUM, "policy: forest query failed");
	rec[0] = 0.0;
	for (t = 0; t < nl; t++)
		mom_merge(dz, rec, p->lm + (size_t)ws->leaves[t] * LM);
	if (drec) {
		drec[0] = 0.0;
		for (t = 0; t < nl; t++)
			mom_merge(p->da, drec, p->ld + (size_t)ws->leaves[t] * LD);
	}
	/* the samples are walked for the residual covariance, for sum w-hat^2
	 * without the pair table, and to count them when no active leaf alone
	 * holds ds + 1 weighted samples */
	for (t = 0; t < nl; t++)
		maxpos = p->lpos[ws->leaves[t]] > maxpos ? p->lpos[ws->leaves[t]] : maxpos;
	walk = !p->w2 || (p->covmode == PR_COV_RESIDUAL && !drec) || maxpos < p->ds + 1;
	if (!(rec[0] > 0.0) || !isfinite(rec[0])) {
		/* no weight around s: the global weighted fit */
		f |= PR_POLICY_GLOBAL;
		global_records(p, rec, drec);
		st = lwr(p, rec, drec, rec[0], p->gw2 / (rec[0] * rec[0]), 1, 0, p->gpos < p->ds + 1, s, ws);
	} else {
		if (walk)
			nt = walk_weights(p, ws->leaves, nl, ws);
		if (p->w2) {
			for (t = 0; t < nl; t++)
				for (u = 0; u < nl; u++)
					s2 += p->w2[(size_t)ws->leaves[t] * p->nl + ws->leaves[u]];
		} else {
			for (t = 0; t < nt; t++)
				s2 += ws->what[ws->touched[t]] * ws->what[ws->touched[t]] * (double)p->M * p->M;
		}
		tot = rec[0] / p->M;
		s2n = s2 / (rec[0] * rec[0]);
		st = lwr(p, rec, drec, tot, s2n, 0, nt, walk && nt < p->ds + 1, s, ws);
		if (walk)
			unwalk(ws, nt);
	}
	if (st < 0)
		return pr_err(err, PR_ENUM, "policy: local regression failed");
	f |= st;
	if ((st & PR_POLICY_COVFALL) && !(f & PR_POLICY_GLOBAL)) {
		/* one effective local sample: take the spread of the global weights
		 * around the local mean's global counterpart */
		memcpy(ws->cov2, ws->mean, (size_t)p->da * sizeof *ws->mean);
		global_records(p, rec, drec);
		st = lwr(p, rec, drec, rec[0], p->gw2 / (rec[0] * rec[0]), 1, 0, p->gpos < p->ds + 1, s, ws);
		if (st < 0)
			return pr_err(err, PR_ENUM, "policy: global regression failed");
		memcpy(ws->mean, ws->cov2, (size_t)p->da * sizeof *ws->mean);
	}
	if (cov_floor(p->da, ws->cov, p->min_std, &ws->ea, &f) != PR_OK)
		return pr_err(err, PR_ENUM, "policy: covariance eigen-decomposition failed");
	if (flags)
		*flags = f;
	return PR_OK;
}

/* Mean and covariance into ws->mean, ws->cov. */
static int eval_into(const pr_policy *p, const double *s, int *flags, pr_policy_work *ws,
                     char *err)
{
	int j, l;

	for (j = 0; j < p->ds; j++)
		if (!isfinite(s[j]))
			return pr_err(err, PR_EINVAL, "policy: state %d is not finite", j);
	if (p->kind == PR_POLICY_TREE)
		return tree_eval(p, s, flags, ws, err);
	if (flags)
		*flags = 0;
	if (p->nf == 1) {
		memcpy(ws->mean, p->W, (size_t)p->da * sizeof *p->W);
	} else {
		double *psi = malloc(((size_t)p->nf + (size_t)p->ds) * sizeof *psi), *u = psi + p->nf;

		if (!psi)
			return pr_err(err, PR_ENOMEM, "policy: out of memory");
		for (j = 0; j < p->ds; j++)
			u[j] = s[j] - p->xc[j];
		pr_policy_features(p->features, u, p->ds, psi);
		for (j = 0; j < p->da; j++) {
			ws->mean[j] = 0.0;
			for (l = 0; l < p->nf; l++)
				ws->mean[j] += p->W[j * p->nf + l] * psi[l];
		}
		free(psi);
	}
	memcpy(ws->cov, p->cov, (size_t)p->da * p->da * sizeof *p->cov);
	return PR_OK;
}

int pr_policy_eval(const pr_policy *p, const double *s, double *mean, double *cov,
                   int *flags, pr_policy_work *ws, char *err)
{
	pr_policy_work *own = NULL;
	int st;

	if (!ws && !(ws = own = pr_policy_work_new(p, err)))
		return PR_ENOMEM;
	st = eval_into(p, s, flags, ws, err);
	if (st == PR_OK) {
		if (mean)
			memcpy(mean, ws->mean, (size_t)p->da * sizeof *mean);
		if (cov)
			memcpy(cov, ws->cov, (size_t)p->da * p->da * sizeof *cov);
	}
	pr_policy_work_free(own);
	return st;
}

/* a = mu + V diag(sqrt lam) z, z ~ N(0, I), for k draws. */
static void draw(int da, const double *mu, const double *V, const double *lam, int k,
                 gsl_rng *rng, double *z, double *a)
{
	int t, j, m;

	for (t = 0; t < k; t++) {
		for (m = 0; m < da; m++)
			z[m] = sqrt(lam[m]) * gsl_ran_gaussian(rng, 1.0);
		for (j = 0; j < da; j++) {
			double v = mu[j];

			for (m = 0; m < da; m++)
				v += V[j * da + m] * z[m];
			a[(size_t)t * da + j] = v;
		}
	}
}

/* log N(a | mu, V diag(lam) V^T) */
static double logpdf_eig(int da, const double *mu, const double *V, const double *lam,
                         double logdet, const double *a)
{
	double q = 0.0;
	int j, m;

	for (m = 0; m < da; m++) {
		double y = 0.0;

		for (j = 0; j < da; j++)
			y += V[j * da + m] * (a[j] - mu[j]);
		q += y * y / lam[m];
	}
	return -0.5 * (da * LOG_2PI + logdet + q);
}

/* The tree policy's decomposition of ws->cov, left in ws->ea by cov_floor,
 * copied into V and lam; returns log det. */
static double tree_eig(const pr_policy_work *ws, int da, double *V, double *lam)
{
	double logdet;

	keep_eig(da, &ws->ea, V, lam, &logdet);
	return logdet;
}

int pr_policy_sample(const pr_policy *p, const double *s, int k, gsl_rng *rng,
                     double *a, int *flags, pr_policy_work *ws, char *err)
{
	pr_policy_work *own = NULL;
	int st;

	if (k < 0)
		return pr_err(err, PR_EINVAL, "policy: negative sample count");
	if (!ws && !(ws = own = pr_policy_work_new(p, err)))
		return PR_ENOMEM;
	st = eval_into(p, s, flags, ws, err);
	if (st == PR_OK) {
		if (p->kind == PR_POLICY_TREE) {
			tree_eig(ws, p->da, ws->cov2, ws->lam);
			draw(p->da, ws->mean, ws->cov2, ws->lam, k, rng, ws->z, a);
		} else {
			draw(p->da, ws->mean, p->V, p->lam, k, rng, ws->z, a);
		}
	}
	pr_policy_work_free(own);
	return st;
}

int pr_policy_logpdf(const pr_policy *p, const double *s, const double *a,
                     double *logpdf, int *flags, pr_policy_work *ws, char *err)
{
	pr_policy_work *own = NULL;
	int st, j;

	for (j = 0; j < p->da; j++)
		if (!isfinite(a[j]))
			return pr_err(err, PR_EINVAL, "policy: action %d is not finite", j);
	if (!ws && !(ws = own = pr_policy_work_new(p, err)))
		return PR_ENOMEM;
	st = eval_into(p, s, flags, ws, err);
	if (st == PR_OK) {
		if (p->kind == PR_POLICY_TREE) {
			double logdet = tree_eig(ws, p->da, ws->cov2, ws->lam);

			*logpdf = logpdf_eig(p->da, ws->mean, ws->cov2, ws->lam, logdet, a);
		} else {
			*logpdf = logpdf_eig(p->da, ws->mean, p->V, p->lam, p->logdet, a);
		}
	}
	pr_policy_work_free(own);
	return st;
}

/* Decompose a caller's covariance for the helpers below; eigenvalues must be
 * positive up to round-off (those within 64 eps of the largest in magnitude
 * are lifted to that size). */
static int helper_eig(int da, const double *cov, double *V, double *lam, double *logdet,
                      char *err)
{
	eig e;
	double lmax = 0.0;
	int m, st;

	if (eig_alloc(&e, da))
		return pr_err(err, PR_ENOMEM, "policy: out of memory");
	st = sym_eig(da, cov, &e);
	for (m = 0; st == PR_OK && m < da; m++)
		lmax = fmax(lmax, gsl_vector_get(e.ev, (size_t)m));
	for (m = 0; st == PR_OK && m < da; m++) {
		double l = gsl_vector_get(e.ev, (size_t)m);

		if (!(lmax > 0.0) || l < -64.0 * DBL_EPSILON * lmax)
			st = PR_EINVAL;
		else if (l < 64.0 * DBL_EPSILON * lmax)
			gsl_vector_set(e.ev, (size_t)m, 64.0 * DBL_EPSILON * lmax);
	}
	if (st == PR_OK)
		keep_eig(da, &e, V, lam, logdet);
	eig_free(&e);
	return st == PR_OK ? PR_OK
	                   : pr_err(err, PR_ENUM, "policy: covariance is not positive definite");
}

int pr_policy_gauss_sample(int da, const double *mean, const double *cov, int k,
                           gsl_rng *rng, double *a, char *err)
{
	double *V = malloc((size_t)da * da * sizeof *V), *lam = malloc((size_t)da * sizeof *lam);
	double *z = malloc((size_t)da * sizeof *z), logdet;
	int st;

	if (!V || !lam || !z)
		st = pr_err(err, PR_ENOMEM, "policy: out of memory");
	else if ((st = helper_eig(da, cov, V, lam, &logdet, err)) == PR_OK)
		draw(da, mean, V, lam, k, rng, z, a);
	free(V);
	free(lam);
	free(z);
	return st;
}

int pr_policy_gauss_logpdf(int da, const double *mean, const double *cov,
                           const double *a, double *logpdf, char *err)
{
	double *V = malloc((size_t)da * da * sizeof *V), *lam = malloc((size_t)da * sizeof *lam);
	double logdet;
	int st;

	if (!V || !lam)
		st = pr_err(err, PR_ENOMEM, "policy: out of memory");
	else if ((st = helper_eig(da, cov, V, lam, &logdet, err)) == PR_OK)
		*logpdf = logpdf_eig(da, mean, V, lam, logdet, a);
	free(V);
	free(lam);
	return st;
}
