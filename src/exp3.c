/* exp3.c — Experiment 3 (thesis 7.5): learning to pocket a ball with REPS.
 *
 * A job is one (repetition k, variant) pair. It owns its simulator, random
 * streams, forests and policies, so jobs run on any thread in any order and
 * the output never depends on the thread count.
 *
 * One job (thesis 7.5.1, SPEC.md §4-5):
 *   iteration 0: init_samples episodes from pi_0 = N(0, init_std^2 I);
 *   iteration t = 1..T:
 *     window = the latest `window` episodes, drawn by pi_pmin .. pi_{t-1};
 *     q      = importance weights pi_{t-1} / pi_mix, pi_mix the sample-count
 *              mixture of the drawing policies (SPEC.md §4);
 *     phi    = value features of the window states: a forest states ->
 *              returns, active leaves (eq. 5.4) or active samples (eq. 5.6);
 *              quadratic features for the `handcrafted` variant;
 *     p      = REPS weights with base weights q (eq. 3.7-3.8);
 *     pi_t   = a policy fitted to the window with weights p (ch. 6);
 *     then `samples` new episodes from pi_t.
 * log pi_m(a_i|s_i) never changes once both exist, so each value is computed
 * once: for a new policy on the window, for a new episode under every live
 * policy. A policy lives while an episode it drew is in the window.
 *
 * The learner sees only the state coordinates that vary (those whose start
 * box has extent): the cue ball starts at a point, and a constant column
 * would make the design matrix of eq. 6.6 singular without changing a
 * prediction. The raw CSV keeps the full state.
 *
 * Streams: start states and pi_0's actions depend on (seed, k) alone, so all
 * variants of a repetition share start states and initial episodes (common
 * random numbers); forests and later actions on (seed, k, variant).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_rng.h>

#include "poolreps/cmaes.h"
#include "poolreps/config.h"
#include "poolreps/csvio.h"
#include "poolreps/exp.h"
#include "poolreps/forest.h"
#include "poolreps/policy.h"
#include "poolreps/reps.h"
#include "poolreps/sim.h"
#include "exp_priv.h"

#define PATHLEN 1024
#define DIST_BINS_PER_M 20 /* Fig. 7.10 histogram: 0.05 m bins */
#define MAX_REDRAW 100 /* draws of an action faster than sim.max_speed */

enum { V_NRVR_RS, V_RVR_RS, V_NRVR_A, V_RVR_A, V_BASELINE, V_HANDCRAFTED, NVAR };
static const char *const var_name[NVAR] = {
	"nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a", "baseline", "handcrafted"
};

/* Random streams of pr_exp_rng (seed, stream, k). */
enum { STREAM_START = 0x3e30, STREAM_INIT = 0x3e31, STREAM_LEARN = 0x3e40 };

void pr_exp3_opts_init(pr_exp3_opts *o)
{
	memset(o, 0, sizeof *o);
	o->init_samples = 200;
	o->init_std = 0.1;
	o->iterations = 100;
	o->samples = 20;
	o->window = 200;
	snprintf(o->policies, sizeof o->policies, "nrvr_rs,rvr_rs,nrvr_a,rvr_a,baseline,handcrafted");
	o->baseline_n_min = 250;
	o->final_episodes = 500;
}

/* The variants of exp3.policies, in its order; a name twice is an error. */
static int parse_variants(const pr_config *cfg, int *var, int *nvar, char *err)
{
	const char *p = cfg->exp3.policies;
	char at[320];

	*nvar = 0;
	do {
		size_t len = strcspn(p, ","), b = 0, e = len;
		char item[32];
		int v, j;

		while (b < e && (p[b] == ' ' || p[b] == '\t'))
			++b;
		while (e > b && (p[e - 1] == ' ' || p[e - 1] == '\t'))
			--e;
		snprintf(item, sizeof item, "%.*s", (int)(e - b < 31 ? e - b : 31), p + b);
		for (v = 0; v < NVAR && strcmp(var_name[v], item) != 0; ++v)
			;
		if (v == NVAR)
			return pr_err(err, PR_EINVAL, "%s: exp3.policies: '%s' is not one of "
			              "nrvr_rs|rvr_rs|nrvr_a|rvr_a|baseline|handcrafted",
			              pr_config_where(cfg, "exp3.policies", at, sizeof at), item);
		for (j = 0; j < *nvar; ++j)
			if (var[j] == v)
				return pr_err(err, PR_EINVAL, "%s: exp3.policies: '%s' listed twice",
				              pr_config_where(cfg, "exp3.policies", at, sizeof at), item);
		var[(*nvar)++] = v;
		p += len;
	} while (*p++ == ',');
	return PR_OK;
}

/* The variants this process runs: all of exp3.policies, or the one
 * experiment.variant picks. Each draws from its own stream (STREAM_LEARN +
 * its id), so alone it writes exactly its rows of the full run. */
static int run_variants(const pr_config *cfg, int *var, int *nvar, char *err)
{
	int rc;

	if ((rc = parse_variants(cfg, var, nvar, err)) || (rc = pr_exp_check_variant(cfg, *nvar, err)))
		return rc;
	if (cfg->run.variant >= 0) {
		var[0] = var[cfg->run.variant];
		*nvar = 1;
	}
	return PR_OK;
}

int pr_exp3_variants(const pr_config *cfg, pr_variants *out, char *err)
{
	int var[NVAR], j, rc;

	if ((rc = parse_variants(cfg, var, &out->n, err)))
		return rc;
	for (j = 0; j < out->n; ++j)
		snprintf(out->name[j], sizeof out->name[j], "%s", var_name[var[j]]);
	return PR_OK;
}

/* ---- one job ---- */

/* REPS and policy diagnostics of one iteration (raw exp3_reps.csv). */
typedef struct {
	double eta, kl, ess, q_ess, residual, kl_gap, residual_rel;
	int bound, nfeat, evals, redraws, flags, status;
} rep_row;

/* Everything a job produces, kept until the fixed-order write. */
typedef struct {
	double *S;       /* neps x ds start states */
	double *A;       /* neps x 2 actions */
	double *R;       /* neps returns */
	double *F;       /* neps x 2 final position of reward ball 1 */
	int *pocket;     /* neps: reward ball 1's pocket id or -1 */
	int *hit;        /* neps: the cue ball touched a reward ball */
	int *iter;       /* neps: 0 = initial samples; episodes of iteration t by pi_t */
	rep_row *reps;   /* iterations */
} job;

/* Read-only after setup; shared by the threads. */
typedef struct {
	const pr_config *cfg;
	int var[NVAR], nvar;
	int lo, nrep;          /* repetitions lo .. lo + nrep - 1 */
	int nballs, ds;        /* full state: ds = 2 * nballs */
	int nx;                /* learning state: the coordinates that vary */
	int *xdim;             /* nx indices into the full state */
	double *xmid, *xhalf;  /* their box centres and half-widths */
	int neps;              /* episodes per job */
	job *jobs;             /* nrep x nvar, repetition-major */
	pr_exp_ticker tick;
} setup;

/* Scratch of one running job. */
typedef struct {
	const setup *su;
	int k, v;
	job *o;
	pr_sim *sim;
	gsl_rng *r_start, *r_init, *r_learn;
	double *X;                /* neps x nx learning states */
	pr_policy **pol;          /* iterations + 1; NULL once dead */
	pr_policy_work **work;
	int pmin;                 /* oldest live policy */
	int redraws;              /* actions drawn again in this iteration */
	/* log pi_m(a_i|s_i) in a ring: episode slot i % SC, policy slot m % PC;
	 * each cell is tagged with its (i, m) so a stale read is caught. */
	int SC, PC;
	double *lp;
	int *tag_i, *tag_m;
	/* window scratch */
	double *q, *logpi, *logcur, *p, *phi, *u;
	int *counts, *rowptr, *col;
	/* handcrafted: sampling means per episode (policy.cov_center = old), or
	 * the C-CMA-ES state and its baseline features (handcrafted_method) */
	double *mu;
	pr_cmaes *cm;
	double *base;
} learner;

