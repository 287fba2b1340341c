/* sim_stepped.c — the thesis's fixed-step scheme (7.1.2, sim.mode = stepped).
 *
 * Per step of dt: move every moving ball by v dt; pocket test (centre within
 * the pocket radius); cushions (centre beyond its line and moving outwards:
 * eq. 7.4); ball pairs that overlap and approach exchange their normal
 * velocity components (eq. 7.5-7.6); friction multiplies every velocity by
 * 1 - f with f = 1 - e^{-c dt}, the same c as event mode; a ball slower than
 * the stop speed stops. Positions are not corrected after a bounce, as in
 * the thesis, so the scheme converges to event mode at first order in dt.
 * That friction is the thesis's law; another law (s->law) applies its own
 * step to each moving ball instead, and every step runs the tested phases.
 *
 * Without a trace, stretches of steps in which no test can fire run without
 * the tests (see "Event-free windows" below); the arithmetic of every step
 * is unchanged, so the results are bit-identical.
 */
#include <math.h>

#include "sim_priv.h"

static int trace_all(const pr_sim *s, int n, pr_sim_trace *tr, double t)
{
	int i;

	for (i = 0; i < n; ++i) {
		const pr_sim_ball *b = &s->b[i];
		if (b->st != PR_BALL_POCKETED && pr_sim_trace_add(tr, t, i, b->x, b->y, b->ux, b->uy))
			return PR_ENOMEM;
	}
	return PR_OK;
}

static double gap2(const pr_sim *s, int nr, double best)
{
	const pr_sim_ball *c = &s->b[0];
	int i;

	if (c->st == PR_BALL_POCKETED)
		return best;
	for (i = 1; i <= nr; ++i) {
		const pr_sim_ball *r = &s->b[i];
		double dx = r->x - c->x, dy = r->y - c->y;
		if (r->st != PR_BALL_POCKETED && dx * dx + dy * dy < best)
			best = dx * dx + dy * dy;
	}
	return best;
}

typedef struct {
	double dt, kappa, decay, vs2, r2, rp2, ypk, hx, hy;
	int law_step;        /* 1: the law's step, not v *= decay, is the friction */
	int n, nr, nmov, hit;
	long step;
	double g2;           /* smallest squared cue-reward centre distance */
	pr_sim_trace *tr;
} stepper;

static int pocket_of(const pr_sim *s, double rp2, double x, double y)
{
	int j;

	for (j = 0; j < PR_SIM_POCKETS; ++j) {
		double dx = x - s->px[j], dy = y - s->py[j];
		if (dx * dx + dy * dy <= rp2)
			return j;
	}
	return -1;
}

/* Move, pocket test and cushions for every moving ball. Returns 1 if
 * something happened, PR_ENOMEM if the trace cannot grow. */
static int phase_move(pr_sim *s, stepper *k)
{
	int i, j, ev = 0;

	for (i = 0; i < k->n; ++i) {
		pr_sim_ball *bi = &s->b[i];
		if (bi->st != PR_BALL_MOVING)
			continue;
		bi->x += bi->ux * k->dt;
		bi->y += bi->uy * k->dt;
		if (fabs(bi->y) >= k->ypk && (j = pocket_of(s, k->rp2, bi->x, bi->y)) >= 0) {
			double t = k->step * k->dt;
			if (k->tr && pr_sim_trace_add(k->tr, t, i, bi->x, bi->y, bi->ux, bi->uy))
				return PR_ENOMEM;
			s->pocket[i] = j;
			bi->x = s->px[j];
			bi->y = s->py[j];
			bi->ux = bi->uy = 0;
			bi->st = PR_BALL_POCKETED;
			if (k->tr && pr_sim_trace_add(k->tr, t, i, bi->x, bi->y, 0, 0))
				return PR_ENOMEM;
			--k->nmov;
			ev = 1;
			continue;
		}
		if ((bi->x > k->hx && bi->ux > 0) || (bi->x < -k->hx && bi->ux < 0)) {
			bi->ux = -k->kappa * bi->ux;
			ev = 1;
		}
		if ((bi->y > k->hy && bi->uy > 0) || (bi->y < -k->hy && bi->uy < 0)) {
			bi->uy = -k->kappa * bi->uy;
			ev = 1;
		}
	}
	return ev;
}

