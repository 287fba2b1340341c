/* csvio.h — CSV in and out through libcsv, with line-numbered errors and
 * atomic writes (temporary file renamed on success). */
#ifndef POOLREPS_CSVIO_H
#define POOLREPS_CSVIO_H

#include "poolreps/common.h"

/* The longest field (a column name included) any CSV reader accepts. */
#define PR_CSV_MAX_FIELD 4096

/* A numeric table with a header row. Rows are stored row-major. */
typedef struct pr_csv pr_csv;

/* New empty table with ncols named columns (names are copied). */
pr_csv *pr_csv_new(int ncols, const char *const *names, char *err);
void pr_csv_free(pr_csv *t);

/* Read path (NULL or "-" = stdin). The first row is the header; every other
 * field must be a finite number. Errors name file, line and column:
 * "in.csv:7: column 'vx': not a number: 'abc'". *out is owned by the caller. */
int pr_csv_read(const char *path, pr_csv **out, char *err);

int pr_csv_ncols(const pr_csv *t);
long pr_csv_nrows(const pr_csv *t);
const char *pr_csv_name(const pr_csv *t, int j);
int pr_csv_find(const pr_csv *t, const char *name); /* column index or -1 */
double pr_csv_get(const pr_csv *t, long i, int j);
const double *pr_csv_row(const pr_csv *t, long i);
/* The source line of data row i (1-based file line), for error messages. */
long pr_csv_line(const pr_csv *t, long i);
const char *pr_csv_path(const pr_csv *t); /* "<stdin>" for stdin */

/* A numeric table read in chunks, for commands that handle one row at a
 * time: memory stays bounded whatever the number of rows. The input is read
 * and checked as pr_csv_read does (same limits and messages). open reads
 * through the header; pr_csv_stream_columns gives its names, count and path
 * (use pr_csv_find, pr_csv_name, pr_csv_select on it). Each next call
 * hands out the rows that one more read of the input completed (a pipe's
 * rows as they arrive; from a file about 64 KiB of text), with their source
 * lines (pr_csv_line), or *chunk = NULL at the end. The chunk is owned by the
 * stream and valid until the next call. A failure is returned only after
 * every row before it was handed out, so the rows are the file's good rows
 * up to the first bad one. *out is owned by the caller (pr_csv_stream_free,
 * NULL is a no-op). */
typedef struct pr_csv_stream pr_csv_stream;
int pr_csv_stream_open(const char *path, pr_csv_stream **out, char *err);
const pr_csv *pr_csv_stream_columns(const pr_csv_stream *s);
int pr_csv_stream_next(pr_csv_stream *s, const pr_csv **chunk, char *err);
void pr_csv_stream_free(pr_csv_stream *s);
/* The failure the reads so far found (after the rows still to hand out),
 * or PR_OK: a caller that refuses the header may name an earlier-read bad
 * row first, as a whole-file read would. */
int pr_csv_stream_failed(const pr_csv_stream *s, char *err);

/* Append a row of ncols values; non-finite values are refused. */
int pr_csv_add_row(pr_csv *t, const double *row, char *err);

/* Resolve a column list: "a,b,c" or a prefix ending in '*' ("phi*").
 * Fills cols (capacity maxcols) and returns the count, or a negative status. */
int pr_csv_select(const pr_csv *t, const char *list, int *cols, int maxcols, char *err);

/* Write the table (NULL or "-" = stdout; otherwise atomically). */
int pr_csv_write(const pr_csv *t, const char *path, char *err);

/* ---- writing ----
 *
 * A writer for mixed text and number rows ("%.17g" at most, C locale).
 *
 * Where it writes. NULL, "-", or a path naming the file standard output is
 * already open on (/dev/stdout, /dev/fd/1, or the file stdout is redirected
 * to) write to standard output. A FIFO or device is written in place
 * (renaming over it would replace the device itself). Anything else is a
 * regular file, reached through any chain of symlinks, which is written under
 * a short temporary name in its own folder and renamed over it only when
 * complete, so any name the file system accepts works. A file that existed
 * keeps its permission bits (and, for root, its owner); a file the user may
 * not write is refused, as is a directory.
 *
 * Sticky status. The first failure of any call sticks: a write error (with
 * its errno), or a refused non-finite number (PR_ENUM). Every later call is
 * a no-op returning that status, so a writer may be fed a whole table without
 * checking each call; pr_csvw_close (or pr_outset_commit) reports it once,
 * naming the file, the reason and, for a non-finite number, the row and field.
 *
 * Several outputs of one command go into one pr_outset: they are committed
 * together only after every write succeeded, and on any failure every
 * temporary file is removed and every pre-existing path is left untouched.
 * Temporary files are registered with pr_cleanup_add_file, so a fatal signal
 * removes them too. */
typedef struct pr_csvw pr_csvw;
pr_csvw *pr_csvw_open(const char *path, char *err);
int pr_csvw_str(pr_csvw *w, const char *s);
int pr_csvw_num(pr_csvw *w, double v);  /* PR_ENUM for NaN or inf: never written */
int pr_csvw_int(pr_csvw *w, long v);
int pr_csvw_endrow(pr_csvw *w);
/* A whole header row from a comma list of names, e.g. "policy,count". */
int pr_csvw_header(pr_csvw *w, const char *names);
/* Raw text, not CSV (parameter and provenance files). */
int pr_csvw_raw(pr_csvw *w, const char *s, size_t n);
/* Push the rows written so far to standard output, a FIFO or a device, so
 * that a consumer sees them at once; a staged file keeps its buffer (it
 * appears only when committed). Returns the sticky status. */
int pr_csvw_flush(pr_csvw *w);
/* The sticky status: PR_OK, PR_EIO or PR_ENUM. */
int pr_csvw_status(const pr_csvw *w);
/* Flush, check, rename into place, free; reports the sticky status. */
int pr_csvw_close(pr_csvw *w, char *err);
/* Remove the temporary file and free (after an error). NULL is a no-op. */
void pr_csvw_abort(pr_csvw *w);
/* End a file whose writing stopped with status rc: PR_OK or the writer's own
 * failure closes it (pr_csvw_close reports a write error or a refused NaN);
 * any other failure, already described in err, removes it and returns rc. */
int pr_csvw_finish(pr_csvw *w, int rc, char *err);

/* A set of outputs committed together. */
typedef struct pr_outset pr_outset;
pr_outset *pr_outset_new(char *err);
/* Open one more output of the set (NULL or "-" = stdout) into *w. A path
 * that names the same file as an earlier member (stdout twice included) is
 * refused (PR_EINVAL). The writer belongs to the set: never close or abort
 * it yourself. */
int pr_outset_add(pr_outset *s, const char *path, pr_csvw **w, char *err);
/* If rc is PR_OK and every writer's sticky status is too, rename every
 * member into place (all or none) and return PR_OK; otherwise remove every
 * temporary file and return rc, or the first writer's failure (described in
 * err). Frees the set either way; NULL is a no-op returning rc. */
int pr_outset_commit(pr_outset *s, int rc, char *err);

#endif
