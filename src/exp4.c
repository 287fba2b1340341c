/* exp4.c — Experiment 4 (beyond the thesis): does initialising the policy by
 * imitation rescue the tree policies of Experiment 3? The thesis closes 7.5.2
 * with that conjecture; here every policy of Experiment 3 is fitted to
 * ghost-ball demonstrations (Experiment 2's expert, thesis 7.4.1) and then
 * trained with Experiment 3's REPS loop unchanged (exp3_learn.c).
 *
 * A job is one (repetition k, variant) pair, variant = (policy, init, cov)
 * (exp4_priv.h). Per job:
 *   scratch    Experiment 3's run itself: the same learner, options and
 *              streams, so its rows equal exp3_episodes.csv's for the same
 *              seed (with policy.cov = cov);
 *   otherwise  the repetition's n_demo demonstrations: start states in
 *              Experiment 3's box, the expert's action plus N(0,
 *              demo_noise^2 I), shot; pi_0 = the policy fitted to them with
 *              unit weights (tree policies: n_min = fit_n_min_frac x n_demo,
 *              Experiment 2's rule; the baseline: one node; hand-crafted:
 *              weighted ML of the linear-Gaussian policy); then
 *     imitation  pi_0 draws exp3.init_samples + iterations x samples
 *                episodes, never replaced (the reference);
 *     policy     pi_0 draws exp3.init_samples episodes (iteration 0), then
 *                REPS iterations;
 *     demo       the demonstrations are iteration 0 and REPS's first
 *                window, counted as pi_0's episodes in the importance
 *                weights (the noise-free expert has no density); then REPS
 *                iterations.
 *
 * Streams (streams.h), all indexed by the repetition k: start states come
 * from Experiment 3's start stream in every run, and a demo run first skips
 * the exp3.init_samples states it does not draw, so that episode j of
 * iteration t >= 1 starts from the same state in every variant (common
 * random numbers); the demonstrations from one stream per repetition (the
 * first n of any larger n_demo, the same states whatever demo_noise); pi_0's
 * forest from a stream per policy kind (s -> rs, s -> a, baseline,
 * hand-crafted), so nrvr_x and rvr_x start from one fitted policy; pi_0's
 * iteration-0 draws from a stream per (kind, cov), shared by imitation and
 * policy runs; everything later from a stream per variant.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_randist.h>

#include "poolreps/forest.h"
#include "poolreps/sim.h"
#include "exp4_priv.h"
#include "streams.h"

#define DA 2            /* action: cue-ball velocity */
#define MAX_NOISE_DRAWS 100

/* ---- demonstrations and the fit to them ---- */

void pr_exp4_demo_free(pr_exp4_demo *d)
{
	free(d->S);
	free(d->A);
	free(d->E);
	free(d->R);
	free(d->F);
	free(d->pocket);
	free(d->hit);
	memset(d, 0, sizeof *d);
}

void pr_exp4_fit_free(pr_exp4_fit *f)
{
	free(f->S);
	free(f->E);
	free(f->M);
	free(f->sd);
	memset(f, 0, sizeof *f);
}

/* The expert's action a plus N(0, noise^2 I), drawn again while faster
 * than sim.max_speed. Both normals are drawn whatever the noise, so the
 * stream, and with it every later state, does not depend on it. */
static int noisy(const pr_config *cfg, double noise, gsl_rng *rng, const double *a, double *out,
                 char *err)
{
	char at[PR_WHERE_LEN];
	int t;

	for (t = 0; t < MAX_NOISE_DRAWS; ++t) {
		out[0] = a[0] + noise * gsl_ran_gaussian(rng, 1.0);
		out[1] = a[1] + noise * gsl_ran_gaussian(rng, 1.0);
		if (hypot(out[0], out[1]) <= cfg->sim.max_speed)
			return PR_OK;
	}
	return pr_err(err, PR_EINVAL, "%s: exp4.demo_noise: %g m/s: %d noisy actions in a row "
	              "faster than sim.max_speed", pr_config_where(cfg, "exp4.demo_noise", at, sizeof at),
	              noise, MAX_NOISE_DRAWS);
}

