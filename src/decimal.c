/* decimal.c — exact decimal-to-double conversion for the numbers CSV files
 * usually hold, without strtod's arbitrary-precision machinery.
 *
 * A decimal [+-]digits[.digits][(e|E)[+-]digits] with at most 19
 * significant digits is the integer w < 2^64 times 10^q. Its double is
 * found from exact integer arithmetic, so there is no hard case:
 *   - w <= 2^53 and |q| <= 22: w and 10^|q| are exact doubles, and one
 *     IEEE multiplication or division rounds their product or quotient
 *     correctly (needs FLT_EVAL_METHOD 0: no wider intermediate);
 *   - 0 <= q <= 27: w * 5^q is exact in 128 bits; the value is that times 2^q;
 *   - -27 <= q < 0: one 64 x 64 multiplication by a rounded-up reciprocal
 *     of 5^-q gives the quotient's top bits to within one unit, which
 *     decides the rounding unless they lie next to a rounding edge (about
 *     1 in 2^8, quotient_mul); then w 2^(s+t) / 5^-q (w shifted left by s
 *     to fill 64 bits, 2^t <= 5^-q < 2^(t+1)) is a quotient of 63 or 64
 *     bits whose remainder says exactly whether anything lies below the
 *     bits kept, so rounding to nearest-even is exact.
 * Everything else (more digits, a larger exponent, a zero with an
 * exponent, hex, inf, nan, a result outside the normal range) is left to
 * the caller, which then asks strtod: whatever this returns is the double
 * strtod returns for the same text (tests/test_csvio.c compares both on
 * random and adversarial inputs).
 * The other way, pr_csv_format_double (the writer's shortest text that
 * reads back) takes one printf and this parser where the loop over
 * %.15g..%.17g took up to three of each, for the same text.
 */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csvio_priv.h"

#if defined(__SIZEOF_INT128__) && FLT_RADIX == 2 && DBL_MANT_DIG == 53 && DBL_MAX_EXP == 1024
__extension__ typedef unsigned __int128 u128;

/* 5^k, k = 0..27 (5^27 < 2^63) */
static const uint64_t pow5[28] = {
	1ULL, 5ULL, 25ULL, 125ULL,
	625ULL, 3125ULL, 15625ULL, 78125ULL,
	390625ULL, 1953125ULL, 9765625ULL, 48828125ULL,
	244140625ULL, 1220703125ULL, 6103515625ULL, 30517578125ULL,
	152587890625ULL, 762939453125ULL, 3814697265625ULL, 19073486328125ULL,
	95367431640625ULL, 476837158203125ULL, 2384185791015625ULL, 11920928955078125ULL,
	59604644775390625ULL, 298023223876953125ULL, 1490116119384765625ULL, 7450580596923828125ULL,
};

static int bit_length(u128 x)
{
	uint64_t hi = (uint64_t)(x >> 64);

	return hi ? 128 - __builtin_clzll(hi) : 64 - __builtin_clzll((uint64_t)x);
}

/* The double nearest (x + f) 2^e for x > 0 and 0 <= f < 1 (f > 0 iff
 * sticky; sticky only with x >= 2^54, so that f lies below the bits kept);
 * 0 when that is not a normal double. */
static inline __attribute__((always_inline)) int round_even(u128 x, int sticky, int e, double *v)
{
	int sh = bit_length(x) - 54, biased;
	uint64_t top, m, bits;

	if (sh > 0) {
		sticky |= (x & (((u128)1 << sh) - 1)) != 0;
		top = (uint64_t)(x >> sh);
	} else {
		top = (uint64_t)x << -sh;
	}
	/* top: 53 bits of mantissa and the rounding bit */
	m = top >> 1;
	if ((top & 1) && (sticky || (m & 1)))
		++m;
	e += sh + 1;
	if (m >> 53) {
		m >>= 1;
		++e;
	}
	biased = e + 52 + 1023;
	if (biased < 1 || biased > 2046)
		return 0;
	bits = (uint64_t)biased << 52 | (m & ((1ULL << 52) - 1));
	memcpy(v, &bits, sizeof *v);
	return 1;
}

