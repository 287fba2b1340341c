/* exp_bench.c — REPS validation problems: the 1-D contextual quadratic and
 * the contextual sphere and Rosenbrock functions of Abdolmaleki et al.,
 * "Contextual Covariance Matrix Adaptation Evolutionary Strategies", IJCAI
 * 2017, §6.1 (see bench.h for the definitions used). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "poolreps/bench.h"
#include "poolreps/cmaes.h"
#include "poolreps/csvio.h"
#include "poolreps/learner.h"
#include "poolreps/policy.h"
#include "poolreps/reps.h"
#include "exp_priv.h"
#include "streams.h"


enum { P_QUADRATIC, P_SPHERE, P_ROSENBROCK };

/* Per-row metrics after repetition and iteration, in file order. */
enum { M_SAMPLES, M_RETURN, M_TEST_RETURN, M_TEST_ERROR, M_STD, M_ETA, M_KL, M_ESS, M_BOUND,
       M_FLAGS, M_KLGAP, M_RESREL, M_UNREACH, M_FAILED, NMET };
static const char *const met_name[NMET] = {
	"samples", "mean_return", "test_return", "test_error", "mean_std", "eta", "kl", "ess", "bound",
	"policy_flags", "kl_gap", "residual_rel", "unreachable", "failed"
};

void pr_bench_opts_init(pr_bench_opts *o)
{
	o->iterations = 200;
	o->samples = 50;
	o->dims = 20;
	o->context_dims = 2;
	o->init_std = 1.0;
	o->min_std = 1e-12;
	o->value_degree = 1;
	o->test_contexts = 100;
	o->method = PR_METHOD_CREPS;
}

int pr_bench_opts_check(const pr_bench_opts *o, char *err)
{
	if (o->iterations < 1 || o->iterations > 1000000)
		return pr_err(err, PR_EINVAL, "bench.iterations: must be in 1..1000000 (got %d)", o->iterations);
	if (o->samples < 2 || o->samples > 10000000)
		return pr_err(err, PR_EINVAL, "bench.samples: must be in 2..10000000 (got %d)", o->samples);
	if (o->dims < 1 || o->dims > 10000)
		return pr_err(err, PR_EINVAL, "bench.dims: must be in 1..10000 (got %d)", o->dims);
	if (o->context_dims < 1 || o->context_dims > 100)
		return pr_err(err, PR_EINVAL, "bench.context_dims: must be in 1..100 (got %d)",
		              o->context_dims);
	if (!(o->init_std > 0.0) || !isfinite(o->init_std))
		return pr_err(err, PR_EINVAL, "bench.init_std: must be > 0 (got %g)", o->init_std);
	if (!(o->min_std > 0.0) || !isfinite(o->min_std))
		return pr_err(err, PR_EINVAL, "bench.min_std: must be > 0 (got %g)", o->min_std);
	if (o->value_degree != 1 && o->value_degree != 2)
		return pr_err(err, PR_EINVAL, "bench.value_degree: must be 1 or 2 (got %d)", o->value_degree);
	if (o->test_contexts < 1 || o->test_contexts > 1000000)
		return pr_err(err, PR_EINVAL, "bench.test_contexts: must be in 1..1000000 (got %d)",
		              o->test_contexts);
	if (o->method != PR_METHOD_CREPS && o->method != PR_METHOD_CCMAES)
		return pr_err(err, PR_EINVAL, "bench.method: must be creps or ccmaes");
	return PR_OK;
}

static void init_keys(void *o)
{
	pr_bench_opts_init(o);
}

static int check_keys(const void *o, char *err)
{
	return pr_bench_opts_check(o, err);
}

