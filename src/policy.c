/* policy.c — Gaussian policies: fixed, linear on hand-made features
 * (weighted ML, eq. 3.10), and tree-based locally weighted regression
 * (eq. 6.4-6.9). */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_eigen.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_matrix.h>
#include <gsl/gsl_randist.h>

#include "poolreps/policy.h"

/* Eigenvalues below this fraction of the largest are dropped (pseudo-inverse). */
#define RCOND 1e-12
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
	/* gaussian and linear: mean = W psi(s), fixed covariance */
	int features, nf;
	double *W;          /* da x nf */
	double *cov;        /* da x da */
	double *V, *lam;    /* cov = V diag(lam) V^T, lam > 0 (floored) */
	double logdet;      /* sum log lam */
	/* tree */
	pr_forest *forest;
	int n, M, cap;
	double *X;          /* n x (ds+1) design rows [1, s_i] (eq. 6.6) */
	double *A;          /* n x da */
	double *w;          /* n REPS weights */
	double lambda, min_std;
	int covmode;
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
	double *what;     /* n: eq. 6.4 weights */
	double *wn;       /* n: normalised */
	int *leaves;      /* cap active leaves */
	double *rhs, *B;  /* (ds+1) x da */
	double *mean, *cov, *cov2, *z, *lam;
	eig ek;           /* ds+1 */
	eig ea;           /* da: after a query, the eigenvectors and floored
	                     eigenvalues of ws->cov */
};

void pr_policy_work_free(pr_policy_work *w)
{
	if (!w)
		return;
	free(w->what);
	free(w->wn);
	free(w->leaves);
	free(w->rhs);
	free(w->B);
	free(w->mean);
	free(w->cov);
	free(w->cov2);
	free(w->z);
	free(w->lam);
	eig_free(&w->ek);
	eig_free(&w->ea);
	free(w);
}

