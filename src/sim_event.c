/* sim_event.c — exact event-driven time advance (sim.mode = event).
 *
 * The friction law (s->law, sim_priv.h) says how a ball moves between
 * events, in its event variable tau: where a ball is, its own next event
 * (the end of its phase, a cushion, a pocket) and when two balls touch.
 * This file orders the events and applies them: the collision laws (eq.
 * 7.4-7.6) act on the velocities at the event's tau.
 *
 * Each ball caches the earliest event it takes part in, and its own next
 * event alone; after an event only the balls involved are re-predicted in
 * full, the others are checked against them (or re-predicted, on their
 * cached own event, when their cached partner was involved).
 * Positions are advanced lazily: a ball's reference changes only when its
 * velocity does. Ties: pocket < stop < cushion < ball collision, then by
 * ball index.
 */
#include <math.h>

#include "sim_priv.h"

/* Contact time (absolute tau) of balls i and j, both on the table, seen
 * from tau; HUGE_VAL if none. */
static double pair_time(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj, double tau)
{
	if (bi->st != PR_BALL_MOVING && bj->st != PR_BALL_MOVING)
		return HUGE_VAL;
	return s->law->pair(s, bi, bj, tau);
}

/* The pair times of an event's np balls part[], once each: row[k][j] is
 * that of part[k] and ball j, for the first done of them. pair_time is
 * symmetric in its two balls (the relative quantities change sign
 * exactly), so row[k][j] is also what ball j would compute against part[k]
 * at the same tau. */
typedef struct {
	int part[2], np, done;
	double *row[2];
} event_rows;

/* Pair time of balls i and j at tau, from er when already known there. */
static double pair_once(const pr_sim *s, const event_rows *er, int i, int j, double tau)
{
	int k;

	for (k = 0; er && k < er->done; ++k)
		if (er->part[k] == j)
			return er->row[k][i];
	return pair_time(s, &s->b[i], &s->b[j], tau);
}

/* Re-predict ball i in full: its own events (again only when own is set:
 * otherwise its state has not changed since they were), then every pair
 * with it; row, when given, receives the pair times. */
static void predict_full(pr_sim *s, int n, int i, double tau, int own, const event_rows *er,
                         double *row)
{
	pr_sim_ball *b = s->b, *bi = &b[i];
	int j;

	if (own)
		s->law->own(s, bi);
	bi->et = bi->ot;
	bi->etype = bi->otype;
	bi->eother = bi->oother;
	if (bi->st == PR_BALL_POCKETED)
		return;
	for (j = 0; j < n; ++j) {
		double t;
		if (j == i || b[j].st == PR_BALL_POCKETED)
			continue;
		t = pair_once(s, er, i, j, tau);
		if (row)
			row[j] = t;
		if (t < HUGE_VAL && pr_sim_earlier(t, PR_EV_BALL, bi->et, bi->etype)) {
			bi->et = t;
			bi->etype = PR_EV_BALL;
			bi->eother = j;
		}
	}
}

typedef struct {
	int nr;         /* reward balls 1..nr */
	int hit;
	double gap;     /* smallest centre distance so far */
} gap_state;

/* Smallest distance between the cue ball and reward ball i over the last
 * piece [max(tr0, tri), tau] of both paths. */
static void gap_piece(const pr_sim *s, gap_state *g, int i, double tau)
{
	const pr_sim_ball *c = &s->b[0], *r = &s->b[i];
	double d;

	if (c->st == PR_BALL_POCKETED || r->st == PR_BALL_POCKETED)
		return;
	d = s->law->min_dist(s, c, r, tau, g->gap);
	if (d < g->gap)
		g->gap = d;
}

/* Before ball k's velocity changes: close its pieces with the cue/reward balls. */
static void gap_close(const pr_sim *s, gap_state *g, int k, double tau)
{
	int i;

	if (g->hit || k > g->nr)
		return;
	if (k > 0) {
		gap_piece(s, g, k, tau);
		return;
	}
	for (i = 1; i <= g->nr; ++i)
		gap_piece(s, g, i, tau);
}

