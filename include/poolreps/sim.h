/* sim.h — the 2-D pool simulator of thesis section 7.1.
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

/* table.friction_law: how a rolling ball slows. */
enum {
	PR_FRICTION_EXPONENTIAL = 0, /* v' = -c v (thesis): v(t) = v0 e^(-c t) */
	PR_FRICTION_CONSTANT = 1,    /* |v|' = -a (rolling resistance, a = mu_r g) */
	PR_FRICTION_SLIDE_ROLL = 2   /* slides at mu_s g against the slip, then rolls at mu_r g */
};
/* Their names, in that order (table.friction_law's values). */
#define PR_FRICTION_NAMES "exponential|constant|slide_roll"

/* Table geometry and physics constants (keys table.*). */
typedef struct {
	double length;        /* m, long side (x) */
	double width;         /* m, short side (y) */
	double ball_radius;   /* m, R */
	double pocket_radius; /* m */
	double restitution;   /* cushion kappa, eq. 7.4 */
	double friction;      /* c in v(t) = v0 exp(-c t), 1/s (exponential law) */
	int friction_law;     /* PR_FRICTION_* */
	double deceleration;  /* a in |v|(t) = v0 - a t, m/s^2 (constant law) */
	double mu_slide;      /* sliding friction coefficient (slide_roll law) */
	double mu_roll;       /* rolling resistance coefficient, below mu_slide (slide_roll law) */
	double stop_speed;    /* m/s; slower balls stop */
	int balls;            /* cue + reward + obstacle balls */
	int reward_balls;     /* b */
} pr_table;
void pr_sim_table_init(pr_table *t);

enum { PR_SIM_EVENT = 0, PR_SIM_STEPPED = 1 };

/* How time advances (keys sim.*). */
typedef struct {
	int mode;          /* PR_SIM_EVENT (exact) or PR_SIM_STEPPED (thesis 7.1.2) */
	double dt;         /* s, stepped mode step */
	double max_time;   /* s of simulated time */
	long max_events;   /* event mode: past this the shot fails */
	double max_speed;  /* m/s; faster actions are rejected */
	double trace_dt;   /* s, stepped mode: trace interval (events are always traced) */
} pr_sim_opts;
void pr_sim_opts_init(pr_sim_opts *o);

/* Reward, eq. 7.7 (keys reward.*). */
typedef struct {
	int ntargets;
	int targets[PR_SIM_POCKETS]; /* pocket ids */
	double miss_penalty;         /* times the smallest cue-reward gap */
	double scratch_penalty;      /* added (subtracted) when the cue ball is pocketed */
} pr_reward_opts;
void pr_sim_reward_opts_init(pr_reward_opts *o);

/* Start-state boxes of eq. 7.2 (keys start.*). */
typedef struct {
	double cue_box[4];      /* xmin, xmax, ymin, ymax */
	double reward_box[4];
	double obstacle_box[4];
	int max_tries;          /* redraws before giving up */
} pr_start_opts;
void pr_sim_start_opts_init(pr_start_opts *o);

/* Expert and scripted shots (keys ghost.*, exp1.aim_speed). */
enum { PR_GHOST_AIM_CENTRE = 0, PR_GHOST_AIM_CORRIDOR = 1 };
typedef struct {
	double arrival_speed; /* m/s at the aim point, ghost-ball expert */
	int aim;              /* ghost.aim: PR_GHOST_AIM_CENTRE or PR_GHOST_AIM_CORRIDOR */
	double aim_speed;     /* m/s, Experiment 1's aim-at-ball data policy */
} pr_expert_opts;

/* ---- Simulator --------------------------------------------------------- */

#define PR_SIM_MAX_BALLS 10000

/* A simulator: a copy of the table and options plus a workspace that grows
 * with the largest ball count seen (no allocation per shot after that).
 * Not thread-safe; use one per thread. No global mutable state. */
typedef struct pr_sim pr_sim;

/* Validates t and o (positive sizes, friction > 0, deceleration > 0, stop speed > 0, the ball
 * fits on the table, ...). Returns NULL and fills err on failure. */
