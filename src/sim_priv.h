/* sim_priv.h — the simulator's internals: the ball state and the
 * simulator object, the shared core below both time-advance schemes
 * (sim_core.c: trace, path hits), the constant law's event arithmetic
 * (sim_event_const.c) and the two schemes the dispatcher (sim.c) calls. */
#ifndef POOLREPS_SIM_PRIV_H
#define POOLREPS_SIM_PRIV_H

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
	double ex, ey;   /* constant law, event mode, sp > 0: the direction u / sp */
	double et;       /* cached earliest event involving this ball (absolute tau) */
	int etype;       /* PR_EV_* */
	int eother;      /* partner ball, cushion (0..3) or pocket (0..5) */
	double ot;       /* its own next event alone (stop, cushion, pocket): as et */
	int otype, oother;
	int st;          /* PR_BALL_* */
} pr_sim_ball;

struct pr_sim {
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

/* Event mode under the constant-deceleration law (sim_event_const.c). The
 * event variable is the real time t; (x,y) and (ux,uy) are a ball's
 * position and velocity at its reference time tr. */
void pr_sim_const_at(const pr_sim *s, const pr_sim_ball *b, double t, double p[2], double v[2]);
void pr_sim_const_advance(const pr_sim *s, pr_sim_ball *b, double t);
/* Sets b's direction (ex, ey) from its velocity, after the velocity changed. */
void pr_sim_const_heading(pr_sim_ball *b);
void pr_sim_const_predict_own(const pr_sim *s, pr_sim_ball *b);
double pr_sim_const_pair_time(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj,
                              double t);
/* Smallest centre distance of balls i and j over [max(tr_i, tr_j), t], or
 * HUGE_VAL when one is at rest and it is provably above gap. */
double pr_sim_const_min_dist(const pr_sim *s, const pr_sim_ball *bi, const pr_sim_ball *bj,
                             double t, double gap);

/* The two time-advance schemes. They start from s->b[0..n-1] set up by
 * pr_sim_shoot (positions, cue velocity, states) and fill res except nballs,
 * final and pocket, which they leave in s->final and s->pocket. */
int pr_sim_run_event(pr_sim *s, int n, pr_shot *res, pr_sim_trace *tr, char *err);
int pr_sim_run_stepped(pr_sim *s, int n, pr_shot *res, pr_sim_trace *tr, char *err);

#endif
