/* fuzz_csv.c — libFuzzer harness for the CSV reader and writer.
 *
 * The input is written to a temporary file and read with pr_csv_read. A
 * table that reads is put through pr_csv_select (every column by prefix,
 * the first and the last column by name), written with pr_csv_write and read
 * back: the copy must hold the same names and bit-identical numbers, and no
 * temporary file may remain. Errors must be one line starting with the path. */
#include "fuzz_common.h"
#include "poolreps/csvio.h"

static void same_or_abort(const pr_csv *a, const pr_csv *b)
{
	long i;
	int j;

	if (pr_csv_ncols(a) != pr_csv_ncols(b) || pr_csv_nrows(a) != pr_csv_nrows(b))
		abort();
	for (j = 0; j < pr_csv_ncols(a); ++j)
		if (strcmp(pr_csv_name(a, j), pr_csv_name(b, j)) != 0) {
			fprintf(stderr, "fuzz harness: column %d: '%s' reads back as '%s'\n", j,
			        pr_csv_name(a, j), pr_csv_name(b, j));
			abort();
		}
	for (i = 0; i < pr_csv_nrows(a); ++i)
		for (j = 0; j < pr_csv_ncols(a); ++j)
			if (memcmp(pr_csv_row(a, i) + j, pr_csv_row(b, i) + j, sizeof(double)) != 0)
				abort();
}

/* A name that a column list can spell as itself. */
static int plain(const char *name)
{
	return strlen(name) < 256 && !strpbrk(name, ",*");
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static char path[256], out[256];
	pr_csv *t = NULL, *u = NULL;
	char err[PR_ERRLEN], list[8300]; /* two header names of at most 4096 bytes */
	int cols[8], n, last;

	if (!path[0]) {
		fuzz_tmp_path(path, sizeof path, "csv_in", "csv");
		fuzz_tmp_path(out, sizeof out, "csv_out", "csv");
	}
	fuzz_write_file(path, data, size);
	err[0] = '\0';
	if (pr_csv_read(path, &t, err) != PR_OK) {
		if (t)
			abort();
		fuzz_check_err(err, path);
		return 0;
	}
	/* "*" selects every column, so it fails exactly when there are more than 8 */
	last = pr_csv_ncols(t) - 1;
	n = pr_csv_select(t, "*", cols, 8, err);
	if (n < 0)
		fuzz_check_err(err, path);
	if ((n < 0) != (pr_csv_ncols(t) > 8) || (n >= 0 && n != pr_csv_ncols(t)))
		abort();
	snprintf(list, sizeof list, "%s,%s", pr_csv_name(t, 0), pr_csv_name(t, last));
	n = pr_csv_select(t, list, cols, 8, err);
	if (n < 0)
		fuzz_check_err(err, path);
	else if (plain(pr_csv_name(t, 0)) && plain(pr_csv_name(t, last)) &&
	         (n != 2 || cols[0] != 0 || cols[1] != last))
		abort();

	unlink(out);
	if (pr_csv_write(t, out, err) != PR_OK) {
		fprintf(stderr, "fuzz harness: writing a table that was read failed: %s\n", err);
		abort();
	}
	fuzz_check_no_tmp(out);
	/* The reader drops a byte-order mark at the start of the file only; one
	 * before a header row further down stays in the first name, and the copy
	 * (header on line 1) would lose it. */
	if (strncmp(pr_csv_name(t, 0), "\xEF\xBB\xBF", 3) == 0) {
		pr_csv_free(t);
		return 0;
	}
	if (pr_csv_read(out, &u, err) != PR_OK) {
		fprintf(stderr, "fuzz harness: a written table does not read back: %s\n", err);
		abort();
	}
	same_or_abort(t, u);
	pr_csv_free(u);
	pr_csv_free(t);
	return 0;
}
