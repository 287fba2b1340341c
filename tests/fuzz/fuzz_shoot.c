/* fuzz_shoot.c — libFuzzer harness for the `shoot` input path.
 *
 * The input is written to a temporary CSV and run through pr_shoot_csv with
 * the default configuration, output and trace to temporary files. On
 * success the output must read back as a CSV with one row per input row
 * (no NaN or inf can reach it: the reader refuses them); on failure the
 * error must be one line and neither output nor trace may exist. */
#include "fuzz_common.h"
#include "poolreps/config.h"
#include "poolreps/csvio.h"
#include "poolreps/exp.h"
#include "poolreps/internal.h"
#include "poolreps/shoot.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static char in[256], out[256], trace[256];
	static pr_config cfg;
	pr_shoot_files f;
	pr_csv *ti = NULL, *to = NULL;
	char err[PR_ERRLEN];

	if (!in[0]) {
		fuzz_tmp_path(in, sizeof in, "shoot_in", "csv");
		fuzz_tmp_path(out, sizeof out, "shoot_out", "csv");
		fuzz_tmp_path(trace, sizeof trace, "shoot_trace", "csv");
		pr_config_init(&cfg, pr_exp_config);
	}
	fuzz_write_file(in, data, size);
	unlink(out);
	unlink(trace);
	memset(&f, 0, sizeof f);
	f.input = in;
	f.output = out;
	f.trace = size % 2 ? trace : NULL; /* half the inputs also write a trace */
	err[0] = '\0';
	if (pr_shoot_csv(&cfg, &f, err) != PR_OK) {
		fuzz_check_err(err, NULL);
		if (access(out, F_OK) == 0 || access(trace, F_OK) == 0) {
			fprintf(stderr, "fuzz harness: failed shoot left an output file: %s\n", err);
			abort();
		}
	} else {
		if (pr_csv_read(in, &ti, err) != PR_OK || pr_csv_read(out, &to, err) != PR_OK) {
			fprintf(stderr, "fuzz harness: shoot output does not read back: %s\n", err);
			abort();
		}
		if (pr_csv_nrows(ti) != pr_csv_nrows(to))
			abort();
		pr_csv_free(ti);
		pr_csv_free(to);
	}
	fuzz_check_no_tmp(out);
	fuzz_check_no_tmp(trace);
	return 0;
}
