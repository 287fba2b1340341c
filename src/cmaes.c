/* cmaes.c — contextual CMA-ES (Abdolmaleki et al., IJCAI 2017).
 *
 * Notation: da parameters x, ds context dimensions s, mean features psi(s)
 * (nf of them), search distribution N(W psi(s), sigma^2 C). One update uses
 * one generation of n samples. The paper keeps CMA-ES's defaults (Hansen,
 * "The CMA Evolution Strategy: A Tutorial", 2016) with the dimension taken
 * as n_tot = da + ds, and adds log(ds + 1) to the step-size damping:
 *
 *   mu = floor(n/2),  d'_i = log(mu + 1/2) - log i (i <= mu),  d = d'/sum d'
 *   mueff = 1 / sum d_i^2
 *   c_sigma = (mueff + 2) / (n_tot + mueff + 5)
 *   d_sigma = 1 + 2 max(0, sqrt((mueff - 1)/(n_tot + 1)) - 1) + c_sigma + log(ds + 1)
 *   c_c = (4 + mueff/n_tot) / (n_tot + 4 + 2 mueff/n_tot)
 *   c_1 = 2 / ((n_tot + 1.3)^2 + mueff)
 *   c_mu = min(1 - c_1, 2 (mueff - 2 + 1/mueff) / ((n_tot + 2)^2 + mueff))
 *   E|N(0, I_da)| ~ sqrt(da) (1 - 1/(4 da) + 1/(21 da^2))
 *
 * The constants depend on n, so they are computed per update: a generation
 * of any size n >= 2 is accepted (Experiment 3's first one is larger).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_eigen.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_multifit.h>
#include <gsl/gsl_sort.h>

#include "poolreps/cmaes.h"
#include "poolreps/internal.h"

/* Singular values below this fraction of the largest are dropped in the
 * baseline regression (minimum-norm least squares). */
#define BASE_RCOND 1e-12

struct pr_cmaes {
	int features, ds, da, nf;
	double lambda;
	double *W;       /* da x nf mean coefficients */
	double *C;       /* da x da, symmetric positive definite */
	double *V, *ev;  /* C = V diag(ev) V^T (kept in step with C) */
	double *pc, *ps; /* evolution paths (da) */
	double sigma;
	long g;          /* generations done */
};

void pr_cmaes_free(pr_cmaes *c)
{
	if (!c)
		return;
	free(c->W);
	free(c->C);
	free(c->V);
	free(c->ev);
	free(c->pc);
	free(c->ps);
	free(c);
}

/* V, ev from C; PR_ENUM unless every eigenvalue is finite and > 0. */
static int decompose(int da, const double *C, double *V, double *ev)
{
	gsl_matrix *M = gsl_matrix_alloc((size_t)da, (size_t)da);
	gsl_matrix *E = gsl_matrix_alloc((size_t)da, (size_t)da);
	gsl_vector *l = gsl_vector_alloc((size_t)da);
	gsl_eigen_symmv_workspace *ws = gsl_eigen_symmv_alloc((size_t)da);
	int i, j, rc = PR_OK;

	if (!M || !E || !l || !ws) {
		rc = PR_ENOMEM;
		goto done;
	}
	for (i = 0; i < da; i++)
		for (j = 0; j < da; j++) {
			if (!isfinite(C[i * da + j])) {
				rc = PR_ENUM;
				goto done;
			}
			gsl_matrix_set(M, (size_t)i, (size_t)j, C[i * da + j]);
		}
	if (gsl_eigen_symmv(M, l, E, ws) != GSL_SUCCESS) {
		rc = PR_ENUM;
		goto done;
	}
	for (j = 0; j < da; j++) {
		ev[j] = gsl_vector_get(l, (size_t)j);
		if (!(ev[j] > 0.0) || !isfinite(ev[j]))
			rc = PR_ENUM;
		for (i = 0; i < da; i++)
			V[i * da + j] = gsl_matrix_get(E, (size_t)i, (size_t)j);
	}
done:
	gsl_matrix_free(M);
	gsl_matrix_free(E);
	gsl_vector_free(l);
	gsl_eigen_symmv_free(ws);
	return rc;
}