static void set_lp(learner *L, int i, int m, double v)
{
	size_t c = (size_t)(i % L->SC) * (size_t)L->PC + (size_t)(m % L->PC);

	L->lp[c] = v;
	L->tag_i[c] = i;
	L->tag_m[c] = m;
}

static int get_lp(const learner *L, int i, int m, double *v, char *err)
{
	size_t c = (size_t)(i % L->SC) * (size_t)L->PC + (size_t)(m % L->PC);

	if (L->tag_i[c] != i || L->tag_m[c] != m)
		return pr_err(err, PR_ENUM, "internal: log-density of episode %d under policy %d missing",
		              i, m);
	*v = L->lp[c];
	return PR_OK;
}

/* Draw the start state of episode i and its learning coordinates. */
static int draw_start(learner *L, int i, char *err)
{
	const setup *su = L->su;
	double *s = L->o->S + (size_t)i * su->ds;
	int j, rc;

	rc = pr_sim_sample_start(&su->cfg->table, &su->cfg->start, su->nballs, L->r_start, s, err);
	for (j = 0; rc == PR_OK && j < su->nx; ++j)
		L->X[(size_t)i * su->nx + j] = s[su->xdim[j]];
	return rc;
}

/* Draw episode i's action from policy m, and note log pi_j(a_i|s_i) for
 * every live policy j <= m. Actions faster than sim.max_speed are drawn
 * again (the simulator refuses them), so the policy really draws from its
 * Gaussian truncated there; the noted densities are the untruncated ones
 * (they lack -log P(|a| <= max_speed | s)). Redraws are counted in
 * exp3_reps.csv, so their share is on record. */
static int draw_action(learner *L, int i, int m, gsl_rng *rng, int *flags, char *err)
{
	const setup *su = L->su;
	const double *x = L->X + (size_t)i * su->nx;
	double mean[2], cov[4], lp, *a = L->o->A + 2 * (size_t)i;
	int rc, j, tries = 0, f = 0;

	if ((rc = pr_policy_eval(L->pol[m], x, mean, cov, &f, L->work[m], err)))
		return rc;
	*flags |= f;
	if (L->mu)
		memcpy(L->mu + 2 * (size_t)i, mean, sizeof mean);
	do {
		if (tries++ == MAX_REDRAW)
			return pr_err(err, PR_ENUM, "episode %d: %d actions drawn, all faster than "
			              "sim.max_speed = %g m/s", i, MAX_REDRAW, su->cfg->sim.max_speed);
		if ((rc = pr_policy_gauss_sample(2, mean, cov, 1, rng, a, err)))
			return rc;
		if (L->cm && hypot(a[0], a[1]) > su->cfg->sim.max_speed) {
			/* C-CMA-ES: the draw is projected onto the speed limit and the
			 * projected action is shot and used in the update (a repair
			 * that keeps the mean near admissible actions; redrawing would
			 * let it drift past the limit, where every draw is refused) */
			double shrink = su->cfg->sim.max_speed / hypot(a[0], a[1]) * (1.0 - 1e-12);

			a[0] *= shrink;
			a[1] *= shrink;
		}
	} while (hypot(a[0], a[1]) > su->cfg->sim.max_speed);
	L->redraws += tries - 1;
	if ((rc = pr_policy_gauss_logpdf(2, mean, cov, a, &lp, err)))
		return rc;
	set_lp(L, i, m, lp);
	for (j = L->pmin; j < m; ++j) {
		f = 0;
		if ((rc = pr_policy_logpdf(L->pol[j], x, a, &lp, &f, L->work[j], err)))
			return rc;
		*flags |= f;
		set_lp(L, i, j, lp);
	}
	return PR_OK;
}

/* Simulate episode i and record its outcome. */
static int shoot(learner *L, int i, char *err)
{
	const setup *su = L->su;
	const pr_config *cfg = su->cfg;
	job *o = L->o;
	pr_shot res;
	int rc;

	rc = pr_sim_shoot(L->sim, o->S + (size_t)i * su->ds, su->nballs, o->A + 2 * (size_t)i, &res,
	                  NULL, err);
	if (rc)
		return rc;
	o->R[i] = pr_sim_reward(&cfg->table, &cfg->reward, &res);
	o->F[2 * i] = res.final[2];
	o->F[2 * i + 1] = res.final[3];
	o->pocket[i] = res.pocket[1];
	o->hit[i] = res.hit;
	return PR_OK;
}

/* Episodes [from, from + count) of iteration m, drawn by policy m. */
static int play(learner *L, int from, int count, int m, gsl_rng *rng, int *flags, char *err)
{
	int i, rc;

	for (i = from; i < from + count; ++i) {
		L->o->iter[i] = m;
		if ((rc = draw_start(L, i, err)) || (rc = draw_action(L, i, m, rng, flags, err)) ||
		    (rc = shoot(L, i, err)))
			return rc;
	}
	return PR_OK;
}

/* Quadratic features of the box-normalised coordinates of n learning
 * states X into phi (n x pr_policy_features_count(QUADRATIC, nx)). */
static void quadratic_features(learner *L, const double *X, int n, double *phi)
{
	const setup *su = L->su;
	int d = pr_policy_features_count(PR_FEATURES_QUADRATIC, su->nx), i, j;

	for (i = 0; i < n; ++i) {
		for (j = 0; j < su->nx; ++j)
			L->u[j] = (X[(size_t)i * su->nx + j] - su->xmid[j]) / su->xhalf[j];
		pr_policy_features_quadratic(L->u, su->nx, phi + (size_t)i * d);
	}
}

/* Value features of the window's n states into the REPS problem: one-hot
 * active leaves (CSR, eq. 5.4), active samples (dense, eq. 5.6), or the
 * quadratic features of the box-normalised coordinates (handcrafted). The
 * forest is returned in *fo (caller frees); NULL for handcrafted. */
static int value_features(learner *L, const double *Xw, const double *Rw, int n,
                          pr_reps_problem *pb, pr_forest **fo, char *err)
{
	const setup *su = L->su;
	const pr_config *cfg = su->cfg;
	pr_forest_opts vo = cfg->value;
	pr_forest *f;
	int i, M, rc;

	*fo = NULL;
	if (L->v == V_HANDCRAFTED) {
		quadratic_features(L, Xw, n, L->phi);
		pb->d = pr_policy_features_count(PR_FEATURES_QUADRATIC, su->nx);
		pb->phi = L->phi;
		return PR_OK;
	}
	if (L->v == V_NRVR_RS || L->v == V_NRVR_A)
		vo.score = PR_SCORE_NRVR;
	else if (L->v == V_RVR_RS || L->v == V_RVR_A)
		vo.score = PR_SCORE_RVR;
	if (!(f = pr_forest_fit(&vo, Xw, n, su->nx, Rw, 1, NULL, L->r_learn, err)))
		return PR_ENUM;
	*fo = f;
	M = pr_forest_ntrees(f);
	if (strcmp(cfg->value_features, "samples") == 0) {
		for (i = 0; i < n; ++i)
			if ((rc = pr_forest_active_samples(f, Xw + (size_t)i * su->nx, su->nx,
			                                   L->phi + (size_t)i * n)))
				return rc;
		pb->d = n;
		pb->phi = L->phi;
		return PR_OK;
	}
	for (i = 0; i < n; ++i) {
		L->rowptr[i] = i * M;
		rc = pr_forest_active(f, Xw + (size_t)i * su->nx, su->nx, L->col + (size_t)i * M, M);
		if (rc != M)
			return rc < 0 ? rc : pr_err(err, PR_ENUM, "internal: %d active leaves, %d trees", rc, M);
	}
	L->rowptr[n] = n * M;
	pb->d = pr_forest_nleaves(f);
	pb->rowptr = L->rowptr;
	pb->col = L->col;
	pb->val = NULL;
	return PR_OK;
}

