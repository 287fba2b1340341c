/* sim_accel.c — when two balls whose accelerations are constant over a
 * window touch: the law-neutral arithmetic of the event mode of every law
 * whose phases have constant accelerations.
 *
 * Their separation d(s) = D + W s + H s^2 (H the half relative
 * acceleration) is quadratic, and contact |d| = 2R is a quartic in s. It is
 * solved on [0, S], S the end of the window (the first of the two balls'
 * own events, which re-predict the pair), by bracketing: the roots of the
 * quadratic g'' (g = |d|^2) split [0, S] into pieces where g' is monotone;
 * a sign change of g' on a piece brackets a critical point of g; between
 * consecutive critical points g is monotone, so the first piece where
 * |d| - 2R changes sign from + to - holds the first contact, which
 * safeguarded Newton steps polish to rounding. Every step keeps a bracket,
 * so no root is lost to an eigen-solver's failure, and a tangential graze
 * (a minimum of |d| at 2R) is a contact whose closing speed is below
 * PR_SIM_MIN_CLOSING: no collision, and the search goes on.
 */
#include <float.h>
#include <math.h>

#include <gsl/gsl_poly.h>

#include "sim_priv.h"

#define MAX_POLISH 200   /* safeguarded Newton steps; bisection alone needs < 1100 */

typedef pr_sim_rel_path rel_path;

static double norm(double x, double y)
{
	return sqrt(x * x + y * y);
}

/* max(x, 0) and min(x, y) without a call to libm (GCC does not inline fmax
 * and fmin); the same values, as none of their arguments here is a NaN or
 * a negative zero. */
static double least(double x, double y)
{
	return y < x ? y : x;
}

/* s at which a ball of speed v has travelled l (0 <= l <= v^2 / 2a). */
static void rel_at(const rel_path *q, double s, double d[2], double dd[2])
{
	d[0] = q->D[0] + s * (q->W[0] + s * q->H[0]);
	d[1] = q->D[1] + s * (q->W[1] + s * q->H[1]);
	dd[0] = q->W[0] + 2 * s * q->H[0];
	dd[1] = q->W[1] + 2 * s * q->H[1];
}

/* f = |d| - 2R and f' (the contact equation). */
static void gap_fn(const rel_path *q, double s, double *f, double *df)
{
	double d[2], dd[2], n;

	rel_at(q, s, d, dd);
	n = norm(d[0], d[1]);
	*f = n - q->r2;
	*df = n > 0 ? (d[0] * dd[0] + d[1] * dd[1]) / n : 0;
}

/* f = g'/2 = d.d' and f' = g''/2 = |d'|^2 + 2 d.H (critical points of |d|). */
static void slope_fn(const rel_path *q, double s, double *f, double *df)
{
	double d[2], dd[2];

	rel_at(q, s, d, dd);
	*f = d[0] * dd[0] + d[1] * dd[1];
	*df = dd[0] * dd[0] + dd[1] * dd[1] + 2 * (d[0] * q->H[0] + d[1] * q->H[1]);
}

typedef void (*fn_t)(const rel_path *q, double s, double *f, double *df);

/* The root of fn in [lo, hi], where fn is monotone and fn(lo) > 0 >= fn(hi)
 * (or the reverse when up): safeguarded Newton, the bracket kept. */
static double polish(fn_t fn, const rel_path *q, double lo, double hi, int up)
{
	double x = 0.5 * (lo + hi);
	int it;

	for (it = 0; it < MAX_POLISH && hi - lo > 2 * DBL_EPSILON * fmax(fabs(lo), fabs(hi)); ++it) {
		double f, df, xn;
		fn(q, x, &f, &df);
		if (f == 0)
			return x;
		if ((f > 0) != up)
			lo = x;
		else
			hi = x;
		xn = df != 0 ? x - f / df : lo;
		if (fabs(xn - x) <= DBL_EPSILON * fabs(x) && xn >= lo && xn <= hi)
			return xn;
		x = xn > lo && xn < hi ? xn : 0.5 * (lo + hi);
	}
	return x;
}