pr_cmaes *pr_cmaes_new(int features, int ds, int da, const double *W0, double sigma0,
                       double lambda, char *err)
{
	pr_cmaes *c;
	int nf = pr_policy_features_count(features, ds), i;

	if (ds < 1 || da < 1 || nf < 1) {
		pr_err(err, PR_EINVAL, "cmaes: need ds, da >= 1 and known features (got %d, %d, %d)",
		       ds, da, features);
		return NULL;
	}
	if (!(sigma0 > 0.0) || !isfinite(sigma0) || !(lambda >= 0.0) || !isfinite(lambda)) {
		pr_err(err, PR_EINVAL, "cmaes: need sigma0 > 0 and lambda >= 0, finite (got %g, %g)",
		       sigma0, lambda);
		return NULL;
	}
	for (i = 0; i < da * nf; i++)
		if (!isfinite(W0[i])) {
			pr_err(err, PR_EINVAL, "cmaes: initial mean coefficient %d is not finite", i);
			return NULL;
		}
	c = calloc(1, sizeof *c);
	if (!c || !(c->W = malloc((size_t)da * nf * sizeof *c->W)) ||
	    !(c->C = calloc((size_t)da * da, sizeof *c->C)) ||
	    !(c->V = calloc((size_t)da * da, sizeof *c->V)) ||
	    !(c->ev = malloc((size_t)da * sizeof *c->ev)) ||
	    !(c->pc = calloc((size_t)da, sizeof *c->pc)) ||
	    !(c->ps = calloc((size_t)da, sizeof *c->ps))) {
		pr_cmaes_free(c);
		pr_err(err, PR_ENOMEM, "cmaes: out of memory");
		return NULL;
	}
	c->features = features;
	c->ds = ds;
	c->da = da;
	c->nf = nf;
	c->lambda = lambda;
	c->sigma = sigma0;
	memcpy(c->W, W0, (size_t)da * nf * sizeof *W0);
	for (i = 0; i < da; i++) {
		c->C[i * da + i] = 1.0;
		c->V[i * da + i] = 1.0;
		c->ev[i] = 1.0;
	}
	return c;
}

double pr_cmaes_sigma(const pr_cmaes *c) { return c->sigma; }

void pr_cmaes_state(const pr_cmaes *c, double *W, double *C)
{
	if (W)
		memcpy(W, c->W, (size_t)c->da * c->nf * sizeof *W);
	if (C)
		memcpy(C, c->C, (size_t)c->da * c->da * sizeof *C);
}

/* Advantages R_i - V(s_i), V fitted to R by minimum-norm least squares on
 * the baseline features (the paper's context-dependent baseline). */
static int advantages(const pr_cmaes_batch *b, double *adv)
{
	gsl_matrix *X = gsl_matrix_alloc((size_t)b->n, (size_t)b->nb);
	gsl_matrix *cov = gsl_matrix_alloc((size_t)b->nb, (size_t)b->nb);
	gsl_vector *y = gsl_vector_alloc((size_t)b->n), *beta = gsl_vector_alloc((size_t)b->nb);
	gsl_multifit_linear_workspace *ws = gsl_multifit_linear_alloc((size_t)b->n, (size_t)b->nb);
	double chisq;
	size_t rank;
	int i, j, rc = PR_OK;

	if (!X || !cov || !y || !beta || !ws) {
		rc = PR_ENOMEM;
		goto done;
	}
	for (i = 0; i < b->n; i++) {
		gsl_vector_set(y, (size_t)i, b->R[i]);
		for (j = 0; j < b->nb; j++)
			gsl_matrix_set(X, (size_t)i, (size_t)j, b->B[(size_t)i * b->nb + j]);
	}
	if (gsl_multifit_linear_tsvd(X, y, BASE_RCOND, beta, cov, &chisq, &rank, ws) != GSL_SUCCESS) {
		rc = PR_ENUM;
		goto done;
	}
	for (i = 0; i < b->n; i++) {
		double v = 0.0;

		for (j = 0; j < b->nb; j++)
			v += gsl_vector_get(beta, (size_t)j) * b->B[(size_t)i * b->nb + j];
		adv[i] = b->R[i] - v;
		if (!isfinite(adv[i]))
			rc = PR_ENUM;
	}
done:
	gsl_matrix_free(X);
	gsl_matrix_free(cov);
	gsl_vector_free(y);
	gsl_vector_free(beta);
	gsl_multifit_linear_free(ws);
	return rc;
}

