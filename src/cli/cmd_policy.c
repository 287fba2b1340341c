/* cmd_policy.c — `poolreps policy`: fit the tree-LWR Gaussian
 * policy (keys policy.*) from weighted samples and query it.
 *
 * --train FILE holds the samples: --state COLS, --action COLS (comma lists
 * or prefixes ending in '*'), --weight COL (REPS weights; omitted = 1) and,
 * for policy.target = reward_state, --target COLS (the final reward-ball
 * positions the forest learns), for policy.cov_center = old, --old-mean
 * COLS (the means of the policies that drew the rows, one per action, at
 * the rows' states). -i holds the query states, with the same
 * state column names. Output, one row per query state:
 *   <state cols>, mean_<action>..., cov_<i>_<j> (i <= j, action indices
 *   0-based, upper triangle of the symmetric covariance), status
 * and with --sample N, N rows per query state:
 *   <state cols>, sample (0..N-1), <action cols> (the draw), mean_..., cov_..., status
 * so the output feeds `poolreps shoot` directly. status holds the
 * PR_POLICY_* fallback bits (1 global fit, 2 pseudo-inverse, 4 mean only,
 * 8 covariance fallback, 16 min_std floor). Every check of the training
 * samples and of the query header comes before the fit, the fit before
 * anything is written; the query states then stream (pr_query_policy).
 */
#include <stdio.h>
#include <stdlib.h>

#include <gsl/gsl_rng.h>

#include "poolreps/csvio.h"
#include "poolreps/policy.h"
#include "poolreps/query.h"
#include "poolreps/internal.h"
#include "cli.h"

/* The options of `poolreps policy` (its table: cli_policy below). */
typedef struct {
	const char *input, *output, *train, *state, *action, *weight, *target;
	const char *old_mean; /* --old-mean COLS: sampling means (policy.cov_center = old) */
	long sample;          /* --sample N, 0 = none */
	int sample_set;
} policy_args;

/* The training samples with their columns and arrays, and the query
 * states' stream. */
typedef struct {
	pr_csv *tr;
	pr_query *in;
	int *sc, *ac, *yc, *mc; /* states, actions, targets, sampling means in tr */
	int ds, da, dy;
	const char **sn, **an;  /* the state and action names, borrowed from tr */
	double *S, *A, *Y, *Mo, *wt;
} samples;

static void samples_free(samples *m)
{
	pr_csv_free(m->tr);
	pr_query_free(m->in);
	free(m->sc);
	free(m->ac);
	free(m->yc);
	free(m->mc);
	free(m->sn);
	free(m->an);
	free(m->S);
	free(m->A);
	free(m->Y);
	free(m->Mo);
	free(m->wt);
}

/* The query states' stream, its header checked: the state columns by name. */
static int open_queries(const policy_args *a, samples *m, char *err)
{
	int j;

	m->sn = malloc((size_t)m->ds * sizeof *m->sn);
	m->an = malloc((size_t)m->da * sizeof *m->an);
	if (!m->sn || !m->an)
		return pr_err(err, PR_ENOMEM, "policy: out of memory");
	for (j = 0; j < m->ds; j++)
		m->sn[j] = pr_csv_name(m->tr, m->sc[j]);
	for (j = 0; j < m->da; j++)
		m->an[j] = pr_csv_name(m->tr, m->ac[j]);
	return pr_query_open(a->input, m->sn, m->ds, "state", &m->in, err);
}

/* Read the training samples, open the query states: every check before the fit. */
static int read_samples(const policy_args *a, int reward, int old, samples *m, char *err)
{
	int wcol = -1, dm = 0, rc;

	if ((rc = pr_csv_read(a->train, &m->tr, err)))
		return rc;
	if ((m->ds = pr_cmd_columns(m->tr, a->state, &m->sc, err)) < 0)
		return m->ds;
	if ((m->da = pr_cmd_columns(m->tr, a->action, &m->ac, err)) < 0)
		return m->da;
	if (reward && (m->dy = pr_cmd_columns(m->tr, a->target, &m->yc, err)) < 0)
		return m->dy;
	if (old && (dm = pr_cmd_columns(m->tr, a->old_mean, &m->mc, err)) < 0)
		return dm;
	if (old && dm != m->da)
		return pr_err(err, PR_EINVAL, "%s: --old-mean selects %d columns, --action %d",
		              pr_csv_path(m->tr), dm, m->da);
	if (a->weight && (wcol = pr_cmd_column(m->tr, a->weight, "--weight", err)) < 0)
		return wcol;
	/* a column cannot be the state, the action and the weight at once */
	rc = pr_cmd_disjoint(m->tr, m->sc, m->ds, "a state", m->ac, m->da, "an action", err);
	if (rc == PR_OK && wcol >= 0)
		rc = pr_cmd_disjoint(m->tr, &wcol, 1, "the weight", m->sc, m->ds, "a state", err);
	if (rc == PR_OK && wcol >= 0)
		rc = pr_cmd_disjoint(m->tr, &wcol, 1, "the weight", m->ac, m->da, "an action", err);
	if (rc)
		return rc;
	if ((rc = pr_cmd_check_rows(m->tr, err)) || (rc = open_queries(a, m, err)))
		return rc;
	if (!(m->S = pr_cmd_matrix(m->tr, m->sc, m->ds, err)) ||
	    !(m->A = pr_cmd_matrix(m->tr, m->ac, m->da, err)) ||
	    (reward && !(m->Y = pr_cmd_matrix(m->tr, m->yc, m->dy, err))) ||
	    (old && !(m->Mo = pr_cmd_matrix(m->tr, m->mc, m->da, err))))
		return PR_ENOMEM;
	return pr_cmd_weights(m->tr, wcol, a->weight, "weight", &m->wt, err);
}

