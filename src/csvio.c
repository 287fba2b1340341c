/* csvio.c — the one CSV reader (libcsv, strict, limits applied as bytes
 * arrive), numeric tables on top of it, and the atomic writer with its
 * sticky status and output sets (see csvio.h and csvio_priv.h).
 *
 * The reader feeds libcsv block by block, split at line ends, so that every
 * record is reported with the file line it ends on. A whole line with no
 * quote, blank or inner carriage return, read while libcsv holds no part of
 * a record, is split at its commas directly (what libcsv would do with it,
 * at a fraction of the cost); the callbacks and limits are the same. In a
 * numeric table such a line's numbers are read in place (plain_numbers).
 */
#define _DEFAULT_SOURCE /* realpath */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/xattr.h>
#include <unistd.h>

#include <csv.h>

#include "poolreps/csvio.h"
#include "common_priv.h"
#include "csvio_priv.h"


struct pr_csv {
	int ncols;
	char **names;
	long nrows, cap;
	double *data;
	long *lines;
	char *path;
};

pr_csv *pr_csv_new(int ncols, const char *const *names, char *err)
{
	pr_csv *t;
	int j;

	if (ncols < 1 || ncols > PR_CSV_MAX_COLS) {
		pr_err(err, PR_EINVAL, "table: %d columns (must be 1..%d)", ncols, PR_CSV_MAX_COLS);
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
	free(t->path);
	free(t);
}

int pr_csv_ncols(const pr_csv *t) { return t->ncols; }
long pr_csv_nrows(const pr_csv *t) { return t->nrows; }
const char *pr_csv_name(const pr_csv *t, int j) { return t->names[j]; }
double pr_csv_get(const pr_csv *t, long i, int j) { return t->data[i * t->ncols + j]; }
const double *pr_csv_row(const pr_csv *t, long i) { return t->data + i * t->ncols; }
long pr_csv_line(const pr_csv *t, long i) { return t->lines ? t->lines[i] : i + 2; }
const char *pr_csv_path(const pr_csv *t) { return t->path ? t->path : "<table>"; }

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
	const char *fast;
	char *end;

	while (*s == ' ' || *s == '\t')
		++s;
	if (!*s)
		return PR_EINVAL;
	/* the common case exactly without strtod (decimal.c); the rest, and any
	 * text after the number, is strtod's to judge as before */
	if (pr_decimal_parse(s, &fast, v)) {
		while (*fast == ' ' || *fast == '\t' || *fast == '\r')
			++fast;
		if (!*fast)
			return PR_OK;
	}
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

/* ---- the one reader ---- */

/* A numeric table being read: the table and a row of values. */
typedef struct {
	pr_csv *t;
	double *row;
} numeric;

static int numeric_row(void *user, const char *path, long line, int n, char **fields, char *err);

typedef struct {
	const char *path;
	unsigned flags;
	pr_csv_record_fn header, row;
	void *user;
	char *err;
	long line;                 /* current physical line, 1-based */
	int status, header_done, ncols;
	long nfields_seen;         /* fields completed so far (limit bookkeeping) */
	int idle;                  /* libcsv holds no part of a record (libcsv_took) */
	int in_quote;              /* libcsv is inside a quoted field */
	int nfield, capfield;
	size_t *off;               /* start of each field of the record in text */
	char *text;                /* the record's fields, NUL-terminated, end to end */
	size_t len, cap;
	char **ptr;                /* handed to the callbacks */
	numeric *num;              /* the table the rows go to (numeric_row), or NULL */
} scanner;

static void on_field(void *s, size_t len, void *data)
{
	scanner *r = data;

	if (r->status)
		return;
	r->nfields_seen++;
	if (r->nfield >= PR_CSV_MAX_COLS) {
		r->status = pr_err(r->err, PR_EIO, "%s:%ld: more than %d fields", r->path, r->line,
		                   PR_CSV_MAX_COLS);
		return;
	}
	if (len > PR_CSV_MAX_FIELD) {
		r->status = pr_err(r->err, PR_EIO, "%s:%ld: field %d is longer than %d bytes",
		                   r->path, r->line, r->nfield + 1, PR_CSV_MAX_FIELD);
		return;
	}
	if (r->nfield == r->capfield) {
		int cap = r->capfield ? 2 * r->capfield : 16;
		size_t *o = realloc(r->off, (size_t)cap * sizeof *o);
		char **q = o ? realloc(r->ptr, (size_t)cap * sizeof *q) : NULL;
		if (o)
			r->off = o;
		if (!q) {
			r->status = pr_err(r->err, PR_ENOMEM, "%s:%ld: out of memory", r->path, r->line);
			return;
		}
		r->ptr = q;
		r->capfield = cap;
	}
	if (r->len + len + 1 > r->cap) {
		size_t cap = 2 * (r->len + len + 1) + 256;
		char *t = realloc(r->text, cap);
		if (!t) {
			r->status = pr_err(r->err, PR_ENOMEM, "%s:%ld: out of memory", r->path, r->line);
			return;
		}
		r->text = t;
		r->cap = cap;
	}
	r->off[r->nfield++] = r->len;
	if (len)
		memcpy(r->text + r->len, s, len);
	r->len += len;
	r->text[r->len++] = '\0';
}

/* FNV-1a: the hash of the duplicate-name set. */
static size_t name_hash(const char *s)
{
	size_t h = 2166136261u;

	for (; *s; ++s)
		h = (h ^ (unsigned char)*s) * 16777619u;
	return h;
}

/* Insert index j (name names[j]) into the open-addressing set slot[mask + 1]
 * (-1: empty); the index of an equal name already there, else -1. */
static int name_set_add(int *slot, size_t mask, char *const *names, int j)
{
	size_t h = name_hash(names[j]) & mask;

	for (; slot[h] >= 0; h = (h + 1) & mask)
		if (strcmp(names[slot[h]], names[j]) == 0)
			return slot[h];
	slot[h] = j;
	return -1;
}

/* Header names: trailing blanks trimmed, non-empty, no control character,
 * no name twice (a hash set: linear in the number of columns). */
static int check_header(scanner *r)
{
	size_t cap = 16;
	int *slot, j, k, rc = PR_OK;

	while (cap < 2 * (size_t)r->nfield)
		cap *= 2;
	if (!(slot = malloc(cap * sizeof *slot)))
		return pr_err(r->err, PR_ENOMEM, "out of memory");
	memset(slot, 0xff, cap * sizeof *slot);
	for (j = 0; j < r->nfield && rc == PR_OK; ++j) {
		char *h = r->ptr[j];
		size_t n = strlen(h);

		while (n && (h[n - 1] == ' ' || h[n - 1] == '\t' || h[n - 1] == '\r'))
			h[--n] = '\0';
		if (!n)
			rc = pr_err(r->err, PR_EIO, "%s:%ld: header column %d is empty", r->path, r->line, j + 1);
		for (k = 0; rc == PR_OK && h[k]; ++k)
			if ((unsigned char)h[k] < 0x20 || h[k] == 0x7f)
				rc = pr_err(r->err, PR_EIO, "%s:%ld: header column %d contains a control character",
				            r->path, r->line, j + 1);
		if (rc == PR_OK && name_set_add(slot, cap - 1, r->ptr, j) >= 0)
			rc = pr_err(r->err, PR_EIO, "%s:%ld: header column '%s' appears twice", r->path, r->line, h);
	}
	free(slot);
	return rc;
}

static void on_record(int c, void *data)
{
	scanner *r = data;
	int j;

	(void)c;
	if (!r->status) {
		for (j = 0; j < r->nfield; ++j)
			r->ptr[j] = r->text + r->off[j];
		if (!r->header_done) {
			r->header_done = 1;
			r->ncols = r->nfield;
			if (!(r->status = check_header(r)))
				r->status = r->header(r->user, r->path, r->line, r->nfield, r->ptr, r->err);
		} else if (r->nfield != r->ncols) {
			r->status = pr_err(r->err, PR_EIO, "%s:%ld: %d fields, but the header has %d",
			                   r->path, r->line, r->nfield, r->ncols);
		} else {
			r->status = r->row(r->user, r->path, r->line, r->nfield, r->ptr, r->err);
		}
	}
	r->nfield = 0;
	r->len = 0;
}

/* The ncols numbers of a plain line (plain_line; end bytes, without its
 * line end) read in place into row, without the copy of its fields: 1 when
 * it holds as many fields as that, each a number decimal.c reads exactly
 * (the value numeric_row would store) and no longer than a field may be; 0
 * for the general way, which reports what is wrong. The block's padding
 * lets the parser load 8 bytes at a time. */
static int numbers_in_place(const char *s, size_t end, int ncols, double *row)
{
	const char *f = s, *stop = s, *e = s + end;
	int j;

	for (j = 0; j < ncols; j++, f = stop + 1) {
		if (!pr_decimal_parse_padded(f, &stop, &row[j]) || stop - f > PR_CSV_MAX_FIELD ||
		    (stop != e && *stop != ','))
			return 0;
		if (stop == e)
			break;
	}
	return j == ncols - 1 && stop == e;
}

static int plain_numbers(scanner *r, const char *s, size_t end)
{
	if (!numbers_in_place(s, end, r->ncols, r->num->row))
		return 0;
	r->nfields_seen += r->ncols;
	r->status = add_row(r->num->t, r->num->row, r->line, r->err);
	return 1;
}

/* 1 if the n bytes at s are a whole line that libcsv would split at every
 * comma and nowhere else: a line end at the end, and no quote, no blank
 * (which libcsv trims), no carriage return but one right before the line
 * end; *end: the bytes before the line end. */
static int plain_bytes(const char *s, size_t n, size_t *end)
{
	size_t i;

	if (!n || s[n - 1] != '\n')
		return 0;
	*end = n - 1;
	if (*end && s[*end - 1] == '\r')
		--*end;
	/* one memchr per byte that disqualifies (each runs at vector speed,
	 * where a loop over the bytes comparing each with all four did not) */
	for (i = 0; i < 4; ++i)
		if (memchr(s, "\" \t\r"[i], *end))
			return 0;
	return 1;
}

/* Report a whole plain line (plain_bytes) through the same callbacks, without libcsv's
 * byte-by-byte state machine and copy; 0, with nothing reported, for any
 * other piece. Called only while libcsv holds no part of a record. */
static int plain_line(scanner *r, const char *s, size_t n)
{
	size_t end;
	const char *f, *c;

	if (!plain_bytes(s, n, &end))
		return 0;
	if (!end)
		return 1; /* an empty line: no record, as in libcsv */
	if (r->num && r->header_done && plain_numbers(r, s, end))
		return 1;
	for (f = s; !r->status; f = c + 1) {
		if (!(c = memchr(f, ',', (size_t)(s + end - f)))) {
			on_field((void *)f, (size_t)(s + end - f), r);
			break;
		}
		on_field((void *)f, (size_t)(c - f), r);
	}
	on_record('\n', r);
	return 1;
}

/* libcsv's state after it took the n bytes at s, from the bytes alone (its
 * struct is not read): inside a quoted field while an odd number of quotes
 * has gone by (with CSV_STRICT a quote only opens, doubles or closes one);
 * between records after a line end outside quotes. A piece without a line
 * end counts as holding part of a record, which at worst sends the next
 * piece through libcsv too. */
static void libcsv_took(scanner *r, const char *s, size_t n)
{
	const char *q = s, *e = s + n;

	while ((q = memchr(q, '"', (size_t)(e - q)))) {
		r->in_quote = !r->in_quote;
		++q;
	}
	r->idle = !r->in_quote && n && s[n - 1] == '\n';
}

/* Feed one piece (at most one line end, at its end) to libcsv. pending
 * counts the bytes since the last completed field, which libcsv buffers: a
 * quoted field may double its quotes, so more than twice the field limit
 * (plus a block) means a field over the limit that has not ended yet. A
 * piece after which libcsv is between records (a blank line) buffers
 * nothing. */
static void feed(scanner *r, struct csv_parser *p, const char *s, size_t n, long *pending,
                 long *linelen)
{
	long before = r->nfields_seen;
	/* libcsv between records: a plain line may bypass it */
	int direct = !(r->flags & PR_CSV_LIBCSV_ONLY) && r->idle;

	*linelen += (long)n;
	if (*linelen > PR_CSV_MAX_LINE + 1) {
		r->status = pr_err(r->err, PR_EIO, "%s:%ld: line longer than %ld bytes", r->path,
		                   r->line, PR_CSV_MAX_LINE);
		return;
	}
	if (!(direct && plain_line(r, s, n))) {
		if (csv_parse(p, s, n, on_field, on_record, r) != n && !r->status)
			r->status = pr_err(r->err, csv_error(p) == CSV_ENOMEM ? PR_ENOMEM : PR_EIO,
			                   "%s:%ld: malformed CSV: %s", r->path, r->line,
			                   csv_strerror(csv_error(p)));
		libcsv_took(r, s, n);
	}
	*pending = r->nfields_seen == before && !r->idle ? *pending + (long)n : 0;
	if (!r->status && *pending > 2L * PR_CSV_MAX_FIELD + 2)
		r->status = pr_err(r->err, PR_EIO, "%s:%ld: field %d is longer than %d bytes%s",
		                   r->path, r->line, r->nfield + 1, PR_CSV_MAX_FIELD,
		                   r->in_quote ? " (a quote that never ends?)" : "");
}

/* The reader's state between blocks: the scanner, libcsv and the file. A
 * streamed source (eager) takes what one read(2) returns, so that a pipe's
 * rows are parsed as they arrive; a plain one fills whole blocks. */
typedef struct {
	scanner r;
	struct csv_parser p;
	FILE *fp;
	char *buf;
	long pending, linelen;
	int std, first, last, eager, read_errno;
} source;

#define SCAN_BLOCK ((size_t)1 << 16)

/* The scanner and libcsv of a source that reads the file shown as shown. */
static int source_setup(source *src, const char *shown, unsigned flags, pr_csv_record_fn header,
                        pr_csv_record_fn row, void *user, char *err)
{
	scanner *r = &src->r;

	src->first = 1;
	src->last = '\n';
	r->path = shown;
	r->flags = flags;
	r->header = header;
	r->row = row;
	r->user = user;
	r->err = err;
	r->line = 1;
	r->num = row == numeric_row ? user : NULL;
	/* zeroed padding after a block: plain_numbers' 8-byte loads */
	src->buf = calloc(1, SCAN_BLOCK + 8);
	if (!src->buf || csv_init(&src->p, CSV_APPEND_NULL | CSV_STRICT | CSV_STRICT_FINI) != 0) {
		free(src->buf);
		src->buf = NULL;
		return pr_err(err, PR_ENOMEM, "%s: out of memory", shown);
	}
	r->idle = 1;
	return PR_OK;
}

static int source_open(source *src, const char *path, unsigned flags, pr_csv_record_fn header,
                       pr_csv_record_fn row, void *user, int eager, char *err)
{
	struct stat st;

	memset(src, 0, sizeof *src);
	src->std = !path || strcmp(path, "-") == 0;
	src->eager = eager;
	src->fp = src->std ? stdin : fopen(path, "rb");
	if (!src->fp)
		return pr_err(err, pr_errno_status(), "%s: cannot open: %s", path, strerror(errno));
	if (fstat(fileno(src->fp), &st) == 0 && S_ISDIR(st.st_mode)) {
		if (!src->std)
			fclose(src->fp);
		return pr_err(err, PR_EIO, "%s: is a directory, not a CSV file", src->std ? "<stdin>" : path);
	}
	if (source_setup(src, src->std ? "<stdin>" : path, flags, header, row, user, err)) {
		if (!src->std)
			fclose(src->fp);
		return PR_ENOMEM;
	}
	return PR_OK;
}

/* One read(2), retried when a signal that did not stop the command
 * interrupted it; the first block holds at least the 3 bytes of a
 * byte-order mark (or the whole input). 0 at the end or on an error. */
static size_t read_eager(source *src)
{
	size_t n = 0;

	do {
		ssize_t k = read(fileno(src->fp), src->buf + n, SCAN_BLOCK - n);
		if (k < 0 && errno == EINTR && !pr_interrupted)
			continue;
		if (k < 0)
			src->read_errno = errno;
		if (k <= 0)
			break;
		n += (size_t)k;
	} while (src->first && n < 3);
	return n;
}

/* Feed the n > 0 bytes at s (one block of the input), split at line ends. */
static void scan_block(source *src, char *s, size_t n)
{
	scanner *r = &src->r;
	char *end = s + n, *nul;

	/* a UTF-8 byte-order mark (spreadsheet exports) is not part of the header */
	if (src->first && n >= 3 && memcmp(s, "\xEF\xBB\xBF", 3) == 0)
		s += 3;
	src->first = 0;
	if ((nul = memchr(s, '\0', (size_t)(end - s)))) {
		long line = r->line;
		for (; s < nul; ++s)
			line += *s == '\n';
		r->status = pr_err(r->err, PR_EIO, "%s:%ld: NUL byte: not a text CSV file", r->path, line);
		return;
	}
	while (!r->status && s < end) {
		char *nl = memchr(s, '\n', (size_t)(end - s));
		size_t len = nl ? (size_t)(nl + 1 - s) : (size_t)(end - s);
		feed(r, &src->p, s, len, &src->pending, &src->linelen);
		if (nl && !r->status) {
			r->line++;
			src->linelen = 0;
		}
		s += len;
	}
	src->last = (unsigned char)end[-1];
}

/* Read one block and feed it; 0 at the end of the input. */
static size_t source_block(source *src)
{
	size_t n = src->eager ? read_eager(src) : fread(src->buf, 1, SCAN_BLOCK, src->fp);

	if (n)
		scan_block(src, src->buf, n);
	return n;
}

/* After the last block: a read error, the record without a line end, an
 * unterminated quote, no header, an incomplete file. */
static void source_end(source *src)
{
	scanner *r = &src->r;
	char *err = r->err;

	if (!r->status && (src->eager ? src->read_errno != 0 : ferror(src->fp) != 0)) {
		if (src->eager)
			errno = src->read_errno;
		r->status = pr_err(err, pr_errno_status(), "%s: read error: %s", r->path, strerror(errno));
	}
	if (src->last == '\n')
		r->line--; /* messages at the end name the last line that has bytes */
	if (!r->status && csv_fini(&src->p, on_field, on_record, r) != 0 && !r->status)
		r->status = csv_error(&src->p) == CSV_ENOMEM ? pr_err(err, PR_ENOMEM, "%s: out of memory", r->path)
		            : pr_err(err, PR_EIO, "%s:%ld: malformed CSV: unterminated quoted field",
		                     r->path, r->line);
	if (!r->status && !r->header_done)
		r->status = pr_err(err, PR_EIO, "%s: empty file: no header row", r->path);
	if (!r->status && (r->flags & PR_CSV_COMPLETE) && src->last != '\n')
		r->status = pr_err(err, PR_EIO, "%s:%ld: the last line has no line end (incomplete file?)",
		                   r->path, r->line);
}

/* What source_setup and the scan allocated. */
static void source_release(source *src)
{
	if (src->buf)
		csv_free(&src->p);
	free(src->buf);
	free(src->r.off);
	free(src->r.ptr);
	free(src->r.text);
}

static void source_close(source *src)
{
	source_release(src);
	if (!src->std)
		fclose(src->fp);
}

int pr_csv_scan(const char *path, unsigned flags, pr_csv_record_fn header,
                pr_csv_record_fn row, void *user, char *err)
{
	source src;
	int rc = source_open(&src, path, flags, header, row, user, 0, err);

	if (rc)
		return rc;
	while (!src.r.status && source_block(&src) > 0)
		;
	source_end(&src);
	rc = src.r.status;
	source_close(&src);
	return rc;
}

/* ---- numeric tables ---- */

static int numeric_header(void *user, const char *path, long line, int n, char **names, char *err)
{
	numeric *u = user;

	(void)line;
	if (!(u->t = pr_csv_new(n, (const char *const *)names, err)))
		return PR_ENOMEM;
	if (!(u->t->path = strdup(path)) || !(u->row = malloc((size_t)n * sizeof *u->row)))
		return pr_err(err, PR_ENOMEM, "%s: out of memory", path);
	return PR_OK;
}

static int numeric_row(void *user, const char *path, long line, int n, char **fields, char *err)
{
	numeric *u = user;
	int j;

	for (j = 0; j < n; ++j)
		if (pr_csv_parse_double(fields[j], &u->row[j]))
			return pr_err(err, PR_EIO, "%s:%ld: column '%s': not a finite number: '%.40s'",
			              path, line, u->t->names[j], fields[j]);
	return add_row(u->t, u->row, line, err);
}

/* The table's arrays cut to its rows: the room doubling left unused goes
 * back before a command's later steps. */
static void fit_rows(pr_csv *t)
{
	double *d;
	long *l;

	if (t->nrows == t->cap || t->nrows == 0)
		return;
	if ((d = realloc(t->data, (size_t)t->nrows * (size_t)t->ncols * sizeof *d)))
		t->data = d;
	if ((l = realloc(t->lines, (size_t)t->nrows * sizeof *l)))
		t->lines = l;
	/* an array that could not shrink is still longer */
	t->cap = t->nrows;
}

int pr_csv_read(const char *path, pr_csv **out, char *err)
{
	numeric u = {NULL, NULL};
	int rc = pr_csv_scan(path, 0, numeric_header, numeric_row, &u, err);

	free(u.row);
	if (rc) {
		pr_csv_free(u.t);
		u.t = NULL;
	} else {
		fit_rows(u.t);
	}
	*out = u.t;
	return rc;
}

/* ---- a numeric table read in chunks ----
 *
 * The scan of pr_csv_read, paused after every block: the rows a block
 * completed are the chunk. A failure (a bad field, a short line, a read
 * error) is kept until the rows before it are handed out, so a consumer sees
 * every good row before the first bad one, in file order. */

struct pr_csv_stream {
	source src;
	numeric u;        /* u.t: the names, then each chunk's rows */
	int eof, handed;  /* handed: the table's rows went out as a chunk */
	char perr[PR_ERRLEN];
};

void pr_csv_stream_free(pr_csv_stream *s)
{
	if (!s)
		return;
	source_close(&s->src);
	free(s->u.row);
	pr_csv_free(s->u.t);
	free(s);
}

/* Read one more block; at the end, the checks of the end of a file. */
static void stream_block(pr_csv_stream *s)
{
	if (source_block(&s->src) == 0) {
		source_end(&s->src);
		s->eof = 1;
	}
}

int pr_csv_stream_open(const char *path, pr_csv_stream **out, char *err)
{
	pr_csv_stream *s = calloc(1, sizeof *s);
	int rc;

	*out = NULL;
	if (!s)
		return pr_err(err, PR_ENOMEM, "out of memory");
	if ((rc = source_open(&s->src, path, 0, numeric_header, numeric_row, &s->u, 1, s->perr))) {
		snprintf(err, PR_ERRLEN, "%s", s->perr);
		free(s);
		return rc;
	}
	/* u.t exists once the header was read and checked */
	while (!s->src.r.status && !s->u.t && !s->eof)
		stream_block(s);
	if (!s->u.t) {
		rc = s->src.r.status;
		snprintf(err, PR_ERRLEN, "%s", s->perr);
		pr_csv_stream_free(s);
		return rc;
	}
	*out = s;
	return PR_OK;
}

int pr_csv_stream_failed(const pr_csv_stream *s, char *err)
{
	if (s->src.r.status)
		snprintf(err, PR_ERRLEN, "%s", s->perr);
	return s->src.r.status;
}

const pr_csv *pr_csv_stream_columns(const pr_csv_stream *s)
{
	return s->u.t;
}

int pr_csv_stream_next(pr_csv_stream *s, const pr_csv **chunk, char *err)
{
	pr_csv *t = s->u.t;

	*chunk = NULL;
	if (s->handed)
		t->nrows = 0;
	s->handed = 0;
	for (;;) {
		if (t->nrows > 0) {
			*chunk = t;
			s->handed = 1;
			return PR_OK;
		}
		if (s->src.r.status) {
			snprintf(err, PR_ERRLEN, "%s", s->perr);
			return s->src.r.status;
		}
		if (s->eof)
			return PR_OK;
		stream_block(s);
	}
}

/* Append column j to cols[*n]: a column selected twice would give an output
 * with two columns of one name (or a feature twice). taken[j]: selected. */
static int select_one(const pr_csv *t, const char *list, int *cols, int *n, int maxcols, int j,
                      char *taken, char *err)
{
	if (taken[j])
		return pr_err(err, PR_EINVAL, "%s: column '%s' selected twice by '%s'", pr_csv_path(t),
		              t->names[j], list);
	if (*n >= maxcols)
		return pr_err(err, PR_EINVAL, "%s: more than %d columns selected", pr_csv_path(t), maxcols);
	taken[j] = 1;
	cols[(*n)++] = j;
	return PR_OK;
}

/* One name or prefix* of a column list into cols. */
static int select_name(const pr_csv *t, const char *list, const char *name, size_t len, int *cols,
                       int *n, int maxcols, char *taken, char *err)
{
	int j, rc, found = 0;

	if (name[len - 1] != '*') {
		if ((j = pr_csv_find(t, name)) < 0)
			return pr_err(err, PR_EINVAL, "%s: no column '%s'", pr_csv_path(t), name);
		return select_one(t, list, cols, n, maxcols, j, taken, err);
	}
	for (j = 0; j < t->ncols; ++j)
		if (strncmp(t->names[j], name, len - 1) == 0) {
			if ((rc = select_one(t, list, cols, n, maxcols, j, taken, err)))
				return rc;
			found = 1;
		}
	return found ? PR_OK : pr_err(err, PR_EINVAL, "%s: no column matches '%s'", pr_csv_path(t), name);
}

int pr_csv_select(const pr_csv *t, const char *list, int *cols, int maxcols, char *err)
{
	char name[256], *taken;
	const char *p = list, *q;
	int n = 0, rc = PR_OK;
	size_t len;

	if (!list || !*list)
		return pr_err(err, PR_EINVAL, "%s: empty column list", pr_csv_path(t));
	if (!(taken = calloc((size_t)t->ncols + 1, 1)))
		return pr_err(err, PR_ENOMEM, "out of memory");
	while (*p && rc == PR_OK) {
		q = strchr(p, ',');
		len = q ? (size_t)(q - p) : strlen(p);
		if (len == 0 || len >= sizeof name) {
			rc = pr_err(err, PR_EINVAL, "%s: bad column list '%s'", pr_csv_path(t), list);
			break;
		}
		memcpy(name, p, len);
		name[len] = '\0';
		rc = select_name(t, list, name, len, cols, &n, maxcols, taken, err);
		p += len;
		if (*p == ',')
			++p;
	}
	free(taken);
	return rc == PR_OK ? n : rc;
}

/* ---- writer ---- */

enum { W_STDOUT, W_DIRECT, W_FILE };

struct pr_csvw {
	FILE *fp;
	int kind;
	int status, err_no;  /* sticky: the first failure and its errno */
	int nfield;
	long rows;           /* rows ended so far */
	long bad_line;       /* where a non-finite number was refused */
	int bad_field;
	char *shown;         /* the path as given, for messages */
	char *target;        /* W_FILE: the regular file renamed over */
	char *tmp;           /* W_FILE: the temporary file */
	char *backup;        /* during a commit: a second link to the old target */
	int existed;         /* target (or device) existed: dev, ino identify it */
	dev_t dev;
	ino_t ino;
	char *canon;         /* a new file: its folder's real path and its name */
	pr_csvw *next;       /* in a pr_outset */
};

#define TMP_PREFIX ".poolreps-tmp-"
/* inside the open functions: fail with a status and a message */
#define FAIL_OPEN(status, ...) do { \
	*st = pr_err(err, status, __VA_ARGS__); \
	return writer_fail(w); \
} while (0)