/* Fit pi_t to the window with the REPS weights p. */
static pr_policy *fit_policy(learner *L, const pr_policy_data *d, int *flags, char *err)
{
	const pr_config *cfg = L->su->cfg;
	pr_policy_opts po = cfg->policy;

	switch (L->v) {
	case V_HANDCRAFTED:
		return pr_policy_linear_fit(PR_FEATURES_AFFINE, d, po.lambda, po.min_std, po.cov_center,
		                            flags, err);
	case V_BASELINE:
		/* n_min above the window size: one node, a global linear-Gaussian policy */
		po.forest.n_min = cfg->exp3.baseline_n_min;
		break;
	case V_NRVR_RS:
	case V_RVR_RS:
		po.target = PR_TARGET_REWARD_STATE;
		break;
	default:
		po.target = PR_TARGET_ACTION;
		break;
	}
	return pr_policy_tree_fit(&po, d, L->r_learn, err);
}

/* Iteration t's episodes [end, end + samples) from pi_t; policies pmin ..
 * t - 1 are still evaluated on them. */
static int play_iteration(learner *L, int t, int end, int pmin, int flags, rep_row *row,
                          char *err)
{
	int rc;

	L->pmin = pmin;
	L->redraws = 0;
	rc = play(L, end, L->su->cfg->exp3.samples, t, L->r_learn, &flags, err);
	row->flags = flags;
	row->redraws = L->redraws;
	return rc;
}

/* Iteration t >= 1 of the hand-crafted loop with exp3.handcrafted_method =
 * ccmaes: one C-CMA-ES update from the latest generation (pi_{t-1}'s
 * episodes, or the initial ones), baseline features as REPS's value
 * features, then pi_t's episodes. No samples are reused, so q_ess is the
 * generation size; there is no dual (eta, kl, bound, residual 0) and ess is
 * the selection's mueff. */
static int iterate_ccmaes(learner *L, int t, char *err)
{
	const setup *su = L->su;
	const pr_exp3_opts *e = &su->cfg->exp3;
	job *o = L->o;
	rep_row *row = &o->reps[t - 1];
	const int end = e->init_samples + (t - 1) * e->samples;
	const int n = t == 1 ? e->init_samples : e->samples, a0 = end - n;
	pr_cmaes_batch b;
	pr_cmaes_info info;
	int rc, floored;

	b.n = n;
	b.nb = pr_policy_features_count(PR_FEATURES_QUADRATIC, su->nx);
	b.S = L->X + (size_t)a0 * su->nx;
	b.X = o->A + 2 * (size_t)a0;
	b.R = o->R + a0;
	b.B = L->base;
	quadratic_features(L, b.S, n, L->base);
	if ((rc = pr_cmaes_update(L->cm, &b, &info, err)))
		return rc;
	memset(row, 0, sizeof *row);
	row->ess = info.mueff;
	row->q_ess = n;
	row->nfeat = b.nb;
	if (!(L->pol[t] = pr_cmaes_policy(L->cm, su->cfg->policy.min_std, &floored, err)))
		return PR_ENOMEM;
	if (!(L->work[t] = pr_policy_work_new(L->pol[t], err)))
		return PR_ENOMEM;
	pr_policy_free(L->pol[t - 1]);
	pr_policy_work_free(L->work[t - 1]);
	L->pol[t - 1] = NULL;
	L->work[t - 1] = NULL;
	return play_iteration(L, t, end, t, info.flags | (floored ? PR_POLICY_FLOOR : 0), row, err);
}

/* Iteration t >= 1: importance weights, value features, REPS, a new policy
 * and its episodes. */
static int iterate(learner *L, int t, char *err)
{
	const setup *su = L->su;
	const pr_config *cfg = su->cfg;
	const pr_exp3_opts *e = &cfg->exp3;
	job *o = L->o;
	rep_row *row = &o->reps[t - 1];
	int end = e->init_samples + (t - 1) * e->samples;
	int n = end < e->window ? end : e->window, a0 = end - n;
	int pmin = o->iter[a0], npol = t - pmin, i, m, rc, flags = 0;
	const double *Xw = L->X + (size_t)a0 * su->nx, *Rw = o->R + a0;
	pr_reps_problem pb;
	pr_reps_result *res = NULL;
	pr_forest *vf = NULL;
	pr_policy_data d;

	if (L->cm)
		return iterate_ccmaes(L, t, err);
	/* q_i = pi_{t-1}(a_i|s_i) / pi_mix(a_i|s_i), SPEC.md §4 */
	memset(L->counts, 0, (size_t)npol * sizeof *L->counts);
	for (i = 0; i < n; ++i) {
		L->counts[o->iter[a0 + i] - pmin]++;
		for (m = 0; m < npol; ++m)
			if ((rc = get_lp(L, a0 + i, pmin + m, &L->logpi[(size_t)m * n + i], err)))
				return rc;
		if ((rc = get_lp(L, a0 + i, t - 1, &L->logcur[i], err)))
			return rc;
	}
	rc = pr_reps_importance(npol, n, L->logpi, L->counts, L->logcur, L->q, NULL, &row->q_ess, err);
	if (rc)
		return rc;

	memset(&pb, 0, sizeof pb);
	pb.n = n;
	pb.R = Rw;
	pb.q = L->q;
	rc = value_features(L, Xw, Rw, n, &pb, &vf, err);
	if (rc == PR_OK)
		rc = pr_reps_solve(&cfg->reps, &pb, &res, err);
	pr_forest_free(vf);
	if (rc)
		return rc;
	memcpy(L->p, res->p, (size_t)n * sizeof *L->p);
	row->eta = res->eta;
	row->kl = res->kl;
	row->ess = res->ess;
	row->residual = res->residual;
	row->bound = res->bound;
	row->nfeat = pb.d;
	row->evals = res->iterations;
	row->kl_gap = res->kl_gap;
	row->residual_rel = res->residual_rel;
	row->status = res->status;
	if (res->status == PR_REPS_FAILED && !cfg->reps.allow_failed)
		rc = pr_err(err, PR_ENUM, "iteration %d: REPS answer not certified: %s "
		            "(reps.allow_failed = 1 records such solves and goes on)", t, res->reason);
	pr_reps_result_free(res);
	if (rc)
		return rc;

	d.n = n;
	d.ds = su->nx;
	d.da = 2;
	d.dy = 2;
	d.S = Xw;
	d.A = o->A + 2 * (size_t)a0;
	d.Y = o->F + 2 * (size_t)a0;
	d.w = L->p;
	d.M = L->mu ? L->mu + 2 * (size_t)a0 : NULL;
	if (!(L->pol[t] = fit_policy(L, &d, &flags, err)))
		return PR_ENUM;
	if (!(L->work[t] = pr_policy_work_new(L->pol[t], err)))
		return PR_ENOMEM;
	for (i = a0; i < end; ++i) {
		double lp;
		int f = 0;
		rc = pr_policy_logpdf(L->pol[t], L->X + (size_t)i * su->nx, o->A + 2 * (size_t)i, &lp, &f,
		                      L->work[t], err);
		if (rc)
			return rc;
		flags |= f;
		set_lp(L, i, t, lp);
	}

	if ((rc = play_iteration(L, t, end, pmin, flags, row, err)))
		return rc;

	/* policies that drew no episode of the next window never count again */
	end += e->samples;
	n = end < e->window ? end : e->window;
	for (m = pmin; m < o->iter[end - n]; ++m) {
		pr_policy_free(L->pol[m]);
		pr_policy_work_free(L->work[m]);
		L->pol[m] = NULL;
		L->work[m] = NULL;
	}
	return PR_OK;
}

