/* exp2.c — Experiment 2 (thesis 7.4): how well tree-based policies represent
 * the ghost-ball expert (pr_sim_ghost_action).
 *
 * Repetition k draws, from streams of (seed, k) alone:
 *   - max(exp2.sizes) training states with the expert's action, the final
 *     reward-ball position and the return; a training set of size n is the
 *     first n of them (nested sets: sizes differ only in the data added);
 *   - exp2.test test states, shared by every size and policy of repetition k.
 * States where the expert has no shot (cut of 90 degrees or more, or a speed
 * above sim.max_speed) are redrawn: the expert's data covers only states it
 * can play. With the default start boxes that never happens.
 *
 * Policies (tree-LWR of thesis ch. 6, uniform weights: expert data), with the
 * policy.* keys except n_min and target:
 *   single  n_min = n: one node per tree, the global linear-Gaussian policy
 *   s_a     forest on states -> actions, n_min = round(exp2.n_min_frac * n)
 *   s_rs    forest on states -> final reward-ball positions, same n_min
 * Each is evaluated on every test state with its mean action (mode mean) and
 * one action drawn from pi(a|s) (mode sample). A drawn action faster than
 * sim.max_speed is scaled down to it. The input is the full state
 * (x0,y0,x1,y1); the cue ball's constant coordinates are never cut.
 *
 * Raw exp2_returns.csv (first column repetition):
 *   repetition,size,policy,mode,mean_return,std_return,n,pocketed,policy_flags
 * with std the sample standard deviation over the n test shots, pocketed
 * the fraction of them that put the reward ball into a target pocket and
 * policy_flags the PR_POLICY_* fallbacks of the policy's queries, or-ed
 * (0 for the expert). Each
 * repetition starts with the expert's own row (size 0, policy expert, mode
 * mean) on the same test states.
 * Derived exp2_summary.csv (summarize, from the raw file alone):
 *   size,policy,mode,mean_return,two_se,two_se_shots,repetitions,shots,pocketed,
 *   policy_flags (or-ed over repetitions)
 * mean_return is the mean over repetitions; two_se = 2 sd/sqrt(R) over the R
 * repetition means (0 when R = 1); two_se_shots = 2 sqrt(var/N) over all N
 * test shots pooled (the thesis's error bar if each repetition is one run).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "poolreps/csvio.h"
#include "poolreps/policy.h"
#include "poolreps/sim.h"
#include "exp_priv.h"
#include "streams.h"

#define DS 4 /* state: cue ball and reward ball */
#define DA 2

enum { POL_SINGLE, POL_SA, POL_SRS, NPOL };
static const char *const pol_name[NPOL] = {"single", "s_a", "s_rs"};
enum { MODE_MEAN, MODE_SAMPLE, NMODES };
static const char *const mode_name[NMODES] = {"mean", "sample"};

void pr_exp2_opts_init(pr_exp2_opts *o)
{
	static const double sizes[] = {10, 20, 50, 100, 200, 500, 1000};

	memset(o, 0, sizeof *o);
	o->sizes.n = (int)(sizeof sizes / sizeof sizes[0]);
	memcpy(o->sizes.v, sizes, sizeof sizes);
	o->test = 1000;
	o->n_min_frac = 0.1;
}

static void init_keys(void *o)
{
	pr_exp2_opts_init(o);
}

#define F(field) offsetof(pr_exp2_opts, field)
static const pr_config_key key_table[] = {
	{"exp2", "sizes", PR_KEY_ILIST, F(sizes), 2, 10000000, 0, "", "training-set sizes"},
	{"exp2", "test", PR_KEY_INT, F(test), 1, 10000000, 0, "", "test shots per size and policy"},
	{"exp2", "n_min_frac", PR_KEY_DOUBLE, F(n_min_frac), 0, 1, PR_KEY_OPEN_LO, "", "tree policies: n_min = frac * size"},
};
#undef F

const pr_config_block pr_exp2_keys = {
	key_table, (int)(sizeof key_table / sizeof key_table[0]), sizeof(pr_exp2_opts), init_keys, NULL
};

/* What data/exp2.ini states: the policy forests of thesis 7.4. */
const pr_config_default pr_exp2_defaults[] = {
	{"policy.trees", "30"},
	{"policy.cuts", "10"},
	{NULL, NULL}
};

static const pr_exp2_opts *opts_of(const pr_config *cfg)
{
	return pr_config_opts(cfg, &pr_exp2_keys);
}

/* Returns over the test states of one policy and mode. */
typedef struct {
	double mean, std, pocketed;
	int n;
	int flags;            /* PR_POLICY_* fallbacks of the queries, or-ed */
} stats;

