/* learner.c — the ask/tell learner (learner.h): a window of episodes,
 * importance weights, value features, REPS and the policy fit.
 *
 * Storage: the window's episodes oldest first, each with its drawing
 * policy and log pi_m(a|s) under every live policy m (a row whose column
 * m - pbase, pbase the oldest live policy). A policy lives while an episode
 * it drew is in the window. Each fitted policy keeps its fit's inputs and
 * the random stream's state before the fit, so a saved learner refits it
 * bit for bit on load. A tell builds the next window and policy aside and
 * commits them only when everything succeeded.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "poolreps/learner.h"
#include "poolreps/internal.h"

#define MAX_REDRAW 100   /* draws of an action beyond max_norm */
#define MAX_DIM 100000   /* context, action, target and feature dimensions */
#define MAX_WINDOW 10000000
#define MAX_ACTION 1000  /* action dimensions (two da x da scratch covariances per learner) */

typedef struct {
	pr_policy *p;
	pr_policy_work *w;
	int n, dy;               /* fit: window size (0: pi_0) and target dimensions */
	double *X, *A, *Y, *wt, *M;
	unsigned char *rs;       /* the stream's state before a tree fit */
} lpol;

/* A window of episodes (or the last ask's): rows with lp under live policies. */
typedef struct {
	int n, lc;               /* episodes, lp columns */
	double *X, *A, *R, *Y, *G, *mu, *lp;
	int *it;
} win;

struct pr_learner {
	pr_learner_opts o;
	int dx, da, dy, dg;      /* dy, dg: 0 until a tell gives targets, features */
	gsl_rng *rng;
	int niter, pbase, given0; /* given0: pi_0 came from set_policy */
	int npol, cpol;          /* live policies pbase .. niter and capacity */
	lpol *pol;
	win w, ask;              /* the window; the last ask (ask.lc policies from pbase) */
	int ask_iter;            /* iteration of the last ask, -1: none */
	int redraws, ask_flags;
	int bad_row;             /* the row the last ask, mean or tell failed at, or -1 */
	pr_learner_summary last;
	char **names;            /* dx + da column names, or NULL */
	double *m0, *c0, *m1, *c1; /* scratch mean (da) and covariance (da x da): two levels,
	                            * as pol_lp runs inside ask_one */
};

void pr_learner_opts_init(pr_learner_opts *o)
{
	memset(o, 0, sizeof *o);
	o->value = PR_LEARNER_VALUE_TREES;
	o->policy_type = PR_LEARNER_POLICY_TREE;
	o->window = 400;
	o->init_std = 1.0;
	o->truncation = PR_LEARNER_REDRAW;
	/* Experiment 3's value forests (thesis 7.5.1): about 7 leaves per tree
	 * on 200 episodes; with n_min 20 the forest has more leaves than
	 * episodes and REPS's bound is often out of reach */
	pr_forest_opts_init(&o->value_forest);
	o->value_forest.trees = 10;
	o->value_forest.cuts = 10;
	o->value_forest.n_min = 60;
	o->value_features = PR_VALUE_LEAVES;
	pr_reps_opts_init(&o->reps);
	pr_policy_opts_init(&o->policy);
}

int pr_learner_opts_check(const pr_learner_opts *o, char *err)
{
	int rc;

	if (o->value < PR_LEARNER_VALUE_TREES || o->value > PR_LEARNER_VALUE_GIVEN)
		return pr_err(err, PR_EINVAL, "learner.value: unknown value features %d", o->value);
	if (o->policy_type != PR_LEARNER_POLICY_TREE && o->policy_type != PR_LEARNER_POLICY_LINEAR)
		return pr_err(err, PR_EINVAL, "learner.policy: unknown policy %d", o->policy_type);
	if ((o->window < 2 && o->window != 0) || o->window > MAX_WINDOW)
		return pr_err(err, PR_EINVAL, "learner.window: must be 0 or in 2 .. %d (got %d)",
		              MAX_WINDOW, o->window);
	/* init_std^2 must stay a normal double: the covariance of pi_0 */
	if (!(o->init_std >= 1e-100 && o->init_std <= 1e6))
		return pr_err(err, PR_EINVAL, "learner.init_std: must be in 1e-100 .. 1e6 (got %g)",
		              o->init_std);
	if (!(o->max_norm >= 0) || !isfinite(o->max_norm))
		return pr_err(err, PR_EINVAL, "learner.max_norm: must be >= 0 (got %g)", o->max_norm);
	if (o->truncation < PR_LEARNER_REDRAW || o->truncation > PR_LEARNER_CORRECTED)
		return pr_err(err, PR_EINVAL, "learner.truncation: unknown mode %d", o->truncation);
	if (o->draw != PR_LEARNER_DRAW_QUERY && o->draw != PR_LEARNER_DRAW_FIT)
		return pr_err(err, PR_EINVAL, "learner.draw: unknown mode %d", o->draw);
	if (o->value_features != PR_VALUE_LEAVES && o->value_features != PR_VALUE_SAMPLES)
		return pr_err(err, PR_EINVAL, "value.features: unknown kind %d", o->value_features);
	if (!(o->reps.epsilon > 0) || !isfinite(o->reps.epsilon))
		return pr_err(err, PR_EINVAL, "reps.epsilon: must be > 0 (got %g)", o->reps.epsilon);
	if ((rc = pr_forest_opts_check(&o->value_forest, "value", err)))
		return rc;
	return pr_policy_opts_check(&o->policy, err);
}

/* ---- memory ---- */

static void win_free(win *w)
{
	free(w->X);
	free(w->A);
	free(w->R);
	free(w->Y);
	free(w->G);
	free(w->mu);
	free(w->lp);
	free(w->it);
	memset(w, 0, sizeof *w);
}

/* Room for n episodes with lc lp columns, dy targets, dg features and mu as
 * the learner has them. */