/* recip5[k] = ceil(2^(63 + e) / 5^k), e the bit length of 5^k: in
 * (2^63, 2^64), for k = 1..27 (entry 0 unused) */
static const uint64_t recip5[28] = {
	0,
	0xcccccccccccccccdULL, 0xa3d70a3d70a3d70bULL, 0x83126e978d4fdf3cULL,
	0xd1b71758e219652cULL, 0xa7c5ac471b478424ULL, 0x8637bd05af6c69b6ULL,
	0xd6bf94d5e57a42bdULL, 0xabcc77118461cefdULL, 0x89705f4136b4a598ULL,
	0xdbe6fecebdedd5bfULL, 0xafebff0bcb24aaffULL, 0x8cbccc096f5088ccULL,
	0xe12e13424bb40e14ULL, 0xb424dc35095cd810ULL, 0x901d7cf73ab0acdaULL,
	0xe69594bec44de15cULL, 0xb877aa3236a4b44aULL, 0x9392ee8e921d5d08ULL,
	0xec1e4a7db69561a6ULL, 0xbce5086492111aebULL, 0x971da05074da7befULL,
	0xf1c90080baf72cb2ULL, 0xc16d9a0095928a28ULL, 0x9abe14cd44753b53ULL,
	0xf79687aed3eec552ULL, 0xc612062576589ddbULL, 0x9e74d1b791e07e49ULL,
};

/* w 10^-k for 1 <= k <= 27 by one 64 x 64 multiplication: W = w shifted to
 * fill 64 bits, P = W recip5[k] is W 2^(63+e) / 5^k plus less than 2^64, so
 * its top 64 bits hi lie within 1 of y = W 2^(e-1) / 5^k, and the value is
 * y 2^(1 - s - k - e). Unless the bits of hi below the 54 kept are 0, 1 or
 * all ones (then y might lie in another block of them, or on its edge), y
 * lies strictly inside the block hi is in: the 54 bits are y's and
 * something lies below them, so hi with a sticky bit rounds as y does. 0
 * when undecided (about 1 in 2^8; the exact division below decides). */
static int quotient_mul(uint64_t w, int k, double *v)
{
	const int s = __builtin_clzll(w), e = 64 - __builtin_clzll(pow5[k]);
	const uint64_t hi = (uint64_t)(((u128)(w << s) * recip5[k]) >> 64);
	const int sh = 64 - __builtin_clzll(hi) - 54;
	const uint64_t low = hi & ((1ULL << sh) - 1);

	if (low < 2 || low == (1ULL << sh) - 1)
		return 0;
	return round_even(hi, 1, 1 - s - k - e, v);
}

/* The double of w 10^q for w > 0 (see the top of the file); 0: not here. */
static int scale(uint64_t w, int q, double *v)
{
	static const double p10[23] = {
		1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11,
		1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
	};
	int s, t;
	u128 num;

#if FLT_EVAL_METHOD == 0
	if (w <= (1ULL << 53) && q >= -22 && q <= 22) {
		*v = q < 0 ? (double)w / p10[-q] : (double)w * p10[q];
		return 1;
	}
#else
	(void)p10;
#endif
	if (q < -27 || q > 27)
		return 0;
	if (q < 0 && quotient_mul(w, -q, v))
		return 1;
	if (q >= 0)
		return round_even((u128)w * pow5[q], 0, q, v);
	/* w shifted to fill 64 bits, then by one bit less than 5^-q has, so that
	 * the quotient (more than 62 bits) fits one 128 / 64 division */
	s = __builtin_clzll(w);
	t = 63 - __builtin_clzll(pow5[-q]);
	num = (u128)(w << s) << t;
	return round_even(num / pow5[-q], num % pow5[-q] != 0, q - s - t, v);
}

#define DIGIT(c) ((unsigned)((c) - '0') < 10)

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
/* The eight bytes at p as an 8-digit number if they are all digits (one
 * load and three multiplications where a loop takes eight dependent
 * steps); -1 otherwise. */