#define F(field) offsetof(pr_bench_opts, field)
static const pr_config_key key_table[] = {
	{"bench", "iterations", PR_KEY_INT, F(iterations), 1, 1000000, 0, "", "REPS iterations (quadratic: 40)"},
	{"bench", "samples", PR_KEY_INT, F(samples), 2, 10000000, 0, "", "episodes per iteration"},
	{"bench", "dims", PR_KEY_INT, F(dims), 1, 10000, 0, "", "action (parameter) dimensions (quadratic: 1)"},
	{"bench", "context_dims", PR_KEY_INT, F(context_dims), 1, 100, 0, "",
	 "context dimensions k (quadratic, rosenbrock: 1)"},
	{"bench", "init_std", PR_KEY_DOUBLE, F(init_std), 1e-100, 1e6, 0, "", "initial policy standard deviation"},
	{"bench", "min_std", PR_KEY_DOUBLE, F(min_std), 1e-100, 1e6, 0, "", "floor on policy standard deviations"},
	{"bench", "value_degree", PR_KEY_INT, F(value_degree), 1, 2, 0, "",
	 "REPS value features: 1 = s, 2 = s and its products (quadratic: 2)"},
	{"bench", "test_contexts", PR_KEY_INT, F(test_contexts), 1, 1000000, 0, "",
	 "fixed contexts scoring the policy mean"},
	{"bench", "method", PR_KEY_ENUM, F(method), 0, 0, 0, "creps|ccmaes",
	 "contextual REPS or contextual CMA-ES"},
};
#undef F

const pr_config_block pr_bench_keys = {
	key_table, (int)(sizeof key_table / sizeof key_table[0]), sizeof(pr_bench_opts), init_keys, check_keys
};

/* Each problem's setup (what data/<name>.ini states). The policy is refitted
 * around the sampling mean (policy.cov_center = old), as C-REPS does. */
const pr_config_default pr_quadratic_defaults[] = {
	{"bench.iterations", "40"},
	{"bench.dims", "1"},
	{"bench.context_dims", "1"},
	{"bench.value_degree", "2"},
	{"policy.cov_center", "old"},
	{NULL, NULL}
};
const pr_config_default pr_sphere_defaults[] = {
	{"reps.epsilon", "1"},
	{"policy.cov_center", "old"},
	{NULL, NULL}
};
const pr_config_default pr_rosenbrock_defaults[] = {
	{"bench.context_dims", "1"},
	{"reps.epsilon", "1"},
	{"policy.cov_center", "old"},
	{NULL, NULL}
};

typedef struct {
	const pr_config *cfg;
	const pr_bench_opts *b;
	int problem, dims, k, lo;
	double *res;          /* (hi - lo) x iterations x NMET */
	pr_exp_ticker tick;
} bench_ctx;

/* Return of action x in context s; y is dims scratch. */
static double objective(const bench_ctx *c, const double *G, const double *x, const double *s,
                        double *y)
{
	double f = 0.0;
	int i, j;

	if (c->problem == P_QUADRATIC)
		return -(x[0] - s[0]) * (x[0] - s[0]);
	for (i = 0; i < c->dims; i++) {
		y[i] = x[i];
		for (j = 0; j < c->k; j++)
			y[i] += G[i * c->k + j] * s[j];
	}
	if (c->problem == P_SPHERE) {
		for (i = 0; i < c->dims; i++)
			f += y[i] * y[i];
		return -f;
	}
	for (i = 0; i + 1 < c->dims; i++)
		f += 100.0 * (y[i + 1] - y[i] * y[i]) * (y[i + 1] - y[i] * y[i]) +
		     (1.0 - y[i]) * (1.0 - y[i]);
	return -f;
}

/* The optimal action x*(s). */
static void optimum(const bench_ctx *c, const double *G, const double *s, double *x)
{
	int i, j;

	if (c->problem == P_QUADRATIC) {
		x[0] = s[0];
		return;
	}
	for (i = 0; i < c->dims; i++) {
		x[i] = c->problem == P_ROSENBROCK ? 1.0 : 0.0;
		for (j = 0; j < c->k; j++)
			x[i] -= G[i * c->k + j] * s[j];
	}
}

static void draw_context(const bench_ctx *c, gsl_rng *rng, double *s)
{
	int j;

	for (j = 0; j < c->k; j++)
		s[j] = c->problem == P_QUADRATIC ? 2.0 * gsl_rng_uniform(rng) - 1.0
		                                 : 1.0 + gsl_rng_uniform(rng);
}

