/* test_bind_threads.c — pr_bind_shoot_params on several threads gives what
 * one thread gives: every output byte, with and without per-row
 * parameters, on seeded random batches whose rows cost from one to many
 * events; a batch with bad rows fails with the first bad row's message
 * whatever the thread count; a bad thread count or key is refused. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <gsl/gsl_rng.h>

#include "poolreps/bind.h"

enum { N = 3000, BALLS = 2 };

typedef struct {
	double final[N * 2 * BALLS], min_gap[N], reward[N], t_end[N];
	int pocket[N * BALLS];
	unsigned char hit[N];
	long events[N];
} outputs;

static const char *const KEYS[] = {"table.friction", "table.restitution"};

static int shoot(const pr_config *c, const double *balls, const double *actions,
                 const double *values, int threads, outputs *o, char *err)
{
	memset(o, 0, sizeof *o);
	return pr_bind_shoot_params(c, 0, N, BALLS, balls, actions, values ? 2 : 0, KEYS, values,
	                            o->final, o->pocket, o->hit, o->min_gap, o->reward, o->t_end,
	                            o->events, threads, err);
}

/* A seeded batch: start states, speeds from slow to near the limit, and
 * friction and restitution per row (runs of equal values among them). */
static void batch(const pr_config *c, unsigned long seed, double *balls, double *actions,
                  double *values)
{
	gsl_rng *r = pr_bind_rng_new(seed);
	char err[PR_ERRLEN];
	int i;

	assert_non_null(r);
	assert_int_equal(pr_bind_starts(c, r, N, balls, err), PR_OK);
	for (i = 0; i < N; ++i) {
		const double scale = (const double[]){0.1, 1.0, 6.0}[gsl_rng_uniform_int(r, 3)];

		actions[2 * i] = scale * (gsl_rng_uniform(r) - 0.5);
		actions[2 * i + 1] = scale * (gsl_rng_uniform(r) - 0.5);
		values[2 * i] = i % 5 ? 0.05 + 1.5 * gsl_rng_uniform(r) : 0.2;
		values[2 * i + 1] = gsl_rng_uniform(r);
	}
	pr_bind_rng_free(r);
}

static void test_same_bytes(void **state)
{
	static double balls[N * 2 * BALLS], actions[2 * N], values[2 * N];
	static outputs one, many;
	static const int counts[] = {2, 3, 8, 0, 64, 1000};
	pr_config *c = pr_config_new();
	char err[PR_ERRLEN];
	unsigned long seed;
	size_t k;
	int p;

	(void)state;
	assert_non_null(c);
	for (seed = 1; seed <= 3; ++seed) {
		batch(c, seed, balls, actions, values);
		for (p = 0; p < 2; ++p) {
			const double *v = p ? values : NULL;

			assert_int_equal(shoot(c, balls, actions, v, 1, &one, err), PR_OK);
			for (k = 0; k < sizeof counts / sizeof *counts; ++k) {
				assert_int_equal(shoot(c, balls, actions, v, counts[k], &many, err), PR_OK);
				assert_memory_equal(&one, &many, sizeof one);
			}
		}
	}
	pr_config_free(c);
}

static void test_first_bad_row(void **state)
{
	static double balls[N * 2 * BALLS], actions[2 * N], values[2 * N];
	static outputs o;
	static const int counts[] = {1, 2, 4, 0};
	pr_config *c = pr_config_new();
	char want[PR_ERRLEN], err[PR_ERRLEN];
	size_t k;

	(void)state;
	assert_non_null(c);
	batch(c, 9, balls, actions, values);
	values[2 * 2900] = -1.0; /* friction below its range, in the last part */
	values[2 * 2000] = -1.0;
	assert_int_equal(shoot(c, balls, actions, values, 1, &o, want), PR_EINVAL);
	assert_non_null(strstr(want, "row 2000:"));
	for (k = 0; k < sizeof counts / sizeof *counts; ++k) {
		assert_int_equal(shoot(c, balls, actions, values, counts[k], &o, err), PR_EINVAL);
		assert_string_equal(err, want);
	}
	assert_int_equal(shoot(c, balls, actions, values, -1, &o, err), PR_EINVAL);
	assert_non_null(strstr(err, "threads"));
	pr_config_free(c);
}

static void test_bad_key_without_rows(void **state)
{
	const char *const keys[] = {"table.frction"};
	pr_config *c = pr_config_new();
	char err[PR_ERRLEN];

	(void)state;
	assert_non_null(c);
	assert_int_equal(pr_bind_shoot_params(c, 0, 0, BALLS, NULL, NULL, 1, keys, NULL, NULL, NULL,
	                                      NULL, NULL, NULL, NULL, NULL, 4, err), PR_EINVAL);
	assert_non_null(strstr(err, "table.frction"));
	pr_config_free(c);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_same_bytes),
		cmocka_unit_test(test_first_bad_row),
		cmocka_unit_test(test_bad_key_without_rows),
	};

	pr_bind_init();
	return cmocka_run_group_tests(tests, NULL, NULL);
}
