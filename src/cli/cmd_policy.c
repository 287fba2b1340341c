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
 * 8 covariance fallback, 16 min_std floor). Everything is computed before
 * anything is written.
 */
#include <stdio.h>
#include <stdlib.h>

#include <gsl/gsl_rng.h>

#include "poolreps/csvio.h"
#include "poolreps/policy.h"
#include "cli.h"

/* The options of `poolreps policy` (its table: cli_policy below). */
typedef struct {
	const char *input, *output, *train, *state, *action, *weight, *target;
	const char *old_mean; /* --old-mean COLS: sampling means (policy.cov_center = old) */
	long sample;          /* --sample N, 0 = none */
	int sample_set;
} policy_args;

static int write_header(pr_csvw *w, const pr_csv *tr, const int *sc, int ds, const int *ac,
                        int da, int sampling)
{
	char name[PR_CSV_MAX_FIELD + sizeof "mean_"];
	int j, l, rc = 0;

	for (j = 0; j < ds && !rc; j++)
		rc = pr_csvw_str(w, pr_csv_name(tr, sc[j]));
	if (sampling) {
		if (!rc)
			rc = pr_csvw_str(w, "sample");
		for (j = 0; j < da && !rc; j++)
			rc = pr_csvw_str(w, pr_csv_name(tr, ac[j]));
	}
	for (j = 0; j < da && !rc; j++) {
		snprintf(name, sizeof name, "mean_%s", pr_csv_name(tr, ac[j]));
		rc = pr_csvw_str(w, name);
	}
	for (j = 0; j < da && !rc; j++)
		for (l = j; l < da && !rc; l++) {
			snprintf(name, sizeof name, "cov_%d_%d", j, l);
			rc = pr_csvw_str(w, name);
		}
	if (!rc)
		rc = pr_csvw_str(w, "status");
	return rc ? rc : pr_csvw_endrow(w);
}

static int write_row(pr_csvw *w, const double *s, int ds, long sample, const double *draw,
                     const double *mean, const double *cov, int da, int status)
{
	int j, l, rc = 0;

	for (j = 0; j < ds && !rc; j++)
		rc = pr_csvw_num(w, s[j]);
	if (draw) {
		if (!rc)
			rc = pr_csvw_int(w, sample);
		for (j = 0; j < da && !rc; j++)
			rc = pr_csvw_num(w, draw[j]);
	}
	for (j = 0; j < da && !rc; j++)
		rc = pr_csvw_num(w, mean[j]);
	for (j = 0; j < da && !rc; j++)
		for (l = j; l < da && !rc; l++)
			rc = pr_csvw_num(w, cov[j * da + l]);
	if (!rc)
		rc = pr_csvw_int(w, status);
	return rc ? rc : pr_csvw_endrow(w);
}

/* The training samples and query states with their columns and arrays. */
typedef struct {
	pr_csv *tr, *in;
	int *sc, *ac, *yc, *mc, *qc; /* states, actions, targets, sampling means in tr; states in in */
	int ds, da, dy;
	double *S, *A, *Y, *Mo, *wt, *Q;
} samples;

static void samples_free(samples *m)
{
	pr_csv_free(m->tr);
	pr_csv_free(m->in);
	free(m->sc);
	free(m->ac);
	free(m->yc);
	free(m->mc);
	free(m->qc);
	free(m->S);
	free(m->A);
	free(m->Y);
	free(m->Mo);
	free(m->wt);
	free(m->Q);
}

