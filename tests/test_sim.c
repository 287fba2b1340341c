/* test_sim.c — the pool simulator: known answers in event mode, the stepped
 * scheme's first-order convergence, the ghost-ball expert, invariants. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <gsl/gsl_rng.h>

#include "poolreps/sim.h"
#include "poolreps/internal.h"
#include "test_util.h"

#define R 0.015
#define C 0.25
#define VS 0.002
#define KAPPA 0.8
#define A 0.0625 /* table.deceleration under the constant law */

typedef struct {
	pr_table t;
	pr_sim_opts o;
	pr_reward_opts ro;
	pr_expert_opts eo;
	pr_start_opts so;
	pr_sim *sim;
	pr_sim_trace *tr;
	pr_shot res;
	char err[PR_ERRLEN];
} fixture;

static fixture *make(int mode, int reward_balls)
{
	fixture *f = calloc(1, sizeof *f);

	assert_non_null(f);
	pr_sim_table_init(&f->t);
	pr_sim_opts_init(&f->o);
	pr_sim_reward_opts_init(&f->ro);
	pr_sim_expert_opts_init(&f->eo);
	pr_sim_start_opts_init(&f->so);
	f->t.reward_balls = reward_balls;
	f->o.mode = mode;
	f->sim = pr_sim_new(&f->t, &f->o, f->err);
	assert_non_null(f->sim);
	f->tr = pr_sim_trace_new(f->err);
	assert_non_null(f->tr);
	return f;
}

static void rebuild(fixture *f)
{
	pr_sim_free(f->sim);
	f->sim = pr_sim_new(&f->t, &f->o, f->err);
	assert_non_null(f->sim);
}

/* A fixture under friction law law (PR_FRICTION_*), deceleration A. */
static fixture *make_law(int mode, int reward_balls, int law)
{
	fixture *f = make(mode, reward_balls);

	f->t.friction_law = law;
	f->t.deceleration = A;
	rebuild(f);
	return f;
}

static void destroy(fixture *f)
{
	pr_sim_free(f->sim);
	pr_sim_trace_free(f->tr);
	free(f);
}

static int shoot(fixture *f, const double *st, int n, double vx, double vy)
{
	double a[2] = {vx, vy};
	return pr_sim_shoot(f->sim, st, n, a, &f->res, f->tr, f->err);
}

/* First trace row of ball b strictly after time t0 (the state after its event). */
static const pr_sim_trace_row *row_after(const fixture *f, int b, double t0)
{
	const pr_sim_trace_row *rows = pr_sim_trace_rows(f->tr);
	long k;

	for (k = 0; k < pr_sim_trace_len(f->tr); ++k)
		if (rows[k].ball == b && rows[k].t > t0)
			return &rows[k];
	fail_msg("no trace row of ball %d after t = %g", b, t0);
	return NULL;
}

/* Free flight stops after v0/c (1 - v_stop/v0) at t = ln(v0/v_stop)/c. */
static void test_free_flight(void **state)
{
	fixture *f = make(PR_SIM_EVENT, 0);
	double st[2] = {-0.45, -0.1};
	double v0 = 0.2, d = v0 / C * (1 - VS / v0);

	(void)state;
	assert_int_equal(shoot(f, st, 1, v0, 0), PR_OK);
	assert_near(f->res.final[0], -0.45 + d, 1e-13);
	assert_near(f->res.final[1], -0.1, 0);
	assert_near(f->res.t_end, log(v0 / VS) / C, 1e-11);
	assert_int_equal(f->res.events, 1);
	assert_int_equal(f->res.pocket[0], -1);
	/* diagonal, speed 0.1 */
	assert_int_equal(shoot(f, st, 1, 0.08, 0.06), PR_OK);
	d = 0.1 / C * (1 - VS / 0.1);
	assert_near(f->res.final[0], -0.45 + 0.8 * d, 1e-13);
	assert_near(f->res.final[1], -0.1 + 0.6 * d, 1e-13);
	/* slower than the stop speed: nothing moves */
	assert_int_equal(shoot(f, st, 1, 0.001, 0.001), PR_OK);
	assert_int_equal(f->res.events, 0);
	assert_near(f->res.final[0], -0.45, 0);
	destroy(f);
}

