/* fuzz_common.h — helpers shared by the libFuzzer harnesses: temporary file
 * names per process and the invariants every error message must keep. */
#ifndef POOLREPS_FUZZ_COMMON_H
#define POOLREPS_FUZZ_COMMON_H

#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "poolreps/common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Temporary files of this process, removed when libFuzzer exits. */
static char fuzz_paths[4][256];

static void fuzz_cleanup(void)
{
	int i;

	for (i = 0; i < 4; ++i)
		if (fuzz_paths[i][0])
			unlink(fuzz_paths[i]);
}

/* "<TMPDIR or /tmp>/pr_fuzz_<tag>_<pid>.<ext>" into buf (n <= 256). */
static inline void fuzz_tmp_path(char *buf, size_t n, const char *tag, const char *ext)
{
	const char *dir = getenv("TMPDIR");
	int i;

	snprintf(buf, n, "%s/pr_fuzz_%s_%ld.%s", dir && *dir ? dir : "/tmp", tag, (long)getpid(), ext);
	for (i = 0; i < 4 && fuzz_paths[i][0]; ++i)
		;
	if (i == 4)
		abort();
	if (i == 0)
		atexit(fuzz_cleanup);
	snprintf(fuzz_paths[i], sizeof fuzz_paths[i], "%s", buf);
}

/* Write the fuzz input to path; a failure here is the harness's, not the library's. */
static inline void fuzz_write_file(const char *path, const uint8_t *data, size_t size)
{
	FILE *fp = fopen(path, "wb");

	if (!fp || (size && fwrite(data, 1, size, fp) != size) || fclose(fp) != 0) {
		fprintf(stderr, "fuzz harness: cannot write %s\n", path);
		abort();
	}
}

/* The CLI prints err as one line: it must be non-empty, free of line breaks,
 * shorter than PR_ERRLEN, and (when prefix is given) start with it. */
static inline void fuzz_check_err(const char *err, const char *prefix)
{
	size_t n = strnlen(err, PR_ERRLEN);

	if (n == 0 || n == PR_ERRLEN || strpbrk(err, "\r\n") ||
	    (prefix && strncmp(err, prefix, strlen(prefix)) != 0)) {
		fprintf(stderr, "fuzz harness: bad error message: '%.*s'\n", (int)n, err);
		abort();
	}
}

/* No temporary file of this process (".poolreps-tmp-<pid>-<n>" in the
 * folder of path) may remain after a call returned. */
static inline void fuzz_check_no_tmp(const char *path)
{
	char dir[1024], prefix[64];
	const char *slash = strrchr(path, '/');
	struct dirent *e;
	DIR *d;

	snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - path) : 1, slash ? path : ".");
	snprintf(prefix, sizeof prefix, ".poolreps-tmp-%ld-", (long)getpid());
	if (!(d = opendir(dir)))
		return;
	while ((e = readdir(d)))
		if (strncmp(e->d_name, prefix, strlen(prefix)) == 0) {
			fprintf(stderr, "fuzz harness: temporary file %s/%s left behind\n", dir, e->d_name);
			abort();
		}
	closedir(d);
}

#endif
