/* sim_event_const.c — exact event-mode motion under the constant-deceleration
 * law (table.friction_law = constant); the event loop is sim_event.c's.
 *
 * A moving ball slows at the constant rate a = table.deceleration along its
 * direction of motion e. From its reference time tr, where its speed is v
 * and its position p, it is at p + e l(s) with l(s) = v s - a s^2 / 2,
 * s = t - tr, until its speed v - a s reaches stop_speed at
 * s = (v - v_stop) / a. Its path is a straight line, so cushion and pocket
 * entries are the linear and quadratic equations of the exponential law in
 * the distance l, mapped back to time by s = 2 l / (v + sqrt(v^2 - 2 a l)).
 *
 * Two balls moving in different directions decelerate along different
 * directions: their separation d(s) = D + W s + H s^2 (H the half relative
 * acceleration) is quadratic, and contact |d| = 2R is a quartic in s. It is
 * solved on [0, S], S the time until the first of the two stops (a stop
 * re-predicts the pair), by bracketing: the roots of the quadratic g''
 * (g = |d|^2) split [0, S] into pieces where g' is monotone; a sign change
 * of g' on a piece brackets a critical point of g; between consecutive
 * critical points g is monotone, so the first piece where |d| - 2R changes
 * sign from + to - holds the first contact, which safeguarded Newton steps
 * polish to rounding. Every step keeps a bracket, so no root is lost to an
 * eigen-solver's failure, and a tangential graze (a minimum of |d| at 2R)
 * is a contact whose closing speed is below MIN_CLOSING: no collision, and
 * the search goes on. With one ball at rest the separation is linear in the
 * mover's distance l, a quadratic as under the exponential law.
 */
#include <float.h>
#include <math.h>

#include <gsl/gsl_poly.h>

#include "sim_priv.h"

#define MIN_CLOSING 1e-9 /* m/s: slower approaches are not collisions (as sim_event.c) */
#define MAX_POLISH 200   /* safeguarded Newton steps; bisection alone needs < 1100 */

/* |(x, y)|: table distances and speeds, far from overflow, so no hypot (its
 * care costs several times the square root here) */
static double norm(double x, double y)
{
	return sqrt(x * x + y * y);
}

/* s at which a ball of speed v has travelled l (0 <= l <= v^2 / 2a). */
static double time_for(double v, double a, double l)
{
	return l <= 0 ? 0 : 2 * l / (v + sqrt(fmax(0, v * v - 2 * a * l)));
}

/* Time left until a moving ball of speed v stops. */
static double stop_in(const pr_sim *s, double v)
{
	return fmax(0, (v - s->t.stop_speed) / s->t.deceleration);
}

/* Distance left until a moving ball of speed v stops. */
static double reach(const pr_sim *s, double v)
{
	const double vs = s->t.stop_speed;

	return v > vs ? (v * v - vs * vs) / (2 * s->t.deceleration) : 0;
}

void pr_sim_const_at(const pr_sim *s, const pr_sim_ball *b, double t, double p[2], double v[2])
{
	const double a = s->t.deceleration;
	double sg = t - b->tr, l, f;

	if (b->sp == 0) {
		p[0] = b->x;
		p[1] = b->y;
		v[0] = v[1] = 0;
		return;
	}
	l = b->sp * sg - 0.5 * a * sg * sg;
	f = (b->sp - a * sg) / b->sp;
	p[0] = b->x + b->ux / b->sp * l;
	p[1] = b->y + b->uy / b->sp * l;
	v[0] = b->ux * f;
	v[1] = b->uy * f;
}

void pr_sim_const_advance(const pr_sim *s, pr_sim_ball *b, double t)
{
	double p[2], v[2];

	pr_sim_const_at(s, b, t, p, v);
	b->x = p[0];
	b->y = p[1];
	b->ux = v[0];
	b->uy = v[1];
	b->sp = norm(v[0], v[1]);
	b->tr = t;
}

static int earlier(double t1, int k1, double t2, int k2)
{
	return t1 < t2 || (t1 == t2 && k1 < k2);
}

