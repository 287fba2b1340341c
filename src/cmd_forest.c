/* cmd_forest.c — `poolreps forest` (SPEC.md §6): fit extra trees on one CSV,
 * predict another.
 *
 * Inputs are every training column except the targets (--target, a comma
 * list or a prefix ending in '*') and the weight column (--weight). The test
 * CSV must hold the input columns by name; if it also holds every target,
 * the test MSE is reported. Output: one pred_<target> column per target, one
 * row per test row; --leaves FILE: columns tree0..tree{M-1}, each test row's
 * active leaf, numbered within its tree. Options come from cfg->forest and
 * the seed from cfg->run.seed. Every check runs before anything is written;
 * on an error no output file is left.
 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include <gsl/gsl_rng.h>

#include "poolreps/cmd.h"
#include "poolreps/csvio.h"
#include "poolreps/forest.h"

static double seconds(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int write_pred(pr_csvw *w, const pr_csv *tr, const int *tc, int dy, const double *P,
                      long nt)
{
	char name[300];
	int rc = 0;

	for (int k = 0; k < dy && !rc; k++) {
		snprintf(name, sizeof name, "pred_%s", pr_csv_name(tr, tc[k]));
		rc = pr_csvw_str(w, name);
	}
	if (!rc)
		rc = pr_csvw_endrow(w);
	for (long i = 0; i < nt && !rc; i++) {
		for (int k = 0; k < dy && !rc; k++)
			rc = pr_csvw_num(w, P[(size_t)i * dy + k]);
		if (!rc)
			rc = pr_csvw_endrow(w);
	}
	return rc;
}

/* Each test row's active leaf per tree, as a leaf index within the tree. */
static int write_leaves(pr_csvw *w, const pr_forest *f, const double *Xt, int dx, long nt,
                        int *act)
{
	char name[32];
	int M = pr_forest_ntrees(f), rc = 0;

	for (int t = 0; t < M && !rc; t++) {
		snprintf(name, sizeof name, "tree%d", t);
		rc = pr_csvw_str(w, name);
	}
	if (!rc)
		rc = pr_csvw_endrow(w);
	for (long i = 0; i < nt && !rc; i++) {
		int c = pr_forest_active(f, Xt + (size_t)i * dx, dx, act, M);
		if (c != M)
			return PR_EINVAL;
		for (int t = 0; t < M && !rc; t++)
			rc = pr_csvw_int(w, act[t] - pr_forest_tree_leaf0(f, t));
		if (!rc)
			rc = pr_csvw_endrow(w);
	}
	return rc;
}