/* sim.max_time cuts a shot: position after 1 s is x0 + v0 (1 - e^{-c})/c. */
static void test_max_time(void **state)
{
	fixture *f = make(PR_SIM_EVENT, 0);
	double st[2] = {-0.45, 0};

	(void)state;
	f->o.max_time = 1;
	rebuild(f);
	assert_int_equal(shoot(f, st, 1, 0.2, 0), PR_OK);
	assert_near(f->res.t_end, 1, 0);
	assert_near(f->res.final[0], -0.45 + 0.2 * -expm1(-C) / C, 1e-13);
	destroy(f);
}

/* A head-on hit exchanges the velocities (eq. 7.5-7.6). */
static void test_head_on(void **state)
{
	fixture *f = make(PR_SIM_EVENT, 1);
	double st[4] = {-0.2, 0, 0, 0};
	double vc = 0.1 - C * (0.2 - 2 * R); /* speed at contact: v = v0 - c s */
	const pr_sim_trace_row *r0, *r1;

	(void)state;
	assert_int_equal(shoot(f, st, 2, 0.1, 0), PR_OK);
	assert_int_equal(f->res.hit, 1);
	assert_near(f->res.min_gap, 0, 0);
	assert_near(f->res.final[0], -2 * R, 1e-15);
	assert_near(f->res.final[1], 0, 0);
	assert_near(f->res.final[2], (vc - VS) / C, 1e-13);
	r0 = row_after(f, 0, 0);
	r1 = row_after(f, 1, 0);
	assert_near(r0->t, log(0.1 / vc) / C, 1e-12);
	assert_near(r0->vx, 0, 0);
	assert_near(r1->vx, vc, 1e-15);
	assert_near(r1->vy, 0, 0);
	destroy(f);
}

/* A cushion multiplies the normal speed by kappa and keeps the tangential. */
static void test_cushion(void **state)
{
	fixture *f = make(PR_SIM_EVENT, 0);
	double st[2] = {0.3, 0}, hx = 0.5 - R;
	double vin = 0.2 - C * (hx - 0.3), vout = KAPPA * vin;
	const pr_sim_trace_row *r;

	(void)state;
	assert_int_equal(shoot(f, st, 1, 0.2, 0), PR_OK);
	assert_int_equal(f->res.events, 2);
	assert_near(f->res.final[0], hx - (vout - VS) / C, 1e-13);
	r = row_after(f, 0, 0);
	assert_near(r->x, hx, 0);
	assert_near(r->vx, -vout, 1e-15);
	/* oblique: only the normal component changes */
	assert_int_equal(shoot(f, st, 1, 0.2, 0.05), PR_OK);
	r = row_after(f, 0, 0);
	assert_near(r->x, hx, 0);
	assert_near(r->vx / r->vy, -KAPPA * 0.2 / 0.05, 1e-12);
	destroy(f);
}

/* Pocket entry: the ball falls when its centre is within the pocket radius;
 * it reports the pocket centre. Corner pocket 5 and middle pocket 1. */
static void test_pocket_entry(void **state)
{
	fixture *f = make(PR_SIM_EVENT, 0);
	double st[2] = {0.3, 0.1}, st2[2] = {0, -0.1};
	double s = 0.25 - 0.03, ve = 0.5 - C * s; /* entry after 0.22 m */
	const pr_sim_trace_row *r;

	(void)state;
	assert_int_equal(shoot(f, st, 1, 0.4, 0.3), PR_OK);
	assert_int_equal(f->res.pocket[0], 5);
	assert_near(f->res.final[0], 0.5, 0);
	assert_near(f->res.final[1], 0.25, 0);
	assert_near(f->res.t_end, log(0.5 / ve) / C, 1e-12);
	r = row_after(f, 0, 0);
	assert_near(hypot(r->x - 0.5, r->y - 0.25), 0.03, 1e-14);
	assert_near(hypot(r->vx, r->vy), ve, 1e-14);
	assert_int_equal(shoot(f, st2, 1, 0, -0.3), PR_OK);
	assert_int_equal(f->res.pocket[0], 1);
	assert_near(f->res.final[0], 0, 0);
	assert_near(f->res.final[1], -0.25, 0);
	destroy(f);
}