static int check_batch(const pr_cmaes *c, const pr_cmaes_batch *b, char *err)
{
	size_t i;

	if (b->n < 2 || b->nb < 1)
		return pr_err(err, PR_EINVAL, "cmaes: need n >= 2 samples and nb >= 1 baseline features "
		              "(got %d, %d)", b->n, b->nb);
	if (!b->S || !b->X || !b->R || !b->B)
		return pr_err(err, PR_EINVAL, "cmaes: missing contexts, parameters, returns or features");
	for (i = 0; i < (size_t)b->n; i++)
		if (!isfinite(b->R[i]))
			return pr_err(err, PR_EINVAL, "cmaes: sample %zu: return is not finite", i);
	for (i = 0; i < (size_t)b->n * b->nb; i++)
		if (!isfinite(b->B[i]))
			return pr_err(err, PR_EINVAL, "cmaes: sample %zu: baseline feature %zu is not finite",
			              i / b->nb, i % b->nb);
	for (i = 0; i < (size_t)b->n * c->ds; i++)
		if (!isfinite(b->S[i]))
			return pr_err(err, PR_EINVAL, "cmaes: sample %zu: context %zu is not finite",
			              i / c->ds, i % c->ds);
	for (i = 0; i < (size_t)b->n * c->da; i++)
		if (!isfinite(b->X[i]))
			return pr_err(err, PR_EINVAL, "cmaes: sample %zu: parameter %zu is not finite",
			              i / c->da, i % c->da);
	return PR_OK;
}

/* The strategy's learning rates from the effective sample size mueff
 * (contextual CMA-ES: n = d_a + d_s in place of the dimension). */
typedef struct {
	double mueff, csig, dsig, cc, c1, cmu, chin;
} rates;

static rates learning_rates(const pr_cmaes *c, double mueff)
{
	const int da = c->da;
	const double ntot = da + c->ds;
	rates r;

	r.mueff = mueff;
	r.csig = (mueff + 2.0) / (ntot + mueff + 5.0);
	r.dsig = 1.0 + 2.0 * fmax(0.0, sqrt((mueff - 1.0) / (ntot + 1.0)) - 1.0) + r.csig + log(c->ds + 1.0);
	r.cc = (4.0 + mueff / ntot) / (ntot + 4.0 + 2.0 * mueff / ntot);
	r.c1 = 2.0 / ((ntot + 1.3) * (ntot + 1.3) + mueff);
	r.cmu = fmin(1.0 - r.c1, 2.0 * (mueff - 2.0 + 1.0 / mueff) / ((ntot + 2.0) * (ntot + 2.0) + mueff));
	r.chin = sqrt((double)da) * (1.0 - 1.0 / (4.0 * da) + 1.0 / (21.0 * da * da));
	return r;
}

/* The update's work arrays (one allocation failure frees them all). */
typedef struct {
	double *adv, *d, *M, *psi, *phibar, *Wn, *Z, *Cn, *Vn, *evn, *y, *z, *pc, *ps;
	size_t *order;
} update_work;