pr_sim *pr_sim_new(const pr_table *t, const pr_sim_opts *o, char *err);
void pr_sim_free(pr_sim *s);

/* Outcome of one shot. final and pocket point into the pr_sim's workspace
 * and stay valid until the next pr_sim_shoot on it or pr_sim_free. */
typedef struct {
	int nballs;
	const double *final;  /* 2*nballs: final x,y; a pocketed ball's pocket centre */
	const int *pocket;    /* nballs: pocket id (0..5) or -1 */
	int hit;              /* 1 if the cue ball touched a reward ball */
	double min_gap;       /* m, smallest centre distance - 2R between the cue ball and a
	                       * reward ball over the trajectory (0 after a hit) */
	double t_end;         /* s, when the last ball stopped or fell (or sim.max_time) */
	long events;          /* event mode: events processed; stepped mode: steps */
} pr_shot;

/* A trajectory record: one row per ball at the start, at every event (event
 * mode) or every sim.trace_dt and every step with a collision (stepped mode),
 * and at the end. vx,vy are the velocities just after that moment; a
 * pocketed ball's last row is its pocket centre with zero velocity. */
typedef struct {
	double t, x, y, vx, vy;
	int ball;
} pr_sim_trace_row;
typedef struct pr_sim_trace pr_sim_trace;



/* Simulate one shot: state holds 2*nballs positions, action the cue ball's
 * initial velocity. Needs nballs >= 1 + table.reward_balls. Fills *res; if
 * trace is not NULL it is cleared and filled. Returns PR_OK, PR_EINVAL (bad
 * state or action, see the checks above), PR_ENUM (event mode: more than
 * sim.max_events events) or PR_ENOMEM. */
int pr_sim_shoot(pr_sim *s, const double *state, int nballs, const double action[2],
                 pr_shot *res, pr_sim_trace *trace, char *err);

/* Return of eq. 7.7: 0 if a reward ball fell into a target
 * pocket, else minus the smallest distance from a reward ball's final
 * position to a target pocket centre; minus miss_penalty * min_gap if the cue
 * ball touched no reward ball; minus scratch_penalty if the cue ball fell. */
double pr_sim_reward(const pr_table *t, const pr_reward_opts *o, const pr_shot *r);

/* Draw a start state (eq. 7.2): ball 0 uniform in cue_box, balls
 * 1..reward_balls in reward_box, the rest in obstacle_box; redraw the whole
 * state while pr_sim_check_state fails, at most o->max_tries times. */
int pr_sim_sample_start(const pr_table *t, const pr_start_opts *o, int nballs, gsl_rng *rng,
                        double *state, char *err);


/* Geometry of a ghost-ball shot (thesis Fig. 7.5). */
typedef struct {
	int target;        /* pocket id */
	double aim[2];     /* aim point: the target pocket's centre or corridor entry (ghost.aim) */
	double entry[2];   /* the target pocket's corridor entry, whatever the aim */
	double ghost[2];   /* cue centre at contact: r - 2R u */
	double dir[2];     /* u, unit vector reward ball -> aim point */
	double cut;        /* rad, cut angle between cue direction and u */
	double v_contact;  /* m/s, cue speed at contact */
	double v0;         /* m/s, cue speed at the start */
} pr_sim_ghost;

/* Ghost-ball expert (thesis 7.4.1): target = the target pocket
 * nearest reward ball 1 (by its centre); aim point = its centre or, with
 * e->aim = PR_GHOST_AIM_CORRIDOR, its corridor entry (pr_sim_pocket_entry,
 * as the caption of the thesis's Fig. 7.5 says); speed from v = v0 - c s
 * (exponential law) or v^2 = v0^2 - 2 a s (constant law) so that the reward
 * ball arrives at the aim point at e->arrival_speed. PR_EINVAL if the cut is 90
 * degrees or more (no contact at the ghost position) or the speed exceeds
 * o->max_speed. geom may be NULL. */
int pr_sim_ghost_action(const pr_table *t, const pr_sim_opts *o, const pr_reward_opts *ro,
                        const pr_expert_opts *e, const double *state, double action[2],
                        pr_sim_ghost *geom, char *err);

#endif