/* Glancing shots: centre offset 2R - 1e-9 hits, 2R + 1e-9 misses by 1e-9. */
static void test_glancing(void **state)
{
	fixture *f = make(PR_SIM_EVENT, 1);
	double hit[4] = {-0.3, 0, 0, 2 * R - 1e-9}, miss[4] = {-0.3, 0, 0, 2 * R + 1e-9};
	/* the object ball gets the normal component, v_contact n_x, then stops */
	double nx = sqrt((2 * R - hit[3]) * (2 * R + hit[3])) / (2 * R);
	double vc = 0.5 - C * (0.3 - 2 * R * nx);
	const pr_sim_trace_row *r;

	(void)state;
	assert_int_equal(shoot(f, hit, 2, 0.5, 0), PR_OK);
	assert_int_equal(f->res.hit, 1);
	r = row_after(f, 1, 0);
	assert_near(hypot(r->vx, r->vy), vc * nx, 1e-9 * vc * nx);
	assert_true(r->vy > 0);
	assert_int_equal(shoot(f, miss, 2, 0.5, 0), PR_OK);
	assert_int_equal(f->res.hit, 0);
	assert_near(f->res.final[2], 0, 0);
	assert_near(f->res.final[3], miss[3], 0);
	assert_near(f->res.min_gap, 1e-9, 1e-14);
	destroy(f);
}

/* Touching balls collide at once when approaching, not when separating;
 * overlapping balls are refused. */
static void test_touching_overlapping(void **state)
{
	fixture *f = make(PR_SIM_EVENT, 1);
	double touch[4] = {0, 0, 2 * R, 0}, over[4] = {0, 0, 2 * R - 1e-6, 0};

	(void)state;
	assert_int_equal(shoot(f, touch, 2, 0.1, 0), PR_OK);
	assert_int_equal(f->res.hit, 1);
	assert_near(f->res.final[0], 0, 0);
	assert_near(f->res.final[2], 2 * R + (0.1 - VS) / C, 1e-13);
	assert_int_equal(shoot(f, touch, 2, -0.1, 0), PR_OK);
	assert_int_equal(f->res.hit, 0);
	assert_near(f->res.min_gap, 0, 0);
	assert_near(f->res.final[2], 2 * R, 0);
	assert_int_equal(shoot(f, over, 2, 0.1, 0), PR_EINVAL);
	assert_non_null(strstr(f->err, "overlap"));
	destroy(f);
}

static void test_check_state(void **state)
{
	pr_table t;
	char err[PR_ERRLEN];
	double ok[4] = {-0.485, 0.1, 0.3, 0.235}; /* touching two cushions */
	double off[4] = {-0.25, 0, 0.4851, 0};
	double pocket[4] = {-0.25, 0, 0.0, 0.225};
	double nan_[4] = {-0.25, 0, NAN, 0};
	pr_sim_opts o;
	double fast[2] = {7.1, 7.1}, inf_[2] = {INFINITY, 0};

	(void)state;
	pr_sim_table_init(&t);
	pr_sim_opts_init(&o);
	assert_int_equal(pr_sim_check_state(&t, ok, 2, err), PR_OK);
	assert_int_equal(pr_sim_check_state(&t, off, 2, err), PR_EINVAL);
	assert_non_null(strstr(err, "ball 1: off the table"));
	assert_int_equal(pr_sim_check_state(&t, pocket, 2, err), PR_EINVAL);
	assert_non_null(strstr(err, "inside pocket 4"));
	assert_int_equal(pr_sim_check_state(&t, nan_, 2, err), PR_EINVAL);
	assert_int_equal(pr_sim_check_state(&t, ok, 0, err), PR_EINVAL);
	assert_int_equal(pr_sim_check_state(&t, ok, PR_SIM_MAX_BALLS + 1, err), PR_EINVAL);
	assert_int_equal(pr_sim_check_action(&o, fast, err), PR_EINVAL);
	assert_non_null(strstr(err, "max_speed"));
	assert_int_equal(pr_sim_check_action(&o, inf_, err), PR_EINVAL);
}

/* The shot that once looped forever in a naive event solver. */
static void test_once_infinite_loop(void **state)
{
	fixture *f = make(PR_SIM_EVENT, 1);
	double st[4] = {-0.25, 0, 0.10335764983769453, 0.0074324223076832332};

	(void)state;
	f->t.friction = 1.005;
	f->t.stop_speed = 0.01;
	f->t.restitution = 0.8;
	rebuild(f);
	assert_int_equal(shoot(f, st, 2, 1.271579804933515, 0.030327333866585399), PR_OK);
	assert_int_equal(f->res.hit, 1);
	assert_true(f->res.events > 2 && f->res.events < 100);
	destroy(f);
}

/* Past sim.max_events the shot fails; it never loops. */
static void test_max_events(void **state)
{
	fixture *f = make(PR_SIM_EVENT, 1);
	double st[4] = {-0.25, 0, 0.1, 0.2};

	(void)state;
	f->o.max_events = 3;
	rebuild(f);
	assert_int_equal(shoot(f, st, 2, 1.5, 0.1), PR_ENUM);
	assert_non_null(strstr(f->err, "max_events"));
	destroy(f);
}

