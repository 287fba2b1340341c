/* test_format.c — pr_csv_format_double (one printf of 17 digits, the
 * shorter roundings derived from them, the read-back check through the
 * exact parser) writes the text of the plain rule it replaces: the first of
 * %.15g, %.16g, %.17g that strtod reads back as the value. Seeded random
 * bit patterns (subnormals and the ends of the range included), values of
 * the sizes the experiments write, short decimals, values whose 17 digits
 * end in the ambiguous 5000... at 15 or 16 digits, and edges. */
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "csvio_priv.h"

static void ref_format(double v, char *buf, size_t n)
{
	int prec;

	for (prec = 15; prec <= 17; ++prec) {
		snprintf(buf, n, "%.*g", prec, v);
		if (strtod(buf, NULL) == v)
			return;
	}
}

static void check(double v)
{
	char a[40], b[40];

	pr_csv_format_double(v, a, sizeof a);
	ref_format(v, b, sizeof b);
	if (strcmp(a, b) != 0)
		fail_msg("%a: wrote '%s', the rule gives '%s'", v, a, b);
}

static double from_bits(uint64_t u)
{
	double d;

	memcpy(&d, &u, sizeof d);
	return d;
}

static void test_bit_patterns(void **state)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	int i;

	(void)state;
	gsl_rng_set(r, 1);
	for (i = 0; i < 300000; ++i) {
		uint64_t u = (uint64_t)gsl_rng_get(r) << 32 | (uint64_t)gsl_rng_get(r);
		switch (i % 4) {
		case 0: u &= 0x800fffffffffffffULL; break;                        /* subnormal */
		case 1: u = (u & 0x800fffffffffffffULL) | 0x7fe0000000000000ULL; break; /* huge */
		default: break;
		}
		check(from_bits(u));
	}
	gsl_rng_free(r);
}

/* What the experiments write: moderate values at full precision, short
 * decimals (0.1, 2.5e-05, 1200), integers, and values next to powers of
 * ten, where the exponent and the notation change. */
static void test_usual_values(void **state)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	char buf[40];
	int i, k;

	(void)state;
	gsl_rng_set(r, 2);
	for (i = 0; i < 300000; ++i) {
		double v = gsl_ran_gaussian(r, 1.0) * pow(10, (int)gsl_rng_uniform_int(r, 41) - 20);
		check(v);
		snprintf(buf, sizeof buf, "%.*g", 1 + (int)gsl_rng_uniform_int(r, 17), v);
		check(strtod(buf, NULL));
		check((double)(long long)(v * 1e6));
	}
	for (k = -310; k <= 310; ++k) {
		double p = pow(10, k);
		check(p);
		check(nextafter(p, 0));
		check(nextafter(p, INFINITY));
		check(-p);
	}
	gsl_rng_free(r);
}

/* Values whose 17 digits continue a 15- or 16-digit prefix with 5 and
 * zeros: the one case the 17 digits cannot decide. */
static void test_ambiguous_tails(void **state)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	char buf[64];
	int i, found = 0;

	(void)state;
	gsl_rng_set(r, 3);
	for (i = 0; i < 200000; ++i) {
		int p = 15 + (int)gsl_rng_uniform_int(r, 2);
		unsigned long long m = 1 + gsl_rng_uniform_int(r, 999999999UL);
		double v;
		char d17[32];

		snprintf(buf, sizeof buf, "%llu%0*lu5e%d", m, p - 9, gsl_rng_uniform_int(r, 1000000UL),
		         (int)gsl_rng_uniform_int(r, 61) - 30 - p);
		v = strtod(buf, NULL);
		snprintf(d17, sizeof d17, "%.16e", v);
		found += d17[p + 1] == '5' && strspn(d17 + p + 2, "0") == (size_t)(16 - p);
		check(v);
		check(nextafter(v, 0));
		check(nextafter(v, INFINITY));
	}
	gsl_rng_free(r);
	assert_true(found > 1000);
}

static void test_edges(void **state)
{
	static const double v[] = {
		0.0, 1.0, -1.0, 0.1, 0.2, 0.3, 1e-4, 9.9999999999999991e-05, 1e-5, 1e15, 1e16, 1e17,
		123456789012345680.0, 0.5, 1.5, 2.5, 1e22, 1e23, 9007199254740993.0, DBL_MAX, -DBL_MAX,
		DBL_MIN, DBL_TRUE_MIN, -DBL_TRUE_MIN, DBL_EPSILON, 999999999999999.9, 99999999999999.99,
	};
	char a[40], b[40];
	size_t i;

	(void)state;
	for (i = 0; i < sizeof v / sizeof *v; ++i)
		check(v[i]);
	check(-0.0);
	check(INFINITY);
	check(-INFINITY);
	pr_csv_format_double(NAN, a, sizeof a);
	ref_format(NAN, b, sizeof b);
	assert_string_equal(a, b);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_bit_patterns),
		cmocka_unit_test(test_usual_values),
		cmocka_unit_test(test_ambiguous_tails),
		cmocka_unit_test(test_edges),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