static void work_free(update_work *w)
{
	free(w->adv);
	free(w->d);
	free(w->M);
	free(w->psi);
	free(w->phibar);
	free(w->Wn);
	free(w->Z);
	free(w->Cn);
	free(w->Vn);
	free(w->evn);
	free(w->y);
	free(w->z);
	free(w->pc);
	free(w->ps);
	free(w->order);
}

static int work_alloc(update_work *w, int n, int da, int nf)
{
	w->adv = malloc((size_t)n * sizeof *w->adv);
	w->d = calloc((size_t)n, sizeof *w->d);
	w->M = malloc((size_t)n * da * sizeof *w->M);
	w->psi = malloc((size_t)nf * sizeof *w->psi);
	w->phibar = calloc((size_t)nf, sizeof *w->phibar);
	w->Wn = malloc((size_t)da * nf * sizeof *w->Wn);
	w->Z = malloc((size_t)da * da * sizeof *w->Z);
	w->Cn = malloc((size_t)da * da * sizeof *w->Cn);
	w->Vn = malloc((size_t)da * da * sizeof *w->Vn);
	w->evn = malloc((size_t)da * sizeof *w->evn);
	w->y = malloc((size_t)da * sizeof *w->y);
	w->z = malloc((size_t)da * sizeof *w->z);
	w->pc = malloc((size_t)da * sizeof *w->pc);
	w->ps = malloc((size_t)da * sizeof *w->ps);
	w->order = malloc((size_t)n * sizeof *w->order);
	return w->adv && w->d && w->M && w->psi && w->phibar && w->Wn && w->Z && w->Cn && w->Vn &&
	       w->evn && w->y && w->z && w->pc && w->ps && w->order;
}

/* Rank weights d_i: log(mu + 1/2) - log(rank) for the best mu = n/2
 * samples by advantage, 0 for the rest, summing to 1; returns mueff = 1 / sum d_i^2. */
static double rank_weights(const update_work *w, int n)
{
	const int mu = n / 2;
	double dsum = 0.0, d2 = 0.0;
	int i;

	gsl_sort_index(w->order, w->adv, 1, (size_t)n);
	for (i = 0; i < mu; i++) {
		w->d[w->order[n - 1 - i]] = log(mu + 0.5) - log(i + 1.0);
		dsum += w->d[w->order[n - 1 - i]];
	}
	for (i = 0; i < n; i++) {
		w->d[i] /= dsum;
		d2 += w->d[i] * w->d[i];
	}
	return 1.0 / d2;
}

/* Old means W_old psi(s_i) into M and the batch's mean features psi_bar. */
static void old_means(const pr_cmaes *c, const pr_cmaes_batch *b, const update_work *w)
{
	const int da = c->da, nf = c->nf, n = b->n;
	int i, j, l;

	for (i = 0; i < n; i++) {
		pr_policy_features(c->features, b->S + (size_t)i * c->ds, c->ds, w->psi);
		for (l = 0; l < nf; l++)
			w->phibar[l] += w->psi[l] / n;
		for (j = 0; j < da; j++) {
			w->M[(size_t)i * da + j] = 0.0;
			for (l = 0; l < nf; l++)
				w->M[(size_t)i * da + j] += c->W[j * nf + l] * w->psi[l];
		}
	}
}

/* Mean: weighted linear regression of x on psi(s) with the weights d into
 * Wn; the same fit's residual covariance around the old means,
 * sum_i d_i (x_i - m_i)(x_i - m_i)^T (sigma^2 times the rank-mu term), into Z. */