static int trace_all(const pr_sim *s, int n, pr_sim_trace *tr, double tau, double t)
{
	int i;

	for (i = 0; i < n; ++i) {
		const pr_sim_ball *b = &s->b[i];
		double p[2], v[2];
		if (b->st == PR_BALL_POCKETED)
			continue;
		s->law->at(s, b, tau, p, v);
		if (pr_sim_trace_add(tr, t, i, p[0], p[1], v[0], v[1]))
			return PR_ENOMEM;
	}
	return PR_OK;
}

/* After an event of the np balls part[]: re-predict them in full, every
 * other ball against them (or in full if its cached partner was one), each
 * pair of an event's ball computed once. */
static void repredict(pr_sim *s, int n, const int *part, int np, double tau)
{
	pr_sim_ball *b = s->b;
	event_rows er;
	int i, j;

	er.np = np;
	er.done = 0;
	for (j = 0; j < np; ++j) {
		er.part[j] = part[j];
		er.row[j] = s->scr + j * s->cap;
	}
	for (j = 0; j < np; ++j) {
		predict_full(s, n, part[j], tau, 1, &er, er.row[j]);
		er.done = j + 1;
	}
	for (i = 0; i < n; ++i) {
		pr_sim_ball *bi = &b[i];
		if (i == part[0] || (np == 2 && i == part[1]) || bi->st == PR_BALL_POCKETED)
			continue;
		if (bi->etype == PR_EV_BALL && (bi->eother == part[0] || (np == 2 && bi->eother == part[1]))) {
			predict_full(s, n, i, tau, 0, &er, NULL);
			continue;
		}
		for (j = 0; j < np; ++j) {
			double t;
			if (b[part[j]].st == PR_BALL_POCKETED)
				continue;
			t = er.row[j][i];
			if (t < HUGE_VAL && pr_sim_earlier(t, PR_EV_BALL, bi->et, bi->etype)) {
				bi->et = t;
				bi->etype = PR_EV_BALL;
				bi->eother = part[j];
			}
		}
	}
}

/* The ball whose cached event comes first (ties by type, then index), or -1. */
static int next_event(const pr_sim *s, int n)
{
	const pr_sim_ball *b = s->b;
	int i, k = -1;

	for (i = 0; i < n; ++i)
		if (b[i].etype != PR_EV_NONE && (k < 0 || pr_sim_earlier(b[i].et, b[i].etype, b[k].et, b[k].etype)))
			k = i;
	return k;
}

/* Ball k drops into pocket bk->eother at tau: traced where it crossed the
 * capture circle, then at rest on the pocket's centre. */
static int pocket_ball(pr_sim *s, int k, double tau, pr_sim_trace *tr)
{
	pr_sim_ball *bk = &s->b[k];
	double p[2], v[2];

	s->law->at(s, bk, tau, p, v);
	if (tr && pr_sim_trace_add(tr, s->law->time_of(s, tau), k, p[0], p[1], v[0], v[1]))
		return PR_ENOMEM;
	s->pocket[k] = bk->eother;
	bk->x = s->px[bk->eother];
	bk->y = s->py[bk->eother];
	bk->ux = bk->uy = bk->sp = 0;
	bk->st = PR_BALL_POCKETED;
	if (tr && pr_sim_trace_add(tr, s->law->time_of(s, tau), k, bk->x, bk->y, 0, 0))
		return PR_ENOMEM;
	return PR_OK;
}

/* eq. 7.4: the cushion reverses the normal component, scaled by the
 * restitution; the centre sits exactly on its line. */
static void cushion_bounce(const pr_sim *s, pr_sim_ball *bk)
{
	const double kappa = s->t.restitution;

	if (bk->eother < 2) {
		bk->x = bk->eother ? s->hx : -s->hx;
		bk->ux = -kappa * bk->ux;
	} else {
		bk->y = bk->eother == 3 ? s->hy : -s->hy;
		bk->uy = -kappa * bk->uy;
	}
	s->law->changed(s, bk);
}

/* eq. 7.5-7.6: balls k and j = bk->eother collide at tau and exchange the
 * normal components of their velocities; a contact of the cue ball with a
 * reward ball ends the gap record. */
