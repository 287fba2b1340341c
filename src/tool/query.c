/* query.c — fitted models queried over a streamed CSV (query.h): a
 * forest's predictions, a policy's means, covariances and draws.
 *
 * Invariant: one chunk of query rows, its matrix of model inputs and its
 * results are in memory at a time; chunks are handled in file order, so
 * every result (and every random draw) is the one an all-in-memory pass
 * would give.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "poolreps/query.h"
#include "poolreps/internal.h"
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

/* draws per pr_policy_gauss_sample call: bounds the buffer whatever --sample */
enum { POLICY_DRAWS = 1024 };

static void policy_header(const pr_query *q, const char *const *anames, int da, int sampling,
                          pr_csvw *w)
{
	char name[PR_CSV_MAX_FIELD + sizeof "mean_"];

	for (int j = 0; j < q->k; j++)
		pr_csvw_str(w, q->names[j]);
	if (sampling) {
		pr_csvw_str(w, "sample");
		for (int j = 0; j < da; j++)
			pr_csvw_str(w, anames[j]);
	}
	for (int j = 0; j < da; j++) {
		snprintf(name, sizeof name, "mean_%s", anames[j]);
		pr_csvw_str(w, name);
	}
	for (int j = 0; j < da; j++)
		for (int l = j; l < da; l++) {
			snprintf(name, sizeof name, "cov_%d_%d", j, l);
			pr_csvw_str(w, name);
		}
	pr_csvw_str(w, "status");
	pr_csvw_endrow(w);
}

/* One output row: the state, [sample index and draw,] mean, covariance, status. */
static void policy_row(pr_csvw *w, const double *s, int ds, long sample, const double *draw,
                       const double *mean, const double *cov, int da, int status)
{
	for (int j = 0; j < ds; j++)
		pr_csvw_num(w, s[j]);
	if (draw) {
		pr_csvw_int(w, sample);
		for (int j = 0; j < da; j++)
			pr_csvw_num(w, draw[j]);
	}
	for (int j = 0; j < da; j++)
		pr_csvw_num(w, mean[j]);
	for (int j = 0; j < da; j++)
		for (int l = j; l < da; l++)
			pr_csvw_num(w, cov[j * da + l]);
	pr_csvw_int(w, status);
	pr_csvw_endrow(w);
}

/* The scratch of pr_query_policy: one state's answer and a chunk of draws. */
typedef struct {
	pr_policy_work *ws;
	double *mean, *cov, *draws;
	int status;
} policy_scratch;

/* One query state s: its answer, then its ns rows in chunks of draws. A
 * write error sticks in w: stop, the commit reports it. */
static int policy_state(const pr_policy *p, const double *s, long ns, gsl_rng *rng,
                        policy_scratch *b, pr_csvw *w, char *err)
{
	const int ds = pr_policy_ds(p), da = pr_policy_da(p);
	int rc = pr_policy_eval(p, s, b->mean, b->cov, &b->status, b->ws, err);

	if (rc || !ns) {
		if (!rc)
			policy_row(w, s, ds, 0, NULL, b->mean, b->cov, da, b->status);
		return rc;
	}
	for (long k0 = 0; k0 < ns && !pr_csvw_status(w); k0 += POLICY_DRAWS) {
		const long m = ns - k0 < POLICY_DRAWS ? ns - k0 : POLICY_DRAWS;

		if (pr_interrupted)
			return pr_err(err, PR_EINTR, "policy: interrupted");
		if ((rc = pr_policy_gauss_sample(da, b->mean, b->cov, (int)m, rng, b->draws, err)))
			return rc;
		for (long k = 0; k < m; k++)
			policy_row(w, s, ds, k0 + k, b->draws + (size_t)k * da, b->mean, b->cov, da,
			           b->status);
	}
	return PR_OK;
}

/* A numerical failure at the state of row i of chunk: the file and line,
 * the state's largest value by magnitude and its column, then the message
 * (a state such as 1e155 beyond the training data's range makes the
 * weights or the covariance overflow). */
static void name_state(const pr_query *q, const pr_csv *chunk, long i, char *err)
{
	char msg[PR_ERRLEN];
	const double *s = q->X + (size_t)i * q->k;
	int big = 0;

	for (int j = 1; j < q->k; j++)
		if (fabs(s[j]) > fabs(s[big]))
			big = j;
	snprintf(msg, sizeof msg, "%s", err ? err : "");
	pr_err(err, PR_ENUM, "%s:%ld: state %s = %.17g: %s", pr_query_path(q), pr_csv_line(chunk, i),
	       q->k > 0 ? q->names[big] : "-", q->k > 0 ? s[big] : 0.0, msg);
}

int pr_query_policy(pr_query *q, const pr_policy *p, const char *const *anames, long ns,
                    gsl_rng *rng, pr_csvw *w, char *err)
{
	const int da = pr_policy_da(p);
	const pr_csv *chunk;
	policy_scratch b = { 0 };
	long n, i;
	int rc = PR_OK;

	b.mean = malloc((size_t)da * sizeof *b.mean);
	b.cov = malloc((size_t)da * da * sizeof *b.cov);
	b.draws = ns ? malloc((size_t)POLICY_DRAWS * da * sizeof *b.draws) : NULL;
	if (!b.mean || !b.cov || (ns && !b.draws)) {
		rc = pr_err(err, PR_ENOMEM, "policy: out of memory");
		goto done;
	}
	if (!(b.ws = pr_policy_work_new(p, err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	policy_header(q, anames, da, ns > 0, w);
	while (!(rc = next_inputs(q, &chunk, &n, err)) && n > 0 && !pr_csvw_status(w)) {
		if (pr_interrupted) {
			rc = pr_err(err, PR_EINTR, "policy: interrupted");
			break;
		}
		for (i = 0; i < n && !rc && !pr_csvw_status(w); i++)
			rc = policy_state(p, q->X + (size_t)i * q->k, ns, rng, &b, w, err);
		if (rc == PR_ENUM)
			name_state(q, chunk, i - 1, err);
		if (rc)
			break;
		pr_csvw_flush(w);
	}
done:
	pr_policy_work_free(b.ws);
	free(b.mean);
	free(b.cov);
	free(b.draws);
	return rc;
}
