/* csvio.c — numeric CSV tables read through libcsv, and an atomic writer.
 *
 * The reader feeds libcsv one physical line at a time so that every record
 * can be reported with the file line it ends on. The writer never writes a
 * non-finite number and writes files under a temporary name that is renamed
 * only when the file is complete (pr_csvw_close).
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <csv.h>

#include "poolreps/csvio.h"
#include "csvio_priv.h"

#define MAX_FIELD 4096        /* bytes in one field */
#define MAX_LINE (1L << 24)   /* bytes in one physical line */
#define MAX_COLS 100000

struct pr_csv {
	int ncols;
	char **names;
	long nrows, cap;
	double *data;
	long *lines;
	char path[256];
};

pr_csv *pr_csv_new(int ncols, const char *const *names, char *err)
{
	pr_csv *t;
	int j;

	if (ncols < 1 || ncols > MAX_COLS) {
		pr_err(err, PR_EINVAL, "table: %d columns (must be 1..%d)", ncols, MAX_COLS);
		return NULL;
	}
	t = calloc(1, sizeof *t);
	if (!t || !(t->names = calloc((size_t)ncols, sizeof *t->names))) {
		free(t);
		pr_err(err, PR_ENOMEM, "out of memory");
		return NULL;
	}
	t->ncols = ncols;
	for (j = 0; j < ncols; ++j) {
		if (!(t->names[j] = strdup(names[j]))) {
			pr_csv_free(t);
			pr_err(err, PR_ENOMEM, "out of memory");
			return NULL;
		}
	}
	return t;
}

void pr_csv_free(pr_csv *t)
{
	int j;

	if (!t)
		return;
	if (t->names)
		for (j = 0; j < t->ncols; ++j)
			free(t->names[j]);
	free(t->names);
	free(t->data);
	free(t->lines);
	free(t);
}

int pr_csv_ncols(const pr_csv *t) { return t->ncols; }
long pr_csv_nrows(const pr_csv *t) { return t->nrows; }
const char *pr_csv_name(const pr_csv *t, int j) { return t->names[j]; }
double pr_csv_get(const pr_csv *t, long i, int j) { return t->data[i * t->ncols + j]; }
const double *pr_csv_row(const pr_csv *t, long i) { return t->data + i * t->ncols; }
long pr_csv_line(const pr_csv *t, long i) { return t->lines ? t->lines[i] : i + 2; }
const char *pr_csv_path(const pr_csv *t) { return t->path[0] ? t->path : "<table>"; }

int pr_csv_find(const pr_csv *t, const char *name)
{
	int j;

	for (j = 0; j < t->ncols; ++j)
		if (strcmp(t->names[j], name) == 0)
			return j;
	return -1;
}

static int add_row(pr_csv *t, const double *row, long line, char *err)
{
	if (t->nrows == t->cap) {
		long cap = t->cap ? 2 * t->cap : 64;
		double *d = realloc(t->data, (size_t)cap * (size_t)t->ncols * sizeof *d);
		long *l;

		if (!d)
			return pr_err(err, PR_ENOMEM, "out of memory reading %ld rows", t->nrows);
		t->data = d;
		l = realloc(t->lines, (size_t)cap * sizeof *l);
		if (!l)
			return pr_err(err, PR_ENOMEM, "out of memory reading %ld rows", t->nrows);
		t->lines = l;
		t->cap = cap;
	}
	memcpy(t->data + t->nrows * t->ncols, row, (size_t)t->ncols * sizeof *row);
	t->lines[t->nrows++] = line;
	return PR_OK;
}

int pr_csv_add_row(pr_csv *t, const double *row, char *err)
{
	int j;

	for (j = 0; j < t->ncols; ++j)
		if (!isfinite(row[j]))
			return pr_err(err, PR_ENUM, "column '%s': refusing to store a non-finite value",
			              t->names[j]);
	return add_row(t, row, t->nrows + 2, err);
}

int pr_csv_parse_double(const char *s, double *v)
{
	char *end;

	while (*s == ' ' || *s == '\t')
		++s;
	if (!*s)
		return PR_EINVAL;
	errno = 0;
	*v = strtod(s, &end);
	while (*end == ' ' || *end == '\t' || *end == '\r')
		++end;
	/* ERANGE also flags subnormal results, which are exact enough to keep
	 * (the writer may print them); only overflow and underflow to 0 fail */
	if (end == s || *end || !isfinite(*v) || (errno == ERANGE && *v == 0))
		return PR_EINVAL;
	return PR_OK;
}

