/* test_decimal.c — the CSV number parser (pr_csv_parse_double, with its
 * exact fast path pr_decimal_parse) gives the bits and the verdict that
 * strtod gives, on seeded random and adversarial texts: every finite bit
 * pattern (subnormals included) printed at 1..21 digits, random digit
 * strings with long mantissas and exponents to +-400, decimal texts next to
 * the midpoints between neighbouring doubles, and integer ties. */
#include <errno.h>
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

#include "poolreps/common.h"
#include "csvio_priv.h"

/* The reference: strtod with the reader's rules (blanks around, finite,
 * subnormal kept, underflow to 0 refused). */
static int ref_parse(const char *s, double *v)
{
	const char *num = s + strspn(s, " \t");
	char *end;

	errno = 0;
	*v = strtod(num, &end);
	return end > num && !end[strspn(end, " \t\r")] && isfinite(*v) && !(errno == ERANGE && *v == 0)
	       ? PR_OK : PR_EINVAL;
}

static long n_checked, n_fast;

/* pr_decimal_parse_padded answers as pr_decimal_parse (verdict, end, bits),
 * with digits after the text's end, where 8-byte loads see them. */
static void check_padded(const char *s)
{
	char buf[160];
	const char *e1, *e2;
	double a = 0, b = 0;
	size_t n = strlen(s);
	int r1, r2;

	if (n + 9 > sizeof buf)
		return;
	memcpy(buf, s, n + 1);
	memset(buf + n + 1, '9', 8);
	r1 = pr_decimal_parse(s, &e1, &a);
	r2 = pr_decimal_parse_padded(buf, &e2, &b);
	if (r1 != r2 || (r1 && (e1 - s != e2 - buf || memcmp(&a, &b, sizeof a) != 0)))
		fail_msg("'%s': padded %d %a (end %td), plain %d %a (end %td)", s, r2, b, e2 - buf, r1, a,
		         e1 - s);
}

/* Same verdict and same bits as strtod; fast-path answers counted. */
static void check(const char *s)
{
	double a = 0, b = 0, f = 0;
	const char *end;
	int ra = pr_csv_parse_double(s, &a), rb = ref_parse(s, &b);

	if (ra != rb || (ra == PR_OK && memcmp(&a, &b, sizeof a) != 0))
		fail_msg("'%s': parsed %d %.17g (%a), strtod %d %.17g (%a)", s, ra, a, a, rb, b, b);
	if (pr_decimal_parse(s, &end, &f)) {
		if (*end == '\0' && (rb != PR_OK || memcmp(&f, &b, sizeof f) != 0))
			fail_msg("'%s': fast path %a, strtod %a", s, f, b);
		n_fast++;
	}
	check_padded(s);
	n_checked++;
}

static uint64_t rand64(gsl_rng *r)
{
	return (uint64_t)gsl_rng_get(r) << 32 | (uint64_t)gsl_rng_get(r);
}

static double rand_bits(gsl_rng *r)
{
	uint64_t u;
	double d;

	do {
		u = rand64(r);
		/* one in four: a subnormal or a value near the ends of the range */
		switch (gsl_rng_uniform_int(r, 8)) {
		case 0: u &= 0x800fffffffffffffULL; break;
		case 1: u = (u & 0x800fffffffffffffULL) | 0x7fe0000000000000ULL; break;
		default: break;
		}
		memcpy(&d, &u, sizeof d);
	} while (!isfinite(d));
	return d;
}

static void test_bit_patterns(void **state)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	char buf[64];
	int i, prec;

	(void)state;
	gsl_rng_set(r, 1);
	for (i = 0; i < 100000; ++i) {
		double d = rand_bits(r);
		prec = 1 + (int)gsl_rng_uniform_int(r, 21);
		snprintf(buf, sizeof buf, i & 1 ? "%.*g" : "%.*e", prec, d);
		check(buf);
		snprintf(buf, sizeof buf, "%.17g", d);
		check(buf);
	}
	/* the usual CSV texts (values of moderate size at 17 digits) nearly all
	 * take the fast path */
	n_checked = n_fast = 0;
	for (i = 0; i < 100000; ++i) {
		snprintf(buf, sizeof buf, "%.17g", gsl_ran_gaussian(r, 1.0) * pow(10, (int)gsl_rng_uniform_int(r, 11) - 5));
		check(buf);
	}
	gsl_rng_free(r);
	assert_true(n_fast > n_checked * 99 / 100);
}

