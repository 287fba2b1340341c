/* exp_util.c — helpers of the experiments: random streams, the
 * repetitions and variant a process runs, repetitions on threads,
 * thread-safe progress, and reading raw CSVs that hold text columns
 * (sweep, policy, mode), which the numeric pr_csv_read refuses; both go
 * through the one CSV reader, pr_csv_scan.
 *
 * Determinism: a repetition's results depend only on (seed, k), never on
 * which thread ran it or when, so the thread count cannot change a byte. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "poolreps/sim.h"
#include "csvio_priv.h"
#include "exp_priv.h"

/* ---- streams, repetitions, variants ---- */

/* splitmix64 finaliser: decorrelates nearby (seed, stream, index) triples. */
static unsigned long long mix(unsigned long long z)
{
	z += 0x9e3779b97f4a7c15ULL;
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
	return z ^ (z >> 31);
}

gsl_rng *pr_exp_rng(unsigned long seed, unsigned long stream, unsigned long index)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	unsigned long long h;

	if (!r)
		return NULL;
	h = mix(mix(mix((unsigned long long)seed) ^ (unsigned long long)stream) ^ (unsigned long long)index);
	/* mt19937 takes a 32-bit seed; 0 would select GSL's default seed */
	h &= 0xffffffffULL;
	gsl_rng_set(r, h ? (unsigned long)h : 1UL);
	return r;
}

void pr_exp_reps(const pr_config *cfg, int *lo, int *hi)
{
	if (cfg->run.repetition >= 0) {
		*lo = cfg->run.repetition;
		*hi = cfg->run.repetition + 1;
	} else {
		*lo = 0;
		*hi = cfg->run.repetitions;
	}
}

int pr_exp_check_variant(const pr_config *cfg, int n, char *err)
{
	char at[PR_WHERE_LEN];

	if (cfg->run.variant < n)
		return PR_OK;
	pr_config_where(cfg, "experiment.variant", at, sizeof at);
	if (n == 0)
		return pr_err(err, PR_EINVAL, "%s: experiment.variant: %d, but %s has no variants",
		              at, cfg->run.variant, cfg->run.name);
	return pr_err(err, PR_EINVAL, "%s: experiment.variant: %d, but %s has %d variants (0..%d)",
	              at, cfg->run.variant, cfg->run.name, n, n - 1);
}

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

/* ---- text CSV (through the one reader, pr_csv_scan) ---- */

struct pr_exp_table {
	char *path;
	int ncols;         /* 0 until the header row is read */
	char **hdr;        /* ncols names */
	long nrows, cap;
	char **cell;       /* nrows x ncols fields */
	long *line;        /* file line of each data row */
};

/* n strings copied into a new array at *out. */
static int copy_fields(int n, char **fields, char **out, const char *path, char *err)
{
	int j;

	for (j = 0; j < n; ++j)
		if (!(out[j] = strdup(fields[j]))) {
			while (j--)
				free(out[j]);
			return pr_err(err, PR_ENOMEM, "%s: out of memory", path);
		}
	return PR_OK;
}

static int table_header(void *user, const char *path, long line, int n, char **names, char *err)
{
	pr_exp_table *t = user;

	(void)line;
	if (!(t->hdr = calloc((size_t)n, sizeof *t->hdr)))
		return pr_err(err, PR_ENOMEM, "%s: out of memory", path);
	if (copy_fields(n, names, t->hdr, path, err))
		return PR_ENOMEM;
	t->ncols = n;
	return PR_OK;
}

static int table_row(void *user, const char *path, long line, int n, char **fields, char *err)
{
	pr_exp_table *t = user;

	if (t->nrows == t->cap) {
		long cap = t->cap ? 2 * t->cap : 256;
		char **g = realloc(t->cell, (size_t)cap * (size_t)n * sizeof *g);
		long *l = g ? realloc(t->line, (size_t)cap * sizeof *l) : NULL;
		if (g)
			t->cell = g;
		if (!l)
			return pr_err(err, PR_ENOMEM, "%s: out of memory", path);
		t->line = l;
		t->cap = cap;
	}
	if (copy_fields(n, fields, t->cell + (size_t)t->nrows * (size_t)n, path, err))
		return PR_ENOMEM;
	t->line[t->nrows++] = line;
	return PR_OK;
}

void pr_exp_table_free(pr_exp_table *t)
{
	long i;

	if (!t)
		return;
	for (i = 0; t->hdr && i < t->ncols; ++i)
		free(t->hdr[i]);
	for (i = 0; i < t->nrows * t->ncols; ++i)
		free(t->cell[i]);
	free(t->hdr);
	free(t->cell);
	free(t->line);
	free(t->path);
	free(t);
}

int pr_exp_table_read(const char *path, pr_exp_table **out, char *err)
{
	pr_exp_table *t = calloc(1, sizeof *t);
	int rc;

	*out = NULL;
	if (!t || !(t->path = strdup(path))) {
		free(t);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	/* raw tables are written whole by poolreps: a missing last line end
	 * means a truncated file */
	if ((rc = pr_csv_scan(path, PR_CSV_COMPLETE, table_header, table_row, t, err))) {
		pr_exp_table_free(t);
		return rc;
	}
	*out = t;
	return PR_OK;
}

int pr_exp_table_ncols(const pr_exp_table *t)
{
	return t->ncols;
}

const char *pr_exp_table_name(const pr_exp_table *t, int j)
{
	return t->hdr[j];
}

long pr_exp_table_nrows(const pr_exp_table *t)
{
	return t->nrows;
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

int pr_exp_expert_state(const pr_config *cfg, int nballs, gsl_rng *rng, double *s, double a[2],
                        char *err)
{
	char why[PR_ERRLEN] = "";
	int t, rc;

	for (t = 0; t < cfg->start.max_tries; ++t) {
		if ((rc = pr_sim_sample_start(&cfg->table, &cfg->start, nballs, rng, s, err)))
			return rc;
		if (pr_sim_ghost_action(&cfg->table, &cfg->sim, &cfg->reward, &cfg->expert, s, a,
		                        NULL, why) == PR_OK)
			return PR_OK;
	}
	return pr_err(err, PR_EINVAL, "%s: no start state the ghost-ball expert can play in "
	              "%d draws (last: %s)", cfg->run.name, cfg->start.max_tries, why);
}

pr_csvw *pr_exp_csv_open(char *err, const char *fmt, ...)
{
	char path[PR_PATHLEN];
	va_list ap;

	va_start(ap, fmt);
	vsnprintf(path, sizeof path, fmt, ap);
	va_end(ap);
	return pr_csvw_open(path, err);
}