int pr_cmd_forest(const pr_config *cfg, const pr_cmd_args *a, char *err)
{
	pr_csv *tr = NULL, *te = NULL;
	pr_forest *f = NULL;
	pr_outset *set = NULL;
	pr_csvw *pw = NULL, *lw = NULL;
	gsl_rng *rng = NULL;
	double *X = NULL, *Y = NULL, *W = NULL, *Xt = NULL, *P = NULL;
	int *tc = NULL, *xc = NULL, *xt = NULL, *yt = NULL, *act = NULL;
	int ncol, dy, dx = 0, wc = -1, have_y = 1, rc;
	long n, nt;
	double t0, tfit, tpred;

	if (!a->train || !a->test || !a->target)
		return pr_err(err, PR_EINVAL, "forest: --train, --test and --target are required");
	if ((rc = pr_forest_opts_check(&cfg->forest, "forest", err)))
		return rc;
	if ((rc = pr_csv_read(a->train, &tr, err)) || (rc = pr_csv_read(a->test, &te, err)))
		goto done;
	n = pr_csv_nrows(tr);
	nt = pr_csv_nrows(te);
	ncol = pr_csv_ncols(tr);
	if (n < 1 || n > 100000000) {
		rc = pr_err(err, PR_EIO, "%s: no data rows", pr_csv_path(tr));
		goto done;
	}
	if (n < cfg->forest.n_c) {
		rc = pr_err(err, PR_EINVAL, "%s: %ld rows, fewer than forest.n_c = %d",
		            pr_csv_path(tr), n, cfg->forest.n_c);
		goto done;
	}
	if ((long long)n * cfg->forest.trees >= 2147483647LL) {
		rc = pr_err(err, PR_EINVAL, "%s: %ld rows x forest.trees = %d is too large",
		            pr_csv_path(tr), n, cfg->forest.trees);
		goto done;
	}
	tc = malloc((size_t)ncol * sizeof *tc);
	xc = malloc((size_t)ncol * sizeof *xc);
	xt = malloc((size_t)ncol * sizeof *xt);
	yt = malloc((size_t)ncol * sizeof *yt);
	if (!tc || !xc || !xt || !yt) {
		rc = pr_err(err, PR_ENOMEM, "forest: out of memory");
		goto done;
	}
	dy = pr_csv_select(tr, a->target, tc, ncol, err);
	if (dy < 0) {
		rc = PR_EIO;
		goto done;
	}
	for (int k = 0; k < dy; k++)
		for (int q = 0; q < k; q++)
			if (tc[q] == tc[k]) {
				rc = pr_err(err, PR_EINVAL, "%s: target column '%s' given twice",
				            pr_csv_path(tr), pr_csv_name(tr, tc[k]));
				goto done;
			}
	if (a->weight) {
		wc = pr_csv_find(tr, a->weight);
		if (wc < 0) {
			rc = pr_err(err, PR_EIO, "%s:1: no column '%s' (--weight)", pr_csv_path(tr),
			            a->weight);
			goto done;
		}
		for (int k = 0; k < dy; k++)
			if (tc[k] == wc) {
				rc = pr_err(err, PR_EINVAL, "%s: column '%s' is both a target and the weight",
				            pr_csv_path(tr), a->weight);
				goto done;
			}
	}
	for (int j = 0; j < ncol; j++) {
		int used = j == wc;
		for (int k = 0; k < dy; k++)
			used |= tc[k] == j;
		if (!used)
			xc[dx++] = j;
	}
	if (dx == 0) {
		rc = pr_err(err, PR_EINVAL, "%s: no input columns besides the targets and weight",
		            pr_csv_path(tr));
		goto done;
	}
	for (int j = 0; j < dx; j++) {
		xt[j] = pr_csv_find(te, pr_csv_name(tr, xc[j]));
		if (xt[j] < 0) {
			rc = pr_err(err, PR_EIO, "%s:1: missing input column '%s'", pr_csv_path(te),
			            pr_csv_name(tr, xc[j]));
			goto done;
		}
	}
	for (int k = 0; k < dy; k++) {
		yt[k] = pr_csv_find(te, pr_csv_name(tr, tc[k]));
		have_y &= yt[k] >= 0;
	}
	X = malloc((size_t)n * dx * sizeof *X);
	Y = malloc((size_t)n * dy * sizeof *Y);
	W = wc >= 0 ? malloc((size_t)n * sizeof *W) : NULL;
	Xt = malloc(((size_t)nt + 1) * dx * sizeof *Xt);
	P = malloc(((size_t)nt + 1) * dy * sizeof *P);
	act = malloc((size_t)cfg->forest.trees * sizeof *act);
	if (!X || !Y || (wc >= 0 && !W) || !Xt || !P || !act) {
		rc = pr_err(err, PR_ENOMEM, "forest: out of memory");
		goto done;
	}
	for (long i = 0; i < n; i++) {
		const double *row = pr_csv_row(tr, i);
		for (int j = 0; j < dx; j++)
			X[(size_t)i * dx + j] = row[xc[j]];
		for (int k = 0; k < dy; k++)
			Y[(size_t)i * dy + k] = row[tc[k]];
		if (W) {
			W[i] = row[wc];
			if (!(W[i] >= 0)) {
				rc = pr_err(err, PR_EINVAL, "%s:%ld: column '%s': weight must be >= 0 (got %g)",
				            pr_csv_path(tr), pr_csv_line(tr, i), a->weight, W[i]);
				goto done;
			}
		}
	}
	if (W) {
		double s = 0;
		for (long i = 0; i < n; i++)
			s += W[i];
		if (!(s > 0)) {
			rc = pr_err(err, PR_EINVAL, "%s: column '%s': weights are all zero",
			            pr_csv_path(tr), a->weight);
			goto done;
		}
	}
	for (long i = 0; i < nt; i++)
		for (int j = 0; j < dx; j++)
			Xt[(size_t)i * dx + j] = pr_csv_get(te, i, xt[j]);
	rng = gsl_rng_alloc(gsl_rng_mt19937);
	if (!rng) {
		rc = pr_err(err, PR_ENOMEM, "forest: out of memory");
		goto done;
	}
	gsl_rng_set(rng, cfg->run.seed);
	t0 = seconds();
	f = pr_forest_fit(&cfg->forest, X, (int)n, dx, Y, dy, W, rng, err);
	tfit = seconds() - t0;
	if (!f) {
		/* the options and data were checked above: what is left is memory
		 * or an interruption */
		rc = pr_interrupted ? PR_EINTR : PR_ENOMEM;
		goto done;
	}
	t0 = seconds();
	pr_forest_predict_many(f, Xt, (int)nt, P);
	tpred = seconds() - t0;

	/* predictions and leaves are committed together, only if both are complete */
	if (!(set = pr_outset_new(err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	if ((rc = pr_outset_add(set, a->output, &pw, err)) ||
	    (a->leaves && (rc = pr_outset_add(set, a->leaves, &lw, err))))
		goto done;
	write_pred(pw, tr, tc, dy, P, nt);
	if (lw && write_leaves(lw, f, Xt, dx, nt, act) == PR_EINVAL) {
		rc = pr_err(err, PR_ENUM, "%s: a test row reaches no leaf of some tree", pr_csv_path(te));
		goto done;
	}
	if (!a->quiet) {
		int len = snprintf(a->note, PR_ERRLEN, "forest: %d trees, %d leaves, fit %.3f s, predict %.3f s",
		                   pr_forest_ntrees(f), pr_forest_nleaves(f), tfit, tpred);
		if (have_y && nt > 0 && len > 0 && len < PR_ERRLEN) {
			double sse = 0;
			for (long i = 0; i < nt; i++)
				for (int k = 0; k < dy; k++) {
					double e = P[(size_t)i * dy + k] - pr_csv_get(te, i, yt[k]);
					sse += e * e;
				}
			snprintf(a->note + len, (size_t)(PR_ERRLEN - len), ", test MSE %.6g", sse / ((double)nt * dy));
		}
	}
done:
	rc = pr_outset_commit(set, rc, err);
	pr_forest_free(f);
	gsl_rng_free(rng);
	pr_csv_free(tr);
	pr_csv_free(te);
	free(tc);
	free(xc);
	free(xt);
	free(yt);
	free(X);
	free(Y);
	free(W);
	free(Xt);
	free(P);
	free(act);
	return rc;
}