/* Repetition k's demonstrations: start states where the expert has a shot,
 * its action with noise, and the outcome of that shot. */
static int make_demos(const pr_config *cfg, const pr_exp4_opts *e4, int k, pr_exp4_demo *d,
                      char *err)
{
	const int n = e4->n_demo, nb = cfg->table.balls;
	gsl_rng *rng = pr_exp_rng(cfg->run.seed, PR_STREAM_EXP4_DEMO, (unsigned long)k);
	pr_sim *sim = NULL;
	int i, rc = PR_OK;

	d->n = n;
	d->ds = 2 * nb;
	d->S = malloc((size_t)n * d->ds * sizeof *d->S);
	d->A = malloc(DA * (size_t)n * sizeof *d->A);
	d->E = malloc(DA * (size_t)n * sizeof *d->E);
	d->R = malloc((size_t)n * sizeof *d->R);
	d->F = malloc(2 * (size_t)n * sizeof *d->F);
	d->pocket = malloc((size_t)n * sizeof *d->pocket);
	d->hit = malloc((size_t)n * sizeof *d->hit);
	if (!rng || !d->S || !d->A || !d->E || !d->R || !d->F || !d->pocket || !d->hit)
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	else if (!(sim = pr_sim_new(&cfg->table, &cfg->sim, err)))
		rc = PR_EINVAL;
	for (i = 0; rc == PR_OK && i < n; ++i) {
		double *s = d->S + (size_t)i * d->ds, *a = d->A + DA * (size_t)i;
		pr_shot shot;
		if ((rc = pr_exp_expert_state(cfg, nb, rng, s, d->E + DA * (size_t)i, err)) ||
		    (rc = noisy(cfg, e4->demo_noise, rng, d->E + DA * (size_t)i, a, err)) ||
		    (rc = pr_sim_shoot(sim, s, nb, a, &shot, NULL, err)))
			break;
		d->R[i] = pr_sim_reward(&cfg->table, &cfg->reward, &shot);
		d->F[2 * i] = shot.final[2];
		d->F[2 * i + 1] = shot.final[3];
		d->pocket[i] = shot.pocket[1];
		d->hit[i] = shot.hit;
	}
	pr_sim_free(sim);
	gsl_rng_free(rng);
	return rc;
}

/* Policy kinds: variants that share a fitted pi_0. */
static int kind_of(int policy)
{
	switch (policy) {
	case PR_EXP3_NRVR_RS:
	case PR_EXP3_RVR_RS:
		return 0;
	case PR_EXP3_NRVR_A:
	case PR_EXP3_RVR_A:
		return 1;
	case PR_EXP3_BASELINE:
		return 2;
	default:
		return 3;
	}
}

/* The tree policies' n_min in a fit to n samples: fit_n_min_frac x n. */
static int frac_n_min(const pr_exp4_opts *e4, int n)
{
	int m = (int)lround(e4->fit_n_min_frac * n);

	return m < 1 ? 1 : m;
}

/* ... in the fit to the demonstrations, pi_0. */
static int demo_n_min(const pr_exp4_opts *e4)
{
	return frac_n_min(e4, e4->n_demo);
}

/* ... in the matched control's REPS fits: the same fraction of the window,
 * so the trees of pi_t split the state box about as finely as pi_0's (pi_0's
 * n_min itself, 5 episodes a leaf, let a run with eq. 6.8's covariance
 * draw 100 actions in a row faster than sim.max_speed). */
static int matched_n_min(const pr_config *cfg, const pr_exp4_opts *e4)
{
	return frac_n_min(e4, pr_exp3_opts_of(cfg)->window);
}

/* pi_0: the policy fitted to the demonstrations d (unit weights) on the
 * learning state (nx coordinates xdim of the full state). */