static pr_csvw *writer_fail(pr_csvw *w)
{
	if (w) {
		if (w->fp && w->kind != W_STDOUT)
			fclose(w->fp);
		if (w->tmp) {
			unlink(w->tmp);
			pr_cleanup_remove_file(w->tmp);
		}
		free(w->shown);
		free(w->target);
		free(w->tmp);
		free(w->backup);
		free(w->canon);
		free(w);
	}
	return NULL;
}

/* The file a chain of symlinks at path ends in (malloc'd; path itself when
 * it is no symlink), or NULL with errno set. */
static char *follow_links(const char *path)
{
	char *cur = strdup(path), link[PATH_MAX];
	struct stat st;
	int depth;

	for (depth = 0; cur && depth < 40; ++depth) {
		ssize_t len;
		const char *slash;
		char *next;

		if (lstat(cur, &st) != 0 || !S_ISLNK(st.st_mode))
			return cur;
		len = readlink(cur, link, sizeof link - 1);
		if (len < 0) {
			free(cur);
			return NULL;
		}
		link[len] = '\0';
		slash = strrchr(cur, '/');
		/* a relative target is relative to the link's folder */
		if (link[0] != '/' && slash) {
			next = malloc((size_t)(slash - cur) + 2 + (size_t)len);
			if (next)
				sprintf(next, "%.*s/%s", (int)(slash - cur), cur, link);
		} else {
			next = strdup(link);
		}
		free(cur);
		cur = next;
	}
	if (cur)
		errno = ELOOP;
	else
		errno = ENOMEM;
	free(cur);
	return NULL;
}

