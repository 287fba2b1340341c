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

/* max(x, 0) and min(x, y) without a call to libm (GCC does not inline fmax
 * and fmin); the same values, as none of their arguments here is a NaN or
 * a negative zero. */
static double nonneg(double x)
{
	return x > 0 ? x : 0;
}

static double least(double x, double y)
{
	return y < x ? y : x;
}

/* s at which a ball of speed v has travelled l (0 <= l <= v^2 / 2a). */
static double time_for(double v, double a, double l)
{
	return l <= 0 ? 0 : 2 * l / (v + sqrt(nonneg(v * v - 2 * a * l)));
}

/* Time left until a moving ball of speed v stops. */
static double stop_in(const pr_sim *s, double v)
{
	return nonneg((v - s->t.stop_speed) / s->t.deceleration);
}

/* Distance left until a moving ball of speed v stops. */
static double reach(const pr_sim *s, double v)
{
	const double vs = s->t.stop_speed;

	return v > vs ? (v * v - vs * vs) / (2 * s->t.deceleration) : 0;
}

/* Distance a moving ball b has travelled along its line by time t. */
static double dist_at(const pr_sim *s, const pr_sim_ball *b, double t)
{
	const double sg = t - b->tr;

	return b->sp * sg - 0.5 * s->t.deceleration * sg * sg;
}

void pr_sim_const_at(const pr_sim *s, const pr_sim_ball *b, double t, double p[2], double v[2])
{
	double l, f;

	if (b->sp == 0) {
		p[0] = b->x;
		p[1] = b->y;
		v[0] = v[1] = 0;
		return;
	}
	l = dist_at(s, b, t);
	f = (b->sp - s->t.deceleration * (t - b->tr)) / b->sp;
	p[0] = b->x + b->ex * l;
	p[1] = b->y + b->ey * l;
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
	pr_sim_const_heading(b);
}

