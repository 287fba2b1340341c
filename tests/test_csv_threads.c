/* test_csv_threads.c — a CSV file read in parts on several threads
 * (pr_csv_read_threads) gives what pr_csv_read gives: the same status and
 * message, and for a good file the same names, values (bits), rows and
 * lines, on seeded random files of 1.2 to 3 MiB in every form the reader
 * takes (blank lines, CRLF, blanks around fields, quoted fields, a
 * byte-order mark, no final line end, numbers strtod must read) and with
 * one defect placed late in the file (a bad number, a short row, a NUL, an
 * over-long field, an open quote). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>
#include <gsl/gsl_rng.h>

#include "poolreps/csvio.h"
#include "csvio_priv.h"
#include "text_buf.h"

/* One field: mostly what the writer prints; with hard, sometimes what
 * other tools do (numbers only strtod reads). */
static void number(text_buf *t, gsl_rng *r, int hard)
{
	char buf[64];
	double x = (gsl_rng_uniform(r) - 0.5) * 1e3;
	int c = (int)gsl_rng_uniform_int(r, 12);

	if (!hard && c >= 3 && c <= 5)
		c = 6;
	switch (c) {
	case 0: snprintf(buf, sizeof buf, "%ld", (long)(x * 1e3)); break;
	case 1: snprintf(buf, sizeof buf, "%.3e", x * 1e-10); break;
	case 2: snprintf(buf, sizeof buf, "0000%.6f", x < 0 ? -x : x); break;
	case 3: snprintf(buf, sizeof buf, "%.25f", x); break; /* more digits than the exact path takes */
	case 4: snprintf(buf, sizeof buf, "%a", x); break;       /* hex */
	case 5: snprintf(buf, sizeof buf, "%.3e", x * 1e-300); break; /* an exponent past 27 */
	case 6: snprintf(buf, sizeof buf, "+.%u", (unsigned)gsl_rng_get(r)); break;
	default: snprintf(buf, sizeof buf, "%.17g", x); break;
	}
	text_puts(t, buf);
}

/* A line end: LF, or CRLF. */
static void eol(text_buf *t, gsl_rng *r, int crlf)
{
	text_puts(t, crlf && gsl_rng_uniform_int(r, 2) ? "\r\n" : "\n");
}

enum { GOOD, BAD_NUMBER, SHORT_ROW, NUL, LONG_FIELD, OPEN_QUOTE, QUOTED_NEWLINE, NDEFECTS };

/* A file of at least `bytes` bytes with ncols columns; with a defect, in
 * the last third; hard: with what the parts leave to the one reader (a
 * quoted header, blanks, quoted fields, numbers only strtod reads). Returns
 * the text (NUL-terminated, n bytes). */
static text_buf make_file(gsl_rng *r, size_t bytes, int ncols, int defect, int hard)
{
	text_buf t = { NULL, 0, 0 };
	char name[32];
	const int bom = gsl_rng_uniform_int(r, 4) == 0,
	          crlf = gsl_rng_uniform_int(r, 2), blanks = hard && gsl_rng_uniform_int(r, 3) == 0,
	          quotes = hard && gsl_rng_uniform_int(r, 2) == 0, last_eol = gsl_rng_uniform_int(r, 4) != 0;
	int j, placed = 0, here;

	if (bom)
		text_puts(&t, "\xEF\xBB\xBF");
	for (j = 0; j < ncols; j++) {
		snprintf(name, sizeof name, j == 1 && quotes ? "%s\"c,%d\"" : "%sc%d", j ? "," : "", j);
		text_puts(&t, name);
	}
	eol(&t, r, crlf);
	while (t.len < bytes) {
		here = defect && !placed && t.len > bytes * 2 / 3;
		if (gsl_rng_uniform_int(r, 50) == 0) { /* a blank line */
			eol(&t, r, crlf);
			continue;
		}
		for (j = 0; j < ncols; j++) {
			if (j)
				text_puts(&t, ",");
			if (here && j == ncols - 1) {
				switch (defect) {
				case BAD_NUMBER: text_puts(&t, "1.5x"); break;
				/* one field less (drops the comma), or one more */
				case SHORT_ROW: ncols > 1 ? (void)t.len-- : text_puts(&t, "1,2"); break;
				case NUL: text_append(&t, "1\0", 2); break;
				case LONG_FIELD: {
					char *z = malloc(5000);
					memset(z, '0', 5000);
					text_append(&t, z, 5000);
					free(z);
					text_puts(&t, "1");
					break;
				}
				case OPEN_QUOTE: text_puts(&t, "\"2"); break;
				case QUOTED_NEWLINE: text_puts(&t, "\"2\n\""); break;
				default: break;
				}
				placed = 1;
				continue;
			}
			if (blanks && gsl_rng_uniform_int(r, 20) == 0)
				text_puts(&t, " ");
			if (quotes && gsl_rng_uniform_int(r, 500) == 0) {
				text_puts(&t, "\"");
				number(&t, r, hard);
				text_puts(&t, "\"");
			} else {
				number(&t, r, hard);
			}
		}
		if (t.len < bytes || last_eol)
			eol(&t, r, crlf);
	}
		return t;
}

