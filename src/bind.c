/* bind.c — flat entry points for foreign-function interfaces (bind.h).
 *
 * Each function repeats what the matching src/cmd_*.c does between reading
 * its CSV and writing its output — same options, same generator, same calls
 * in the same order — so a binding's numbers equal the CLI's bit for bit.
 * The REPS result is exposed through one table of named fields (below), the
 * only place that follows pr_reps_result's layout.
 */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_errno.h>

#include "poolreps/bind.h"
#include "poolreps/exp.h"
#include "poolreps/shotparams.h"
#include "poolreps/sim.h"
#include "poolreps/internal.h"
#include "common_priv.h"
#include "streams.h"

/* Constructors and fits return NULL for bad input and for a failed allocation
 * alike; their messages say which. */
static int null_status(const char *err)
{
	return strstr(err, "out of memory") ? PR_ENOMEM : PR_EINVAL;
}

const char *pr_bind_init(void)
{
	gsl_set_error_handler(pr_gsl_error_handler);
	return pr_version();
}

void pr_bind_free(void *p)
{
	free(p);
}

char *pr_bind_config_ini(const pr_config *c, char *err)
{
	char *buf = NULL;
	size_t len = 0;
	FILE *fp = open_memstream(&buf, &len);
	int rc;

	if (!fp) {
		pr_err(err, PR_ENOMEM, "config: out of memory");
		return NULL;
	}
	rc = pr_config_write(c, fp);
	if (fclose(fp) || rc) {
		free(buf);
		pr_err(err, PR_ENOMEM, "config: out of memory");
		return NULL;
	}
	return buf;
}

/* A batch of pr_bind_shoot_params shared by the threads that shoot it.
 * Rows are claimed in chunks from an atomic counter, so a thread the
 * scheduler holds back (a busy machine) delays no other: the caller shoots
 * whatever is left and waits only for chunks already claimed. Helpers are
 * detached; the last thread out frees the batch, so a helper that starts
 * after the call returned finds nothing to claim and touches nothing of
 * the caller's. Each thread has its own simulator (pr_shot_params), so a
 * row's bits do not depend on which thread shot it. */
typedef struct {
	const pr_config *c;
	long lo, hi, chunk;
	int nballs, nkeys;
	const char *const *keys;
	const double *balls, *actions, *values;
	double *final, *min_gap, *reward, *t_end;
	int *pocket;
	unsigned char *hit;
	long *events;
	atomic_long next; /* the first row not claimed */
	atomic_long bad;  /* the first row that failed (hi: none) */
	pthread_mutex_t mu;
	pthread_cond_t cv;
	long done;        /* rows shot or skipped */
	int refs, rc;     /* threads holding the batch; the first bad row's status */
	char err[PR_ERRLEN];
} shoot_batch;

/* Row r failed with status rc and message why: kept if it is the first. */
static void shoot_fail(shoot_batch *b, long r, int rc, const char *why)
{
	pthread_mutex_lock(&b->mu);
	if (r < atomic_load(&b->bad)) {
		atomic_store(&b->bad, r);
		b->rc = rc;
		snprintf(b->err, sizeof b->err, "%s", why);
	}
	pthread_mutex_unlock(&b->mu);
}