static void learner_free(learner *L)
{
	int m;

	if (L->pol)
		for (m = 0; m <= L->su->cfg->exp3.iterations; ++m) {
			pr_policy_free(L->pol[m]);
			pr_policy_work_free(L->work[m]);
		}
	free(L->pol);
	free(L->work);
	pr_sim_free(L->sim);
	gsl_rng_free(L->r_start);
	gsl_rng_free(L->r_init);
	gsl_rng_free(L->r_learn);
	free(L->X);
	free(L->lp);
	free(L->tag_i);
	free(L->tag_m);
	free(L->q);
	free(L->logpi);
	free(L->logcur);
	free(L->p);
	free(L->phi);
	free(L->u);
	free(L->counts);
	free(L->rowptr);
	free(L->col);
	free(L->mu);
	pr_cmaes_free(L->cm);
	free(L->base);
}

static int learner_init(learner *L, const setup *su, int j, char *err)
{
	const pr_config *cfg = su->cfg;
	const pr_exp3_opts *e = &cfg->exp3;
	int W = e->window, T = e->iterations, M = cfg->value.trees, nq, dphi;
	size_t cells;
	unsigned long k;

	memset(L, 0, sizeof *L);
	L->su = su;
	L->k = su->lo + j / su->nvar;
	L->v = su->var[j % su->nvar];
	L->o = &su->jobs[j];
	k = (unsigned long)L->k;
	L->SC = W + e->samples;
	L->PC = (W - 1) / e->samples + 2;
	cells = (size_t)L->SC * (size_t)L->PC;
	nq = pr_policy_features_count(PR_FEATURES_QUADRATIC, su->nx);
	dphi = strcmp(cfg->value_features, "samples") == 0 && W > nq ? W : nq;
	if (!(L->sim = pr_sim_new(&cfg->table, &cfg->sim, err)))
		return PR_EINVAL;
	L->r_start = pr_exp_rng(cfg->run.seed, STREAM_START, k);
	L->r_init = pr_exp_rng(cfg->run.seed, STREAM_INIT, k);
	L->r_learn = pr_exp_rng(cfg->run.seed, STREAM_LEARN + (unsigned long)L->v, k);
	L->X = malloc((size_t)su->neps * su->nx * sizeof *L->X);
	L->pol = calloc((size_t)T + 1, sizeof *L->pol);
	L->work = calloc((size_t)T + 1, sizeof *L->work);
	L->lp = malloc(cells * sizeof *L->lp);
	L->tag_i = malloc(cells * sizeof *L->tag_i);
	L->tag_m = malloc(cells * sizeof *L->tag_m);
	L->q = malloc((size_t)W * sizeof *L->q);
	L->logpi = malloc((size_t)W * L->PC * sizeof *L->logpi);
	L->logcur = malloc((size_t)W * sizeof *L->logcur);
	L->p = malloc((size_t)W * sizeof *L->p);
	L->phi = malloc((size_t)W * dphi * sizeof *L->phi);
	L->u = malloc((size_t)su->nx * sizeof *L->u);
	L->counts = malloc((size_t)L->PC * sizeof *L->counts);
	L->rowptr = malloc(((size_t)W + 1) * sizeof *L->rowptr);
	L->col = malloc((size_t)W * M * sizeof *L->col);
	if (!L->r_start || !L->r_init || !L->r_learn || !L->X || !L->pol || !L->work || !L->lp ||
	    !L->tag_i || !L->tag_m || !L->q || !L->logpi || !L->logcur || !L->p || !L->phi ||
	    !L->u || !L->counts || !L->rowptr || !L->col)
		return pr_err(err, PR_ENOMEM, "out of memory");
	if (L->v == V_HANDCRAFTED && e->handcrafted_method == PR_METHOD_CCMAES) {
		/* N(W [1, x], init_std^2 I) with W = 0: pi_0 */
		double *W0 = calloc(2 * ((size_t)su->nx + 1), sizeof *W0);

		L->cm = W0 ? pr_cmaes_new(PR_FEATURES_AFFINE, su->nx, 2, W0, e->init_std, cfg->policy.lambda,
		                          err) : NULL;
		free(W0);
		L->base = malloc((size_t)(e->init_samples > e->samples ? e->init_samples : e->samples) *
		                 nq * sizeof *L->base);
		if (!L->cm || !L->base)
			return pr_err(err, PR_ENOMEM, "out of memory");
	} else if (L->v == V_HANDCRAFTED && cfg->policy.cov_center == PR_COV_CENTER_OLD &&
	           !(L->mu = malloc(2 * (size_t)su->neps * sizeof *L->mu))) {
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	/* no cell holds a value yet */
	memset(L->tag_i, 0xff, cells * sizeof *L->tag_i);
	memset(L->tag_m, 0xff, cells * sizeof *L->tag_m);
	return PR_OK;
}

static void job_free(job *o)
{
	free(o->S);
	free(o->A);
	free(o->R);
	free(o->F);
	free(o->pocket);
	free(o->hit);
	free(o->iter);
	free(o->reps);
}

static int job_alloc(job *o, const setup *su, int iterations)
{
	size_t n = (size_t)su->neps;

	o->S = malloc(n * su->ds * sizeof *o->S);
	o->A = malloc(2 * n * sizeof *o->A);
	o->R = malloc(n * sizeof *o->R);
	o->F = malloc(2 * n * sizeof *o->F);
	o->pocket = malloc(n * sizeof *o->pocket);
	o->hit = malloc(n * sizeof *o->hit);
	o->iter = malloc(n * sizeof *o->iter);
	o->reps = calloc((size_t)iterations + 1, sizeof *o->reps);
	return o->S && o->A && o->R && o->F && o->pocket && o->hit && o->iter && o->reps;
}

/* The job behind index j (pr_exp_parallel hands out 0 .. nrep * nvar - 1). */
static int run_job(void *ctx, int j, char *err)
{
	setup *su = ctx;
	const pr_exp3_opts *e = &su->cfg->exp3;
	char msg[PR_ERRLEN];
	double mean0[2] = {0.0, 0.0}, cov0[4];
	learner L;
	int rc, t, flags = 0;

	memset(&L, 0, sizeof L);
	cov0[0] = cov0[3] = e->init_std * e->init_std;
	cov0[1] = cov0[2] = 0.0;
	rc = job_alloc(&su->jobs[j], su, e->iterations) ? PR_OK : pr_err(msg, PR_ENOMEM, "out of memory");
	if (rc == PR_OK)
		rc = learner_init(&L, su, j, msg);
	if (rc == PR_OK && !(L.pol[0] = pr_policy_gaussian_new(su->nx, 2, mean0, cov0, msg)))
		rc = PR_EINVAL;
	if (rc == PR_OK && !(L.work[0] = pr_policy_work_new(L.pol[0], msg)))
		rc = PR_ENOMEM;
	if (rc == PR_OK)
		rc = play(&L, 0, e->init_samples, 0, L.r_init, &flags, msg);
	if (rc == PR_OK)
		pr_exp_ticker_add(&su->tick, e->init_samples);
	for (t = 1; rc == PR_OK && t <= e->iterations; ++t) {
		if (pr_interrupted) {
			rc = pr_err(msg, PR_EINTR, "interrupted");
			break;
		}
		rc = iterate(&L, t, msg);
		if (rc == PR_OK)
			pr_exp_ticker_add(&su->tick, e->samples);
	}
	if (L.su)
		learner_free(&L);
	if (rc)
		return pr_err(err, rc, "exp3: repetition %d, policy %s: %s", su->lo + j / su->nvar,
		              var_name[su->var[j % su->nvar]], msg);
	return PR_OK;
}

/* ---- raw output ---- */

static int write_episodes(const setup *su, const char *dir, char *err)
{
	char path[PATHLEN], name[32];
	pr_csvw *w;
	int j, i, b, rc = PR_OK;

	snprintf(path, sizeof path, "%s/exp3_episodes.csv", dir);
	if (!(w = pr_csvw_open(path, err)))
		return PR_EIO;
	rc |= pr_csvw_str(w, "repetition");
	rc |= pr_csvw_str(w, "policy");
	rc |= pr_csvw_str(w, "iteration");
	for (b = 0; b < su->nballs; ++b) {
		snprintf(name, sizeof name, "x%d", b);
		rc |= pr_csvw_str(w, name);
		snprintf(name, sizeof name, "y%d", b);
		rc |= pr_csvw_str(w, name);
	}
	rc |= pr_csvw_str(w, "vx");
	rc |= pr_csvw_str(w, "vy");
	rc |= pr_csvw_str(w, "return");
	rc |= pr_csvw_str(w, "rx");
	rc |= pr_csvw_str(w, "ry");
	rc |= pr_csvw_str(w, "pocket");
	rc |= pr_csvw_str(w, "hit");
	rc |= pr_csvw_endrow(w);
	for (j = 0; rc == PR_OK && j < su->nrep * su->nvar; ++j) {
		const job *o = &su->jobs[j];
		for (i = 0; rc == PR_OK && i < su->neps; ++i) {
			rc |= pr_csvw_int(w, su->lo + j / su->nvar);
			rc |= pr_csvw_str(w, var_name[su->var[j % su->nvar]]);
			rc |= pr_csvw_int(w, o->iter[i]);
			for (b = 0; b < su->ds; ++b)
				rc |= pr_csvw_num(w, o->S[(size_t)i * su->ds + b]);
			rc |= pr_csvw_num(w, o->A[2 * i]);
			rc |= pr_csvw_num(w, o->A[2 * i + 1]);
			rc |= pr_csvw_num(w, o->R[i]);
			rc |= pr_csvw_num(w, o->F[2 * i]);
			rc |= pr_csvw_num(w, o->F[2 * i + 1]);
			rc |= pr_csvw_int(w, o->pocket[i]);
			rc |= pr_csvw_int(w, o->hit[i]);
			rc |= pr_csvw_endrow(w);
		}
	}
	return pr_csvw_finish(w, rc, err);
}

static int write_reps(const setup *su, const char *dir, char *err)
{
	char path[PATHLEN];
	pr_csvw *w;
	int j, t, rc = PR_OK;

	snprintf(path, sizeof path, "%s/exp3_reps.csv", dir);
	if (!(w = pr_csvw_open(path, err)))
		return PR_EIO;
	rc = pr_csvw_header(w, "repetition,policy,iteration,eta,kl,ess,bound,residual,q_ess,"
	                       "features,dual_evals,redraws,policy_flags,kl_gap,residual_rel,status");
	for (j = 0; rc == PR_OK && j < su->nrep * su->nvar; ++j)
		for (t = 0; rc == PR_OK && t < su->cfg->exp3.iterations; ++t) {
			const rep_row *r = &su->jobs[j].reps[t];
			rc |= pr_csvw_int(w, su->lo + j / su->nvar);
			rc |= pr_csvw_str(w, var_name[su->var[j % su->nvar]]);
			rc |= pr_csvw_int(w, t + 1);
			rc |= pr_csvw_num(w, r->eta);
			rc |= pr_csvw_num(w, r->kl);
			rc |= pr_csvw_num(w, r->ess);
			rc |= pr_csvw_int(w, r->bound);
			rc |= pr_csvw_num(w, r->residual);
			rc |= pr_csvw_num(w, r->q_ess);
			rc |= pr_csvw_int(w, r->nfeat);
			rc |= pr_csvw_int(w, r->evals);
			rc |= pr_csvw_int(w, r->redraws);
			rc |= pr_csvw_int(w, r->flags);
			rc |= pr_csvw_num(w, r->kl_gap);
			rc |= pr_csvw_num(w, r->residual_rel);
			rc |= pr_csvw_str(w, pr_reps_status_name(r->status));
			rc |= pr_csvw_endrow(w);
		}
	return pr_csvw_finish(w, rc, err);
}

/* Options this experiment needs beyond the per-key ranges. */
static int check_setup(const pr_config *cfg, char *err)
{
	const pr_exp3_opts *e = &cfg->exp3;
	char at[320];
	int rc;

	if (cfg->table.reward_balls != 1)
		return pr_err(err, PR_EINVAL, "%s: table.reward_balls: Experiment 3 has one reward ball (got %d)",
		              pr_config_where(cfg, "table.reward_balls", at, sizeof at), cfg->table.reward_balls);
	if (e->window < 2)
		return pr_err(err, PR_EINVAL, "%s: exp3.window: must be >= 2 (got %d)",
		              pr_config_where(cfg, "exp3.window", at, sizeof at), e->window);
	if (strcmp(cfg->value_features, "leaves") != 0 && strcmp(cfg->value_features, "samples") != 0)
		return pr_err(err, PR_EINVAL, "%s: value.features: '%s' is not one of leaves|samples",
		              pr_config_where(cfg, "value.features", at, sizeof at), cfg->value_features);
	if ((long)e->iterations * e->samples + e->init_samples > 100000000L)
		return pr_err(err, PR_EINVAL, "%s: exp3.iterations: %d iterations x exp3.samples %d: more "
		              "than 1e8 episodes per run", pr_config_where(cfg, "exp3.iterations", at, sizeof at),
		              e->iterations, e->samples);
	if ((rc = pr_forest_opts_check(&cfg->value, "value", err)))
		return rc;
	return pr_policy_opts_check(&cfg->policy, err);
}

/* The coordinates whose start box has extent: the learner's state. */
static int learning_dims(setup *su, char *err)
{
	const pr_start_opts *so = &su->cfg->start;
	char at[320];
	int b, c;

	su->xdim = malloc((size_t)su->ds * sizeof *su->xdim);
	su->xmid = malloc((size_t)su->ds * sizeof *su->xmid);
	su->xhalf = malloc((size_t)su->ds * sizeof *su->xhalf);
	if (!su->xdim || !su->xmid || !su->xhalf)
		return pr_err(err, PR_ENOMEM, "out of memory");
	su->nx = 0;
	for (b = 0; b < su->nballs; ++b) {
		const double *box = b == 0 ? so->cue_box : b <= su->cfg->table.reward_balls ?
		                    so->reward_box : so->obstacle_box;
		for (c = 0; c < 2; ++c)
			if (box[2 * c + 1] > box[2 * c]) {
				su->xdim[su->nx] = 2 * b + c;
				su->xmid[su->nx] = 0.5 * (box[2 * c] + box[2 * c + 1]);
				su->xhalf[su->nx] = 0.5 * (box[2 * c + 1] - box[2 * c]);
				su->nx++;
			}
	}
	if (su->nx == 0)
		return pr_err(err, PR_EINVAL, "%s: start.reward_box: every start box is a point: Experiment 3 "
		              "needs varying start states",
		              pr_config_where(su->cfg, "start.reward_box", at, sizeof at));
	return PR_OK;
}

int pr_exp3_run(const pr_config *cfg, const char *dir, const pr_progress *prog, char *err)
{
	const pr_exp3_opts *e = &cfg->exp3;
	setup su;
	int hi, j, njobs = 0, rc;

	memset(&su, 0, sizeof su);
	su.cfg = cfg;
	su.nballs = cfg->table.balls;
	su.ds = 2 * su.nballs;
	su.neps = e->init_samples + e->iterations * e->samples;
	pr_exp_reps(cfg, &su.lo, &hi);
	su.nrep = hi - su.lo;
	rc = check_setup(cfg, err);
	if (rc == PR_OK)
		rc = run_variants(cfg, su.var, &su.nvar, err);
	if (rc == PR_OK)
		rc = learning_dims(&su, err);
	if (rc == PR_OK) {
		njobs = su.nrep * su.nvar;
		if (!(su.jobs = calloc((size_t)njobs, sizeof *su.jobs)))
			rc = pr_err(err, PR_ENOMEM, "out of memory");
	}
	if (rc == PR_OK) {
		pr_exp_ticker_init(&su.tick, prog, (long)njobs * su.neps, "exp3 episodes");
		rc = pr_exp_parallel(0, njobs, cfg->run.threads, run_job, &su, err);
		pr_exp_ticker_destroy(&su.tick);
	}
	if (rc == PR_OK)
		rc = write_episodes(&su, dir, err);
	if (rc == PR_OK)
		rc = write_reps(&su, dir, err);
	for (j = 0; su.jobs && j < njobs; ++j)
		job_free(&su.jobs[j]);
	free(su.jobs);
	free(su.xdim);
	free(su.xmid);
	free(su.xhalf);
	return rc;
}

/* ---- summaries (from the raw CSVs on disk only) ---- */

/* The raw episodes, parsed. */
typedef struct {
	long n;
	int nv, nr, T;     /* variants (exp3.policies order), repetitions found, iterations */
	long *rep;         /* nr sorted repetition numbers */
	int *v, *r, *it;   /* per row: variant, repetition index, iteration */
	int *pocket;
	double *ret, *dist;
} episodes;

static void episodes_free(episodes *E)
{
	free(E->rep);
	free(E->v);
	free(E->r);
	free(E->it);
	free(E->pocket);
	free(E->ret);
	free(E->dist);
}

static int cmp_long(const void *a, const void *b)
{
	long x = *(const long *)a, y = *(const long *)b;

	return (x > y) - (x < y);
}

static int is_target(const pr_reward_opts *ro, int pocket)
{
	int j;

	for (j = 0; j < ro->ntargets; ++j)
		if (ro->targets[j] == pocket)
			return 1;
	return 0;
}

/* Variant index of a name within var[0..nvar), or -1. */
static int variant_of(const char *name, const int *var, int nvar)
{
	int j;

	for (j = 0; j < nvar; ++j)
		if (strcmp(var_name[var[j]], name) == 0)
			return j;
	return -1;
}

/* Distance of the final reward-ball position to the nearest target pocket
 * (0 when it fell into one): the distance term of eq. 7.7. */
static double target_distance(const pr_config *cfg, int pocket, double rx, double ry)
{
	double best = HUGE_VAL, p[2];
	int j;

	if (is_target(&cfg->reward, pocket))
		return 0.0;
	for (j = 0; j < cfg->reward.ntargets; ++j) {
		double d;
		pr_sim_pocket_xy(&cfg->table, cfg->reward.targets[j], p);
		d = hypot(rx - p[0], ry - p[1]);
		if (d < best)
			best = d;
	}
	return best;
}

static int read_episodes(const pr_config *cfg, const char *dir, const int *var, int nvar,
                         episodes *E, char *err)
{
	enum { C_REP, C_POL, C_IT, C_RET, C_RX, C_RY, C_POCKET, NC };
	static const char *const cname[NC] = {
		"repetition", "policy", "iteration", "return", "rx", "ry", "pocket"
	};
	char path[PATHLEN];
	pr_exp_table *t = NULL;
	int col[NC], c, rc;
	long i, j, x;

	memset(E, 0, sizeof *E);
	E->nv = nvar;
	E->T = cfg->exp3.iterations;
	snprintf(path, sizeof path, "%s/exp3_episodes.csv", dir);
	if ((rc = pr_exp_table_read(path, &t, err)))
		return rc;
	for (c = 0; c < NC; ++c)
		if ((col[c] = pr_exp_table_col(t, cname[c], err)) < 0) {
			pr_exp_table_free(t);
			return col[c];
		}
	E->n = pr_exp_table_nrows(t);
	E->rep = malloc(((size_t)E->n + 1) * sizeof *E->rep);
	E->v = malloc(((size_t)E->n + 1) * sizeof *E->v);
	E->r = malloc(((size_t)E->n + 1) * sizeof *E->r);
	E->it = malloc(((size_t)E->n + 1) * sizeof *E->it);
	E->pocket = malloc(((size_t)E->n + 1) * sizeof *E->pocket);
	E->ret = malloc(((size_t)E->n + 1) * sizeof *E->ret);
	E->dist = malloc(((size_t)E->n + 1) * sizeof *E->dist);
	if (!E->rep || !E->v || !E->r || !E->it || !E->pocket || !E->ret || !E->dist) {
		pr_exp_table_free(t);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	for (i = 0; rc == PR_OK && i < E->n; ++i) {
		double rx, ry;
		if ((rc = pr_exp_table_int(t, i, col[C_REP], 0, 9999, &E->rep[i], err)) ||
		    (rc = pr_exp_table_int(t, i, col[C_IT], 0, E->T, &x, err)))
			break;
		E->it[i] = (int)x;
		if ((rc = pr_exp_table_int(t, i, col[C_POCKET], -1, PR_SIM_POCKETS - 1, &x, err)))
			break;
		E->pocket[i] = (int)x;
		if ((rc = pr_exp_table_num(t, i, col[C_RET], &E->ret[i], err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_RX], &rx, err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_RY], &ry, err)))
			break;
		E->dist[i] = target_distance(cfg, E->pocket[i], rx, ry);
		if ((E->v[i] = variant_of(pr_exp_table_str(t, i, col[C_POL]), var, nvar)) < 0)
			rc = pr_err(err, PR_EIO, "%s: row %ld: policy '%.40s' is not in exp3.policies",
			            path, i + 2, pr_exp_table_str(t, i, col[C_POL]));
	}
	pr_exp_table_free(t);
	if (rc)
		return rc;
	if (E->n == 0)
		return pr_err(err, PR_EIO, "%s: no episodes", path);
	/* repetition numbers -> indices 0..nr-1 */
	for (i = 0; i < E->n; ++i)
		E->r[i] = 0;
	{
		long *sorted = malloc((size_t)E->n * sizeof *sorted);
		if (!sorted)
			return pr_err(err, PR_ENOMEM, "out of memory");
		memcpy(sorted, E->rep, (size_t)E->n * sizeof *sorted);
		qsort(sorted, (size_t)E->n, sizeof *sorted, cmp_long);
		for (i = 0, j = 0; i < E->n; ++i)
			if (i == 0 || sorted[i] != sorted[j - 1])
				sorted[j++] = sorted[i];
		E->nr = (int)j;
		for (i = 0; i < E->n; ++i) {
			const long *hit = bsearch(&E->rep[i], sorted, (size_t)E->nr, sizeof *sorted, cmp_long);
			E->r[i] = (int)(hit - sorted);
		}
		memcpy(E->rep, sorted, (size_t)E->nr * sizeof *sorted);
		free(sorted);
	}
	return PR_OK;
}

