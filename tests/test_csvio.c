/* test_csvio.c — CSV reading (libcsv) with line-numbered errors, atomic writes. */
#include <dirent.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "poolreps/csvio.h"

static char path[64], out[64];

static const char *write_file(const char *text, size_t n)
{
	FILE *fp;

	snprintf(path, sizeof path, "/tmp/pr_test_csv_%ld.csv", (long)getpid());
	fp = fopen(path, "wb");
	assert_non_null(fp);
	fwrite(text, 1, n, fp);
	fclose(fp);
	return path;
}

static int read_text(const char *text, pr_csv **t, char *err)
{
	return pr_csv_read(write_file(text, strlen(text)), t, err);
}

static void test_read_valid_and_odd(void **state)
{
	pr_csv *t;
	char err[PR_ERRLEN];

	(void)state;
	assert_int_equal(read_text("a,b ,\"c\"\r\n1,2,3\r\n\"4\", 5 ,6e-1\r\n", &t, err), PR_OK);
	assert_int_equal(pr_csv_ncols(t), 3);
	assert_int_equal(pr_csv_nrows(t), 2);
	assert_string_equal(pr_csv_name(t, 1), "b");
	assert_int_equal(pr_csv_find(t, "c"), 2);
	assert_int_equal(pr_csv_find(t, "d"), -1);
	assert_float_equal(pr_csv_get(t, 1, 0), 4, 0);
	assert_float_equal(pr_csv_get(t, 1, 1), 5, 0);
	assert_float_equal(pr_csv_get(t, 1, 2), 0.6, 0);
	assert_int_equal(pr_csv_line(t, 1), 3);
	pr_csv_free(t);
	/* no trailing newline, blank lines */
	assert_int_equal(read_text("x\n\n1\n\n2", &t, err), PR_OK);
	assert_int_equal(pr_csv_nrows(t), 2);
	assert_int_equal(pr_csv_line(t, 1), 5);
	pr_csv_free(t);
	/* more blank lines than a field may have bytes: they buffer nothing */
	{
		char *many = malloc(30000);
		size_t k, n = 0;

		assert_non_null(many);
		n += (size_t)sprintf(many, "x,y\n");
		for (k = 0; k < 9000; k++)
			n += (size_t)sprintf(many + n, k % 2 ? "\r\n" : "\n");
		sprintf(many + n, "1,2\n");
		assert_int_equal(read_text(many, &t, err), PR_OK);
		assert_int_equal(pr_csv_nrows(t), 1);
		assert_int_equal(pr_csv_line(t, 0), 9002);
		pr_csv_free(t);
		free(many);
	}
	/* header only */
	assert_int_equal(read_text("x,y\n", &t, err), PR_OK);
	assert_int_equal(pr_csv_nrows(t), 0);
	pr_csv_free(t);
}

static void expect(const char *text, size_t n, int status, const char *needle)
{
	pr_csv *t = NULL;
	char err[PR_ERRLEN] = "";

	assert_int_equal(pr_csv_read(write_file(text, n), &t, err), status);
	assert_null(t);
	if (!strstr(err, needle))
		fail_msg("error '%s' lacks '%s'", err, needle);
	assert_null(strchr(err, '\n'));
}

#define EXPECT(text, status, needle) expect(text, sizeof(text) - 1, status, needle)

static void test_read_errors(void **state)
{
	char *big;

	(void)state;
	EXPECT("", PR_EIO, "empty file");
	EXPECT("a,b\n1,2\n3\n", PR_EIO, ":3: 1 fields, but the header has 2");
	EXPECT("a,b\n1,2,3\n", PR_EIO, ":2: 3 fields");
	EXPECT("a,b\n1,x\n", PR_EIO, ":2: column 'b': not a finite number: 'x'");
	EXPECT("a,b\n1,nan\n", PR_EIO, ":2: column 'b'");
	EXPECT("a,b\n1,-inf\n", PR_EIO, ":2: column 'b'");
	EXPECT("a,b\n1,1e400\n", PR_EIO, ":2: column 'b'");
	EXPECT("a,b\n1,\n", PR_EIO, ":2: column 'b'");
	EXPECT("a,a\n1,2\n", PR_EIO, ":1: header column 'a' appears twice");
	EXPECT("a,\n1,2\n", PR_EIO, ":1: header column 2 is empty");
	EXPECT("a,b\n1,\0\n", PR_EIO, ":2:");
	EXPECT("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", PR_EIO, ":");
	big = malloc(20000);
	assert_non_null(big);
	memcpy(big, "a\n", 2);
	memset(big + 2, '1', 10000);
	big[10002] = '\n';
	expect(big, 10003, PR_EIO, ":2: field 1 is longer than");
	free(big);
	{
		pr_csv *t;
		char err[PR_ERRLEN];
		assert_int_equal(pr_csv_read("/nonexistent.csv", &t, err), PR_EIO);
		assert_non_null(strstr(err, "/nonexistent.csv: cannot open"));
		assert_int_equal(pr_csv_read("/tmp", &t, err), PR_EIO);
		assert_non_null(strstr(err, "is a directory"));
	}
}

static void test_select(void **state)
{
	pr_csv *t;
	char err[PR_ERRLEN];
	int cols[8];

	(void)state;
	assert_int_equal(read_text("phi0,r,phi1,phi2\n1,2,3,4\n", &t, err), PR_OK);
	assert_int_equal(pr_csv_select(t, "phi*", cols, 8, err), 3);
	assert_int_equal(cols[2], 3);
	assert_int_equal(pr_csv_select(t, "r,phi0", cols, 8, err), 2);
	assert_int_equal(cols[0], 1);
	assert_true(pr_csv_select(t, "q", cols, 8, err) < 0);
	assert_non_null(strstr(err, "no column 'q'"));
	assert_true(pr_csv_select(t, "x*", cols, 8, err) < 0);
	assert_true(pr_csv_select(t, "phi*", cols, 2, err) < 0);
	pr_csv_free(t);
}