static pr_policy_work *work_new(int n, int ds, int da, int cap, char *err)
{
	pr_policy_work *w = calloc(1, sizeof *w);
	size_t k = (size_t)ds + 1, a = (size_t)da;

	if (!w) {
		pr_err(err, PR_ENOMEM, "policy: out of memory");
		return NULL;
	}
	w->n = n;
	w->ds = ds;
	w->da = da;
	w->cap = cap;
	w->what = calloc((size_t)(n > 0 ? n : 1), sizeof *w->what);
	w->wn = calloc((size_t)(n > 0 ? n : 1), sizeof *w->wn);
	w->leaves = calloc((size_t)(cap > 0 ? cap : 1), sizeof *w->leaves);
	w->rhs = calloc(k * a, sizeof *w->rhs);
	w->B = calloc(k * a, sizeof *w->B);
	w->mean = calloc(a, sizeof *w->mean);
	w->cov = calloc(a * a, sizeof *w->cov);
	w->cov2 = calloc(a * a, sizeof *w->cov2);
	w->z = calloc(a, sizeof *w->z);
	w->lam = calloc(a, sizeof *w->lam);
	if (!w->what || !w->wn || !w->leaves || !w->rhs || !w->B || !w->mean || !w->cov ||
	    !w->cov2 || !w->z || !w->lam || eig_alloc(&w->ek, (int)k) || eig_alloc(&w->ea, da)) {
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

/* B (k x da) = (X^T W X + lambda I)^+ X^T W A (eq. 6.6) over the rows with
 * w_i > 0, through the eigen-decomposition of the k x k normal matrix:
 * eigenvalues below RCOND times the largest are dropped (PR_POLICY_PINV).
 * Returns the flags, or a negative status when GSL fails. */
static int ridge_solve(int n, int k, int da, const double *X, const double *w,
                       const double *A, double lambda, eig *e, double *rhs, double *B)
{
	double lmax = 0.0;
	int i, j, l, m, flags = 0;

	gsl_matrix_set_zero(e->M);
	memset(rhs, 0, (size_t)k * da * sizeof *rhs);
	for (i = 0; i < n; i++) {
		const double *x = X + (size_t)i * k, *a = A + (size_t)i * da;

		if (!(w[i] > 0.0))
			continue;
		for (j = 0; j < k; j++) {
			double wx = w[i] * x[j];

			for (l = j; l < k; l++)
				*gsl_matrix_ptr(e->M, (size_t)j, (size_t)l) += wx * x[l];
			for (m = 0; m < da; m++)
				rhs[j * da + m] += wx * a[m];
		}
	}
	for (j = 0; j < k; j++) {
		*gsl_matrix_ptr(e->M, (size_t)j, (size_t)j) += lambda;
		for (l = j + 1; l < k; l++)
			gsl_matrix_set(e->M, (size_t)l, (size_t)j, gsl_matrix_get(e->M, (size_t)j, (size_t)l));
	}
	if (gsl_eigen_symmv(e->M, e->ev, e->V, e->ws) != GSL_SUCCESS)
		return PR_ENUM;
	for (j = 0; j < k; j++)
		lmax = fmax(lmax, gsl_vector_get(e->ev, (size_t)j));
	memset(B, 0, (size_t)k * da * sizeof *B);
	for (l = 0; l < k; l++) {
		double ll = gsl_vector_get(e->ev, (size_t)l);

		if (!(ll > RCOND * lmax) || !(ll > 0.0)) {
			flags |= PR_POLICY_PINV;
			continue;
		}
		for (m = 0; m < da; m++) {
			double c = 0.0;

			for (j = 0; j < k; j++)
				c += gsl_matrix_get(e->V, (size_t)j, (size_t)l) * rhs[j * da + m];
			c /= ll;
			for (j = 0; j < k; j++)
				B[j * da + m] += c * gsl_matrix_get(e->V, (size_t)j, (size_t)l);
		}
	}
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
	free(p->X);
	free(p->A);
	free(p->w);
	free(p);
}

int pr_policy_kind(const pr_policy *p) { return p->kind; }
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
	if (!p || !(p->W = malloc((size_t)da * nf * sizeof *p->W)) || eig_alloc(&e, da)) {
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

int pr_policy_linear_params(const pr_policy *p, double *W, double *cov, char *err)
{
	if (p->kind == PR_POLICY_TREE)
		return pr_err(err, PR_EINVAL, "policy: a tree policy has no fixed parameters");
	if (W)
		memcpy(W, p->W, (size_t)p->da * p->nf * sizeof *W);
	if (cov)
		memcpy(cov, p->cov, (size_t)p->da * p->da * sizeof *cov);
	return PR_OK;
}

/* Shared checks of fitting data; returns the sum of the weights via *sw. */
static int check_data(const pr_policy_data *d, int need_y, double *sw, char *err)
{
	size_t i;

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
		*sw += wi;
	}
	if (!(*sw > 0.0) || !isfinite(*sw))
		return pr_err(err, PR_EINVAL, "policy: the weights sum to 0");
	return PR_OK;
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
 * sum 1, W^T = (Psi^T D Psi + lambda I)^+ Psi^T D A maximises
 * sum w_i log N(a_i | W psi_i, Sigma) for any Sigma, and then
 * Sigma = sum w_i r_i r_i^T, r_i = a_i - c_i with the centre c_i = W psi_i
 * (PR_COV_CENTER_NEW) or the sampling mean M_i (PR_COV_CENTER_OLD). */
pr_policy *pr_policy_linear_fit(int features, const pr_policy_data *d, double lambda,
                                double min_std, int cov_center, int *flags, char *err)
{
	pr_policy *p = NULL;
	double *X = NULL, *wn = NULL, *rhs = NULL, *B = NULL, sw, *r;
	eig ek = { 0 }, ea = { 0 };
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
	if (check_data(d, 0, &sw, err) != PR_OK || check_centres(d, cov_center, err) != PR_OK)
		return NULL;
	p = policy_alloc(PR_POLICY_LINEAR, d->ds, d->da);
	X = malloc((size_t)d->n * nf * sizeof *X);
	wn = malloc((size_t)d->n * sizeof *wn);
	rhs = malloc((size_t)nf * d->da * sizeof *rhs);
	B = malloc((size_t)nf * d->da * sizeof *B);
	if (!p || !X || !wn || !rhs || !B || eig_alloc(&ek, nf) || eig_alloc(&ea, d->da) ||
	    !(p->W = malloc((size_t)d->da * nf * sizeof *p->W))) {
		pr_err(err, PR_ENOMEM, "policy: out of memory");
		goto fail;
	}
	p->features = features;
	p->nf = nf;
	for (i = 0; i < d->n; i++) {
		pr_policy_features(features, d->S + (size_t)i * d->ds, d->ds, X + (size_t)i * nf);
		wn[i] = (d->w ? d->w[i] : 1.0) / sw;
	}
	st = ridge_solve(d->n, nf, d->da, X, wn, d->A, lambda, &ek, rhs, B);
	if (st < 0) {
		pr_err(err, PR_ENUM, "policy: weighted regression failed");
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
	free(X);
	free(wn);
	free(rhs);
	free(B);
	eig_free(&ek);
	eig_free(&ea);
	return p;
fail:
	free(X);
	free(wn);
	free(rhs);
	free(B);
	eig_free(&ek);
	eig_free(&ea);
	pr_policy_free(p);
	return NULL;
}

pr_policy *pr_policy_tree_fit(const pr_policy_opts *o, const pr_policy_data *d,
                              gsl_rng *rng, char *err)
{
	pr_policy *p;
	const int reward = o->target == PR_TARGET_REWARD_STATE;
	double sw;
	int i, j, k;

	if (pr_policy_opts_check(o, err) != PR_OK || check_data(d, reward, &sw, err) != PR_OK)
		return NULL;
	p = policy_alloc(PR_POLICY_TREE, d->ds, d->da);
	if (!p) {
		pr_err(err, PR_ENOMEM, "policy: out of memory");
		return NULL;
	}
	p->n = d->n;
	p->lambda = o->lambda;
	p->min_std = o->min_std;
	p->covmode = o->cov;
	k = d->ds + 1;
	p->X = malloc((size_t)d->n * k * sizeof *p->X);
	p->A = malloc((size_t)d->n * d->da * sizeof *p->A);
	p->w = malloc((size_t)d->n * sizeof *p->w);
	if (!p->X || !p->A || !p->w) {
		pr_policy_free(p);
		pr_err(err, PR_ENOMEM, "policy: out of memory");
		return NULL;
	}
	for (i = 0; i < d->n; i++) {
		p->X[(size_t)i * k] = 1.0;
		for (j = 0; j < d->ds; j++)
			p->X[(size_t)i * k + 1 + j] = d->S[(size_t)i * d->ds + j];
		p->w[i] = d->w ? d->w[i] : 1.0;
	}
	memcpy(p->A, d->A, (size_t)d->n * d->da * sizeof *p->A);
	/* eq. 6.3: the weighted score uses the REPS weights */
	p->forest = pr_forest_fit(&o->forest, d->S, d->n, d->ds, reward ? d->Y : d->A,
	                          reward ? d->dy : d->da, p->w, rng, err);
	if (!p->forest) {
		pr_policy_free(p);
		return NULL;
	}
	p->M = pr_forest_ntrees(p->forest);
	p->cap = p->M;
	return p;
}

/* Locally weighted regression with the weights what (eq. 6.6-6.9), at
 * state s: mean and (unfloored) covariance into ws->mean, ws->cov. The
 * weights are normalised to sum 1 first, which leaves eq. 6.7-6.9 as they
 * are; the ridge is divided by the same total, so it is eq. 6.6's lambda on
 * the raw weights. Returns the flags, PR_POLICY_COVFALL when Z <= 0 (mean
 * still valid), or a negative status. */
static int lwr(const pr_policy *p, const double *s, const double *what, pr_policy_work *ws)
{
	const int k = p->ds + 1, da = p->da;
	double tot = 0.0, s2 = 0.0, Z;
	int i, j, l, npos = 0, flags = 0;
	double *mu = ws->mean, *C = ws->cov, *r = ws->z;

	for (i = 0; i < p->n; i++)
		tot += what[i];
	for (i = 0; i < p->n; i++) {
		ws->wn[i] = what[i] / tot;
		s2 += ws->wn[i] * ws->wn[i];
		npos += ws->wn[i] > 0.0;
	}
	memset(mu, 0, (size_t)da * sizeof *mu);
	if (npos < k) {
		/* fewer weighted samples than coefficients: no slope to fit */
		flags |= PR_POLICY_MEANONLY;
		for (i = 0; i < p->n; i++)
			for (j = 0; j < da; j++)
				mu[j] += ws->wn[i] * p->A[(size_t)i * da + j];
	} else {
		int st = ridge_solve(p->n, k, da, p->X, ws->wn, p->A, p->lambda / tot, &ws->ek, ws->rhs, ws->B);

		if (st < 0)
			return st;
		flags |= st;
		/* eq. 6.7: mu = beta s + alpha */
		for (j = 0; j < da; j++) {
			mu[j] = ws->B[j];
			for (l = 1; l < k; l++)
				mu[j] += ws->B[l * da + j] * s[l - 1];
		}
	}
	/* eq. 6.9 with sum w = 1 */
	Z = 1.0 - s2;
	memset(C, 0, (size_t)da * da * sizeof *C);
	if (!(Z > ZMIN))
		return flags | PR_POLICY_COVFALL;
	for (i = 0; i < p->n; i++) {
		const double *a = p->A + (size_t)i * da;

		if (!(ws->wn[i] > 0.0))
			continue;
		for (j = 0; j < da; j++) {
			double c = mu[j];

			if (p->covmode == PR_COV_RESIDUAL && !(flags & PR_POLICY_MEANONLY)) {
				c = ws->B[j];
				for (l = 1; l < k; l++)
					c += ws->B[l * da + j] * p->X[(size_t)i * k + l];
			}
			r[j] = a[j] - c;
		}
		/* eq. 6.8 */
		for (j = 0; j < da; j++)
			for (l = j; l < da; l++)
				C[j * da + l] += ws->wn[i] * r[j] * r[l];
	}
	for (j = 0; j < da; j++)
		for (l = j; l < da; l++)
			C[l * da + j] = C[j * da + l] /= Z;
	return flags;
}

/* The tree policy at s: eq. 6.4 weights by walking the active leaves and
 * their sample lists, then lwr(), with the fallbacks of PR_POLICY_*. */
static int tree_eval(const pr_policy *p, const double *s, int *flags, pr_policy_work *ws,
                     char *err)
{
	double tot = 0.0;
	int nl, t, i, f = 0, st;

	nl = pr_forest_active(p->forest, s, p->ds, ws->leaves, ws->cap);
	if (nl < 0)
		return pr_err(err, PR_ENUM, "policy: forest query failed");
	memset(ws->what, 0, (size_t)p->n * sizeof *ws->what);
	for (t = 0; t < nl; t++) {
		const int *idx;
		int m = pr_forest_leaf_samples(p->forest, ws->leaves[t], &idx);

		/* eq. 6.4: w_i/M times the number of active leaves shared with s */
		for (i = 0; i < m; i++)
			ws->what[idx[i]] += p->w[idx[i]] / p->M;
	}
	for (i = 0; i < p->n; i++)
		tot += ws->what[i];
	if (!(tot > 0.0) || !isfinite(tot)) {
		f |= PR_POLICY_GLOBAL;
		memcpy(ws->what, p->w, (size_t)p->n * sizeof *p->w);
	}
	st = lwr(p, s, ws->what, ws);
	if (st < 0)
		return pr_err(err, PR_ENUM, "policy: local regression failed");
	f |= st;
	if ((st & PR_POLICY_COVFALL) && !(f & PR_POLICY_GLOBAL)) {
		/* one effective local sample: take the spread of the global weights
		 * around the local mean's global counterpart */
		memcpy(ws->cov2, ws->mean, (size_t)p->da * sizeof *ws->mean);
		st = lwr(p, s, p->w, ws);
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
		double *psi = malloc((size_t)p->nf * sizeof *psi);

		if (!psi)
			return pr_err(err, PR_ENOMEM, "policy: out of memory");
		pr_policy_features(p->features, s, p->ds, psi);
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
