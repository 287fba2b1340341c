/* test_syrk.c — pr_syrk_acc_rows gives the bits of the plain triple loop (each
 * H_jk summed over the rows in order), on seeded random matrices of
 * several widths, rows split into calls of several sizes, and values
 * spanning many decades (where a reordered or fused sum would differ);
 * so does pr_syrk_acc_rows over the row ranges pr_syrk_split gives any
 * number of threads, which cover H's rows once, in tile multiples, without
 * reading the columns of Y that such a thread does not fill. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <gsl/gsl_rng.h>

#include "syrk_priv.h"

static void test_syrk_is_the_scalar_loop(void **state)
{
	static const int widths[] = {1, 15, 16, 17, 40, 140, 200};
	static const int chunks[] = {1, 7, 64, 1000};
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	const int m = 300;
	size_t w, c;

	(void)state;
	gsl_rng_set(r, 23);
	for (w = 0; w < sizeof widths / sizeof *widths; w++) {
		const int nf = widths[w], nfp = (nf + PR_SYRK_W - 1) / PR_SYRK_W * PR_SYRK_W;
		double *Y = calloc((size_t)m * nfp, sizeof *Y), *H = malloc((size_t)nfp * nfp * sizeof *H);
		double *ref = calloc((size_t)nf * nf, sizeof *ref);
		int i, j, k;

		assert_true(Y && H && ref);
		for (i = 0; i < m; i++)
			for (j = 0; j < nf; j++)
				Y[(size_t)i * nfp + j] = (gsl_rng_uniform(r) - 0.5) * pow(10.0, 8.0 * gsl_rng_uniform(r) - 4.0);
		for (i = 0; i < m; i++)
			for (j = 0; j < nf; j++)
				for (k = j; k < nf; k++)
					ref[(size_t)j * nf + k] += Y[(size_t)i * nfp + j] * Y[(size_t)i * nfp + k];
		for (c = 0; c < sizeof chunks / sizeof *chunks; c++) {
			memset(H, 0, (size_t)nfp * nfp * sizeof *H);
			for (i = 0; i < m; i += chunks[c])
				pr_syrk_acc_rows(Y + (size_t)i * nfp, m - i < chunks[c] ? m - i : chunks[c], nfp,
				                 H, 0, nfp);
			for (j = 0; j < nf; j++)
				for (k = j; k < nf; k++)
					if (memcmp(&H[(size_t)j * nfp + k], &ref[(size_t)j * nf + k], sizeof *H))
						fail_msg("width %d, chunk %d: H[%d][%d] = %.17g, loop %.17g", nf,
						         chunks[c], j, k, H[(size_t)j * nfp + k], ref[(size_t)j * nf + k]);
		}
		free(Y);
		free(H);
		free(ref);
	}
	gsl_rng_free(r);
}

static void test_split_rows_are_the_scalar_loop(void **state)
{
	static const int widths[] = {16, 48, 144, 208};
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	const int m = 130;
	size_t w;

	(void)state;
	gsl_rng_set(r, 29);
	for (w = 0; w < sizeof widths / sizeof *widths; w++) {
		const int nfp = widths[w];
		double *Y = malloc((size_t)m * nfp * sizeof *Y), *H = malloc((size_t)nfp * nfp * sizeof *H);
		double *ref = calloc((size_t)nfp * nfp, sizeof *ref), *Yp = malloc((size_t)m * nfp * sizeof *Yp);
		int i, j, k, parts, t;

		assert_true(Y && H && ref && Yp);
		for (i = 0; i < m * nfp; i++)
			Y[i] = (gsl_rng_uniform(r) - 0.5) * pow(10.0, 8.0 * gsl_rng_uniform(r) - 4.0);
		for (i = 0; i < m; i++)
			for (j = 0; j < nfp; j++)
				for (k = j; k < nfp; k++)
					ref[(size_t)j * nfp + k] += Y[(size_t)i * nfp + j] * Y[(size_t)i * nfp + k];
		for (parts = 1; parts <= 7; parts++) {
			memset(H, 0, (size_t)nfp * nfp * sizeof *H);
			assert_int_equal(pr_syrk_split(nfp, parts, 0), 0);
			assert_int_equal(pr_syrk_split(nfp, parts, parts), nfp);
			for (t = 0; t < parts; t++) {
				const int lo = pr_syrk_split(nfp, parts, t), hi = pr_syrk_split(nfp, parts, t + 1);

				assert_true(lo <= hi && lo % PR_SYRK_TJ == 0 && (hi % PR_SYRK_TJ == 0 || hi == nfp));
				/* the columns below lo's run of PR_SYRK_W are not read (a
				 * thread does not fill them): NaN there would show */
				memcpy(Yp, Y, (size_t)m * nfp * sizeof *Yp);
				for (i = 0; i < m; i++)
					for (j = 0; j < lo / PR_SYRK_W * PR_SYRK_W; j++)
						Yp[(size_t)i * nfp + j] = NAN;
				/* in two calls over the rows, as a thread does in blocks */
				pr_syrk_acc_rows(Yp, 50, nfp, H, lo, hi);
				pr_syrk_acc_rows(Yp + (size_t)50 * nfp, m - 50, nfp, H, lo, hi);
			}
			for (j = 0; j < nfp; j++)
				for (k = j; k < nfp; k++)
					if (memcmp(&H[(size_t)j * nfp + k], &ref[(size_t)j * nfp + k], sizeof *H))
						fail_msg("width %d, %d parts: H[%d][%d] = %.17g, loop %.17g", nfp, parts,
						         j, k, H[(size_t)j * nfp + k], ref[(size_t)j * nfp + k]);
		}
		free(Y);
		free(Yp);
		free(H);
		free(ref);
	}
	gsl_rng_free(r);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_syrk_is_the_scalar_loop),
		cmocka_unit_test(test_split_rows_are_the_scalar_loop),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