/* Control characters in a quoted field would break a one-line error message:
 * header names may not hold them, and rejected values show them as '?'. */
static int has_control(const char *s)
{
	for (; *s; ++s)
		if ((unsigned char)*s < 0x20 || *s == 0x7f)
			return 1;
	return 0;
}

static void visible(char *s)
{
	for (; *s; ++s)
		if ((unsigned char)*s < 0x20 || *s == 0x7f)
			*s = '?';
}

/* State shared with the libcsv callbacks. */
typedef struct {
	pr_csv *t;
	const char *path;
	long line;
	int nfield, header_done, status;
	char **hdr;
	int nhdr, cap_hdr;
	double *row;
	char *err;
} reader;

static void on_field(void *s, size_t len, void *data)
{
	reader *r = data;
	char buf[MAX_FIELD + 1];
	double v;

	if (r->status)
		return;
	if (len > MAX_FIELD) {
		r->status = pr_err(r->err, PR_EIO, "%s:%ld: field %d is longer than %d bytes",
		                   r->path, r->line, r->nfield + 1, MAX_FIELD);
		return;
	}
	if (s)
		memcpy(buf, s, len);
	buf[len] = '\0';
	if (len && memchr(buf, '\0', len)) {
		r->status = pr_err(r->err, PR_EIO, "%s:%ld: field %d contains a NUL byte",
		                   r->path, r->line, r->nfield + 1);
		return;
	}
	if (!r->header_done) {
		if (r->nhdr >= MAX_COLS) {
			r->status = pr_err(r->err, PR_EIO, "%s:%ld: more than %d columns",
			                   r->path, r->line, MAX_COLS);
			return;
		}
		if (r->nhdr == r->cap_hdr) {
			int cap = r->cap_hdr ? 2 * r->cap_hdr : 16;
			char **h = realloc(r->hdr, (size_t)cap * sizeof *h);
			if (!h) {
				r->status = pr_err(r->err, PR_ENOMEM, "out of memory");
				return;
			}
			r->hdr = h;
			r->cap_hdr = cap;
		}
		if (!(r->hdr[r->nhdr] = strdup(buf))) {
			r->status = pr_err(r->err, PR_ENOMEM, "out of memory");
			return;
		}
		r->nhdr++;
		r->nfield++;
		return;
	}
	if (r->nfield >= r->t->ncols) {
		r->nfield++;
		return;
	}
	if (pr_csv_parse_double(buf, &v)) {
		visible(buf);
		r->status = pr_err(r->err, PR_EIO, "%s:%ld: column '%s': not a finite number: '%.40s'",
		                   r->path, r->line, r->t->names[r->nfield], buf);
		return;
	}
	r->row[r->nfield++] = v;
}

static int start_table(reader *r)
{
	int j, k;

	for (j = 0; j < r->nhdr; ++j) {
		char *h = r->hdr[j];
		size_t n = strlen(h);

		while (n && (h[n - 1] == ' ' || h[n - 1] == '\t' || h[n - 1] == '\r'))
			h[--n] = '\0';
		if (!n)
			return pr_err(r->err, PR_EIO, "%s:%ld: header column %d is empty",
			              r->path, r->line, j + 1);
		if (has_control(h))
			return pr_err(r->err, PR_EIO, "%s:%ld: header column %d contains a control character",
			              r->path, r->line, j + 1);
		for (k = 0; k < j; ++k)
			if (strcmp(r->hdr[k], h) == 0)
				return pr_err(r->err, PR_EIO, "%s:%ld: header column '%s' appears twice",
				              r->path, r->line, h);
	}
	r->t = pr_csv_new(r->nhdr, (const char *const *)r->hdr, r->err);
	if (!r->t)
		return PR_ENOMEM;
	snprintf(r->t->path, sizeof r->t->path, "%s", r->path);
	r->row = malloc((size_t)r->nhdr * sizeof *r->row);
	if (!r->row)
		return pr_err(r->err, PR_ENOMEM, "out of memory");
	return PR_OK;
}

static void on_row(int c, void *data)
{
	reader *r = data;

	(void)c;
	if (r->status)
		return;
	if (!r->header_done) {
		r->header_done = 1;
		r->status = start_table(r);
	} else if (r->nfield != r->t->ncols) {
		r->status = pr_err(r->err, PR_EIO, "%s:%ld: %d fields, but the header has %d",
		                   r->path, r->line, r->nfield, r->t->ncols);
	} else {
		r->status = add_row(r->t, r->row, r->line, r->err);
	}
	r->nfield = 0;
}