static int new_mean(const pr_cmaes *c, const pr_cmaes_batch *b, const update_work *w, int *flags,
                    char *err)
{
	pr_policy_data pd;
	pr_policy *fit;

	memset(&pd, 0, sizeof pd);
	pd.n = b->n;
	pd.ds = c->ds;
	pd.da = c->da;
	pd.S = b->S;
	pd.A = b->X;
	pd.w = w->d;
	pd.M = w->M;
	if (!(fit = pr_policy_linear_fit(c->features, &pd, c->lambda, 0.0, PR_COV_CENTER_OLD, flags, err)))
		return PR_ENUM;
	pr_policy_linear_params(fit, w->Wn, w->Z, err);
	pr_policy_free(fit);
	return PR_OK;
}

/* The evolution paths from y_w = (W_new - W_old) psi_bar / sigma, the mean
 * shift at the batch's mean context features in units of sigma, into w->ps
 * and w->pc; returns h_sigma, *psn = |p_sigma|. */
static int new_paths(const pr_cmaes *c, const rates *r, const update_work *w, double *psn)
{
	const int da = c->da, nf = c->nf;
	double *y = w->y, *z = w->z;
	int j, l, hsig;

	for (j = 0; j < da; j++) {
		y[j] = 0.0;
		for (l = 0; l < nf; l++)
			y[j] += (w->Wn[j * nf + l] - c->W[j * nf + l]) * w->phibar[l];
		y[j] /= c->sigma;
	}
	/* p_sigma <- (1 - c_sigma) p_sigma + sqrt(c_sigma (2 - c_sigma) mueff) C^(-1/2) y_w */
	for (l = 0; l < da; l++) {
		z[l] = 0.0;
		for (j = 0; j < da; j++)
			z[l] += c->V[j * da + l] * y[j];
		z[l] /= sqrt(c->ev[l]);
	}
	*psn = 0.0;
	for (j = 0; j < da; j++) {
		double v = 0.0;

		for (l = 0; l < da; l++)
			v += c->V[j * da + l] * z[l];
		w->ps[j] = (1.0 - r->csig) * c->ps[j] + sqrt(r->csig * (2.0 - r->csig) * r->mueff) * v;
		*psn += w->ps[j] * w->ps[j];
	}
	*psn = sqrt(*psn);
	/* h_sigma stalls the rank-one path while |p_sigma| is large */
	hsig = *psn / sqrt(1.0 - pow(1.0 - r->csig, 2.0 * (c->g + 1))) < (1.4 + 2.0 / (da + 1.0)) * r->chin;
	/* p_c <- (1 - c_c) p_c + h_sigma sqrt(c_c (2 - c_c) mueff) y_w */
	for (j = 0; j < da; j++)
		w->pc[j] = (1.0 - r->cc) * c->pc[j] + hsig * sqrt(r->cc * (2.0 - r->cc) * r->mueff) * y[j];
	return hsig;
}

/* C <- (1 + c_1 delta(h_sigma) - c_1 - c_mu) C + c_1 p_c p_c^T
 *      + c_mu sum_i d_i y_i y_i^T,   y_i = (x_i - W_old psi(s_i)) / sigma,
 * delta(h_sigma) = (1 - h_sigma) c_c (2 - c_c): the contextual rank-mu
 * update around the old mean, into w->Cn. */
static void new_covariance(const pr_cmaes *c, const rates *r, int hsig, const update_work *w)
{
	const int da = c->da;
	const double sig2 = c->sigma * c->sigma, dh = (1 - hsig) * r->cc * (2.0 - r->cc);
	int j, l;

	for (j = 0; j < da; j++)
		for (l = j; l < da; l++) {
			double v = (1.0 + r->c1 * dh - r->c1 - r->cmu) * c->C[j * da + l] +
			           r->c1 * w->pc[j] * w->pc[l] +
			           r->cmu * 0.5 * (w->Z[j * da + l] + w->Z[l * da + j]) / sig2;

			w->Cn[j * da + l] = w->Cn[l * da + j] = v;
		}
}

