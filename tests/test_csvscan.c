/* test_csvscan.c — the reader's direct split of plain lines gives exactly
 * what libcsv gives: on seeded random files (quotes, blanks, carriage
 * returns, empty lines, empty fields, wrong field counts, long fields and
 * lines longer than a read block) pr_csv_scan reports the same records,
 * fields, line numbers, status and message with and without
 * PR_CSV_LIBCSV_ONLY. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>
#include <gsl/gsl_rng.h>

#include "poolreps/common.h"
#include "csvio_priv.h"
#include "text_buf.h"

static int record(void *user, const char *path, long line, int n, char **fields, char *err)
{
	text_buf *g = user;
	char head[64];
	int j;

	(void)path;
	(void)err;
	text_append(g, head, (size_t)snprintf(head, sizeof head, "\n%ld:%d:", line, n));
	for (j = 0; j < n; ++j) {
		text_append(g, fields[j], strlen(fields[j]));
		text_append(g, "\x1f", 1);
	}
	return PR_OK;
}

/* One scan as text: every record, then the status and the message. */
static char *scan(const char *file, unsigned flags)
{
	text_buf g = { NULL, 0, 0 };
	char err[PR_ERRLEN] = "", tail[PR_ERRLEN + 32];
	int rc = pr_csv_scan(file, flags, record, record, &g, err);

	text_append(&g, tail, (size_t)snprintf(tail, sizeof tail, "\nstatus %d: %s", rc, rc ? err : ""));
	return g.buf;
}

/* A random CSV text: mostly plain numeric lines, some with the bytes
 * libcsv treats specially. */
static size_t random_csv(gsl_rng *r, char *buf, size_t cap)
{
	static const char *odd[] = {"\"", "\"\"", " ", "\t", "\r", "\r\n", ",", "\n", "x", "\"a,b\"",
	                            " 1 ", "\"q\"\"q\"", ""};
	int rows = 1 + (int)gsl_rng_uniform_int(r, 30), cols = 1 + (int)gsl_rng_uniform_int(r, 6);
	int long_lines = gsl_rng_uniform_int(r, 8) == 0, i, j;
	size_t n = 0;

	for (i = 0; i < rows && n + 70000 < cap; ++i) {
		int c = gsl_rng_uniform_int(r, 10) == 0 ? cols + (int)gsl_rng_uniform_int(r, 3) - 1 : cols;
		for (j = 0; j < c; ++j) {
			if (j)
				buf[n++] = ',';
			if (gsl_rng_uniform_int(r, 12) == 0)
				n += (size_t)sprintf(buf + n, "%s", odd[gsl_rng_uniform_int(r, 13)]);
			else if (long_lines)
				n += (size_t)sprintf(buf + n, "%.*d", 1 + (int)gsl_rng_uniform_int(r, 4200), 7);
			else
				n += (size_t)sprintf(buf + n, "%.17g", gsl_rng_uniform(r) - 0.5);
		}
		switch (gsl_rng_uniform_int(r, 12)) {
		case 0: n += (size_t)sprintf(buf + n, "\r\n"); break;
		case 1: n += (size_t)sprintf(buf + n, "\n\n"); break;
		case 2: if (i == rows - 1) break; /* fall through */
		default: buf[n++] = '\n'; break;
		}
	}
	return n;
}

static void test_direct_split_is_libcsv(void **state)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	size_t cap = 1 << 22, n;
	char *buf = malloc(cap), file[64];
	int k, flags;

	(void)state;
	assert_non_null(buf);
	gsl_rng_set(r, 5);
	snprintf(file, sizeof file, "/tmp/pr_test_csvscan_%ld.csv", (long)getpid());
	for (k = 0; k < 2000; ++k) {
		FILE *fp = fopen(file, "wb");
		assert_non_null(fp);
		n = random_csv(r, buf, cap);
		assert_int_equal(fwrite(buf, 1, n, fp), n);
		fclose(fp);
		for (flags = 0; flags <= PR_CSV_COMPLETE; ++flags) {
			char *a = scan(file, (unsigned)flags), *b = scan(file, (unsigned)flags | PR_CSV_LIBCSV_ONLY);
			if (strcmp(a, b) != 0)
				fail_msg("file %d: direct split\n%s\n--- libcsv\n%s", k, a, b);
			free(a);
			free(b);
		}
	}
	unlink(file);
	free(buf);
	gsl_rng_free(r);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_direct_split_is_libcsv),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