static pr_policy *fit_demos(const pr_config *cfg, const pr_exp3_opts *e3, const pr_exp4_opts *e4,
                            int policy, const pr_exp4_demo *d, int nx, const int *xdim, int k,
                            char *err)
{
	pr_policy_opts po = cfg->policy;
	pr_policy_data pd;
	pr_policy *p = NULL;
	double *X = malloc((size_t)d->n * nx * sizeof *X);
	gsl_rng *rng = pr_exp_rng(cfg->run.seed, PR_STREAM_EXP4_FIT + (unsigned long)kind_of(policy),
	                          (unsigned long)k);
	int i, j, flags = 0;

	if (!X || !rng) {
		pr_err(err, PR_ENOMEM, "out of memory");
		goto done;
	}
	for (i = 0; i < d->n; ++i)
		for (j = 0; j < nx; ++j)
			X[(size_t)i * nx + j] = d->S[(size_t)i * d->ds + xdim[j]];
	memset(&pd, 0, sizeof pd);
	pd.n = d->n;
	pd.ds = nx;
	pd.da = DA;
	pd.dy = 2;
	pd.S = X;
	pd.A = d->A;
	pd.Y = d->F;
	/* the distribution that drew a demonstration is centred on the expert */
	pd.M = d->E;
	po.forest.n_min = demo_n_min(e4);
	switch (policy) {
	case PR_EXP3_HANDCRAFTED:
		p = pr_policy_linear_fit(PR_FEATURES_AFFINE, &pd, po.lambda, po.min_std, po.cov_center,
		                         &flags, err);
		break;
	case PR_EXP3_BASELINE:
		/* one node, as in Experiment 3, however many demonstrations */
		po.forest.n_min = e3->baseline_n_min > d->n ? e3->baseline_n_min : d->n;
		p = pr_policy_tree_fit(&po, &pd, rng, err);
		break;
	case PR_EXP3_NRVR_RS:
	case PR_EXP3_RVR_RS:
		po.target = PR_TARGET_REWARD_STATE;
		p = pr_policy_tree_fit(&po, &pd, rng, err);
		break;
	default:
		po.target = PR_TARGET_ACTION;
		p = pr_policy_tree_fit(&po, &pd, rng, err);
		break;
	}
done:
	free(X);
	gsl_rng_free(rng);
	return p;
}

/* Standard deviations of a symmetric 2 x 2 covariance along its principal
 * axes, the larger first. */
static void principal_sd(const double *c, double *sd)
{
	double m = 0.5 * (c[0] + c[3]), r = hypot(0.5 * (c[0] - c[3]), c[1]);

	sd[0] = sqrt(m + r);
	sd[1] = sqrt(fmax(m - r, 0.0));
}

/* pi_0 against the expert on repetition k's first exp3.init_samples start
 * states (those iteration 0 of the runs that draw it starts from); states
 * where the expert has no shot are left out. */
static int eval_fit(const pr_config *cfg, const pr_exp3_opts *e3, const pr_policy *p, int nx,
                    const int *xdim, int k, pr_exp4_fit *f, char *err)
{
	const int n = e3->init_samples, nb = cfg->table.balls;
	gsl_rng *rng = pr_exp_rng(cfg->run.seed, PR_STREAM_EXP3_START, (unsigned long)k);
	pr_policy_work *ws = pr_policy_work_new(p, err);
	double *x = malloc((size_t)nx * sizeof *x), cov[DA * DA];
	char why[PR_ERRLEN];
	int i, j, rc = PR_OK;

	f->n = 0;
	f->ds = 2 * nb;
	f->S = malloc((size_t)n * f->ds * sizeof *f->S);
	f->E = malloc(DA * (size_t)n * sizeof *f->E);
	f->M = malloc(DA * (size_t)n * sizeof *f->M);
	f->sd = malloc(DA * (size_t)n * sizeof *f->sd);
	if (!rng || !ws || !x || !f->S || !f->E || !f->M || !f->sd)
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	for (i = 0; rc == PR_OK && i < n; ++i) {
		double *s = f->S + (size_t)f->n * f->ds;
		if ((rc = pr_sim_sample_start(&cfg->table, &cfg->start, nb, rng, s, err)))
			break;
		if (pr_sim_ghost_action(&cfg->table, &cfg->sim, &cfg->reward, &cfg->expert, s,
		                        f->E + DA * (size_t)f->n, NULL, why) != PR_OK)
			continue;
		for (j = 0; j < nx; ++j)
			x[j] = s[xdim[j]];
		if ((rc = pr_policy_eval(p, x, f->M + DA * (size_t)f->n, cov, NULL, ws, err)))
			break;
		principal_sd(cov, f->sd + DA * (size_t)f->n);
		f->n++;
	}
	free(x);
	pr_policy_work_free(ws);
	gsl_rng_free(rng);
	return rc;
}

