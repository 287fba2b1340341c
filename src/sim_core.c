/* sim_core.c — what both time-advance schemes (sim_event.c, sim_stepped.c)
 * and the dispatcher above them (sim.c) share: the pockets' positions and
 * entries, the checks of a state and an action, the trace of a shot and
 * where a straight path first meets a cushion or a pocket. */
#include <math.h>
#include <stdlib.h>

#include "sim_priv.h"

#define POS_SLACK 1e-12 /* m: touching balls and cushions survive rounding */
#define POCKET_MARGIN 1e-6 /* m: a pocket this far from a path's box is out of its reach */

static double least(double x, double y)
{
	return y < x ? y : x;
}

static double most(double x, double y)
{
	return y > x ? y : x;
}

void pr_sim_pocket_xy(const pr_table *t, int id, double xy[2])
{
	/* ids 0,1,2 along y = -W/2 and 3,4,5 along y = +W/2, x = -L/2, 0, +L/2 */
	xy[0] = (id % 3 - 1) * t->length / 2;
	xy[1] = (id < 3 ? -1 : 1) * t->width / 2;
}

int pr_sim_pocket_entry(const pr_table *t, int id, double xy[2], char *err)
{
	double p[2], R = t->ball_radius, rp = t->pocket_radius;
	int corner = id % 3 != 1;
	/* unit vector from the pocket into the table; the lines clipping the disc,
	 * y = +-(W/2 - R) and at a corner x = +-(L/2 - R), both lie R from the
	 * pocket centre, so the entry arc is symmetric about it */
	double nx = corner ? sqrt(0.5) : 0, ny = corner ? sqrt(0.5) : 1;

	pr_sim_pocket_xy(t, id, p);
	xy[0] = p[0] - copysign(rp * nx, p[0]);
	xy[1] = p[1] - copysign(rp * ny, p[1]);
	if (!(rp > (corner ? R * sqrt(2.0) : R)))
		return pr_err(err, PR_EINVAL, "pocket %d: its corridor is empty (table.pocket_radius %g <= %s)",
		              id, rp, corner ? "R sqrt 2" : "R");
	return PR_OK;
}

pr_sim_trace *pr_sim_trace_new(char *err)
{
	pr_sim_trace *tr = calloc(1, sizeof *tr);

	if (!tr)
		pr_err(err, PR_ENOMEM, "trace: out of memory");
	return tr;
}

void pr_sim_trace_free(pr_sim_trace *tr)
{
	if (!tr)
		return;
	free(tr->rows);
	free(tr);
}

long pr_sim_trace_len(const pr_sim_trace *tr)
{
	return tr->n;
}

const pr_sim_trace_row *pr_sim_trace_rows(const pr_sim_trace *tr)
{
	return tr->rows;
}

int pr_sim_trace_add(pr_sim_trace *tr, double t, int ball, double x, double y, double vx, double vy)
{
	pr_sim_trace_row *r;

	if (tr->n == tr->cap) {
		long cap = tr->cap ? 2 * tr->cap : 256;
		r = realloc(tr->rows, (size_t)cap * sizeof *r);
		if (!r)
			return PR_ENOMEM;
		tr->rows = r;
		tr->cap = cap;
	}
	r = &tr->rows[tr->n++];
	r->t = t;
	r->ball = ball;
	r->x = x;
	r->y = y;
	r->vx = vx;
	r->vy = vy;
	return PR_OK;
}

int pr_sim_check_state(const pr_table *t, const double *st, int n, char *err)
{
	double hx = t->length / 2 - t->ball_radius + POS_SLACK;
	double hy = t->width / 2 - t->ball_radius + POS_SLACK;
	double d2min = (2 * t->ball_radius - POS_SLACK) * (2 * t->ball_radius - POS_SLACK);
	double r2 = t->pocket_radius * t->pocket_radius;
	int i, j, side;

	if (n < 1 || n > PR_SIM_MAX_BALLS)
		return pr_err(err, PR_EINVAL, "%d balls: must be 1 to %d", n, PR_SIM_MAX_BALLS);
	for (i = 0; i < n; ++i) {
		double x = st[2 * i], y = st[2 * i + 1];
		if (!isfinite(x) || !isfinite(y))
			return pr_err(err, PR_EINVAL, "ball %d: position is not finite", i);
		if (fabs(x) > hx || fabs(y) > hy)
			return pr_err(err, PR_EINVAL, "ball %d: off the table: centre (%g, %g) must be at "
			              "least R = %g from the cushions (|x| <= %g, |y| <= %g)", i, x, y,
			              t->ball_radius, hx - POS_SLACK, hy - POS_SLACK);
		for (side = 0; side < 2; ++side) {
			/* a side's three pockets share their y (pr_sim_pocket_xy's): when
			 * dy^2 alone exceeds rp^2, so does dx^2 + dy^2 for all three */
			double dy = y - (side ? 1 : -1) * t->width / 2;
			if (dy * dy > r2)
				continue;
			for (j = 3 * side; j < 3 * side + 3; ++j) {
				double p[2], dx;
				pr_sim_pocket_xy(t, j, p);
				dx = x - p[0];
				dy = y - p[1];
				if (dx * dx + dy * dy <= r2)
					return pr_err(err, PR_EINVAL, "ball %d: inside pocket %d: centre (%g, %g) "
					              "within %g of (%g, %g)", i, j, x, y, t->pocket_radius, p[0], p[1]);
			}
		}
	}
	for (i = 0; i < n; ++i)
		for (j = i + 1; j < n; ++j) {
			double dx = st[2 * j] - st[2 * i], dy = st[2 * j + 1] - st[2 * i + 1];
			if (dx * dx + dy * dy < d2min)
				return pr_err(err, PR_EINVAL, "balls %d and %d overlap: centre distance %g < 2R = %g",
				              i, j, sqrt(dx * dx + dy * dy), 2 * t->ball_radius);
		}
	return PR_OK;
}

