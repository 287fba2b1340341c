/* sim_priv.h — the simulator's internals: the ball state and the
 * simulator object, the shared core below both time-advance schemes
 * (sim_core.c: trace, path hits; sim_accel.c: contact of two paths of
 * constant acceleration), the friction-law interface (one table of
 * functions per law, sim_law_*.c, found through the registry sim_law.c)
 * and the two schemes the dispatcher (sim.c) calls. */
#ifndef POOLREPS_SIM_PRIV_H
#define POOLREPS_SIM_PRIV_H

#include <math.h>

#include "poolreps/sim.h"
#include "poolreps/internal.h"

/* Ball states. */
enum { PR_BALL_MOVING = 0, PR_BALL_REST = 1, PR_BALL_POCKETED = 2 };

/* Event-mode event types, in tie-break order (pocket and stop
 * before collisions, then by ball index). */
enum { PR_EV_POCKET = 0, PR_EV_STOP = 1, PR_EV_CUSHION = 2, PR_EV_BALL = 3, PR_EV_NONE = 4 };

/* One ball. Event mode: (x,y) is the position at reference tau tr and (ux,uy)
 * the velocity rescaled to t = 0, so between events the position is
 * (x,y) + u (tau - tr) (see sim_event.c). Stepped mode: (x,y) and (ux,uy) are
 * the current position and real velocity; tr, sp and the event caches are unused. */
typedef struct {
	double x, y, ux, uy;
	double tr;       /* reference tau of (x,y) */
	double sp;       /* |u| */
	double ex, ey;   /* event mode, for the law's use (a direction, an acceleration) */
	double wx, wy;   /* the rolling spin as a velocity, R w x z (for a law that keeps one) */
	double tend;     /* event mode, for the law's use: the end of the current phase */
	int ph;          /* event mode, for the law's use: the current phase */
	double et;       /* cached earliest event involving this ball (absolute tau) */
	int etype;       /* PR_EV_* */
	int eother;      /* partner ball, cushion (0..3) or pocket (0..5) */
	double ot;       /* its own next event alone (stop, cushion, pocket): as et */
	int otype, oother;
	int st;          /* PR_BALL_* */
} pr_sim_ball;

typedef struct pr_sim_law pr_sim_law;

struct pr_sim {
	const pr_sim_law *law;   /* table.friction_law's functions */
	pr_table t;
	pr_sim_opts o;
	double hx, hy;           /* |x| <= hx, |y| <= hy: the centre's free region */
	double px[PR_SIM_POCKETS], py[PR_SIM_POCKETS];
	int cap;                 /* balls the workspace holds */
	pr_sim_ball *b;
	double *final;
	int *pocket;
	int *idx;                /* cap ints of scratch (stepped mode) */
	double *scr;             /* 2*cap doubles of scratch (stepped mode; event mode: the
	                            pair times of an event's balls) */
};

struct pr_sim_trace {
	long n, cap;
	pr_sim_trace_row *rows;
};

/* ---- the core (sim_core.c) ---- */

/* Append a row; PR_ENOMEM if the trace cannot grow. */
int pr_sim_trace_add(pr_sim_trace *tr, double t, int ball, double x, double y,
                     double vx, double vy);

/* Where a straight path from (x,y) along (ux,uy), |u| = sp, first meets a
 * cushion line (cushion 0 x = -hx, 1 x = +hx, 2 y = -hy, 3 y = +hy) and a
 * pocket's capture circle, in units of the path parameter s of
 * (x,y) + u s (HUGE_VAL and -1 if never; an entry already under way is 0).
 * A pocket that can only be entered after the cushion line is not reported. */
typedef struct {
	double cushion, pocket;
	int cid, pid;
} pr_sim_hits;
void pr_sim_path_hits(const pr_sim *s, double x, double y, double ux, double uy, double sp,
                      pr_sim_hits *h);

/* Whether event (t1, type k1) comes before (t2, k2): by time, ties by type. */
static inline int pr_sim_earlier(double t1, int k1, double t2, int k2)
{
	return t1 < t2 || (t1 == t2 && k1 < k2);
}

/* A law's search for a ball's own next event (ot, otype, oother): none
 * for a ball not moving (returns 0); the law then sets the stop and offers
 * each cushion or pocket entry, the earliest staying (ties by type). */
static inline int pr_sim_own_moving(pr_sim_ball *b)
{
	b->ot = HUGE_VAL;
	b->otype = PR_EV_NONE;
	b->oother = -1;
	return b->st == PR_BALL_MOVING;
}

static inline void pr_sim_own_offer(pr_sim_ball *b, double t, int type, int other)
{
	if (pr_sim_earlier(t, type, b->ot, b->otype)) {
		b->ot = t;
		b->otype = type;
		b->oother = other;
	}
}

/* After a hit or a bounce: sp = |u|, moving if sp > 0 (the changed of a
 * law without spin); and a stop (its settle). */
void pr_sim_ball_changed(pr_sim_ball *b);
void pr_sim_ball_stop(const pr_sim *s, pr_sim_ball *b);
/* The reference of b moved to t, where it is at p with velocity v (sp = |v|). */
void pr_sim_ball_rebase(pr_sim_ball *b, double t, const double p[2], const double v[2]);
/* PR_OK if v is finite and > 0, else a message naming key. */
int pr_sim_check_positive(double v, const char *key, char *err);