/* Draw (and forget) the next n start states of `start`. */
static int skip_starts(const pr_config *cfg, gsl_rng *start, int n, char *err)
{
	double *s = malloc(2 * (size_t)cfg->table.balls * sizeof *s);
	int i, rc = s ? PR_OK : pr_err(err, PR_ENOMEM, "out of memory");

	for (i = 0; rc == PR_OK && i < n; ++i)
		rc = pr_sim_sample_start(&cfg->table, &cfg->start, cfg->table.balls, start, s, err);
	free(s);
	return rc;
}

/* ---- the jobs ---- */

/* A variant's own learning stream, fixed whatever the lists hold: variant
 * ids 0..71 for the four inits, 72..107 for refit and matched; refit_matched
 * (added later) has a range of its own, so the others keep theirs. */
static unsigned long learn_stream(const pr_exp4_variant *v)
{
	if (v->init == PR_EXP4_REFIT_MATCHED)
		return PR_STREAM_EXP4_LEARN_RM + (unsigned long)(v->policy * PR_EXP4_NCOV + v->cov);
	if (v->init < PR_EXP4_REFIT)
		return PR_STREAM_EXP4_LEARN +
		       (unsigned long)((v->policy * PR_EXP4_REFIT + v->init) * PR_EXP4_NCOV + v->cov);
	return PR_STREAM_EXP4_LEARN + (unsigned long)(PR_EXP3_NVAR * PR_EXP4_REFIT * PR_EXP4_NCOV +
	                       ((v->policy * 2 + v->init - PR_EXP4_REFIT) * PR_EXP4_NCOV + v->cov));
}

/* Read-only after setup; shared by the threads. */
typedef struct {
	const pr_config *cfg;
	const pr_exp4_opts *e4;
	pr_exp4_variant var[PR_EXP4_NVAR];
	int nvar, lo, nrep;
	int first;             /* index of var[0] among all variants */
	int writer;            /* index of the variant whose runs keep the demonstrations */
	pr_exp4_job *runs;     /* nrep x nvar, repetition-major */
	pr_exp_ticker tick;
} setup;

/* Iteration 0 of a run that starts from the demonstrations: pi_0 fitted to
 * them, then its own episodes, the demonstrations, or (imitation) its own
 * episodes and the fit rows. */
static int start_imitation(const pr_config *cfg, const pr_exp4_opts *e4, pr_exp4_job *run,
                           pr_exp3_learner *L, gsl_rng *start, char *err)
{
	const pr_exp3_opts *e3 = pr_exp3_opts_of(cfg);
	const pr_exp4_demo *d = &run->demo;
	const int *xdim;
	int nx = pr_exp3_learner_state_dims(L, &xdim), rc;
	pr_policy *p;

	if ((rc = make_demos(cfg, e4, run->repetition, &run->demo, err)))
		return rc;
	if (!(p = fit_demos(cfg, e3, e4, run->var.policy, d, nx, xdim, run->repetition, err)))
		return PR_EINVAL;
	if (run->var.init == PR_EXP4_IMITATION &&
	    (rc = eval_fit(cfg, e3, p, nx, xdim, run->repetition, &run->fit, err))) {
		pr_policy_free(p);
		return rc;
	}
	if ((rc = pr_exp3_learner_set_policy(L, p, err)))
		return rc;
	if (run->var.init != PR_EXP4_DEMO)
		return pr_exp3_learner_start(L, err);
	/* the start states iteration 0 would have drawn, so later ones match */
	if ((rc = skip_starts(cfg, start, e3->init_samples, err)))
		return rc;
	return pr_exp3_learner_seed(L, d->n, d->S, d->A, d->R, d->F, d->pocket, d->hit, NULL, err);
}

/* The controls of the policy start (exp4_priv.h): refit without REPS, or
 * REPS with the tree policies at pi_0's resolution, or refit at it. */
