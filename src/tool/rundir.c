/* rundir.c — what `poolreps CONFIG`, `poolreps merge` and `poolreps config`
 * do (rundir.h): run an experiment into an output folder with its
 * provenance (outdir.c: all or nothing), and merge per-process outputs.
 */
#define _DEFAULT_SOURCE /* strndup */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "poolreps/csvio.h"
#include "poolreps/exp.h"
#include "poolreps/rundir.h"
#include "exp_priv.h"
#include "outdir.h"


static void config_text(FILE *fp, const void *cfg)
{
	pr_config_write(cfg, fp);
}

int pr_rundir_config(const pr_config *cfg, const char *path, char *err)
{
	return pr_outdir_write_text(path, config_text, cfg, err);
}

static int run_work(const pr_config *cfg, const char *dir, const void *arg, char *err)
{
	const pr_rundir_args *a = arg;
	const pr_experiment *e = pr_exp_find(cfg->run.name);
	pr_variants variants;
	char at[PR_WHERE_LEN];
	int rc;

	if (!e)
		return pr_err(err, PR_EINVAL, "%s: experiment.name: '%s' is not available",
		              pr_config_where(cfg, "experiment.name", at, sizeof at), cfg->run.name);
	if ((rc = pr_exp_variants(cfg, &variants, err)))
		return rc;
	rc = e->run(cfg, dir, &a->progress, err);
	if (rc == PR_OK && e->summarize)
		rc = e->summarize(cfg, dir, err);
	return rc;
}

int pr_rundir_run(const pr_config *cfg, const pr_rundir_args *a, char *err)
{
	char dir[PR_PATHLEN];

	if (a->output && snprintf(dir, sizeof dir, "%s", a->output) >= (int)sizeof dir)
		return pr_err(err, PR_EINVAL, "%.100s...: path too long", a->output);
	/* the registry's folder (the simulator figures' data: results/sim, as
	 * results/figures is where `make reproduce` gathers the drawn figures) */
	if (!a->output)
		snprintf(dir, sizeof dir, "results/%s", pr_exp_find(cfg->run.name)->folder);
	return pr_outdir_run(cfg, &a->prov, dir, run_work, a, err);
}

/* ---- merge ---- */

typedef struct {
	long rep;
	int var;  /* experiment.variant of the input, -1 for all */
	int src;
	long row;
} mrow;

static int cmp_mrow(const void *x, const void *y)
{
	const mrow *a = x, *b = y;

	if (a->rep != b->rep)
		return a->rep < b->rep ? -1 : 1;
	if (a->var != b->var)
		return a->var < b->var ? -1 : 1;
	if (a->src != b->src)
		return a->src < b->src ? -1 : 1;
	return a->row < b->row ? -1 : a->row > b->row;
}

/* Where each row of a merged raw CSV came from, so that an error a summary
 * reports at a line of the merged file pr_names the source file and line. */
typedef struct {
	char *name;
	long n;
	int *src;
	long *line;
} origin;

typedef struct {
	const pr_rundir_args *a;
	origin *o;
	int no;
	int nrep;          /* experiment.repetitions */
	int *rep;          /* per input: the repetition its config.ini holds, -1 all */
	int *var;          /* per input: its experiment.variant, -1 all */
} merge_ctx;

/* Input k's config.ini into c. */
static int input_config(const pr_rundir_args *a, int k, pr_config *c, char *err)
{
	char path[PR_PATHLEN + 16];
	struct stat st;
	int rc;

	pr_config_init(c, pr_exp_config);
	snprintf(path, sizeof path, "%s/config.ini", a->inputs[k]);
	/* a run folder holds a plain file: a FIFO would block the read */
	if (stat(path, &st) == 0 && !S_ISREG(st.st_mode))
		return pr_err(err, PR_EIO, "%s: not a regular file", path);
	if ((rc = pr_config_load(c, path, err)))
		return rc;
	/* a run publishes provenance.txt last: without it the folder is no finished run */
	snprintf(path, sizeof path, "%s/provenance.txt", a->inputs[k]);
	if (stat(path, &st) != 0)
		return pr_err(err, pr_errno_status(), "%s: not a finished run: %s", path, strerror(errno));
	if (!S_ISREG(st.st_mode))
		return pr_err(err, PR_EIO, "%s: not a regular file", path);
	return PR_OK;
}