/* Overlapping, approaching pairs exchange normal components. */
static int phase_pairs(pr_sim *s, stepper *k)
{
	int i, j, ev = 0;

	for (i = 0; i < k->n; ++i) {
		pr_sim_ball *bi = &s->b[i];
		if (bi->st == PR_BALL_POCKETED)
			continue;
		for (j = i + 1; j < k->n; ++j) {
			pr_sim_ball *bj = &s->b[j];
			double dx, dy, d2, wx, wy, dv;
			if (bj->st == PR_BALL_POCKETED || (bi->st != PR_BALL_MOVING && bj->st != PR_BALL_MOVING))
				continue;
			dx = bj->x - bi->x;
			dy = bj->y - bi->y;
			d2 = dx * dx + dy * dy;
			wx = bj->ux - bi->ux;
			wy = bj->uy - bi->uy;
			if (d2 >= k->r2 || dx * wx + dy * wy >= 0)
				continue;
			dv = (wx * dx + wy * dy) / d2;
			bi->ux += dv * dx;
			bi->uy += dv * dy;
			bj->ux -= dv * dx;
			bj->uy -= dv * dy;
			k->nmov += (bi->st != PR_BALL_MOVING) + (bj->st != PR_BALL_MOVING);
			bi->st = bj->st = PR_BALL_MOVING;
			if (i == 0 && j <= k->nr)
				k->hit = 1;
			ev = 1;
		}
	}
	return ev;
}

/* Friction factor 1 - f = e^{-c dt} and the stop threshold, or the law's
 * own step. */
static int phase_friction(pr_sim *s, stepper *k)
{
	int i, ev = 0, stop;

	for (i = 0; i < k->n; ++i) {
		pr_sim_ball *bi = &s->b[i];
		if (bi->st != PR_BALL_MOVING)
			continue;
		if (k->law_step) {
			stop = s->law->step(s, bi);
		} else {
			bi->ux *= k->decay;
			bi->uy *= k->decay;
			stop = bi->ux * bi->ux + bi->uy * bi->uy < k->vs2;
		}
		if (stop) {
			bi->ux = bi->uy = 0;
			bi->st = PR_BALL_REST;
			--k->nmov;
			ev = 1;
		}
	}
	return ev;
}

/* The register loops below keep a ball's velocity in locals: a ball slower
 * than the stop speed comes to rest (returns 1). */
static inline int rests(pr_sim_ball *b, double *vx, double *vy, double vs2)
{
	if (!(*vx * *vx + *vy * *vy < vs2))
		return 0;
	*vx = *vy = 0;
	b->st = PR_BALL_REST;
	return 1;
}

/* A register loop's copy of a ball goes back into its state. */
static inline void put_ball(pr_sim_ball *b, double x, double y, double vx, double vy)
{
	b->x = x;
	b->y = y;
	b->ux = vx;
	b->uy = vy;
}

/* The same step as phase_move, phase_pairs and phase_friction, specialised
 * to one moving ball among resting ones and kept in registers: it runs
 * until that ball stops, falls, reaches the step limit (returns 0: the
 * steps are complete) or overlaps an approaching ball (returns 1: that
 * step's move is done and the caller continues it from phase_pairs). */