static int win_alloc(const pr_learner *L, win *w, int n, int lc, int dy, int dg, char *err)
{
	size_t m = n > 0 ? (size_t)n : 1;
	int mu = L->o.policy.cov_center == PR_COV_CENTER_OLD;

	memset(w, 0, sizeof *w);
	w->n = n;
	w->lc = lc;
	/* zeroed: an ask's window has no returns yet, and is saved as it is */
	w->X = calloc(m * L->dx, sizeof *w->X);
	w->A = calloc(m * L->da, sizeof *w->A);
	w->R = calloc(m, sizeof *w->R);
	w->Y = dy ? calloc(m * dy, sizeof *w->Y) : NULL;
	w->G = dg ? calloc(m * dg, sizeof *w->G) : NULL;
	w->mu = mu ? calloc(m * L->da, sizeof *w->mu) : NULL;
	w->lp = calloc(m * (lc > 0 ? (size_t)lc : 1), sizeof *w->lp);
	w->it = calloc(m, sizeof *w->it);
	if (!w->X || !w->A || !w->R || (dy && !w->Y) || (dg && !w->G) || (mu && !w->mu) ||
	    !w->lp || !w->it) {
		win_free(w);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	return PR_OK;
}

static void lpol_free(lpol *p)
{
	pr_policy_free(p->p);
	pr_policy_work_free(p->w);
	free(p->X);
	free(p->A);
	free(p->Y);
	free(p->wt);
	free(p->M);
	free(p->rs);
	memset(p, 0, sizeof *p);
}

static void free_names(char **names, int n)
{
	int j;

	for (j = 0; names && j < n; ++j)
		free(names[j]);
	free(names);
}

void pr_learner_free(pr_learner *L)
{
	int k;

	if (!L)
		return;
	for (k = 0; k < L->npol; ++k)
		lpol_free(&L->pol[k]);
	free(L->pol);
	win_free(&L->w);
	win_free(&L->ask);
	free_names(L->names, L->dx + L->da);
	free(L->m0);
	free(L->m1);
	free(L);
}

/* pi_0 = N(0, init_std^2 I) as the only live policy. */
static int default_pi0(pr_learner *L, char *err)
{
	double *mean = calloc((size_t)L->da, sizeof *mean);
	double *cov = calloc((size_t)L->da * L->da, sizeof *cov);
	int j, rc = mean && cov ? PR_OK : pr_err(err, PR_ENOMEM, "out of memory");

	for (j = 0; rc == PR_OK && j < L->da; ++j)
		cov[j * L->da + j] = L->o.init_std * L->o.init_std;
	if (rc == PR_OK && !(L->pol[0].p = pr_policy_gaussian_new(L->dx, L->da, mean, cov, err)))
		rc = PR_EINVAL;
	if (rc == PR_OK && !(L->pol[0].w = pr_policy_work_new(L->pol[0].p, err)))
		rc = PR_ENOMEM;
	free(mean);
	free(cov);
	return rc;
}

pr_learner *pr_learner_new(const pr_learner_opts *o, int dx, int da, gsl_rng *rng, char *err)
{
	pr_learner *L;

	if (pr_learner_opts_check(o, err))
		return NULL;
	if (dx < 1 || dx > MAX_DIM || da < 1 || da > MAX_ACTION) {
		pr_err(err, PR_EINVAL, "learner: context dimensions must be in 1 .. %d and action "
		       "dimensions in 1 .. %d (got %d and %d)", MAX_DIM, MAX_ACTION, dx, da);
		return NULL;
	}
	if (o->truncation == PR_LEARNER_CORRECTED && o->max_norm > 0 && da != 2) {
		pr_err(err, PR_EINVAL, "learner.truncation: corrected needs 2 action dimensions (got %d)", da);
		return NULL;
	}
	if (!(L = calloc(1, sizeof *L)) || !(L->pol = calloc(4, sizeof *L->pol))) {
		free(L);
		pr_err(err, PR_ENOMEM, "out of memory");
		return NULL;
	}
	L->o = *o;
	L->dx = dx;
	L->da = da;
	L->m0 = malloc(((size_t)da * da + da) * sizeof *L->m0);
	L->m1 = malloc(((size_t)da * da + da) * sizeof *L->m1);
	if (!L->m0 || !L->m1) {
		pr_learner_free(L);
		pr_err(err, PR_ENOMEM, "out of memory");
		return NULL;
	}
	L->c0 = L->m0 + da;
	L->c1 = L->m1 + da;
	L->rng = rng;
	L->npol = 1;
	L->cpol = 4;
	L->ask_iter = -1;
	L->bad_row = -1;
	L->last.status = PR_REPS_ACTIVE;
	if (default_pi0(L, err) || pr_learner_set_names(L, NULL, err)) {
		pr_learner_free(L);
		return NULL;
	}
	return L;
}

void pr_learner_set_rng(pr_learner *L, gsl_rng *rng)
{
	L->rng = rng;
}

int pr_learner_set_policy(pr_learner *L, pr_policy *p, char *err)
{
	pr_policy_work *w;

	if (L->niter > 0 || L->ask_iter >= 0 || pr_policy_ds(p) != L->dx || pr_policy_da(p) != L->da) {
		pr_policy_free(p);
		return pr_err(err, PR_EINVAL, "learner: an initial policy is set before the first ask "
		              "and tell, with the learner's dimensions");
	}
	if (!(w = pr_policy_work_new(p, err))) {
		pr_policy_free(p);
		return PR_ENOMEM;
	}
	lpol_free(&L->pol[0]);
	L->pol[0].p = p;
	L->pol[0].w = w;
	L->given0 = 1;
	return PR_OK;
}

int pr_learner_set_options(pr_learner *L, const pr_learner_opts *o, char *err)
{
	int rc;

	if ((rc = pr_learner_opts_check(o, err)))
		return rc;
	if (L->niter > 0 || (L->ask_iter >= 0 && (o->policy.cov_center != L->o.policy.cov_center ||
	                                          o->max_norm != L->o.max_norm ||
	                                          o->truncation != L->o.truncation)))
		return pr_err(err, PR_EINVAL, "learner: options change before the first tell, and after "
		              "an ask only where the ask's densities stay valid");
	if (o->truncation == PR_LEARNER_CORRECTED && o->max_norm > 0 && L->da != 2)
		return pr_err(err, PR_EINVAL, "learner.truncation: corrected needs 2 action dimensions");
	L->o = *o;
	if (L->ask_iter >= 0 || L->given0)
		return PR_OK;
	/* pi_0 of the new init_std */
	lpol_free(&L->pol[0]);
	return default_pi0(L, err);
}

/* ---- densities ---- */

#define DISC_DIRS 2048 /* directions of the quadrature */
#define DISC_SIGMAS 8  /* a disc holding the 8-sigma ellipse holds all the mass */

double pr_learner_disc_logmass(const double mean[2], const double cov[4], double vmax)
{
	const double tr = 0.5 * (cov[0] + cov[3]), df = 0.5 * (cov[0] - cov[3]);
	const double lmax = tr + sqrt(df * df + cov[1] * cov[1]);
	const double l11 = sqrt(cov[0]), l21 = cov[2] / l11, l22 = sqrt(fmax(0, cov[3] - l21 * l21));
	const double mm = mean[0] * mean[0] + mean[1] * mean[1] - vmax * vmax;
	double z = 0;
	int k;

	if (hypot(mean[0], mean[1]) + DISC_SIGMAS * sqrt(lmax) <= vmax)
		return 0;
	/* a = mean + L r u(phi), r^2 ~ chi^2_2: the ray's mass inside the disc is
	 * e^{-lo^2/2} - e^{-hi^2/2} for the roots lo <= hi of |mean + r w|^2 = vmax^2 */
	for (k = 0; k < DISC_DIRS; ++k) {
		double ph = 4 * acos(0.0) * k / DISC_DIRS, u0 = cos(ph), u1 = sin(ph);
		double w0 = l11 * u0, w1 = l21 * u0 + l22 * u1;
		double ww = w0 * w0 + w1 * w1, mw = mean[0] * w0 + mean[1] * w1, disc = mw * mw - ww * mm;
		double lo, hi;
		if (disc <= 0 || ww == 0)
			continue;
		lo = fmax(0, (-mw - sqrt(disc)) / ww);
		hi = fmax(0, (-mw + sqrt(disc)) / ww);
		z += exp(-0.5 * lo * lo) - exp(-0.5 * hi * hi);
	}
	z /= DISC_DIRS;
	return z > 0 ? log(fmin(z, 1)) : -HUGE_VAL;
}

static int corrected(const pr_learner *L)
{
	return L->o.max_norm > 0 && L->o.truncation == PR_LEARNER_CORRECTED;
}

/* log N(a; mean, cov), divided by the mass inside max_norm when corrected. */
static int gauss_lp(const pr_learner *L, const double *mean, const double *cov, const double *a,
                    double *lp, char *err)
{
	int rc = pr_policy_gauss_logpdf(L->da, mean, cov, a, lp, err);

	if (rc == PR_OK && corrected(L))
		*lp -= pr_learner_disc_logmass(mean, cov, L->o.max_norm);
	return rc;
}

/* log pi(a|x) of live policy P, truncated as gauss_lp says. */
static int pol_lp(const pr_learner *L, const lpol *P, const double *x, const double *a,
                  double *lp, int *flags, char *err)
{
	double *m = L->m1, *c = L->c1;
	int rc;

	if (!corrected(L))
		return pr_policy_logpdf(P->p, x, a, lp, flags, P->w, err);
	/* corrected: two action dimensions */
	if ((rc = pr_policy_eval(P->p, x, m, c, flags, P->w, err)))
		return rc;
	return gauss_lp(L, m, c, a, lp, err);
}

static int finite_rows(const double *v, int n, int d, const char *what, char *err)
{
	int i, j;

	for (i = 0; i < n; ++i)
		for (j = 0; j < d; ++j)
			if (!isfinite(v[(size_t)i * d + j]))
				return pr_err(err, PR_EINVAL, "%s: row %d, column %d is not finite (%g)", what, i,
				              j, v[(size_t)i * d + j]);
	return PR_OK;
}

/* ---- ask ---- */

/* Draw one action a at context x from the current policy's N(mean, cov),
 * within max_norm. */
static double norm(const pr_learner *L, const double *a)
{
	double s = 0;
	int j;

	if (L->da == 2)
		return hypot(a[0], a[1]);
	for (j = 0; j < L->da; ++j)
		s += a[j] * a[j];
	return sqrt(s);
}

static int draw(pr_learner *L, int i, const double *x, const double *mean, const double *cov,
                double *a, char *err)
{
	const lpol *cur = &L->pol[L->npol - 1];
	const double vmax = L->o.max_norm;
	int rc, j, tries = 0, clipped = 0;

	do {
		if (tries++ == MAX_REDRAW)
			return pr_err(err, PR_ENUM, "contexts: row %d: %d actions drawn, all beyond "
			              "learner.max_norm = %g", i, MAX_REDRAW, vmax);
		rc = L->o.draw == PR_LEARNER_DRAW_FIT
		     ? pr_policy_sample(cur->p, x, 1, L->rng, a, NULL, cur->w, err)
		     : pr_policy_gauss_sample(L->da, mean, cov, 1, L->rng, a, err);
		if (rc)
			return rc;
		if (vmax > 0 && L->o.truncation == PR_LEARNER_CLIP && norm(L, a) > vmax) {
			/* scaled strictly inside the limit (the product may round above it) */
			double shrink = vmax / norm(L, a) * (1.0 - 1e-12);
			for (j = 0; j < L->da; ++j)
				a[j] *= shrink;
			clipped = 1;
		}
	} while (vmax > 0 && norm(L, a) > vmax);
	L->redraws += tries - 1 + clipped;
	return PR_OK;
}

/* rc of a failure at row i: the message names the row, and the caller
 * may too (pr_learner_bad_row: a file's line). */
static int row_failed(pr_learner *L, int i, int rc, char *err)
{
	char msg[PR_ERRLEN];

	snprintf(msg, sizeof msg, "%s", err);
	L->bad_row = i;
	return pr_err(err, rc, "contexts: row %d: %s", i, msg);
}

/* Episode i of an ask into w: its action and its densities under the live policies. */
static int ask_one(pr_learner *L, win *w, int i, int *flags, char *err)
{
	const lpol *cur = &L->pol[L->npol - 1];
	const double *x = w->X + (size_t)i * L->dx;
	double *m = L->m0, *c = L->c0;
	double *a = w->A + (size_t)i * L->da;
	double *lp = w->lp + (size_t)i * w->lc;
	int rc, k, f = 0;

	if ((rc = pr_policy_eval(cur->p, x, m, c, &f, cur->w, err)))
		return row_failed(L, i, rc, err);
	*flags |= f;
	if (w->mu)
		memcpy(w->mu + (size_t)i * L->da, m, (size_t)L->da * sizeof *m);
	if ((rc = draw(L, i, x, m, c, a, err)))
		return rc; /* its message names the row */
	/* the density of the decomposition the action was drawn with */
	rc = L->o.draw == PR_LEARNER_DRAW_FIT ? pol_lp(L, cur, x, a, &lp[L->npol - 1], &f, err)
	                                      : gauss_lp(L, m, c, a, &lp[L->npol - 1], err);
	if (rc)
		return row_failed(L, i, rc, err);
	for (k = 0; k < L->npol - 1; ++k) {
		f = 0;
		if ((rc = pol_lp(L, &L->pol[k], x, a, &lp[k], &f, err)))
			return row_failed(L, i, rc, err);
		*flags |= f;
	}
	return PR_OK;
}

static int check_rows(int n, const void *x, const void *a, char *err)
{
	if (n < 1)
		return pr_err(err, PR_EINVAL, "learner: no episodes (n = %d)", n);
	if (n > MAX_WINDOW)
		return pr_err(err, PR_EINVAL, "learner: %d rows, at most %d at once", n, MAX_WINDOW);
	if (!x || !a)
		return pr_err(err, PR_EINVAL, "learner: contexts and actions are required");
	return PR_OK;
}

int pr_learner_ask(pr_learner *L, int n, const double *contexts, double *actions, char *err)
{
	gsl_rng *keep;
	win w;
	int i, rc, flags = 0;

	L->bad_row = -1;
	if ((rc = check_rows(n, contexts, actions, err)) ||
	    (rc = finite_rows(contexts, n, L->dx, "contexts", err)))
		return rc;
	if ((rc = win_alloc(L, &w, n, L->npol, 0, 0, err)))
		return rc;
	if (!(keep = gsl_rng_clone(L->rng))) {
		win_free(&w);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	memcpy(w.X, contexts, (size_t)n * L->dx * sizeof *w.X);
	L->redraws = 0;
	for (i = 0; i < n && rc == PR_OK; ++i) {
		w.it[i] = L->niter;
		rc = ask_one(L, &w, i, &flags, err);
	}
	if (rc) {
		gsl_rng_memcpy(L->rng, keep);
		win_free(&w);
	} else {
		memcpy(actions, w.A, (size_t)n * L->da * sizeof *w.A);
		win_free(&L->ask);
		L->ask = w;
		L->ask_iter = L->niter;
		L->ask_flags = flags;
	}
	gsl_rng_free(keep);
	return rc;
}

int pr_learner_check_targets(const pr_learner *L, int given, char *err)
{
	if (given && !(L->o.policy_type == PR_LEARNER_POLICY_TREE &&
	               L->o.policy.target == PR_TARGET_REWARD_STATE))
		return pr_err(err, PR_EINVAL, "targets: given, but only the tree policy with "
		              "policy.target = reward_state reads them");
	return PR_OK;
}

int pr_learner_bad_row(const pr_learner *L)
{
	return L->bad_row;
}

void pr_learner_ask_info(const pr_learner *L, int *redraws, int *flags)
{
	if (redraws)
		*redraws = L->redraws;
	if (flags)
		*flags = L->ask_flags;
}

int pr_learner_mean(pr_learner *L, int n, const double *contexts, double *actions, char *err)
{
	const lpol *cur = &L->pol[L->npol - 1];
	double *cov = L->c0;
	int i, rc;

	L->bad_row = -1;
	if ((rc = check_rows(n, contexts, actions, err)) ||
	    (rc = finite_rows(contexts, n, L->dx, "contexts", err)))
		return rc;
	for (i = 0; i < n; ++i)
		if ((rc = pr_policy_eval(cur->p, contexts + (size_t)i * L->dx,
		                         actions + (size_t)i * L->da, cov, NULL, cur->w, err)))
			return row_failed(L, i, rc, err);
	return PR_OK;
}

/* ---- tell ---- */

/* A tell's next state, built aside. */
typedef struct {
	win w;               /* the next window; lp columns from policy pmin */
	int pmin, t, dy, dg, flags;
	lpol np;             /* pi_t */
	double *q, *p, *logpi, *logcur, *phi;
	int *counts, *rowptr, *col;
	pr_learner_summary s;
} stage;

static void stage_free(stage *S)
{
	win_free(&S->w);
	lpol_free(&S->np);
	free(S->q);
	free(S->p);
	free(S->logpi);
	free(S->logcur);
	free(S->phi);
	free(S->counts);
	free(S->rowptr);
	free(S->col);
}

typedef pr_learner_batch told;

/* Quadratic value features s_j s_k of each told context, finite: a context
 * beyond about 1e154 squares to infinity, which REPS would refuse as a
 * bad feature of no row of the caller's. */
static int quadratic_finite(pr_learner *L, const told *b, char *err)
{
	const int d = pr_policy_features_count(PR_FEATURES_QUADRATIC, L->dx);
	double *phi = malloc((size_t)d * sizeof *phi);
	int i, j, rc = phi ? PR_OK : pr_err(err, PR_ENOMEM, "out of memory");

	for (i = 0; rc == PR_OK && i < b->n; ++i) {
		pr_policy_features(PR_FEATURES_QUADRATIC, b->contexts + (size_t)i * L->dx, L->dx, phi);
		for (j = 0; rc == PR_OK && j < d; ++j)
			if (!isfinite(phi[j]))
				rc = row_failed(L, i, pr_err(err, PR_EINVAL, "learner.value = quadratic: "
				                             "feature %d overflows", j), err);
	}
	free(phi);
	return rc;
}

static int check_told(pr_learner *L, const told *b, char *err)
{
	int rc;

	if ((rc = check_rows(b->n, b->contexts, b->actions, err)))
		return rc;
	/* REPS weighs at least two episodes (a window > 0 keeps at least two) */
	if ((L->o.window ? L->w.n + b->n : b->n) < 2)
		return pr_err(err, PR_EINVAL, "learner: 1 episode to weigh (%s): REPS needs at least 2",
		              L->o.window ? "the first tell" : "learner.window = 0");
	if (!b->returns)
		return pr_err(err, PR_EINVAL, "learner: returns are required");
	if ((rc = finite_rows(b->contexts, b->n, L->dx, "contexts", err)) ||
	    (rc = finite_rows(b->actions, b->n, L->da, "actions", err)) ||
	    (rc = finite_rows(b->returns, b->n, 1, "returns", err)))
		return rc;
	if ((L->o.value == PR_LEARNER_VALUE_GIVEN) != (b->features != NULL))
		return pr_err(err, PR_EINVAL, "features: %s", b->features ? "given, but learner.value is not "
		              "given" : "required by learner.value = given");
	if (b->features && (b->d < 1 || b->d > MAX_DIM || (L->dg && b->d != L->dg)))
		return pr_err(err, PR_EINVAL, "features: %d columns (%s)", b->d,
		              L->dg ? "the first tell had another count" : "must be 1 .. 100000");
	if (b->features && (rc = finite_rows(b->features, b->n, b->d, "features", err)))
		return rc;
	if (b->targets && (b->dy < 1 || b->dy > MAX_DIM || (L->niter > 0 && b->dy != L->dy)))
		return pr_err(err, PR_EINVAL, "targets: %d columns (the learner has %d)", b->dy, L->dy);
	if (!b->targets && L->dy)
		return pr_err(err, PR_EINVAL, "targets: required (the first tell gave %d columns)", L->dy);
	if (!b->targets && L->o.policy_type == PR_LEARNER_POLICY_TREE && L->o.policy.target == PR_TARGET_REWARD_STATE)
		return pr_err(err, PR_EINVAL, "targets: required by policy.target = reward_state");
	if (b->targets && (rc = finite_rows(b->targets, b->n, b->dy, "targets", err)))
		return rc;
	if (b->logq && (rc = finite_rows(b->logq, b->n, 1, "logq", err)))
		return rc;
	if (L->o.value == PR_LEARNER_VALUE_QUADRATIC)
		return quadratic_finite(L, b, err);
	return PR_OK;
}

/* Batch episode b's densities under policies pmin .. the current one (lp
 * columns from pmin) and its sampling mean: the last ask's when its context
 * and action are the asked ones, else computed now (their flags are not
 * the ask's and are not reported). */
static int told_densities(pr_learner *L, stage *S, const told *b, int i, int j, char *err)
{
	const lpol *cur = &L->pol[L->npol - 1];
	const double *x = b->contexts + (size_t)i * L->dx, *a = b->actions + (size_t)i * L->da;
	double *lp = S->w.lp + (size_t)j * S->w.lc, *mu = S->w.mu ? S->w.mu + (size_t)j * L->da : NULL;
	double *cov = L->c0;
	int k, rc, f = 0, off = S->pmin - L->pbase;

	if (L->ask_iter == L->niter && i < L->ask.n &&
	    !memcmp(x, L->ask.X + (size_t)i * L->dx, (size_t)L->dx * sizeof *x) &&
	    !memcmp(a, L->ask.A + (size_t)i * L->da, (size_t)L->da * sizeof *a)) {
		memcpy(lp, L->ask.lp + (size_t)i * L->ask.lc + off,
		       (size_t)(L->npol - off) * sizeof *lp);
		if (mu)
			memcpy(mu, L->ask.mu + (size_t)i * L->da, (size_t)L->da * sizeof *mu);
		return PR_OK;
	}
	if (mu && (rc = pr_policy_eval(cur->p, x, mu, cov, &f, cur->w, err)))
		return rc;
	for (k = off; k < L->npol; ++k)
		if ((rc = pol_lp(L, &L->pol[k], x, a, &lp[k - off], &f, err)))
			return rc;
	if (b->logq)
		lp[L->npol - 1 - off] = b->logq[i];
	return PR_OK;
}

/* Row s of src (d columns) into row j of dst, when dst exists. */
static void copy_row(double *dst, int j, const double *src, int s, int d)
{
	if (dst)
		memcpy(dst + (size_t)j * d, src + (size_t)s * d, (size_t)d * sizeof *dst);
}

/* The next window: the latest `window` of the old window's episodes and
 * the told ones, with their densities under the policies that stay live. */
static int next_window(pr_learner *L, stage *S, const told *b, char *err)
{
	const win *o = &L->w;
	const int wmax = L->o.window ? L->o.window : b->n; /* 0: the told episodes alone */
	const int total = o->n + b->n, n = total < wmax ? total : wmax;
	const int skip = total - n, dx = L->dx, da = L->da;
	int j, rc, off;

	S->pmin = skip < o->n ? o->it[skip] : L->niter;
	off = S->pmin - L->pbase;
	if ((rc = win_alloc(L, &S->w, n, L->niter - S->pmin + 2, S->dy, S->dg, err)))
		return rc;
	for (j = 0; j < n; ++j) {
		int s = skip + j, i = s - o->n;
		win *w = &S->w;
		if (s < o->n) {
			copy_row(w->X, j, o->X, s, dx);
			copy_row(w->A, j, o->A, s, da);
			copy_row(w->R, j, o->R, s, 1);
			copy_row(w->Y, j, o->Y, s, S->dy);
			copy_row(w->G, j, o->G, s, S->dg);
			copy_row(w->mu, j, o->mu, s, da);
			memcpy(w->lp + (size_t)j * w->lc, o->lp + (size_t)s * o->lc + off,
			       (size_t)(L->npol - off) * sizeof *w->lp);
			w->it[j] = o->it[s];
			continue;
		}
		copy_row(w->X, j, b->contexts, i, dx);
		copy_row(w->A, j, b->actions, i, da);
		copy_row(w->R, j, b->returns, i, 1);
		copy_row(w->Y, j, b->targets, i, S->dy);
		copy_row(w->G, j, b->features, i, S->dg);
		w->it[j] = L->niter;
		if ((rc = told_densities(L, S, b, i, j, err)))
			return row_failed(L, i, rc, err);
	}
	return PR_OK;
}

/* q_i = pi_current(a_i|s_i) / pi_mix(a_i|s_i) over the window. */
static int importance(pr_learner *L, stage *S, char *err)
{
	const int n = S->w.n, npol = L->niter - S->pmin + 1;
	int i, m;

	S->q = malloc((size_t)n * sizeof *S->q);
	S->p = malloc((size_t)n * sizeof *S->p);
	S->logpi = malloc((size_t)n * npol * sizeof *S->logpi);
	S->logcur = malloc((size_t)n * sizeof *S->logcur);
	S->counts = calloc((size_t)npol, sizeof *S->counts);
	if (!S->q || !S->p || !S->logpi || !S->logcur || !S->counts)
		return pr_err(err, PR_ENOMEM, "out of memory");
	for (i = 0; i < n; ++i) {
		const double *lp = S->w.lp + (size_t)i * S->w.lc;
		S->counts[S->w.it[i] - S->pmin]++;
		for (m = 0; m < npol; ++m)
			S->logpi[(size_t)m * n + i] = lp[m];
		S->logcur[i] = lp[npol - 1];
	}
	return pr_reps_importance(npol, n, S->logpi, S->counts, S->logcur, S->q, NULL, &S->s.q_ess, err);
}

/* Value features of the window contexts: one-hot active leaves (CSR, eq.
 * 5.4) or active samples (dense, eq. 5.6) of a forest contexts -> returns,
 * hand-made features, or the caller's. */
static int value_features(pr_learner *L, stage *S, pr_reps_problem *pb, char *err)
{
	const win *w = &S->w;
	const int n = w->n, dx = L->dx, v = L->o.value;
	pr_forest_opts vo = L->o.value_forest;
	pr_forest *f;
	int i, M, rc = PR_OK, kind = v == PR_LEARNER_VALUE_LINEAR ? PR_FEATURES_AFFINE
	                            : PR_FEATURES_QUADRATIC;

	if (v == PR_LEARNER_VALUE_GIVEN) {
		pb->d = S->dg;
		pb->phi = w->G;
		return PR_OK;
	}
	if (v == PR_LEARNER_VALUE_LINEAR || v == PR_LEARNER_VALUE_QUADRATIC) {
		pb->d = pr_policy_features_count(kind, dx);
		if (!(S->phi = malloc((size_t)n * pb->d * sizeof *S->phi)))
			return pr_err(err, PR_ENOMEM, "out of memory");
		for (i = 0; i < n; ++i)
			pr_policy_features(kind, w->X + (size_t)i * dx, dx, S->phi + (size_t)i * pb->d);
		pb->phi = S->phi;
		return PR_OK;
	}
	if (v != PR_LEARNER_VALUE_TREES)
		vo.score = v == PR_LEARNER_VALUE_NRVR ? PR_SCORE_NRVR : PR_SCORE_RVR;
	if (!(f = pr_forest_fit(&vo, w->X, n, dx, w->R, 1, NULL, L->rng, err)))
		return PR_ENUM;
	M = pr_forest_ntrees(f);
	if (L->o.value_features == PR_VALUE_SAMPLES) {
		pb->d = n;
		if (!(S->phi = malloc((size_t)n * n * sizeof *S->phi)))
			rc = pr_err(err, PR_ENOMEM, "out of memory");
		for (i = 0; rc == PR_OK && i < n; ++i)
			rc = pr_forest_active_samples(f, w->X + (size_t)i * dx, dx, S->phi + (size_t)i * n);
		pb->phi = S->phi;
		pr_forest_free(f);
		return rc;
	}
	S->rowptr = malloc(((size_t)n + 1) * sizeof *S->rowptr);
	S->col = malloc((size_t)n * M * sizeof *S->col);
	if (!S->rowptr || !S->col)
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	for (i = 0; rc == PR_OK && i < n; ++i) {
		S->rowptr[i] = i * M;
		rc = pr_forest_active(f, w->X + (size_t)i * dx, dx, S->col + (size_t)i * M, M);
		rc = rc == M ? PR_OK : rc < 0 ? rc : pr_err(err, PR_ENUM, "internal: %d active leaves, "
		                                             "%d trees", rc, M);
	}
	if (rc == PR_OK)
		S->rowptr[n] = n * M;
	pb->d = pr_forest_nleaves(f);
	pb->rowptr = S->rowptr;
	pb->col = S->col;
	pb->val = NULL;
	pr_forest_free(f);
	return rc;
}

/* REPS on the window with base weights q: the weights into S->p. */
static int reps_weights(pr_learner *L, stage *S, char *err)
{
	pr_reps_problem pb;
	pr_reps_result *res = NULL;
	pr_learner_summary *s = &S->s;
	int rc;

	memset(&pb, 0, sizeof pb);
	pb.n = S->w.n;
	pb.R = S->w.R;
	/* window 0: on-policy, the base weights uniform as in C-REPS */
	pb.q = L->o.window ? S->q : NULL;
	if ((rc = value_features(L, S, &pb, err)) ||
	    (rc = pr_reps_solve(&L->o.reps, &pb, &res, err)))
		return rc;
	memcpy(S->p, res->p, (size_t)S->w.n * sizeof *S->p);
	s->eta = res->eta;
	s->kl = res->kl;
	s->ess = res->ess;
	s->residual = res->residual;
	s->bound = res->bound;
	s->nfeat = pb.d;
	s->evals = res->iterations;
	s->kl_gap = res->kl_gap;
	s->residual_rel = res->residual_rel;
	s->status = res->status;
	if (res->status == PR_REPS_FAILED)
		snprintf(s->reason, sizeof s->reason, "%s", res->reason);
	if (res->status == PR_REPS_FAILED && !L->o.reps.allow_failed)
		rc = pr_err(err, PR_ENUM, "iteration %d: REPS answer not certified: %s "
		            "(reps.allow_failed = 1 records such solves and goes on)", S->t, res->reason);
	pr_reps_result_free(res);
	return rc;
}

static double *dup(const double *v, size_t n)
{
	double *c = v ? malloc((n ? n : 1) * sizeof *c) : NULL;

	if (c)
		memcpy(c, v, n * sizeof *c);
	return c;
}

/* Fit policy P from its kept inputs (P->X, A, Y, wt, M over P->n episodes),
 * a tree from the stream state P->rs. */
static int refit_policy(const pr_learner *L, lpol *P, int *flags, char *err)
{
	pr_policy_data d;
	gsl_rng *r = NULL;

	d.n = P->n;
	d.ds = L->dx;
	d.da = L->da;
	d.dy = P->dy;
	d.S = P->X;
	d.A = P->A;
	d.Y = P->Y;
	d.w = P->wt;
	d.M = P->M;
	if (L->o.policy_type == PR_LEARNER_POLICY_LINEAR) {
		P->p = pr_policy_linear_fit(PR_FEATURES_AFFINE, &d, L->o.policy.lambda,
		                            L->o.policy.min_std, L->o.policy.cov_center, flags, err);
	} else {
		if (!(r = gsl_rng_clone(L->rng)))
			return pr_err(err, PR_ENOMEM, "out of memory");
		memcpy(gsl_rng_state(r), P->rs, gsl_rng_size(r));
		P->p = pr_policy_tree_fit(&L->o.policy, &d, r, err);
		/* the learner's stream goes on from where the fit left it */
		memcpy(gsl_rng_state(L->rng), gsl_rng_state(r), gsl_rng_size(r));
		gsl_rng_free(r);
	}
	if (!P->p)
		return PR_ENUM;
	if (!(P->w = pr_policy_work_new(P->p, err)))
		return PR_ENOMEM;
	return PR_OK;
}

/* pi_t fitted to the window with weights p, and the window's densities under it. */
static int fit(pr_learner *L, stage *S, char *err)
{
	const win *w = &S->w;
	const size_t n = (size_t)w->n;
	lpol *P = &S->np;
	int i, rc, col = L->niter + 1 - S->pmin;

	P->n = w->n;
	P->dy = S->dy;
	P->X = dup(w->X, n * L->dx);
	P->A = dup(w->A, n * L->da);
	P->Y = dup(w->Y, n * S->dy);
	P->wt = dup(S->p, n);
	P->M = dup(w->mu, n * L->da);
	P->rs = L->o.policy_type == PR_LEARNER_POLICY_TREE ? malloc(gsl_rng_size(L->rng)) : NULL;
	if (!P->X || !P->A || (w->Y && !P->Y) || !P->wt || (w->mu && !P->M) ||
	    (L->o.policy_type == PR_LEARNER_POLICY_TREE && !P->rs))
		return pr_err(err, PR_ENOMEM, "out of memory");
	if (P->rs)
		memcpy(P->rs, gsl_rng_state(L->rng), gsl_rng_size(L->rng));
	if ((rc = refit_policy(L, P, &S->flags, err)))
		return rc;
	for (i = 0; i < w->n; ++i) {
		int f = 0;
		rc = pol_lp(L, P, w->X + (size_t)i * L->dx, w->A + (size_t)i * L->da,
		            &w->lp[(size_t)i * w->lc + col], &f, err);
		if (rc)
			return rc;
		S->flags |= f;
	}
	return PR_OK;
}

/* The staged state becomes the learner's: the policies older than the
 * window's oldest die, pi_t joins. */
static int commit(pr_learner *L, stage *S, char *err)
{
	int k, drop = S->pmin - L->pbase, need = L->npol - drop + 1;

	if (need > L->cpol) {
		lpol *np = realloc(L->pol, (size_t)(2 * need) * sizeof *np);
		if (!np)
			return pr_err(err, PR_ENOMEM, "out of memory");
		L->pol = np;
		L->cpol = 2 * need;
	}
	for (k = 0; k < drop; ++k)
		lpol_free(&L->pol[k]);
	memmove(L->pol, L->pol + drop, (size_t)(L->npol - drop) * sizeof *L->pol);
	L->npol -= drop;
	L->pol[L->npol++] = S->np;
	memset(&S->np, 0, sizeof S->np);
	if (drop > 0)
		L->given0 = 0;
	L->pbase = S->pmin;
	L->niter = S->t;
	L->dy = S->dy;
	L->dg = S->dg;
	win_free(&L->w);
	L->w = S->w;
	memset(&S->w, 0, sizeof S->w);
	win_free(&L->ask);
	L->ask_iter = -1;
	S->s.iteration = S->t;
	S->s.n = L->w.n;
	S->s.flags = S->flags;
	L->last = S->s;
	return PR_OK;
}

int pr_learner_tell_batch(pr_learner *L, const pr_learner_batch *b, char *err)
{
	stage S;
	gsl_rng *keep;
	int rc;

	L->bad_row = -1;
	if ((rc = check_told(L, b, err)))
		return rc;
	memset(&S, 0, sizeof S);
	S.t = L->niter + 1;
	S.dy = b->targets ? b->dy : 0;
	S.dg = b->features ? b->d : 0;
	S.s.status = PR_REPS_ACTIVE;
	if (!(keep = gsl_rng_clone(L->rng)))
		return pr_err(err, PR_ENOMEM, "out of memory");
	if ((rc = next_window(L, &S, b, err)) == PR_OK && (rc = importance(L, &S, err)) == PR_OK) {
		if (L->o.refit) {
			memcpy(S.p, S.q, (size_t)S.w.n * sizeof *S.p);
			S.s.ess = S.s.q_ess;
		} else {
			rc = reps_weights(L, &S, err);
		}
	}
	if (rc == PR_OK && (rc = fit(L, &S, err)) == PR_OK)
		rc = commit(L, &S, err);
	if (rc)
		gsl_rng_memcpy(L->rng, keep);
	gsl_rng_free(keep);
	stage_free(&S);
	return rc;
}

int pr_learner_tell(pr_learner *L, int n, const double *contexts, const double *actions,
                    const double *returns, const double *features, int d, char *err)
{
	pr_learner_batch b = {n, d, 0, contexts, actions, returns, features, NULL, NULL};

	return pr_learner_tell_batch(L, &b, err);
}

#define NAME_MAX_LEN 255

/* Which list column j of the names is in, and its place there. */
static const char *name_kind(const pr_learner *L, int j, int *k)
{
	*k = j < L->dx ? j : j - L->dx;
	return j < L->dx ? "context" : "action";
}

/* A name a CSV header holds as it is (the reader trims trailing blanks and
 * refuses control characters), so that a CSV can name the column. */
static int name_fits(const char *s)
{
	const size_t n = strlen(s);
	size_t i;

	if (n < 1 || n > NAME_MAX_LEN || s[n - 1] == ' ')
		return 0;
	for (i = 0; i < n; ++i)
		if ((unsigned char)s[i] < 0x20 || s[i] == 0x7f)
			return 0;
	return 1;
}

int pr_learner_set_names(pr_learner *L, const char *const *names, char *err)
{
	const int n = L->dx + L->da;
	char **c = calloc((size_t)n, sizeof *c);
	int j, i, k, m, rc = c ? PR_OK : pr_err(err, PR_ENOMEM, "out of memory");

	for (j = 0; rc == PR_OK && j < n; ++j) {
		const char *kind = name_kind(L, j, &k), *nm;
		char def[16];
		/* the defaults s0 .. and a0 .. (the thesis's s and a) */
		snprintf(def, sizeof def, "%c%d", kind[0] == 'c' ? 's' : 'a', k);
		nm = names && names[j] ? names[j] : def;
		if (!name_fits(nm))
			rc = pr_err(err, PR_EINVAL, "learner: %s name %d must be 1 .. %d bytes without a "
			            "control character or a trailing blank", kind, k, NAME_MAX_LEN);
		else if (!(c[j] = strdup(nm)))
			rc = pr_err(err, PR_ENOMEM, "out of memory");
		for (i = 0; rc == PR_OK && i < j; ++i) {
			const char *other = name_kind(L, i, &m);
			if (!strcmp(c[i], c[j]))
				rc = pr_err(err, PR_EINVAL, "learner: %s name %d '%s' is also %s name %d", kind, k,
				            c[j], other, m);
		}
	}
	if (rc) {
		free_names(c, n);
		return rc;
	}
	free_names(L->names, n);
	L->names = c;
	return PR_OK;
}

const char *const *pr_learner_names(const pr_learner *L)
{
	return (const char *const *)L->names;
}

int pr_learner_iteration(const pr_learner *L)
{
	return L->niter;
}

int pr_learner_context_dim(const pr_learner *L)
{
	return L->dx;
}

int pr_learner_action_dim(const pr_learner *L)
{
	return L->da;
}

const pr_learner_summary *pr_learner_last(const pr_learner *L)
{
	return &L->last;
}

const pr_policy *pr_learner_policy(const pr_learner *L)
{
	return L->pol[L->npol - 1].p;
}

const pr_learner_opts *pr_learner_options(const pr_learner *L)
{
	return &L->o;
}

/* ---- the state file (docs/learner.md) ---- */

static const char MAGIC[] = "poolreps-learner\n";
#define MAGIC_LEN 17 /* then the version: PR_LEARNER_HEAD_LEN */

typedef struct {
	unsigned char *b;
	size_t n, cap;
	int fail;
} wbuf;

static void put(wbuf *w, const void *v, size_t n)
{
	if (w->fail || n == 0)
		return;
	if (w->n + n > w->cap) {
		size_t cap = 2 * (w->n + n);
		unsigned char *b = realloc(w->b, cap);
		if (!b) {
			w->fail = 1;
			return;
		}
		w->b = b;
		w->cap = cap;
	}
	memcpy(w->b + w->n, v, n);
	w->n += n;
}

static void put_i(wbuf *w, int v)
{
	int32_t x = v;

	put(w, &x, sizeof x);
}

static void put_d(wbuf *w, const double *v, size_t n)
{
	put(w, v, n * sizeof *v);
}

/* The options: integers, then doubles, in this order. */
#define OPT_INTS(X, o) \
	X(o->value) X(o->policy_type) X(o->window) X(o->truncation) X(o->refit) \
	X(o->value_forest.trees) X(o->value_forest.cuts) X(o->value_forest.n_min) \
	X(o->value_forest.n_c) X(o->value_forest.score) X(o->value_forest.with_replacement) \
	X(o->value_forest.outputs) X(o->value_features) X(o->reps.max_iter) \
	X(o->reps.allow_failed) X(o->reps.solver) X(o->reps.threads) X(o->policy.target) \
	X(o->policy.cov) X(o->policy.cov_center) X(o->policy.forest.trees) \
	X(o->policy.forest.cuts) X(o->policy.forest.n_min) X(o->policy.forest.n_c) \
	X(o->policy.forest.score) X(o->policy.forest.with_replacement) X(o->policy.forest.outputs) \
	X(o->draw)
#define OPT_DOUBLES(X, o) \
	X(o->init_std) X(o->max_norm) X(o->reps.epsilon) X(o->reps.ridge) X(o->reps.eta_min) \
	X(o->policy.lambda) X(o->policy.min_std)

static void put_win(wbuf *b, const pr_learner *L, const win *w)
{
	put_i(b, w->n);
	put_i(b, w->n ? w->lc : 0); /* an empty window's columns are its allocation's: not saved */
	put_d(b, w->X, (size_t)w->n * L->dx);
	put_d(b, w->A, (size_t)w->n * L->da);
	put_d(b, w->R, (size_t)w->n);
	put_d(b, w->Y, w->Y ? (size_t)w->n * L->dy : 0);
	put_d(b, w->G, w->G ? (size_t)w->n * L->dg : 0);
	put_d(b, w->mu, w->mu ? (size_t)w->n * L->da : 0);
	put_d(b, w->lp, (size_t)w->n * w->lc);
	put(b, w->it, (size_t)w->n * sizeof *w->it);
}

static void put_pol(wbuf *b, const pr_learner *L, const lpol *P)
{
	const size_t n = (size_t)P->n;

	put_i(b, P->n);
	put_i(b, P->dy);
	put_i(b, P->M != NULL);
	put_d(b, P->X, n * L->dx);
	put_d(b, P->A, n * L->da);
	put_d(b, P->Y, P->Y ? n * P->dy : 0);
	put_d(b, P->wt, n);
	put_d(b, P->M, P->M ? n * L->da : 0);
	put(b, P->rs, P->rs ? gsl_rng_size(L->rng) : 0);
}

int pr_learner_save(const pr_learner *L, unsigned char **buf, size_t *len, char *err)
{
	const pr_learner_opts *o = &L->o;
	const pr_learner_summary *s = &L->last;
	const char *name = gsl_rng_name(L->rng);
	char reason[sizeof s->reason] = {0};
	wbuf b = {NULL, 0, 0, 0};
	int k;

	*buf = NULL;
	*len = 0;
	if (L->given0 && L->pbase == 0)
		return pr_err(err, PR_EINVAL, "learner: not saved: its initial policy was given by the "
		              "caller and is still in use");
	put(&b, MAGIC, MAGIC_LEN);
	put_i(&b, PR_LEARNER_FORMAT);
#define PUT_I(v) put_i(&b, v);
#define PUT_D(v) put_d(&b, &v, 1);
	OPT_INTS(PUT_I, o)
	OPT_DOUBLES(PUT_D, o)
	put_i(&b, L->dx);
	put_i(&b, L->da);
	put_i(&b, L->dy);
	put_i(&b, L->dg);
	put_i(&b, L->niter);
	put_i(&b, L->pbase);
	put_i(&b, L->npol);
	put_i(&b, L->ask_iter);
	put_i(&b, L->redraws);
	put_i(&b, L->ask_flags);
	put_i(&b, (int)strlen(name));
	put(&b, name, strlen(name));
	put_i(&b, (int)gsl_rng_size(L->rng));
	put(&b, gsl_rng_state(L->rng), gsl_rng_size(L->rng));
	for (k = 0; k < L->npol; ++k)
		put_pol(&b, L, &L->pol[k]);
	put_win(&b, L, &L->w);
	put_win(&b, L, &L->ask);
	PUT_I(s->iteration) PUT_I(s->n) PUT_I(s->bound) PUT_I(s->nfeat) PUT_I(s->evals)
	PUT_I(s->status) PUT_I(s->flags)
	PUT_D(s->eta) PUT_D(s->kl) PUT_D(s->ess) PUT_D(s->q_ess) PUT_D(s->residual)
	PUT_D(s->kl_gap) PUT_D(s->residual_rel)
	/* the reason's bytes after its NUL as zeros: the same state, the same bytes */
	memcpy(reason, s->reason, strnlen(s->reason, sizeof reason - 1));
	put(&b, reason, sizeof reason);
	put_i(&b, L->dx + L->da);
	for (k = 0; k < L->dx + L->da; ++k) {
		put_i(&b, (int)strlen(L->names[k]));
		put(&b, L->names[k], strlen(L->names[k]));
	}
#undef PUT_I
#undef PUT_D
	if (b.fail) {
		free(b.b);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	*buf = b.b;
	*len = b.n;
	return PR_OK;
}

typedef struct {
	const unsigned char *b;
	size_t n, at;
	const char *what;
	char *err;
	int rc;
} rbuf;

static int bad(rbuf *r, const char *why)
{
	if (r->rc == PR_OK)
		r->rc = pr_err(r->err, PR_EIO, "%s: not a valid learner state: %s", r->what, why);
	return r->rc;
}

static void get(rbuf *r, void *v, size_t n)
{
	if (r->rc || n == 0)
		return;
	if (n > r->n - r->at) {
		bad(r, "truncated");
		return;
	}
	memcpy(v, r->b + r->at, n);
	r->at += n;
}

/* 1 if what is left holds count items of at least each bytes: a count is
 * checked against the state's size before anything is allocated for it. */
static int holds(rbuf *r, size_t count, size_t each, const char *name)
{
	char why[96];

	if (r->rc || count <= (r->n - r->at) / each)
		return r->rc == PR_OK;
	snprintf(why, sizeof why, "truncated (%zu %s, more than its %zu bytes hold)", count, name, r->n);
	bad(r, why);
	return 0;
}

/* An integer in lo .. hi. */
static int get_i(rbuf *r, int lo, int hi, const char *name)
{
	int32_t x = lo;

	get(r, &x, sizeof x);
	if (r->rc == PR_OK && (x < lo || x > hi)) {
		char why[96];
		snprintf(why, sizeof why, "%s = %d outside %d .. %d", name, (int)x, lo, hi);
		bad(r, why);
		return lo;
	}
	return r->rc ? lo : (int)x;
}

/* n doubles into v (allocated by the caller): finite (any 0), finite or
 * -inf (any 2: a log-density, zero where an action is beyond a policy's
 * reach) or any value (1). */
static void get_d(rbuf *r, double *v, size_t n, int any, const char *name)
{
	size_t i;

	if (r->rc || n == 0)
		return;
	if (n > (r->n - r->at) / sizeof *v) {
		bad(r, "truncated");
		return;
	}
	get(r, v, n * sizeof *v);
	for (i = 0; any != 1 && i < n; ++i)
		if (!isfinite(v[i]) && !(any == 2 && v[i] == -HUGE_VAL) && r->rc == PR_OK)
			bad(r, name);
}

static void get_win(rbuf *r, pr_learner *L, win *w, int lc, int dy, int dg)
{
	int n = get_i(r, 0, MAX_WINDOW, "episodes"), i;
	const size_t mu = L->o.policy.cov_center == PR_COV_CENTER_OLD ? (size_t)L->da : 0;

	if (get_i(r, n ? lc : 0, lc, "columns") != lc && n)
		return;
	/* an episode: its numbers (a mean too when kept) and its policy */
	const size_t each = (size_t)L->dx + (size_t)L->da + 1 + (size_t)dy + (size_t)dg + (size_t)lc + mu;

	if (r->rc || !holds(r, (size_t)n, sizeof(int32_t) + sizeof(double) * each, "episodes"))
		return;
	if (win_alloc(L, w, n, lc, dy, dg, r->err)) {
		r->rc = PR_ENOMEM;
		return;
	}
	get_d(r, w->X, (size_t)n * L->dx, 0, "a context is not finite");
	get_d(r, w->A, (size_t)n * L->da, 0, "an action is not finite");
	get_d(r, w->R, (size_t)n, 0, "a return is not finite");
	get_d(r, w->Y, w->Y ? (size_t)n * dy : 0, 0, "a target is not finite");
	get_d(r, w->G, w->G ? (size_t)n * dg : 0, 0, "a feature is not finite");
	get_d(r, w->mu, w->mu ? (size_t)n * L->da : 0, 0, "a mean is not finite");
	get_d(r, w->lp, (size_t)n * lc, 2, "a log-density is NaN or +inf");
	for (i = 0; i < n && r->rc == PR_OK; ++i)
		w->it[i] = get_i(r, L->pbase, L->niter, "drawing policy");
}

/* Policy k, refitted from its inputs (pi_0 of the options when n = 0). */
static void get_pol(rbuf *r, pr_learner *L, int k)
{
	lpol *P = &L->pol[k];
	const int tree = L->o.policy_type == PR_LEARNER_POLICY_TREE;
	const int wmax = L->o.window ? L->o.window : MAX_WINDOW;
	int n = get_i(r, L->pbase + k == 0 ? 0 : 2, L->pbase + k == 0 ? 0 : wmax, "fit size");
	int dy = get_i(r, 0, MAX_DIM, "targets"), hm = get_i(r, 0, 1, "means");
	size_t m = (size_t)n;

	if (r->rc || n == 0)
		return;
	if (dy != L->dy || hm != (L->o.policy.cov_center == PR_COV_CENTER_OLD)) {
		bad(r, "a policy's fit does not match the options");
		return;
	}
	/* contexts, actions, targets, weights and means: at least dx + da + dy + 1 numbers a row */
	if (!holds(r, m, sizeof(double) * ((size_t)L->dx + (size_t)L->da + (size_t)dy + 1), "fit rows"))
		return;
	lpol_free(P);
	P->n = n;
	P->dy = dy;
	P->X = malloc(m * L->dx * sizeof *P->X);
	P->A = malloc(m * L->da * sizeof *P->A);
	P->Y = dy ? malloc(m * dy * sizeof *P->Y) : NULL;
	P->wt = malloc(m * sizeof *P->wt);
	P->M = hm ? malloc(m * L->da * sizeof *P->M) : NULL;
	P->rs = tree ? malloc(gsl_rng_size(L->rng)) : NULL;
	if (!P->X || !P->A || (dy && !P->Y) || !P->wt || (hm && !P->M) || (tree && !P->rs)) {
		r->rc = pr_err(r->err, PR_ENOMEM, "out of memory");
		return;
	}
	get_d(r, P->X, m * L->dx, 0, "a context is not finite");
	get_d(r, P->A, m * L->da, 0, "an action is not finite");
	get_d(r, P->Y, dy ? m * dy : 0, 0, "a target is not finite");
	get_d(r, P->wt, m, 0, "a weight is not finite");
	get_d(r, P->M, hm ? m * L->da : 0, 0, "a mean is not finite");
	get(r, P->rs, tree ? gsl_rng_size(L->rng) : 0);
	if (r->rc == PR_OK && refit_policy(L, P, NULL, r->err))
		bad(r, "a policy does not refit");
}

int pr_learner_check_head(const unsigned char *buf, size_t len, const char *what, char *err)
{
	int32_t v;

	if (len < MAGIC_LEN || memcmp(buf, MAGIC, MAGIC_LEN))
		return pr_err(err, PR_EIO, "%s: not a poolreps learner state", what);
	if (len < PR_LEARNER_HEAD_LEN)
		return pr_err(err, PR_EIO, "%s: not a valid learner state: truncated", what);
	memcpy(&v, buf + MAGIC_LEN, sizeof v);
	if (v != PR_LEARNER_FORMAT)
		return pr_err(err, PR_EINVAL, "%s: learner format version %d, this library reads "
		              "version %d", what, (int)v, PR_LEARNER_FORMAT);
	return PR_OK;
}

/* The header and options of a state; *o filled. */
static void get_head(rbuf *r, pr_learner_opts *o)
{
	if ((r->rc = pr_learner_check_head(r->b, r->n, r->what, r->err)))
		return;
	r->at = PR_LEARNER_HEAD_LEN;
	pr_learner_opts_init(o);
#define GET_I(f) f = get_i(r, INT32_MIN + 1, INT32_MAX, "an option");
#define GET_D(f) get_d(r, &f, 1, 0, "an option is not finite");
	OPT_INTS(GET_I, o)
	OPT_DOUBLES(GET_D, o)
#undef GET_I
#undef GET_D
}

/* The learner's counters and stream; *state points into the buffer. */
static void get_counts(rbuf *r, pr_learner *L, gsl_rng *rng, const unsigned char **state)
{
	const char *name = gsl_rng_name(rng);
	int len;

	L->dy = get_i(r, 0, MAX_DIM, "targets");
	L->dg = get_i(r, 0, MAX_DIM, "features");
	L->niter = get_i(r, 0, INT32_MAX - 1, "iteration");
	L->pbase = get_i(r, 0, L->niter, "oldest policy");
	get_i(r, L->niter - L->pbase + 1, L->niter - L->pbase + 1, "policies");
	/* each policy: its fit size, targets and means, at least */
	holds(r, (size_t)(L->niter - L->pbase + 1), 3 * sizeof(int32_t), "policies");
	L->ask_iter = get_i(r, -1, L->niter, "ask");
	L->redraws = get_i(r, 0, INT32_MAX, "redraws");
	L->ask_flags = get_i(r, 0, INT32_MAX, "flags");
	len = get_i(r, 0, 256, "generator name");
	if (r->rc == PR_OK && ((size_t)len != strlen(name) || r->n - r->at < (size_t)len ||
	                       memcmp(r->b + r->at, name, (size_t)len)))
		r->rc = pr_err(r->err, PR_EINVAL, "%s: saved with another random number generator "
		               "than %s", r->what, name);
	r->at += r->rc ? 0 : (size_t)len;
	if (get_i(r, 0, INT32_MAX, "generator state") != (int)gsl_rng_size(rng) && r->rc == PR_OK)
		bad(r, "generator state size");
	if (r->rc == PR_OK && r->n - r->at < gsl_rng_size(rng))
		bad(r, "truncated");
	*state = r->b + r->at;
	r->at += r->rc ? 0 : gsl_rng_size(rng);
}

static void get_summary(rbuf *r, pr_learner_summary *s)
{
#define GET_I(f) f = get_i(r, INT32_MIN + 1, INT32_MAX, "summary");
#define GET_D(f) get_d(r, &f, 1, 1, "");
	GET_I(s->iteration) GET_I(s->n) GET_I(s->bound) GET_I(s->nfeat) GET_I(s->evals)
	GET_I(s->status) GET_I(s->flags)
	GET_D(s->eta) GET_D(s->kl) GET_D(s->ess) GET_D(s->q_ess) GET_D(s->residual)
	GET_D(s->kl_gap) GET_D(s->residual_rel)
#undef GET_I
#undef GET_D
	get(r, s->reason, sizeof s->reason);
	s->reason[sizeof s->reason - 1] = '\0';
}

/* The column names, checked as pr_learner_set_names checks a caller's. */
static void get_names(rbuf *r, pr_learner *L)
{
	const int n = L->dx + L->da;
	char **c, why[PR_ERRLEN];
	int k, len, count = get_i(r, 0, n, "names");

	/* none (a state saved before names were kept): the defaults stay */
	if (r->rc || count == 0)
		return;
	if (count != n) {
		bad(r, "not a name for each column");
		return;
	}
	if (!holds(r, (size_t)n, sizeof(int32_t) + 1, "names"))
		return;
	if (!(c = calloc((size_t)n, sizeof *c))) {
		r->rc = pr_err(r->err, PR_ENOMEM, "out of memory");
		return;
	}
	for (k = 0; k < n && r->rc == PR_OK; ++k) {
		len = get_i(r, 1, NAME_MAX_LEN, "name length");
		if (r->rc == PR_OK && !(c[k] = calloc((size_t)len + 1, 1)))
			r->rc = pr_err(r->err, PR_ENOMEM, "out of memory");
		get(r, c[k], (size_t)len);
		if (r->rc == PR_OK && strlen(c[k]) != (size_t)len)
			bad(r, "a NUL in a column name");
	}
	if (r->rc == PR_OK && pr_learner_set_names(L, (const char *const *)c, why))
		bad(r, why);
	free_names(c, n);
}

pr_learner *pr_learner_load(const unsigned char *buf, size_t len, const char *what, gsl_rng *rng,
                            char *err)
{
	rbuf r = {buf, len, 0, what, err, PR_OK};
	pr_learner_opts o;
	pr_learner *L = NULL;
	const unsigned char *state = NULL;
	const int oom = pr_out_of_memory;
	char why[PR_ERRLEN];
	int dx, da, k;

	get_head(&r, &o);
	dx = get_i(&r, 1, MAX_DIM, "context dimensions");
	da = get_i(&r, 1, MAX_ACTION, "action dimensions");
	if (r.rc == PR_OK && !(L = pr_learner_new(&o, dx, da, rng, why)))
		r.rc = pr_out_of_memory && !oom ? pr_err(err, PR_ENOMEM, "%s", why) : bad(&r, why);
	if (r.rc == PR_OK)
		get_counts(&r, L, rng, &state);
	/* get_counts checked the policy count against the state's size */
	if (r.rc == PR_OK && L->niter - L->pbase + 1 > L->cpol) {
		lpol *p = realloc(L->pol, (size_t)(L->niter - L->pbase + 1) * sizeof *p);
		if (!p)
			r.rc = pr_err(err, PR_ENOMEM, "out of memory");
		else
			memset(p + L->npol, 0, (size_t)(L->niter - L->pbase + 1 - L->npol) * sizeof *p);
		L->pol = p ? p : L->pol;
		L->cpol = p ? L->niter - L->pbase + 1 : L->cpol;
	}
	if (r.rc == PR_OK && L->pbase > 0)
		lpol_free(&L->pol[0]);
	for (k = 0; r.rc == PR_OK && k < L->niter - L->pbase + 1; ++k) {
		L->npol = k + 1;
		get_pol(&r, L, k);
	}
	if (r.rc == PR_OK)
		get_win(&r, L, &L->w, L->niter ? L->npol : 0, L->dy, L->dg);
	if (r.rc == PR_OK)
		get_win(&r, L, &L->ask, L->npol, 0, 0);
	if (r.rc == PR_OK)
		get_summary(&r, &L->last);
	if (r.rc == PR_OK)
		get_names(&r, L);
	if (r.rc == PR_OK && r.at != len)
		bad(&r, "bytes after the end");
	if (r.rc == PR_OK && L->ask_iter < 0 && L->ask.n)
		bad(&r, "an ask without its iteration");
	if (r.rc) {
		pr_learner_free(L);
		return NULL;
	}
	memcpy(gsl_rng_state(rng), state, gsl_rng_size(rng));
	return L;
}