/* Both readers on the file: the same answer. */
static void compare(const char *path, int threads)
{
	pr_csv *a = NULL, *b = NULL;
	char ea[PR_ERRLEN] = "", eb[PR_ERRLEN] = "";
	int ra = pr_csv_read(path, &a, ea), rb = pr_csv_read_threads(path, threads, &b, eb), j;
	long i;

	assert_int_equal(ra, rb);
	if (ra != PR_OK) {
		assert_string_equal(ea, eb);
		assert_null(b);
		return;
	}
	assert_int_equal(pr_csv_ncols(a), pr_csv_ncols(b));
	assert_int_equal(pr_csv_nrows(a), pr_csv_nrows(b));
	for (j = 0; j < pr_csv_ncols(a); j++)
		assert_string_equal(pr_csv_name(a, j), pr_csv_name(b, j));
	for (i = 0; i < pr_csv_nrows(a); i++) {
		if (memcmp(pr_csv_row(a, i), pr_csv_row(b, i), (size_t)pr_csv_ncols(a) * sizeof(double)))
			fail_msg("%s: row %ld differs on %d threads", path, i, threads);
		assert_int_equal(pr_csv_line(a, i), pr_csv_line(b, i));
	}
	assert_string_equal(pr_csv_path(a), pr_csv_path(b));
	pr_csv_free(a);
	pr_csv_free(b);
}

static char path[64];

static void write_text(const text_buf *t)
{
	FILE *fp = fopen(path, "wb");

	assert_non_null(fp);
	assert_int_equal(fwrite(t->buf, 1, t->len, fp), t->len);
	assert_int_equal(fclose(fp), 0);
}

static void test_same_answer(void **state)
{
	static const int threads[] = { 2, 3, 4, 7 };
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	long parts_before = pr_csv_parts_reads(), good = 0;
	int c, k, defect;

	(void)state;
	gsl_rng_set(r, 20261204);
	for (c = 0; c < 3 * NDEFECTS; c++) {
		static const int widths[] = { 1, 3, 17, 40 };
		text_buf t;

		defect = c % NDEFECTS;
		t = make_file(r, (size_t)(1.2e6 + gsl_rng_uniform(r) * 1.8e6),
		              widths[gsl_rng_uniform_int(r, 4)], defect, c / NDEFECTS == 1);
		write_text(&t);
		for (k = 0; k < 4; k++)
			compare(path, threads[k]);
		good += defect == GOOD;
		free(t.buf);
	}
	/* the parts' way ran (good files without quotes take it) */
	assert_true(pr_csv_parts_reads() > parts_before);
	assert_true(good > 0);
	gsl_rng_free(r);
	unlink(path);
}

/* A header line that holds data rows too (a bare carriage return ends the
 * header record): the one reader reads it, with the same rows. */
static void test_header_line_with_rows(void **state)
{
	text_buf t = { NULL, 0, 0 };
	char row[64];
	long before = pr_csv_parts_reads(), i;

	(void)state;
	text_puts(&t, "R,phi0\r0.5,1.25\r0.25,3\n");
	for (i = 0; t.len < 1300000; i++) {
		snprintf(row, sizeof row, "%ld.5,%ld\n", i % 7, i % 13);
		text_puts(&t, row);
	}
		write_text(&t);
	compare(path, 2);
	compare(path, 5);
	assert_int_equal(pr_csv_parts_reads(), before);
	free(t.buf);
	unlink(path);
}

/* A FIFO is never opened to look at it (that would wait for a writer, or
 * take and drop what one wrote): its rows come through whole. */
static void test_fifo(void **state)
{
	char fifo[64];
	pr_csv *t = NULL;
	char err[PR_ERRLEN];
	pid_t pid;
	int st;

	(void)state;
	snprintf(fifo, sizeof fifo, "/tmp/pr_test_csvt_fifo_%ld", (long)getpid());
	unlink(fifo);
	assert_int_equal(mkfifo(fifo, 0600), 0);
	pid = fork();
	assert_true(pid >= 0);
	if (pid == 0) {
		FILE *fp = fopen(fifo, "w");
		_exit(fp && fputs("R,phi0\n1,2\n3,4\n5,7\n", fp) >= 0 && fclose(fp) == 0 ? 0 : 1);
	}
	alarm(20); /* a hang fails the test */
	assert_int_equal(pr_csv_read_threads(fifo, 2, &t, err), PR_OK);
	alarm(0);
	assert_int_equal(pr_csv_nrows(t), 3);
	pr_csv_free(t);
	assert_int_equal(waitpid(pid, &st, 0), pid);
	assert_true(WIFEXITED(st) && WEXITSTATUS(st) == 0);
	unlink(fifo);
}

/* Small files, stdin-like paths and non-files take the one-thread way and
 * answer as pr_csv_read does. */
static void test_one_thread_cases(void **state)
{
	long before = pr_csv_parts_reads();

	(void)state;
	{
		text_buf t = { NULL, 0, 0 };
		text_puts(&t, "a,b\n1,2\n");
				write_text(&t);
		compare(path, 4);
		free(t.buf);
	}
	compare("/nonexistent.csv", 4);
	compare("/tmp", 4);
	compare("/dev/null", 4);
	assert_int_equal(pr_csv_parts_reads(), before);
	unlink(path);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_same_answer),
		cmocka_unit_test(test_one_thread_cases),
		cmocka_unit_test(test_header_line_with_rows),
		cmocka_unit_test(test_fifo),
	};

	snprintf(path, sizeof path, "/tmp/pr_test_csvt_%ld.csv", (long)getpid());
	return cmocka_run_group_tests(tests, NULL, NULL);
}