static void shoot_row(shoot_batch *b, pr_shot_params *p, long r)
{
	const size_t k = (size_t)r * (size_t)b->nballs;
	char why[PR_ERRLEN], msg[PR_ERRLEN];
	pr_sim *sim;
	pr_shot res;
	int j, rc = PR_OK;

	/* a binding's worker thread is told to stop (a Ctrl-C in Python) */
	if (pr_interrupted) {
		shoot_fail(b, r, pr_err(msg, PR_EINTR, "shoot: interrupted"), msg);
		return;
	}
	sim = pr_shot_params_row(p, b->values + (size_t)r * (size_t)b->nkeys, &rc, why);
	if (!sim || (rc = pr_sim_shoot(sim, b->balls + 2 * k, b->nballs, b->actions + 2 * r, &res,
	                               NULL, why))) {
		shoot_fail(b, r, pr_err(msg, rc, "row %ld: %s", r, why), msg);
		return;
	}
	/* plain loops: for a few balls a memcpy call costs more than the copy */
	for (j = 0; j < b->nballs; ++j) {
		b->final[2 * (k + j)] = res.final[2 * j];
		b->final[2 * (k + j) + 1] = res.final[2 * j + 1];
		b->pocket[k + j] = res.pocket[j];
	}
	b->hit[r] = (unsigned char)res.hit;
	b->min_gap[r] = res.min_gap;
	b->reward[r] = pr_sim_reward(&pr_shot_params_config(p)->table,
	                             &pr_shot_params_config(p)->reward, &res);
	b->t_end[r] = res.t_end;
	b->events[r] = res.events;
}

/* Claims and shoots chunks until none is left; p is the thread's
 * simulator, made at its first chunk when NULL (c lives while a chunk is
 * claimed and not done). Rows after the first failed one are skipped. */
static void shoot_chunks(shoot_batch *b, pr_shot_params *p)
{
	pr_shot_params *own = NULL;
	char why[PR_ERRLEN];
	long r0, r;

	while ((r0 = atomic_fetch_add(&b->next, b->chunk)) < b->hi) {
		const long r1 = r0 + b->chunk < b->hi ? r0 + b->chunk : b->hi;

		if (!p && !(p = own = pr_shot_params_new(b->c, b->nkeys, b->keys, why)))
			shoot_fail(b, r0, null_status(why), why);
		for (r = r0; p && r < r1 && r < atomic_load(&b->bad); ++r)
			shoot_row(b, p, r);
		pthread_mutex_lock(&b->mu);
		if ((b->done += r1 - r0) == b->hi - b->lo)
			pthread_cond_broadcast(&b->cv);
		pthread_mutex_unlock(&b->mu);
	}
	pr_shot_params_free(own);
}

static void shoot_release(shoot_batch *b)
{
	int last;

	pthread_mutex_lock(&b->mu);
	last = --b->refs == 0;
	pthread_mutex_unlock(&b->mu);
	if (last) {
		pthread_mutex_destroy(&b->mu);
		pthread_cond_destroy(&b->cv);
		free(b);
	}
}

static void *shoot_helper(void *arg)
{
	shoot_chunks(arg, NULL);
	shoot_release(arg);
	return NULL;
}

/* Starts up to n detached helpers on b; a helper that cannot start is
 * left out (the others and the caller shoot its rows). */
static void shoot_helpers(shoot_batch *b, int n)
{
	pthread_attr_t attr;
	pthread_t tid;

	if (pthread_attr_init(&attr) != 0)
		return;
	if (pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED) == 0)
		while (n-- > 0) {
			pthread_mutex_lock(&b->mu);
			b->refs++;
			pthread_mutex_unlock(&b->mu);
			if (pthread_create(&tid, &attr, shoot_helper, b) != 0) {
				shoot_release(b);
				break;
			}
		}
	pthread_attr_destroy(&attr);
}

/* Rows per thread below which another thread costs more than it saves
 * (starting one takes tens of microseconds, a shot one to ten). */
#define SHOOT_ROWS_PER_THREAD 64

