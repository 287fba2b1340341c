/* exp3.c — Experiment 3 (thesis 7.5): learning to pocket a ball with REPS.
 *
 * A job is one (repetition k, variant) pair: one learner (exp3_learn.c)
 * with its own simulator, random streams, forests and policies, so jobs run
 * on any thread in any order and the output never depends on the thread
 * count. The raw CSVs and the summaries are written by exp3_out.c.
 *
 * Streams: start states and pi_0's actions depend on (seed, k) alone, so all
 * variants of a repetition share start states and initial episodes (common
 * random numbers); forests and later actions on (seed, k, variant).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "exp3_priv.h"
#include "streams.h"

/* ---- the jobs ---- */

/* Read-only after setup; shared by the threads. */
typedef struct {
	const pr_config *cfg;
	const pr_exp3_opts *e;
	int var[PR_EXP3_NVAR], nvar;
	int lo, nrep;          /* repetitions lo .. lo + nrep - 1 */
	pr_exp3_job *runs;     /* nrep x nvar, repetition-major */
	pr_exp_ticker tick;
} setup;

/* exp3.mean_eval: when the run's episodes are a multiple of
 * exp3.mean_eval_every, the latest policy's mean action from the
 * repetition's evaluation states (the same at every evaluation and in
 * every variant: those of PocketEnv.reset_batch(n, seed=mean_eval_seed + k)). */
static int mean_eval(const pr_exp3_opts *e, pr_exp3_learner *L, pr_exp3_job *run, char *err)
{
	const int n = e->mean_eval, eps = pr_exp3_learner_episodes(L)->n;
	const int cap = (e->init_samples + e->iterations * e->samples) / e->mean_eval_every + 1;
	gsl_rng *rng;
	double sum;
	int in, hits, rc;

	if (n <= 0 || eps % e->mean_eval_every != 0)
		return PR_OK;
	if (!run->mean_eps) {
		run->mean_eps = malloc((size_t)cap * sizeof *run->mean_eps);
		run->mean_ret = malloc((size_t)cap * sizeof *run->mean_ret);
		run->mean_pocket = malloc((size_t)cap * sizeof *run->mean_pocket);
	}
	rng = gsl_rng_alloc(gsl_rng_mt19937);
	rc = rng && run->mean_eps && run->mean_ret && run->mean_pocket
	         ? PR_OK : pr_err(err, PR_ENOMEM, "out of memory");
	if (rc == PR_OK) {
		gsl_rng_set(rng, (e->mean_eval_seed + (unsigned long)run->repetition) & 0xffffffffUL);
		rc = pr_exp3_learner_mean_eval(L, n, rng, &sum, &in, &hits, err);
	}
	if (rc == PR_OK) {
		run->mean_eps[run->nmean] = eps;
		run->mean_ret[run->nmean] = sum / n;
		run->mean_pocket[run->nmean++] = (double)in / n;
	}
	gsl_rng_free(rng);
	return rc;
}

/* The job behind index j (pr_exp_parallel hands out 0 .. nrep * nvar - 1):
 * iteration 0, then every REPS iteration; its episodes go into su->runs[j]. */
static int run_job(void *ctx, int j, char *err)
{
	setup *su = ctx;
	const pr_exp3_opts *e = su->e;
	pr_exp3_job *run = &su->runs[j];
	unsigned long seed = su->cfg->run.seed, k;
	gsl_rng *start, *init, *learn;
	pr_exp3_learner *L = NULL;
	char msg[PR_ERRLEN];
	int rc = PR_OK, t;

	run->repetition = su->lo + j / su->nvar;
	run->variant = su->var[j % su->nvar];
	k = (unsigned long)run->repetition;
	start = pr_exp_rng(seed, PR_STREAM_EXP3_START, k);
	init = pr_exp_rng(seed, PR_STREAM_EXP3_INIT, k);
	learn = pr_exp_rng(seed, PR_STREAM_EXP3_LEARN + (unsigned long)run->variant, k);
	if (!start || !init || !learn)
		rc = pr_err(msg, PR_ENOMEM, "out of memory");
	if (rc == PR_OK)
		rc = pr_exp3_learner_new(su->cfg, e, run->variant, start, init, learn, &L, msg);
	if (rc == PR_OK)
		rc = pr_exp3_learner_start(L, msg);
	if (rc == PR_OK)
		pr_exp_ticker_add(&su->tick, e->init_samples);
	if (rc == PR_OK)
		rc = mean_eval(e, L, run, msg);
	for (t = 1; rc == PR_OK && t <= e->iterations; ++t) {
		if (pr_interrupted) {
			rc = pr_err(msg, PR_EINTR, "interrupted");
			break;
		}
		rc = pr_exp3_learner_iterate(L, msg);
		if (rc == PR_OK)
			pr_exp_ticker_add(&su->tick, e->samples);
		if (rc == PR_OK)
			rc = mean_eval(e, L, run, msg);
	}
	if (L)
		pr_exp3_learner_take(L, &run->ep);
	pr_exp3_learner_free(L);
	gsl_rng_free(start);
	gsl_rng_free(init);
	gsl_rng_free(learn);
	if (rc)
		return pr_err(err, rc, "exp3: repetition %d, policy %s: %s", run->repetition,
		              pr_exp3_variant_name[run->variant], msg);
	return PR_OK;
}

int pr_exp3_run(const pr_config *cfg, const char *dir, const pr_progress *prog, char *err)
{
	const pr_exp3_opts *e = pr_exp3_opts_of(cfg);
	setup su;
	int hi, j, njobs = 0, rc;

	memset(&su, 0, sizeof su);
	su.cfg = cfg;
	su.e = e;
	pr_exp_reps(cfg, &su.lo, &hi);
	su.nrep = hi - su.lo;
	rc = pr_exp3_learner_check(cfg, e, err);
	if (rc == PR_OK)
		rc = pr_exp3_selected(cfg, su.var, &su.nvar, err);
	if (rc == PR_OK) {
		njobs = su.nrep * su.nvar;
		if (!(su.runs = calloc((size_t)njobs, sizeof *su.runs)))
			rc = pr_err(err, PR_ENOMEM, "out of memory");
	}
	if (rc == PR_OK) {
		long neps = e->init_samples + (long)e->iterations * e->samples;
		pr_exp_ticker_init(&su.tick, prog, (long)njobs * neps, "exp3 episodes");
		rc = pr_exp_parallel(0, njobs, cfg->run.threads, run_job, &su, err);
		pr_exp_ticker_destroy(&su.tick);
	}
	if (rc == PR_OK)
		rc = pr_exp3_write_raw(cfg, su.runs, njobs, dir, err);
	for (j = 0; su.runs && j < njobs; ++j) {
		pr_exp3_episodes_free(&su.runs[j].ep);
		free(su.runs[j].mean_eps);
		free(su.runs[j].mean_ret);
		free(su.runs[j].mean_pocket);
	}
	free(su.runs);
	return rc;
}