/* [sign][zeros]digits[.digits][e|E[sign]exp], 1..24 significant digits. */
static void random_text(gsl_rng *r, char *buf)
{
	static const char *signs[] = {"", "-", "+"};
	int nd = 1 + (int)gsl_rng_uniform_int(r, 24), point = (int)gsl_rng_uniform_int(r, nd + 2);
	int k, e;
	char *p = buf;

	p += sprintf(p, "%s", signs[gsl_rng_uniform_int(r, 3)]);
	if (gsl_rng_uniform_int(r, 4) == 0)
		p += sprintf(p, "000");
	if (point == nd + 1)
		*p++ = '.';
	for (k = 0; k < nd; ++k) {
		if (k == point)
			*p++ = '.';
		*p++ = (char)('0' + (k == 0 ? 1 + gsl_rng_uniform_int(r, 9) : gsl_rng_uniform_int(r, 10)));
	}
	if (gsl_rng_uniform_int(r, 3)) {
		e = gsl_rng_uniform_int(r, 4) ? (int)gsl_rng_uniform_int(r, 61) - 30
		                                : (int)gsl_rng_uniform_int(r, 801) - 400;
		p += sprintf(p, "%s%s%d", gsl_rng_uniform_int(r, 2) ? "e" : "E",
		             e >= 0 && gsl_rng_uniform_int(r, 2) ? "+" : "", e);
	}
	*p = '\0';
}

static void test_random_texts(void **state)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	char buf[128];
	int i;

	(void)state;
	gsl_rng_set(r, 2);
	for (i = 0; i < 200000; ++i) {
		random_text(r, buf);
		check(buf);
	}
	gsl_rng_free(r);
}

/* Decimal texts next to the exact midpoint of two neighbouring doubles
 * (where a wrong rounding shows first), and integers whose bits below the
 * 53 kept are exactly one half (ties to even) or one unit either side. */
static void test_near_halfway(void **state)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	char buf[128];
	int i, prec;

	(void)state;
	gsl_rng_set(r, 3);
	for (i = 0; i < 100000; ++i) {
		double d = fabs(rand_bits(r));
		if (LDBL_MANT_DIG >= 64 && d < DBL_MAX) {
			long double mid = ((long double)d + (long double)nextafter(d, INFINITY)) / 2;
			for (prec = 15; prec <= 21; ++prec) {
				snprintf(buf, sizeof buf, "%.*Le", prec, mid);
				check(buf);
			}
		}
	}
	for (i = 0; i < 100000; ++i) {
		int k = 1 + (int)gsl_rng_uniform_int(r, 11);
		uint64_t u = (rand64(r) | 1ULL << 63) >> (gsl_rng_uniform_int(r, 11));
		u = (u >> k << k) | (1ULL << (k - 1));
		for (int delta = -1; delta <= 1; ++delta) {
			snprintf(buf, sizeof buf, "%llu", (unsigned long long)(u + (uint64_t)delta));
			check(buf);
			snprintf(buf, sizeof buf, "%llue-%d", (unsigned long long)(u + (uint64_t)delta),
			         (int)gsl_rng_uniform_int(r, 28));
			check(buf);
		}
	}
	gsl_rng_free(r);
}

static void test_edges(void **state)
{
	static const char *texts[] = {
		"0", "-0", "+0", "0.0", "-0.000", "0e0", "-0e-400", "0e999", ".5", "5.", "-.5e1",
		"1e22", "1e23", "9007199254740992", "9007199254740993", "9007199254740995",
		"18446744073709551615", "18446744073709551616", "9999999999999999999",
		"1.7976931348623157e308", "1.7976931348623158e308", "1.8e308", "1e309",
		"2.2250738585072014e-308", "2.2250738585072011e-308", "4.9406564584124654e-324",
		"2.4703282292062327e-324", "2.4703282292062328e-324", "1e-400", "1e-27", "1e27",
		"1.2345678901234567e-27", "1.2345678901234567e27", "1.2345678901234567e-28",
		"0.1", "0.2", "0.3", "123456789012345678e-20", " 1.5\t", "1.5\r", "1.5 x", "1e",
		"1e+", "e5", ".", "-", "+", "0x1p3", "0x10", "inf", "nan", "1..2", "1.5e5.5",
		"00000000000000000000000000001", "1.00000000000000000000000000", "1e0000000000000000005",
		"1e-0000000000000000005", "\v1", "1,5",
	};
	size_t i;

	(void)state;
	for (i = 0; i < sizeof texts / sizeof *texts; ++i)
		check(texts[i]);
}

/* Every byte that is not a digit, at every place of a run of digits in the
 * integer part, the fraction and the exponent: the 8-digit loads stop
 * where the byte loop stops. */
static void test_padded_stops(void **state)
{
	static const char *forms[] = { "%s", "-0.%s", "1.%se5", "12345.6789%s" };
	const char run[] = "1234567890123456789";
	char digits[24], text[64];
	size_t f, pos;
	int c;

	(void)state;
	for (f = 0; f < sizeof forms / sizeof *forms; f++)
		for (pos = 0; pos < sizeof run - 1; pos++)
			for (c = 1; c < 256; c++) {
				if (c >= '0' && c <= '9')
					continue;
				memcpy(digits, run, sizeof run);
				digits[pos] = (char)c;
				snprintf(text, sizeof text, forms[f], digits);
				check(text);
			}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_bit_patterns),
		cmocka_unit_test(test_random_texts),
		cmocka_unit_test(test_near_halfway),
		cmocka_unit_test(test_edges),
		cmocka_unit_test(test_padded_stops),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