int pr_bind_shoot_params(const pr_config *c, long lo, long hi, int nballs, const double *balls,
                         const double *actions, int nkeys, const char *const *keys,
                         const double *values, double *final, int *pocket, unsigned char *hit,
                         double *min_gap, double *reward, double *t_end, long *events,
                         int threads, char *err)
{
	const long n = hi > lo ? hi - lo : 0;
	long most = n / SHOOT_ROWS_PER_THREAD;
	shoot_batch *b;
	pr_shot_params *p;
	int nt, rc;

	if (nballs > PR_SIM_MAX_BALLS || nballs < 1 + c->table.reward_balls)
		return pr_err(err, PR_EINVAL, "%d balls: need 1 + table.reward_balls (%d) to %d",
		              nballs, c->table.reward_balls, PR_SIM_MAX_BALLS);
	if (threads < 0)
		return pr_err(err, PR_EINVAL, "threads: must be >= 0 (0: one per CPU), got %d",
		              threads);
	/* the keys are checked here, before any thread starts */
	if (!(p = pr_shot_params_new(c, nkeys, keys, err)))
		return null_status(err);
	if (!(b = malloc(sizeof *b))) {
		pr_shot_params_free(p);
		return pr_err(err, PR_ENOMEM, "shoot: out of memory");
	}
	nt = threads == 0 ? pr_cpu_count() : threads > PR_MAX_THREADS ? PR_MAX_THREADS : threads;
	if (nt > most)
		nt = most > 1 ? (int)most : 1;
	memset(b, 0, sizeof *b);
	b->c = c;
	b->lo = lo;
	b->hi = lo + n;
	/* about 8 chunks a thread, of 8 to 1024 rows */
	b->chunk = n / (8 * nt) < 8 ? 8 : n / (8 * nt) > 1024 ? 1024 : n / (8 * nt);
	b->nballs = nballs;
	b->nkeys = nkeys;
	b->keys = keys;
	b->balls = balls;
	b->actions = actions;
	b->values = values;
	b->final = final;
	b->min_gap = min_gap;
	b->reward = reward;
	b->t_end = t_end;
	b->pocket = pocket;
	b->hit = hit;
	b->events = events;
	atomic_init(&b->next, lo);
	atomic_init(&b->bad, lo + n);
	pthread_mutex_init(&b->mu, NULL);
	pthread_cond_init(&b->cv, NULL);
	b->refs = 1;
	shoot_helpers(b, nt - 1);
	shoot_chunks(b, p);
	pthread_mutex_lock(&b->mu);
	while (b->done < n)
		pthread_cond_wait(&b->cv, &b->mu);
	rc = b->rc;
	if (rc)
		snprintf(err, PR_ERRLEN, "%s", b->err);
	pthread_mutex_unlock(&b->mu);
	shoot_release(b);
	pr_shot_params_free(p);
	return rc;
}

int pr_bind_shoot_range(const pr_config *c, long lo, long hi, int nballs, const double *balls,
                        const double *actions, double *final, int *pocket, unsigned char *hit,
                        double *min_gap, double *reward, double *t_end, long *events, char *err)
{
	return pr_bind_shoot_params(c, lo, hi, nballs, balls, actions, 0, NULL, NULL, final, pocket,
	                            hit, min_gap, reward, t_end, events, 1, err);
}

int pr_bind_shoot(const pr_config *c, long n, int nballs, const double *balls,
                  const double *actions, double *final, int *pocket, unsigned char *hit,
                  double *min_gap, double *reward, double *t_end, long *events, char *err)
{
	return pr_bind_shoot_range(c, 0, n, nballs, balls, actions, final, pocket, hit, min_gap,
	                           reward, t_end, events, err);
}

gsl_rng *pr_bind_rng_new(unsigned long seed)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);

	if (r)
		gsl_rng_set(r, seed);
	return r;
}

size_t pr_bind_rng_size(const gsl_rng *rng)
{
	return gsl_rng_size(rng);
}

void *pr_bind_rng_state(gsl_rng *rng)
{
	return gsl_rng_state(rng);
}

void pr_bind_rng_free(gsl_rng *rng)
{
	if (rng)
		gsl_rng_free(rng);
}

gsl_rng *pr_bind_exp3_start_rng(unsigned long seed, unsigned long repetition)
{
	return pr_exp_rng(seed, PR_STREAM_EXP3_START, repetition);
}