/* The folder of path (malloc'd): "." for a bare name. */
static char *folder_of(const char *path)
{
	const char *slash = strrchr(path, '/');

	if (!slash)
		return strdup(".");
	if (slash == path)
		return strdup("/");
	return strndup(path, (size_t)(slash - path));
}

/* Remove temporary files in folder left by processes provably gone (killed
 * with SIGKILL): their names hold the owner tag (pr_owner_dead). */
static void sweep_stale(const char *folder)
{
	DIR *d = opendir(folder);
	struct dirent *e;

	if (!d)
		return;
	while ((e = readdir(d)))
		if (strncmp(e->d_name, TMP_PREFIX, strlen(TMP_PREFIX)) == 0 &&
		    pr_owner_dead(e->d_name + strlen(TMP_PREFIX)))
			unlinkat(dirfd(d), e->d_name, 0);
	closedir(d);
}

/* A new, registered file in folder named TMP_PREFIX<owner tag>-<n>, opened for
 * writing with mode 0666 less the umask; fd, or -1 with errno set. */
int pr_csv_copy_xattrs(const char *from, int fd, char *bad, size_t nbad)
{
	ssize_t n = listxattr(from, NULL, 0), k;
	char *names, *p, *val = NULL;
	int rc = 0;

	if (n <= 0)
		return n < 0 && errno != ENOTSUP ? -1 : 0;
	if (!(names = malloc((size_t)n)))
		return -1;
	if ((n = listxattr(from, names, (size_t)n)) < 0)
		rc = -1;
	for (p = names; rc == 0 && p < names + n; p += strlen(p) + 1) {
		char *nv;

		snprintf(bad, nbad, "%s", p);
		if ((k = getxattr(from, p, NULL, 0)) < 0 || !(nv = realloc(val, (size_t)k + 1)))
			rc = -1;
		else if ((val = nv), (k = getxattr(from, p, val, (size_t)k)) < 0 ||
		         fsetxattr(fd, p, val, (size_t)k, 0) != 0)
			rc = -1;
	}
	free(val);
	free(names);
	return rc;
}

