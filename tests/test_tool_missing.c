/* test_tool_missing.c — `poolreps sweep --missing` (pr_rundir_missing, a call
 * of the tool layer): the unfinished jobs go to the output the caller names,
 * never to a stream it did not give; a malformed jobs.txt writes nothing. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "poolreps/rundir.h"

static const char *const JOBS[] = {"poolreps run a.ini -o runs/p0\n",
                                   "poolreps run a.ini -o runs/p1\n"};

static void write_file(const char *path, const char *text)
{
	FILE *fp = fopen(path, "w");

	assert_non_null(fp);
	assert_int_equal(fputs(text, fp) >= 0, 1);
	assert_int_equal(fclose(fp), 0);
}

/* The whole file, or NULL when there is none. Caller frees. */
static char *slurp(const char *path)
{
	FILE *fp = fopen(path, "r");
	char *buf;
	size_t n;

	if (!fp)
		return NULL;
	buf = calloc(4096, 1);
	assert_non_null(buf);
	n = fread(buf, 1, 4095, fp);
	buf[n] = '\0';
	fclose(fp);
	return buf;
}

/* A sweep folder of two jobs over one grid key, neither run yet. */
static void make_sweep(const char *root, int extra_job_line)
{
	char path[512], jobs[256];

	snprintf(jobs, sizeof jobs, "%s%s", JOBS[0], JOBS[1]);
	snprintf(path, sizeof path, "%s/manifest.csv", root);
	write_file(path, "job,point,exp.x,repetition,variant,variant_name,output\n"
	                 "0,0,1,-1,-1,all,runs/p0\n"
	                 "1,1,2,-1,-1,all,runs/p1\n");
	snprintf(path, sizeof path, "%s/jobs.txt", root);
	write_file(path, extra_job_line ? "a\nb\nc\n" : jobs);
}

/* Remove the folder and what the tests put there. */
static void remove_sweep(const char *dir)
{
	static const char *const files[] = {"stdout.txt", "manifest.csv", "jobs.txt", "todo.txt"};
	char path[512];
	size_t i;

	for (i = 0; i < sizeof files / sizeof files[0]; ++i) {
		snprintf(path, sizeof path, "%s/%s", dir, files[i]);
		unlink(path);
	}
	assert_int_equal(rmdir(dir), 0);
}

/* stdout to a file for the duration of one call: what lands there. */
static char *call_capturing_stdout(const char *dir, const char *root, const char *out, int *rc,
                                   char *err)
{
	char cap[512];
	int saved, fd;

	snprintf(cap, sizeof cap, "%s/stdout.txt", dir);
	fflush(stdout);
	saved = dup(STDOUT_FILENO);
	assert_true(saved >= 0);
	assert_non_null(freopen(cap, "w", stdout));
	*rc = pr_rundir_missing(root, out, err);
	fflush(stdout);
	fd = dup2(saved, STDOUT_FILENO);
	assert_true(fd >= 0);
	close(saved);
	return slurp(cap);
}

/* A fresh sweep folder (extra: a jobs.txt of one line too many), then
 * pr_rundir_missing into dir/todo.txt: its status; nothing on stdout. */
static int run_missing(char *dir, int extra, char *out, size_t n, char *err)
{
	char *captured;
	int rc;

	assert_non_null(mkdtemp(dir));
	make_sweep(dir, extra);
	snprintf(out, n, "%s/todo.txt", dir);
	captured = call_capturing_stdout(dir, dir, out, &rc, err);
	assert_string_equal(captured, "");
	free(captured);
	return rc;
}

static void test_the_jobs_go_to_the_named_output_and_nothing_to_stdout(void **state)
{
	char dir[] = "/tmp/pr_missing_XXXXXX", out[512], err[PR_ERRLEN] = "", expect[256];
	char *got;

	(void)state;
	assert_int_equal(run_missing(dir, 0, out, sizeof out, err), PR_OK);
	snprintf(expect, sizeof expect, "%s%s", JOBS[0], JOBS[1]);
	got = slurp(out);
	assert_non_null(got);
	assert_string_equal(got, expect);
	free(got);
	remove_sweep(dir);
}

static void test_a_malformed_jobs_file_writes_nothing(void **state)
{
	char dir[] = "/tmp/pr_missing_XXXXXX", out[512], err[PR_ERRLEN] = "";

	(void)state;
	assert_int_equal(run_missing(dir, 1, out, sizeof out, err), PR_EIO);
	assert_non_null(strstr(err, "jobs.txt:3: more jobs than manifest.csv lists"));
	assert_int_equal(access(out, F_OK), -1);
	remove_sweep(dir);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_the_jobs_go_to_the_named_output_and_nothing_to_stdout),
		cmocka_unit_test(test_a_malformed_jobs_file_writes_nothing),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