/* ---- the friction-law interface ----
 *
 * A law says how a ball moves between events. Event mode: the engine works
 * in the law's event variable tau (an increasing function of the real
 * time); a moving ball's (x,y) and (ux,uy) are what the law keeps at its
 * reference tr (sim_event.c's comment). Stepped mode: the law slows one
 * ball by one step. The engines call only these functions. */
struct pr_sim_law {
	/* tau at real time t, and the real time at tau */
	double (*tau_of)(const pr_sim *s, double t);
	double (*time_of)(const pr_sim *s, double tau);
	/* position and velocity of a ball on the table at tau */
	void (*at)(const pr_sim *s, const pr_sim_ball *b, double tau, double p[2], double v[2]);
	/* moves b's reference to tau (before its velocity changes there) */
	void (*advance)(const pr_sim *s, pr_sim_ball *b, double tau);
	/* after a hit or a bounce changed b's velocity at its reference (and at
	 * the start, for a moving ball): its speed sp, state st and the law's
	 * caches */
	void (*changed)(const pr_sim *s, pr_sim_ball *b);
	/* b's own next event (ot, otype, oother): the end of its phase (stop
	 * time, PR_EV_STOP), a cushion line or a pocket's capture circle */
	void (*own)(const pr_sim *s, pr_sim_ball *b);
	/* on b's PR_EV_STOP, at its reference: it stops, or its next phase starts */
	void (*settle)(const pr_sim *s, pr_sim_ball *b);
	/* contact time of two balls on the table (at least one moving), seen
	 * from tau: HUGE_VAL if none before either's own event */
	double (*pair)(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj, double tau);
	/* smallest centre distance of bi and bj over [max(tr_i, tr_j), tau], or
	 * HUGE_VAL when it is provably above gap */
	double (*min_dist)(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj, double tau,
	                   double gap);
	/* Stepped mode: the factor every velocity is multiplied by per step
	 * when that is all the law does (the engine's fast paths use it), or 0;
	 * then step applies one step's friction to a moving ball and returns 1
	 * if the ball stops. */
	double (*step_decay)(const pr_sim *s);
	int (*step)(const pr_sim *s, pr_sim_ball *b);
	/* Speed a ball struck without spin needs to cover distance d and still
	 * have speed v (the ghost-ball expert's). */
	double (*speed_for)(const pr_table *t, double v, double d);
	/* The law's parameters valid (PR_OK) or a message naming the key;
	 * active: the law is table.friction_law (else only each key's range) */
	int (*check)(const pr_table *t, const pr_sim_opts *o, int active, char *err);
};

/* The registry (sim_law.c): the law of table.friction_law, NULL if none;
 * every law's parameter check, in the registry's order. */
const pr_sim_law *pr_sim_law_get(int law);
int pr_sim_law_check_all(const pr_table *t, const pr_sim_opts *o, char *err);
/* 1 if table.key is a parameter of friction laws other than law only
 * (another law's coefficient): that law ignores it. */
int pr_sim_law_idle_key(int law, const char *key);

/* ---- paths of constant acceleration (sim_accel.c) ----
 * The separation of two balls whose accelerations are constant over a
 * window [0, S]: d(s) = D + W s + H s^2 (H the half relative acceleration),
 * r2 the contact distance. */
typedef struct {
	double D[2], W[2], H[2], r2;
} pr_sim_rel_path;
/* First s in [0, S] where |d| = r2 while closing at MIN_CLOSING or more;
 * HUGE_VAL if none. */
double pr_sim_accel_first_contact(const pr_sim_rel_path *q, double S);
/* Smallest |d| over [0, S] (q->r2 unused). */
double pr_sim_accel_min_norm(const pr_sim_rel_path *q, double S);
/* Provable misses on [0, T] (the window's travel LT of both balls; dn =
 * |D| - r2): 1 if no contact can lie there. */
/* A ball moving straight at speed sp along v/|v|, slowing at a, reaching at
 * most lmax further, against one at rest at (dx, dy) from it: the distance
 * l it travels to touch it (|(dx,dy) - e l| = r2) closing at
 * PR_SIM_MIN_CLOSING or more, HUGE_VAL if none (the discriminant by the
 * Lagrange identity, so an exact graze is none). */
double pr_sim_accel_line_contact(double dx, double dy, const double v[2], double sp, double a,
                                 double lmax, double r2);
int pr_sim_accel_apart(const pr_sim_rel_path *q, double dn, double T, double LT);
int pr_sim_accel_misses(const pr_sim_rel_path *q, double T);

#define PR_SIM_MIN_CLOSING 1e-9 /* m/s: slower approaches are not collisions */

/* The two time-advance schemes. They start from s->b[0..n-1] set up by
 * pr_sim_shoot (positions, cue velocity, states) and fill res except nballs,
 * final and pocket, which they leave in s->final and s->pocket. */
int pr_sim_run_event(pr_sim *s, int n, pr_shot *res, pr_sim_trace *tr, char *err);
int pr_sim_run_stepped(pr_sim *s, int n, pr_shot *res, pr_sim_trace *tr, char *err);

#endif
