/* sim_law_slide.c — sliding, then rolling (table.friction_law = slide_roll).
 *
 * A ball carries its velocity v and its rolling spin as a velocity
 * w = R (omega_y, -omega_x) (no side spin): its contact point slips at
 * v - w, and it rolls when v = w. While it slides, friction mu_s m g acts
 * against the slip direction c: v' = -mu_s g c, and its torque turns the
 * spin, w' = +5/2 mu_s g c (a solid ball, I = 2/5 m R^2). The slip shrinks
 * along its own direction at 7/2 mu_s g, so c is constant, the
 * acceleration is constant, the path is a parabola, and the ball rolls
 * after |v - w| / (7/2 mu_s g). Rolling, it slows at mu_r g along v (w = v)
 * until its speed is stop_speed. A ball struck without spin (every start
 * is a stun shot) slides straight and rolls at 5/7 of its speed.
 *
 * Collisions act on v alone (docs/sim.md): ball-ball contacts are
 * frictionless and exchange the normal components of the velocities, not
 * the spins, so a cue ball stopped by a straight hit keeps its roll and
 * follows to 2/7 of its speed; the cushion mirrors v with kappa (eq. 7.4)
 * and, frictionless at the centre's height, leaves w unchanged, so the
 * ball slides after a bounce.
 *
 * Event mode (the event variable is the real time). Every phase (a slide,
 * a roll) has a constant acceleration a, kept in (ex, ey), and ends at
 * tend, a PR_EV_STOP: the slide turns into a roll, the roll into rest. From
 * its reference tr a ball is at p + u s + a s^2 / 2. Cushion entries are
 * quadratics per axis, pocket entries and ball contacts the quartic of
 * sim_accel.c, each solved up to the end of the phases.
 *
 * Stepped mode (the thesis's scheme, 7.1.2): per step the slip shrinks by
 * 7/2 mu_s g dt; a step that would pass zero ends the slide exactly
 * (v = w = (5 v + 2 w) / 7), then the roll loses mu_r g dt of speed. The
 * slide is resolved to one step: its position error is first order in dt
 * as under the other laws (docs/sim.md gives the bound).
 */
#include <math.h>

#include "sim_priv.h"

#define G 9.81 /* m/s^2 */

enum { SLIDE = 0, ROLL = 1 }; /* a ball's phase in event mode (ph) */

static double norm(double x, double y)
{
	return sqrt(x * x + y * y);
}

static double same_time(const pr_sim *s, double t)
{
	(void)s;
	return t;
}

/* The phase starting at b's reference: a slide when it slips, else a roll
 * (or rest); sets a, tend, sp and st. */
static void phase(const pr_sim *s, pr_sim_ball *b)
{
	const double cx = b->ux - b->wx, cy = b->uy - b->wy, slip = norm(cx, cy);
	const double ms = s->t.mu_slide * G, mr = s->t.mu_roll * G;

	b->sp = norm(b->ux, b->uy);
	b->ph = slip > 0 ? SLIDE : ROLL;
	if (slip > 0) {
		b->ex = -ms * cx / slip;
		b->ey = -ms * cy / slip;
		b->tend = b->tr + slip / (3.5 * ms);
		b->st = PR_BALL_MOVING;
	} else if (b->sp > 0) {
		b->ex = -mr * b->ux / b->sp;
		b->ey = -mr * b->uy / b->sp;
		b->tend = b->tr + fmax(0, (b->sp - s->t.stop_speed) / mr);
		b->st = PR_BALL_MOVING;
	} else {
		b->ex = b->ey = 0;
		b->st = PR_BALL_REST;
	}
}

static void slide_at(const pr_sim *s, const pr_sim_ball *b, double t, double p[2], double v[2])
{
	const double h = t - b->tr;

	(void)s;
	if (b->st != PR_BALL_MOVING) {
		p[0] = b->x;
		p[1] = b->y;
		v[0] = v[1] = 0;
		return;
	}
	p[0] = b->x + h * (b->ux + 0.5 * h * b->ex);
	p[1] = b->y + h * (b->uy + 0.5 * h * b->ey);
	v[0] = b->ux + h * b->ex;
	v[1] = b->uy + h * b->ey;
}

/* Moves the reference to t within the phase; the spin follows: w' = -5/2 a
 * while sliding, w = v while rolling. */
static void slide_advance(const pr_sim *s, pr_sim_ball *b, double t)
{
	const double h = t - b->tr;
	double p[2], v[2];

	if (b->st != PR_BALL_MOVING) {
		b->tr = t;
		return;
	}
	slide_at(s, b, t, p, v);
	if (b->ph == SLIDE) {
		b->wx -= 2.5 * h * b->ex;
		b->wy -= 2.5 * h * b->ey;
	} else {
		b->wx = v[0];
		b->wy = v[1];
	}
	pr_sim_ball_rebase(b, t, p, v);
}

static void slide_changed(const pr_sim *s, pr_sim_ball *b)
{
	phase(s, b);
}