static double fn_value(fn_t fn, const rel_path *q, double s)
{
	double f, df;

	fn(q, s, &f, &df);
	return f;
}

/* Split points of [0, S] between which |d| is monotone: 0, the critical
 * points of |d|^2 in (0, S) in order, S. Returns their count (<= 5). */
static int split_points(const rel_path *q, double S, double *pt)
{
	const double hh = q->H[0] * q->H[0] + q->H[1] * q->H[1];
	const double wh = q->W[0] * q->H[0] + q->W[1] * q->H[1];
	const double ww = q->W[0] * q->W[0] + q->W[1] * q->W[1];
	const double dh = q->D[0] * q->H[0] + q->D[1] * q->H[1];
	double piece[4], r0, r1, f0;
	int np = 0, nr, k, m = 0;

	/* g''/2 = 6|H|^2 s^2 + 6 W.H s + |W|^2 + 2 D.H: g' is monotone between its roots */
	piece[np++] = 0;
	nr = gsl_poly_solve_quadratic(6 * hh, 6 * wh, ww + 2 * dh, &r0, &r1);
	if (nr > 0 && r0 > 0 && r0 < S)
		piece[np++] = r0;
	if (nr > 1 && r1 > piece[np - 1] && r1 < S)
		piece[np++] = r1;
	piece[np++] = S;
	pt[m++] = 0;
	f0 = fn_value(slope_fn, q, 0);
	for (k = 1; k < np; ++k) {
		double f1 = fn_value(slope_fn, q, piece[k]);
		if ((f0 < 0 && f1 > 0) || (f0 > 0 && f1 < 0))
			pt[m++] = polish(slope_fn, q, piece[k - 1], piece[k], f0 < 0);
		f0 = f1;
	}
	pt[m++] = S;
	return m;
}

/* Closing speed -(d.d')/|d| at s. */
static double closing(const rel_path *q, double s)
{
	double f, df;

	gap_fn(q, s, &f, &df);
	return -df;
}

/* First contact in [0, S] with a closing speed of at least PR_SIM_MIN_CLOSING. */
double pr_sim_accel_first_contact(const rel_path *q, double S)
{
	double pt[5], f0;
	int m = split_points(q, S, pt), k;

	f0 = fn_value(gap_fn, q, 0);
	if (f0 <= 0 && closing(q, 0) >= PR_SIM_MIN_CLOSING)
		return 0; /* touching by rounding, and approaching */
	for (k = 1; k < m; ++k) {
		double f1 = fn_value(gap_fn, q, pt[k]);
		if (f0 > 0 && f1 <= 0) {
			double r = polish(gap_fn, q, pt[k - 1], pt[k], 0);
			if (closing(q, r) >= PR_SIM_MIN_CLOSING)
				return r;
		}
		f0 = f1;
	}
	return HUGE_VAL;
}

/* A ball at time t: position p, velocity v, speed sp. */
/* Gap dn = |D| - 2R, window T, both balls' travel LT by T: (a) the gap is
 * wider than both travel; or (b) |d| grows on all of [0, T]: g'/2 = d.d' =
 * D.W + (|W|^2 + 2 D.H) s + 3 W.H s^2 + 2 |H|^2 s^3 is at least the line
 * D.W + s (|W|^2 + 2 D.H + 3 min(0, W.H) T) there, which is positive at both
 * ends (a root first_contact found there would separate, and be refused). */