static int run_single(pr_sim *s, stepper *k, long maxsteps)
{
	const double dt = k->dt, hx = k->hx, hy = k->hy, kappa = k->kappa, decay = k->decay;
	const double vs2 = k->vs2, r2 = k->r2, ypk = k->ypk;
	pr_sim_ball *b = s->b, *bm;
	double *ox = s->scr, *oy = s->scr + s->cap;
	int *partner = s->idx;
	double x, y, vx, vy, g2 = k->g2;
	long step = k->step;
	int m, j, q, no = 0, ret = 0;

	for (m = 0; b[m].st != PR_BALL_MOVING; ++m)
		;
	bm = &b[m];
	/* the resting balls on the table, and whether each one's distance to
	 * the mover is a cue-reward gap still to track */
	for (j = 0; j < k->n; ++j)
		if (j != m && b[j].st != PR_BALL_POCKETED) {
			ox[no] = b[j].x;
			oy[no] = b[j].y;
			partner[no++] = !k->hit && (m == 0 ? j <= k->nr : m <= k->nr && j == 0);
		}
	x = bm->x;
	y = bm->y;
	vx = bm->ux;
	vy = bm->uy;
	while (step < maxsteps) {
		++step;
		x += vx * dt;
		y += vy * dt;
		if (fabs(y) >= ypk && (j = pocket_of(s, k->rp2, x, y)) >= 0) {
			s->pocket[m] = j;
			x = s->px[j];
			y = s->py[j];
			vx = vy = 0;
			bm->st = PR_BALL_POCKETED;
			k->nmov = 0;
			goto out;
		}
		if ((x > hx && vx > 0) || (x < -hx && vx < 0))
			vx = -kappa * vx;
		if ((y > hy && vy > 0) || (y < -hy && vy < 0))
			vy = -kappa * vy;
		/* (p_j - p_m).(v_j - v_m) < 0 with v_j = 0; the distance is also the
		 * gap the general loop would measure after friction (which moves nothing) */
		for (q = 0; q < no; ++q) {
			double ex = ox[q] - x, ey = oy[q] - y, d2 = ex * ex + ey * ey;
			if (d2 < r2 && ex * vx + ey * vy > 0) {
				ret = 1;
				goto out;
			}
			if (partner[q] && d2 < g2)
				g2 = d2;
		}
		vx *= decay;
		vy *= decay;
		if (rests(bm, &vx, &vy, vs2)) {
			k->nmov = 0;
			break;
		}
	}
out:
	put_ball(bm, x, y, vx, vy);
	k->g2 = g2;
	k->step = step;
	return ret;
}

/* The same step for exactly two balls, both moving, in registers. A step
 * that brings a ball near a pocket's cushion line is left to the general
 * phases (returns before starting it); otherwise it runs until a ball stops
 * or the step limit. */
static void run_pair(pr_sim *s, stepper *k, long maxsteps)
{
	pr_sim_ball *b0 = &s->b[0], *b1 = &s->b[1];
	double x0 = b0->x, y0 = b0->y, vx0 = b0->ux, vy0 = b0->uy;
	double x1 = b1->x, y1 = b1->y, vx1 = b1->ux, vy1 = b1->uy;
	const double dt = k->dt, hx = k->hx, hy = k->hy, kappa = k->kappa, decay = k->decay;
	const double vs2 = k->vs2, r2 = k->r2, ypk = k->ypk;
	const int gap = k->nr >= 1;
	double g2 = k->g2;
	long step = k->step;
	int hit = k->hit, nmov = 2;

	while (step < maxsteps) {
		double nx0 = x0 + vx0 * dt, ny0 = y0 + vy0 * dt;
		double nx1 = x1 + vx1 * dt, ny1 = y1 + vy1 * dt;
		double dx, dy, d2, wx, wy;
		if (fabs(ny0) >= ypk || fabs(ny1) >= ypk)
			break;
		++step;
		x0 = nx0;
		y0 = ny0;
		x1 = nx1;
		y1 = ny1;
		if ((x0 > hx && vx0 > 0) || (x0 < -hx && vx0 < 0))
			vx0 = -kappa * vx0;
		if ((y0 > hy && vy0 > 0) || (y0 < -hy && vy0 < 0))
			vy0 = -kappa * vy0;
		if ((x1 > hx && vx1 > 0) || (x1 < -hx && vx1 < 0))
			vx1 = -kappa * vx1;
		if ((y1 > hy && vy1 > 0) || (y1 < -hy && vy1 < 0))
			vy1 = -kappa * vy1;
		dx = x1 - x0;
		dy = y1 - y0;
		d2 = dx * dx + dy * dy;
		wx = vx1 - vx0;
		wy = vy1 - vy0;
		if (d2 < r2 && dx * wx + dy * wy < 0) {
			double dv = (wx * dx + wy * dy) / d2;
			vx0 += dv * dx;
			vy0 += dv * dy;
			vx1 -= dv * dx;
			vy1 -= dv * dy;
			hit |= gap;
		}
		vx0 *= decay;
		vy0 *= decay;
		vx1 *= decay;
		vy1 *= decay;
		nmov -= rests(b0, &vx0, &vy0, vs2);
		nmov -= rests(b1, &vx1, &vy1, vs2);
		if (!hit && gap && d2 < g2)
			g2 = d2;
		if (nmov < 2)
			break;
	}
	put_ball(b0, x0, y0, vx0, vy0);
	put_ball(b1, x1, y1, vx1, vy1);
	k->g2 = g2;
	k->step = step;
	k->hit = hit;
	k->nmov = nmov;
}