static int make_temp(const char *folder, char **name)
{
	static atomic_long seq;
	int fd;

	for (;;) {
		long k = atomic_fetch_add(&seq, 1);
		*name = malloc(strlen(folder) + 160);
		if (!*name) {
			errno = ENOMEM;
			return -1;
		}
		sprintf(*name, "%s/%s%s-%ld", folder, TMP_PREFIX, pr_owner_tag(), k);
		pr_cleanup_add_file(*name);
		fd = open(*name, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
		if (fd >= 0)
			return fd;
		pr_cleanup_remove_file(*name);
		free(*name);
		*name = NULL;
		if (errno != EEXIST)
			return -1;
	}
}

static pr_csvw *open_file(pr_csvw *w, const char *path, const struct stat *sb, int *st,
                          char *err)
{
	char *folder, *real;
	int fd;

	/* renaming over a symlink would replace the link: write to its target */
	if (!(w->target = follow_links(path)))
		FAIL_OPEN(pr_errno_status(), "%s: cannot write: %s", path, strerror(errno));
	if (!(folder = folder_of(w->target)))
		FAIL_OPEN(PR_ENOMEM, "out of memory");
	if (w->existed) {
		/* root may write anything; anyone else keeps a file they may not write */
		if (faccessat(AT_FDCWD, w->target, W_OK, AT_EACCESS) != 0) {
			*st = pr_err(err, pr_errno_status(), "%s: cannot write: %s", path, strerror(errno));
			free(folder);
			return writer_fail(w);
		}
	} else if ((real = realpath(folder, NULL))) {
		const char *base = strrchr(w->target, '/');
		w->canon = malloc(strlen(real) + strlen(w->target) + 2);
		if (w->canon)
			sprintf(w->canon, "%s/%s", real, base ? base + 1 : w->target);
		free(real);
	}
	sweep_stale(folder);
	fd = make_temp(folder, &w->tmp);
	free(folder);
	if (fd < 0)
		FAIL_OPEN(pr_errno_status(), "%s: cannot write: %s", path, strerror(errno));
	if (w->existed) {
		/* the file keeps its permission bits, and for root its owner */
		if (fchmod(fd, sb->st_mode & 07777) != 0) {
			*st = pr_err(err, pr_errno_status(), "%s: cannot keep its permissions: %s", path, strerror(errno));
			close(fd);
			return writer_fail(w);
		}
		if (geteuid() == 0 && fchown(fd, sb->st_uid, sb->st_gid) != 0) {
			*st = pr_err(err, pr_errno_status(), "%s: cannot keep its owner: %s", path, strerror(errno));
			close(fd);
			return writer_fail(w);
		}
		/* and its extended attributes (after the owner: a chown drops some) */
		char xa[256] = "";
		if (pr_csv_copy_xattrs(w->target, fd, xa, sizeof xa) != 0) {
			*st = pr_err(err, pr_errno_status(), "%s: cannot keep its extended attribute %s: %s", path,
			             xa, strerror(errno));
			close(fd);
			return writer_fail(w);
		}
	}
	if (!(w->fp = fdopen(fd, "wb"))) {
		close(fd);
		FAIL_OPEN(PR_ENOMEM, "out of memory");
	}
	w->kind = W_FILE;
	return w;
}

static pr_csvw *open_any(const char *path, int *st, char *err)
{
	pr_csvw *w = calloc(1, sizeof *w);
	struct stat sb, out;

	if (!w || !(w->shown = strdup(path && strcmp(path, "-") ? path : "<stdout>"))) {
		*st = pr_err(err, PR_ENOMEM, "out of memory");
		return writer_fail(w);
	}
	if (!path || strcmp(path, "-") == 0) {
		w->fp = stdout;
		return w;
	}
	if (!*path)
		FAIL_OPEN(PR_EINVAL, "output file name is empty");
	if (stat(path, &sb) != 0) {
		if (errno != ENOENT)
			FAIL_OPEN(pr_errno_status(), "%s: cannot write: %s", path, strerror(errno));
		return open_file(w, path, &sb, st, err);
	}
	w->existed = 1;
	w->dev = sb.st_dev;
	w->ino = sb.st_ino;
	if (S_ISDIR(sb.st_mode))
		FAIL_OPEN(PR_EIO, "%s: cannot write: is a directory", path);
	/* /dev/stdout, /dev/fd/1, or the file stdout is redirected to */
	if (fstat(STDOUT_FILENO, &out) == 0 && out.st_dev == sb.st_dev && out.st_ino == sb.st_ino) {
		w->fp = stdout;
		return w;
	}
	if (S_ISREG(sb.st_mode))
		return open_file(w, path, &sb, st, err);
	/* a FIFO or device: renaming over it would replace the device itself */
	if (!(w->fp = fopen(path, "wb")))
		FAIL_OPEN(pr_errno_status(), "%s: cannot write: %s", path, strerror(errno));
	w->kind = W_DIRECT;
	return w;
}

pr_csvw *pr_csvw_open(const char *path, char *err)
{
	int st;

	return open_any(path, &st, err);
}

/* Record the first failure; later calls see it and do nothing. */
static int fail_io(pr_csvw *w)
{
	if (!w->status) {
		w->status = PR_EIO;
		w->err_no = errno ? errno : EIO;
	}
	return w->status;
}

static int sep(pr_csvw *w)
{
	if (w->status)
		return w->status;
	errno = 0;
	if (w->nfield++ && fputc(',', w->fp) == EOF)
		return fail_io(w);
	return PR_OK;
}

int pr_csvw_str(pr_csvw *w, const char *s)
{
	if (sep(w))
		return w->status;
	if (strpbrk(s, ",\"\r\n") || (*s && (s[0] == ' ' || s[strlen(s) - 1] == ' '))) {
		if (csv_fwrite(w->fp, s, strlen(s)) != 0)
			return fail_io(w);
	} else if (fputs(s, w->fp) == EOF) {
		return fail_io(w);
	}
	return PR_OK;
}

int pr_csvw_num(pr_csvw *w, double v)
{
	char buf[40];

	if (w->status)
		return w->status;
	if (!isfinite(v)) {
		w->status = PR_ENUM;
		w->bad_line = w->rows + 1;
		w->bad_field = w->nfield + 1;
		return w->status;
	}
	if (sep(w))
		return w->status;
	pr_csv_format_double(v, buf, sizeof buf);
	if (fputs(buf, w->fp) == EOF)
		return fail_io(w);
	return PR_OK;
}

int pr_csvw_int(pr_csvw *w, long v)
{
	if (sep(w))
		return w->status;
	if (fprintf(w->fp, "%ld", v) < 0)
		return fail_io(w);
	return PR_OK;
}

int pr_csvw_endrow(pr_csvw *w)
{
	w->nfield = 0;
	if (w->status)
		return w->status;
	errno = 0;
	if (fputc('\n', w->fp) == EOF)
		return fail_io(w);
	w->rows++;
	return PR_OK;
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

int pr_csvw_raw(pr_csvw *w, const char *s, size_t n)
{
	if (w->status)
		return w->status;
	errno = 0;
	if (n && fwrite(s, 1, n, w->fp) != n)
		return fail_io(w);
	return PR_OK;
}

int pr_csvw_flush(pr_csvw *w)
{
	if (w->status || w->kind == W_FILE)
		return w->status;
	errno = 0;
	if (fflush(w->fp) != 0)
		return fail_io(w);
	return PR_OK;
}

int pr_csvw_status(const pr_csvw *w)
{
	return w->status;
}

/* Flush and close (a temporary file: not yet renamed); report the sticky
 * status once. The writer stays allocated. */
static int finish(pr_csvw *w, char *err)
{
	FILE *fp = w->fp;

	w->fp = NULL;
	errno = 0;
	if (!w->status && (fflush(fp) != 0 || ferror(fp)))
		fail_io(w);
	if (w->kind != W_STDOUT && fclose(fp) != 0)
		fail_io(w);
	if (w->status == PR_ENUM)
		return pr_err(err, PR_ENUM, "%s:%ld: field %d: refusing to write a non-finite number "
		              "(numerical failure)", w->shown, w->bad_line, w->bad_field);
	if (w->status)
		return pr_err(err, w->err_no == ENOMEM ? PR_ENOMEM : PR_EIO, "%s: write error: %s", w->shown,
		              strerror(w->err_no));
	return PR_OK;
}

void pr_csvw_abort(pr_csvw *w)
{
	if (!w)
		return;
	if (w->fp && w->kind == W_STDOUT)
		fflush(w->fp);
	if (w->kind == W_STDOUT)
		w->fp = NULL;
	writer_fail(w);
}

int pr_csvw_close(pr_csvw *w, char *err)
{
	int rc = finish(w, err);
	sigset_t old;

	if (rc == PR_OK && w->kind == W_FILE) {
		pr_cleanup_hold(&old);
		if (rename(w->tmp, w->target) != 0) {
			rc = pr_err(err, pr_errno_status(), "%s: cannot rename into place: %s", w->shown, strerror(errno));
		} else {
			pr_cleanup_remove_file(w->tmp);
			free(w->tmp);
			w->tmp = NULL;
		}
		pr_commit_end(&old, rc, w->target);
	}
	writer_fail(w);
	return rc;
}

int pr_csvw_finish(pr_csvw *w, int rc, char *err)
{
	if (rc && rc != w->status) {
		pr_csvw_abort(w);
		return rc;
	}
	return pr_csvw_close(w, err);
}

/* ---- several outputs, committed together ---- */

struct pr_outset {
	pr_csvw *first, *last;
};

pr_outset *pr_outset_new(char *err)
{
	pr_outset *s = calloc(1, sizeof *s);

	if (!s)
		pr_err(err, PR_ENOMEM, "out of memory");
	return s;
}

static int same_output(const pr_csvw *a, const pr_csvw *b)
{
	if (a->fp == stdout || b->fp == stdout)
		return a->fp == b->fp;
	if (a->existed && b->existed)
		return a->dev == b->dev && a->ino == b->ino;
	return a->canon && b->canon && strcmp(a->canon, b->canon) == 0;
}

int pr_outset_add(pr_outset *s, const char *path, pr_csvw **out, char *err)
{
	pr_csvw *w, *o;
	int rc;

	*out = NULL;
	if (!(w = open_any(path, &rc, err)))
		return rc;
	for (o = s->first; o; o = o->next)
		if (same_output(o, w)) {
			rc = pr_err(err, PR_EINVAL, "%s: named twice as an output (also as %s)", w->shown,
			            o->shown);
			pr_csvw_abort(w);
			return rc;
		}
	if (s->last)
		s->last->next = w;
	else
		s->first = w;
	s->last = w;
	*out = w;
	return PR_OK;
}

static void free_set(pr_outset *s, int unlink_tmp)
{
	pr_csvw *w = s->first, *next;

	for (; w; w = next) {
		next = w->next;
		if (!unlink_tmp && w->tmp) {
			pr_cleanup_remove_file(w->tmp);
			free(w->tmp);
			w->tmp = NULL;
		}
		if (w->kind == W_STDOUT && w->fp)
			fflush(w->fp);
		if (w->kind == W_STDOUT)
			w->fp = NULL;
		writer_fail(w);
	}
	free(s);
}

/* Rename every member into place; on a failure, put back what was replaced
 * (from a second hard link made before) and remove what was new. */
static int rename_all(pr_outset *s, char *err)
{
	pr_csvw *w, *u;
	int rc = PR_OK, nfiles = 0;

	for (w = s->first; w; w = w->next)
		nfiles += w->kind == W_FILE;
	for (w = s->first; nfiles > 1 && w && rc == PR_OK; w = w->next) {
		char *folder;
		int fd;
		if (w->kind != W_FILE || !w->existed)
			continue;
		if (!(folder = folder_of(w->target))) {
			rc = pr_err(err, PR_ENOMEM, "out of memory");
			break;
		}
		fd = make_temp(folder, &w->backup);
		free(folder);
		if (fd >= 0) {
			close(fd);
			/* link() cannot replace: make room for it */
			unlink(w->backup);
		}
		if (fd < 0 || link(w->target, w->backup) != 0)
			rc = pr_err(err, pr_errno_status(), "%s: cannot keep the earlier file while replacing it: %s",
			            w->shown, strerror(errno));
	}
	for (w = s->first; w && rc == PR_OK; w = w->next) {
		if (w->kind != W_FILE)
			continue;
		if (rename(w->tmp, w->target) != 0) {
			rc = pr_err(err, pr_errno_status(), "%s: cannot rename into place: %s; every output left as it was",
			            w->shown, strerror(errno));
			for (u = s->first; u != w; u = u->next) {
				if (u->kind != W_FILE)
					continue;
				if (u->backup)
					rename(u->backup, u->target);
				else if (!u->existed)
					unlink(u->target);
			}
			break;
		}
		pr_cleanup_remove_file(w->tmp);
		free(w->tmp);
		w->tmp = NULL;
	}
	for (w = s->first; w; w = w->next)
		if (w->backup) {
			unlink(w->backup);
			pr_cleanup_remove_file(w->backup);
			free(w->backup);
			w->backup = NULL;
		}
	return rc;
}

int pr_outset_commit(pr_outset *s, int rc, char *err)
{
	pr_csvw *w;
	sigset_t old;

	if (!s)
		return rc;
	for (w = s->first; w; w = w->next) {
		int r;
		if (!w->fp)
			continue;
		r = rc == PR_OK ? finish(w, err) : PR_OK;
		if (rc == PR_OK)
			rc = r;
	}
	if (rc == PR_OK) {
		const char *target = "";
		for (w = s->first; w; w = w->next)
			if (w->kind == W_FILE) {
				target = w->target;
				break;
			}
		pr_cleanup_hold(&old);
		rc = rename_all(s, err);
		pr_commit_end(&old, rc, target);
	}
	free_set(s, rc != PR_OK);
	return rc;
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
