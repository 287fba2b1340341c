/* exp3_priv.h — Experiment 3 (thesis 7.5) inside the library: its options,
 * its variants, the REPS learner of one (repetition, variant) pair
 * (exp3_learn.c) and the raw writers and summaries (exp3_out.c). Another
 * experiment may reuse the learner: create one with its own options and
 * random streams, seed it with episodes or an initial policy, run REPS
 * iterations and read back what happened.
 *
 * A learner (thesis 7.5.1):
 *   iteration 0: n0 episodes, drawn from pi_0 (N(0, init_std^2 I) or a given
 *     policy), or given by the caller;
 *   iteration t = 1..iterations:
 *     window = the latest `window` episodes, drawn by pi_pmin .. pi_{t-1};
 *     q      = importance weights pi_{t-1} / pi_mix, pi_mix the sample-count
 *              mixture of the drawing policies;
 *     phi    = value features of the window states: a forest states ->
 *              returns, active leaves (eq. 5.4) or active samples (eq. 5.6);
 *              quadratic features for the `handcrafted` variant;
 *     p      = REPS weights with base weights q (eq. 3.7-3.8);
 *     pi_t   = a policy fitted to the window with weights p (ch. 6);
 *     then `samples` new episodes from pi_t.
 * The learner sees only the state coordinates that vary (those whose start
 * box has extent); the episodes keep the full state. */
#ifndef POOLREPS_EXP3_PRIV_H
#define POOLREPS_EXP3_PRIV_H

#include <gsl/gsl_rng.h>

#include "poolreps/config.h"
#include "poolreps/csvio.h"
#include "poolreps/policy.h"
#include "exp_priv.h"

/* Keys exp3.*. */
typedef struct {
	int init_samples;      /* samples of the initial policy */
	double init_std;       /* initial policy N(0, init_std^2 I), m/s */
	int iterations;        /* REPS iterations */
	int samples;           /* new samples per iteration */
	int window;            /* samples REPS reuses, importance weighted */
	char policies[PR_KEY_NAMES_LEN]; /* comma list of variants */
	int baseline_n_min;    /* n_min of the single-node baseline policy */
	int final_episodes;    /* Figs. 7.8-7.10 use each run's last episodes */
	int handcrafted_method; /* PR_METHOD_*: the hand-crafted variant's learner */
	int state;             /* PR_EXP3_STATE_*: the learner's state coordinates */
	int truncation;        /* PR_EXP3_TRUNC_*: actions faster than sim.max_speed */
	int mean_eval;         /* start states the mean action is evaluated on (0: none) */
	int mean_eval_every;   /* ... whenever a run's episodes are a multiple of this */
	unsigned long mean_eval_seed; /* repetition k's states: mt19937 set to this + k */
} pr_exp3_opts;
/* exp3.state: the coordinates whose start box has extent (the cue ball's is a
 * point), or every ball's position as in eq. 7.1 (4-D with two balls). */
enum { PR_EXP3_STATE_VARYING = 0, PR_EXP3_STATE_FULL = 1 };
/* exp3.truncation: an action drawn faster than sim.max_speed is drawn again
 * with the untruncated densities in the importance weights (redraw), scaled
 * onto the limit and shot (clip), or drawn again with each density divided by
 * the policy's mass inside the limit, P(|a| <= max_speed | s) (corrected). */
enum { PR_EXP3_TRUNC_REDRAW = 0, PR_EXP3_TRUNC_CLIP = 1, PR_EXP3_TRUNC_CORRECTED = 2 };
void pr_exp3_opts_init(pr_exp3_opts *o);
/* cfg's exp3.* options. */
const pr_exp3_opts *pr_exp3_opts_of(const pr_config *cfg);

/* The variants: value features and policy fit of a learner. */
enum {
	PR_EXP3_NRVR_RS,     /* NRVR value forest; policy forest states -> reward-ball positions */
	PR_EXP3_RVR_RS,      /* RVR value forest; same policy */
	PR_EXP3_NRVR_A,      /* NRVR value forest; policy forest states -> actions */
	PR_EXP3_RVR_A,       /* RVR value forest; same policy */
	PR_EXP3_BASELINE,    /* value forest at value.*; one-node policy (exp3.baseline_n_min) */
	PR_EXP3_HANDCRAFTED, /* quadratic value features; linear policy, or C-CMA-ES */
	PR_EXP3_NVAR
};
extern const char *const pr_exp3_variant_name[PR_EXP3_NVAR];
/* The variants this process runs, in exp3.policies order: all of them, or
 * the one experiment.variant picks. */