/* Fit the policy, then stream its answer at every query state into the
 * output (committed by the caller). */
static int fit_and_query(const pr_config *cfg, const samples *m, long ns, pr_outset *set,
                         const char *output, char *err)
{
	pr_policy_data d = { 0 };
	pr_policy *p = NULL;
	pr_csvw *w = NULL;
	gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
	int rc = PR_OK;

	if (!rng)
		return pr_err(err, PR_ENOMEM, "policy: out of memory");
	gsl_rng_set(rng, cfg->run.seed);
	d.n = (int)pr_csv_nrows(m->tr);
	d.ds = m->ds;
	d.da = m->da;
	d.dy = m->dy;
	d.S = m->S;
	d.A = m->A;
	d.Y = m->Y;
	d.w = m->wt;
	d.M = m->Mo;
	/* the options and data were checked: a failed fit is memory (main
	 * turns it into exit 4) or a numerical failure */
	if (!(p = pr_policy_tree_fit(&cfg->policy, &d, rng, err)))
		rc = PR_ENUM;
	else if (!(rc = pr_outset_add(set, output, &w, err)))
		rc = pr_query_policy(m->in, p, m->an, ns, rng, w, err);
	pr_policy_free(p);
	gsl_rng_free(rng);
	return rc;
}

static int pr_cmd_policy(const pr_config *cfg, const policy_args *a, char *err)
{
	const int reward = cfg->policy.target == PR_TARGET_REWARD_STATE;
	const int old = cfg->policy.cov_center == PR_COV_CENTER_OLD;
	samples m = { 0 };
	pr_outset *set = NULL;
	int rc;

	if (!a->train || !a->state || !a->action)
		return pr_err(err, PR_EINVAL, "policy: --train FILE, --state COLS and --action COLS are required");
	if (reward && !a->target)
		return pr_err(err, PR_EINVAL,
		              "policy: policy.target = reward_state needs --target COLS (final reward-ball positions)");
	if (!reward && a->target)
		return pr_err(err, PR_EINVAL, "policy: --target applies only with policy.target = reward_state");
	if (old && !a->old_mean)
		return pr_err(err, PR_EINVAL, "policy: policy.cov_center = old needs --old-mean COLS "
		              "(the means of the policies that drew the training rows)");
	if (!old && a->old_mean)
		return pr_err(err, PR_EINVAL, "policy: --old-mean applies only with policy.cov_center = old");
	if (!(rc = pr_policy_opts_check(&cfg->policy, err)) &&
	    !(rc = read_samples(a, reward, old, &m, err))) {
		if (!(set = pr_outset_new(err)))
			rc = PR_ENOMEM;
		else
			rc = fit_and_query(cfg, &m, a->sample > 0 ? a->sample : 0, set, a->output, err);
	}
	rc = pr_outset_commit(set, rc, err);
	samples_free(&m);
	return rc;
}

static int policy_main(const pr_config *cfg, const void *opts, char *err)
{
	return pr_cmd_policy(cfg, opts, err);
}

/* --sample N: an integer in 1..1000000 */
static const char *parse_sample(const char *arg, void *target)
{
	long *v = target;
	char *end;

	*v = strtol(arg, &end, 10);
	return end == arg || *end || *v < 1 || *v > 1000000 ? "an integer in 1..1000000" : NULL;
}

static const cli_opt policy_opts[] = {
	CLI_COMMON_C,
	CLI_OPT("i", "STATES.csv", policy_args, input,
	        "the query states, state columns by name (default stdin)"),
	CLI_OPT("o", "OUT.csv", policy_args, output,
	        "a row per state, N with --sample (default stdout)"),
	CLI_COMMON_SET, CLI_COMMON_SEED,
	CLI_OPT("train", "FILE", policy_args, train, "the weighted samples"),
	CLI_OPT("state", "COLS", policy_args, state,
	        "the states: a comma list or a prefix ending in '*'"),
	CLI_OPT("action", "COLS", policy_args, action, "the actions, as --state"),
	CLI_OPT("weight", "COL", policy_args, weight, "the samples' REPS weights (default 1)"),
	CLI_OPT_NUMBER("sample", "N", policy_args, sample, sample_set, parse_sample,
	               "also draw N actions per state (1..1000000)"),
	CLI_OPT("target", "COLS", policy_args, target,
	        "final reward-ball x,y (policy.target = reward_state)"),
	CLI_OPT("old-mean", "COLS", policy_args, old_mean,
	        "means that drew the rows (policy.cov_center = old)"),
	CLI_END
};

const cli_command cli_policy = {
	"policy",
	"poolreps policy --train FILE --state COLS --action COLS --weight COL [--sample N]\n"
	"                [--target COLS] [--old-mean COLS] [-i STATES.csv] [-o OUT.csv]\n"
	"                [--set policy.key=value]...\n"
	"  Fit the tree-LWR Gaussian policy; write mean and covariance (and N samples)\n"
	"  for every state row of the input.",
	policy_opts, sizeof(policy_args), "policy.,experiment.seed", CLI_OPS_NONE, 0, NULL, policy_main
};