/* Temporary files of this process in /tmp (".poolreps-tmp-PID-N"). */
static int temp_files(void)
{
	char prefix[64];
	DIR *d = opendir("/tmp");
	struct dirent *e;
	int n = 0;

	snprintf(prefix, sizeof prefix, ".poolreps-tmp-%ld-", (long)getpid());
	while (d && (e = readdir(d)))
		n += strncmp(e->d_name, prefix, strlen(prefix)) == 0;
	if (d)
		closedir(d);
	return n;
}

static void test_write_round_trip_and_atomic(void **state)
{
	const char *names[] = {"x", "y"};
	double row[2] = {0.1, -1e-300}, bad[2] = {1, NAN};
	pr_csv *t, *u;
	pr_csvw *w;
	char err[PR_ERRLEN];

	(void)state;
	t = pr_csv_new(2, names, err);
	assert_non_null(t);
	assert_int_equal(pr_csv_add_row(t, row, err), PR_OK);
	assert_int_equal(pr_csv_add_row(t, bad, err), PR_ENUM);
	snprintf(out, sizeof out, "/tmp/pr_test_csv_out_%ld.csv", (long)getpid());
	assert_int_equal(pr_csv_write(t, out, err), PR_OK);
	assert_int_equal(pr_csv_read(out, &u, err), PR_OK);
	assert_int_equal(pr_csv_nrows(u), 1);
	assert_true(pr_csv_get(u, 0, 0) == 0.1);
	assert_true(pr_csv_get(u, 0, 1) == -1e-300);
	pr_csv_free(u);
	pr_csv_free(t);
	unlink(out);

	/* a NaN is refused and nothing appears under the final name */
	w = pr_csvw_open(out, err);
	assert_non_null(w);
	assert_int_equal(temp_files(), 1);
	pr_csvw_str(w, "a,b");
	pr_csvw_endrow(w);
	assert_int_equal(pr_csvw_num(w, NAN), PR_ENUM);
	assert_int_equal(pr_csvw_close(w, err), PR_ENUM);
	assert_int_equal(access(out, F_OK), -1);
	assert_int_equal(temp_files(), 0);

	w = pr_csvw_open(out, err);
	pr_csvw_str(w, "name");
	pr_csvw_endrow(w);
	pr_csvw_abort(w);
	assert_int_equal(access(out, F_OK), -1);
	assert_int_equal(temp_files(), 0);

	assert_null(pr_csvw_open("/nonexistent/dir/x.csv", err));
	assert_non_null(strstr(err, "cannot write"));
}

/* A header row from a comma list: one field per name, then the row ends. */
static void test_header(void **state)
{
	pr_csvw *w;
	pr_csv *t;
	char err[PR_ERRLEN];

	(void)state;
	snprintf(out, sizeof out, "/tmp/pr_test_csv_hdr_%ld.csv", (long)getpid());
	w = pr_csvw_open(out, err);
	assert_non_null(w);
	assert_int_equal(pr_csvw_header(w, "policy,count,x_1"), PR_OK);
	pr_csvw_int(w, 7);
	pr_csvw_int(w, 3);
	pr_csvw_num(w, 0.5);
	pr_csvw_endrow(w);
	assert_int_equal(pr_csvw_close(w, err), PR_OK);
	assert_int_equal(pr_csv_read(out, &t, err), PR_OK);
	assert_int_equal(pr_csv_ncols(t), 3);
	assert_string_equal(pr_csv_name(t, 0), "policy");
	assert_string_equal(pr_csv_name(t, 2), "x_1");
	assert_int_equal(pr_csv_nrows(t), 1);
	assert_true(pr_csv_get(t, 0, 2) == 0.5);
	pr_csv_free(t);
	unlink(out);
}

/* finish: the writer's own failure is reported by close; another failure
 * (already in err) removes the file and is returned as it is. */
static void test_finish(void **state)
{
	pr_csvw *w;
	char err[PR_ERRLEN], tmp[160];

	(void)state;
	snprintf(out, sizeof out, "/tmp/pr_test_csv_fin_%ld.csv", (long)getpid());
	snprintf(tmp, sizeof tmp, "%s.tmp.%ld", out, (long)getpid());
	w = pr_csvw_open(out, err);
	pr_csvw_header(w, "a");
	assert_int_equal(pr_csvw_finish(w, pr_csvw_num(w, NAN), err), PR_ENUM);
	assert_non_null(strstr(err, "non-finite"));
	assert_int_equal(access(out, F_OK), -1);
	w = pr_csvw_open(out, err);
	pr_csvw_header(w, "a");
	snprintf(err, PR_ERRLEN, "shot failed");
	assert_int_equal(pr_csvw_finish(w, PR_EINVAL, err), PR_EINVAL);
	assert_string_equal(err, "shot failed");
	assert_int_equal(access(out, F_OK), -1);
	assert_int_equal(temp_files(), 0);
	w = pr_csvw_open(out, err);
	pr_csvw_header(w, "a");
	assert_int_equal(pr_csvw_finish(w, PR_OK, err), PR_OK);
	assert_int_equal(access(out, F_OK), 0);
	unlink(out);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_read_valid_and_odd),
		cmocka_unit_test(test_read_errors),
		cmocka_unit_test(test_select),
		cmocka_unit_test(test_write_round_trip_and_atomic),
		cmocka_unit_test(test_header),
		cmocka_unit_test(test_finish),
	};
	int rc = cmocka_run_group_tests(tests, NULL, NULL);
	unlink(path);
	unlink(out);
	return rc;
}