/* Score the policy mean on the test contexts: mean return, RMS distance to
 * x*(s), and the root mean variance of the (state-independent) covariance. */
static int score(const bench_ctx *c, const pr_policy *p, const double *G, const double *tc,
                 pr_policy_work *ws, double *buf, double *m, int *flags, char *err)
{
	const int da = c->dims;
	double *mean = buf, *cov = mean + da, *xs = cov + (size_t)da * da, *y = xs + da;
	double ret = 0.0, e2 = 0.0, tr = 0.0;
	int t, j, rc, f;

	for (t = 0; t < c->b->test_contexts; t++) {
		const double *s = tc + (size_t)t * c->k;

		f = 0;
		if ((rc = pr_policy_eval(p, s, mean, cov, &f, ws, err)))
			return rc;
		*flags |= f;
		ret += objective(c, G, mean, s, y);
		optimum(c, G, s, xs);
		for (j = 0; j < da; j++)
			e2 += (mean[j] - xs[j]) * (mean[j] - xs[j]);
	}
	for (j = 0; j < da; j++)
		tr += cov[j * da + j];
	m[M_TEST_RETURN] = ret / c->b->test_contexts;
	m[M_TEST_ERROR] = sqrt(e2 / c->b->test_contexts);
	m[M_STD] = sqrt(tr / da);
	return PR_OK;
}

/* One iteration's samples in a repetition (run_rep's buffers). */
typedef struct {
	int n, dv, nq;
	double *S, *X, *R, *phi;  /* contexts, actions, returns, REPS value features */
	double *B;                /* quadratic context features (ccmaes baseline), or NULL */
} batch;

/* C-REPS as the ask/tell learner: value features given (s, or s and its
 * products), no window and uniform base weights (learner.window = 0), a
 * linear-Gaussian policy refitted by weighted ML (eq. 3.10) with the floor
 * bench.min_std, drawing with its fit's decomposition (learner.draw = fit),
 * pi_0 = N(mu0, init_std^2 I). */
static pr_learner *creps_new(const bench_ctx *c, const double *mean, const double *cov,
                             gsl_rng *rng, char *err)
{
	pr_learner_opts o;
	pr_learner *L;
	pr_policy *p0;

	pr_config_learner_opts(c->cfg, &o);
	o.value = PR_LEARNER_VALUE_GIVEN;
	o.policy_type = PR_LEARNER_POLICY_LINEAR;
	o.window = 0;
	o.init_std = c->b->init_std;
	o.max_norm = 0;
	o.refit = 0;
	o.draw = PR_LEARNER_DRAW_FIT;
	o.policy.min_std = c->b->min_std;
	if (!(L = pr_learner_new(&o, c->k, c->dims, rng, err)))
		return NULL;
	if (!(p0 = pr_policy_gaussian_new(c->k, c->dims, mean, cov, err)) ||
	    pr_learner_set_policy(L, p0, err)) {
		pr_learner_free(L);
		return NULL;
	}
	return L;
}

/* One C-REPS iteration: the learner's tell, its certificate into m. */
static int update_creps(pr_learner *L, const batch *bt, double *m, int *fitflags, char *err)
{
	const pr_learner_summary *s;
	int rc = pr_learner_tell(L, bt->n, bt->S, bt->X, bt->R, bt->phi, bt->dv, err);

	if (rc)
		return rc;
	s = pr_learner_last(L);
	m[M_ETA] = s->eta;
	m[M_KL] = s->kl;
	m[M_ESS] = s->ess;
	m[M_BOUND] = s->bound;
	/* the certificate: bound 1 active, unreachable 1, failed 1 */
	m[M_KLGAP] = s->kl_gap;
	m[M_RESREL] = s->residual_rel;
	m[M_UNREACH] = s->status == PR_REPS_UNREACHABLE;
	m[M_FAILED] = s->status == PR_REPS_FAILED;
	*fitflags = s->flags;
	return PR_OK;
}