static int set_control(const pr_config *cfg, const pr_exp4_opts *e4, const pr_exp4_variant *v,
                       pr_exp3_learner *L, char *err)
{
	if (v->init == PR_EXP4_REFIT)
		return pr_exp3_learner_set_control(L, 1, 0, err);
	if (v->init == PR_EXP4_MATCHED || v->init == PR_EXP4_REFIT_MATCHED)
		return pr_exp3_learner_set_control(L, v->init == PR_EXP4_REFIT_MATCHED,
		                                   matched_n_min(cfg, e4), err);
	return PR_OK;
}

/* The forest n_min of variant v's last policy (0: no forest): fit_demos's
 * for pi_0, fit_policy's (exp3_learn.c) after REPS. */
static int forest_n_min(const pr_config *cfg, const pr_exp4_opts *e4, const pr_exp4_variant *v,
                        int forest)
{
	const int nb = pr_exp3_opts_of(cfg)->baseline_n_min;

	if (!forest)
		return 0;
	if (v->policy == PR_EXP3_BASELINE)
		return v->init == PR_EXP4_IMITATION && e4->n_demo > nb ? e4->n_demo : nb;
	if (v->init == PR_EXP4_IMITATION)
		return demo_n_min(e4);
	if (v->init == PR_EXP4_MATCHED || v->init == PR_EXP4_REFIT_MATCHED)
		return matched_n_min(cfg, e4);
	return cfg->policy.forest.n_min;
}

/* exp4.mean_eval: the last policy's mean action on the repetition's
 * evaluation states (the same in every variant), and its forest's size. */
static int mean_eval(const pr_config *cfg, const pr_exp4_opts *e4, pr_exp3_learner *L,
                     pr_exp4_job *run, char *err)
{
	const int n = e4->mean_eval;
	const pr_forest *f = pr_policy_forest(pr_exp3_learner_policy(L));
	gsl_rng *rng = pr_exp_rng(cfg->run.seed, PR_STREAM_EXP4_MEAN, (unsigned long)run->repetition);
	int rc = rng ? PR_OK : pr_err(err, PR_ENOMEM, "out of memory");

	if (rc == PR_OK)
		rc = pr_exp3_learner_mean_eval(L, n, rng, &run->mean_sum, &run->mean_pocket,
		                               &run->mean_hit, err);
	run->mean_n = n;
	run->leaves = f ? pr_forest_nleaves(f) : 0;
	run->n_min = forest_n_min(cfg, e4, &run->var, f != NULL);
	gsl_rng_free(rng);
	return rc;
}