int pr_bind_trace(const pr_config *c, int nballs, const double *state, const double *action,
                  double **rows, long *nrows, char *err)
{
	pr_sim *sim = pr_sim_new(&c->table, &c->sim, err);
	pr_sim_trace *tr = sim ? pr_sim_trace_new(err) : NULL;
	pr_shot res;
	int rc = PR_ENOMEM;

	*rows = NULL;
	*nrows = 0;
	if (!sim || !tr) {
		rc = sim ? PR_ENOMEM : null_status(err);
	} else if ((rc = pr_sim_shoot(sim, state, nballs, action, &res, tr, err)) == PR_OK) {
		const pr_sim_trace_row *t = pr_sim_trace_rows(tr);
		const long n = pr_sim_trace_len(tr);

		if (!(*rows = malloc(((size_t)n + 1) * 4 * sizeof **rows))) {
			rc = pr_err(err, PR_ENOMEM, "trace: out of memory");
		} else {
			for (long i = 0; i < n; ++i) {
				(*rows)[4 * i] = t[i].t;
				(*rows)[4 * i + 1] = t[i].x;
				(*rows)[4 * i + 2] = t[i].y;
				(*rows)[4 * i + 3] = t[i].ball;
			}
			*nrows = n;
		}
	}
	pr_sim_trace_free(tr);
	pr_sim_free(sim);
	return rc;
}

int pr_bind_check_state(const pr_config *c, const double *state, int nballs, char *err)
{
	return pr_sim_check_state(&c->table, state, nballs, err);
}

int pr_bind_starts(const pr_config *c, gsl_rng *rng, long n, double *states, char *err)
{
	const int b = c->table.balls;
	long i;
	int rc;

	for (i = 0; i < n; ++i)
		if ((rc = pr_sim_sample_start(&c->table, &c->start, b, rng, states + 2 * (size_t)b * i, err)))
			return rc;
	return PR_OK;
}

void pr_bind_uniforms_each(gsl_rng *const *rngs, long n, int k, double *u)
{
	long i;
	int j;

	for (i = 0; i < n; ++i)
		for (j = 0; j < k; ++j)
			u[(size_t)i * (size_t)k + (size_t)j] = gsl_rng_uniform(rngs[i]);
}

int pr_bind_starts_each(const pr_config *c, gsl_rng *const *rngs, long n, double *states, char *err)
{
	const size_t w = 2 * (size_t)c->table.balls;
	long i;
	int rc;

	for (i = 0; i < n; ++i)
		if ((rc = pr_bind_starts(c, rngs[i], 1, states + w * (size_t)i, err)))
			return rc;
	return PR_OK;
}

int pr_bind_forest_fit(const pr_config *c, int n, int dx, int dy, const double *X,
                       const double *Y, const double *w, pr_forest **out, char *err)
{
	gsl_rng *rng;
	double *wc = NULL;
	int rc;

	/* as cmd_forest.c: options first, so messages name forest.<key> */
	if ((rc = pr_forest_opts_check(&c->forest, "forest", err)))
		return rc;
	if (w && !(wc = malloc((size_t)(n > 0 ? n : 1) * sizeof *wc)))
		return pr_err(err, PR_ENOMEM, "forest: out of memory");
	if (!(rng = pr_bind_rng_new(c->run.seed))) {
		free(wc);
		return pr_err(err, PR_ENOMEM, "forest: out of memory");
	}
	/* as cmd_forest.c: the weights' scale does not change a bit */
	if (wc) {
		memcpy(wc, w, (size_t)n * sizeof *wc);
		pr_forest_weights_canonical(wc, n);
	}
	*out = pr_forest_fit(&c->forest, X, n, dx, Y, dy, wc, rng, err);
	gsl_rng_free(rng);
	free(wc);
	return *out ? PR_OK : null_status(err);
}

