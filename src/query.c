/* query.c — fitted models queried over a streamed CSV (query.h).
 *
 * Invariant: one chunk of query rows, its matrix of model inputs and its
 * results are in memory at a time; chunks are handled in file order, so
 * every result (and every random draw) is the one an all-in-memory pass
 * would give.
 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "poolreps/query.h"
#include "csvio_priv.h"

struct pr_query {
	pr_csv_stream *in;
	const char *const *names;
	int k, *col;   /* the model's inputs: their columns in the CSV */
	double *X;     /* a chunk's inputs, row-major, rows x k */
	long cap;      /* rows X holds */
};

void pr_query_free(pr_query *q)
{
	if (!q)
		return;
	pr_csv_stream_free(q->in);
	free(q->col);
	free(q->X);
	free(q);
}

const char *pr_query_path(const pr_query *q)
{
	return pr_csv_path(pr_csv_stream_columns(q->in));
}

int pr_query_open(const char *path, const char *const *names, int k, const char *what,
                  pr_query **out, char *err)
{
	pr_query *q = calloc(1, sizeof *q);
	const pr_csv *h;
	int j, rc;

	*out = NULL;
	if (!q || !(q->col = malloc((size_t)(k > 0 ? k : 1) * sizeof *q->col))) {
		free(q);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	q->names = names;
	q->k = k;
	if ((rc = pr_csv_stream_open(path, &q->in, err))) {
		pr_query_free(q);
		return rc;
	}
	h = pr_csv_stream_columns(q->in);
	for (j = 0; j < k; j++)
		if ((q->col[j] = pr_csv_find(h, names[j])) < 0) {
			/* a bad row already read is named first, as by pr_csv_read */
			if (!(rc = pr_csv_stream_failed(q->in, err)))
				rc = pr_err(err, PR_EIO, "%s:1: missing %s column '%s'", pr_csv_path(h), what, names[j]);
			pr_query_free(q);
			return rc;
		}
	*out = q;
	return PR_OK;
}

/* The next chunk's model inputs into q->X; *n rows (0 at the end). */
static int next_inputs(pr_query *q, const pr_csv **chunk, long *n, char *err)
{
	int rc = pr_csv_stream_next(q->in, chunk, err);
	long i;

	*n = rc || !*chunk ? 0 : pr_csv_nrows(*chunk);
	if (*n > q->cap) {
		double *X = realloc(q->X, (size_t)*n * (size_t)q->k * sizeof *X);
		if (!X)
			return pr_err(err, PR_ENOMEM, "%s: out of memory", pr_query_path(q));
		q->X = X;
		q->cap = *n;
	}
	for (i = 0; i < *n; i++)
		for (int j = 0; j < q->k; j++)
			q->X[(size_t)i * q->k + j] = pr_csv_get(*chunk, i, q->col[j]);
	return rc;
}

static double seconds(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void forest_headers(const pr_forest *f, const char *const *ynames, pr_csvw *pred,
                           pr_csvw *leaves)
{
	char name[PR_CSV_MAX_FIELD + sizeof "pred_"];

	for (int k = 0; k < pr_forest_dy(f); k++) {
		snprintf(name, sizeof name, "pred_%s", ynames[k]);
		pr_csvw_str(pred, name);
	}
	pr_csvw_endrow(pred);
	for (int t = 0; leaves && t < pr_forest_ntrees(f); t++) {
		snprintf(name, sizeof name, "tree%d", t);
		pr_csvw_str(leaves, name);
	}
	if (leaves)
		pr_csvw_endrow(leaves);
}

/* One chunk: predictions, leaves and the squared errors (yc: the targets'
 * columns, or NULL). */
static int forest_chunk(const pr_query *q, const pr_forest *f, const pr_csv *chunk, long n,
                        const int *yc, double *P, int *act, pr_csvw *pred, pr_csvw *leaves,
                        pr_query_stats *st, char *err)
{
	const int dy = pr_forest_dy(f), M = pr_forest_ntrees(f);
	double t0 = seconds();

	pr_forest_predict_many(f, q->X, (int)n, P);
	st->seconds += seconds() - t0;
	for (long i = 0; i < n; i++) {
		for (int k = 0; k < dy; k++) {
			pr_csvw_num(pred, P[(size_t)i * dy + k]);
			if (yc) {
				double e = P[(size_t)i * dy + k] - pr_csv_get(chunk, i, yc[k]);
				st->mse += e * e;
			}
		}
		pr_csvw_endrow(pred);
		if (!leaves)
			continue;
		if (pr_forest_active(f, q->X + (size_t)i * q->k, q->k, act, M) != M)
			return pr_err(err, PR_ENUM, "%s: a test row reaches no leaf of some tree",
			              pr_query_path(q));
		for (int t = 0; t < M; t++)
			pr_csvw_int(leaves, act[t] - pr_forest_tree_leaf0(f, t));
		pr_csvw_endrow(leaves);
	}
	st->rows += n;
	pr_csvw_flush(pred);
	if (leaves)
		pr_csvw_flush(leaves);
	return PR_OK;
}

int pr_query_forest(pr_query *q, const pr_forest *f, const char *const *ynames, pr_csvw *pred,
                    pr_csvw *leaves, pr_query_stats *st, char *err)
{
	const int dy = pr_forest_dy(f);
	const pr_csv *h = pr_csv_stream_columns(q->in), *chunk;
	int *yc = malloc((size_t)dy * sizeof *yc), *act = malloc((size_t)pr_forest_ntrees(f) * sizeof *act);
	double *P = NULL;
	long n, cap = 0;
	int rc = PR_OK;

	st->rows = 0;
	st->have_y = 1;
	st->mse = st->seconds = 0;
	if (!yc || !act) {
		rc = pr_err(err, PR_ENOMEM, "forest: out of memory");
		goto done;
	}
	for (int k = 0; k < dy; k++)
		st->have_y &= (yc[k] = pr_csv_find(h, ynames[k])) >= 0;
	forest_headers(f, ynames, pred, leaves);
	while (!(rc = next_inputs(q, &chunk, &n, err)) && n > 0) {
		if (n > cap) {
			double *np = realloc(P, (size_t)n * dy * sizeof *P);
			if (!np) {
				rc = pr_err(err, PR_ENOMEM, "forest: out of memory");
				break;
			}
			P = np;
			cap = n;
		}
		if (pr_interrupted) {
			rc = pr_err(err, PR_EINTR, "forest: interrupted");
			break;
		}
		if ((rc = forest_chunk(q, f, chunk, n, st->have_y ? yc : NULL, P, act, pred, leaves, st, err)))
			break;
	}
	if (st->have_y && st->rows > 0)
		st->mse /= (double)st->rows * dy;
done:
	free(yc);
	free(act);
	free(P);
	return rc;
}