/* ---- Event-free windows ------------------------------------------------
 *
 * Between a ball's events the step only moves and slows it. safe_steps()
 * bounds, from the current positions and speeds, how many steps K surely
 * contain no pocket test that can succeed, no cushion test that can fire and
 * no ball pair that can overlap; the win* loops then run those K steps with
 * the identical per-step arithmetic (x += v dt; v *= decay; stop test) and
 * skip the tests. The bounds are conservative including rounding:
 *
 *  - during a window no velocity changes except by the factor decay < 1, so
 *    every computed |vx|, |vy| is at most its value at the window's start,
 *    each coordinate is monotone, and after K steps a coordinate has moved
 *    by at most K (|vx| dt (1 + u) + u X), X bounding |x| on the way;
 *  - the cushion test of x only fires while the ball moves towards that
 *    line, so only the distance to the line ahead counts (likewise y);
 *  - the pocket test only runs while |y| >= W/2 - r_p; past that gate, a
 *    ball farther than r_p from every pocket centre by more than it can
 *    travel cannot fall;
 *  - two balls cannot overlap if their distance exceeds 2R by more than
 *    both can travel.
 *
 * Per step each coordinate is given the rate |v| dt (1 + 1e-9) + 1e-15 S,
 * with S = 1 + L + W + 2 sum over movers (|x| + |y|), so that 1e-15 S is at
 * least 4u times any coordinate reached within the window (the cushion bound
 * keeps |x| below |x0| + L). Every distance gets a relative margin of 1e-9
 * and an absolute one of 1e-12 S. The smallest cue-reward gap stays exact: a pair
 * whose distance cannot fall to the current smallest gap within the window
 * is not measured (its gap cannot change the minimum); every other pair is
 * measured at every step exactly as gap2() does. */
#define WIN_MIN 8         /* shorter windows run the tested steps instead */
#define WIN_CAP (1L << 24)
#define WIN_REL 1e-9      /* the relative margin on every rate and distance */

/* Safe step count (0 if below WIN_MIN) for the moving balls. Sets *track
 * to the number of cue-reward pairs whose gap must be measured per step;
 * with a single mover their partner indices go to s->idx. */