/* Sample standard deviation (n - 1) of x[0..n) around mean m; 0 for n < 2. */
static double sample_std(double ss, long n)
{
	return n > 1 ? sqrt(ss / (double)(n - 1)) : 0.0;
}

/* exp3_curve.csv: per policy and iteration, the mean and std over the
 * repetitions of the iteration's average return (Fig. 7.7). */
static int write_curve(const pr_config *cfg, const episodes *E, const int *var, const char *dir,
                       char *err)
{
	size_t cells = (size_t)E->nv * E->nr * (E->T + 1);
	double *sum = calloc(cells, sizeof *sum);
	long *cnt = calloc(cells, sizeof *cnt), i;
	char path[PATHLEN];
	pr_csvw *w = NULL;
	int v, r, t, rc = PR_OK;

	if (!sum || !cnt) {
		free(sum);
		free(cnt);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	for (i = 0; i < E->n; ++i) {
		size_t c = ((size_t)E->v[i] * E->nr + E->r[i]) * (E->T + 1) + E->it[i];
		sum[c] += E->ret[i];
		cnt[c]++;
	}
	for (v = 0; rc == PR_OK && v < E->nv; ++v)
		for (r = 0; rc == PR_OK && r < E->nr; ++r)
			for (t = 0; t <= E->T; ++t)
				if (!cnt[((size_t)v * E->nr + r) * (E->T + 1) + t]) {
					rc = pr_err(err, PR_EIO, "%s/exp3_episodes.csv: policy %s, repetition %ld: "
					            "no episodes of iteration %d", dir, var_name[var[v]], E->rep[r], t);
					break;
				}
	snprintf(path, sizeof path, "%s/exp3_curve.csv", dir);
	if (rc == PR_OK && !(w = pr_csvw_open(path, err)))
		rc = PR_EIO;
	if (rc == PR_OK) {
		pr_csvw_str(w, "policy");
		pr_csvw_str(w, "iteration");
		pr_csvw_str(w, "episodes");
		pr_csvw_str(w, "mean_return");
		pr_csvw_str(w, "std_return");
		rc = pr_csvw_str(w, "repetitions");
		pr_csvw_endrow(w);
	}
	for (v = 0; rc == PR_OK && v < E->nv; ++v)
		for (t = 0; rc == PR_OK && t <= E->T; ++t) {
			double m = 0.0, ss = 0.0;
			for (r = 0; r < E->nr; ++r) {
				size_t c = ((size_t)v * E->nr + r) * (E->T + 1) + t;
				m += sum[c] / (double)cnt[c];
			}
			m /= E->nr;
			for (r = 0; r < E->nr; ++r) {
				size_t c = ((size_t)v * E->nr + r) * (E->T + 1) + t;
				double dv = sum[c] / (double)cnt[c] - m;
				ss += dv * dv;
			}
			pr_csvw_str(w, var_name[var[v]]);
			pr_csvw_int(w, t);
			pr_csvw_int(w, (long)cfg->exp3.init_samples + (long)t * cfg->exp3.samples);
			pr_csvw_num(w, m);
			pr_csvw_num(w, sample_std(ss, E->nr));
			pr_csvw_int(w, E->nr);
			rc = pr_csvw_endrow(w);
		}
	free(sum);
	free(cnt);
	if (!w)
		return rc;
	return pr_csvw_finish(w, rc, err);
}

/* Mark each run's last `last` episodes (rows are in episode order within a
 * run). fin[i] = 1 for the rows Figs. 7.8-7.10 use. */
static int mark_final(const episodes *E, long last, char *fin, char *err)
{
	size_t runs = (size_t)E->nv * E->nr;
	long *tot = calloc(runs, sizeof *tot), *seen = calloc(runs, sizeof *seen), i;

	if (!tot || !seen) {
		free(tot);
		free(seen);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	for (i = 0; i < E->n; ++i)
		tot[(size_t)E->v[i] * E->nr + E->r[i]]++;
	for (i = 0; i < E->n; ++i) {
		size_t c = (size_t)E->v[i] * E->nr + E->r[i];
		fin[i] = seen[c]++ >= tot[c] - last;
	}
	free(tot);
	free(seen);
	return PR_OK;
}

/* exp3_final.csv: the last episodes of each run (Fig. 7.8), one row per
 * policy and repetition and a pooled row with repetition -1. */
static int write_final(const pr_config *cfg, const episodes *E, const int *var, const char *fin,
                       const char *dir, char *err)
{
	char path[PATHLEN];
	pr_csvw *w;
	int v, r, rc = PR_OK;

	snprintf(path, sizeof path, "%s/exp3_final.csv", dir);
	if (!(w = pr_csvw_open(path, err)))
		return PR_EIO;
	rc = pr_csvw_header(w, "policy,repetition,episodes,mean_return,std_return,pocketed_target,"
	                       "pocketed_other,mean_distance");
	for (v = 0; rc == PR_OK && v < E->nv; ++v)
		for (r = 0; rc == PR_OK && r <= E->nr; ++r) {
			/* r == nr: all repetitions pooled */
			double s = 0.0, ss = 0.0, ds = 0.0, m;
			long i, n = 0, tgt = 0, other = 0;
			for (i = 0; i < E->n; ++i)
				if (fin[i] && E->v[i] == v && (r == E->nr || E->r[i] == r)) {
					s += E->ret[i];
					ds += E->dist[i];
					n++;
					if (E->pocket[i] >= 0)
						*(is_target(&cfg->reward, E->pocket[i]) ? &tgt : &other) += 1;
				}
			m = s / (double)n;
			for (i = 0; i < E->n; ++i)
				if (fin[i] && E->v[i] == v && (r == E->nr || E->r[i] == r))
					ss += (E->ret[i] - m) * (E->ret[i] - m);
			pr_csvw_str(w, var_name[var[v]]);
			pr_csvw_int(w, r == E->nr ? -1 : E->rep[r]);
			pr_csvw_int(w, n);
			pr_csvw_num(w, m);
			pr_csvw_num(w, sample_std(ss, n));
			pr_csvw_int(w, tgt);
			pr_csvw_int(w, other);
			pr_csvw_num(w, ds / (double)n);
			rc = pr_csvw_endrow(w);
		}
	return pr_csvw_finish(w, rc, err);
}

/* exp3_pockets.csv (Fig. 7.9) and exp3_dist.csv (Fig. 7.10) over the last
 * episodes of every repetition. */
static int write_pockets_dist(const pr_config *cfg, const episodes *E, const int *var,
                              const char *fin, const char *dir, char *err)
{
	int nbins = (int)ceil(hypot(cfg->table.length, cfg->table.width) * DIST_BINS_PER_M);
	long *hist = calloc((size_t)nbins + 1, sizeof *hist), pk[PR_SIM_POCKETS + 1], tot, i;
	char path[PATHLEN];
	pr_csvw *w;
	int v, b, rc = PR_OK;

	if (!hist)
		return pr_err(err, PR_ENOMEM, "out of memory");
	snprintf(path, sizeof path, "%s/exp3_pockets.csv", dir);
	if (!(w = pr_csvw_open(path, err))) {
		free(hist);
		return PR_EIO;
	}
	rc = pr_csvw_header(w, "policy,pocket,target,count,fraction");
	for (v = 0; rc == PR_OK && v < E->nv; ++v) {
		memset(pk, 0, sizeof pk);
		for (i = 0, tot = 0; i < E->n; ++i)
			if (fin[i] && E->v[i] == v) {
				pk[E->pocket[i] + 1]++;
				tot++;
			}
		for (b = -1; b < PR_SIM_POCKETS; ++b) {
			pr_csvw_str(w, var_name[var[v]]);
			pr_csvw_int(w, b);
			pr_csvw_int(w, is_target(&cfg->reward, b));
			pr_csvw_int(w, pk[b + 1]);
			pr_csvw_num(w, (double)pk[b + 1] / (double)tot);
			rc = pr_csvw_endrow(w);
		}
	}
	if ((rc = pr_csvw_finish(w, rc, err))) {
		free(hist);
		return rc;
	}

	snprintf(path, sizeof path, "%s/exp3_dist.csv", dir);
	if (!(w = pr_csvw_open(path, err))) {
		free(hist);
		return PR_EIO;
	}
	rc = pr_csvw_header(w, "policy,bin_lo,bin_hi,count,fraction");
	for (v = 0; rc == PR_OK && v < E->nv; ++v) {
		memset(hist, 0, ((size_t)nbins + 1) * sizeof *hist);
		for (i = 0, tot = 0; i < E->n; ++i)
			if (fin[i] && E->v[i] == v) {
				b = (int)floor(E->dist[i] * DIST_BINS_PER_M);
				hist[b < nbins ? b : nbins - 1]++;
				tot++;
			}
		for (b = 0; b < nbins; ++b) {
			pr_csvw_str(w, var_name[var[v]]);
			pr_csvw_num(w, (double)b / DIST_BINS_PER_M);
			pr_csvw_num(w, (double)(b + 1) / DIST_BINS_PER_M);
			pr_csvw_int(w, hist[b]);
			pr_csvw_num(w, (double)hist[b] / (double)tot);
			rc = pr_csvw_endrow(w);
		}
	}
	free(hist);
	return pr_csvw_finish(w, rc, err);
}

/* exp3_reps_summary.csv: per policy, how often the KL bound was active,
 * mean KL, the largest feature-expectation residual |sum p phi - phi_hat|,
 * ESS of p and of the importance weights, the iterations in which
 * min_std floored a policy variance or a policy fit or query fell back
 * (PR_POLICY_* flags), the actions drawn again for exceeding
 * sim.max_speed, and the REPS certificates: solves that were unreachable
 * (eta = 0, the eta -> 0 limit) or failed, and the largest relative
 * feature residual. */
static int write_reps_summary(const int *var, int nvar, const char *dir, char *err)
{
	enum { C_POL, C_KL, C_ESS, C_BOUND, C_QESS, C_FEAT, C_REDRAW, C_FLAGS, C_RES, C_RREL, C_ST, NC };
	static const char *const cname[NC] = {
		"policy", "kl", "ess", "bound", "q_ess", "features", "redraws", "policy_flags", "residual",
		"residual_rel", "status"
	};
	char path[PATHLEN];
	pr_exp_table *t = NULL;
	pr_csvw *w = NULL;
	double (*acc)[5] = calloc((size_t)nvar, sizeof *acc);
	double *maxres = calloc(2 * (size_t)nvar, sizeof *maxres);
	long (*cnt)[7] = calloc((size_t)nvar, sizeof *cnt), i, x, nr;
	int col[NC], c, v, rc;

	if (!acc || !cnt || !maxres) {
		free(acc);
		free(cnt);
		free(maxres);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	snprintf(path, sizeof path, "%s/exp3_reps.csv", dir);
	rc = pr_exp_table_read(path, &t, err);
	for (c = 0; rc == PR_OK && c < NC; ++c)
		if ((col[c] = pr_exp_table_col(t, cname[c], err)) < 0)
			rc = col[c];
	for (i = 0; rc == PR_OK && i < pr_exp_table_nrows(t); ++i) {
		double kl, ess, qess, nf, res, rrel;
		const char *st;
		long bound;
		if ((v = variant_of(pr_exp_table_str(t, i, col[C_POL]), var, nvar)) < 0) {
			rc = pr_err(err, PR_EIO, "%s: row %ld: policy '%.40s' is not in exp3.policies",
			            path, i + 2, pr_exp_table_str(t, i, col[C_POL]));
			break;
		}
		if ((rc = pr_exp_table_num(t, i, col[C_KL], &kl, err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_ESS], &ess, err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_QESS], &qess, err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_FEAT], &nf, err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_RES], &res, err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_RREL], &rrel, err)) ||
		    (rc = pr_exp_table_int(t, i, col[C_BOUND], 0, 1, &bound, err)) ||
		    (rc = pr_exp_table_int(t, i, col[C_REDRAW], 0, 1000000000L, &nr, err)) ||
		    (rc = pr_exp_table_int(t, i, col[C_FLAGS], 0, 1 << 20, &x, err)))
			break;
		st = pr_exp_table_str(t, i, col[C_ST]);
		if (strcmp(st, pr_reps_status_name(PR_REPS_ACTIVE)) != 0 &&
		    strcmp(st, pr_reps_status_name(PR_REPS_UNREACHABLE)) != 0 &&
		    strcmp(st, pr_reps_status_name(PR_REPS_FAILED)) != 0) {
			rc = pr_err(err, PR_EIO, "%s: row %ld: status '%.40s' is not active, unreachable "
			            "or failed", path, i + 2, st);
			break;
		}
		cnt[v][5] += strcmp(st, pr_reps_status_name(PR_REPS_UNREACHABLE)) == 0;
		cnt[v][6] += strcmp(st, pr_reps_status_name(PR_REPS_FAILED)) == 0;
		acc[v][0] += kl;
		maxres[v] = fmax(maxres[v], res);
		maxres[nvar + v] = fmax(maxres[nvar + v], rrel);
		acc[v][1] += ess;
		acc[v][2] += qess;
		acc[v][3] += nf;
		cnt[v][0]++;
		cnt[v][1] += bound;
		cnt[v][2] += (x & PR_POLICY_FLOOR) != 0;
		cnt[v][3] += (x & ~(long)PR_POLICY_FLOOR) != 0;
		cnt[v][4] += nr;
	}
	pr_exp_table_free(t);
	snprintf(path, sizeof path, "%s/exp3_reps_summary.csv", dir);
	if (rc == PR_OK && !(w = pr_csvw_open(path, err)))
		rc = PR_EIO;
	if (rc == PR_OK) {
		rc = pr_csvw_header(w, "policy,solves,bound_active,bound_inactive,mean_kl,max_residual,"
		                    "mean_ess,mean_q_ess,mean_features,floor_iterations,"
		                    "fallback_iterations,redraws,unreachable,failed,max_residual_rel");
	}
	for (v = 0; rc == PR_OK && v < nvar; ++v) {
		double n = cnt[v][0] > 0 ? (double)cnt[v][0] : 1.0;
		pr_csvw_str(w, var_name[var[v]]);
		pr_csvw_int(w, cnt[v][0]);
		pr_csvw_int(w, cnt[v][1]);
		pr_csvw_int(w, cnt[v][0] - cnt[v][1]);
		pr_csvw_num(w, acc[v][0] / n);
		pr_csvw_num(w, maxres[v]);
		pr_csvw_num(w, acc[v][1] / n);
		pr_csvw_num(w, acc[v][2] / n);
		pr_csvw_num(w, acc[v][3] / n);
		pr_csvw_int(w, cnt[v][2]);
		pr_csvw_int(w, cnt[v][3]);
		pr_csvw_int(w, cnt[v][4]);
		pr_csvw_int(w, cnt[v][5]);
		pr_csvw_int(w, cnt[v][6]);
		pr_csvw_num(w, maxres[nvar + v]);
		rc = pr_csvw_endrow(w);
	}
	free(acc);
	free(cnt);
	free(maxres);
	if (!w)
		return rc;
	return pr_csvw_finish(w, rc, err);
}

int pr_exp3_summarize(const pr_config *cfg, const char *dir, char *err)
{
	episodes E;
	char *fin = NULL;
	int var[NVAR], nvar, rc;

	if ((rc = run_variants(cfg, var, &nvar, err)))
		return rc;
	rc = read_episodes(cfg, dir, var, nvar, &E, err);
	if (rc == PR_OK)
		rc = write_curve(cfg, &E, var, dir, err);
	if (rc == PR_OK && !(fin = malloc((size_t)E.n)))
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	if (rc == PR_OK)
		rc = mark_final(&E, cfg->exp3.final_episodes, fin, err);
	if (rc == PR_OK)
		rc = write_final(cfg, &E, var, fin, dir, err);
	if (rc == PR_OK)
		rc = write_pockets_dist(cfg, &E, var, fin, dir, err);
	if (rc == PR_OK)
		rc = write_reps_summary(var, nvar, dir, err);
	free(fin);
	episodes_free(&E);
	return rc;
}
