/* cmd_reps.c — `poolreps reps`: REPS weights for a table of
 * samples.
 *
 * Input: one row per sample, with the return column (--return), the state
 * feature columns (--features, a comma list or a prefix ending in '*';
 * omitted = no features) and optionally base weights (--base). Output:
 * one column p, one row per input row, in input order. --summary FILE
 * writes one row eta,dual,kl,ess,bound,residual,iterations,kl_gap,
 * residual_rel,status (the certificate, reps.h). A solve that cannot be
 * certified exits 3 with one line naming what failed (e.g. the feature
 * residual). Features that are all 0 or 1 take the solver's one-hot path
 * (reps.h). Every input check runs before anything is written;
 * on an error no file is left.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "poolreps/cmd.h"
#include "poolreps/csvio.h"
#include "poolreps/reps.h"

static int write_weights(pr_csvw *w, const pr_reps_result *r)
{
	int i, rc = pr_csvw_str(w, "p");

	if (!rc)
		rc = pr_csvw_endrow(w);
	for (i = 0; i < r->n && !rc; i++) {
		rc = pr_csvw_num(w, r->p[i]);
		if (!rc)
			rc = pr_csvw_endrow(w);
	}
	return rc;
}

static int write_summary(pr_csvw *w, const pr_reps_result *r)
{
	int rc = pr_csvw_header(w, "eta,dual,kl,ess,bound,residual,iterations,kl_gap,residual_rel,"
	                           "status");

	rc |= pr_csvw_num(w, r->eta);
	rc |= pr_csvw_num(w, r->dual);
	rc |= pr_csvw_num(w, r->kl);
	rc |= pr_csvw_num(w, r->ess);
	rc |= pr_csvw_int(w, r->bound);
	rc |= pr_csvw_num(w, r->residual);
	rc |= pr_csvw_int(w, r->iterations);
	rc |= pr_csvw_num(w, r->kl_gap);
	rc |= pr_csvw_num(w, r->residual_rel);
	rc |= pr_csvw_str(w, pr_reps_status_name(r->status));
	return rc ? rc : pr_csvw_endrow(w);
}

int pr_cmd_reps(const pr_config *cfg, const pr_cmd_args *a, char *err)
{
	pr_reps_opts o = cfg->reps;
	pr_reps_problem pb = { 0 };
	pr_reps_result *r = NULL;
	pr_csv *in = NULL;
	pr_outset *set = NULL;
	pr_csvw *w = NULL, *sw = NULL;
	double *R = NULL, *q = NULL, *phi = NULL, sq = 0.0;
	int *fc = NULL, rcol, bcol = -1, d = 0, j, rc;
	long i, n;

	if (a->epsilon_set) {
		o.epsilon = a->epsilon;
		if (!(o.epsilon > 0.0) || !isfinite(o.epsilon))
			return pr_err(err, PR_EINVAL, "--epsilon: must be > 0 (got %g)", o.epsilon);
	}
	if (!a->ret)
		return pr_err(err, PR_EINVAL, "reps: --return COL is required");
	if ((rc = pr_csv_read(a->input, &in, err)))
		return rc;
	n = pr_csv_nrows(in);
	if (n < 1 || n > 100000000) {
		rc = pr_err(err, PR_EIO, "%s: no data rows", pr_csv_path(in));
		goto done;
	}
	rcol = pr_csv_find(in, a->ret);
	if (rcol < 0) {
		rc = pr_err(err, PR_EIO, "%s:1: missing column '%s' (--return)", pr_csv_path(in), a->ret);
		goto done;
	}
	if (a->base && (bcol = pr_csv_find(in, a->base)) < 0) {
		rc = pr_err(err, PR_EIO, "%s:1: missing column '%s' (--base)", pr_csv_path(in), a->base);
		goto done;
	}
	fc = malloc((size_t)pr_csv_ncols(in) * sizeof *fc);
	R = malloc((size_t)n * sizeof *R);
	q = malloc((size_t)n * sizeof *q);
	if (!fc || !R || !q) {
		rc = pr_err(err, PR_ENOMEM, "reps: out of memory");
		goto done;
	}
	if (a->features) {
		d = pr_csv_select(in, a->features, fc, pr_csv_ncols(in), err);
		if (d < 0) {
			rc = PR_EIO;
			goto done;
		}
		for (j = 0; j < d; j++)
			if (fc[j] == rcol || fc[j] == bcol) {
				rc = pr_err(err, PR_EINVAL, "%s: column '%s' is both a feature and the %s",
				            pr_csv_path(in), pr_csv_name(in, fc[j]),
				            fc[j] == rcol ? "return" : "base weight");
				goto done;
			}
		phi = malloc((size_t)n * (size_t)d * sizeof *phi);
		if (!phi) {
			rc = pr_err(err, PR_ENOMEM, "reps: out of memory");
			goto done;
		}
	}
	for (i = 0; i < n; i++) {
		const double *row = pr_csv_row(in, i);

		R[i] = row[rcol];
		q[i] = bcol >= 0 ? row[bcol] : 1.0;
		if (q[i] < 0.0) {
			rc = pr_err(err, PR_EINVAL, "%s:%ld: column '%s': base weight must be >= 0 (got %g)",
			            pr_csv_path(in), pr_csv_line(in, i), a->base, q[i]);
			goto done;
		}
		sq += q[i];
		for (j = 0; j < d; j++)
			phi[(size_t)i * d + j] = row[fc[j]];
	}
	if (!(sq > 0.0)) {
		rc = pr_err(err, PR_EINVAL, "%s: column '%s': base weights are all zero",
		            pr_csv_path(in), a->base);
		goto done;
	}
	pb.n = (int)n;
	pb.d = d;
	pb.R = R;
	pb.q = q;
	pb.phi = phi;
	if ((rc = pr_reps_solve(&o, &pb, &r, err)))
		goto done;
	if (r->status == PR_REPS_FAILED) {
		rc = pr_err(err, PR_ENUM, "reps: %s: no certified answer: %s", pr_csv_path(in), r->reason);
		goto done;
	}
	if (r->status == PR_REPS_UNREACHABLE)
		pr_err(a->note, PR_OK, "reps: KL bound unreachable: %s (KL = %.6g < epsilon = %g, eta = 0)",
		       r->constant ? "all returns are equal" :
		       "p is the eta -> 0 limit, the feature-matching solution closest to q",
		       r->kl, o.epsilon);
	/* weights and summary are committed together, only if both are complete */
	if (!(set = pr_outset_new(err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	if ((rc = pr_outset_add(set, a->output, &w, err)) ||
	    (a->summary && (rc = pr_outset_add(set, a->summary, &sw, err))))
		goto done;
	write_weights(w, r);
	if (sw)
		write_summary(sw, r);
done:
	rc = pr_outset_commit(set, rc, err);
	pr_reps_result_free(r);
	pr_csv_free(in);
	free(fc);
	free(R);
	free(q);
	free(phi);
	return rc;
}