/* C-CMA-ES: one generation with the quadratic context baseline. No dual:
 * eta, kl and bound are 0, ess is the selection's mueff. */
static pr_policy *update_ccmaes(const bench_ctx *c, pr_cmaes *cm, const batch *bt, double *m,
                                int *fitflags, int *rc, char *err)
{
	pr_cmaes_batch cb = { bt->n, bt->nq, bt->S, bt->X, bt->R, bt->B };
	pr_cmaes_info info;
	pr_policy *next;
	int floored;

	if ((*rc = pr_cmaes_update(cm, &cb, &info, err)))
		return NULL;
	m[M_ETA] = m[M_KL] = m[M_BOUND] = m[M_KLGAP] = m[M_RESREL] = m[M_UNREACH] = m[M_FAILED] = 0.0;
	m[M_ESS] = info.mueff;
	next = pr_cmaes_policy(cm, c->b->min_std, &floored, err);
	*fitflags = info.flags | (floored ? PR_POLICY_FLOOR : 0);
	*rc = next ? PR_OK : PR_ENOMEM;
	return next;
}

/* One iteration's n episodes into bt, drawn from pol (C-CMA-ES) or asked
 * of L (C-REPS); their mean return into m, the policies' flags into *flags. */
static int sample_batch(const bench_ctx *c, gsl_rng *rng, pr_policy *pol, pr_learner *L,
                        pr_policy_work *ws, const double *G, batch *bt, double *psi, double *buf,
                        double *m, int *flags, char *err)
{
	const int k = c->k, da = c->dims;
	int i, j, rc;

	m[M_RETURN] = 0.0;
	*flags = 0;
	for (i = 0; i < bt->n; i++) {
		double *s = bt->S + (size_t)i * k, *x = bt->X + (size_t)i * da;
		int f = 0;

		draw_context(c, rng, s);
		/* one context at a time: the stream's draws stay in the order
		 * context, action, context, ... */
		if (pol)
			rc = pr_policy_sample(pol, s, 1, rng, x, &f, ws, err);
		else if ((rc = pr_learner_ask(L, 1, s, x, err)) == PR_OK)
			pr_learner_ask_info(L, NULL, &f);
		if (rc)
			return rc;
		*flags |= f;
		bt->R[i] = objective(c, G, x, s, buf);
		m[M_RETURN] += bt->R[i] / bt->n;
		/* value features: s, or s and s_j s_k (eq. 3.4 with hand-made phi) */
		pr_policy_features_quadratic(s, k, psi);
		for (j = 0; j < bt->dv; j++)
			bt->phi[(size_t)i * bt->dv + j] = psi[1 + j];
		if (bt->B)
			memcpy(bt->B + (size_t)i * bt->nq, psi, (size_t)bt->nq * sizeof *psi);
	}
	return PR_OK;
}