int pr_exp3_selected(const pr_config *cfg, int *var, int *nvar, char *err);

/* ---- the learner (exp3_learn.c) ---- */

/* REPS and policy diagnostics of iteration t (a row of exp3_reps.csv). */
typedef struct {
	double eta, kl, ess, q_ess, residual, kl_gap, residual_rel;
	int bound;     /* the KL bound is active */
	int nfeat;     /* value features */
	int evals;     /* dual evaluations */
	int redraws;   /* actions drawn again for exceeding sim.max_speed */
	int flags;     /* PR_POLICY_* of the fit and the queries, or-ed */
	int status;    /* PR_REPS_* */
} pr_exp3_iter;

/* A learner's episodes in the order they were played, and its iterations. */
typedef struct {
	int n;             /* episodes so far */
	int ds;            /* full state: 2 x table.balls */
	double *S;         /* n x ds start states */
	double *A;         /* n x 2 actions */
	double *R;         /* n returns */
	double *F;         /* n x 2 final position of reward ball 1 */
	int *pocket;       /* n: reward ball 1's pocket id or -1 */
	int *hit;          /* n: the cue ball touched a reward ball */
	int *iter;         /* n: 0 = iteration 0; episodes of iteration t were drawn by pi_t */
	int niter;         /* iterations done */
	pr_exp3_iter *it;  /* niter rows: it[t - 1] describes iteration t */
} pr_exp3_episodes;
void pr_exp3_episodes_free(pr_exp3_episodes *ep);

typedef struct pr_exp3_learner pr_exp3_learner;

/* Everything a learner needs but cannot check itself once running: one
 * reward ball, a window of >= 2 episodes, at most 1e8 episodes, varying
 * start states, valid value.* and policy.* options. Errors name the key. */
int pr_exp3_learner_check(const pr_config *cfg, const pr_exp3_opts *e, char *err);

/* A learner of variant v (PR_EXP3_*) with cfg's table, sim, reward, start,
 * value, reps and policy options and e's init_samples, init_std,
 * iterations, samples, window, baseline_n_min and handcrafted_method. It
 * draws start states from `start`, pi_0's actions from `init`, forests and
 * later actions from `learn`; it borrows them (the caller frees them after
 * pr_exp3_learner_free). cfg and e must outlive it. *out is NULL on failure. */
int pr_exp3_learner_new(const pr_config *cfg, const pr_exp3_opts *e, int v, gsl_rng *start,
                        gsl_rng *init, gsl_rng *learn, pr_exp3_learner **out, char *err);
void pr_exp3_learner_free(pr_exp3_learner *L);

/* pi_0 = p instead of N(0, init_std^2 I): a policy on the learning state
 * (pr_exp3_learner_state_dims) with 2 action dimensions. The learner owns p
 * from this call on, whether it succeeds or not. Before iteration 0 only;
 * refused for the C-CMA-ES hand-crafted learner, whose search starts from
 * N(0, init_std^2 I). */
int pr_exp3_learner_set_policy(pr_exp3_learner *L, pr_policy *p, char *err);

/* Iteration 0 from n given episodes instead of init_samples drawn ones:
 * full start states S (n x ds), actions A (n x 2), returns R, final
 * reward-ball positions F (n x 2), pockets and hits (each NULL: -1 and 0)
 * and logq, the log-density of each action under the distribution that drew
 * it (NULL: computed from pi_0). The episodes count as pi_0's: the mixture
 * of later importance weights evaluates pi_0 (set_policy, or N(0,
 * init_std^2 I)) at later episodes, so give the policy that drew them. */
int pr_exp3_learner_seed(pr_exp3_learner *L, int n, const double *S, const double *A,
                         const double *R, const double *F, const int *pocket, const int *hit,
                         const double *logq, char *err);

/* Iteration 0: init_samples episodes drawn from pi_0 (nothing to do after
 * pr_exp3_learner_seed). */
int pr_exp3_learner_start(pr_exp3_learner *L, char *err);

/* The next REPS iteration (at most e->iterations after iteration 0). */
int pr_exp3_learner_iterate(pr_exp3_learner *L, char *err);

/* The next iteration without REPS: `samples` new episodes drawn from pi_0
 * with `learn` (their iteration number is the iteration's); its row holds
 * only redraws and flags. A learner either repeats or runs REPS, never
 * both. Refused for the C-CMA-ES hand-crafted learner. */
int pr_exp3_learner_repeat(pr_exp3_learner *L, char *err);