static long safe_steps(pr_sim *s, const stepper *k, long limit, int *track)
{
	const pr_sim_ball *b = s->b;
	const double dt = k->dt, rel = 1 + WIN_REL, lo = 1 - WIN_REL, r2R = 2 * s->t.ball_radius * rel;
	const double rp = s->t.pocket_radius * rel, hx = k->hx, hy = k->hy, ypk = k->ypk;
	double *ae = s->scr, S = 1 + s->t.length + s->t.width, eps, mg, K = (double)limit;
	int i, j, n = k->n, nt = 0;

	for (i = 0; i < n; ++i)
		if (b[i].st == PR_BALL_MOVING)
			S += 2 * (fabs(b[i].x) + fabs(b[i].y));
	eps = 1e-15 * S;
	mg = 1e-12 * S;
	for (i = 0; i < n; ++i) {
		const double x = b[i].x, y = b[i].y, vx = b[i].ux, vy = b[i].uy;
		double ax, ay, q;
		if (b[i].st != PR_BALL_MOVING) {
			ae[i] = 0;
			continue;
		}
		ax = fabs(vx) * dt * rel + eps;
		ay = fabs(vy) * dt * rel + eps;
		ae[i] = sqrt(vx * vx + vy * vy) * dt * (1 + 1e-8) + 2 * eps;
		if (vx != 0) {
			q = ((vx > 0 ? hx - x : x + hx) - mg) / ax;
			if (!(q >= K))
				K = q;
		}
		if (vy != 0) {
			q = ((vy > 0 ? hy - y : y + hy) - mg) / ay;
			if (!(q >= K))
				K = q;
		}
		/* pockets: steps before |y| can reach the gate ... */
		q = 0;
		if (fabs(y) < ypk)
			q = vy == 0 ? K : ((vy > 0 ? ypk - y : y + ypk) - mg) / ay;
		if (!(q >= K)) { /* ... or before the ball can reach a pocket */
			double d2 = HUGE_VAL, qd;
			for (j = 0; j < PR_SIM_POCKETS; ++j) {
				double dx = x - s->px[j], dy = y - s->py[j];
				if (!(dx * dx + dy * dy >= d2))
					d2 = dx * dx + dy * dy;
			}
			qd = (sqrt(d2) * lo - rp - mg) / ae[i];
			if (!(q >= qd))
				q = qd;
			if (!(q >= K))
				K = q;
		}
		if (!(K >= WIN_MIN))
			return 0;
	}
	for (i = 0; i < n; ++i) {
		if (b[i].st == PR_BALL_POCKETED)
			continue;
		for (j = i + 1; j < n; ++j) {
			double dx, dy, q;
			if (b[j].st == PR_BALL_POCKETED || (ae[i] == 0 && ae[j] == 0))
				continue;
			dx = b[j].x - b[i].x;
			dy = b[j].y - b[i].y;
			q = (sqrt(dx * dx + dy * dy) * lo - r2R - mg) / (ae[i] + ae[j]);
			if (!(q >= K))
				K = q;
		}
		if (!(K >= WIN_MIN))
			return 0;
	}
	K = floor(K);
	if (K > WIN_CAP)
		K = WIN_CAP;
	if (!k->hit && b[0].st != PR_BALL_POCKETED) {
		const double g = sqrt(k->g2) * rel + mg;
		for (j = 1; j <= k->nr; ++j) {
			double dx, dy;
			if (b[j].st == PR_BALL_POCKETED || (ae[0] == 0 && ae[j] == 0))
				continue;
			dx = b[j].x - b[0].x;
			dy = b[j].y - b[0].y;
			if (!(sqrt(dx * dx + dy * dy) * lo - K * (ae[0] + ae[j]) >= g)) {
				if (k->nmov == 1)
					s->idx[nt] = ae[0] != 0 ? j : 0;
				++nt;
			}
		}
	}
	*track = nt;
	return (long)K;
}

/* K event-free steps of the single moving ball m, measuring its gap to the
 * nt resting partners s->idx[0..nt-1]; stops after a step where it stops. */
