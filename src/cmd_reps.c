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
 * residual). Features that are all 0 or 1 are handed to the solver as
 * sparse one-hot rows. Every input check runs before anything is written;
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

/* Features that are all 0 or 1 (one-hot leaves, eq. 5.4) go to the solver
 * in sparse form, as the experiments hand them over: the one-hot path. */
static int sparse_if_binary(pr_reps_problem *pb, int **rowptr, int **col, char *err)
{
	size_t i, nnz = 0, nd = (size_t)pb->n * (size_t)pb->d;
	int r;

	for (i = 0; i < nd; i++) {
		if (pb->phi[i] != 0.0 && pb->phi[i] != 1.0)
			return PR_OK;
		nnz += pb->phi[i] == 1.0;
	}
	*rowptr = malloc(((size_t)pb->n + 1) * sizeof **rowptr);
	*col = malloc((nnz > 0 ? nnz : 1) * sizeof **col);
	if (!*rowptr || !*col)
		return pr_err(err, PR_ENOMEM, "reps: out of memory");
	for (r = 0, nnz = 0; r < pb->n; r++) {
		int j;

		(*rowptr)[r] = (int)nnz;
		for (j = 0; j < pb->d; j++)
			if (pb->phi[(size_t)r * pb->d + j] == 1.0)
				(*col)[nnz++] = j;
	}
	(*rowptr)[pb->n] = (int)nnz;
	pb->phi = NULL;
	pb->rowptr = *rowptr;
	pb->col = *col;
	pb->val = NULL;
	return PR_OK;
}

int pr_cmd_reps(const pr_config *cfg, const pr_cmd_args *a, char *err)
{
	pr_reps_opts o = cfg->reps;
	pr_reps_problem pb = { 0 };
	pr_reps_result *r = NULL;
	pr_csv *in = NULL;
	pr_csvw *w = NULL, *sw = NULL;
	double *R = NULL, *q = NULL, *phi = NULL, sq = 0.0;
	int *fc = NULL, *rowptr = NULL, *col = NULL, rcol, bcol = -1, d = 0, j, rc;
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
	if (d > 0 && (rc = sparse_if_binary(&pb, &rowptr, &col, err)))
		goto done;
	if ((rc = pr_reps_solve(&o, &pb, &r, err)))
		goto done;
	if (r->status == PR_REPS_FAILED) {
		rc = pr_err(err, PR_ENUM, "reps: %s: no certified answer: %s", pr_csv_path(in), r->reason);
		goto done;
	}
	if (r->status == PR_REPS_UNREACHABLE && !a->quiet)
		fprintf(stderr, "poolreps: reps: KL bound unreachable: %s (KL = %.6g < epsilon = %g, "
		        "eta = 0)\n", r->constant ? "all returns are equal" :
		        "p is the eta -> 0 limit, the feature-matching solution closest to q",
		        r->kl, o.epsilon);
	w = pr_csvw_open(a->output, err);
	if (!w) {
		rc = PR_EIO;
		goto done;
	}
	if (a->summary && !(sw = pr_csvw_open(a->summary, err))) {
		rc = PR_EIO;
		goto done;
	}
	if (write_weights(w, r) || (sw && write_summary(sw, r))) {
		rc = pr_err(err, PR_EIO, "%s: write error",
		            a->output && *a->output ? a->output : "<stdout>");
		goto done;
	}
	rc = pr_csvw_close(w, err);
	w = NULL;
	if (!rc && sw) {
		rc = pr_csvw_close(sw, err);
		sw = NULL;
	}
done:
	pr_csvw_abort(w);
	pr_csvw_abort(sw);
	pr_reps_result_free(r);
	pr_csv_free(in);
	free(fc);
	free(rowptr);
	free(col);
	free(R);
	free(q);
	free(phi);
	return rc;
}