/* Controls (Experiment 4), before iteration 1, not for C-CMA-ES: refit =
 * 1 skips REPS, so pi_t is fitted to the window with the importance
 * weights q alone (a refit of pi_{t-1} on its own samples); n_min > 0 fits
 * the tree-LWR policies (not the baseline, not hand-crafted) with that
 * forest n_min instead of policy.n_min. */
int pr_exp3_learner_set_control(pr_exp3_learner *L, int refit, int n_min, char *err);

/* The policy that drew the latest iteration: pi_t after REPS iteration t,
 * pi_0 after iteration 0 or repeats. Valid until the next call on L. */
const pr_policy *pr_exp3_learner_policy(const pr_exp3_learner *L);

/* The latest policy's mean action (scaled down to sim.max_speed, no
 * sampling) shot from n start states drawn from `states`: the sum of the
 * returns (in draw order), the shots that sink reward ball 1 in a target
 * pocket and the hits, the summary Experiments 3 and 4 both report. */
int pr_exp3_learner_mean_eval(pr_exp3_learner *L, int n, gsl_rng *states, double *sum,
                              int *in, int *hits, char *err);

/* The learning state: nx coordinates of the full state (indices xdim). */
int pr_exp3_learner_state_dims(const pr_exp3_learner *L, const int **xdim);

/* What the learner did so far; valid until the next call on L. */
const pr_exp3_episodes *pr_exp3_learner_episodes(const pr_exp3_learner *L);

/* Move the episodes out into *out (the caller frees them with
 * pr_exp3_episodes_free); the learner then has none. */
void pr_exp3_learner_take(pr_exp3_learner *L, pr_exp3_episodes *out);

/* ---- outputs (exp3_out.c) ---- */

/* One learner's episodes with its repetition and variant, and its mean-action
 * evaluations (exp3.mean_eval > 0): nmean rows of (episodes so far, mean
 * return, pocket rate). */
typedef struct {
	int repetition, variant;
	pr_exp3_episodes ep;
	int nmean;
	int *mean_eps;
	double *mean_ret, *mean_pocket;
} pr_exp3_job;

/* Raw dir/exp3_episodes.csv and dir/exp3_reps.csv of runs in order, and
 * dir/exp3_mean.csv when exp3.mean_eval > 0. */
int pr_exp3_write_raw(const pr_config *cfg, const pr_exp3_job *runs, int nruns, const char *dir,
                      char *err);

/* The columns of a raw row after its labels, for experiments that reuse the
 * learner: episode i (iteration, start state, action, return, final
 * reward-ball position, pocket, hit; ends the row), or one iteration's
 * diagnostics (PR_EXP3_ITER_COLUMNS; ends the row). Nonzero: a write failed. */
int pr_exp3_write_episode(pr_csvw *w, const pr_exp3_episodes *o, int i);
/* The state column names x0,y0,x1,y1,... of nballs balls (no row end). */
int pr_exp3_write_state_names(pr_csvw *w, int nballs);
/* The header of an episodes file: repetition, policy (the run's label),
 * then the columns pr_exp3_write_episode writes; ends the row. */
int pr_exp3_write_episode_header(pr_csvw *w, int nballs);
#define PR_EXP3_ITER_COLUMNS "eta,kl,ess,bound,residual,q_ess,features,dual_evals,redraws," \
	"policy_flags,kl_gap,residual_rel,status"
int pr_exp3_write_iter(pr_csvw *w, const pr_exp3_iter *r);

/* The runs of a raw episodes / reps pair written with the columns above:
 * files dir/<prefix>_episodes.csv and dir/<prefix>_reps.csv, runs labelled
 * name[0..n) (the policy column, in output order; `key` is the key that
 * lists them, for errors), n0[v] episodes in iteration 0 of run v. */
typedef struct {
	const char *prefix, *key;
	int n;
	const char (*name)[32];
	const int *n0;
} pr_exp3_labels;
/* Experiment 3's summaries of such a pair: <prefix>_curve.csv,
 * _final.csv, _pockets.csv, _dist.csv and _reps_summary.csv. */
int pr_exp3_summaries(const pr_config *cfg, const pr_exp3_labels *lb, const char *dir, char *err);

/* 1 if pocket is one of reward.targets. */
int pr_exp3_is_target(const pr_reward_opts *ro, int pocket);
/* Distance of the final reward-ball position to the nearest target pocket
 * (0 when it fell into one): the distance term of eq. 7.7. */
double pr_exp3_target_distance(const pr_config *cfg, int pocket, double rx, double ry);

#endif