int pr_sim_check_action(const pr_sim_opts *o, const double a[2], char *err)
{
	double v;

	if (!isfinite(a[0]) || !isfinite(a[1]))
		return pr_err(err, PR_EINVAL, "action: velocity is not finite");
	v = hypot(a[0], a[1]);
	if (v > o->max_speed)
		return pr_err(err, PR_EINVAL, "action: speed %g m/s exceeds sim.max_speed = %g", v, o->max_speed);
	return PR_OK;
}

void pr_sim_path_hits(const pr_sim *s, double x, double y, double ux, double uy, double sp,
                      pr_sim_hits *h)
{
	const double rp = s->t.pocket_radius;
	double sy, ex, ey, lo[2], hi[2];
	int j;

	h->cushion = h->pocket = HUGE_VAL;
	h->cid = h->pid = -1;
	if (ux > 0) {
		h->cushion = (s->hx - x) / ux;
		h->cid = 1;
	} else if (ux < 0) {
		h->cushion = (-s->hx - x) / ux;
		h->cid = 0;
	}
	sy = HUGE_VAL;
	if (uy > 0)
		sy = (s->hy - y) / uy;
	else if (uy < 0)
		sy = (-s->hy - y) / uy;
	if (sy < h->cushion) {
		h->cushion = sy;
		h->cid = uy > 0 ? 3 : 2;
	}
	h->cushion = fmax(h->cushion, 0);
	/* The path ends at the cushion line: a pocket whose capture circle lies
	 * POCKET_MARGIN outside the box around that segment can only be entered
	 * beyond it, after the bounce, so its root (far more exact than the
	 * margin) is not computed. */
	ex = ux != 0 ? x + ux * h->cushion : x;  /* no 0 * inf: the cushion may be HUGE_VAL */
	ey = uy != 0 ? y + uy * h->cushion : y;
	lo[0] = least(x, ex) - rp - POCKET_MARGIN;
	hi[0] = most(x, ex) + rp + POCKET_MARGIN;
	lo[1] = least(y, ey) - rp - POCKET_MARGIN;
	hi[1] = most(y, ey) + rp + POCKET_MARGIN;
	/* pockets: |d + u s| = rp, entering (d.u < 0); discriminant via the
	 * Lagrange identity b^2 - a c = a rp^2 - (d x u)^2 to avoid cancellation */
	for (j = 0; j < PR_SIM_POCKETS; ++j) {
		double dx, dy, bq, cc, cr, disc, t;
		/* one branch, mostly taken alike, instead of four at random */
		if (!((s->px[j] >= lo[0]) & (s->px[j] <= hi[0]) & (s->py[j] >= lo[1]) & (s->py[j] <= hi[1])))
			continue;
		dx = x - s->px[j];
		dy = y - s->py[j];
		bq = dx * ux + dy * uy;
		if (bq >= 0)
			continue;
		cr = dx * uy - dy * ux;
		disc = rp * rp * sp * sp - cr * cr;
		if (disc < 0)
			continue;
		cc = dx * dx + dy * dy - rp * rp;
		t = cc <= 0 ? 0 : cc / (-bq + sqrt(disc));
		if (t < h->pocket) {
			h->pocket = t;
			h->pid = j;
		}
	}
}

void pr_sim_ball_changed(pr_sim_ball *b)
{
	b->sp = hypot(b->ux, b->uy);
	b->st = b->sp > 0 ? PR_BALL_MOVING : PR_BALL_REST;
}

void pr_sim_ball_stop(const pr_sim *s, pr_sim_ball *b)
{
	(void)s;
	b->ux = b->uy = b->sp = 0;
	b->st = PR_BALL_REST;
}

int pr_sim_check_positive(double v, const char *key, char *err)
{
	if (!(v > 0) || !isfinite(v))
		return pr_err(err, PR_EINVAL, "%s: must be > 0 (got %g)", key, v);
	return PR_OK;
}

void pr_sim_ball_rebase(pr_sim_ball *b, double t, const double p[2], const double v[2])
{
	b->x = p[0];
	b->y = p[1];
	b->ux = v[0];
	b->uy = v[1];
	b->sp = sqrt(v[0] * v[0] + v[1] * v[1]);
	b->tr = t;
}