/* One process writes as many rows of a raw CSV for every repetition: a row
 * lost or repeated (a truncated or edited file) shows as another count.
 * rows are sorted by repetition. */
static int same_rows_each_repetition(const merge_ctx *m, const mrow *rows, long n, const char *name,
                                     char *err)
{
	long i, first = 0, count0 = -1;
	int src0 = 0;

	for (i = 1; i <= n; ++i) {
		if (i < n && rows[i].rep == rows[first].rep)
			continue;
		if (count0 < 0) {
			count0 = i - first;
			src0 = rows[first].src;
		} else if (i - first != count0) {
			return pr_err(err, PR_EIO, "%s/%s: %ld rows of repetition %ld, but %s/%s has %ld of "
			              "repetition %ld (a row lost or repeated?)", m->a->inputs[rows[first].src],
			              name, i - first, rows[first].rep, m->a->inputs[src0], name, count0,
			              rows[0].rep);
		}
		first = i;
	}
	/* a repetition without rows while others have some */
	if (count0 > 0 && n != count0 * m->nrep) {
		long r;
		int k;
		for (r = 0, i = 0; i < n && rows[i].rep == r; i += count0, ++r)
			;
		for (k = 0; k < m->a->ninputs - 1 && m->rep[k] >= 0 && m->rep[k] != r; ++k)
			;
		return pr_err(err, PR_EIO, "%s/%s: no rows of repetition %ld, but %s/%s has %ld of "
		              "repetition %ld", m->a->inputs[k], name, r, m->a->inputs[src0], name,
		              count0, rows[0].rep);
	}
	return PR_OK;
}

/* Read the raw CSV `name` of every input folder (complete files, one header,
 * consistent field counts: the one reader), order the rows by the leading
 * repetition column and write them; a repetition in two inputs is an error. */