static int run_rep(void *ctx, int rep, char *err)
{
	bench_ctx *c = ctx;
	const pr_bench_opts *b = c->b;
	const int n = b->samples, k = c->k, da = c->dims;
	const int cmaes = b->method == PR_METHOD_CCMAES;
	gsl_rng *rng = pr_exp_rng(c->cfg->run.seed, PR_STREAM_BENCH, (unsigned long)rep);
	pr_policy *pol = NULL, *next;
	pr_policy_work *ws = NULL;
	pr_cmaes *cm = NULL;
	pr_learner *L = NULL;
	batch bt = { n, b->value_degree == 1 ? k : k + k * (k + 1) / 2, 1 + k + k * (k + 1) / 2,
	             NULL, NULL, NULL, NULL, NULL };
	double *G = NULL, *tc = NULL, *psi = NULL, *buf = NULL;
	int it, i, j, flags, fitflags = 0, rc = PR_OK;

	G = malloc((size_t)da * k * sizeof *G);
	tc = malloc((size_t)b->test_contexts * k * sizeof *tc);
	bt.S = malloc((size_t)n * k * sizeof *bt.S);
	bt.X = malloc((size_t)n * da * sizeof *bt.X);
	bt.R = malloc((size_t)n * sizeof *bt.R);
	bt.phi = malloc((size_t)n * bt.dv * sizeof *bt.phi);
	bt.B = cmaes ? malloc((size_t)n * bt.nq * sizeof *bt.B) : NULL;
	psi = malloc((size_t)bt.nq * sizeof *psi);
	buf = malloc(((size_t)da * da + 4 * (size_t)da) * sizeof *buf);
	if (!rng || !G || !tc || !bt.S || !bt.X || !bt.R || !bt.phi || (cmaes && !bt.B) || !psi ||
	    !buf) {
		rc = pr_err(err, PR_ENOMEM, "bench: out of memory");
		goto done;
	}
	/* problem and initial policy (as in the IJCAI 2017 setup: G and the
	 * initial mean have N(0, 1) entries, initial covariance init_std^2 I) */
	for (i = 0; i < da * k; i++)
		G[i] = c->problem == P_QUADRATIC ? 0.0 : gsl_ran_gaussian(rng, 1.0);
	for (i = 0; i < da; i++)
		buf[i] = c->problem == P_QUADRATIC ? 0.0 : gsl_ran_gaussian(rng, 1.0);
	for (i = 0; i < da * da; i++)
		buf[da + i] = i % (da + 1) == 0 ? b->init_std * b->init_std : 0.0;
	for (i = 0; i < b->test_contexts; i++)
		draw_context(c, rng, tc + (size_t)i * k);
	if (cmaes) {
		/* mean W [1, s] with W = [mu0, 0]: the same initial distribution */
		double *W0 = buf + da + (size_t)da * da;

		for (i = 0; i < da; i++)
			for (j = 0; j <= k; j++)
				W0[i * (k + 1) + j] = j == 0 ? buf[i] : 0.0;
		if (!(cm = pr_cmaes_new(PR_FEATURES_AFFINE, k, da, W0, b->init_std, c->cfg->policy.lambda,
		                        err)) || !(pol = pr_cmaes_policy(cm, b->min_std, NULL, err))) {
			rc = PR_ENOMEM;
			goto done;
		}
	} else if (!(L = creps_new(c, buf, buf + da, rng, err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	/* one work buffer serves every policy of these dimensions */
	if (!(ws = pr_policy_work_new(cmaes ? pol : pr_learner_policy(L), err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	for (it = 0; it < b->iterations; it++) {
		double *m = c->res + ((size_t)(rep - c->lo) * b->iterations + it) * NMET;

		if (pr_interrupted) {
			rc = pr_err(err, PR_EINTR, "bench: interrupted");
			goto done;
		}
		if ((rc = sample_batch(c, rng, cmaes ? pol : NULL, L, ws, G, &bt, psi, buf, m, &flags,
		                       err)))
			goto done;
		m[M_SAMPLES] = (double)(it + 1) * n;
		if ((rc = score(c, cmaes ? pol : pr_learner_policy(L), G, tc, ws, buf, m, &flags, err)))
			goto done;
		if (!cmaes) {
			rc = update_creps(L, &bt, m, &fitflags, err);
			m[M_FLAGS] = flags | fitflags;
			if (rc)
				goto done;
			pr_exp_ticker_add(&c->tick, 1);
			continue;
		}
		next = update_ccmaes(c, cm, &bt, m, &fitflags, &rc, err);
		/* the policy that drew this iteration's samples, and the fit it led to */
		m[M_FLAGS] = flags | fitflags;
		if (!next)
			goto done;
		pr_policy_free(pol);
		pol = next;
		pr_exp_ticker_add(&c->tick, 1);
	}
done:
	pr_cmaes_free(cm);
	pr_learner_free(L);
	pr_policy_work_free(ws);
	pr_policy_free(pol);
	if (rng)
		gsl_rng_free(rng);
	free(G);
	free(tc);
	free(bt.S);
	free(bt.X);
	free(bt.R);
	free(bt.phi);
	free(bt.B);
	free(psi);
	free(buf);
	return rc;
}

static int write_curve(const char *dir, const bench_ctx *c, int lo, int hi, char *err)
{
	pr_csvw *w;
	int rep, it, j, rc = 0;

	if (!(w = pr_exp_csv_open(err, "%s/bench_curve.csv", dir)))
		return PR_EIO;
	rc = pr_csvw_str(w, "repetition");
	if (!rc)
		rc = pr_csvw_str(w, "iteration");
	for (j = 0; j < NMET && !rc; j++)
		rc = pr_csvw_str(w, met_name[j]);
	if (!rc)
		rc = pr_csvw_endrow(w);
	for (rep = lo; rep < hi && !rc; rep++)
		for (it = 0; it < c->b->iterations && !rc; it++) {
			const double *m = c->res + ((size_t)(rep - lo) * c->b->iterations + it) * NMET;

			rc = pr_csvw_int(w, rep);
			if (!rc)
				rc = pr_csvw_int(w, it);
			for (j = 0; j < NMET && !rc; j++)
				rc = j == M_SAMPLES || j == M_BOUND || j == M_FLAGS || j == M_UNREACH || j == M_FAILED ?
				     pr_csvw_int(w, (long)m[j]) : pr_csvw_num(w, m[j]);
			if (!rc)
				rc = pr_csvw_endrow(w);
		}
	return pr_csvw_finish(w, rc, err);
}

int pr_bench_run(const pr_config *cfg, const pr_bench_opts *b, const char *dir,
                 const pr_progress *prog, char *err)
{
	bench_ctx c;
	int lo, hi, rc;

	if ((rc = pr_bench_opts_check(b, err)))
		return rc;
	memset(&c, 0, sizeof c);
	c.cfg = cfg;
	c.b = b;
	if (strcmp(cfg->run.name, "quadratic") == 0) {
		c.problem = P_QUADRATIC;
		c.dims = 1;
		c.k = 1;
	} else if (strcmp(cfg->run.name, "sphere") == 0 || strcmp(cfg->run.name, "rosenbrock") == 0) {
		c.problem = cfg->run.name[0] == 's' ? P_SPHERE : P_ROSENBROCK;
		c.dims = b->dims;
		c.k = b->context_dims;
		if (c.problem == P_ROSENBROCK && c.dims < 2)
			return pr_err(err, PR_EINVAL, "bench.dims: rosenbrock needs >= 2 (got %d)", c.dims);
	} else {
		return pr_err(err, PR_EINVAL, "experiment.name: '%s' is not a benchmark "
		              "(quadratic, sphere, rosenbrock)", cfg->run.name);
	}
	pr_exp_reps(cfg, &lo, &hi);
	c.lo = lo;
	c.res = calloc((size_t)(hi - lo) * b->iterations * NMET, sizeof *c.res);
	if (!c.res)
		return pr_err(err, PR_ENOMEM, "bench: out of memory");
	pr_exp_ticker_init(&c.tick, prog, (long)(hi - lo) * b->iterations, cfg->run.name);
	rc = pr_exp_parallel(lo, hi, cfg->run.threads, run_rep, &c, err);
	pr_exp_ticker_destroy(&c.tick);
	if (rc == PR_OK)
		rc = write_curve(dir, &c, lo, hi, err);
	free(c.res);
	return rc;
}

int pr_exp_benchmark_run(const pr_config *cfg, const char *dir, const pr_progress *prog,
                         char *err)
{
	return pr_bench_run(cfg, pr_config_opts(cfg, &pr_bench_keys), dir, prog, err);
}

/* Mean and standard deviation over repetitions, per iteration, of the
 * returns, test error and bound activity, from bench_curve.csv alone. */
int pr_exp_benchmark_summarize(const pr_config *cfg, const char *dir, char *err)
{
	enum { S_RET, S_TRET, S_TERR, S_BOUND, S_UNREACH, S_FAILED, NS };
	static const int src[NS] = { M_RETURN, M_TEST_RETURN, M_TEST_ERROR, M_BOUND, M_UNREACH,
	                             M_FAILED };
	char path[PR_PATHLEN];
	pr_csv *t = NULL;
	pr_csvw *w = NULL;
	double *sum = NULL, *ss = NULL, *samples = NULL;
	long *cnt = NULL, i, nrow, niter = 0;
	int col[2 + NMET], j, rc, pass;

	(void)cfg;
	snprintf(path, sizeof path, "%s/bench_curve.csv", dir);
	if ((rc = pr_csv_read(path, &t, err)))
		return rc;
	for (j = 0; j < 2 + NMET; j++) {
		const char *name = j == 0 ? "repetition" : j == 1 ? "iteration" : met_name[j - 2];

		if ((col[j] = pr_csv_find(t, name)) < 0) {
			rc = pr_err(err, PR_EIO, "%s:1: missing column '%s'", path, name);
			goto done;
		}
	}
	nrow = pr_csv_nrows(t);
	for (i = 0; i < nrow; i++) {
		double v = pr_csv_get(t, i, col[1]);

		if (v < 0 || v > 1e7 || v != floor(v)) {
			rc = pr_err(err, PR_EIO, "%s:%ld: bad iteration %g", path, pr_csv_line(t, i), v);
			goto done;
		}
		if ((long)v + 1 > niter)
			niter = (long)v + 1;
	}
	sum = calloc((size_t)(niter > 0 ? niter : 1) * NS, sizeof *sum);
	ss = calloc((size_t)(niter > 0 ? niter : 1) * NS, sizeof *ss);
	samples = calloc((size_t)(niter > 0 ? niter : 1), sizeof *samples);
	cnt = calloc((size_t)(niter > 0 ? niter : 1), sizeof *cnt);
	if (!sum || !ss || !samples || !cnt) {
		rc = pr_err(err, PR_ENOMEM, "bench: out of memory");
		goto done;
	}
	/* pass 0: sums; pass 1: squared deviations from the means */
	for (pass = 0; pass < 2; pass++)
		for (i = 0; i < nrow; i++) {
			long it = (long)pr_csv_get(t, i, col[1]);

			if (pass == 0) {
				cnt[it]++;
				samples[it] = pr_csv_get(t, i, col[2 + M_SAMPLES]);
			}
			for (j = 0; j < NS; j++) {
				double v = pr_csv_get(t, i, col[2 + src[j]]);

				if (pass == 0)
					sum[it * NS + j] += v;
				else
					ss[it * NS + j] += (v - sum[it * NS + j] / cnt[it]) *
					                   (v - sum[it * NS + j] / cnt[it]);
			}
		}
	if (!(w = pr_exp_csv_open(err, "%s/bench_summary.csv", dir))) {
		rc = PR_EIO;
		goto done;
	}
	{
		static const char *const head[] = {
			"iteration", "samples", "repetitions", "mean_return_mean", "mean_return_std",
			"test_return_mean", "test_return_std", "test_error_mean", "test_error_std",
			"bound_frac", "unreachable_frac", "failed_frac"
		};
		for (j = 0; j < 12 && !rc; j++)
			rc = pr_csvw_str(w, head[j]);
		if (!rc)
			rc = pr_csvw_endrow(w);
	}
	for (i = 0; i < niter && !rc; i++) {
		if (!cnt[i])
			continue;
		rc = pr_csvw_int(w, i);
		if (!rc)
			rc = pr_csvw_int(w, (long)samples[i]);
		if (!rc)
			rc = pr_csvw_int(w, cnt[i]);
		for (j = 0; j < NS && !rc; j++) {
			rc = pr_csvw_num(w, sum[i * NS + j] / cnt[i]);
			if (!rc && j < S_BOUND)
				rc = pr_csvw_num(w, cnt[i] > 1 ? sqrt(ss[i * NS + j] / (cnt[i] - 1)) : 0.0);
		}
		if (!rc)
			rc = pr_csvw_endrow(w);
	}
	rc = pr_csvw_finish(w, rc, err);
	w = NULL;
done:
	pr_csvw_abort(w);
	pr_csv_free(t);
	free(sum);
	free(ss);
	free(samples);
	free(cnt);
	return rc;
}
