/* exp3_learn.c — the REPS learner of Experiment 3 (thesis 7.5.1; the loop
 * is in exp3_priv.h): one (repetition, variant) pair, its episodes, REPS
 * iterations and policy fits.
 *
 * log pi_m(a_i|s_i) never changes once both exist, so each value is computed
 * once: for a new policy on the window, for a new episode under every live
 * policy. A policy lives while an episode it drew is in the window.
 *
 * The learner sees only the state coordinates that vary (those whose start
 * box has extent): the cue ball starts at a point, and a constant column
 * would make the design matrix of eq. 6.6 singular without changing a
 * prediction.
 *
 * Streams: start states come from `start`, pi_0's actions from `init`,
 * forests and later actions from `learn`; Experiment 3 shares the first two
 * between the variants of a repetition (common random numbers).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "poolreps/cmaes.h"
#include "poolreps/forest.h"
#include "poolreps/reps.h"
#include "poolreps/sim.h"
#include "exp3_priv.h"

#define MAX_REDRAW 100 /* draws of an action faster than sim.max_speed */
#define MAX_EPISODES 100000000L /* per learner: the memory of a run stays bounded */
#define SPEED_MARGIN 1e-12 /* C-CMA-ES projection: strictly inside the speed limit */
#define DA 2 /* action: cue-ball velocity */

struct pr_exp3_learner {
	const pr_config *cfg;
	const pr_exp3_opts *e;
	int v;                    /* PR_EXP3_* */
	int nballs, ds;           /* full state: ds = 2 * nballs */
	int nx;                   /* learning state: the coordinates that vary */
	int *xdim;                /* nx indices into the full state */
	double *xmid, *xhalf;     /* their box centres and half-widths */
	gsl_rng *r_start, *r_init, *r_learn; /* borrowed */
	pr_sim *sim;
	int n0;                   /* episodes of iteration 0; 0 before it */
	int cap;                  /* episodes n0 + iterations * samples */
	pr_exp3_episodes o;
	double *X;                /* cap x nx learning states */
	pr_policy **pol;          /* iterations + 1; NULL once dead */
	pr_policy_work **work;
	int pmin;                 /* oldest live policy */
	int redraws;              /* actions drawn again in this iteration */
	int repeats;              /* pr_exp3_learner_repeat ran: pi_0 is never replaced */
	int refit;                /* control: no REPS, pi_t fitted with the weights q alone */
	int n_min;                /* control: tree-LWR forest n_min (0: policy.n_min) */
	/* log pi_m(a_i|s_i) in a ring: episode slot i % SC, policy slot m % PC;
	 * each cell is tagged with its (i, m) so a stale read is caught. */
	int SC, PC;
	double *lp;
	int *tag_i, *tag_m;
	/* window scratch */
	double *q, *logpi, *logcur, *p, *phi, *u;
	int *counts, *rowptr, *col;
	/* sampling means per episode (policy.cov_center = old: every fitted
	 * policy, linear or tree-LWR, centres its covariance on them), or the
	 * C-CMA-ES state and its baseline features (handcrafted_method) */
	double *mu;
	pr_cmaes *cm;
	double *base;
};

static void set_lp(pr_exp3_learner *L, int i, int m, double v)
{
	size_t c = (size_t)(i % L->SC) * (size_t)L->PC + (size_t)(m % L->PC);

	L->lp[c] = v;
	L->tag_i[c] = i;
	L->tag_m[c] = m;
}

static int get_lp(const pr_exp3_learner *L, int i, int m, double *v, char *err)
{
	size_t c = (size_t)(i % L->SC) * (size_t)L->PC + (size_t)(m % L->PC);

	if (L->tag_i[c] != i || L->tag_m[c] != m)
		return pr_err(err, PR_ENUM, "internal: log-density of episode %d under policy %d missing",
		              i, m);
	*v = L->lp[c];
	return PR_OK;
}

/* The learning coordinates of episode i from its full state. */
static void learning_state(pr_exp3_learner *L, int i)
{
	const double *s = L->o.S + (size_t)i * L->ds;
	int j;

	for (j = 0; j < L->nx; ++j)
		L->X[(size_t)i * L->nx + j] = s[L->xdim[j]];
}

/* Draw the start state of episode i and its learning coordinates. */
static int draw_start(pr_exp3_learner *L, int i, char *err)
{
	int rc = pr_sim_sample_start(&L->cfg->table, &L->cfg->start, L->nballs, L->r_start,
	                             L->o.S + (size_t)i * L->ds, err);

	if (rc == PR_OK)
		learning_state(L, i);
	return rc;
}