/* The job behind index j: its learner from iteration 0 to the last. */
static int run_job(void *ctx, int j, char *err)
{
	setup *su = ctx;
	pr_exp4_job *run = &su->runs[j];
	const pr_exp4_variant *v = &su->var[j % su->nvar];
	const int scratch = v->init == PR_EXP4_SCRATCH;
	unsigned long seed = su->cfg->run.seed, k;
	pr_config *cfg = malloc(sizeof *cfg);
	const pr_exp3_opts *e3;
	gsl_rng *start = NULL, *init = NULL, *learn = NULL;
	pr_exp3_learner *L = NULL;
	char msg[PR_ERRLEN], label[64];
	int rc = PR_OK, t;

	run->repetition = su->lo + j / su->nvar;
	run->var = *v;
	k = (unsigned long)run->repetition;
	if (!cfg)
		return pr_err(err, PR_ENOMEM, "out of memory");
	*cfg = *su->cfg;
	if (v->cov != PR_EXP4_COV_NONE)
		cfg->policy.cov = v->cov;
	e3 = pr_exp3_opts_of(cfg);
	/* scratch: Experiment 3's own streams, so its rows are Experiment 3's */
	start = pr_exp_rng(seed, PR_STREAM_EXP3_START, k);
	init = scratch ? pr_exp_rng(seed, PR_STREAM_EXP3_INIT, k)
	               : pr_exp_rng(seed, PR_STREAM_EXP4_INIT + (unsigned long)(kind_of(v->policy) *
	                            PR_EXP4_NCOV + v->cov), k);
	learn = scratch ? pr_exp_rng(seed, PR_STREAM_EXP3_LEARN + (unsigned long)v->policy, k)
	                : pr_exp_rng(seed, learn_stream(v), k);
	if (!start || !init || !learn)
		rc = pr_err(msg, PR_ENOMEM, "out of memory");
	if (rc == PR_OK)
		rc = pr_exp3_learner_new(cfg, e3, v->policy, start, init, learn, &L, msg);
	if (rc == PR_OK)
		rc = scratch ? pr_exp3_learner_start(L, msg)
		             : start_imitation(cfg, su->e4, run, L, start, msg);
	if (rc == PR_OK)
		rc = set_control(cfg, su->e4, v, L, msg);
	/* one run per repetition keeps its demonstrations for exp4_demo.csv */
	if (rc == PR_OK && su->first + j % su->nvar != su->writer)
		pr_exp4_demo_free(&run->demo);
	if (rc == PR_OK)
		pr_exp_ticker_add(&su->tick, pr_exp3_learner_episodes(L)->n);
	for (t = 1; rc == PR_OK && t <= e3->iterations; ++t) {
		if (pr_interrupted) {
			rc = pr_err(msg, PR_EINTR, "interrupted");
			break;
		}
		rc = v->init == PR_EXP4_IMITATION ? pr_exp3_learner_repeat(L, msg)
		                                  : pr_exp3_learner_iterate(L, msg);
		if (rc == PR_OK)
			pr_exp_ticker_add(&su->tick, e3->samples);
	}
	if (rc == PR_OK && su->e4->mean_eval > 0)
		rc = mean_eval(cfg, su->e4, L, run, msg);
	if (L)
		pr_exp3_learner_take(L, &run->ep);
	pr_exp3_learner_free(L);
	gsl_rng_free(start);
	gsl_rng_free(init);
	gsl_rng_free(learn);
	free(cfg);
	if (rc) {
		pr_exp4_variant_label(v, label, sizeof label);
		return pr_err(err, rc, "exp4: repetition %d, %s: %s", run->repetition, label, msg);
	}
	return PR_OK;
}

/* 1 if key got its value from the configuration file or --set. */
static int key_given(const pr_config *cfg, const char *key)
{
	char at[PR_WHERE_LEN];
	const char *c;

	pr_config_where(cfg, key, at, sizeof at);
	c = strrchr(at, ':');
	return strcmp(at, "--set") == 0 || (c && c[1] && strspn(c + 1, "0123456789") == strlen(c + 1));
}

/* A control run with a key none of the runs reads: the REPS keys when
 * only refit runs (at either resolution, and imitation), policy.n_min
 * when only the matched resolution (and imitation) runs. */
static int check_controls(const pr_config *cfg, char *err)
{
	static const char *const reps_keys[] = {
		"reps.epsilon", "reps.ridge", "reps.eta_min", "reps.max_iter", "reps.allow_failed"
	};
	const pr_exp4_opts *e4 = pr_exp4_opts_of(cfg);
	int init[PR_EXP4_NINIT], ni = pr_exp4_name_indices(e4->inits, pr_exp4_init_name, PR_EXP4_NINIT, init);
	int has[PR_EXP4_NINIT] = {0}, j, reps, nmin;
	char at[PR_WHERE_LEN];

	for (j = 0; j < ni; ++j)
		has[init[j]] = 1;
	reps = has[PR_EXP4_SCRATCH] || has[PR_EXP4_DEMO] || has[PR_EXP4_POLICY] || has[PR_EXP4_MATCHED];
	nmin = has[PR_EXP4_SCRATCH] || has[PR_EXP4_DEMO] || has[PR_EXP4_POLICY] || has[PR_EXP4_REFIT];
	for (j = 0; (has[PR_EXP4_REFIT] || has[PR_EXP4_REFIT_MATCHED]) && !reps &&
	            j < (int)(sizeof reps_keys / sizeof *reps_keys); ++j)
		if (key_given(cfg, reps_keys[j]))
			return pr_err(err, PR_EINVAL, "%s: %s: exp4.inits = %s runs no REPS; the key has no "
			              "effect on refit runs", pr_config_where(cfg, reps_keys[j], at, sizeof at),
			              reps_keys[j], e4->inits);
	if ((has[PR_EXP4_MATCHED] || has[PR_EXP4_REFIT_MATCHED]) && !nmin && key_given(cfg, "policy.n_min"))
		return pr_err(err, PR_EINVAL, "%s: policy.n_min: exp4.inits = %s: matched runs refit at "
		              "exp4.fit_n_min_frac x exp3.window, so the key has no effect",
		              pr_config_where(cfg, "policy.n_min", at, sizeof at), e4->inits);
	return PR_OK;
}