int pr_bind_forest_apply(const pr_forest *f, long n, const double *X, int *leaves, char *err)
{
	const int M = pr_forest_ntrees(f), dx = pr_forest_dx(f);
	long i;
	int t;

	for (i = 0; i < n; ++i) {
		int *row = leaves + (size_t)i * M;
		int got = pr_forest_active(f, X + (size_t)i * dx, dx, row, M);

		if (got != M)
			return pr_err(err, got < 0 ? got : PR_ENUM, "row %ld: %d active leaves, expected %d",
			              i, got, M);
		for (t = 0; t < M; ++t)
			row[t] -= pr_forest_tree_leaf0(f, t);
	}
	return PR_OK;
}

int pr_bind_reps(const pr_config *c, int n, int d, const double *R, const double *q,
                 const double *phi, const int *rowptr, const int *col, const double *val,
                 pr_reps_result **out, char *err)
{
	const pr_reps_problem pb = { .n = n, .d = d, .R = R, .q = q, .phi = phi,
	                             .rowptr = rowptr, .col = col, .val = val };

	int rc;

	*out = NULL;
	if ((rc = pr_reps_solve(&c->reps, &pb, out, err)) != PR_OK)
		return rc;
	/* as the CLI: an uncertified answer is an error unless reps.allow_failed */
	if ((*out)->status == PR_REPS_FAILED && !c->reps.allow_failed) {
		rc = pr_err(err, PR_ENUM, "reps: no certified answer: %s", (*out)->reason);
		pr_reps_result_free(*out);
		*out = NULL;
	}
	return rc;
}

/* The scalar fields of pr_reps_result that bindings report, in the order of
 * `poolreps reps --summary` and then the rest. */
static const struct {
	const char *name;
	char kind;
	size_t off;
} reps_fields[] = {
	{"eta", 'd', offsetof(pr_reps_result, eta)},
	{"dual", 'd', offsetof(pr_reps_result, dual)},
	{"kl", 'd', offsetof(pr_reps_result, kl)},
	{"ess", 'd', offsetof(pr_reps_result, ess)},
	{"bound", 'i', offsetof(pr_reps_result, bound)},
	{"residual", 'd', offsetof(pr_reps_result, residual)},
	{"iterations", 'i', offsetof(pr_reps_result, iterations)},
	{"kl_gap", 'd', offsetof(pr_reps_result, kl_gap)},
	{"residual_rel", 'd', offsetof(pr_reps_result, residual_rel)},
	{"status", 's', offsetof(pr_reps_result, status)},
	{"rank", 'i', offsetof(pr_reps_result, rank)},
	{"cond", 'd', offsetof(pr_reps_result, cond)},
	{"path", 's', offsetof(pr_reps_result, path)},
	{"constant", 'i', offsetof(pr_reps_result, constant)},
	{"reason", 's', offsetof(pr_reps_result, reason)},
};
#define NREPS_FIELDS (sizeof reps_fields / sizeof reps_fields[0])

const char *pr_bind_reps_field(int i, char *kind)
{
	if (i < 0 || (size_t)i >= NREPS_FIELDS)
		return NULL;
	*kind = reps_fields[i].kind;
	return reps_fields[i].name;
}

double pr_bind_reps_value(const pr_reps_result *r, int i)
{
	const char *at = (const char *)r + reps_fields[i].off;

	if (reps_fields[i].off == offsetof(pr_reps_result, reason) ||
	    reps_fields[i].off == offsetof(pr_reps_result, path))
		return 0.0;
	return reps_fields[i].kind == 'd' ? *(const double *)at : (double)*(const int *)at;
}

const char *pr_bind_reps_text(const pr_reps_result *r, int i)
{
	if (i < 0 || (size_t)i >= NREPS_FIELDS || reps_fields[i].kind != 's')
		return NULL;
	if (reps_fields[i].off == offsetof(pr_reps_result, status))
		return pr_reps_status_name(r->status);
	return (const char *)r + reps_fields[i].off;
}

const double *pr_bind_reps_p(const pr_reps_result *r)
{
	return r->p;
}

const double *pr_bind_reps_theta(const pr_reps_result *r)
{
	return r->theta;
}