static int merge_csv(merge_ctx *m, const char *name, const char *outdir, char *err)
{
	const pr_rundir_args *a = m->a;
	pr_exp_table **t = calloc((size_t)a->ninputs, sizeof *t);
	mrow *rows = NULL;
	origin *o = &m->o[m->no];
	long n = 0, i;
	char path[PR_PATHLEN];
	int k, j, rc = PR_OK;
	pr_csvw *w = NULL;

	if (!t)
		return pr_err(err, PR_ENOMEM, "out of memory merging %s", name);
	for (k = 0; rc == PR_OK && k < a->ninputs; ++k) {
		snprintf(path, sizeof path, "%s/%s", a->inputs[k], name);
		if ((rc = pr_exp_table_read(path, &t[k], err)))
			break;
		if (pr_exp_table_ncols(t[k]) != pr_exp_table_ncols(t[0]))
			rc = pr_err(err, PR_EIO, "%s:1: header differs from %s/%s", path, a->inputs[0], name);
		for (j = 0; rc == PR_OK && j < pr_exp_table_ncols(t[k]); ++j)
			if (strcmp(pr_exp_table_name(t[k], j), pr_exp_table_name(t[0], j)) != 0)
				rc = pr_err(err, PR_EIO, "%s:1: header differs from %s/%s", path, a->inputs[0], name);
		n += pr_exp_table_nrows(t[k]);
	}
	if (rc == PR_OK && !(rows = malloc((size_t)(n ? n : 1) * sizeof *rows)))
		rc = pr_err(err, PR_ENOMEM, "out of memory merging %s", name);
	for (n = 0, k = 0; rc == PR_OK && k < a->ninputs; ++k)
		for (i = 0; rc == PR_OK && i < pr_exp_table_nrows(t[k]); ++i, ++n) {
			rows[n].src = k;
			rows[n].var = m->var[k];
			rows[n].row = i;
			rc = pr_exp_table_int(t[k], i, 0, 0, m->nrep - 1, &rows[n].rep, err);
			/* a run of one repetition holds only that one's rows */
			if (rc == PR_OK && m->rep[k] >= 0 && rows[n].rep != m->rep[k])
				rc = pr_err(err, PR_EIO, "%s/%s:%ld: repetition %ld, but %s/config.ini ran "
				            "only repetition %d", a->inputs[k], name, pr_exp_table_line(t[k], i),
				            rows[n].rep, a->inputs[k], m->rep[k]);
		}
	if (rc == PR_OK && n > 0)
		qsort(rows, (size_t)n, sizeof *rows, cmp_mrow);
	/* inputs split by variant share repetitions, each its own rows */
	for (i = 1; rc == PR_OK && i < n; ++i)
		if (rows[i].rep == rows[i - 1].rep && rows[i].src != rows[i - 1].src &&
		    (rows[i].var == rows[i - 1].var || rows[i - 1].var < 0))
			rc = pr_err(err, PR_EINVAL, "%s/%s and %s/%s both hold repetition %ld",
			            a->inputs[rows[i - 1].src], name, a->inputs[rows[i].src], name,
			            rows[i].rep);
	if (rc == PR_OK)
		rc = same_rows_each_repetition(m, rows, n, name, err);
	if (rc == PR_OK) {
		o->name = strdup(name);
		o->src = malloc((size_t)(n ? n : 1) * sizeof *o->src);
		o->line = malloc((size_t)(n ? n : 1) * sizeof *o->line);
		m->no++;
		if (!o->name || !o->src || !o->line)
			rc = pr_err(err, PR_ENOMEM, "out of memory merging %s", name);
	}
	if (rc == PR_OK) {
		snprintf(path, sizeof path, "%s/%s", outdir, name);
		if (!(w = pr_csvw_open(path, err)))
			rc = PR_EIO;
	}
	if (rc == PR_OK) {
		for (j = 0; j < pr_exp_table_ncols(t[0]); ++j)
			pr_csvw_str(w, pr_exp_table_name(t[0], j));
		pr_csvw_endrow(w);
		for (i = 0; i < n; ++i) {
			const pr_exp_table *src = t[rows[i].src];
			for (j = 0; j < pr_exp_table_ncols(src); ++j)
				pr_csvw_str(w, pr_exp_table_str(src, rows[i].row, j));
			pr_csvw_endrow(w);
			o->src[i] = rows[i].src;
			o->line[i] = pr_exp_table_line(src, rows[i].row);
		}
		o->n = n;
		rc = pr_csvw_close(w, err);
	}
	for (k = 0; k < a->ninputs; ++k)
		pr_exp_table_free(t[k]);
	free(t);
	free(rows);
	return rc;
}

static int is_raw_csv(const char *dir, const char *name)
{
	char path[PR_PATHLEN], buf[16] = "";
	size_t n = strlen(name);
	struct stat st;
	FILE *fp;

	if (n < 5 || strcmp(name + n - 4, ".csv") != 0)
		return 0;
	snprintf(path, sizeof path, "%s/%s", dir, name);
	/* a FIFO would block the open */
	if (stat(path, &st) != 0 || !S_ISREG(st.st_mode))
		return 0;
	/* unreadable: it may be a raw CSV, so the caller refuses it */
	if (!(fp = fopen(path, "r")))
		return -1;
	if (!fgets(buf, sizeof buf, fp))
		buf[0] = '\0';
	fclose(fp);
	return strncmp(buf, "repetition,", 11) == 0;
}

/* The raw CSVs (leading repetition column) of folder dir; a .csv file it
 * cannot read is an error. */
static int raw_csvs(const char *dir, pr_names *out, char *err)
{
	pr_names all = {NULL, 0};
	int i, rc = pr_outdir_list(dir, &all, err);

	for (i = 0; rc == PR_OK && i < all.n; ++i) {
		int raw = is_raw_csv(dir, all.name[i]);
		if (raw < 0)
			rc = pr_err(err, pr_errno_status(), "%s/%s: cannot open: %s", dir, all.name[i],
			            strerror(errno));
		else if (raw && pr_names_add(out, all.name[i], strlen(all.name[i])))
			rc = pr_err(err, PR_ENOMEM, "out of memory");
	}
	pr_names_free(&all);
	return rc;
}

