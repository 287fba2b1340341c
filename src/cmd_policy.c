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

#include "poolreps/cmd.h"
#include "poolreps/csvio.h"
#include "poolreps/policy.h"

/* Copy the selected columns of every row into X (n x k). */
static void gather(const pr_csv *t, const int *cols, int k, double *X)
{
	long i, n = pr_csv_nrows(t);
	int j;

	for (i = 0; i < n; i++) {
		const double *row = pr_csv_row(t, i);

		for (j = 0; j < k; j++)
			X[(size_t)i * k + j] = row[cols[j]];
	}
}

static int write_header(pr_csvw *w, const pr_csv *tr, const int *sc, int ds, const int *ac,
                        int da, int sampling)
{
	char name[300];
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

int pr_cmd_policy(const pr_config *cfg, const pr_cmd_args *a, char *err)
{
	const int reward = cfg->policy.target == PR_TARGET_REWARD_STATE;
	const int old = cfg->policy.cov_center == PR_COV_CENTER_OLD;
	pr_csv *tr = NULL, *in = NULL;
	pr_outset *set = NULL;
	pr_csvw *w = NULL;
	pr_policy *p = NULL;
	pr_policy_work *ws = NULL;
	pr_policy_data d = { 0 };
	gsl_rng *rng = NULL;
	double *S = NULL, *A = NULL, *Y = NULL, *Mo = NULL, *wt = NULL, *Q = NULL, *mean = NULL;
	double *cov = NULL, *draws = NULL, sw = 0.0;
	int *sc = NULL, *ac = NULL, *yc = NULL, *mc = NULL, *qc = NULL, *status = NULL;
	int ds, da, dy = 0, dm = 0, wcol = -1, nc, j, rc;
	long i, n, nq, k, ns = a->sample > 0 ? a->sample : 0;

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
	if ((rc = pr_policy_opts_check(&cfg->policy, err)))
		return rc;
	if ((rc = pr_csv_read(a->train, &tr, err)))
		return rc;
	if ((rc = pr_csv_read(a->input, &in, err)))
		goto done;
	nc = pr_csv_ncols(tr);
	n = pr_csv_nrows(tr);
	nq = pr_csv_nrows(in);
	sc = malloc((size_t)nc * sizeof *sc);
	ac = malloc((size_t)nc * sizeof *ac);
	yc = malloc((size_t)nc * sizeof *yc);
	mc = malloc((size_t)nc * sizeof *mc);
	if (!sc || !ac || !yc || !mc) {
		rc = pr_err(err, PR_ENOMEM, "policy: out of memory");
		goto done;
	}
	if ((ds = pr_csv_select(tr, a->state, sc, nc, err)) < 0 ||
	    (da = pr_csv_select(tr, a->action, ac, nc, err)) < 0 ||
	    (reward && (dy = pr_csv_select(tr, a->target, yc, nc, err)) < 0) ||
	    (old && (dm = pr_csv_select(tr, a->old_mean, mc, nc, err)) < 0)) {
		rc = PR_EIO;
		goto done;
	}
	if (old && dm != da) {
		rc = pr_err(err, PR_EINVAL, "%s: --old-mean selects %d columns, --action %d",
		            pr_csv_path(tr), dm, da);
		goto done;
	}
	if (a->weight && (wcol = pr_csv_find(tr, a->weight)) < 0) {
		rc = pr_err(err, PR_EIO, "%s:1: missing column '%s' (--weight)", pr_csv_path(tr), a->weight);
		goto done;
	}
	if (n < 1 || n > 100000000) {
		rc = pr_err(err, PR_EIO, "%s: no data rows", pr_csv_path(tr));
		goto done;
	}
	qc = malloc((size_t)ds * sizeof *qc);
	if (!qc) {
		rc = pr_err(err, PR_ENOMEM, "policy: out of memory");
		goto done;
	}
	for (j = 0; j < ds; j++) {
		qc[j] = pr_csv_find(in, pr_csv_name(tr, sc[j]));
		if (qc[j] < 0) {
			rc = pr_err(err, PR_EIO, "%s:1: missing state column '%s'", pr_csv_path(in),
			            pr_csv_name(tr, sc[j]));
			goto done;
		}
	}
	S = malloc((size_t)n * ds * sizeof *S);
	A = malloc((size_t)n * da * sizeof *A);
	Y = reward ? malloc((size_t)n * dy * sizeof *Y) : NULL;
	Mo = old ? malloc((size_t)n * da * sizeof *Mo) : NULL;
	wt = malloc((size_t)n * sizeof *wt);
	Q = malloc((size_t)(nq > 0 ? nq : 1) * ds * sizeof *Q);
	mean = malloc((size_t)(nq > 0 ? nq : 1) * da * sizeof *mean);
	cov = malloc((size_t)(nq > 0 ? nq : 1) * da * da * sizeof *cov);
	status = malloc((size_t)(nq > 0 ? nq : 1) * sizeof *status);
	draws = ns ? malloc((size_t)(nq > 0 ? nq : 1) * ns * da * sizeof *draws) : NULL;
	if (!S || !A || (reward && !Y) || (old && !Mo) || !wt || !Q || !mean || !cov || !status || (ns && !draws)) {
		rc = pr_err(err, PR_ENOMEM, "policy: out of memory");
		goto done;
	}
	gather(tr, sc, ds, S);
	gather(tr, ac, da, A);
	if (reward)
		gather(tr, yc, dy, Y);
	if (old)
		gather(tr, mc, da, Mo);
	for (i = 0; i < n; i++) {
		wt[i] = wcol >= 0 ? pr_csv_get(tr, i, wcol) : 1.0;
		if (wt[i] < 0.0) {
			rc = pr_err(err, PR_EINVAL, "%s:%ld: column '%s': weight must be >= 0 (got %g)",
			            pr_csv_path(tr), pr_csv_line(tr, i), a->weight, wt[i]);
			goto done;
		}
		sw += wt[i];
	}
	if (!(sw > 0.0)) {
		rc = pr_err(err, PR_EINVAL, "%s: column '%s': weights are all zero", pr_csv_path(tr),
		            a->weight);
		goto done;
	}
	gather(in, qc, ds, Q);

	d.n = (int)n;
	d.ds = ds;
	d.da = da;
	d.dy = dy;
	d.S = S;
	d.A = A;
	d.Y = Y;
	d.w = wt;
	d.M = Mo;
	rng = gsl_rng_alloc(gsl_rng_mt19937);
	if (!rng) {
		rc = pr_err(err, PR_ENOMEM, "policy: out of memory");
		goto done;
	}
	gsl_rng_set(rng, cfg->run.seed);
	if (!(p = pr_policy_tree_fit(&cfg->policy, &d, rng, err))) {
		/* the options and data were checked above: memory (main turns it
		 * into exit 4) or a numerical failure */
		rc = PR_ENUM;
		goto done;
	}
	if (!(ws = pr_policy_work_new(p, err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	for (i = 0; i < nq; i++) {
		rc = pr_policy_eval(p, Q + (size_t)i * ds, mean + (size_t)i * da,
		                    cov + (size_t)i * da * da, status + i, ws, err);
		if (!rc && ns)
			rc = pr_policy_gauss_sample(da, mean + (size_t)i * da, cov + (size_t)i * da * da,
			                            (int)ns, rng, draws + (size_t)i * ns * da, err);
		if (rc)
			goto done;
	}

	if (!(set = pr_outset_new(err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	if ((rc = pr_outset_add(set, a->output, &w, err)))
		goto done;
	write_header(w, tr, sc, ds, ac, da, ns > 0);
	for (i = 0; i < nq && !pr_csvw_status(w); i++)
		for (k = 0; k < (ns ? ns : 1); k++)
			write_row(w, Q + (size_t)i * ds, ds, k, ns ? draws + ((size_t)i * ns + k) * da : NULL,
			          mean + (size_t)i * da, cov + (size_t)i * da * da, da, status[i]);
done:
	rc = pr_outset_commit(set, rc, err);
	pr_policy_work_free(ws);
	pr_policy_free(p);
	if (rng)
		gsl_rng_free(rng);
	pr_csv_free(tr);
	pr_csv_free(in);
	free(sc);
	free(ac);
	free(yc);
	free(mc);
	free(qc);
	free(S);
	free(A);
	free(Y);
	free(Mo);
	free(wt);
	free(Q);
	free(mean);
	free(cov);
	free(status);
	free(draws);
	return rc;
}