/* The end of a phase: a slide becomes a roll, a roll ends at rest. */
static void slide_settle(const pr_sim *s, pr_sim_ball *b)
{
	if (b->ph == SLIDE) {
		b->wx = b->ux;
		b->wy = b->uy;
		phase(s, b);
		return;
	}
	b->wx = b->wy = 0;
	pr_sim_ball_stop(s, b);
}

/* First s in [0, S] at which f0 + v s + a s^2 / 2 reaches 0 while rising
 * (the centre crossing a cushion line outwards); HUGE_VAL if none. At
 * s = 0 only when already moving outwards. */
static double first_rise(double f0, double v, double a, double S)
{
	double disc, r, t;

	if (a == 0) {
		t = v > 0 ? fmax(0, -f0 / v) : HUGE_VAL;
	} else {
		disc = v * v - 2 * a * f0;
		if (!(disc > 0))
			return HUGE_VAL;
		r = sqrt(disc); /* f' at the rising root */
		t = v > 0 ? fmax(0, -2 * f0 / (v + r)) : (r - v) / a;
		if (!(t > 0) && !(t == 0 && v > 0))
			return HUGE_VAL;
	}
	return t <= S ? t : HUGE_VAL;
}

/* Its own next event: the phase's end, a cushion line, a pocket. */
static void slide_own(const pr_sim *s, pr_sim_ball *b)
{
	const double S = fmax(0, b->tend - b->tr);
	double t, lt;
	int j;

	if (!pr_sim_own_moving(b))
		return;
	b->ot = b->tend;
	b->otype = PR_EV_STOP;
	for (j = 0; j < 4; ++j) {
		/* cushion j: 0 x = -hx, 1 x = +hx, 2 y = -hy, 3 y = +hy; f = outward excess */
		const double sg = j % 2 ? 1 : -1, h = j < 2 ? s->hx : s->hy;
		const double x = j < 2 ? b->x : b->y, u = j < 2 ? b->ux : b->uy, a = j < 2 ? b->ex : b->ey;
		t = b->tr + first_rise(sg * x - h, sg * u, sg * a, S);
		if (t < HUGE_VAL)
			pr_sim_own_offer(b, t, PR_EV_CUSHION, j);
	}
	/* the speed is convex in time on a phase: the travel is at most S times its larger end */
	lt = S * fmax(b->sp, norm(b->ux + S * b->ex, b->uy + S * b->ey));
	for (j = 0; j < PR_SIM_POCKETS; ++j) {
		pr_sim_rel_path q = {{b->x - s->px[j], b->y - s->py[j]}, {b->ux, b->uy},
		                     {0.5 * b->ex, 0.5 * b->ey}, s->t.pocket_radius};
		if (pr_sim_accel_apart(&q, norm(q.D[0], q.D[1]) - q.r2, S, lt))
			continue;
		t = b->tr + pr_sim_accel_first_contact(&q, S);
		if (t < HUGE_VAL)
			pr_sim_own_offer(b, t, PR_EV_POCKET, j);
	}
}

/* The separation of bj from bi from time t, and the window up to the end
 * of the first of their phases. */
static double relative(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj, double t,
                       pr_sim_rel_path *q, double *LT)
{
	double pi[2], vi[2], pj[2], vj[2], S = HUGE_VAL;
	const pr_sim_ball *b[2] = {bi, bj};
	int k;

	slide_at(s, bi, t, pi, vi);
	slide_at(s, bj, t, pj, vj);
	q->D[0] = pj[0] - pi[0];
	q->D[1] = pj[1] - pi[1];
	q->W[0] = vj[0] - vi[0];
	q->W[1] = vj[1] - vi[1];
	q->H[0] = q->H[1] = 0;
	q->r2 = 2 * s->t.ball_radius;
	for (k = 0; k < 2; ++k)
		if (b[k]->st == PR_BALL_MOVING) {
			const double sg = k ? 0.5 : -0.5;
			q->H[0] += sg * b[k]->ex;
			q->H[1] += sg * b[k]->ey;
			S = fmin(S, b[k]->tend - t);
		}
	S = fmax(S, 0);
	*LT = 0;
	for (k = 0; k < 2; ++k)
		if (b[k]->st == PR_BALL_MOVING) {
			const double *v = k ? vj : vi;
			*LT += S * fmax(norm(v[0], v[1]), norm(v[0] + S * b[k]->ex, v[1] + S * b[k]->ey));
		}
	return S;
}

/* A phase along a straight line that does not turn back: a roll, or the
 * slide of a ball without spin (its slip is its velocity). */
static int straight(const pr_sim_ball *b)
{
	return b->ph == ROLL || (b->wx == 0 && b->wy == 0);
}

/* A straight mover m against o at rest: the contact is a quadratic in the
 * distance, so an exact graze is no contact. */
