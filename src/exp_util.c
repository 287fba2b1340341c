/* exp_util.c — helpers of the experiments: repetitions on threads,
 * thread-safe progress, and reading raw CSVs that hold text columns
 * (sweep, policy, mode), which the numeric pr_csv_read refuses.
 *
 * Determinism: a repetition's results depend only on (seed, k), never on
 * which thread ran it or when, so the thread count cannot change a byte. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <csv.h>

#include "csvio_priv.h"
#include "exp_priv.h"

/* ---- progress ---- */

void pr_exp_ticker_init(pr_exp_ticker *t, const pr_progress *prog, long total, const char *what)
{
	t->prog = prog;
	t->what = what;
	t->done = 0;
	t->total = total;
	pthread_mutex_init(&t->mu, NULL);
}

void pr_exp_ticker_add(pr_exp_ticker *t, long units)
{
	pthread_mutex_lock(&t->mu);
	t->done += units;
	if (t->prog && t->prog->fn)
		t->prog->fn(t->prog->user, t->done, t->total, t->what);
	pthread_mutex_unlock(&t->mu);
}

void pr_exp_ticker_destroy(pr_exp_ticker *t)
{
	pthread_mutex_destroy(&t->mu);
}

/* ---- thread pool over repetitions ---- */

typedef struct {
	int lo, hi, next;
	int failed;                 /* a job failed: start no new repetition */
	int (*job)(void *, int, char *);
	void *ctx;
	int *status;                /* hi - lo */
	char (*msg)[PR_ERRLEN];     /* hi - lo */
	pthread_mutex_t mu;
} pool;

static void *worker(void *arg)
{
	pool *p = arg;

	for (;;) {
		int k, rc;
		pthread_mutex_lock(&p->mu);
		k = p->failed || p->next >= p->hi ? -1 : p->next++;
		pthread_mutex_unlock(&p->mu);
		if (k < 0)
			return NULL;
		rc = p->job(p->ctx, k, p->msg[k - p->lo]);
		p->status[k - p->lo] = rc;
		if (rc) {
			pthread_mutex_lock(&p->mu);
			p->failed = 1;
			pthread_mutex_unlock(&p->mu);
		}
	}
}

int pr_exp_parallel(int lo, int hi, int threads, int (*job)(void *ctx, int k, char *err),
                    void *ctx, char *err)
{
	pool p;
	pthread_t *tid;
	int n = hi - lo, started = 0, i, rc = PR_OK;

	if (n <= 0)
		return PR_OK;
	memset(&p, 0, sizeof p);
	p.lo = lo;
	p.hi = hi;
	p.next = lo;
	p.job = job;
	p.ctx = ctx;
	p.status = calloc((size_t)n, sizeof *p.status);
	p.msg = calloc((size_t)n, sizeof *p.msg);
	if (threads > n)
		threads = n;
	if (threads < 1)
		threads = 1;
	tid = calloc((size_t)threads, sizeof *tid);
	if (!p.status || !p.msg || !tid) {
		free(p.status);
		free(p.msg);
		free(tid);
		return pr_err(err, PR_ENOMEM, "out of memory starting %d threads", threads);
	}
	pthread_mutex_init(&p.mu, NULL);
	if (threads == 1) {
		worker(&p);
	} else {
		for (i = 0; i < threads; ++i) {
			if (pthread_create(&tid[i], NULL, worker, &p) != 0)
				break;
			++started;
		}
		if (started == 0)
			worker(&p); /* no thread could start: run everything here */
		for (i = 0; i < started; ++i)
			pthread_join(tid[i], NULL);
	}
	pthread_mutex_destroy(&p.mu);
	for (i = 0; i < n; ++i)
		if (p.status[i]) {
			rc = p.status[i];
			pr_err(err, rc, "%s", p.msg[i]);
			break;
		}
	free(p.status);
	free(p.msg);
	free(tid);
	return rc;
}

/* ---- text CSV ---- */

struct pr_exp_table {
	char path[256];
	int ncols;         /* 0 until the header row is read */
	char **hdr;        /* ncols names */
	long nrows, cap;
	char **cell;       /* nrows x ncols fields */
	long *line;        /* file line of each data row */
};

typedef struct {
	pr_exp_table *t;
	char **row;        /* fields of the current record */
	int nfield, capfield;
	long line;         /* current file line */
	int status;
	char *err;
} reader;

static void on_field(void *s, size_t len, void *data)
{
	reader *r = data;
	char *f;

	if (r->status)
		return;
	if (r->nfield == r->capfield) {
		int cap = r->capfield ? 2 * r->capfield : 16;
		char **g = realloc(r->row, (size_t)cap * sizeof *g);
		if (!g) {
			r->status = pr_err(r->err, PR_ENOMEM, "out of memory");
			return;
		}
		r->row = g;
		r->capfield = cap;
	}
	f = malloc(len + 1);
	if (!f) {
		r->status = pr_err(r->err, PR_ENOMEM, "out of memory");
		return;
	}
	if (len)
		memcpy(f, s, len);
	f[len] = '\0';
	r->row[r->nfield++] = f;
}

static void drop_fields(reader *r)
{
	int j;

	for (j = 0; j < r->nfield; ++j)
		free(r->row[j]);
	r->nfield = 0;
}