typedef struct {
	const pr_config *cfg;
	int sizes[PR_LIST_MAX];
	int nsizes, nmax, lo;
	stats *res;           /* (hi - lo) x (1 + nsizes * NPOL * NMODES); [0] is the expert */
	pr_exp_ticker tick;
} job_ctx;

static int nres(const job_ctx *c)
{
	return 1 + c->nsizes * NPOL * NMODES;
}

/* Per-repetition workspace. */
typedef struct {
	pr_sim *sim;
	double *S, *A, *Y;    /* nmax training states, actions, final reward-ball positions */
	double *T;            /* test states */
	double *ret;          /* test returns of one policy and mode */
	int *pocketed;
} work;

static void work_free(work *w)
{
	pr_sim_free(w->sim);
	free(w->S);
	free(w->A);
	free(w->Y);
	free(w->T);
	free(w->ret);
	free(w->pocketed);
}

static int in_target(const pr_config *cfg, const pr_shot *shot)
{
	int j;

	for (j = 0; j < cfg->reward.ntargets; ++j)
		if (shot->pocket[1] == cfg->reward.targets[j])
			return 1;
	return 0;
}

static void summarise(const double *ret, const int *pk, int n, stats *st)
{
	double sum = 0, ss = 0;
	int i, np = 0;

	for (i = 0; i < n; ++i) {
		sum += ret[i];
		np += pk[i];
	}
	st->mean = sum / n;
	for (i = 0; i < n; ++i)
		ss += (ret[i] - st->mean) * (ret[i] - st->mean);
	st->std = n > 1 ? sqrt(ss / (n - 1)) : 0.0;
	st->pocketed = (double)np / n;
	st->n = n;
	st->flags = 0;
}

/* Shoot action a from state s; the return and whether it pocketed. */
static int play(const pr_config *cfg, work *w, const double *s, double a[2], int i, char *err)
{
	pr_shot shot;
	double v = hypot(a[0], a[1]);
	int rc;

	if (v > cfg->sim.max_speed) {
		a[0] *= cfg->sim.max_speed / v;
		a[1] *= cfg->sim.max_speed / v;
	}
	if ((rc = pr_sim_shoot(w->sim, s, 2, a, &shot, NULL, err)))
		return rc;
	w->ret[i] = pr_sim_reward(&cfg->table, &cfg->reward, &shot);
	w->pocketed[i] = in_target(cfg, &shot);
	return PR_OK;
}