int pr_sim_accel_apart(const rel_path *q, double dn, double T, double LT)
{
	const double *D = q->D, *W = q->W, *H = q->H;
	const double dw = D[0] * W[0] + D[1] * W[1], mdw = fabs(D[0] * W[0]) + fabs(D[1] * W[1]);
	double wh, ww, dh, k1, m1;

	if (dn > LT * (1 + 1e-9) + 1e-12)
		return 1;
	if (!(dw > 1e-9 * mdw))
		return 0;
	wh = W[0] * H[0] + W[1] * H[1];
	ww = W[0] * W[0] + W[1] * W[1];
	dh = D[0] * H[0] + D[1] * H[1];
	k1 = ww + 2 * dh + 3 * (wh < 0 ? wh : 0) * T;
	m1 = ww + 2 * (fabs(D[0] * H[0]) + fabs(D[1] * H[1])) + 3 * (fabs(W[0] * H[0]) + fabs(W[1] * H[1])) * T;
	return dw + k1 * T > 1e-9 * (mdw + m1 * T);
}

/* (c) The paths miss: on [0, T], g - 4R^2 = c0 + c1 s + c2 s^2 + c3 s^3 +
 * |H|^2 s^4 is at least the quadratic c0 + c1 s + (c2 + min(0, c3) T) s^2,
 * whose smallest value on [0, T] is positive. */
int pr_sim_accel_misses(const rel_path *q, double T)
{
	const double *D = q->D, *W = q->W, *H = q->H;
	const double dd = D[0] * D[0] + D[1] * D[1], c0 = dd - q->r2 * q->r2;
	const double c1 = 2 * (D[0] * W[0] + D[1] * W[1]), wh = W[0] * H[0] + W[1] * H[1];
	const double mc2 = W[0] * W[0] + W[1] * W[1] + 2 * (fabs(D[0] * H[0]) + fabs(D[1] * H[1])) +
	                   2 * (fabs(W[0] * H[0]) + fabs(W[1] * H[1])) * T;
	double k2, lo;

	if (!(c0 > 0))
		return 0;
	/* c2 + min(0, c3) T, lowered by its rounding margin */
	k2 = W[0] * W[0] + W[1] * W[1] + 2 * (D[0] * H[0] + D[1] * H[1]) + 2 * (wh < 0 ? wh : 0) * T -
	     1e-9 * mc2;
	if (k2 > 0 && c1 < 0 && -c1 < 2 * k2 * T)
		lo = c0 - c1 * c1 / (4 * k2); /* the vertex, inside (0, T) */
	else
		lo = least(c0, c0 + T * (c1 + k2 * T));
	return lo > 1e-9 * (dd + q->r2 * q->r2 + fabs(c1) * T + mc2 * T * T);
}


double pr_sim_accel_min_norm(const rel_path *q, double S)
{
	rel_path z = *q;
	double pt[5], best = HUGE_VAL;
	int m, k;

	z.r2 = 0;
	m = split_points(&z, S, pt);
	for (k = 0; k < m; ++k)
		best = fmin(best, fn_value(gap_fn, &z, pt[k]));
	return best;
}

double pr_sim_accel_line_contact(double dx, double dy, const double v[2], double sp, double a,
                                 double lmax, double r2)
{
	const double ex = v[0] / sp, ey = v[1] / sp;
	double bq, cr, cc, disc, l;

	bq = dx * ex + dy * ey;
	if (bq <= 0)
		return HUGE_VAL;
	cr = dx * ey - dy * ex;
	disc = r2 * r2 - cr * cr;
	if (disc <= 0)
		return HUGE_VAL;
	cc = dx * dx + dy * dy - r2 * r2;
	if (cc <= 0) /* touching or overlapping by rounding: a contact now if approaching now */
		return sp * bq / norm(dx, dy) >= PR_SIM_MIN_CLOSING ? 0 : HUGE_VAL;
	l = cc / (bq + sqrt(disc));
	if (l > lmax)
		return HUGE_VAL;
	/* closing speed at contact: the speed there times the normal share sqrt(disc)/2R */
	cc = sp * sp - 2 * a * l;
	if (sqrt(cc > 0 ? cc : 0) * sqrt(disc) / r2 < PR_SIM_MIN_CLOSING)
		return HUGE_VAL;
	return l;
}