int pr_csv_read(const char *path, pr_csv **out, char *err)
{
	struct csv_parser p;
	reader r;
	FILE *fp;
	char *line = NULL;
	size_t cap = 0;
	ssize_t len;
	struct stat st;
	int j, std = !path || strcmp(path, "-") == 0;

	*out = NULL;
	memset(&r, 0, sizeof r);
	r.path = std ? "<stdin>" : path;
	r.err = err;
	fp = std ? stdin : fopen(path, "rb");
	if (!fp)
		return pr_err(err, PR_EIO, "%s: cannot open: %s", path, strerror(errno));
	if (fstat(fileno(fp), &st) == 0 && S_ISDIR(st.st_mode)) {
		if (!std)
			fclose(fp);
		return pr_err(err, PR_EIO, "%s: is a directory, not a CSV file", r.path);
	}
	/* strict: a stray quote or an unterminated quoted field is an error, not data */
	if (csv_init(&p, CSV_APPEND_NULL | CSV_STRICT | CSV_STRICT_FINI) != 0) {
		if (!std)
			fclose(fp);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	while (!r.status && (len = getline(&line, &cap, fp)) != -1) {
		char *s = line;
		r.line++;
		if (len > MAX_LINE) {
			r.status = pr_err(err, PR_EIO, "%s:%ld: line longer than %ld bytes",
			                  r.path, r.line, MAX_LINE);
			break;
		}
		/* a UTF-8 byte-order mark (spreadsheet exports) is not part of the header */
		if (r.line == 1 && len >= 3 && memcmp(s, "\xEF\xBB\xBF", 3) == 0) {
			s += 3;
			len -= 3;
		}
		if (csv_parse(&p, s, (size_t)len, on_field, on_row, &r) != (size_t)len && !r.status)
			r.status = pr_err(err, PR_EIO, "%s:%ld: malformed CSV: %s", r.path, r.line,
			                  csv_strerror(csv_error(&p)));
	}
	if (!r.status && ferror(fp))
		r.status = pr_err(err, PR_EIO, "%s: read error: %s", r.path, strerror(errno));
	if (!r.status && csv_fini(&p, on_field, on_row, &r) != 0 && !r.status)
		r.status = pr_err(err, PR_EIO, "%s:%ld: malformed CSV: unterminated quoted field",
		                  r.path, r.line);
	if (!r.status && !r.header_done)
		r.status = pr_err(err, PR_EIO, "%s: empty file: no header row", r.path);
	csv_free(&p);
	free(line);
	if (!std)
		fclose(fp);
	for (j = 0; j < r.nhdr; ++j)
		free(r.hdr[j]);
	free(r.hdr);
	free(r.row);
	if (r.status) {
		pr_csv_free(r.t);
		return r.status;
	}
	*out = r.t;
	return PR_OK;
}

int pr_csv_select(const pr_csv *t, const char *list, int *cols, int maxcols, char *err)
{
	char name[256];
	const char *p = list, *q;
	int n = 0, j;
	size_t len;

	if (!list || !*list)
		return pr_err(err, PR_EINVAL, "%s: empty column list", pr_csv_path(t));
	while (*p) {
		q = strchr(p, ',');
		len = q ? (size_t)(q - p) : strlen(p);
		if (len == 0 || len >= sizeof name)
			return pr_err(err, PR_EINVAL, "%s: bad column list '%s'", pr_csv_path(t), list);
		memcpy(name, p, len);
		name[len] = '\0';
		if (name[len - 1] == '*') {
			int found = 0;
			for (j = 0; j < t->ncols; ++j) {
				if (strncmp(t->names[j], name, len - 1) == 0) {
					if (n >= maxcols)
						return pr_err(err, PR_EINVAL, "%s: more than %d columns selected",
						              pr_csv_path(t), maxcols);
					cols[n++] = j;
					found = 1;
				}
			}
			if (!found)
				return pr_err(err, PR_EINVAL, "%s: no column matches '%s'", pr_csv_path(t), name);
		} else {
			j = pr_csv_find(t, name);
			if (j < 0)
				return pr_err(err, PR_EINVAL, "%s: no column '%s'", pr_csv_path(t), name);
			if (n >= maxcols)
				return pr_err(err, PR_EINVAL, "%s: more than %d columns selected",
				              pr_csv_path(t), maxcols);
			cols[n++] = j;
		}
		p += len;
		if (*p == ',')
			++p;
	}
	return n;
}

/* ---- writer ---- */

struct pr_csvw {
	FILE *fp;
	int std, nfield, status;
	int direct;        /* a device, FIFO or other non-regular file: written in place */
	char path[1024];
	char tmp[1100];
};

/* Temporary names still open, removed by pr_csvw_cleanup() on a signal. */
#define MAX_OPEN 64
static char open_tmp[MAX_OPEN][1100];

static void track(const char *tmp, int add)
{
	int i;

	for (i = 0; i < MAX_OPEN; ++i) {
		if (add && !open_tmp[i][0]) {
			snprintf(open_tmp[i], sizeof open_tmp[i], "%s", tmp);
			return;
		}
		if (!add && strcmp(open_tmp[i], tmp) == 0) {
			open_tmp[i][0] = '\0';
			return;
		}
	}
}

/* 1 if tmp belongs to a writer still open (two outputs named alike). */
static int tracked(const char *tmp)
{
	int i;

	for (i = 0; i < MAX_OPEN; ++i)
		if (open_tmp[i][0] && strcmp(open_tmp[i], tmp) == 0)
			return 1;
	return 0;
}

int pr_csvw_cleanup(void)
{
	int i, n = 0;

	for (i = 0; i < MAX_OPEN; ++i) {
		if (open_tmp[i][0]) {
			unlink(open_tmp[i]);
			open_tmp[i][0] = '\0';
			++n;
		}
	}
	return n;
}

/* The file a chain of symlinks at path ends in, into out (size n); 0 when
 * path is no symlink or the chain is too long or too deep to follow. */
static int follow_links(const char *path, char *out, size_t n)
{
	char cur[1024], link[1024];
	struct stat st;
	int depth;

	snprintf(cur, sizeof cur, "%s", path);
	for (depth = 0; depth < 16; ++depth) {
		ssize_t len;
		const char *slash;

		if (lstat(cur, &st) != 0 || !S_ISLNK(st.st_mode))
			break;
		len = readlink(cur, link, sizeof link - 1);
		if (len < 0 || (size_t)len >= sizeof link - 1)
			return 0;
		link[len] = '\0';
		slash = strrchr(cur, '/');
		if (link[0] != '/' && slash) {
			/* a relative target is relative to the link's folder */
			char joined[2048];
			snprintf(joined, sizeof joined, "%.*s/%s", (int)(slash - cur), cur, link);
			if (strlen(joined) >= sizeof cur)
				return 0;
			memcpy(cur, joined, strlen(joined) + 1);
		} else {
			memcpy(cur, link, (size_t)len + 1);
		}
	}
	if (depth == 0 || depth == 16 || strlen(cur) >= n)
		return 0;
	memcpy(out, cur, strlen(cur) + 1);
	return 1;
}

pr_csvw *pr_csvw_open(const char *path, char *err)
{
	pr_csvw *w = calloc(1, sizeof *w);
	char real[sizeof w->path];
	struct stat st;

	if (!w) {
		pr_err(err, PR_ENOMEM, "out of memory");
		return NULL;
	}
	if (!path || strcmp(path, "-") == 0) {
		w->std = 1;
		w->fp = stdout;
		snprintf(w->path, sizeof w->path, "<stdout>");
		return w;
	}
	if (strlen(path) >= sizeof w->path) {
		free(w);
		pr_err(err, PR_EINVAL, "%.100s...: path too long", path);
		return NULL;
	}
	/* renaming over a symlink would replace the link: write to its target */
	if (follow_links(path, real, sizeof w->path))
		path = real;
	snprintf(w->path, sizeof w->path, "%s", path);
	/* renaming over /dev/stdout or a FIFO would replace the device itself */
	if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
		w->fp = S_ISDIR(st.st_mode) ? NULL : fopen(path, "wb");
		if (!w->fp) {
			pr_err(err, PR_EIO, "%s: cannot write: %s", w->path,
			       S_ISDIR(st.st_mode) ? "is a directory" : strerror(errno));
			free(w);
			return NULL;
		}
		w->direct = 1;
		return w;
	}
	snprintf(w->tmp, sizeof w->tmp, "%s.tmp.%ld", path, (long)getpid());
	if (tracked(w->tmp)) {
		pr_err(err, PR_EINVAL, "%s: named twice as an output", path);
		free(w);
		return NULL;
	}
	w->fp = fopen(w->tmp, "wb");
	if (!w->fp) {
		pr_err(err, PR_EIO, "%s: cannot write: %s", path, strerror(errno));
		free(w);
		return NULL;
	}
	track(w->tmp, 1);
	return w;
}