/* An error at "<dir>/<name>:<line>:" of a merged file: name the source. */
static void to_source(char *err, const merge_ctx *m, const char *dir)
{
	char out[PR_ERRLEN], *end;
	size_t n = strlen(dir);
	long line, i;
	int k;

	if (strncmp(err, dir, n) != 0 || err[n] != '/')
		return;
	for (k = 0; k < m->no; ++k) {
		size_t len = strlen(m->o[k].name);
		if (strncmp(err + n + 1, m->o[k].name, len) != 0 || err[n + 1 + len] != ':')
			continue;
		line = strtol(err + n + 2 + len, &end, 10);
		i = line - 2; /* line 1 is the header */
		if (*end != ':' || i < 0 || i >= m->o[k].n)
			return;
		snprintf(out, sizeof out, "%s/%s:%ld%s", m->a->inputs[m->o[k].src[i]], m->o[k].name,
		         m->o[k].line[i], end);
		memcpy(err, out, strlen(out) + 1);
		return;
	}
}

static int merge_work(const pr_config *cfg, const char *dir, const void *arg, char *err)
{
	const pr_rundir_args *a = arg;
	const pr_experiment *e = pr_exp_find(cfg->run.name);
	pr_names raw = {NULL, 0}, other = {NULL, 0};
	merge_ctx m = {a, NULL, 0, cfg->run.repetitions, NULL, NULL};
	pr_config c;
	int rc = PR_OK, i, k;

	m.rep = malloc((size_t)a->ninputs * sizeof *m.rep);
	m.var = malloc((size_t)a->ninputs * sizeof *m.var);
	if (!m.rep || !m.var)
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	for (k = 0; rc == PR_OK && k < a->ninputs; ++k)
		if ((rc = input_config(a, k, &c, err)) == PR_OK) {
			m.rep[k] = c.run.repetition;
			m.var[k] = c.run.variant;
		}
	if (rc == PR_OK)
		rc = raw_csvs(a->inputs[0], &raw, err);
	/* every input holds the same raw CSVs */
	for (k = 1; rc == PR_OK && k < a->ninputs; ++k) {
		rc = raw_csvs(a->inputs[k], &other, err);
		for (i = 0; rc == PR_OK && i < raw.n + other.n; ++i) {
			const char *nm = i < raw.n ? raw.name[i] : other.name[i - raw.n];
			if (!pr_names_has(i < raw.n ? &other : &raw, nm))
				rc = pr_err(err, PR_EIO, "%s/%s: %s, but not in %s", i < raw.n ? a->inputs[0] : a->inputs[k],
				            nm, "a raw CSV of this run", i < raw.n ? a->inputs[k] : a->inputs[0]);
		}
		pr_names_free(&other);
	}
	if (rc == PR_OK && raw.n && !(m.o = calloc((size_t)raw.n, sizeof *m.o)))
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	for (i = 0; rc == PR_OK && i < raw.n; ++i)
		rc = merge_csv(&m, raw.name[i], dir, err);
	if (rc == PR_OK && e && e->summarize && (rc = e->summarize(cfg, dir, err)))
		to_source(err, &m, dir);
	for (i = 0; i < m.no; ++i) {
		free(m.o[i].name);
		free(m.o[i].src);
		free(m.o[i].line);
	}
	free(m.o);
	free(m.rep);
	free(m.var);
	pr_names_free(&raw);
	return rc;
}

/* Which input holds each (repetition, variant) cell of the merged run: every
 * cell by exactly one input, as one process would have written it. nv is
 * the experiment's variant count (0: it has none). */