static void ball_collision(pr_sim *s, gap_state *g, int k, double tau)
{
	pr_sim_ball *bk = &s->b[k], *bj = &s->b[bk->eother];
	const int j = bk->eother;
	double nx, ny, d, dv;

	gap_close(s, g, j, tau);
	s->law->advance(s, bj, tau);
	nx = bj->x - bk->x;
	ny = bj->y - bk->y;
	d = hypot(nx, ny);
	nx /= d;
	ny /= d;
	dv = (bj->ux - bk->ux) * nx + (bj->uy - bk->uy) * ny;
	bk->ux += dv * nx;
	bk->uy += dv * ny;
	bj->ux -= dv * nx;
	bj->uy -= dv * ny;
	s->law->changed(s, bk);
	s->law->changed(s, bj);
	if ((k == 0 && j <= g->nr) || (j == 0 && k <= g->nr)) {
		g->hit = 1;
		g->gap = 2 * s->t.ball_radius; /* contact: gap 0 */
	}
}

int pr_sim_run_event(pr_sim *s, int n, pr_shot *res, pr_sim_trace *tr, char *err)
{
	const double tmax = s->law->tau_of(s, s->o.max_time);
	pr_sim_ball *b = s->b;
	event_rows start;
	gap_state g;
	double tau = 0;
	long events = 0;
	int i, k, timeout = 0;

	for (i = 0; i < n; ++i)
		if (b[i].st == PR_BALL_MOVING)
			s->law->changed(s, &b[i]);
	g.nr = s->t.reward_balls;
	g.hit = 0;
	g.gap = HUGE_VAL;
	/* the cue ball's pair times serve the balls at rest, whose other pairs are at rest */
	start.part[0] = 0;
	start.np = 1;
	start.done = 0;
	start.row[0] = s->scr;
	for (i = 0; i < n; ++i) {
		predict_full(s, n, i, 0, 1, &start, i ? NULL : start.row[0]);
		start.done = 1;
	}
	if (tr && trace_all(s, n, tr, 0, 0))
		return pr_err(err, PR_ENOMEM, "trace: out of memory");
	while ((k = next_event(s, n)) >= 0) {
		int part[2], np = 1;
		pr_sim_ball *bk = &b[k];

		if (bk->et > tmax) {
			tau = tmax;
			timeout = 1;
			break;
		}
		if (++events > s->o.max_events)
			return pr_err(err, PR_ENUM, "shot needs more than sim.max_events = %ld events",
			              s->o.max_events);
		tau = bk->et;
		part[0] = k;
		gap_close(s, &g, k, tau);
		s->law->advance(s, bk, tau);
		if (bk->etype == PR_EV_STOP) {
			s->law->settle(s, bk);
		} else if (bk->etype == PR_EV_POCKET) {
			if (pocket_ball(s, k, tau, tr))
				return pr_err(err, PR_ENOMEM, "trace: out of memory");
		} else if (bk->etype == PR_EV_CUSHION) {
			cushion_bounce(s, bk);
		} else { /* PR_EV_BALL */
			part[np++] = bk->eother;
			ball_collision(s, &g, k, tau);
		}
		if (tr && trace_all(s, n, tr, tau, s->law->time_of(s, tau)))
			return pr_err(err, PR_ENOMEM, "trace: out of memory");
		repredict(s, n, part, np, tau);
	}
	if (!g.hit)
		for (i = 1; i <= g.nr; ++i)
			gap_piece(s, &g, i, tau);
	for (i = 0; i < n; ++i) {
		if (b[i].st != PR_BALL_POCKETED)
			s->law->advance(s, &b[i], tau);
		s->final[2 * i] = b[i].x;
		s->final[2 * i + 1] = b[i].y;
	}
	res->hit = g.hit;
	res->min_gap = g.nr < 1 ? 0 : fmax(0, g.gap - 2 * s->t.ball_radius);
	res->t_end = timeout ? s->o.max_time : s->law->time_of(s, tau);
	res->events = events;
	if (tr && trace_all(s, n, tr, tau, res->t_end))
		return pr_err(err, PR_ENOMEM, "trace: out of memory");
	return PR_OK;
}