/* Reward of eq. 7.7 on hand-made outcomes. */
static void test_reward(void **state)
{
	fixture *f = make(PR_SIM_EVENT, 1);
	double away[4] = {-0.25, 0, 0.1, 0}, scratch[4] = {0.3, 0.1, -0.2, -0.1};
	double mid[4] = {0, 0.1, 0, 0.2};
	double d5 = hypot(0.4, 0.25);

	(void)state;
	/* miss: minus the distance to the nearer target minus 10 x the gap */
	assert_int_equal(shoot(f, away, 2, 0, 0.05), PR_OK);
	assert_int_equal(f->res.hit, 0);
	assert_near(f->res.min_gap, 0.35 - 2 * R, 1e-15);
	assert_near(pr_sim_reward(&f->t, &f->ro, &f->res), -d5 - 10 * (0.35 - 2 * R), 1e-14);
	/* scratch: the cue ball falls into pocket 5 */
	f->ro.scratch_penalty = 2;
	assert_int_equal(shoot(f, scratch, 2, 0.4, 0.3), PR_OK);
	assert_int_equal(f->res.pocket[0], 5);
	assert_near(pr_sim_reward(&f->t, &f->ro, &f->res),
	                   -hypot(0.7, 0.15) - 10 * (hypot(0.5, 0.2) - 2 * R) - 2, 1e-14);
	/* reward ball into middle pocket 4, not a target: -distance(4, 5) */
	assert_int_equal(shoot(f, mid, 2, 0, 0.3), PR_OK);
	assert_int_equal(f->res.pocket[1], 4);
	assert_int_equal(f->res.hit, 1);
	assert_near(pr_sim_reward(&f->t, &f->ro, &f->res), -0.5, 1e-15);
	destroy(f);
}

/* Ghost ball: geometry of a known state, and the reward ball enters the
 * pocket at arrival_speed + c rp (it is aimed to reach the centre at
 * arrival_speed, and v = v0 - c s). */
static void test_ghost_known(void **state)
{
	fixture *f = make(PR_SIM_EVENT, 1);
	double st[4] = {-0.25, 0, 0.3, 0.1}, a[2];
	pr_sim_ghost g;
	const pr_sim_trace_row *rows;
	long k;
	int seen = 0;

	(void)state;
	assert_int_equal(pr_sim_ghost_action(&f->t, &f->o, &f->ro, &f->eo, st, a, &g, f->err), PR_OK);
	assert_int_equal(g.target, 5);
	assert_near(g.dir[0], 0.8, 1e-15);
	assert_near(g.dir[1], 0.6, 1e-15);
	assert_near(g.ghost[0], 0.3 - 2 * R * 0.8, 1e-15);
	assert_near(g.ghost[1], 0.1 - 2 * R * 0.6, 1e-15);
	assert_near(hypot(a[0], a[1]), g.v0, 1e-15);
	assert_int_equal(shoot(f, st, 2, a[0], a[1]), PR_OK);
	assert_int_equal(f->res.pocket[1], 5);
	assert_near(pr_sim_reward(&f->t, &f->ro, &f->res), 0, 0);
	rows = pr_sim_trace_rows(f->tr);
	for (k = 0; k < pr_sim_trace_len(f->tr); ++k)
		if (rows[k].ball == 1 && hypot(rows[k].vx, rows[k].vy) > 0 &&
		    fabs(hypot(rows[k].x - 0.5, rows[k].y - 0.25) - 0.03) < 1e-12) {
			assert_near(hypot(rows[k].vx, rows[k].vy), 0.05 + C * 0.03, 1e-12);
			seen = 1;
		}
	assert_true(seen);
	/* Experiment 1's aim shot */
	assert_int_equal(pr_sim_aim_action(&f->eo, st, a, f->err), PR_OK);
	assert_near(a[0], 0.4 * 0.55 / hypot(0.55, 0.1), 1e-15);
	assert_near(a[1], 0.4 * 0.1 / hypot(0.55, 0.1), 1e-15);
	destroy(f);
}

/* The ghost-ball expert pockets from Experiment 2's start region, under
 * friction law law (its speed law re-derived for each). */