int pr_cmaes_update(pr_cmaes *c, const pr_cmaes_batch *b, pr_cmaes_info *info, char *err)
{
	const int da = c->da, nf = c->nf;
	update_work w;
	rates r;
	double psn, sigma;
	int hsig, flags = 0, rc;

	if ((rc = check_batch(c, b, err)))
		return rc;
	if (!work_alloc(&w, b->n, da, nf)) {
		rc = pr_err(err, PR_ENOMEM, "cmaes: out of memory");
		goto done;
	}
	/* advantages and rank weights d_i: the best mu samples by R - V(s) */
	if ((rc = advantages(b, w.adv))) {
		rc = pr_err(err, rc, "cmaes: baseline regression failed");
		goto done;
	}
	r = learning_rates(c, rank_weights(&w, b->n));
	old_means(c, b, &w);
	if ((rc = new_mean(c, b, &w, &flags, err)))
		goto done;
	hsig = new_paths(c, &r, &w, &psn);
	new_covariance(c, &r, hsig, &w);
	/* sigma <- sigma exp((c_sigma / d_sigma) (|p_sigma| / E|N(0, I)| - 1)) */
	sigma = c->sigma * exp(r.csig / r.dsig * (psn / r.chin - 1.0));
	if (!(sigma > 0.0) || !isfinite(sigma)) {
		rc = pr_err(err, PR_ENUM, "cmaes: step size became %g", sigma);
		goto done;
	}
	if ((rc = decompose(da, w.Cn, w.Vn, w.evn))) {
		rc = pr_err(err, rc, "cmaes: covariance lost positive definiteness");
		goto done;
	}
	/* commit */
	memcpy(c->W, w.Wn, (size_t)da * nf * sizeof *w.Wn);
	memcpy(c->C, w.Cn, (size_t)da * da * sizeof *w.Cn);
	memcpy(c->V, w.Vn, (size_t)da * da * sizeof *w.Vn);
	memcpy(c->ev, w.evn, (size_t)da * sizeof *w.evn);
	memcpy(c->pc, w.pc, (size_t)da * sizeof *w.pc);
	memcpy(c->ps, w.ps, (size_t)da * sizeof *w.ps);
	c->sigma = sigma;
	c->g++;
	if (info) {
		info->mueff = r.mueff;
		info->sigma = sigma;
		info->ps_norm = psn;
		info->hsig = hsig;
		info->flags = flags;
	}
done:
	work_free(&w);
	return rc;
}

pr_policy *pr_cmaes_policy(const pr_cmaes *c, double min_std, int *floored, char *err)
{
	const int da = c->da;
	double *cov, *lam, f2 = min_std * min_std;
	pr_policy *p;
	int j, l, m;

	if (floored)
		*floored = 0;
	if (!(min_std > 0.0) || !isfinite(min_std)) {
		pr_err(err, PR_EINVAL, "cmaes: min_std must be > 0 (got %g)", min_std);
		return NULL;
	}
	cov = malloc((size_t)da * da * sizeof *cov);
	lam = malloc((size_t)da * sizeof *lam);
	if (!cov || !lam) {
		free(cov);
		free(lam);
		pr_err(err, PR_ENOMEM, "cmaes: out of memory");
		return NULL;
	}
	/* sigma^2 C = V diag(sigma^2 ev) V^T, eigenvalues floored */
	for (m = 0; m < da; m++) {
		lam[m] = c->sigma * c->sigma * c->ev[m];
		if (lam[m] < f2) {
			lam[m] = f2;
			if (floored)
				*floored = 1;
		}
	}
	for (j = 0; j < da; j++)
		for (l = j; l < da; l++) {
			double v = 0.0;

			for (m = 0; m < da; m++)
				v += c->V[j * da + m] * lam[m] * c->V[l * da + m];
			cov[j * da + l] = cov[l * da + j] = v;
		}
	p = pr_policy_linear_new(c->features, c->ds, da, c->W, cov, err);
	free(cov);
	free(lam);
	return p;
}