static int sep(pr_csvw *w)
{
	if (w->nfield++ && fputc(',', w->fp) == EOF)
		w->status = PR_EIO;
	return w->status;
}

int pr_csvw_str(pr_csvw *w, const char *s)
{
	if (sep(w))
		return w->status;
	if (strpbrk(s, ",\"\r\n") || (*s && (s[0] == ' ' || s[strlen(s) - 1] == ' '))) {
		if (csv_fwrite(w->fp, s, strlen(s)) != 0)
			w->status = PR_EIO;
	} else if (fputs(s, w->fp) == EOF) {
		w->status = PR_EIO;
	}
	return w->status;
}

void pr_csv_format_double(double v, char *buf, size_t n)
{
	int prec;

	/* shortest of %.15g..%.17g that reads back exactly */
	for (prec = 15; prec <= 17; ++prec) {
		snprintf(buf, n, "%.*g", prec, v);
		if (strtod(buf, NULL) == v)
			return;
	}
}

int pr_csvw_num(pr_csvw *w, double v)
{
	char buf[40];

	if (!isfinite(v)) {
		w->status = PR_ENUM;
		return w->status;
	}
	if (sep(w))
		return w->status;
	pr_csv_format_double(v, buf, sizeof buf);
	if (fputs(buf, w->fp) == EOF)
		w->status = PR_EIO;
	return w->status;
}