static void ghost_rate(int law)
{
	fixture *f = make_law(PR_SIM_EVENT, 1, law);
	gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
	double st[4], a[2];
	int i, ok = 0, n = 1000;

	gsl_rng_set(rng, 2);
	for (i = 0; i < n; ++i) {
		assert_int_equal(pr_sim_sample_start(&f->t, &f->so, 2, rng, st, f->err), PR_OK);
		assert_int_equal(pr_sim_ghost_action(&f->t, &f->o, &f->ro, &f->eo, st, a, NULL, f->err), PR_OK);
		assert_int_equal(pr_sim_shoot(f->sim, st, 2, a, &f->res, NULL, f->err), PR_OK);
		ok += pr_sim_reward(&f->t, &f->ro, &f->res) == 0;
	}
	print_message("ghost-ball expert: %d of %d pocketed (event mode, Exp. 2 region, law %d of %s)\n",
	              ok, n, law, PR_FRICTION_NAMES);
	assert_true(ok >= 0.99 * n);
	gsl_rng_free(rng);
	destroy(f);
}

static void test_ghost_rate(void **state)
{
	(void)state;
	ghost_rate(PR_FRICTION_EXPONENTIAL);
	ghost_rate(PR_FRICTION_CONSTANT);
	ghost_rate(PR_FRICTION_SLIDE_ROLL);
}

/* Constant law, free flight: the ball stops after (v0^2 - v_stop^2)/2a at
 * t = (v0 - v_stop)/a; cut by sim.max_time at 1 s it is at v0 - a/2. */
static void test_const_free_flight(void **state)
{
	fixture *f = make_law(PR_SIM_EVENT, 0, PR_FRICTION_CONSTANT);
	double st[2] = {-0.45, -0.1}, v0 = 0.2, d = (v0 * v0 - VS * VS) / (2 * A);

	(void)state;
	assert_int_equal(shoot(f, st, 1, v0, 0), PR_OK);
	assert_near(f->res.final[0], -0.45 + d, 1e-14);
	assert_near(f->res.final[1], -0.1, 0);
	assert_near(f->res.t_end, (v0 - VS) / A, 1e-13);
	assert_int_equal(f->res.events, 1);
	assert_int_equal(shoot(f, st, 1, 0.08, 0.06), PR_OK); /* diagonal, speed 0.1 */
	d = (0.01 - VS * VS) / (2 * A);
	assert_near(f->res.final[0], -0.45 + 0.8 * d, 1e-14);
	assert_near(f->res.final[1], -0.1 + 0.6 * d, 1e-14);
	f->o.max_time = 1;
	rebuild(f);
	assert_int_equal(shoot(f, st, 1, v0, 0), PR_OK);
	assert_near(f->res.t_end, 1, 0);
	assert_near(f->res.final[0], -0.45 + v0 - A / 2, 1e-14);
	destroy(f);
}

/* Constant law, head-on: the cue ball stops at contact, after
 * (v0 - v_c)/a with v_c^2 = v0^2 - 2 a s, and the object ball travels
 * (v_c^2 - v_stop^2)/2a. */
static void test_const_head_on(void **state)
{
	fixture *f = make_law(PR_SIM_EVENT, 1, PR_FRICTION_CONSTANT);
	double st[4] = {-0.2, 0, 0, 0}, v0 = 0.2;
	double vc = sqrt(v0 * v0 - 2 * A * (0.2 - 2 * R));
	const pr_sim_trace_row *r0, *r1;

	(void)state;
	assert_int_equal(shoot(f, st, 2, v0, 0), PR_OK);
	assert_int_equal(f->res.hit, 1);
	assert_near(f->res.final[0], -2 * R, 1e-15);
	assert_near(f->res.final[1], 0, 0);
	assert_near(f->res.final[2], (vc * vc - VS * VS) / (2 * A), 1e-14);
	r0 = row_after(f, 0, 0);
	r1 = row_after(f, 1, 0);
	assert_near(r0->t, (v0 - vc) / A, 1e-13);
	assert_near(r0->vx, 0, 0);
	assert_near(r1->vx, vc, 1e-15);
	assert_near(f->res.t_end, (v0 - vc) / A + (vc - VS) / A, 1e-12);
	destroy(f);
}

/* Constant law, cushions: v_in^2 = v0^2 - 2 a s, out at kappa v_in; the
 * oblique bounce keeps the tangential component. */