static inline __attribute__((always_inline)) int64_t eight_digits(const char *p)
{
	const uint64_t hi = 0xF0F0F0F0F0F0F0F0ULL, zeros = 0x3030303030303030ULL;
	uint64_t v;

	memcpy(&v, p, sizeof v);
	/* each byte 0x30..0x39: high nibble 3, and adding 6 keeps it 3 */
	if ((v & hi) != zeros || ((v + 0x0606060606060606ULL) & hi) != zeros)
		return -1;
	v -= zeros;
	/* pairs, then fours, then all eight (the first byte is the highest digit) */
	v = v * 10 + (v >> 8);
	v = ((v & 0x000000FF000000FFULL) * (100 + (1000000ULL << 32)) +
	     ((v >> 16) & 0x000000FF000000FFULL) * (1 + (10000ULL << 32))) >> 32;
	return (int64_t)(uint32_t)v;
}
#else
static inline __attribute__((always_inline)) int64_t eight_digits(const char *p)
{
	(void)p;
	return -1;
}
#endif

/* Append the digits at *s to w (nd significant digits so far; leading
 * zeros skipped while nd is 0); the number of digits read, or -1 past 19
 * significant digits. padded: 8 bytes may be read from any byte up to the
 * first that is not a digit. */
static inline __attribute__((always_inline)) int digits(const char **s, uint64_t *w, int *nd,
                                                     int padded)
{
	const char *p = *s, *start = p;
	uint64_t x = *w;
	int64_t e;
	int k = *nd;

	if (!k)
		while (*p == '0')
			++p;
	while (padded && k <= 11 && (e = eight_digits(p)) >= 0) {
		x = 100000000 * x + (uint64_t)e;
		k += 8;
		p += 8;
	}
	/* four digits at a time (one multiplication on the chain through x
	 * instead of four); each byte is read only after the one before it
	 * was a digit, so never past the terminating NUL */
	while (k <= 15 && DIGIT(p[0]) && DIGIT(p[1]) && DIGIT(p[2]) && DIGIT(p[3])) {
		x = 10000 * x + (uint64_t)(1000 * (p[0] - '0') + 100 * (p[1] - '0') + 10 * (p[2] - '0') +
		                           (p[3] - '0'));
		k += 4;
		p += 4;
	}
	for (; DIGIT(*p); ++p) {
		if (++k > 19)
			return -1;
		x = 10 * x + (uint64_t)(*p - '0');
	}
	*w = x;
	*nd = k;
	*s = p;
	return (int)(p - start);
}

static int parse(const char *s, const char **end, double *v, int padded)
{
	uint64_t w = 0;
	int neg = 0, nd = 0, q = 0, nint, nfrac = 0, has_exp = 0;

	if (*s == '+' || *s == '-')
		neg = *s++ == '-';
	if ((nint = digits(&s, &w, &nd, padded)) < 0)
		return 0;
	if (*s == '.') {
		++s;
		if ((nfrac = digits(&s, &w, &nd, padded)) < 0)
			return 0;
		q = -nfrac;
	}
	if (!nint && !nfrac)
		return 0;
	if (*s == 'e' || *s == 'E') {
		int eneg = 0, x = 0;
		++s;
		if (*s == '+' || *s == '-')
			eneg = *s++ == '-';
		if (*s < '0' || *s > '9')
			return 0;
		for (; *s >= '0' && *s <= '9'; ++s)
			if (x < 100000)
				x = 10 * x + (*s - '0');
		q += eneg ? -x : x;
		has_exp = 1;
	}
	*end = s;
	if (!w) {
		if (has_exp)
			return 0;
		*v = neg ? -0.0 : 0.0;
		return 1;
	}
	if (!scale(w, q, v))
		return 0;
	if (neg)
		*v = -*v;
	return 1;
}

int pr_decimal_parse(const char *s, const char **end, double *v)
{
	return parse(s, end, v, 0);
}

int pr_decimal_parse_padded(const char *s, const char **end, double *v)
{
	return parse(s, end, v, 1);
}

#else /* no 128-bit integers or no IEEE binary64: strtod decides everything */
int pr_decimal_parse(const char *s, const char **end, double *v)
{
	(void)s;
	(void)end;
	(void)v;
	return 0;
}