#define DISC_DIRS 2048 /* directions of pr_exp3_disc_logmass's quadrature */
#define DISC_SIGMAS 8  /* a disc holding the 8-sigma ellipse holds all the mass */

double pr_exp3_disc_logmass(const double mean[2], const double cov[4], double vmax)
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

/* log of the Gaussian density of a, divided by its mass inside the speed
 * limit under exp3.truncation = corrected. */
static int gauss_logpdf(const pr_exp3_learner *L, const double *mean, const double *cov,
                        const double *a, double *lp, char *err)
{
	int rc = pr_policy_gauss_logpdf(DA, mean, cov, a, lp, err);

	if (rc == PR_OK && L->e->truncation == PR_EXP3_TRUNC_CORRECTED)
		*lp -= pr_exp3_disc_logmass(mean, cov, L->cfg->sim.max_speed);
	return rc;
}

/* log pi_m(a|x), truncated as gauss_logpdf says. */
static int policy_logpdf(pr_exp3_learner *L, int m, const double *x, const double *a, double *lp,
                         int *flags, char *err)
{
	double mean[DA], cov[DA * DA];
	int rc;

	if (L->e->truncation != PR_EXP3_TRUNC_CORRECTED)
		return pr_policy_logpdf(L->pol[m], x, a, lp, flags, L->work[m], err);
	if ((rc = pr_policy_eval(L->pol[m], x, mean, cov, flags, L->work[m], err)))
		return rc;
	return gauss_logpdf(L, mean, cov, a, lp, err);
}

/* Draw episode i's action from policy m, and note log pi_j(a_i|s_i) for
 * every live policy j <= m. Actions faster than sim.max_speed are drawn
 * again (the simulator refuses them), so the policy really draws from its
 * Gaussian truncated there; with exp3.truncation = redraw the noted
 * densities are the untruncated ones (they lack -log P(|a| <= max_speed | s)),
 * with corrected they include it, and with clip a fast draw is scaled onto
 * the limit instead. Redraws (or clips) are counted in exp3_reps.csv, so
 * their share is on record. */
static int draw_action(pr_exp3_learner *L, int i, int m, gsl_rng *rng, int *flags, char *err)
{
	const double *x = L->X + (size_t)i * L->nx;
	const double vmax = L->cfg->sim.max_speed;
	const int clip = L->cm || L->e->truncation == PR_EXP3_TRUNC_CLIP;
	double mean[DA], cov[DA * DA], lp, *a = L->o.A + DA * (size_t)i;
	int rc, j, tries = 0, f = 0, clipped = 0;

	if ((rc = pr_policy_eval(L->pol[m], x, mean, cov, &f, L->work[m], err)))
		return rc;
	*flags |= f;
	if (L->mu)
		memcpy(L->mu + DA * (size_t)i, mean, sizeof mean);
	do {
		if (tries++ == MAX_REDRAW)
			return pr_err(err, PR_ENUM, "episode %d: %d actions drawn, all faster than "
			              "sim.max_speed = %g m/s", i, MAX_REDRAW, vmax);
		if ((rc = pr_policy_gauss_sample(DA, mean, cov, 1, rng, a, err)))
			return rc;
		if (clip && hypot(a[0], a[1]) > vmax) {
			/* C-CMA-ES (always) and exp3.truncation = clip: the draw is
			 * projected onto the speed limit and the projected action is
			 * shot and used in the update (for C-CMA-ES a repair that keeps
			 * the mean near admissible actions; redrawing would let it
			 * drift past the limit, where every draw is refused) */
			double shrink = vmax / hypot(a[0], a[1]) * (1.0 - SPEED_MARGIN);

			a[0] *= shrink;
			a[1] *= shrink;
			clipped = L->e->truncation == PR_EXP3_TRUNC_CLIP;
		}
	} while (hypot(a[0], a[1]) > vmax);
	L->redraws += tries - 1 + clipped;
	if ((rc = gauss_logpdf(L, mean, cov, a, &lp, err)))
		return rc;
	set_lp(L, i, m, lp);
	for (j = L->pmin; j < m; ++j) {
		f = 0;
		if ((rc = policy_logpdf(L, j, x, a, &lp, &f, err)))
			return rc;
		*flags |= f;
		set_lp(L, i, j, lp);
	}
	return PR_OK;
}