static void on_row(int c, void *data)
{
	reader *r = data;
	pr_exp_table *t = r->t;

	(void)c;
	if (r->status) {
		drop_fields(r);
		return;
	}
	if (!t->hdr) {
		t->hdr = malloc((size_t)r->nfield * sizeof *t->hdr);
		if (!t->hdr) {
			r->status = pr_err(r->err, PR_ENOMEM, "out of memory");
			drop_fields(r);
			return;
		}
		memcpy(t->hdr, r->row, (size_t)r->nfield * sizeof *r->row);
		t->ncols = r->nfield;
		r->nfield = 0;
		return;
	}
	if (r->nfield != t->ncols) {
		r->status = pr_err(r->err, PR_EIO, "%s:%ld: %d fields, but the header has %d",
		                   t->path, r->line, r->nfield, t->ncols);
		drop_fields(r);
		return;
	}
	if (t->nrows == t->cap) {
		long cap = t->cap ? 2 * t->cap : 256;
		char **g = realloc(t->cell, (size_t)cap * (size_t)t->ncols * sizeof *g);
		long *l = g ? realloc(t->line, (size_t)cap * sizeof *l) : NULL;
		if (g)
			t->cell = g;
		if (!l) {
			r->status = pr_err(r->err, PR_ENOMEM, "out of memory");
			drop_fields(r);
			return;
		}
		t->line = l;
		t->cap = cap;
	}
	memcpy(t->cell + (size_t)t->nrows * (size_t)t->ncols, r->row,
	       (size_t)t->ncols * sizeof *r->row);
	t->line[t->nrows++] = r->line;
	r->nfield = 0;
}

void pr_exp_table_free(pr_exp_table *t)
{
	long i;

	if (!t)
		return;
	for (i = 0; i < t->ncols; ++i)
		free(t->hdr[i]);
	for (i = 0; i < t->nrows * t->ncols; ++i)
		free(t->cell[i]);
	free(t->hdr);
	free(t->cell);
	free(t->line);
	free(t);
}

int pr_exp_table_read(const char *path, pr_exp_table **out, char *err)
{
	struct csv_parser p;
	reader r;
	FILE *fp;
	char *buf = NULL;
	size_t cap = 0;
	ssize_t len;

	*out = NULL;
	memset(&r, 0, sizeof r);
	r.err = err;
	r.t = calloc(1, sizeof *r.t);
	if (!r.t)
		return pr_err(err, PR_ENOMEM, "out of memory");
	snprintf(r.t->path, sizeof r.t->path, "%s", path);
	fp = fopen(path, "rb");
	if (!fp) {
		pr_exp_table_free(r.t);
		return pr_err(err, PR_EIO, "%s: cannot open: %s", path, strerror(errno));
	}
	if (csv_init(&p, CSV_APPEND_NULL) != 0) {
		fclose(fp);
		pr_exp_table_free(r.t);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	while (!r.status && (len = getline(&buf, &cap, fp)) != -1) {
		r.line++;
		if (csv_parse(&p, buf, (size_t)len, on_field, on_row, &r) != (size_t)len && !r.status)
			r.status = pr_err(err, PR_EIO, "%s:%ld: malformed CSV: %s", path, r.line,
			                  csv_strerror(csv_error(&p)));
	}
	if (!r.status && ferror(fp))
		r.status = pr_err(err, PR_EIO, "%s: read error: %s", path, strerror(errno));
	if (!r.status)
		csv_fini(&p, on_field, on_row, &r);
	if (!r.status && !r.t->hdr)
		r.status = pr_err(err, PR_EIO, "%s: empty file: no header row", path);
	drop_fields(&r);
	csv_free(&p);
	free(buf);
	free(r.row);
	fclose(fp);
	if (r.status) {
		pr_exp_table_free(r.t);
		return r.status;
	}
	*out = r.t;
	return PR_OK;
}

long pr_exp_table_nrows(const pr_exp_table *t)
{
	return t->nrows;
}

int pr_exp_table_ncols(const pr_exp_table *t)
{
	return t->ncols;
}

const char *pr_exp_table_name(const pr_exp_table *t, int j)
{
	return t->hdr[j];
}

const char *pr_exp_table_path(const pr_exp_table *t)
{
	return t->path;
}

long pr_exp_table_line(const pr_exp_table *t, long i)
{
	return t->line[i];
}

int pr_exp_table_col(const pr_exp_table *t, const char *name, char *err)
{
	int j;

	for (j = 0; j < t->ncols; ++j)
		if (strcmp(t->hdr[j], name) == 0)
			return j;
	return pr_err(err, PR_EIO, "%s: no column '%s'", t->path, name);
}

const char *pr_exp_table_str(const pr_exp_table *t, long i, int j)
{
	return t->cell[(size_t)i * (size_t)t->ncols + (size_t)j];
}

int pr_exp_table_num(const pr_exp_table *t, long i, int j, double *v, char *err)
{
	const char *s = pr_exp_table_str(t, i, j);

	if (pr_csv_parse_double(s, v))
		return pr_err(err, PR_EIO, "%s:%ld: column '%s': not a finite number: '%.40s'",
		              t->path, t->line[i], t->hdr[j], s);
	return PR_OK;
}

int pr_exp_table_int(const pr_exp_table *t, long i, int j, long lo, long hi, long *v, char *err)
{
	double x;
	int rc = pr_exp_table_num(t, i, j, &x, err);

	if (rc)
		return rc;
	if (x != floor(x) || x < (double)lo || x > (double)hi)
		return pr_err(err, PR_EIO, "%s:%ld: column '%s': expected an integer in %ld..%ld, got '%.40s'",
		              t->path, t->line[i], t->hdr[j], lo, hi, pr_exp_table_str(t, i, j));
	*v = (long)x;
	return PR_OK;
}

int pr_exp_int_list(const pr_list *l, const char *key, int *out, char *err)
{
	int i;

	for (i = 0; i < l->n; ++i) {
		if (l->v[i] != floor(l->v[i]) || l->v[i] < 1 || l->v[i] > 1e8)
			return pr_err(err, PR_EINVAL, "%s: values must be whole numbers >= 1 (got %g)",
			              key, l->v[i]);
		out[i] = (int)l->v[i];
	}
	return PR_OK;
}