int pr_csvw_int(pr_csvw *w, long v)
{
	if (sep(w))
		return w->status;
	if (fprintf(w->fp, "%ld", v) < 0)
		w->status = PR_EIO;
	return w->status;
}

int pr_csvw_endrow(pr_csvw *w)
{
	if (!w->status && fputc('\n', w->fp) == EOF)
		w->status = PR_EIO;
	w->nfield = 0;
	return w->status;
}

int pr_csvw_header(pr_csvw *w, const char *names)
{
	char name[256];

	while (*names) {
		size_t len = strcspn(names, ",");
		snprintf(name, sizeof name, "%.*s", (int)(len < sizeof name - 1 ? len : sizeof name - 1), names);
		pr_csvw_str(w, name);
		names += len + (names[len] == ',');
	}
	return pr_csvw_endrow(w);
}

void pr_csvw_abort(pr_csvw *w)
{
	if (!w)
		return;
	if (w->direct) {
		fclose(w->fp);
	} else if (!w->std) {
		fclose(w->fp);
		unlink(w->tmp);
		track(w->tmp, 0);
	} else {
		fflush(w->fp);
	}
	free(w);
}

int pr_csvw_close(pr_csvw *w, char *err)
{
	int status = w->status;

	if (status == PR_ENUM) {
		pr_err(err, PR_ENUM, "%s: refusing to write a non-finite number", w->path);
		pr_csvw_abort(w);
		return status;
	}
	if (w->std) {
		if (status || fflush(w->fp) || ferror(w->fp))
			status = pr_err(err, PR_EIO, "%s: write error", w->path);
		free(w);
		return status;
	}
	if (status || ferror(w->fp) || fflush(w->fp)) {
		pr_err(err, PR_EIO, "%s: write error: %s", w->path, strerror(errno));
		pr_csvw_abort(w);
		return PR_EIO;
	}
	if (w->direct) {
		if (fclose(w->fp) != 0)
			status = pr_err(err, PR_EIO, "%s: write error: %s", w->path, strerror(errno));
		free(w);
		return status;
	}
	if (fclose(w->fp) != 0) {
		status = pr_err(err, PR_EIO, "%s: write error: %s", w->path, strerror(errno));
		unlink(w->tmp);
	} else if (rename(w->tmp, w->path) != 0) {
		status = pr_err(err, PR_EIO, "%s: cannot rename into place: %s", w->path, strerror(errno));
		unlink(w->tmp);
	}
	track(w->tmp, 0);
	free(w);
	return status;
}

int pr_csvw_finish(pr_csvw *w, int rc, char *err)
{
	if (rc && rc != w->status) {
		pr_csvw_abort(w);
		return rc;
	}
	return pr_csvw_close(w, err);
}

int pr_csv_write(const pr_csv *t, const char *path, char *err)
{
	pr_csvw *w = pr_csvw_open(path, err);
	long i;
	int j;

	if (!w)
		return PR_EIO;
	for (j = 0; j < t->ncols; ++j)
		pr_csvw_str(w, t->names[j]);
	pr_csvw_endrow(w);
	for (i = 0; i < t->nrows; ++i) {
		for (j = 0; j < t->ncols; ++j)
			pr_csvw_num(w, pr_csv_get(t, i, j));
		pr_csvw_endrow(w);
	}
	return pr_csvw_close(w, err);
}