int pr_decimal_parse_padded(const char *s, const char **end, double *v)
{
	return pr_decimal_parse(s, end, v);
}
#endif

/* ---- the shortest of %.15g..%.17g that reads back exactly ---- */

/* 1 if text s reads back as v (the bits strtod gives, mostly without it). */
static int reads_back(const char *s, double v)
{
	const char *end;
	double r;

	if (!pr_decimal_parse(s, &end, &r) || *end)
		r = strtod(s, NULL);
	return r == v;
}

/* The p leading digits of x rounded to p significant digits, from d, the
 * 17 of its correct rounding, and e10, its decimal exponent: x lies within
 * half a unit of d's last digit, so unless d's digits after the first p are
 * exactly 5000..., they tell on which side of the midpoint x lies. Returns
 * 0 in that one ambiguous case (printf must decide). */
static int round_to(const char *d, int e10, int p, char *dig, int *e)
{
	int i, up = d[p] > '5';

	if (d[p] == '5')
		for (i = p + 1; i < 17 && !up; ++i)
			up = d[i] != '0';
	if (d[p] == '5' && !up)
		return 0;
	memcpy(dig, d, (size_t)p);
	*e = e10;
	if (up) {
		for (i = p - 1; i >= 0 && dig[i] == '9'; --i)
			dig[i] = '0';
		if (i >= 0) {
			dig[i]++;
		} else {
			dig[0] = '1';
			++*e;
		}
	}
	return 1;
}

/* %.{p}g of the value -1^neg x dig[0].dig[1..p) 10^e (dig[0] nonzero),
 * as printf writes it: exponential below 1e-4 and from 10^p on, trailing
 * zeros of the fraction dropped. buf holds at least 32 bytes. */
static void g_text(int neg, const char *dig, int p, int e, char *buf)
{
	char *q = buf;
	int nd = p, i, a = e < 0 ? -e : e;

	while (nd > 1 && dig[nd - 1] == '0')
		--nd;
	if (neg)
		*q++ = '-';
	if (e < -4 || e >= p) {
		*q++ = dig[0];
		if (nd > 1)
			*q++ = '.';
		for (i = 1; i < nd; ++i)
			*q++ = dig[i];
		*q++ = 'e';
		*q++ = e < 0 ? '-' : '+';
		if (a >= 100)
			*q++ = (char)('0' + a / 100);
		*q++ = (char)('0' + a / 10 % 10);
		*q++ = (char)('0' + a % 10);
	} else if (e >= 0) {
		for (i = 0; i <= e; ++i)
			*q++ = dig[i];
		if (nd > e + 1)
			*q++ = '.';
		for (i = e + 1; i < nd; ++i)
			*q++ = dig[i];
	} else {
		*q++ = '0';
		*q++ = '.';
		for (i = 0; i < -e - 1; ++i)
			*q++ = '0';
		for (i = 0; i < nd; ++i)
			*q++ = dig[i];
	}
	*q = '\0';
}

/* One printf (17 digits) instead of up to three, and the read-back check
 * through the exact parser: the same text as the loop over %.15g..%.17g
 * with strtod (tests/test_format.c compares both). */
void pr_csv_format_double(double v, char *buf, size_t n)
{
	char d17[32], dig[17];
	int prec, e10, e;

	if (isfinite(v) && v != 0.0 && n >= 32) {
		/* d.dddddddddddddddde[+-]x: the exponent, then the digits
		 * without the point */
		snprintf(d17, sizeof d17, "%.16e", fabs(v));
		e10 = atoi(d17 + 19);
		memmove(d17 + 1, d17 + 2, 16);
		for (prec = 15; prec <= 16; ++prec) {
			if (round_to(d17, e10, prec, dig, &e))
				g_text(v < 0, dig, prec, e, buf);
			else
				snprintf(buf, n, "%.*g", prec, v);
			if (reads_back(buf, v))
				return;
		}
		g_text(v < 0, d17, 17, e10, buf);
		return;
	}
	for (prec = 15; prec <= 17; ++prec) {
		snprintf(buf, n, "%.*g", prec, v);
		if (strtod(buf, NULL) == v)
			return;
	}
}