static void win_single(pr_sim *s, stepper *k, int m, long K, int nt)
{
	const double dt = k->dt, decay = k->decay, vs2 = k->vs2;
	pr_sim_ball *bm = &s->b[m];
	double *ox = s->scr, *oy = s->scr + s->cap;
	double x = bm->x, y = bm->y, vx = bm->ux, vy = bm->uy, g2 = k->g2;
	long i;
	int q;

	for (q = 0; q < nt; ++q) {
		ox[q] = s->b[s->idx[q]].x;
		oy[q] = s->b[s->idx[q]].y;
	}
	if (nt == 0) { /* the common case gets a loop of its own */
		for (i = 0; i < K;) {
			++i;
			x += vx * dt;
			y += vy * dt;
			vx *= decay;
			vy *= decay;
			if (vx * vx + vy * vy < vs2)
				break;
		}
	} else {
		for (i = 0; i < K;) {
			++i;
			x += vx * dt;
			y += vy * dt;
			for (q = 0; q < nt; ++q) {
				double ex = ox[q] - x, ey = oy[q] - y, d2 = ex * ex + ey * ey;
				if (d2 < g2)
					g2 = d2;
			}
			vx *= decay;
			vy *= decay;
			if (vx * vx + vy * vy < vs2)
				break;
		}
	}
	k->nmov -= rests(bm, &vx, &vy, vs2);
	put_ball(bm, x, y, vx, vy);
	k->g2 = g2;
	k->step += i;
}

/* K event-free steps of the two moving balls m0 < m1, no gap to measure;
 * stops after a step where one stops. */
static void win_two(pr_sim *s, stepper *k, int m0, int m1, long K)
{
	const double dt = k->dt, decay = k->decay, vs2 = k->vs2;
	pr_sim_ball *b0 = &s->b[m0], *b1 = &s->b[m1];
	double x0 = b0->x, y0 = b0->y, vx0 = b0->ux, vy0 = b0->uy;
	double x1 = b1->x, y1 = b1->y, vx1 = b1->ux, vy1 = b1->uy;
	long i;
	int stop = 0;

	for (i = 0; i < K && !stop;) {
		++i;
		x0 += vx0 * dt;
		y0 += vy0 * dt;
		x1 += vx1 * dt;
		y1 += vy1 * dt;
		vx0 *= decay;
		vy0 *= decay;
		vx1 *= decay;
		vy1 *= decay;
		stop = rests(b0, &vx0, &vy0, vs2);
		stop += rests(b1, &vx1, &vy1, vs2);
		k->nmov -= stop;
	}
	put_ball(b0, x0, y0, vx0, vy0);
	put_ball(b1, x1, y1, vx1, vy1);
	k->step += i;
}

/* K event-free steps of any moving balls, in place; if track, every
 * cue-reward gap is measured per step by gap2(). Stops after a step where
 * a ball stops. */
static void win_any(pr_sim *s, stepper *k, long K, int track)
{
	const double dt = k->dt, decay = k->decay, vs2 = k->vs2;
	long i;
	int j, stop = 0;

	for (i = 0; i < K && !stop;) {
		++i;
		for (j = 0; j < k->n; ++j) {
			pr_sim_ball *bj = &s->b[j];
			if (bj->st != PR_BALL_MOVING)
				continue;
			bj->x += bj->ux * dt;
			bj->y += bj->uy * dt;
		}
		for (j = 0; j < k->n; ++j) {
			pr_sim_ball *bj = &s->b[j];
			if (bj->st != PR_BALL_MOVING)
				continue;
			bj->ux *= decay;
			bj->uy *= decay;
			if (rests(bj, &bj->ux, &bj->uy, vs2)) {
				--k->nmov;
				stop = 1;
			}
		}
		if (track)
			k->g2 = gap2(s, k->nr, k->g2);
	}
	k->step += i;
}

/* Runs one event-free window if one of at least WIN_MIN steps is known;
 * returns 0 if not. */