static double line_pair(const pr_sim *s, const pr_sim_ball *m, const pr_sim_ball *o, double t)
{
	const double S = fmax(0, m->tend - t), a = norm(m->ex, m->ey);
	double p[2], v[2], sp, l, d;

	slide_at(s, m, t, p, v);
	sp = norm(v[0], v[1]);
	if (!(sp > 0))
		return HUGE_VAL;
	l = pr_sim_accel_line_contact(o->x - p[0], o->y - p[1], v, sp, a,
	                              fmax(0, S * (sp - 0.5 * a * S)), 2 * s->t.ball_radius);
	if (!(l < HUGE_VAL))
		return HUGE_VAL;
	d = sp * sp - 2 * a * l;
	return l <= 0 ? t : t + 2 * l / (sp + sqrt(d > 0 ? d : 0));
}

static double slide_pair(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj, double t)
{
	pr_sim_rel_path q;
	double LT, S, r;

	if (bi->st != PR_BALL_MOVING && straight(bj))
		return line_pair(s, bj, bi, t);
	if (bj->st != PR_BALL_MOVING && straight(bi))
		return line_pair(s, bi, bj, t);
	S = relative(s, bi, bj, t, &q, &LT);

	if (pr_sim_accel_apart(&q, norm(q.D[0], q.D[1]) - q.r2, S, LT))
		return HUGE_VAL;
	r = pr_sim_accel_first_contact(&q, S);
	return r < HUGE_VAL ? t + r : HUGE_VAL;
}

static double slide_min_dist(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj,
                             double t, double gap)
{
	const double t0 = fmax(bi->tr, bj->tr);
	pr_sim_rel_path q;
	double LT;

	(void)gap;
	relative(s, bi, bj, t0, &q, &LT);
	return pr_sim_accel_min_norm(&q, t - t0);
}

static double slide_step_decay(const pr_sim *s)
{
	(void)s;
	return 0;
}

/* One step's friction (see the top): the slide, ended exactly within the
 * step where it would reverse, or the roll. Returns 1 when the ball stops. */
static int slide_step(const pr_sim *s, pr_sim_ball *b)
{
	const double dt = s->o.dt, vs = s->t.stop_speed;
	const double cx = b->ux - b->wx, cy = b->uy - b->wy, slip = norm(cx, cy);

	if (slip > 0) {
		const double ms = s->t.mu_slide * G;
		if (slip <= 3.5 * ms * dt) {
			b->ux = b->wx = (5 * b->ux + 2 * b->wx) / 7;
			b->uy = b->wy = (5 * b->uy + 2 * b->wy) / 7;
		} else {
			b->ux -= ms * dt * cx / slip;
			b->uy -= ms * dt * cy / slip;
			b->wx += 2.5 * ms * dt * cx / slip;
			b->wy += 2.5 * ms * dt * cy / slip;
			return 0;
		}
	} else {
		const double dv = s->t.mu_roll * G * dt, v = norm(b->ux, b->uy);
		const double f = v > dv ? (v - dv) / v : 0;
		b->ux = b->wx = b->ux * f;
		b->uy = b->wy = b->uy * f;
	}
	if (b->ux * b->ux + b->uy * b->uy < vs * vs) {
		b->wx = b->wy = 0;
		return 1;
	}
	return 0;
}

/* From a stun start: a slide at mu_s g over 12 v0^2 / (49 mu_s g), ending
 * at 5/7 v0, then a roll at mu_r g. */
static double slide_speed_for(const pr_table *t, double v, double d)
{
	const double ms = t->mu_slide * G, mr = t->mu_roll * G;
	const double v0 = sqrt(v * v + 2 * ms * d);

	if (7 * v >= 5 * v0)
		return v0; /* still sliding at d: v^2 = v0^2 - 2 mu_s g d */
	/* (5/7 v0)^2 - 2 mu_r g (d - 12 v0^2 / (49 mu_s g)) = v^2 */
	return sqrt((v * v + 2 * mr * d) / ((25 + 24 * mr / ms) / 49));
}

static int slide_check(const pr_table *t, const pr_sim_opts *o, int active, char *err)
{
	int rc;

	(void)o;
	if ((rc = pr_sim_check_positive(t->mu_slide, "table.mu_slide", err)) ||
	    (rc = pr_sim_check_positive(t->mu_roll, "table.mu_roll", err)))
		return rc;
	if (active && !(t->mu_roll < t->mu_slide))
		return pr_err(err, PR_EINVAL, "table.mu_roll: must be below table.mu_slide (got %g >= %g)",
		              t->mu_roll, t->mu_slide);
	return PR_OK;
}

const pr_sim_law pr_sim_law_slide = {
	.tau_of = same_time, .time_of = same_time, .at = slide_at, .advance = slide_advance,
	.changed = slide_changed, .own = slide_own, .settle = slide_settle, .pair = slide_pair,
	.min_dist = slide_min_dist, .step_decay = slide_step_decay, .step = slide_step,
	.speed_for = slide_speed_for, .check = slide_check,
};