/* What the learner cannot check itself: a fitted pi_0 for every policy;
 * controls with keys they do not read. */
static int check(const pr_config *cfg, char *err)
{
	const pr_exp3_opts *e3 = pr_exp3_opts_of(cfg);
	char at[PR_WHERE_LEN];
	int rc = pr_exp3_learner_check(cfg, e3, err);

	if (rc == PR_OK)
		rc = check_controls(cfg, err);
	if (rc == PR_OK && e3->handcrafted_method == PR_METHOD_CCMAES &&
	    strstr(e3->policies, pr_exp3_variant_name[PR_EXP3_HANDCRAFTED]))
		rc = pr_err(err, PR_EINVAL, "%s: exp3.handcrafted_method: exp4 starts the hand-crafted "
		            "policy from a fit, which C-CMA-ES cannot; use creps",
		            pr_config_where(cfg, "exp3.handcrafted_method", at, sizeof at));
	return rc;
}

static void jobs_free(pr_exp4_job *runs, int n)
{
	int j;

	for (j = 0; runs && j < n; ++j) {
		pr_exp3_episodes_free(&runs[j].ep);
		pr_exp4_demo_free(&runs[j].demo);
		pr_exp4_fit_free(&runs[j].fit);
	}
	free(runs);
}

/* The variants of this process (su->var, su->first) and the one whose runs
 * write the demonstrations: the first that makes them (-1: none does). */
static int pick_variants(const pr_config *cfg, setup *su, char *err)
{
	pr_exp4_variant all[PR_EXP4_NVAR];
	int n, v, rc = pr_exp4_list(cfg, 0, all, &n, err);

	if (rc == PR_OK)
		rc = pr_exp4_list(cfg, 1, su->var, &su->nvar, err);
	su->first = cfg->run.variant >= 0 ? cfg->run.variant : 0;
	for (v = 0, su->writer = -1; v < n && su->writer < 0; ++v)
		if (all[v].init != PR_EXP4_SCRATCH)
			su->writer = v;
	return rc;
}

int pr_exp4_run(const pr_config *cfg, const char *dir, const pr_progress *prog, char *err)
{
	const pr_exp3_opts *e3 = pr_exp3_opts_of(cfg);
	setup su;
	long neps = 0;
	int hi, v, njobs = 0, rc;

	memset(&su, 0, sizeof su);
	su.cfg = cfg;
	su.e4 = pr_exp4_opts_of(cfg);
	pr_exp_reps(cfg, &su.lo, &hi);
	su.nrep = hi - su.lo;
	rc = check(cfg, err);
	if (rc == PR_OK)
		rc = pick_variants(cfg, &su, err);
	if (rc == PR_OK) {
		njobs = su.nrep * su.nvar;
		if (!(su.runs = calloc((size_t)njobs, sizeof *su.runs)))
			rc = pr_err(err, PR_ENOMEM, "out of memory");
	}
	if (rc == PR_OK) {
		for (v = 0; v < su.nvar; ++v)
			neps += (su.var[v].init == PR_EXP4_DEMO ? su.e4->n_demo : e3->init_samples) +
			        (long)e3->iterations * e3->samples;
		pr_exp_ticker_init(&su.tick, prog, neps * su.nrep, "exp4 episodes");
		rc = pr_exp_parallel(0, njobs, cfg->run.threads, run_job, &su, err);
		pr_exp_ticker_destroy(&su.tick);
	}
	if (rc == PR_OK)
		rc = pr_exp4_write_raw(cfg, su.runs, njobs, dir, err);
	jobs_free(su.runs, njobs);
	return rc;
}