static int run_window(pr_sim *s, stepper *k, long maxsteps)
{
	int nt, m0, m1;
	long K = safe_steps(s, k, maxsteps - k->step, &nt);

	if (K < WIN_MIN)
		return 0;
	for (m0 = 0; s->b[m0].st != PR_BALL_MOVING; ++m0)
		;
	if (k->nmov == 1) {
		win_single(s, k, m0, K, nt);
		return 1;
	}
	if (k->nmov == 2 && nt == 0) {
		for (m1 = m0 + 1; s->b[m1].st != PR_BALL_MOVING; ++m1)
			;
		win_two(s, k, m0, m1, K);
		return 1;
	}
	win_any(s, k, K, nt > 0);
	return 1;
}

#define STEP_COUNT_TOL 1e-9

int pr_sim_run_stepped(pr_sim *s, int n, pr_shot *res, pr_sim_trace *tr, char *err)
{
	/* a max_time that is a whole number of steps up to rounding is that number */
	const long maxsteps = (long)ceil(s->o.max_time / s->o.dt - STEP_COUNT_TOL);
	const long tk = lround(s->o.trace_dt / s->o.dt) > 1 ? lround(s->o.trace_dt / s->o.dt) : 1;
	pr_sim_ball *b = s->b;
	stepper k;
	int i;

	k.dt = s->o.dt;
	k.kappa = s->t.restitution;
	k.decay = s->law->step_decay(s);
	k.law_step = k.decay == 0;
	k.vs2 = s->t.stop_speed * s->t.stop_speed;
	k.r2 = 4 * s->t.ball_radius * s->t.ball_radius;
	k.rp2 = s->t.pocket_radius * s->t.pocket_radius;
	k.ypk = s->t.width / 2 - s->t.pocket_radius; /* every pocket lies on y = +-W/2 */
	k.hx = s->hx;
	k.hy = s->hy;
	k.n = n;
	k.nr = s->t.reward_balls;
	k.nmov = 0;
	k.hit = 0;
	k.step = 0;
	k.tr = tr;
	for (i = 0; i < n; ++i)
		k.nmov += b[i].st == PR_BALL_MOVING;
	k.g2 = gap2(s, k.nr, HUGE_VAL);
	if (tr && trace_all(s, n, tr, 0))
		return pr_err(err, PR_ENOMEM, "trace: out of memory");
	while (k.nmov > 0 && k.step < maxsteps) {
		long lim = maxsteps;
		int ev;
		/* the fast paths and windows hard-code v *= decay */
		if (!tr && !k.law_step) {
			if (run_window(s, &k, maxsteps))
				continue;
			/* near an event: tested steps for a while */
			lim = maxsteps - k.step > WIN_MIN ? k.step + WIN_MIN : maxsteps;
		}
		if (k.nmov == 1 && !tr && !k.law_step) {
			if (!run_single(s, &k, lim))
				continue;
			ev = 0;
		} else {
			if (n == 2 && k.nmov == 2 && !tr && !k.law_step) {
				long before = k.step;
				run_pair(s, &k, lim);
				if (k.step > before)
					continue;
			}
			++k.step;
			if ((ev = phase_move(s, &k)) < 0)
				return pr_err(err, PR_ENOMEM, "trace: out of memory");
		}
		ev |= phase_pairs(s, &k);
		ev |= phase_friction(s, &k);
		if (!k.hit)
			k.g2 = gap2(s, k.nr, k.g2);
		if (tr && (ev || k.step % tk == 0) && trace_all(s, n, tr, k.step * k.dt))
			return pr_err(err, PR_ENOMEM, "trace: out of memory");
	}
	for (i = 0; i < n; ++i) {
		s->final[2 * i] = b[i].x;
		s->final[2 * i + 1] = b[i].y;
	}
	res->hit = k.hit;
	res->min_gap = k.hit || k.nr < 1 ? 0 : fmax(0, sqrt(k.g2) - 2 * s->t.ball_radius);
	res->t_end = k.step * k.dt;
	res->events = k.step;
	if (tr && trace_all(s, n, tr, res->t_end))
		return pr_err(err, PR_ENOMEM, "trace: out of memory");
	return PR_OK;
}
