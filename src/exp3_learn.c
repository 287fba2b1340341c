/* exp3_learn.c — the learner of Experiment 3 (thesis 7.5.1; the loop is in
 * exp3_priv.h): the pool task around the ask/tell learner (learner.h). One
 * (repetition, variant) pair: start states, shots and rewards here; the
 * window, REPS and the policy fits in the learner, which draws the actions
 * within sim.max_speed.
 *
 * The learner sees only the state coordinates that vary (those whose start
 * box has extent): the cue ball starts at a point, and a constant column
 * would make the design matrix of eq. 6.6 singular without changing a
 * prediction.
 *
 * Streams: start states come from `start`, pi_0's actions from `init`,
 * forests and later actions from `learn`; Experiment 3 shares the first two
 * between the variants of a repetition (common random numbers). The
 * hand-crafted variant's C-CMA-ES search (exp3.handcrafted_method = ccmaes)
 * is no REPS learner: each generation is drawn by a learner that holds the
 * search distribution as its pi_0.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "poolreps/internal.h"
#include "poolreps/cmaes.h"
#include "poolreps/forest.h"
#include "poolreps/learner.h"
#include "poolreps/sim.h"
#include "exp3_priv.h"

#define MAX_EPISODES 100000000L /* per learner: the memory of a run stays bounded */
#define SPEED_MARGIN 1e-12 /* mean actions: strictly inside the speed limit */
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
	double *G;                /* cap x quadratic features (hand-crafted REPS) */
	pr_learner *lr;           /* the learner (C-CMA-ES: the latest generation's sampler) */
	pr_policy *pi0;           /* set_policy's pi_0 until the learner exists */
	int repeats;              /* pr_exp3_learner_repeat ran: pi_0 is never replaced */
	int refit;                /* control: no REPS, pi_t fitted with the weights q alone */
	int n_min;                /* control: tree-LWR forest n_min (0: policy.n_min) */
	double *logq0;            /* seeded episodes' log-densities, or NULL */
	double *u;                /* nx scratch */
	pr_cmaes *cm;             /* the C-CMA-ES state (handcrafted_method = ccmaes) */
	pr_policy *cpol;          /* its latest search distribution */
	double *base;             /* its baseline features */
};

