/* fuzz_config.c — libFuzzer harness for the parameter-file reader.
 *
 * The input is written to a temporary file and read with pr_config_load,
 * then checked with pr_config_validate. Beyond "no crash", it checks that
 * every error is one line starting with the file name, and that a file that
 * loads writes an effective configuration that loads again (what every run
 * records must be readable). The input up to its first NUL also goes through
 * pr_config_set, the --set path. */
#include "fuzz_common.h"
#include "poolreps/config.h"
#include "poolreps/exp.h"
#include "poolreps/internal.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static char path[256], again[256];
	pr_config c, d;
	char err[PR_ERRLEN], *s;
	FILE *fp;

	if (!path[0]) {
		fuzz_tmp_path(path, sizeof path, "config", "ini");
		fuzz_tmp_path(again, sizeof again, "config_again", "ini");
	}
	fuzz_write_file(path, data, size);
	pr_config_init(&c, pr_exp_config);
	err[0] = '\0';
	if (pr_config_load(&c, path, err) != PR_OK) {
		fuzz_check_err(err, path);
	} else {
		if (pr_config_validate(&c, err) != PR_OK)
			fuzz_check_err(err, path);
		fp = fopen(again, "wb");
		if (!fp || pr_config_write(&c, fp) != PR_OK || fclose(fp) != 0)
			abort();
		pr_config_init(&d, pr_exp_config);
		if (pr_config_load(&d, again, err) != PR_OK) {
			fprintf(stderr, "fuzz harness: effective configuration does not reload: %s\n", err);
			abort();
		}
	}

	s = malloc(size + 1);
	if (!s)
		abort();
	memcpy(s, data, size);
	s[size] = '\0';
	pr_config_init(&c, pr_exp_config);
	if (pr_config_set(&c, s, err) != PR_OK)
		fuzz_check_err(err, NULL);
	free(s);
	return 0;
}
