/* query.h — a fitted model queried row by row over a CSV, streamed: the
 * predictions of `forest --test`, the answers of `policy -i`. Memory holds
 * one chunk of query rows (pr_csv_stream) whatever their number; each
 * chunk's results are pushed to a pipe before the next read.
 *
 * Outputs are the writers of a pr_outset (csvio.h) that the caller commits:
 * a file appears only when every row succeeded; standard output or a pipe
 * holds, after a failure, exactly the rows before the failing one.
 */
#ifndef POOLREPS_QUERY_H
#define POOLREPS_QUERY_H

#include "poolreps/common.h"
#include "poolreps/csvio.h"
#include "poolreps/forest.h"
#include "poolreps/policy.h"

typedef struct pr_query pr_query;

/* Open the query CSV at path (NULL or "-": stdin) and find its k columns
 * names[0..k-1] (the model's inputs, in its order), before any fit: PR_EIO
 * "path:1: missing <what> column 'name'" otherwise. names are borrowed: they
 * must outlive the query. *out is owned by the caller. */
int pr_query_open(const char *path, const char *const *names, int k, const char *what,
                  pr_query **out, char *err);
void pr_query_free(pr_query *q);
const char *pr_query_path(const pr_query *q);

/* What pr_query_forest saw: the rows, and if the CSV also holds every
 * target column (by name), their mean squared error. */
typedef struct {
	long rows;
	int have_y;      /* every target column is in the CSV */
	double mse;      /* sum of squared errors / (rows * dy), when have_y and rows > 0 */
	double seconds;  /* spent in pr_forest_predict_many */
} pr_query_stats;

/* The forest's prediction of every row to pred: a header pred_<ynames[k]>
 * (k < pr_forest_dy) and one row per query row; with leaves, tree0..,
 * each row's active leaf per tree, numbered within its tree (PR_ENUM if a
 * row reaches no leaf of some tree). The same numbers as one
 * pr_forest_predict_many over all rows. */
int pr_query_forest(pr_query *q, const pr_forest *f, const char *const *ynames, pr_csvw *pred,
                    pr_csvw *leaves, pr_query_stats *st, char *err);

/* The policy's answer at every query row to w: a header <names of the
 * query's columns>, [sample, <anames[j]>...,] mean_<anames[j]>...,
 * cov_<i>_<j> (0 <= i <= j < da), status, then per query row its state,
 * pr_policy_eval's mean, covariance (upper triangle) and flags; with ns > 0,
 * ns rows per query row, each with its sample index and one draw of
 * pr_policy_gauss_sample from rng. Draws come in query-row order, in
 * chunks of a fixed size, so they are the draws of one all-in-memory pass
 * and memory depends on neither the rows nor ns. */
int pr_query_policy(pr_query *q, const pr_policy *p, const char *const *anames, long ns,
                    gsl_rng *rng, pr_csvw *w, char *err);

#endif