/* Fit one policy on the first n training samples and evaluate both modes. */
static int eval_policy(const job_ctx *c, work *w, int k, int n, int pol, stats *out, char *err)
{
	const pr_config *cfg = c->cfg;
	const int ntest = opts_of(cfg)->test;
	pr_policy_opts po = cfg->policy;
	pr_policy_data d;
	pr_policy *p;
	pr_policy_work *ws = NULL;
	gsl_rng *fit = pr_exp_rng(cfg->run.seed, PR_STREAM_EXP2_FIT + 4UL * (unsigned long)n + (unsigned long)pol,
	                          (unsigned long)k);
	gsl_rng *draw = pr_exp_rng(cfg->run.seed, PR_STREAM_EXP2_DRAW + 4UL * (unsigned long)n + (unsigned long)pol,
	                           (unsigned long)k);
	int i, m, rc = PR_OK;

	if (!fit || !draw) {
		gsl_rng_free(fit);
		gsl_rng_free(draw);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	if (pol == POL_SINGLE) {
		po.target = PR_TARGET_ACTION;
		po.forest.n_min = n;
	} else {
		po.target = pol == POL_SA ? PR_TARGET_ACTION : PR_TARGET_REWARD_STATE;
		po.forest.n_min = (int)lround(opts_of(cfg)->n_min_frac * n);
		if (po.forest.n_min < 1)
			po.forest.n_min = 1;
	}
	memset(&d, 0, sizeof d);
	d.n = n;
	d.ds = DS;
	d.da = DA;
	d.dy = 2;
	d.S = w->S;
	d.A = w->A;
	d.Y = w->Y;
	p = pr_policy_tree_fit(&po, &d, fit, err);
	if (!p || !(ws = pr_policy_work_new(p, err)))
		rc = p ? PR_ENOMEM : PR_EINVAL;
	for (m = 0; m < NMODES && rc == PR_OK; ++m) {
		int flags = 0;
		for (i = 0; i < ntest && rc == PR_OK; ++i) {
			const double *s = w->T + (size_t)DS * i;
			double a[DA];
			int f = 0;
			if (pr_interrupted)
				rc = pr_err(err, PR_EINTR, "interrupted");
			else if (m == MODE_MEAN)
				rc = pr_policy_eval(p, s, a, NULL, &f, ws, err);
			else
				rc = pr_policy_sample(p, s, 1, draw, a, &f, ws, err);
			flags |= f;
			if (rc == PR_OK)
				rc = play(cfg, w, s, a, i, err);
		}
		if (rc == PR_OK) {
			summarise(w->ret, w->pocketed, ntest, &out[m]);
			out[m].flags = flags;
		}
	}
	pr_policy_work_free(ws);
	pr_policy_free(p);
	gsl_rng_free(fit);
	gsl_rng_free(draw);
	return rc;
}

/* Repetition k: data, the expert's own row, then every size and policy. */
static int run_rep(void *arg, int k, char *err)
{
	job_ctx *c = arg;
	const pr_config *cfg = c->cfg;
	const int ntest = opts_of(cfg)->test;
	stats *res = c->res + (size_t)(k - c->lo) * nres(c);
	work w;
	gsl_rng *rng = NULL;
	int i, j, pol, rc = PR_OK;

	memset(&w, 0, sizeof w);
	w.S = malloc((size_t)c->nmax * DS * sizeof *w.S);
	w.A = malloc((size_t)c->nmax * DA * sizeof *w.A);
	w.Y = malloc((size_t)c->nmax * 2 * sizeof *w.Y);
	w.T = malloc((size_t)ntest * DS * sizeof *w.T);
	w.ret = malloc((size_t)ntest * sizeof *w.ret);
	w.pocketed = malloc((size_t)ntest * sizeof *w.pocketed);
	if (!w.S || !w.A || !w.Y || !w.T || !w.ret || !w.pocketed) {
		work_free(&w);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	if (!(w.sim = pr_sim_new(&cfg->table, &cfg->sim, err))) {
		work_free(&w);
		return PR_EINVAL;
	}
	/* training data: the expert's shots and where they left the reward ball */
	if (!(rng = pr_exp_rng(cfg->run.seed, PR_STREAM_EXP2_TRAIN, (unsigned long)k)))
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	for (i = 0; i < c->nmax && rc == PR_OK; ++i) {
		pr_shot shot;
		if (pr_interrupted)
			rc = pr_err(err, PR_EINTR, "interrupted");
		else if ((rc = pr_exp_expert_state(cfg, DS / 2, rng, w.S + DS * i, w.A + DA * i, err)) == PR_OK &&
		         (rc = pr_sim_shoot(w.sim, w.S + DS * i, 2, w.A + DA * i, &shot, NULL, err)) == PR_OK) {
			w.Y[2 * i] = shot.final[2];
			w.Y[2 * i + 1] = shot.final[3];
		}
	}
	gsl_rng_free(rng);
	/* test states, and the expert on them */
	rng = rc ? NULL : pr_exp_rng(cfg->run.seed, PR_STREAM_EXP2_TEST, (unsigned long)k);
	if (rc == PR_OK && !rng)
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	for (i = 0; i < ntest && rc == PR_OK; ++i) {
		double a[DA];
		if (pr_interrupted)
			rc = pr_err(err, PR_EINTR, "interrupted");
		else if ((rc = pr_exp_expert_state(cfg, DS / 2, rng, w.T + DS * i, a, err)) == PR_OK)
			rc = play(cfg, &w, w.T + DS * i, a, i, err);
	}
	gsl_rng_free(rng);
	if (rc == PR_OK) {
		summarise(w.ret, w.pocketed, ntest, &res[0]);
		pr_exp_ticker_add(&c->tick, 1);
	}
	for (j = 0; j < c->nsizes && rc == PR_OK; ++j)
		for (pol = 0; pol < NPOL && rc == PR_OK; ++pol) {
			rc = eval_policy(c, &w, k, c->sizes[j], pol, res + 1 + (j * NPOL + pol) * NMODES, err);
			if (rc == PR_OK)
				pr_exp_ticker_add(&c->tick, 1);
		}
	work_free(&w);
	return rc;
}

static void write_row(pr_csvw *w, int k, int size, const char *policy, const char *mode,
                      const stats *s)
{
	pr_csvw_int(w, k);
	pr_csvw_int(w, size);
	pr_csvw_str(w, policy);
	pr_csvw_str(w, mode);
	pr_csvw_num(w, s->mean);
	pr_csvw_num(w, s->std);
	pr_csvw_int(w, s->n);
	pr_csvw_num(w, s->pocketed);
	pr_csvw_int(w, s->flags);
	pr_csvw_endrow(w);
}

static int write_returns(const char *dir, const job_ctx *c, int lo, int hi, char *err)
{
	static const char *const cols[] = {"repetition", "size", "policy", "mode", "mean_return",
	                                   "std_return", "n", "pocketed", "policy_flags"};
	pr_csvw *w;
	size_t i;
	int k, j, pol, m;

	if (!(w = pr_exp_csv_open(err, "%s/exp2_returns.csv", dir)))
		return PR_EIO;
	for (i = 0; i < sizeof cols / sizeof cols[0]; ++i)
		pr_csvw_str(w, cols[i]);
	pr_csvw_endrow(w);
	for (k = lo; k < hi; ++k) {
		const stats *res = c->res + (size_t)(k - lo) * nres(c);
		write_row(w, k, 0, "expert", "mean", &res[0]);
		for (j = 0; j < c->nsizes; ++j)
			for (pol = 0; pol < NPOL; ++pol)
				for (m = 0; m < NMODES; ++m)
					write_row(w, k, c->sizes[j], pol_name[pol], mode_name[m],
					          &res[1 + (j * NPOL + pol) * NMODES + m]);
	}
	return pr_csvw_close(w, err);
}

int pr_exp2_run(const pr_config *cfg, const char *dir, const pr_progress *prog, char *err)
{
	char at[PR_WHERE_LEN];
	job_ctx *c;
	int lo, hi, j, rc;

	if (cfg->table.balls != 2)
		return pr_err(err, PR_EINVAL, "%s: table.balls: Experiment 2 uses 2 balls (got %d)",
		              pr_config_where(cfg, "table.balls", at, sizeof at), cfg->table.balls);
	if ((rc = pr_policy_opts_check(&cfg->policy, err)))
		return rc;
	c = calloc(1, sizeof *c);
	if (!c)
		return pr_err(err, PR_ENOMEM, "out of memory");
	c->cfg = cfg;
	c->nsizes = opts_of(cfg)->sizes.n;
	if ((rc = pr_exp_int_list(&opts_of(cfg)->sizes, "exp2.sizes", c->sizes, err))) {
		free(c);
		return rc;
	}
	for (j = 0; j < c->nsizes; ++j) {
		if (c->sizes[j] < 2) {
			rc = pr_err(err, PR_EINVAL, "%s: exp2.sizes: a training set needs at least 2 "
			            "samples (got %d)", pr_config_where(cfg, "exp2.sizes", at, sizeof at),
			            c->sizes[j]);
			free(c);
			return rc;
		}
		if (c->sizes[j] > c->nmax)
			c->nmax = c->sizes[j];
	}
	pr_exp_reps(cfg, &lo, &hi);
	c->lo = lo;
	c->res = calloc((size_t)(hi - lo) * (size_t)nres(c), sizeof *c->res);
	if (!c->res) {
		free(c);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	pr_exp_ticker_init(&c->tick, prog, (long)(hi - lo) * (1 + c->nsizes * NPOL), "exp2");
	rc = pr_exp_parallel(lo, hi, cfg->run.threads, run_rep, c, err);
	pr_exp_ticker_destroy(&c->tick);
	if (rc == PR_OK)
		rc = write_returns(dir, c, lo, hi, err);
	free(c->res);
	free(c);
	return rc;
}

/* ---- summary ---- */

#define MAXGROUPS (1 + PR_LIST_MAX * NPOL * NMODES)

typedef struct {
	long size;
	int policy, mode;       /* policy NPOL: the expert */
	int reps;
	long shots;
	double sum, ss;         /* of the repetition means */
	double wsum, within;    /* n-weighted sum of means; sum of (n-1) std^2 */
	double between;         /* sum of n (mean - grand mean)^2 */
	double pocketed;
	long flags;
} group;

static int lookup(const char *s, const char *const *names, int n)
{
	int i;

	for (i = 0; i < n; ++i)
		if (strcmp(s, names[i]) == 0)
			return i;
	return -1;
}

/* Pass 0: sums; pass 1: squared deviations from the pass-0 means. */
static int accumulate(const pr_exp_table *t, int pass, group *g, int *ng, char *err)
{
	static const char *const names[] = {"size", "policy", "mode", "mean_return", "std_return",
	                                    "n", "pocketed", "policy_flags"};
	int col[8], i, rc;
	long r;

	for (i = 0; i < 8; ++i)
		if ((col[i] = pr_exp_table_col(t, names[i], err)) < 0)
			return col[i];
	for (r = 0; r < pr_exp_table_nrows(t); ++r) {
		const char *ps = pr_exp_table_str(t, r, col[1]), *ms = pr_exp_table_str(t, r, col[2]);
		int pol = strcmp(ps, "expert") == 0 ? NPOL : lookup(ps, pol_name, NPOL);
		int mode = lookup(ms, mode_name, NMODES);
		long size, n, fl;
		double mean, sd, pk;
		group *x = NULL;
		if (pol < 0 || mode < 0)
			return pr_err(err, PR_EIO, "%s:%ld: unknown policy '%.40s' or mode '%.40s'",
			              pr_exp_table_path(t), pr_exp_table_line(t, r), ps, ms);
		if ((rc = pr_exp_table_int(t, r, col[0], 0, PR_KEY_COUNT_MAX, &size, err)) ||
		    (rc = pr_exp_table_num(t, r, col[3], &mean, err)) ||
		    (rc = pr_exp_table_num(t, r, col[4], &sd, err)) ||
		    (rc = pr_exp_table_int(t, r, col[5], 1, PR_KEY_COUNT_MAX, &n, err)) ||
		    (rc = pr_exp_table_num(t, r, col[6], &pk, err)) ||
		    (rc = pr_exp_table_int(t, r, col[7], 0, 1 << 20, &fl, err)))
			return rc;
		for (i = 0; i < *ng; ++i)
			if (g[i].size == size && g[i].policy == pol && g[i].mode == mode)
				x = &g[i];
		if (!x) {
			if (*ng == MAXGROUPS)
				return pr_err(err, PR_EIO, "%s: more than %d settings", pr_exp_table_path(t),
				              MAXGROUPS);
			x = &g[(*ng)++];
			memset(x, 0, sizeof *x);
			x->size = size;
			x->policy = pol;
			x->mode = mode;
		}
		if (pass == 0) {
			x->reps++;
			x->shots += n;
			x->sum += mean;
			x->wsum += (double)n * mean;
			x->within += (double)(n - 1) * sd * sd;
			x->pocketed += pk;
			x->flags |= fl;
		} else {
			double d = mean - x->sum / x->reps, e = mean - x->wsum / (double)x->shots;
			x->ss += d * d;
			x->between += (double)n * e * e;
		}
	}
	return PR_OK;
}

int pr_exp2_summarize(const pr_config *cfg, const char *dir, char *err)
{
	static const char *const cols[] = {"size", "policy", "mode", "mean_return", "two_se",
	                                   "two_se_shots", "repetitions", "shots", "pocketed",
	                                   "policy_flags"};
	char path[PR_PATHLEN];
	pr_exp_table *t = NULL;
	group *g;
	size_t c;
	int ng = 0, i, rc;
	pr_csvw *w;

	(void)cfg;
	snprintf(path, sizeof path, "%s/exp2_returns.csv", dir);
	if ((rc = pr_exp_table_read(path, &t, err)))
		return rc;
	g = malloc(MAXGROUPS * sizeof *g);
	if (!g) {
		pr_exp_table_free(t);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	rc = accumulate(t, 0, g, &ng, err);
	if (rc == PR_OK)
		rc = accumulate(t, 1, g, &ng, err);
	pr_exp_table_free(t);
	if (rc || !(w = pr_exp_csv_open(err, "%s/exp2_summary.csv", dir))) {
		free(g);
		return rc ? rc : PR_EIO;
	}
	for (c = 0; c < sizeof cols / sizeof cols[0]; ++c)
		pr_csvw_str(w, cols[c]);
	pr_csvw_endrow(w);
	for (i = 0; i < ng; ++i) {
		const group *x = &g[i];
		/* pooled variance of all shots: within plus between repetitions */
		double var = x->shots > 1 ? (x->within + x->between) / (double)(x->shots - 1) : 0.0;
		pr_csvw_int(w, x->size);
		pr_csvw_str(w, x->policy == NPOL ? "expert" : pol_name[x->policy]);
		pr_csvw_str(w, mode_name[x->mode]);
		pr_csvw_num(w, x->sum / x->reps);
		pr_csvw_num(w, x->reps > 1 ? 2 * sqrt(x->ss / (x->reps - 1) / x->reps) : 0.0);
		pr_csvw_num(w, 2 * sqrt(var / (double)x->shots));
		pr_csvw_int(w, x->reps);
		pr_csvw_int(w, x->shots);
		pr_csvw_num(w, x->pocketed / x->reps);
		pr_csvw_int(w, x->flags);
		pr_csvw_endrow(w);
	}
	free(g);
	return pr_csvw_close(w, err);
}