/* The learning coordinates of episode i from its full state. */
static void learning_state(pr_exp3_learner *L, int i)
{
	const double *s = L->o.S + (size_t)i * L->ds;
	int j;

	for (j = 0; j < L->nx; ++j)
		L->X[(size_t)i * L->nx + j] = s[L->xdim[j]];
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

/* Episodes [from, from + count) of iteration t: start states, actions the
 * learner draws with rng, shots. row (may be NULL) receives the redraws and
 * or-s in the flags of the draws. */
static int play(pr_exp3_learner *L, int from, int count, int t, gsl_rng *rng, pr_exp3_iter *row,
                char *err)
{
	int i, rc, redraws, flags;

	for (i = from; i < from + count; ++i) {
		rc = pr_sim_sample_start(&L->cfg->table, &L->cfg->start, L->nballs, L->r_start,
		                         L->o.S + (size_t)i * L->ds, err);
		if (rc)
			return rc;
		learning_state(L, i);
		L->o.iter[i] = t;
	}
	pr_learner_set_rng(L->lr, rng);
	rc = pr_learner_ask(L->lr, count, L->X + (size_t)from * L->nx, L->o.A + DA * (size_t)from, err);
	pr_learner_set_rng(L->lr, L->r_learn);
	if (rc)
		return rc;
	pr_learner_ask_info(L->lr, &redraws, &flags);
	if (row) {
		row->redraws = redraws;
		row->flags |= flags;
	}
	for (i = from; i < from + count; ++i) {
		if ((rc = shoot(L, i, err)))
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

/* The learner's options for variant v: value features from an NRVR or RVR
 * forest (or value.score for the baseline), the policy forest's target,
 * the baseline's one node; the hand-crafted variant's quadratic features
 * (given) and linear policy; actions within sim.max_speed. */
static void learner_opts(const pr_exp3_learner *L, pr_learner_opts *lo)
{
	const pr_config *cfg = L->cfg;
	const pr_exp3_opts *e = L->e;

	pr_learner_opts_init(lo);
	lo->window = e->window;
	lo->init_std = e->init_std;
	lo->max_norm = cfg->sim.max_speed;
	lo->truncation = L->cm || e->truncation == PR_EXP3_TRUNC_CLIP ? PR_LEARNER_CLIP
	                 : e->truncation == PR_EXP3_TRUNC_CORRECTED ? PR_LEARNER_CORRECTED
	                 : PR_LEARNER_REDRAW;
	lo->refit = L->refit;
	lo->value_forest = cfg->value;
	lo->value_features = cfg->value_features;
	lo->reps = cfg->reps;
	lo->policy = cfg->policy;
	lo->value = L->v == PR_EXP3_NRVR_RS || L->v == PR_EXP3_NRVR_A ? PR_LEARNER_VALUE_NRVR
	            : L->v == PR_EXP3_RVR_RS || L->v == PR_EXP3_RVR_A ? PR_LEARNER_VALUE_RVR
	            : L->v == PR_EXP3_HANDCRAFTED ? PR_LEARNER_VALUE_GIVEN : PR_LEARNER_VALUE_TREES;
	if (L->v == PR_EXP3_HANDCRAFTED)
		lo->policy_type = PR_LEARNER_POLICY_LINEAR;
	else if (L->v == PR_EXP3_BASELINE)
		/* n_min above the window size: one node, a global linear-Gaussian policy */
		lo->policy.forest.n_min = e->baseline_n_min;
	else
		lo->policy.target = L->v == PR_EXP3_NRVR_RS || L->v == PR_EXP3_RVR_RS ?
		                    PR_TARGET_REWARD_STATE : PR_TARGET_ACTION;
	if (L->n_min > 0)
		lo->policy.forest.n_min = L->n_min;
}

/* Iteration t >= 1 of the hand-crafted loop with exp3.handcrafted_method =
 * ccmaes: one C-CMA-ES update from the latest generation (pi_{t-1}'s
 * episodes, or those of iteration 0), baseline features as REPS's value
 * features, then pi_t's episodes, drawn by a learner holding pi_t. No
 * samples are reused, so q_ess is the generation size; there is no dual
 * (eta, kl, bound, residual 0) and ess is the selection's mueff. */
static int iterate_ccmaes(pr_exp3_learner *L, int t, char *err)
{
	const pr_exp3_opts *e = L->e;
	pr_exp3_episodes *o = &L->o;
	pr_exp3_iter *row = &o->it[t - 1];
	const int end = L->n0 + (t - 1) * e->samples;
	const int n = t == 1 ? L->n0 : e->samples, a0 = end - n;
	pr_learner_opts lo;
	pr_cmaes_batch b;
	pr_cmaes_info info;
	pr_policy *p;
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
	row->flags = info.flags;
	if (!(p = pr_cmaes_policy(L->cm, L->cfg->policy.min_std, &floored, err)))
		return PR_ENOMEM;
	row->flags |= floored ? PR_POLICY_FLOOR : 0;
	pr_learner_free(L->lr);
	learner_opts(L, &lo);
	if (!(L->lr = pr_learner_new(&lo, L->nx, DA, L->r_learn, err))) {
		pr_policy_free(p);
		return PR_ENOMEM;
	}
	if ((rc = pr_learner_set_policy(L->lr, p, err)) ||
	    (rc = play(L, end, e->samples, t, L->r_learn, row, err)))
		return rc;
	/* the draws are projected onto the limit; only exp3.truncation = clip counts them */
	if (e->truncation != PR_EXP3_TRUNC_CLIP)
		row->redraws = 0;
	return PR_OK;
}

/* Iteration t >= 1: iteration t - 1's episodes told to the learner (REPS
 * and a new policy), then `samples` new episodes drawn by it. */
static int iterate(pr_exp3_learner *L, int t, char *err)
{
	const pr_exp3_opts *e = L->e;
	pr_exp3_episodes *o = &L->o;
	pr_exp3_iter *row = &o->it[t - 1];
	const int end = L->n0 + (t - 1) * e->samples, n = t == 1 ? L->n0 : e->samples, a0 = end - n;
	const int nq = pr_policy_features_count(PR_FEATURES_QUADRATIC, L->nx);
	const pr_learner_summary *s;
	pr_learner_batch b;
	int rc;

	if (L->cm)
		return iterate_ccmaes(L, t, err);
	memset(&b, 0, sizeof b);
	b.n = n;
	b.contexts = L->X + (size_t)a0 * L->nx;
	b.actions = o->A + DA * (size_t)a0;
	b.returns = o->R + a0;
	b.targets = o->F + 2 * (size_t)a0;
	b.dy = 2;
	b.logq = t == 1 ? L->logq0 : NULL;
	if (L->G) {
		quadratic_features(L, b.contexts, n, L->G + (size_t)a0 * nq);
		b.features = L->G + (size_t)a0 * nq;
		b.d = nq;
	}
	if ((rc = pr_learner_tell_batch(L->lr, &b, err)))
		return rc;
	s = pr_learner_last(L->lr);
	memset(row, 0, sizeof *row);
#define COPY(f, g) row->f = s->g;
	COPY(eta, eta) COPY(kl, kl) COPY(ess, ess) COPY(q_ess, q_ess) COPY(residual, residual)
	COPY(kl_gap, kl_gap) COPY(residual_rel, residual_rel) COPY(bound, bound)
	COPY(nfeat, nfeat) COPY(evals, evals) COPY(status, status) COPY(flags, flags)
#undef COPY
	return play(L, end, e->samples, t, L->r_learn, row, err);
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
	if (!L)
		return;
	pr_learner_free(L->lr);
	pr_policy_free(L->pi0);
	pr_sim_free(L->sim);
	pr_exp3_episodes_free(&L->o);
	free(L->xdim);
	free(L->xmid);
	free(L->xhalf);
	free(L->X);
	free(L->G);
	free(L->logq0);
	free(L->u);
	pr_cmaes_free(L->cm);
	free(L->base);
	free(L);
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
	else if ((rc = learning_dims(L, err)) == PR_OK &&
	         (!(L->o.it = calloc((size_t)e->iterations + 1, sizeof *L->o.it)) ||
	          !(L->u = malloc((size_t)L->nx * sizeof *L->u))))
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	else if (rc == PR_OK && !(L->sim = pr_sim_new(&cfg->table, &cfg->sim, err)))
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
	if (L->n0 > 0 || L->pi0 || (L->v == PR_EXP3_HANDCRAFTED &&
	                            L->e->handcrafted_method == PR_METHOD_CCMAES)) {
		pr_policy_free(p);
		return pr_err(err, PR_EINVAL, "internal: an initial policy is set once, before "
		              "iteration 0, and not for C-CMA-ES");
	}
	L->pi0 = p;
	return PR_OK;
}

/* Iteration 0 of n0 episodes: the episode arrays, the learner with pi_0,
 * and the hand-crafted learner's state. */
static int begin(pr_exp3_learner *L, int n0, char *err)
{
	const pr_exp3_opts *e = L->e;
	pr_exp3_episodes *o = &L->o;
	pr_learner_opts lo;
	size_t cap;
	int nq = pr_policy_features_count(PR_FEATURES_QUADRATIC, L->nx), rc;

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
	if (L->v == PR_EXP3_HANDCRAFTED && e->handcrafted_method == PR_METHOD_CCMAES) {
		/* N(W [1, x], init_std^2 I) with W = 0: pi_0 */
		double *W0 = calloc(DA * ((size_t)L->nx + 1), sizeof *W0);

		L->cm = W0 ? pr_cmaes_new(PR_FEATURES_AFFINE, L->nx, DA, W0, e->init_std,
		                          L->cfg->policy.lambda, err) : NULL;
		free(W0);
		L->base = malloc((size_t)(n0 > e->samples ? n0 : e->samples) * nq * sizeof *L->base);
		if (!L->cm || !L->base)
			return pr_err(err, PR_ENOMEM, "out of memory");
	} else if (L->v == PR_EXP3_HANDCRAFTED && !(L->G = malloc(cap * nq * sizeof *L->G))) {
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	learner_opts(L, &lo);
	if (!(L->lr = pr_learner_new(&lo, L->nx, DA, L->r_learn, err)))
		return PR_EINVAL;
	if (L->pi0) {
		rc = pr_learner_set_policy(L->lr, L->pi0, err);
		L->pi0 = NULL;
		return rc;
	}
	return PR_OK;
}

int pr_exp3_learner_start(pr_exp3_learner *L, char *err)
{
	int rc;

	if (L->n0 > 0)
		return PR_OK;
	if ((rc = begin(L, L->e->init_samples, err)))
		return rc;
	return play(L, 0, L->n0, 0, L->r_init, NULL, err);
}

int pr_exp3_learner_seed(pr_exp3_learner *L, int n, const double *S, const double *A,
                         const double *R, const double *F, const int *pocket, const int *hit,
                         const double *logq, char *err)
{
	pr_exp3_episodes *o = &L->o;
	int i, rc;

	if (L->cm)
		return pr_err(err, PR_EINVAL, "internal: C-CMA-ES is not seeded");
	if ((rc = begin(L, n, err)))
		return rc;
	memcpy(o->S, S, (size_t)n * L->ds * sizeof *S);
	memcpy(o->A, A, DA * (size_t)n * sizeof *A);
	memcpy(o->R, R, (size_t)n * sizeof *R);
	memcpy(o->F, F, 2 * (size_t)n * sizeof *F);
	for (i = 0; i < n; ++i) {
		o->pocket[i] = pocket ? pocket[i] : -1;
		o->hit[i] = hit ? hit[i] : 0;
		o->iter[i] = 0;
		learning_state(L, i);
		if (logq && !isfinite(logq[i]))
			return pr_err(err, PR_EINVAL, "seeded episode %d: log-density %g", i, logq[i]);
	}
	/* the first tell takes them, with these densities or pi_0's */
	if (logq && !(L->logq0 = malloc((size_t)n * sizeof *L->logq0)))
		return pr_err(err, PR_ENOMEM, "out of memory");
	if (logq)
		memcpy(L->logq0, logq, (size_t)n * sizeof *logq);
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
	int t = L->o.niter + 1, end = L->n0 + (t - 1) * L->e->samples, rc;
	pr_exp3_iter *row = &L->o.it[t - 1];

	if ((rc = next_ok(L, t, 1, err)))
		return rc;
	if (L->cm)
		return pr_err(err, PR_EINVAL, "internal: C-CMA-ES does not repeat");
	L->repeats = 1;
	memset(row, 0, sizeof *row);
	/* pi_0 draws them: the learner is never told */
	if ((rc = play(L, end, L->e->samples, t, L->r_learn, row, err)))
		return rc;
	L->o.niter = t;
	return PR_OK;
}

int pr_exp3_learner_set_control(pr_exp3_learner *L, int refit, int n_min, char *err)
{
	pr_learner_opts lo;

	if (L->o.niter > 0 || L->cm || n_min < 0 || (n_min > 0 && (L->v == PR_EXP3_BASELINE ||
	                                                          L->v == PR_EXP3_HANDCRAFTED)))
		return pr_err(err, PR_EINVAL, "internal: a control is set before iteration 1, on a "
		              "fitted learner, and n_min only for the tree policies");
	L->refit = refit;
	L->n_min = n_min;
	if (!L->lr)
		return PR_OK;
	learner_opts(L, &lo);
	return pr_learner_set_options(L->lr, &lo, err);
}

const pr_policy *pr_exp3_learner_policy(const pr_exp3_learner *L)
{
	return L->lr ? pr_learner_policy(L->lr) : L->pi0;
}

int pr_exp3_learner_mean_eval(pr_exp3_learner *L, int n, gsl_rng *states, double *sum,
                              int *in, int *hits, char *err)
{
	const pr_policy *p = pr_exp3_learner_policy(L);
	const double vmax = L->cfg->sim.max_speed;
	double *s = malloc((size_t)L->ds * sizeof *s), *x = malloc((size_t)L->nx * sizeof *x);
	double a[DA], cov[DA * DA], v;
	pr_policy_work *ws = p ? pr_policy_work_new(p, err) : NULL;
	pr_shot shot;
	int i, j, rc = p ? PR_OK : pr_err(err, PR_EINVAL, "internal: no policy to evaluate");

	*sum = 0;
	*in = *hits = 0;
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
		*sum += pr_sim_reward(&L->cfg->table, &L->cfg->reward, &shot);
		*in += shot.pocket[1] >= 0 && pr_exp3_is_target(&L->cfg->reward, shot.pocket[1]);
		*hits += shot.hit;
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
