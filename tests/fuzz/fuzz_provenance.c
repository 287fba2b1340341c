/* fuzz_provenance.c — libFuzzer harness for the strict reader of a run
 * folder's provenance.txt (pr_outdir_earlier_run): the input is the file.
 * Beyond no crash, no leak, no UB: an error is one line naming the file; a
 * record that reads lists only plain names poolreps writes (never a '/',
 * never a leading '.'), so a later run can remove nothing else. */
#include <sys/stat.h>

#include "fuzz_common.h"
#include "outdir.h"

static char dir[256], file[300];

static void remove_dir(void)
{
	unlink(file);
	rmdir(dir);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	char err[PR_ERRLEN] = "";
	pr_names names = {NULL, 0};
	int rc, i;

	if (!dir[0]) {
		const char *t = getenv("TMPDIR");
		snprintf(dir, sizeof dir, "%s/pr_fuzz_prov_%ld", t && *t ? t : "/tmp", (long)getpid());
		snprintf(file, sizeof file, "%s/provenance.txt", dir);
		if (mkdir(dir, 0777) != 0)
			abort();
		atexit(remove_dir);
	}
	fuzz_write_file(file, data, size);
	rc = pr_outdir_earlier_run(dir, &names, err);
	if (rc != PR_OK) {
		if (rc != PR_EIO && rc != PR_ENOMEM)
			abort();
		fuzz_check_err(err, file);
		if (names.n)
			abort();
	}
	for (i = 0; i < names.n; ++i) {
		const char *n = names.name[i];
		if (!*n || n[0] == '.' || strchr(n, '/') || !pr_outdir_own_name(n, strlen(n))) {
			fprintf(stderr, "fuzz harness: a name a later run would remove: '%s'\n", n);
			abort();
		}
	}
	pr_names_free(&names);
	return 0;
}