int pr_bind_policy_fit(const pr_config *c, int n, int ds, int da, int dy, const double *S,
                       const double *A, const double *w, const double *Y, pr_policy **out,
                       char *err)
{
	const pr_policy_data d = { .n = n, .ds = ds, .da = da, .dy = dy,
	                           .S = S, .A = A, .Y = Y, .w = w };
	gsl_rng *rng;

	if (c->policy.target == PR_TARGET_REWARD_STATE && (!Y || dy < 1))
		return pr_err(err, PR_EINVAL, "policy: policy.target = reward_state needs the "
		              "final reward-ball positions (target)");
	/* as cmd_policy.c: the forest would ignore them */
	if (c->policy.target != PR_TARGET_REWARD_STATE && Y && dy > 0)
		return pr_err(err, PR_EINVAL, "policy: target applies only with policy.target = reward_state");
	if (!(rng = pr_bind_rng_new(c->run.seed)))
		return pr_err(err, PR_ENOMEM, "policy: out of memory");
	*out = pr_policy_tree_fit(&c->policy, &d, rng, err);
	gsl_rng_free(rng);
	return *out ? PR_OK : null_status(err);
}

/* Every query state through one workspace of this call's own, so that
 * calls on one policy may run in parallel. With mean or cov NULL the row's
 * values go to scratch; with rng, k actions per state are drawn after its
 * evaluation, in the order of cmd_policy.c. */
/* A numerical failure at query row i (state s, ds values): the row and
 * the state's largest value by magnitude, then the message, as the policy
 * command names its line. */
static void name_row(const double *s, size_t ds, long i, char *err)
{
	char msg[PR_ERRLEN];
	size_t big = 0;

	for (size_t j = 1; j < ds; j++)
		if (fabs(s[j]) > fabs(s[big]))
			big = j;
	snprintf(msg, sizeof msg, "%s", err ? err : "");
	pr_err(err, PR_ENUM, "row %ld: state %zu = %.17g: %s", i, big, ds ? s[big] : 0.0, msg);
}

static int eval_rows(const pr_policy *p, long nq, const double *S, double *mean, double *cov,
                     int *status, int k, gsl_rng *rng, double *draws, char *err)
{
	const size_t ds = (size_t)pr_policy_ds(p), da = (size_t)pr_policy_da(p);
	pr_policy_work *ws = pr_policy_work_new(p, err);
	double *tmp = malloc((da + da * da) * sizeof *tmp);
	long i;
	int rc = PR_OK;

	if (!ws || !tmp) {
		pr_policy_work_free(ws);
		free(tmp);
		return pr_err(err, PR_ENOMEM, "policy: out of memory");
	}
	for (i = 0; i < nq && !rc; ++i) {
		double *mi = mean ? mean + (size_t)i * da : tmp;
		double *ci = cov ? cov + (size_t)i * da * da : tmp + da;

		rc = pr_policy_eval(p, S + (size_t)i * ds, mi, ci, status + i, ws, err);
		if (!rc && rng)
			rc = pr_policy_gauss_sample((int)da, mi, ci, k, rng, draws + (size_t)i * k * da, err);
		if (rc == PR_ENUM)
			name_row(S + (size_t)i * ds, ds, i, err);
	}
	pr_policy_work_free(ws);
	free(tmp);
	return rc;
}

int pr_bind_policy_eval(const pr_policy *p, long nq, const double *S, double *mean,
                        double *cov, int *status, char *err)
{
	return eval_rows(p, nq, S, mean, cov, status, 0, NULL, NULL, err);
}

gsl_rng *pr_bind_policy_rng_new(unsigned long seed)
{
	gsl_rng *rng = pr_bind_rng_new(seed);

	/* the command's fit took one draw to seed its forest (pr_forest_fit) */
	if (rng)
		gsl_rng_get(rng);
	return rng;
}