/* Simulate episode i and record its outcome. */
static int shoot(pr_exp3_learner *L, int i, char *err)
{
	const pr_config *cfg = L->cfg;
	pr_exp3_episodes *o = &L->o;
	pr_shot res;
	int rc;

	rc = pr_sim_shoot(L->sim, o->S + (size_t)i * L->ds, L->nballs, o->A + DA * (size_t)i, &res,
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
static int play(pr_exp3_learner *L, int from, int count, int m, gsl_rng *rng, int *flags, char *err)
{
	int i, rc;

	for (i = from; i < from + count; ++i) {
		L->o.iter[i] = m;
		if ((rc = draw_start(L, i, err)) || (rc = draw_action(L, i, m, rng, flags, err)) ||
		    (rc = shoot(L, i, err)))
			return rc;
		L->o.n = i + 1;
	}
	return PR_OK;
}

/* Quadratic features of the box-normalised coordinates of n learning
 * states X into phi (n x pr_policy_features_count(QUADRATIC, nx)). */
static void quadratic_features(pr_exp3_learner *L, const double *X, int n, double *phi)
{
	int d = pr_policy_features_count(PR_FEATURES_QUADRATIC, L->nx), i, j;

	for (i = 0; i < n; ++i) {
		for (j = 0; j < L->nx; ++j)
			L->u[j] = (X[(size_t)i * L->nx + j] - L->xmid[j]) / L->xhalf[j];
		pr_policy_features_quadratic(L->u, L->nx, phi + (size_t)i * d);
	}
}

/* Value features of the window's n states into the REPS problem: one-hot
 * active leaves (CSR, eq. 5.4), active samples (dense, eq. 5.6), or the
 * quadratic features of the box-normalised coordinates (handcrafted). The
 * forest is returned in *fo (caller frees); NULL for handcrafted. */
static int value_features(pr_exp3_learner *L, const double *Xw, const double *Rw, int n,
                          pr_reps_problem *pb, pr_forest **fo, char *err)
{
	pr_forest_opts vo = L->cfg->value;
	pr_forest *f;
	int i, M, rc;

	*fo = NULL;
	if (L->v == PR_EXP3_HANDCRAFTED) {
		quadratic_features(L, Xw, n, L->phi);
		pb->d = pr_policy_features_count(PR_FEATURES_QUADRATIC, L->nx);
		pb->phi = L->phi;
		return PR_OK;
	}
	if (L->v == PR_EXP3_NRVR_RS || L->v == PR_EXP3_NRVR_A)
		vo.score = PR_SCORE_NRVR;
	else if (L->v == PR_EXP3_RVR_RS || L->v == PR_EXP3_RVR_A)
		vo.score = PR_SCORE_RVR;
	if (!(f = pr_forest_fit(&vo, Xw, n, L->nx, Rw, 1, NULL, L->r_learn, err)))
		return PR_ENUM;
	*fo = f;
	M = pr_forest_ntrees(f);
	if (L->cfg->value_features == PR_VALUE_SAMPLES) {
		for (i = 0; i < n; ++i)
			if ((rc = pr_forest_active_samples(f, Xw + (size_t)i * L->nx, L->nx,
			                                   L->phi + (size_t)i * n)))
				return rc;
		pb->d = n;
		pb->phi = L->phi;
		return PR_OK;
	}
	for (i = 0; i < n; ++i) {
		L->rowptr[i] = i * M;
		rc = pr_forest_active(f, Xw + (size_t)i * L->nx, L->nx, L->col + (size_t)i * M, M);
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
static pr_policy *fit_policy(pr_exp3_learner *L, const pr_policy_data *d, int *flags, char *err)
{
	pr_policy_opts po = L->cfg->policy;

	switch (L->v) {
	case PR_EXP3_HANDCRAFTED:
		return pr_policy_linear_fit(PR_FEATURES_AFFINE, d, po.lambda, po.min_std, po.cov_center,
		                            flags, err);
	case PR_EXP3_BASELINE:
		/* n_min above the window size: one node, a global linear-Gaussian policy */
		po.forest.n_min = L->e->baseline_n_min;
		break;
	case PR_EXP3_NRVR_RS:
	case PR_EXP3_RVR_RS:
		po.target = PR_TARGET_REWARD_STATE;
		break;
	default:
		po.target = PR_TARGET_ACTION;
		break;
	}
	if (L->n_min > 0)
		po.forest.n_min = L->n_min;
	return pr_policy_tree_fit(&po, d, L->r_learn, err);
}

/* Iteration t's episodes [end, end + samples) from pi_t; policies pmin ..
 * t - 1 are still evaluated on them. */
static int play_iteration(pr_exp3_learner *L, int t, int end, int pmin, int flags,
                          pr_exp3_iter *row, char *err)
{
	int rc;

	L->pmin = pmin;
	L->redraws = 0;
	rc = play(L, end, L->e->samples, t, L->r_learn, &flags, err);
	row->flags = flags;
	row->redraws = L->redraws;
	return rc;
}

/* Iteration t >= 1 of the hand-crafted loop with exp3.handcrafted_method =
 * ccmaes: one C-CMA-ES update from the latest generation (pi_{t-1}'s
 * episodes, or those of iteration 0), baseline features as REPS's value
 * features, then pi_t's episodes. No samples are reused, so q_ess is the
 * generation size; there is no dual (eta, kl, bound, residual 0) and ess is
 * the selection's mueff. */
static int iterate_ccmaes(pr_exp3_learner *L, int t, char *err)
{
	const pr_exp3_opts *e = L->e;
	pr_exp3_episodes *o = &L->o;
	pr_exp3_iter *row = &o->it[t - 1];
	const int end = L->n0 + (t - 1) * e->samples;
	const int n = t == 1 ? L->n0 : e->samples, a0 = end - n;
	pr_cmaes_batch b;
	pr_cmaes_info info;
	int rc, floored;

	b.n = n;
	b.nb = pr_policy_features_count(PR_FEATURES_QUADRATIC, L->nx);
	b.S = L->X + (size_t)a0 * L->nx;
	b.X = o->A + DA * (size_t)a0;
	b.R = o->R + a0;
	b.B = L->base;
	quadratic_features(L, b.S, n, L->base);
	if ((rc = pr_cmaes_update(L->cm, &b, &info, err)))
		return rc;
	memset(row, 0, sizeof *row);
	row->ess = info.mueff;
	row->q_ess = n;
	row->nfeat = b.nb;
	if (!(L->pol[t] = pr_cmaes_policy(L->cm, L->cfg->policy.min_std, &floored, err)))
		return PR_ENOMEM;
	if (!(L->work[t] = pr_policy_work_new(L->pol[t], err)))
		return PR_ENOMEM;
	pr_policy_free(L->pol[t - 1]);
	pr_policy_work_free(L->work[t - 1]);
	L->pol[t - 1] = NULL;
	L->work[t - 1] = NULL;
	return play_iteration(L, t, end, t, info.flags | (floored ? PR_POLICY_FLOOR : 0), row, err);
}

/* REPS on the window's n episodes from a0 with importance weights L->q:
 * the weights into L->p, the diagnostics into row. */
static int reps_weights(pr_exp3_learner *L, int t, int a0, int n, pr_exp3_iter *row, char *err)
{
	const double *Xw = L->X + (size_t)a0 * L->nx, *Rw = L->o.R + a0;
	pr_reps_problem pb;
	pr_reps_result *res = NULL;
	pr_forest *vf = NULL;
	int rc;

	memset(&pb, 0, sizeof pb);
	pb.n = n;
	pb.R = Rw;
	pb.q = L->q;
	rc = value_features(L, Xw, Rw, n, &pb, &vf, err);
	if (rc == PR_OK)
		rc = pr_reps_solve(&L->cfg->reps, &pb, &res, err);
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
	if (res->status == PR_REPS_FAILED && !L->cfg->reps.allow_failed)
		rc = pr_err(err, PR_ENUM, "iteration %d: REPS answer not certified: %s "
		            "(reps.allow_failed = 1 records such solves and goes on)", t, res->reason);
	pr_reps_result_free(res);
	return rc;
}

/* Iteration t >= 1: importance weights, value features, REPS, a new policy
 * and its episodes. */
static int iterate(pr_exp3_learner *L, int t, char *err)
{
	const pr_exp3_opts *e = L->e;
	pr_exp3_episodes *o = &L->o;
	pr_exp3_iter *row = &o->it[t - 1];
	int end = L->n0 + (t - 1) * e->samples;
	int n = end < e->window ? end : e->window, a0 = end - n;
	int pmin = o->iter[a0], npol = t - pmin, i, m, rc, flags = 0;
	pr_policy_data d;

	if (L->cm)
		return iterate_ccmaes(L, t, err);
	/* q_i = pi_{t-1}(a_i|s_i) / pi_mix(a_i|s_i) */
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
	if (rc == PR_OK && L->refit) {
		/* the refit control: p = q, an estimate of pi_{t-1} itself */
		memcpy(L->p, L->q, (size_t)n * sizeof *L->p);
		row->ess = row->q_ess;
	} else if (rc == PR_OK) {
		rc = reps_weights(L, t, a0, n, row, err);
	}
	if (rc)
		return rc;

	d.n = n;
	d.ds = L->nx;
	d.da = DA;
	d.dy = 2;
	d.S = L->X + (size_t)a0 * L->nx;
	d.A = o->A + DA * (size_t)a0;
	d.Y = o->F + 2 * (size_t)a0;
	d.w = L->p;
	d.M = L->mu ? L->mu + DA * (size_t)a0 : NULL;
	if (!(L->pol[t] = fit_policy(L, &d, &flags, err)))
		return PR_ENUM;
	if (!(L->work[t] = pr_policy_work_new(L->pol[t], err)))
		return PR_ENOMEM;
	for (i = a0; i < end; ++i) {
		double lp;
		int f = 0;
		rc = policy_logpdf(L, t, L->X + (size_t)i * L->nx, o->A + DA * (size_t)i, &lp, &f, err);
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

/* ---- setup ---- */

int pr_exp3_learner_check(const pr_config *cfg, const pr_exp3_opts *e, char *err)
{
	const pr_start_opts *so = &cfg->start;
	char at[PR_WHERE_LEN];
	int b, c, rc;

	if (cfg->table.reward_balls != 1)
		return pr_err(err, PR_EINVAL, "%s: table.reward_balls: Experiment 3 has one reward ball (got %d)",
		              pr_config_where(cfg, "table.reward_balls", at, sizeof at), cfg->table.reward_balls);
	if (e->window < 2)
		return pr_err(err, PR_EINVAL, "%s: exp3.window: must be >= 2 (got %d)",
		              pr_config_where(cfg, "exp3.window", at, sizeof at), e->window);
	if ((long)e->iterations * e->samples + e->init_samples > MAX_EPISODES)
		return pr_err(err, PR_EINVAL, "%s: exp3.iterations: %d iterations x exp3.samples %d: more "
		              "than 1e8 episodes per run", pr_config_where(cfg, "exp3.iterations", at, sizeof at),
		              e->iterations, e->samples);
	if ((rc = pr_forest_opts_check(&cfg->value, "value", err)) ||
	    (rc = pr_policy_opts_check(&cfg->policy, err)))
		return rc;
	for (b = 0; b < cfg->table.balls; ++b) {
		const double *box = b == 0 ? so->cue_box : b <= cfg->table.reward_balls ?
		                    so->reward_box : so->obstacle_box;
		for (c = 0; c < 2; ++c)
			if (box[2 * c + 1] > box[2 * c])
				return PR_OK;
	}
	return pr_err(err, PR_EINVAL, "%s: start.reward_box: every start box is a point: Experiment 3 "
	              "needs varying start states", pr_config_where(cfg, "start.reward_box", at, sizeof at));
}

/* The coordinates whose start box has extent, or with exp3.state = full
 * every coordinate (a point box's coordinate is centred on the point, half-width 1): the
 * learner's state. */
static int learning_dims(pr_exp3_learner *L, char *err)
{
	const pr_start_opts *so = &L->cfg->start;
	int b, c;

	L->xdim = malloc((size_t)L->ds * sizeof *L->xdim);
	L->xmid = malloc((size_t)L->ds * sizeof *L->xmid);
	L->xhalf = malloc((size_t)L->ds * sizeof *L->xhalf);
	if (!L->xdim || !L->xmid || !L->xhalf)
		return pr_err(err, PR_ENOMEM, "out of memory");
	L->nx = 0;
	for (b = 0; b < L->nballs; ++b) {
		const double *box = b == 0 ? so->cue_box : b <= L->cfg->table.reward_balls ?
		                    so->reward_box : so->obstacle_box;
		for (c = 0; c < 2; ++c)
			if (box[2 * c + 1] > box[2 * c] || L->e->state == PR_EXP3_STATE_FULL) {
				L->xdim[L->nx] = 2 * b + c;
				L->xmid[L->nx] = 0.5 * (box[2 * c] + box[2 * c + 1]);
				L->xhalf[L->nx] = box[2 * c + 1] > box[2 * c] ? 0.5 * (box[2 * c + 1] - box[2 * c]) : 1;
				L->nx++;
			}
	}
	if (L->nx == 0)
		return pr_exp3_learner_check(L->cfg, L->e, err);
	return PR_OK;
}

void pr_exp3_episodes_free(pr_exp3_episodes *o)
{
	free(o->S);
	free(o->A);
	free(o->R);
	free(o->F);
	free(o->pocket);
	free(o->hit);
	free(o->iter);
	free(o->it);
	memset(o, 0, sizeof *o);
}

void pr_exp3_learner_free(pr_exp3_learner *L)
{
	int m;

	if (!L)
		return;
	/* either may be missing when an allocation failed */
	for (m = 0; L->pol && m <= L->e->iterations; ++m)
		pr_policy_free(L->pol[m]);
	for (m = 0; L->work && m <= L->e->iterations; ++m)
		pr_policy_work_free(L->work[m]);
	free(L->pol);
	free(L->work);
	pr_sim_free(L->sim);
	pr_exp3_episodes_free(&L->o);
	free(L->xdim);
	free(L->xmid);
	free(L->xhalf);
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
	free(L);
}

/* The window scratch, sized by exp3.window, exp3.samples and the forests. */
static int alloc_scratch(pr_exp3_learner *L, char *err)
{
	const pr_exp3_opts *e = L->e;
	int W = e->window, T = e->iterations, M = L->cfg->value.trees, nq, dphi;
	size_t cells;

	L->SC = W + e->samples;
	L->PC = (W - 1) / e->samples + 2;
	cells = (size_t)L->SC * (size_t)L->PC;
	nq = pr_policy_features_count(PR_FEATURES_QUADRATIC, L->nx);
	dphi = L->cfg->value_features == PR_VALUE_SAMPLES && W > nq ? W : nq;
	L->pol = calloc((size_t)T + 1, sizeof *L->pol);
	L->work = calloc((size_t)T + 1, sizeof *L->work);
	L->o.it = calloc((size_t)T + 1, sizeof *L->o.it);
	L->lp = malloc(cells * sizeof *L->lp);
	L->tag_i = malloc(cells * sizeof *L->tag_i);
	L->tag_m = malloc(cells * sizeof *L->tag_m);
	L->q = malloc((size_t)W * sizeof *L->q);
	L->logpi = malloc((size_t)W * L->PC * sizeof *L->logpi);
	L->logcur = malloc((size_t)W * sizeof *L->logcur);
	L->p = malloc((size_t)W * sizeof *L->p);
	L->phi = malloc((size_t)W * dphi * sizeof *L->phi);
	L->u = malloc((size_t)L->nx * sizeof *L->u);
	L->counts = malloc((size_t)L->PC * sizeof *L->counts);
	L->rowptr = malloc(((size_t)W + 1) * sizeof *L->rowptr);
	L->col = malloc((size_t)W * M * sizeof *L->col);
	if (!L->pol || !L->work || !L->o.it || !L->lp || !L->tag_i || !L->tag_m || !L->q ||
	    !L->logpi || !L->logcur || !L->p || !L->phi || !L->u || !L->counts || !L->rowptr || !L->col)
		return pr_err(err, PR_ENOMEM, "out of memory");
	/* no cell holds a value yet */
	memset(L->tag_i, 0xff, cells * sizeof *L->tag_i);
	memset(L->tag_m, 0xff, cells * sizeof *L->tag_m);
	return PR_OK;
}

int pr_exp3_learner_new(const pr_config *cfg, const pr_exp3_opts *e, int v, gsl_rng *start,
                        gsl_rng *init, gsl_rng *learn, pr_exp3_learner **out, char *err)
{
	pr_exp3_learner *L = calloc(1, sizeof *L);
	int rc;

	*out = NULL;
	if (!L)
		return pr_err(err, PR_ENOMEM, "out of memory");
	L->cfg = cfg;
	L->e = e;
	L->v = v;
	L->nballs = cfg->table.balls;
	L->ds = L->o.ds = 2 * L->nballs;
	L->r_start = start;
	L->r_init = init;
	L->r_learn = learn;
	if (v < 0 || v >= PR_EXP3_NVAR)
		rc = pr_err(err, PR_EINVAL, "internal: learner variant %d", v);
	else if ((rc = learning_dims(L, err)) == PR_OK && (rc = alloc_scratch(L, err)) == PR_OK &&
	         !(L->sim = pr_sim_new(&cfg->table, &cfg->sim, err)))
		rc = PR_EINVAL;
	if (rc) {
		pr_exp3_learner_free(L);
		return rc;
	}
	*out = L;
	return PR_OK;
}

int pr_exp3_learner_set_policy(pr_exp3_learner *L, pr_policy *p, char *err)
{
	if (L->n0 > 0 || L->pol[0] || (L->v == PR_EXP3_HANDCRAFTED &&
	                               L->e->handcrafted_method == PR_METHOD_CCMAES)) {
		pr_policy_free(p);
		return pr_err(err, PR_EINVAL, "internal: an initial policy is set once, before "
		              "iteration 0, and not for C-CMA-ES");
	}
	L->pol[0] = p;
	if (!(L->work[0] = pr_policy_work_new(p, err)))
		return PR_ENOMEM;
	return PR_OK;
}

/* Iteration 0 of n0 episodes: the episode arrays, pi_0 unless set, and
 * the hand-crafted learner's state. */
static int begin(pr_exp3_learner *L, int n0, char *err)
{
	const pr_exp3_opts *e = L->e;
	pr_exp3_episodes *o = &L->o;
	size_t cap;
	int nq = pr_policy_features_count(PR_FEATURES_QUADRATIC, L->nx);

	if (L->n0 > 0)
		return pr_err(err, PR_EINVAL, "internal: iteration 0 played twice");
	if (n0 < 1 || (long)e->iterations * e->samples + n0 > MAX_EPISODES)
		return pr_err(err, PR_EINVAL, "internal: %d episodes in iteration 0", n0);
	L->n0 = n0;
	L->cap = n0 + e->iterations * e->samples;
	cap = (size_t)L->cap;
	o->S = malloc(cap * L->ds * sizeof *o->S);
	o->A = malloc(DA * cap * sizeof *o->A);
	o->R = malloc(cap * sizeof *o->R);
	o->F = malloc(2 * cap * sizeof *o->F);
	o->pocket = malloc(cap * sizeof *o->pocket);
	o->hit = malloc(cap * sizeof *o->hit);
	o->iter = malloc(cap * sizeof *o->iter);
	L->X = malloc(cap * L->nx * sizeof *L->X);
	if (!o->S || !o->A || !o->R || !o->F || !o->pocket || !o->hit || !o->iter || !L->X)
		return pr_err(err, PR_ENOMEM, "out of memory");
	if (!L->pol[0]) {
		/* N(0, init_std^2 I) */
		double mean0[DA] = {0.0, 0.0}, cov0[DA * DA];

		cov0[0] = cov0[3] = e->init_std * e->init_std;
		cov0[1] = cov0[2] = 0.0;
		if (!(L->pol[0] = pr_policy_gaussian_new(L->nx, DA, mean0, cov0, err)))
			return PR_EINVAL;
		if (!(L->work[0] = pr_policy_work_new(L->pol[0], err)))
			return PR_ENOMEM;
	}
	if (L->v == PR_EXP3_HANDCRAFTED && e->handcrafted_method == PR_METHOD_CCMAES) {
		/* N(W [1, x], init_std^2 I) with W = 0: pi_0 */
		double *W0 = calloc(DA * ((size_t)L->nx + 1), sizeof *W0);

		L->cm = W0 ? pr_cmaes_new(PR_FEATURES_AFFINE, L->nx, DA, W0, e->init_std,
		                          L->cfg->policy.lambda, err) : NULL;
		free(W0);
		L->base = malloc((size_t)(n0 > e->samples ? n0 : e->samples) * nq * sizeof *L->base);
		if (!L->cm || !L->base)
			return pr_err(err, PR_ENOMEM, "out of memory");
	} else if (L->cfg->policy.cov_center == PR_COV_CENTER_OLD &&
	           !(L->mu = malloc(DA * cap * sizeof *L->mu))) {
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	return PR_OK;
}

int pr_exp3_learner_start(pr_exp3_learner *L, char *err)
{
	int flags = 0, rc;

	if (L->n0 > 0)
		return PR_OK;
	if ((rc = begin(L, L->e->init_samples, err)))
		return rc;
	return play(L, 0, L->n0, 0, L->r_init, &flags, err);
}

int pr_exp3_learner_seed(pr_exp3_learner *L, int n, const double *S, const double *A,
                         const double *R, const double *F, const int *pocket, const int *hit,
                         const double *logq, char *err)
{
	pr_exp3_episodes *o = &L->o;
	double mean[DA], cov[DA * DA], lp;
	int i, rc, f = 0;

	if ((rc = begin(L, n, err)))
		return rc;
	memcpy(o->S, S, (size_t)n * L->ds * sizeof *S);
	memcpy(o->A, A, DA * (size_t)n * sizeof *A);
	memcpy(o->R, R, (size_t)n * sizeof *R);
	memcpy(o->F, F, 2 * (size_t)n * sizeof *F);
	for (i = 0; i < n; ++i) {
		const double *x = L->X + (size_t)i * L->nx;
		o->pocket[i] = pocket ? pocket[i] : -1;
		o->hit[i] = hit ? hit[i] : 0;
		o->iter[i] = 0;
		learning_state(L, i);
		if (L->mu && (rc = pr_policy_eval(L->pol[0], x, mean, cov, &f, L->work[0], err)))
			return rc;
		if (L->mu)
			memcpy(L->mu + DA * (size_t)i, mean, sizeof mean);
		if (logq)
			lp = logq[i];
		else if ((rc = policy_logpdf(L, 0, x, o->A + DA * (size_t)i, &lp, &f, err)))
			return rc;
		if (!isfinite(lp))
			return pr_err(err, PR_EINVAL, "seeded episode %d: log-density %g", i, lp);
		set_lp(L, i, 0, lp);
	}
	o->n = n;
	return PR_OK;
}

/* PR_OK if iteration t may run now: after iteration 0, within the
 * iterations, and of the same kind as the ones before (repeat or REPS). */
static int next_ok(const pr_exp3_learner *L, int t, int repeat, char *err)
{
	if (L->n0 == 0 || t > L->e->iterations)
		return pr_err(err, PR_EINVAL, "internal: iteration %d of %d%s", t, L->e->iterations,
		              L->n0 ? "" : " before iteration 0");
	if (t > 1 && L->repeats != repeat)
		return pr_err(err, PR_EINVAL, "internal: REPS iterations and repeats mixed");
	return PR_OK;
}

int pr_exp3_learner_iterate(pr_exp3_learner *L, char *err)
{
	int t = L->o.niter + 1, rc;

	if ((rc = next_ok(L, t, 0, err)))
		return rc;
	if ((rc = iterate(L, t, err)) == PR_OK)
		L->o.niter = t;
	return rc;
}

int pr_exp3_learner_repeat(pr_exp3_learner *L, char *err)
{
	int t = L->o.niter + 1, end = L->n0 + (t - 1) * L->e->samples, i, rc;
	pr_exp3_iter *row = &L->o.it[t - 1];

	if ((rc = next_ok(L, t, 1, err)))
		return rc;
	if (L->cm)
		return pr_err(err, PR_EINVAL, "internal: C-CMA-ES does not repeat");
	L->repeats = 1;
	memset(row, 0, sizeof *row);
	/* pi_0 draws them: no other policy lives, so no density is noted but its own */
	if ((rc = play_iteration(L, 0, end, 0, 0, row, err)))
		return rc;
	for (i = end; i < end + L->e->samples; ++i)
		L->o.iter[i] = t;
	L->o.niter = t;
	return PR_OK;
}

int pr_exp3_learner_set_control(pr_exp3_learner *L, int refit, int n_min, char *err)
{
	if (L->o.niter > 0 || L->cm || n_min < 0 || (n_min > 0 && (L->v == PR_EXP3_BASELINE ||
	                                                          L->v == PR_EXP3_HANDCRAFTED)))
		return pr_err(err, PR_EINVAL, "internal: a control is set before iteration 1, on a "
		              "fitted learner, and n_min only for the tree policies");
	L->refit = refit;
	L->n_min = n_min;
	return PR_OK;
}

const pr_policy *pr_exp3_learner_policy(const pr_exp3_learner *L)
{
	return L->pol[L->repeats ? 0 : L->o.niter];
}

int pr_exp3_learner_mean_eval(pr_exp3_learner *L, int n, gsl_rng *states, double *ret,
                              int *pocket, int *hit, char *err)
{
	const pr_policy *p = pr_exp3_learner_policy(L);
	const double vmax = L->cfg->sim.max_speed;
	double *s = malloc((size_t)L->ds * sizeof *s), *x = malloc((size_t)L->nx * sizeof *x);
	double a[DA], cov[DA * DA], v;
	pr_policy_work *ws = p ? pr_policy_work_new(p, err) : NULL;
	pr_shot shot;
	int i, j, rc = p ? PR_OK : pr_err(err, PR_EINVAL, "internal: no policy to evaluate");

	if (rc == PR_OK && (!s || !x || !ws))
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	for (i = 0; rc == PR_OK && i < n; ++i) {
		if ((rc = pr_sim_sample_start(&L->cfg->table, &L->cfg->start, L->nballs, states, s, err)))
			break;
		for (j = 0; j < L->nx; ++j)
			x[j] = s[L->xdim[j]];
		if ((rc = pr_policy_eval(p, x, a, cov, NULL, ws, err)))
			break;
		/* a mean beyond the speed limit is scaled down to it, as in Experiment
		 * 2, strictly inside (the rounded product may land just above it) */
		if ((v = hypot(a[0], a[1])) > vmax) {
			a[0] *= vmax / v * (1.0 - SPEED_MARGIN);
			a[1] *= vmax / v * (1.0 - SPEED_MARGIN);
		}
		if ((rc = pr_sim_shoot(L->sim, s, L->nballs, a, &shot, NULL, err)))
			break;
		ret[i] = pr_sim_reward(&L->cfg->table, &L->cfg->reward, &shot);
		pocket[i] = shot.pocket[1];
		hit[i] = shot.hit;
	}
	pr_policy_work_free(ws);
	free(s);
	free(x);
	return rc;
}

int pr_exp3_learner_state_dims(const pr_exp3_learner *L, const int **xdim)
{
	*xdim = L->xdim;
	return L->nx;
}

const pr_exp3_episodes *pr_exp3_learner_episodes(const pr_exp3_learner *L)
{
	return &L->o;
}

void pr_exp3_learner_take(pr_exp3_learner *L, pr_exp3_episodes *out)
{
	*out = L->o;
	memset(&L->o, 0, sizeof L->o);
	L->o.ds = L->ds;
}
