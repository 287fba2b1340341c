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

int pr_cmaes_update(pr_cmaes *c, const pr_cmaes_batch *b, pr_cmaes_info *info, char *err)
{
	const int da = c->da, nf = c->nf, n = b->n, mu = b->n / 2;
	const double ntot = da + c->ds;
	double *adv = NULL, *d = NULL, *M = NULL, *psi = NULL, *phibar = NULL, *Wn = NULL;
	double *Z = NULL, *Cn = NULL, *Vn = NULL, *evn = NULL, *y = NULL, *z = NULL;
	double *pc = NULL, *ps = NULL;
	double dsum = 0.0, d2 = 0.0, mueff, csig, dsig, cc, c1, cmu, chin, psn = 0.0, sig2, dh;
	double sigma;
	size_t *order = NULL;
	pr_policy *fit = NULL;
	pr_policy_data pd;
	int i, j, l, hsig, flags = 0, rc;

	if ((rc = check_batch(c, b, err)))
		return rc;
	adv = malloc((size_t)n * sizeof *adv);
	d = calloc((size_t)n, sizeof *d);
	M = malloc((size_t)n * da * sizeof *M);
	psi = malloc((size_t)nf * sizeof *psi);
	phibar = calloc((size_t)nf, sizeof *phibar);
	Wn = malloc((size_t)da * nf * sizeof *Wn);
	Z = malloc((size_t)da * da * sizeof *Z);
	Cn = malloc((size_t)da * da * sizeof *Cn);
	Vn = malloc((size_t)da * da * sizeof *Vn);
	evn = malloc((size_t)da * sizeof *evn);
	y = malloc((size_t)da * sizeof *y);
	z = malloc((size_t)da * sizeof *z);
	pc = malloc((size_t)da * sizeof *pc);
	ps = malloc((size_t)da * sizeof *ps);
	order = malloc((size_t)n * sizeof *order);
	if (!adv || !d || !M || !psi || !phibar || !Wn || !Z || !Cn || !Vn || !evn || !y || !z ||
	    !pc || !ps || !order) {
		rc = pr_err(err, PR_ENOMEM, "cmaes: out of memory");
		goto done;
	}
	/* advantages and rank weights d_i: the best mu samples by R - V(s) */
	if ((rc = advantages(b, adv))) {
		rc = pr_err(err, rc, "cmaes: baseline regression failed");
		goto done;
	}
	gsl_sort_index(order, adv, 1, (size_t)n);
	for (i = 0; i < mu; i++) {
		d[order[n - 1 - i]] = log(mu + 0.5) - log(i + 1.0);
		dsum += d[order[n - 1 - i]];
	}
	for (i = 0; i < n; i++) {
		d[i] /= dsum;
		d2 += d[i] * d[i];
	}
	mueff = 1.0 / d2;
	csig = (mueff + 2.0) / (ntot + mueff + 5.0);
	dsig = 1.0 + 2.0 * fmax(0.0, sqrt((mueff - 1.0) / (ntot + 1.0)) - 1.0) + csig + log(c->ds + 1.0);
	cc = (4.0 + mueff / ntot) / (ntot + 4.0 + 2.0 * mueff / ntot);
	c1 = 2.0 / ((ntot + 1.3) * (ntot + 1.3) + mueff);
	cmu = fmin(1.0 - c1, 2.0 * (mueff - 2.0 + 1.0 / mueff) / ((ntot + 2.0) * (ntot + 2.0) + mueff));
	chin = sqrt((double)da) * (1.0 - 1.0 / (4.0 * da) + 1.0 / (21.0 * da * da));

	/* old means W_old psi(s_i) and the batch's mean features */
	for (i = 0; i < n; i++) {
		pr_policy_features(c->features, b->S + (size_t)i * c->ds, c->ds, psi);
		for (l = 0; l < nf; l++)
			phibar[l] += psi[l] / n;
		for (j = 0; j < da; j++) {
			M[(size_t)i * da + j] = 0.0;
			for (l = 0; l < nf; l++)
				M[(size_t)i * da + j] += c->W[j * nf + l] * psi[l];
		}
	}
	/* mean: weighted linear regression of x on psi(s) with the weights d;
	 * the same fit's residual covariance around the old means is
	 * sum_i d_i (x_i - m_i)(x_i - m_i)^T, sigma^2 times the rank-mu term */
	memset(&pd, 0, sizeof pd);
	pd.n = n;
	pd.ds = c->ds;
	pd.da = da;
	pd.S = b->S;
	pd.A = b->X;
	pd.w = d;
	pd.M = M;
	if (!(fit = pr_policy_linear_fit(c->features, &pd, c->lambda, 0.0, PR_COV_CENTER_OLD, &flags,
	                                 err))) {
		rc = PR_ENUM;
		goto done;
	}
	pr_policy_linear_params(fit, Wn, Z, err);
	sigma = c->sigma;
	sig2 = sigma * sigma;

	/* y_w = (W_new - W_old) psi_bar / sigma: the mean shift at the batch's
	 * mean context features, in units of sigma */
	for (j = 0; j < da; j++) {
		y[j] = 0.0;
		for (l = 0; l < nf; l++)
			y[j] += (Wn[j * nf + l] - c->W[j * nf + l]) * phibar[l];
		y[j] /= sigma;
	}
	/* p_sigma <- (1 - c_sigma) p_sigma + sqrt(c_sigma (2 - c_sigma) mueff) C^(-1/2) y_w */
	for (l = 0; l < da; l++) {
		z[l] = 0.0;
		for (j = 0; j < da; j++)
			z[l] += c->V[j * da + l] * y[j];
		z[l] /= sqrt(c->ev[l]);
	}
	for (j = 0; j < da; j++) {
		double v = 0.0;

		for (l = 0; l < da; l++)
			v += c->V[j * da + l] * z[l];
		ps[j] = (1.0 - csig) * c->ps[j] + sqrt(csig * (2.0 - csig) * mueff) * v;
		psn += ps[j] * ps[j];
	}
	psn = sqrt(psn);
	/* h_sigma stalls the rank-one path while |p_sigma| is large */
	hsig = psn / sqrt(1.0 - pow(1.0 - csig, 2.0 * (c->g + 1))) < (1.4 + 2.0 / (da + 1.0)) * chin;
	/* p_c <- (1 - c_c) p_c + h_sigma sqrt(c_c (2 - c_c) mueff) y_w */
	for (j = 0; j < da; j++)
		pc[j] = (1.0 - cc) * c->pc[j] + hsig * sqrt(cc * (2.0 - cc) * mueff) * y[j];
	/* C <- (1 + c_1 delta(h_sigma) - c_1 - c_mu) C + c_1 p_c p_c^T
	 *      + c_mu sum_i d_i y_i y_i^T,   y_i = (x_i - W_old psi(s_i)) / sigma,
	 * delta(h_sigma) = (1 - h_sigma) c_c (2 - c_c): the contextual rank-mu
	 * update around the old mean */
	dh = (1 - hsig) * cc * (2.0 - cc);
	for (j = 0; j < da; j++)
		for (l = j; l < da; l++) {
			double v = (1.0 + c1 * dh - c1 - cmu) * c->C[j * da + l] + c1 * pc[j] * pc[l] +
			           cmu * 0.5 * (Z[j * da + l] + Z[l * da + j]) / sig2;

			Cn[j * da + l] = Cn[l * da + j] = v;
		}
	/* sigma <- sigma exp((c_sigma / d_sigma) (|p_sigma| / E|N(0, I)| - 1)) */
	sigma *= exp(csig / dsig * (psn / chin - 1.0));
	if (!(sigma > 0.0) || !isfinite(sigma)) {
		rc = pr_err(err, PR_ENUM, "cmaes: step size became %g", sigma);
		goto done;
	}
	if ((rc = decompose(da, Cn, Vn, evn))) {
		rc = pr_err(err, rc, "cmaes: covariance lost positive definiteness");
		goto done;
	}
	/* commit */
	memcpy(c->W, Wn, (size_t)da * nf * sizeof *Wn);
	memcpy(c->C, Cn, (size_t)da * da * sizeof *Cn);
	memcpy(c->V, Vn, (size_t)da * da * sizeof *Vn);
	memcpy(c->ev, evn, (size_t)da * sizeof *evn);
	memcpy(c->pc, pc, (size_t)da * sizeof *pc);
	memcpy(c->ps, ps, (size_t)da * sizeof *ps);
	c->sigma = sigma;
	c->g++;
	if (info) {
		info->mueff = mueff;
		info->sigma = sigma;
		info->ps_norm = psn;
		info->hsig = hsig;
		info->flags = flags;
	}
done:
	pr_policy_free(fit);
	free(adv);
	free(d);
	free(M);
	free(psi);
	free(phibar);
	free(Wn);
	free(Z);
	free(Cn);
	free(Vn);
	free(evn);
	free(y);
	free(z);
	free(pc);
	free(ps);
	free(order);
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
