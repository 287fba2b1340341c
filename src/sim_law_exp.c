/* sim_law_exp.c — the thesis's exponential friction law
 * (table.friction_law = exponential): v' = -c v, v(t) = v0 e^{-c t}.
 *
 * Event mode. Every moving ball decays at the same rate, so with the event
 * variable tau = (1 - e^{-ct})/c a moving ball's velocity is u e^{-ct} for
 * a constant u (its velocity rescaled to t = 0) and its position is linear
 * in tau: p(tau) = p(tr) + u (tau - tr). Balls at rest have u = 0. The
 * collision laws (eq. 7.4-7.6) are linear in the velocities, so they act on
 * u directly. Hence contact, cushion and pocket-entry times are roots of
 * linear or quadratic equations in tau, and a ball stops at the
 * closed-form tau where |u| e^{-ct} = |u| (1 - c tau) = stop_speed. A ball
 * can never travel farther than |u|/c.
 *
 * Stepped mode: every velocity is multiplied by e^{-c dt} per step.
 */
#include <math.h>

#include "sim_priv.h"

/* tau at real time t, and back: t = -ln(1 - c tau)/c */
static double exp_tau_of(const pr_sim *s, double t)
{
	const double c = s->t.friction;

	return -expm1(-c * t) / c;
}

static double exp_time_of(const pr_sim *s, double tau)
{
	const double c = s->t.friction;

	return -log1p(-c * tau) / c;
}

static void exp_at(const pr_sim *s, const pr_sim_ball *b, double tau, double p[2], double v[2])
{
	double f = 1 - s->t.friction * tau; /* e^{-ct} */

	p[0] = b->x + b->ux * (tau - b->tr);
	p[1] = b->y + b->uy * (tau - b->tr);
	v[0] = b->ux * f;
	v[1] = b->uy * f;
}

static void exp_advance(const pr_sim *s, pr_sim_ball *b, double tau)
{
	(void)s;
	b->x += b->ux * (tau - b->tr);
	b->y += b->uy * (tau - b->tr);
	b->tr = tau;
}

static void exp_changed(const pr_sim *s, pr_sim_ball *b)
{
	(void)s;
	pr_sim_ball_changed(b);
}

/* The ball's own next event: stop, cushion or pocket entry. */
static void exp_own(const pr_sim *s, pr_sim_ball *b)
{
	const double c = s->t.friction;
	pr_sim_hits h;

	if (!pr_sim_own_moving(b))
		return;
	/* |u| (1 - c tau) = stop_speed */
	b->ot = fmax(b->tr, (1 - s->t.stop_speed / b->sp) / c);
	b->otype = PR_EV_STOP;
	pr_sim_path_hits(s, b->x, b->y, b->ux, b->uy, b->sp, &h);
	if (h.cid >= 0)
		pr_sim_own_offer(b, b->tr + h.cushion, PR_EV_CUSHION, h.cid);
	if (h.pid >= 0)
		pr_sim_own_offer(b, b->tr + h.pocket, PR_EV_POCKET, h.pid);
}

/* Contact time (absolute tau) of balls i and j seen from tau:
 * |d + w s| = 2R while approaching; HUGE_VAL if none. */
static double exp_pair(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj, double tau)
{
	const double r2 = 2 * s->t.ball_radius;
	double dx, dy, wx, wy, bq, a, cc, cr, disc, t, close;

	wx = bj->ux - bi->ux;
	wy = bj->uy - bi->uy;
	dx = (bj->x + bj->ux * (tau - bj->tr)) - (bi->x + bi->ux * (tau - bi->tr));
	dy = (bj->y + bj->uy * (tau - bj->tr)) - (bi->y + bi->uy * (tau - bi->tr));
	bq = dx * wx + dy * wy;
	if (bq >= 0)
		return HUGE_VAL;
	a = wx * wx + wy * wy;
	cr = dx * wy - dy * wx;
	disc = a * r2 * r2 - cr * cr;
	if (disc <= 0)
		return HUGE_VAL;
	cc = dx * dx + dy * dy - r2 * r2;
	if (cc <= 0) { /* touching or overlapping by rounding, and approaching */
		t = tau;
		close = -bq / sqrt(dx * dx + dy * dy);
	} else {
		double sq = sqrt(disc);
		t = tau + cc / (-bq + sq); /* stable form of the smaller root */
		close = sq / r2;           /* -(d + w s).w / 2R at contact */
	}
	if (close * (1 - s->t.friction * t) < PR_SIM_MIN_CLOSING)
		return HUGE_VAL;
	return t;
}

/* Smallest distance of bi and bj over the last linear piece
 * [max(tr_i, tr_j), tau] of both paths. */
static double exp_min_dist(const pr_sim *s, const pr_sim_ball *c, const pr_sim_ball *r, double tau,
                           double gap)
{
	double t0, dx, dy, wx, wy, a, sm;

	(void)s;
	(void)gap;
	t0 = fmax(c->tr, r->tr);
	dx = (r->x + r->ux * (t0 - r->tr)) - (c->x + c->ux * (t0 - c->tr));
	dy = (r->y + r->uy * (t0 - r->tr)) - (c->y + c->uy * (t0 - c->tr));
	wx = r->ux - c->ux;
	wy = r->uy - c->uy;
	a = wx * wx + wy * wy;
	sm = a > 0 ? -(dx * wx + dy * wy) / a : 0;
	if (sm <= 0)
		return hypot(dx, dy);
	if (sm >= tau - t0)
		return hypot(dx + wx * (tau - t0), dy + wy * (tau - t0));
	return fabs(dx * wy - dy * wx) / sqrt(a); /* interior minimum: distance to the line */
}

static double exp_step_decay(const pr_sim *s)
{
	return exp(-s->t.friction * s->o.dt);
}

/* under v' = -c v the speed falls linearly with distance: v = v0 - c s */
static double exp_speed_for(const pr_table *t, double v, double d)
{
	return v + t->friction * d;
}

static int exp_check(const pr_table *t, const pr_sim_opts *o, int active, char *err)
{
	(void)o;
	(void)active;
	return pr_sim_check_positive(t->friction, "table.friction", err);
}

/* no step: step_decay is the whole law in stepped mode */
const pr_sim_law pr_sim_law_exp = {
	.tau_of = exp_tau_of, .time_of = exp_time_of, .at = exp_at, .advance = exp_advance,
	.changed = exp_changed, .own = exp_own, .settle = pr_sim_ball_stop, .pair = exp_pair,
	.min_dist = exp_min_dist, .step_decay = exp_step_decay, .speed_for = exp_speed_for,
	.check = exp_check,
};