static void test_const_cushion(void **state)
{
	fixture *f = make_law(PR_SIM_EVENT, 0, PR_FRICTION_CONSTANT);
	double st[2] = {0.3, 0}, hx = 0.5 - R;
	double vin = sqrt(0.04 - 2 * A * (hx - 0.3)), vout = KAPPA * vin;
	const pr_sim_trace_row *r;

	(void)state;
	assert_int_equal(shoot(f, st, 1, 0.2, 0), PR_OK);
	assert_int_equal(f->res.events, 2);
	assert_near(f->res.final[0], hx - (vout * vout - VS * VS) / (2 * A), 1e-14);
	r = row_after(f, 0, 0);
	assert_near(r->x, hx, 0);
	assert_near(r->vx, -vout, 1e-15);
	assert_near(r->t, (0.2 - vin) / A, 1e-13);
	assert_int_equal(shoot(f, st, 1, 0.2, 0.05), PR_OK);
	r = row_after(f, 0, 0);
	assert_near(r->x, hx, 0);
	assert_near(r->vx / r->vy, -KAPPA * 0.2 / 0.05, 1e-12);
	destroy(f);
}

/* Constant law, pocket entry and glancing contacts: 2R - 1e-9 hits with the
 * normal share of the contact speed, 2R + 1e-9 misses by 1e-9. */
static void test_const_pocket_glancing(void **state)
{
	fixture *f = make_law(PR_SIM_EVENT, 1, PR_FRICTION_CONSTANT);
	double st[4] = {0.3, 0.1, -0.3, -0.1}, sp = 0.25 - 0.03, ve = sqrt(0.25 - 2 * A * sp);
	double hit[4] = {-0.3, 0, 0, 2 * R - 1e-9}, miss[4] = {-0.3, 0, 0, 2 * R + 1e-9};
	double nx = sqrt((2 * R - hit[3]) * (2 * R + hit[3])) / (2 * R);
	double vc = sqrt(0.25 - 2 * A * (0.3 - 2 * R * nx));
	const pr_sim_trace_row *r;

	(void)state;
	assert_int_equal(shoot(f, st, 2, 0.4, 0.3), PR_OK);
	assert_int_equal(f->res.pocket[0], 5);
	assert_near(f->res.t_end, (0.5 - ve) / A, 1e-12);
	assert_int_equal(shoot(f, hit, 2, 0.5, 0), PR_OK);
	assert_int_equal(f->res.hit, 1);
	r = row_after(f, 1, 0);
	assert_near(hypot(r->vx, r->vy), vc * nx, 1e-9 * vc * nx);
	assert_int_equal(shoot(f, miss, 2, 0.5, 0), PR_OK);
	assert_int_equal(f->res.hit, 0);
	assert_near(f->res.final[3], miss[3], 0);
	assert_near(f->res.min_gap, 1e-9, 1e-14);
	destroy(f);
}

static void test_sample_start(void **state)
{
	fixture *f = make(PR_SIM_EVENT, 1);
	gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
	double st[10];
	int i, b;

	(void)state;
	gsl_rng_set(rng, 1);
	for (i = 0; i < 200; ++i) {
		assert_int_equal(pr_sim_sample_start(&f->t, &f->so, 5, rng, st, f->err), PR_OK);
		assert_int_equal(pr_sim_check_state(&f->t, st, 5, f->err), PR_OK);
		assert_near(st[0], -0.25, 0);
		assert_near(st[1], 0, 0);
		assert_true(st[2] >= 0.05 && st[2] <= 0.45 && st[3] >= -0.2 && st[3] <= 0.2);
		for (b = 2; b < 5; ++b) {
			assert_near(st[2 * b], 0.0, 0.485);
			assert_near(st[2 * b + 1], 0.0, 0.235);
		}
	}
	/* a reward box on the cue ball can never be drawn */
	f->so.reward_box[0] = f->so.reward_box[1] = -0.25;
	f->so.reward_box[2] = f->so.reward_box[3] = 0;
	f->so.max_tries = 10;
	assert_int_equal(pr_sim_sample_start(&f->t, &f->so, 2, rng, st, f->err), PR_EINVAL);
	assert_non_null(strstr(f->err, "10 tries"));
	gsl_rng_free(rng);
	destroy(f);
}

/* Random shots for the statistical tests: Experiment 3's start region,
 * aimed at the reward ball +-0.2 rad, speed uniform in [0.3, 1.2] m/s. */
static void random_shot(fixture *f, gsl_rng *rng, int n, double *st, double *a)
{
	double ang, v;

	f->so.reward_box[0] = 0.05;
	f->so.reward_box[1] = 0.15;
	f->so.reward_box[2] = -0.1;
	f->so.reward_box[3] = 0.1;
	assert_int_equal(pr_sim_sample_start(&f->t, &f->so, n, rng, st, f->err), PR_OK);
	ang = atan2(st[3] - st[1], st[2] - st[0]) + 0.2 * (2 * gsl_rng_uniform(rng) - 1);
	v = 0.3 + 0.9 * gsl_rng_uniform(rng);
	a[0] = v * cos(ang);
	a[1] = v * sin(ang);
}