void pr_sim_const_predict_own(const pr_sim *s, pr_sim_ball *b)
{
	const double a = s->t.deceleration;
	pr_sim_hits h;
	double best, lmax;
	int type, other = -1;

	b->et = HUGE_VAL;
	b->etype = PR_EV_NONE;
	b->eother = -1;
	if (b->st != PR_BALL_MOVING)
		return;
	best = b->tr + stop_in(s, b->sp);
	type = PR_EV_STOP;
	lmax = reach(s, b->sp);
	/* along the unit direction the path parameter is the distance l */
	pr_sim_path_hits(s, b->x, b->y, b->ux / b->sp, b->uy / b->sp, 1, &h);
	if (h.cid >= 0 && h.cushion <= lmax) {
		double t = b->tr + time_for(b->sp, a, h.cushion);
		if (earlier(t, PR_EV_CUSHION, best, type)) {
			best = t;
			type = PR_EV_CUSHION;
			other = h.cid;
		}
	}
	if (h.pid >= 0 && h.pocket <= lmax) {
		double t = b->tr + time_for(b->sp, a, h.pocket);
		if (earlier(t, PR_EV_POCKET, best, type)) {
			best = t;
			type = PR_EV_POCKET;
			other = h.pid;
		}
	}
	b->et = best;
	b->etype = type;
	b->eother = other;
}

/* ---- two moving balls: d(s) = D + W s + H s^2 ---- */

typedef struct {
	double D[2], W[2], H[2], r2; /* r2 = 2R */
} rel_path;

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

/* First contact in [0, S] with a closing speed of at least MIN_CLOSING. */
static double first_contact(const rel_path *q, double S)
{
	double pt[5], f0;
	int m = split_points(q, S, pt), k;

	f0 = fn_value(gap_fn, q, 0);
	if (f0 <= 0 && closing(q, 0) >= MIN_CLOSING)
		return 0; /* touching by rounding, and approaching */
	for (k = 1; k < m; ++k) {
		double f1 = fn_value(gap_fn, q, pt[k]);
		if (f0 > 0 && f1 <= 0) {
			double r = polish(gap_fn, q, pt[k - 1], pt[k], 0);
			if (closing(q, r) >= MIN_CLOSING)
				return r;
		}
		f0 = f1;
	}
	return HUGE_VAL;
}

/* The relative path of bj seen from bi from time t; S, the time until the
 * first of the moving ones stops, and L, the distance both can still travel. */
static void relative(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj, double t,
                     rel_path *q, double *S, double *L)
{
	const double a = s->t.deceleration;
	double pi[2], vi[2], pj[2], vj[2], si, sj, c;

	pr_sim_const_at(s, bi, t, pi, vi);
	pr_sim_const_at(s, bj, t, pj, vj);
	si = norm(vi[0], vi[1]);
	sj = norm(vj[0], vj[1]);
	q->r2 = 2 * s->t.ball_radius;
	q->D[0] = pj[0] - pi[0];
	q->D[1] = pj[1] - pi[1];
	q->W[0] = vj[0] - vi[0];
	q->W[1] = vj[1] - vi[1];
	q->H[0] = q->H[1] = 0;
	*S = HUGE_VAL;
	*L = 0;
	if (bi->st == PR_BALL_MOVING && si > 0) {
		c = 0.5 * a / si; /* acceleration -a v / |v|, halved */
		q->H[0] += c * vi[0];
		q->H[1] += c * vi[1];
		*S = fmin(*S, stop_in(s, si));
		*L += reach(s, si);
	}
	if (bj->st == PR_BALL_MOVING && sj > 0) {
		c = 0.5 * a / sj;
		q->H[0] -= c * vj[0];
		q->H[1] -= c * vj[1];
		*S = fmin(*S, stop_in(s, sj));
		*L += reach(s, sj);
	}
}

/* One ball moving (m), one at rest (o): contact when |D - e l| = 2R, D from
 * the mover to the other, l the mover's distance; as in sim_event.c's
 * pair_time. Returns the contact's l, HUGE_VAL if none within reach. */
