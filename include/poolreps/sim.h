/* sim.h — the 2-D pool simulator of thesis section 7.1 (SPEC.md §1–3).
 *
 * Coordinates in metres, origin at the table centre, x along the long side.
 * Ball 0 is the cue ball, balls 1..reward_balls the reward balls, the rest
 * obstacles. A state is (x0,y0,x1,y1,...); an action is the cue ball's
 * initial velocity (vx,vy) in m/s.
 */
#ifndef POOLREPS_SIM_H
#define POOLREPS_SIM_H

#include <gsl/gsl_rng.h>
#include "poolreps/common.h"

#define PR_SIM_POCKETS 6

/* Table geometry and physics constants (keys table.*). */
typedef struct {
	double length;        /* m, long side (x) */
	double width;         /* m, short side (y) */
	double ball_radius;   /* m, R */
	double pocket_radius; /* m */
	double restitution;   /* cushion kappa, eq. 7.4 */
	double friction;      /* c in v(t) = v0 exp(-c t), 1/s */
	double stop_speed;    /* m/s; slower balls stop */
	int balls;            /* cue + reward + obstacle balls */
	int reward_balls;     /* b */
} pr_table;
void pr_table_init(pr_table *t);

enum { PR_SIM_EVENT = 0, PR_SIM_STEPPED = 1 };

/* How time advances (keys sim.*). */
typedef struct {
	int mode;          /* PR_SIM_EVENT (exact) or PR_SIM_STEPPED (thesis 7.1.2) */
	double dt;         /* s, stepped mode step */
	double max_time;   /* s of simulated time */
	long max_events;   /* event mode: past this the shot fails */
	double max_speed;  /* m/s; faster actions are rejected */
} pr_sim_opts;
void pr_sim_opts_init(pr_sim_opts *o);

/* Reward of SPEC.md §2, eq. 7.7 (keys reward.*). */
typedef struct {
	int ntargets;
	int targets[PR_SIM_POCKETS]; /* pocket ids */
	double miss_penalty;         /* times the smallest cue-reward gap */
	double scratch_penalty;      /* added (subtracted) when the cue ball is pocketed */
} pr_reward_opts;
void pr_reward_opts_init(pr_reward_opts *o);

/* Start-state boxes of eq. 7.2 (keys start.*). */
typedef struct {
	double cue_box[4];      /* xmin, xmax, ymin, ymax */
	double reward_box[4];
	double obstacle_box[4];
	int max_tries;          /* redraws before giving up */
} pr_start_opts;
void pr_start_opts_init(pr_start_opts *o);

/* Expert and scripted shots (keys ghost.*, exp1.aim_speed). */
typedef struct {
	double arrival_speed; /* m/s at the aim point, ghost-ball expert */
	double aim_speed;     /* m/s, Experiment 1's aim-at-ball data policy */
} pr_expert_opts;
void pr_expert_opts_init(pr_expert_opts *o);

#endif