void pr_sim_const_heading(pr_sim_ball *b)
{
	if (b->sp > 0) {
		b->ex = b->ux / b->sp;
		b->ey = b->uy / b->sp;
	}
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

	b->ot = HUGE_VAL;
	b->otype = PR_EV_NONE;
	b->oother = -1;
	if (b->st != PR_BALL_MOVING)
		return;
	best = b->tr + stop_in(s, b->sp);
	type = PR_EV_STOP;
	lmax = reach(s, b->sp);
	/* along the unit direction the path parameter is the distance l */
	pr_sim_path_hits(s, b->x, b->y, b->ex, b->ey, 1, &h);
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
	b->ot = best;
	b->otype = type;
	b->oother = other;
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

/* A ball at time t: position p, velocity v, speed sp. */
typedef struct {
	double p[2], v[2], sp;
} motion;

/* The relative path of bj seen from bi from time t (both balls' motions in
 * mi, mj) and S, the time until the first of the moving ones stops. */
static void relative(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj, double t,
                     rel_path *q, double *S, motion *mi, motion *mj)
{
	const double a = s->t.deceleration;
	double c;

	pr_sim_const_at(s, bi, t, mi->p, mi->v);
	pr_sim_const_at(s, bj, t, mj->p, mj->v);
	mi->sp = norm(mi->v[0], mi->v[1]);
	mj->sp = norm(mj->v[0], mj->v[1]);
	q->r2 = 2 * s->t.ball_radius;
	q->D[0] = mj->p[0] - mi->p[0];
	q->D[1] = mj->p[1] - mi->p[1];
	q->W[0] = mj->v[0] - mi->v[0];
	q->W[1] = mj->v[1] - mi->v[1];
	q->H[0] = q->H[1] = 0;
	*S = HUGE_VAL;
	if (bi->st == PR_BALL_MOVING && mi->sp > 0) {
		c = 0.5 * a / mi->sp; /* acceleration -a v / |v|, halved */
		q->H[0] += c * mi->v[0];
		q->H[1] += c * mi->v[1];
		*S = least(*S, stop_in(s, mi->sp));
	}
	if (bj->st == PR_BALL_MOVING && mj->sp > 0) {
		c = 0.5 * a / mj->sp;
		q->H[0] -= c * mj->v[0];
		q->H[1] -= c * mj->v[1];
		*S = least(*S, stop_in(s, mj->sp));
	}
}

/* ---- provable misses of two moving balls, before the quartic ----
 *
 * A root of the quartic later than either ball's next own event (stop,
 * cushion or pocket) is never used: that event re-predicts every pair of
 * the ball (sim_event.c), and so does any earlier event of it. So the
 * quartic is skipped when the two provably do not touch on [0, T], T no
 * earlier than that event. The tests bound the exact motion; their margins,
 * 1e-9 of the magnitudes of the terms involved, are far above rounding, so
 * a pair they pass over has no contact on [0, T] that first_contact could
 * find. */

/* Distance a ball of speed v travels in T (T no later than its stop). */
static double travel(const pr_sim *s, double v, double T)
{
	return v * T - 0.5 * s->t.deceleration * T * T;
}

/* No earlier than the next own event of a moving ball: predict_own takes
 * the first of its stop, the cushion line ahead and a pocket, so the first
 * of the stop and the cushion line. */
static double own_bound(const pr_sim *s, const motion *m)
{
	const double *p = m->p, *v = m->v;
	double u = HUGE_VAL, l;

	if (v[0] != 0)
		u = ((v[0] > 0 ? s->hx : -s->hx) - p[0]) / v[0];
	if (v[1] != 0)
		u = least(u, ((v[1] > 0 ? s->hy : -s->hy) - p[1]) / v[1]);
	l = u > 0 ? u * m->sp : 0; /* the path parameter of v, as a distance */
	return l < reach(s, m->sp) ? time_for(m->sp, s->t.deceleration, l) : stop_in(s, m->sp);
}

/* Gap dn = |D| - 2R, window T, both balls' travel LT by T: (a) the gap is
 * wider than both travel; or (b) |d| grows on all of [0, T]: g'/2 = d.d' =
 * D.W + (|W|^2 + 2 D.H) s + 3 W.H s^2 + 2 |H|^2 s^3 is at least the line
 * D.W + s (|W|^2 + 2 D.H + 3 min(0, W.H) T) there, which is positive at both
 * ends (a root first_contact found there would separate, and be refused). */
static int apart(const rel_path *q, double dn, double T, double LT)
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
static int misses(const rel_path *q, double T)
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

/* Whether two moving balls provably do not touch before the first of their
 * own next events (see above): first over [0, S] with what relative gives,
 * then over the window T up to the first own-event bound. */
static int no_contact(const pr_sim *s, const rel_path *q, double S, const motion *mi,
                      const motion *mj)
{
	const double dn = norm(q->D[0], q->D[1]) - q->r2;
	double T;

	if (apart(q, dn, S, travel(s, mi->sp, S) + travel(s, mj->sp, S)))
		return 1;
	T = least(S, least(own_bound(s, mi), own_bound(s, mj)) * (1 + 1e-9) + 1e-12);
	return apart(q, dn, T, travel(s, mi->sp, T) + travel(s, mj->sp, T)) || misses(q, T);
}

/* One ball moving (m), one at rest (o): contact when |D - e l| = 2R, D from
 * the mover to the other, l the mover's distance; as in sim_event.c's
 * pair_time. Returns the contact's l, HUGE_VAL if none within reach. */
static double line_contact(const pr_sim *s, const pr_sim_ball *m, const pr_sim_ball *o, double t,
                           double *sp)
{
	const double r2 = 2 * s->t.ball_radius;
	double pm[2], vm[2], ex, ey, dx, dy, bq, cr, cc, disc, l;

	/* The path is the line through the reference point along u: when it
	 * passes the other ball farther than 2R (a margin of 1e-9, far above the
	 * rounding of the test below), that test fails; skip its work. */
	cr = (o->x - m->x) * m->uy - (o->y - m->y) * m->ux;
	if (fabs(cr) > r2 * m->sp * (1 + 1e-9))
		return HUGE_VAL;
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
	if (sqrt(nonneg(*sp * *sp - 2 * s->t.deceleration * l)) * sqrt(disc) / r2 < MIN_CLOSING)
		return HUGE_VAL;
	return l;
}

double pr_sim_const_pair_time(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj,
                              double t)
{
	rel_path q;
	motion mi, mj;
	double S, r;

	if (bi->st != PR_BALL_MOVING || bj->st != PR_BALL_MOVING) {
		const pr_sim_ball *m = bi->st == PR_BALL_MOVING ? bi : bj, *o = m == bi ? bj : bi;
		double sp, l = line_contact(s, m, o, t, &sp);
		return l < HUGE_VAL ? t + time_for(sp, s->t.deceleration, l) : HUGE_VAL;
	}
	relative(s, bi, bj, t, &q, &S, &mi, &mj);
	if (no_contact(s, &q, S, &mi, &mj))
		return HUGE_VAL;
	r = first_contact(&q, S);
	return r < HUGE_VAL ? t + r : HUGE_VAL;
}

/* One ball at rest (or both): the other's path over [t0, t] is a straight
 * segment, and the smallest distance is the point's to it. The segment's
 * ends are pr_sim_const_at's, sharing its direction u / |u|. */
static double line_min_dist(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj,
                            double t0, double t)
{
	const pr_sim_ball *m = bi->st == PR_BALL_MOVING && bi->sp > 0 ? bi : bj, *o = m == bi ? bj : bi;
	double p0[2], p1[2], ex, ey, len, dx, dy, u;

	if (m->sp == 0) {
		p0[0] = p1[0] = m->x;
		p0[1] = p1[1] = m->y;
	} else {
		const double e0 = m->ex, e1 = m->ey;
		const double l0 = dist_at(s, m, t0), l1 = dist_at(s, m, t);
		p0[0] = m->x + e0 * l0;
		p0[1] = m->y + e1 * l0;
		p1[0] = m->x + e0 * l1;
		p1[1] = m->y + e1 * l1;
	}
	ex = p1[0] - p0[0];
	ey = p1[1] - p0[1];
	dx = o->x - p0[0];
	dy = o->y - p0[1];
	len = ex * ex + ey * ey;
	u = len > 0 ? fmin(1, nonneg((dx * ex + dy * ey) / len)) : 0;
	return norm(dx - u * ex, dy - u * ey);
}

/* Whether a mover m, up to time t, provably stays farther than gap from o
 * at rest: its line passes o farther than gap, or its reference point is
 * farther from o than gap plus the distance it has gone; margins of 1e-9,
 * far above rounding. */
static int beyond(const pr_sim *s, const pr_sim_ball *m, const pr_sim_ball *o, double t,
                  double gap)
{
	const double dx = o->x - m->x, dy = o->y - m->y, cr = dx * m->uy - dy * m->ux;
	const double r = (dist_at(s, m, t) + gap) * (1 + 1e-9), g = gap * m->sp * (1 + 1e-9);

	return m->sp > 0 && (cr * cr > g * g || dx * dx + dy * dy > r * r);
}

double pr_sim_const_min_dist(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj,
                             double t, double gap)
{
	const double t0 = bi->tr > bj->tr ? bi->tr : bj->tr;
	rel_path q;
	motion mi, mj;
	double S, pt[5], best = HUGE_VAL;
	int m, k;

	if (bi->sp == 0 || bj->sp == 0 || bi->st != PR_BALL_MOVING || bj->st != PR_BALL_MOVING) {
		const pr_sim_ball *mv = bi->st == PR_BALL_MOVING && bi->sp > 0 ? bi : bj;
		if (gap < HUGE_VAL && beyond(s, mv, mv == bi ? bj : bi, t, gap))
			return HUGE_VAL;
		return line_min_dist(s, bi, bj, t0, t);
	}
	relative(s, bi, bj, t0, &q, &S, &mi, &mj);
	q.r2 = 0;
	m = split_points(&q, fmin(S, t - t0), pt);
	for (k = 0; k < m; ++k)
		best = fmin(best, fn_value(gap_fn, &q, pt[k]));
	return best;
}
