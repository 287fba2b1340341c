/* sim_law_const.c — the constant-deceleration friction law
 * (table.friction_law = constant): a rolling ball slows at a constant rate
 * a = table.deceleration (rolling resistance, a = mu_r g).
 *
 * Event mode (the event variable is the real time t). A moving ball slows
 * at the rate a along its direction of motion e. From its reference time
 * tr, where its speed is v and its position p, it is at p + e l(s) with
 * l(s) = v s - a s^2 / 2, s = t - tr, until its speed v - a s reaches
 * stop_speed at s = (v - v_stop) / a. Its path is a straight line, so
 * cushion and pocket entries are the linear and quadratic equations of a
 * straight path in the distance l, mapped back to time by
 * s = 2 l / (v + sqrt(v^2 - 2 a l)). Two balls moving in different
 * directions decelerate along different directions: their contact is the
 * quartic of sim_accel.c, solved up to the first of the two stops. With one
 * ball at rest the separation is linear in the mover's distance l, a
 * quadratic.
 *
 * Stepped mode: each step takes a dt off the speed along the direction of
 * motion.
 */
#include <math.h>

#include "sim_priv.h"

typedef pr_sim_rel_path rel_path;


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

static void const_at(const pr_sim *s, const pr_sim_ball *b, double t, double p[2], double v[2])
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

/* Sets b's direction (ex, ey) from its velocity, after the velocity changed. */
static void heading(pr_sim_ball *b)
{
	if (b->sp > 0) {
		b->ex = b->ux / b->sp;
		b->ey = b->uy / b->sp;
	}
}

static void const_advance(const pr_sim *s, pr_sim_ball *b, double t)
{
	double p[2], v[2];

	const_at(s, b, t, p, v);
	pr_sim_ball_rebase(b, t, p, v);
	heading(b);
}

static void const_own(const pr_sim *s, pr_sim_ball *b)
{
	const double a = s->t.deceleration;
	pr_sim_hits h;
	double lmax;

	if (!pr_sim_own_moving(b))
		return;
	b->ot = b->tr + stop_in(s, b->sp);
	b->otype = PR_EV_STOP;
	lmax = reach(s, b->sp);
	/* along the unit direction the path parameter is the distance l */
	pr_sim_path_hits(s, b->x, b->y, b->ex, b->ey, 1, &h);
	if (h.cid >= 0 && h.cushion <= lmax)
		pr_sim_own_offer(b, b->tr + time_for(b->sp, a, h.cushion), PR_EV_CUSHION, h.cid);
	if (h.pid >= 0 && h.pocket <= lmax)
		pr_sim_own_offer(b, b->tr + time_for(b->sp, a, h.pocket), PR_EV_POCKET, h.pid);
}

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

	const_at(s, bi, t, mi->p, mi->v);
	const_at(s, bj, t, mj->p, mj->v);
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
 * a pair they pass over has no contact on [0, T] that the quartic's solver could
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

/* Whether two moving balls provably do not touch before the first of their
 * own next events (see above): first over [0, S] with what relative gives,
 * then over the window T up to the first own-event bound. */
static int no_contact(const pr_sim *s, const rel_path *q, double S, const motion *mi,
                      const motion *mj)
{
	const double dn = norm(q->D[0], q->D[1]) - q->r2;
	double T;

	if (pr_sim_accel_apart(q, dn, S, travel(s, mi->sp, S) + travel(s, mj->sp, S)))
		return 1;
	T = least(S, least(own_bound(s, mi), own_bound(s, mj)) * (1 + 1e-9) + 1e-12);
	return pr_sim_accel_apart(q, dn, T, travel(s, mi->sp, T) + travel(s, mj->sp, T)) ||
	       pr_sim_accel_misses(q, T);
}

/* One ball moving (m), one at rest (o): contact when |D - e l| = 2R, D from
 * the mover to the other, l the mover's distance; as in sim_event.c's
 * pair_time. Returns the contact's l, HUGE_VAL if none within reach. */
static double line_contact(const pr_sim *s, const pr_sim_ball *m, const pr_sim_ball *o, double t,
                           double *sp)
{
	const double r2 = 2 * s->t.ball_radius;
	double pm[2], vm[2], cr;

	/* The path is the line through the reference point along u: when it
	 * passes the other ball farther than 2R (a margin of 1e-9, far above the
	 * rounding of the test below), that test fails; skip its work. */
	cr = (o->x - m->x) * m->uy - (o->y - m->y) * m->ux;
	if (fabs(cr) > r2 * m->sp * (1 + 1e-9))
		return HUGE_VAL;
	const_at(s, m, t, pm, vm);
	*sp = norm(vm[0], vm[1]);
	if (!(*sp > 0))
		return HUGE_VAL;
	return pr_sim_accel_line_contact(o->x - pm[0], o->y - pm[1], vm, *sp, s->t.deceleration,
	                                 reach(s, *sp), r2);
}

static double const_pair(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj,
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
	r = pr_sim_accel_first_contact(&q, S);
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

static double const_min_dist(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj,
                             double t, double gap)
{
	const double t0 = bi->tr > bj->tr ? bi->tr : bj->tr;
	rel_path q;
	motion mi, mj;
	double S;

	if (bi->sp == 0 || bj->sp == 0 || bi->st != PR_BALL_MOVING || bj->st != PR_BALL_MOVING) {
		const pr_sim_ball *mv = bi->st == PR_BALL_MOVING && bi->sp > 0 ? bi : bj;
		if (gap < HUGE_VAL && beyond(s, mv, mv == bi ? bj : bi, t, gap))
			return HUGE_VAL;
		return line_min_dist(s, bi, bj, t0, t);
	}
	relative(s, bi, bj, t0, &q, &S, &mi, &mj);
	return pr_sim_accel_min_norm(&q, fmin(S, t - t0));
}

static double same_time(const pr_sim *s, double t)
{
	(void)s;
	return t;
}

static void const_changed(const pr_sim *s, pr_sim_ball *b)
{
	(void)s;
	pr_sim_ball_changed(b);
	heading(b);
}

/* Stepped mode: |v| <- max(0, |v| - a dt) along the direction of motion. */
static int const_step(const pr_sim *s, pr_sim_ball *b)
{
	const double dv = s->t.deceleration * s->o.dt, vs = s->t.stop_speed;
	double v = hypot(b->ux, b->uy), f = v > dv ? (v - dv) / v : 0;

	b->ux *= f;
	b->uy *= f;
	return b->ux * b->ux + b->uy * b->uy < vs * vs;
}

static double const_step_decay(const pr_sim *s)
{
	(void)s;
	return 0;
}

/* under |v|' = -a: v^2 = v0^2 - 2 a s */
static double const_speed_for(const pr_table *t, double v, double d)
{
	const double a2 = 2 * t->deceleration;

	return sqrt(v * v + a2 * d);
}

static int const_check(const pr_table *t, const pr_sim_opts *o, int active, char *err)
{
	(void)o;
	(void)active;
	return pr_sim_check_positive(t->deceleration, "table.deceleration", err);
}

/* the event variable is the real time */
const pr_sim_law pr_sim_law_const = {
	.tau_of = same_time, .time_of = same_time, .at = const_at, .advance = const_advance,
	.changed = const_changed, .own = const_own, .settle = pr_sim_ball_stop, .pair = const_pair,
	.min_dist = const_min_dist, .step_decay = const_step_decay, .step = const_step,
	.speed_for = const_speed_for, .check = const_check,
};