int pr_bind_policy_sample_rng(const pr_policy *p, long nq, const double *S, int k,
                              gsl_rng *rng, double *draws, int *status, char *err)
{
	return eval_rows(p, nq, S, NULL, NULL, status, k, rng, draws, err);
}

int pr_bind_policy_sample(const pr_policy *p, long nq, const double *S, int k,
                          unsigned long seed, double *draws, int *status, char *err)
{
	gsl_rng *rng = pr_bind_policy_rng_new(seed);
	int rc;

	if (!rng)
		return pr_err(err, PR_ENOMEM, "policy: out of memory");
	rc = pr_bind_policy_sample_rng(p, nq, S, k, rng, draws, status, err);
	gsl_rng_free(rng);
	return rc;
}

int pr_bind_policy_logpdf(const pr_policy *p, long nq, const double *S, const double *A,
                          double *logpdf, int *status, char *err)
{
	const size_t ds = (size_t)pr_policy_ds(p), da = (size_t)pr_policy_da(p);
	pr_policy_work *ws = pr_policy_work_new(p, err);
	long i;
	int rc = PR_OK;

	if (!ws)
		return PR_ENOMEM;
	for (i = 0; i < nq && !rc; ++i)
		rc = pr_policy_logpdf(p, S + (size_t)i * ds, A + (size_t)i * da, logpdf + i,
		                      status + i, ws, err);
	pr_policy_work_free(ws);
	return rc;
}

/* pi_0 = N(mean, init_std^2 I) in place of the learner's N(0, ...). */
static int learner_init_mean(pr_learner *L, const double *mean, char *err)
{
	const int dx = pr_learner_context_dim(L), da = pr_learner_action_dim(L);
	const double sd = pr_learner_options(L)->init_std;
	double *cov = calloc((size_t)da * da, sizeof *cov);
	pr_policy *p = NULL;
	int j, rc;

	if (!cov)
		return pr_err(err, PR_ENOMEM, "out of memory");
	for (j = 0; j < da; ++j)
		cov[j * da + j] = sd * sd;
	if ((p = pr_policy_gaussian_new(dx, da, mean, cov, err)))
		rc = pr_learner_set_policy(L, p, err);
	else
		rc = null_status(err);
	free(cov);
	return rc;
}

pr_learner *pr_bind_learner_new(const pr_config *c, int dx, int da, const char *const *names,
                                const double *init_mean, gsl_rng *rng, char *err)
{
	pr_learner_opts o;
	pr_learner *L;

	pr_config_learner_opts(c, &o);
	if ((L = pr_learner_new(&o, dx, da, rng, err)) &&
	    ((names && pr_learner_set_names(L, names, err)) ||
	     (init_mean && learner_init_mean(L, init_mean, err)))) {
		pr_learner_free(L);
		L = NULL;
	}
	return L;
}

int pr_bind_learner_tell(pr_learner *L, int n, const double *X, const double *A, const double *R,
                         const double *G, int d, const double *Y, int dy, char *err)
{
	const pr_learner_batch b = {n, G ? d : 0, Y ? dy : 0, X, A, R, G, Y, NULL};
	const int rc = pr_learner_check_targets(L, Y != NULL, err);

	return rc ? rc : pr_learner_tell_batch(L, &b, err);
}

const char *pr_bind_learner_summary(const pr_learner *L, double *d, int *i, const char **names)
{
	const pr_learner_summary *s = pr_learner_last(L);
	const double dv[7] = {s->eta, s->kl, s->ess, s->q_ess, s->residual, s->kl_gap, s->residual_rel};
	const int iv[7] = {s->iteration, s->n, s->bound, s->nfeat, s->evals, s->status, s->flags};

	memcpy(d, dv, sizeof dv);
	memcpy(i, iv, sizeof iv);
	if (names)
		memcpy(names, pr_learner_names(L),
		       (size_t)(pr_learner_context_dim(L) + pr_learner_action_dim(L)) * sizeof *names);
	return s->reason;
}