/* Read the training samples and the query states: every check before the fit. */
static int read_samples(const policy_args *a, int reward, int old, samples *m, char *err)
{
	int wcol = -1, dm = 0, j, rc;

	if ((rc = pr_csv_read(a->train, &m->tr, err)) || (rc = pr_csv_read(a->input, &m->in, err)))
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
	if ((rc = pr_cmd_check_rows(m->tr, err)))
		return rc;
	if (!(m->qc = malloc((size_t)m->ds * sizeof *m->qc)))
		return pr_err(err, PR_ENOMEM, "policy: out of memory");
	for (j = 0; j < m->ds; j++) {
		m->qc[j] = pr_csv_find(m->in, pr_csv_name(m->tr, m->sc[j]));
		if (m->qc[j] < 0)
			return pr_err(err, PR_EIO, "%s:1: missing state column '%s'", pr_csv_path(m->in),
			              pr_csv_name(m->tr, m->sc[j]));
	}
	if (!(m->S = pr_cmd_matrix(m->tr, m->sc, m->ds, err)) ||
	    !(m->A = pr_cmd_matrix(m->tr, m->ac, m->da, err)) ||
	    (reward && !(m->Y = pr_cmd_matrix(m->tr, m->yc, m->dy, err))) ||
	    (old && !(m->Mo = pr_cmd_matrix(m->tr, m->mc, m->da, err))) ||
	    !(m->Q = pr_cmd_matrix(m->in, m->qc, m->ds, err)))
		return PR_ENOMEM;
	return pr_cmd_weights(m->tr, wcol, a->weight, "weight", &m->wt, err);
}

/* Fit the policy and query it at every state of m->in: means, covariances,
 * status and, with --sample N, N draws each. */
static int fit_and_query(const pr_config *cfg, const samples *m, long ns, double *mean, double *cov,
                         int *status, double *draws, char *err)
{
	pr_policy_data d = { 0 };
	pr_policy *p = NULL;
	pr_policy_work *ws = NULL;
	gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
	long i, nq = pr_csv_nrows(m->in);
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
	else if (!(ws = pr_policy_work_new(p, err)))
		rc = PR_ENOMEM;
	for (i = 0; rc == PR_OK && i < nq; i++) {
		const int da = m->da;
		rc = pr_policy_eval(p, m->Q + (size_t)i * m->ds, mean + (size_t)i * da,
		                    cov + (size_t)i * da * da, status + i, ws, err);
		if (!rc && ns)
			rc = pr_policy_gauss_sample(da, mean + (size_t)i * da, cov + (size_t)i * da * da,
			                            (int)ns, rng, draws + (size_t)i * ns * da, err);
	}
	pr_policy_work_free(ws);
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
	pr_csvw *w = NULL;
	double *mean = NULL, *cov = NULL, *draws = NULL;
	int *status = NULL, rc;
	long i, nq, k, ns = a->sample > 0 ? a->sample : 0;
	size_t nq1;

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
	if ((rc = pr_policy_opts_check(&cfg->policy, err)) ||
	    (rc = read_samples(a, reward, old, &m, err)))
		goto done;
	nq = pr_csv_nrows(m.in);
	nq1 = (size_t)(nq > 0 ? nq : 1);
	mean = malloc(nq1 * m.da * sizeof *mean);
	cov = malloc(nq1 * m.da * m.da * sizeof *cov);
	status = malloc(nq1 * sizeof *status);
	draws = ns ? malloc(nq1 * ns * m.da * sizeof *draws) : NULL;
	if (!mean || !cov || !status || (ns && !draws)) {
		rc = pr_err(err, PR_ENOMEM, "policy: out of memory");
		goto done;
	}
	if ((rc = fit_and_query(cfg, &m, ns, mean, cov, status, draws, err)))
		goto done;
	if (!(set = pr_outset_new(err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	if ((rc = pr_outset_add(set, a->output, &w, err)))
		goto done;
	write_header(w, m.tr, m.sc, m.ds, m.ac, m.da, ns > 0);
	for (i = 0; i < nq && !pr_csvw_status(w); i++)
		for (k = 0; k < (ns ? ns : 1); k++)
			write_row(w, m.Q + (size_t)i * m.ds, m.ds, k,
			          ns ? draws + ((size_t)i * ns + k) * m.da : NULL, mean + (size_t)i * m.da,
			          cov + (size_t)i * m.da * m.da, m.da, status[i]);
done:
	rc = pr_outset_commit(set, rc, err);
	samples_free(&m);
	free(mean);
	free(cov);
	free(status);
	free(draws);
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