static double line_contact(const pr_sim *s, const pr_sim_ball *m, const pr_sim_ball *o, double t,
                           double *sp)
{
	const double r2 = 2 * s->t.ball_radius;
	double pm[2], vm[2], ex, ey, dx, dy, bq, cr, cc, disc, l;

	pr_sim_const_at(s, m, t, pm, vm);
	*sp = norm(vm[0], vm[1]);
	if (!(*sp > 0))
		return HUGE_VAL;
	ex = vm[0] / *sp;
	ey = vm[1] / *sp;
	dx = o->x - pm[0];
	dy = o->y - pm[1];
	bq = dx * ex + dy * ey;
	if (bq <= 0)
		return HUGE_VAL;
	cr = dx * ey - dy * ex;
	disc = r2 * r2 - cr * cr;
	if (disc <= 0)
		return HUGE_VAL;
	cc = dx * dx + dy * dy - r2 * r2;
	if (cc <= 0) /* touching or overlapping by rounding: a contact now if approaching now */
		return *sp * bq / norm(dx, dy) >= MIN_CLOSING ? 0 : HUGE_VAL;
	l = cc / (bq + sqrt(disc));
	if (l > reach(s, *sp))
		return HUGE_VAL;
	/* closing speed at contact: the speed there times the normal share sqrt(disc)/2R */
	if (sqrt(fmax(0, *sp * *sp - 2 * s->t.deceleration * l)) * sqrt(disc) / r2 < MIN_CLOSING)
		return HUGE_VAL;
	return l;
}

double pr_sim_const_pair_time(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj,
                              double t)
{
	rel_path q;
	double S, L, r;

	if (bi->st != PR_BALL_MOVING || bj->st != PR_BALL_MOVING) {
		const pr_sim_ball *m = bi->st == PR_BALL_MOVING ? bi : bj, *o = m == bi ? bj : bi;
		double sp, l = line_contact(s, m, o, t, &sp);
		return l < HUGE_VAL ? t + time_for(sp, s->t.deceleration, l) : HUGE_VAL;
	}
	relative(s, bi, bj, t, &q, &S, &L);
	/* too far apart to meet: farther than both can still travel */
	if (norm(q.D[0], q.D[1]) * (1 - 1e-9) - q.r2 > L)
		return HUGE_VAL;
	r = first_contact(&q, S);
	return r < HUGE_VAL ? t + r : HUGE_VAL;
}

/* One ball at rest (or both): the other's path over [t0, t] is a straight
 * segment, and the smallest distance is the point's to it. */
static double line_min_dist(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj,
                            double t0, double t)
{
	const pr_sim_ball *m = bi->st == PR_BALL_MOVING && bi->sp > 0 ? bi : bj, *o = m == bi ? bj : bi;
	double p0[2], p1[2], v[2], ex, ey, len, dx, dy, u;

	pr_sim_const_at(s, m, t0, p0, v);
	pr_sim_const_at(s, m, t, p1, v);
	ex = p1[0] - p0[0];
	ey = p1[1] - p0[1];
	dx = o->x - p0[0];
	dy = o->y - p0[1];
	len = ex * ex + ey * ey;
	u = len > 0 ? fmin(1, fmax(0, (dx * ex + dy * ey) / len)) : 0;
	return norm(dx - u * ex, dy - u * ey);
}

double pr_sim_const_min_dist(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj,
                             double t)
{
	const double t0 = fmax(bi->tr, bj->tr);
	rel_path q;
	double S, L, pt[5], best = HUGE_VAL;
	int m, k;

	if (bi->sp == 0 || bj->sp == 0 || bi->st != PR_BALL_MOVING || bj->st != PR_BALL_MOVING)
		return line_min_dist(s, bi, bj, t0, t);
	relative(s, bi, bj, t0, &q, &S, &L);
	q.r2 = 0;
	m = split_points(&q, fmin(S, t - t0), pt);
	for (k = 0; k < m; ++k)
		best = fmin(best, fn_value(gap_fn, &q, pt[k]));
	return best;
}