static int check_cells(const pr_rundir_args *a, const pr_config *cfg, int nv, char *err)
{
	const int nc = nv > 0 ? nv : 1, nrep = cfg->run.repetitions;
	int *held = calloc((size_t)nrep * (size_t)nc, sizeof *held);
	pr_config c;
	int rc = held ? PR_OK : pr_err(err, PR_ENOMEM, "out of memory"), k, r, v;

	for (k = 0; rc == PR_OK && k < a->ninputs; ++k) {
		int r0, v0;

		if ((rc = input_config(a, k, &c, err)))
			break;
		r0 = c.run.repetition;
		v0 = c.run.variant;
		for (r = r0 < 0 ? 0 : r0; rc == PR_OK && r < (r0 < 0 ? nrep : r0 + 1); ++r)
			for (v = v0 < 0 ? 0 : v0; rc == PR_OK && v < (v0 < 0 ? nc : v0 + 1); ++v) {
				int *h = &held[(size_t)r * (size_t)nc + (size_t)v];
				if (*h)
					rc = nv ? pr_err(err, PR_EINVAL, "%s and %s both hold repetition %d of variant %d",
					                 a->inputs[*h - 1], a->inputs[k], r, v)
					        : pr_err(err, PR_EINVAL, "%s and %s both hold repetition %d",
					                 a->inputs[*h - 1], a->inputs[k], r);
				*h = k + 1;
			}
	}
	for (r = 0; rc == PR_OK && r < nrep; ++r)
		for (v = 0; rc == PR_OK && v < nc; ++v)
			if (!held[(size_t)r * (size_t)nc + (size_t)v])
				rc = nv ? pr_err(err, PR_EINVAL, "merge: no input ran repetition %d of variant %d "
				                 "(experiment.repetitions = %d, %d variants)", r, v, nrep, nv)
				        : pr_err(err, PR_EINVAL, "merge: no input ran repetition %d "
				                 "(experiment.repetitions = %d)", r, nrep);
	free(held);
	return rc;
}

int pr_rundir_merge(const pr_rundir_args *a, char *err)
{
	/* threads change no output byte (docs/cluster.md) */
	static const char *const may_differ[] = {"experiment.repetition", "experiment.variant",
	                                         "experiment.threads", NULL};
	pr_provenance prov = a->prov;
	pr_config cfg, other;
	pr_variants variants;
	char key[64], va[160], vb[160];
	char *out, *in;
	int rc, k, d;

	if (!a->output)
		return pr_err(err, PR_EINVAL, "merge: -o DIR is required");
	if (a->ninputs < 1)
		return pr_err(err, PR_EINVAL, "merge: no input folders given");
	/* the merged run is described by the inputs' own configuration, which
	 * must agree in everything but the repetition and the variant */
	if ((rc = input_config(a, 0, &cfg, err)))
		return rc;
	for (k = 1; rc == PR_OK && k < a->ninputs; ++k) {
		if ((rc = input_config(a, k, &other, err)))
			break;
		d = pr_config_diff(&cfg, &other, may_differ, key, sizeof key, va, vb, sizeof va);
		if (d < 0)
			rc = pr_err(err, PR_ENOMEM, "out of memory");
		else if (d)
			rc = pr_err(err, PR_EINVAL, "%s/config.ini: %s = %s, but %s/config.ini has %s (merged "
			            "runs may differ only in experiment.repetition, experiment.variant and "
			            "experiment.threads)", a->inputs[k], key, vb, a->inputs[0], va);
	}
	cfg.run.variant = -1;
	if (rc == PR_OK)
		rc = pr_exp_variants(&cfg, &variants, err);
	if (rc == PR_OK)
		rc = check_cells(a, &cfg, variants.n, err);
	if (rc == PR_OK)
		rc = pr_outdir_versions(a->inputs, a->ninputs, a->allow_versions, (char **)&prov.versions, err);
	if (rc)
		return rc;
	/* writing into one of the inputs would replace what is being read */
	out = realpath(a->output, NULL);
	for (k = 0; out && k < a->ninputs; ++k) {
		in = realpath(a->inputs[k], NULL);
		rc = in && strcmp(in, out) == 0;
		free(in);
		if (rc) {
			free(out);
			free((char *)prov.versions);
			return pr_err(err, PR_EINVAL, "merge: -o %s is also an input folder", a->output);
		}
	}
	free(out);
	cfg.run.repetition = -1;
	cfg.run.variant = -1;
	rc = pr_outdir_run(&cfg, &prov, a->output, merge_work, a, err);
	free((char *)prov.versions);
	return rc;
}