/* Stepped mode converges to event mode at first order: halving dt halves
 * the per-shot final-position error. Per-shot errors are heavy-tailed (a
 * few shots flip a discrete outcome, a pocket or a near-grazing contact, and
 * are not yet in the asymptotic regime), so the ratio is taken of geometric
 * means (mean log error) over the shots; the arithmetic means are printed. */
static void convergence(int law)
{
	fixture *ev = make_law(PR_SIM_EVENT, 1, law), *sp[3];
	gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
	const double dts[3] = {1e-3, 5e-4, 2.5e-4};
	double lg[2] = {0, 0}, mean[3] = {0, 0, 0}, st[4], a[2], fe[4];
	int i, k, b, n = 400, used = 0;

	for (k = 0; k < 3; ++k) {
		sp[k] = make_law(PR_SIM_STEPPED, 1, law);
		sp[k]->o.dt = dts[k];
		rebuild(sp[k]);
	}
	gsl_rng_set(rng, 3);
	for (i = 0; i < n; ++i) {
		double e[3];
		random_shot(ev, rng, 2, st, a);
		assert_int_equal(pr_sim_shoot(ev->sim, st, 2, a, &ev->res, NULL, ev->err), PR_OK);
		memcpy(fe, ev->res.final, sizeof fe);
		for (k = 0; k < 3; ++k) {
			assert_int_equal(pr_sim_shoot(sp[k]->sim, st, 2, a, &sp[k]->res, NULL, sp[k]->err), PR_OK);
			e[k] = 0;
			for (b = 0; b < 2; ++b)
				e[k] += hypot(sp[k]->res.final[2 * b] - fe[2 * b], sp[k]->res.final[2 * b + 1] - fe[2 * b + 1]);
			mean[k] += e[k] / n;
		}
		if (e[0] > 0 && e[1] > 0 && e[2] > 0) { /* both pocketed alike: no error to scale */
			lg[0] += log(e[0] / e[1]);
			lg[1] += log(e[1] / e[2]);
			++used;
		}
	}
	assert_true(used >= 100);
	lg[0] = exp(lg[0] / used);
	lg[1] = exp(lg[1] / used);
	print_message("stepped vs event, law %d of %s, %d shots: error ratio dt 1->0.5 ms %.3f, "
	              "0.5->0.25 ms %.3f (arithmetic means %.3g %.3g %.3g m)\n", law, PR_FRICTION_NAMES,
	              used, lg[0], lg[1], mean[0], mean[1], mean[2]);
	assert_true(lg[0] > 1.6 && lg[0] < 2.6);
	assert_true(lg[1] > 1.6 && lg[1] < 2.6);
	gsl_rng_free(rng);
	for (k = 0; k < 3; ++k)
		destroy(sp[k]);
	destroy(ev);
}

static void test_stepped_convergence(void **state)
{
	(void)state;
	convergence(PR_FRICTION_EXPONENTIAL);
	convergence(PR_FRICTION_CONSTANT);
	convergence(PR_FRICTION_SLIDE_ROLL);
}

/* Invariants over random 5-ball shots in event mode: kinetic energy never
 * grows from one event to the next; no final overlap; no ball beyond a
 * cushion. */
static void test_invariants(void **state)
{
	fixture *f = make(PR_SIM_EVENT, 1);
	gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
	const double hx = 0.5 - R, hy = 0.25 - R;
	double st[10], a[2], v2[5];
	int i, b, c, n = 5, collisions = 0;

	(void)state;
	gsl_rng_set(rng, 4);
	for (i = 0; i < 300; ++i) {
		const pr_sim_trace_row *rows;
		double prev = HUGE_VAL, e = 0, t = 0;
		long k, len;
		random_shot(f, rng, n, st, a);
		assert_int_equal(shoot(f, st, n, a[0], a[1]), PR_OK);
		rows = pr_sim_trace_rows(f->tr);
		len = pr_sim_trace_len(f->tr);
		/* energy after all events at one time: each ball's last row there */
		for (b = 0; b < n; ++b)
			v2[b] = 0;
		for (k = 0; k <= len; ++k) {
			if (k == len || rows[k].t != t) {
				for (e = 0, b = 0; b < n; ++b)
					e += v2[b];
				assert_true(e <= prev * (1 + 1e-12) + 1e-18);
				prev = e;
				if (k == len)
					break;
				t = rows[k].t;
			}
			v2[rows[k].ball] = rows[k].vx * rows[k].vx + rows[k].vy * rows[k].vy;
		}
		collisions += f->res.hit;
		for (b = 0; b < n; ++b) {
			if (f->res.pocket[b] >= 0)
				continue;
			assert_near(f->res.final[2 * b], 0.0, hx + 1e-12);
			assert_near(f->res.final[2 * b + 1], 0.0, hy + 1e-12);
			for (c = b + 1; c < n; ++c)
				if (f->res.pocket[c] < 0)
					assert_true(hypot(f->res.final[2 * c] - f->res.final[2 * b],
					                  f->res.final[2 * c + 1] - f->res.final[2 * b + 1]) > 2 * R - 1e-9);
		}
	}
	assert_true(collisions > 50);
	gsl_rng_free(rng);
	destroy(f);
}

/* Stepped mode's fast paths (event-free windows without the tests; one
 * mover or two balls both moving in registers) run only without a trace;
 * with a trace every step takes the general phases. Both must give
 * bit-identical shots. 2 to 5 balls, so windows with one, two and more
 * movers all run. */
static void test_stepped_fast_paths(void **state)
{
	fixture *f = make(PR_SIM_STEPPED, 1);
	gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
	double st[10], a[2], fin[10], gap;
	int i, b, n, pk[5], hit, hits = 0;
	long steps;

	(void)state;
	gsl_rng_set(rng, 5);
	for (i = 0; i < 400; ++i) {
		n = 2 + i % 4;
		random_shot(f, rng, n, st, a);
		assert_int_equal(pr_sim_shoot(f->sim, st, n, a, &f->res, NULL, f->err), PR_OK);
		memcpy(fin, f->res.final, 2 * n * sizeof *fin);
		for (b = 0; b < n; ++b)
			pk[b] = f->res.pocket[b];
		hit = f->res.hit;
		gap = f->res.min_gap;
		steps = f->res.events;
		hits += hit;
		assert_int_equal(shoot(f, st, n, a[0], a[1]), PR_OK);
		for (b = 0; b < n; ++b) {
			assert_true(f->res.final[2 * b] == fin[2 * b] && f->res.final[2 * b + 1] == fin[2 * b + 1]);
			assert_int_equal(f->res.pocket[b], pk[b]);
		}
		assert_int_equal(f->res.hit, hit);
		assert_true(f->res.min_gap == gap);
		assert_int_equal(f->res.events, steps);
	}
	assert_true(hits > 50);
	gsl_rng_free(rng);
	destroy(f);
}

/* Stepped mode: the same laws, approximately (first order in dt). */
static void test_stepped_basics(void **state)
{
	fixture *f = make(PR_SIM_STEPPED, 1);
	double st[4] = {-0.2, 0, 0, 0};
	double vc = 0.1 - C * (0.2 - 2 * R);

	(void)state;
	assert_int_equal(shoot(f, st, 2, 0.1, 0), PR_OK);
	assert_int_equal(f->res.hit, 1);
	assert_near(f->res.final[2], (vc - VS) / C, 2e-4);
	assert_near(f->res.final[0], -2 * R, 2e-4);
	assert_near(f->res.t_end, f->res.events * 1e-3, 1e-12);
	assert_near(f->res.t_end, log(0.1 / VS) / C, 0.02);
	destroy(f);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_free_flight),
		cmocka_unit_test(test_max_time),
		cmocka_unit_test(test_head_on),
		cmocka_unit_test(test_cushion),
		cmocka_unit_test(test_pocket_entry),
		cmocka_unit_test(test_glancing),
		cmocka_unit_test(test_touching_overlapping),
		cmocka_unit_test(test_check_state),
		cmocka_unit_test(test_once_infinite_loop),
		cmocka_unit_test(test_max_events),
		cmocka_unit_test(test_reward),
		cmocka_unit_test(test_ghost_known),
		cmocka_unit_test(test_ghost_rate),
		cmocka_unit_test(test_sample_start),
		cmocka_unit_test(test_stepped_convergence),
		cmocka_unit_test(test_invariants),
		cmocka_unit_test(test_stepped_fast_paths),
		cmocka_unit_test(test_stepped_basics),
		cmocka_unit_test(test_const_free_flight),
		cmocka_unit_test(test_const_head_on),
		cmocka_unit_test(test_const_cushion),
		cmocka_unit_test(test_const_pocket_glancing),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
