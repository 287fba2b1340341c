/* internal.h — what the library offers the command line, its tool and the
 * tests beyond the public API (include/poolreps): option checks, the
 * configuration's file form, the experiments' seeding, the signal and
 * cleanup machinery of a command, and helpers the numeric modules share.
 * libpoolreps.so does not export these and `make install` does not install
 * this header; the poolreps executable and the tests link libpoolreps.a. */
#ifndef POOLREPS_INTERNAL_H
#define POOLREPS_INTERNAL_H

#include <stdio.h>

#include <gsl/gsl_rng.h>

#include "poolreps/common.h"
#include "poolreps/config.h"
#include "poolreps/exp.h"
#include "poolreps/forest.h"
#include "poolreps/policy.h"
#include "poolreps/reps.h"
#include "poolreps/sim.h"
#include "poolreps/learner.h"

/* ---- the configuration's layout (config.h keeps pr_config opaque) ---- */

#define PR_CONFIG_MAXKEYS 128       /* keys of the modules and every experiment */
#define PR_CONFIG_MAXBLOCKS 16      /* experiments' option blocks */
#define PR_CONFIG_OPTS_BYTES 8192   /* room for the experiments' option blocks */
#define PR_CONFIG_SOURCE_LEN 256    /* the parameter file's name */
#define PR_WHERE_LEN 320            /* pr_config_where's answer: "file:line" */

/* A list-valued key such as "10,20,50". */
typedef struct {
	int n;
	double v[PR_LIST_MAX];
} pr_list;

/* Keys experiment.*: which experiment a parameter file runs. */
typedef struct {
	char name[32];        /* a registered experiment (pr_exp_find) */
	unsigned long seed;   /* master seed; --seed overrides */
	int repetitions;      /* independent repetitions */
	int repetition;       /* -1: all; k: only repetition k (sweeps) */
	int variant;          /* -1: all; v: only variant v (sweeps; pr_exp_variants) */
	int threads;          /* repetitions run on this many threads */
} pr_run_opts;

/* An experiment's option block and per-experiment defaults (config_priv.h). */
struct pr_config_block;
struct pr_config_exp;
/* The schema: fills *out with the i-th experiment and returns 1, or returns
 * 0 past the last one. The experiments' keys follow the modules' keys, block
 * by block in this order (a block shared by several experiments once). */
typedef int (*pr_config_schema)(int i, struct pr_config_exp *out);

struct pr_config {
	pr_run_opts run;          /* experiment.* */
	pr_table table;           /* table.* */
	pr_sim_opts sim;          /* sim.* */
	pr_reward_opts reward;    /* reward.* */
	pr_start_opts start;      /* start.* */
	pr_expert_opts expert;    /* ghost.* */
	pr_forest_opts forest;    /* forest.* (the forest command) */
	pr_reps_opts reps;        /* reps.* */
	pr_policy_opts policy;    /* policy.* */
	pr_forest_opts value;     /* value.*: forests for REPS value features */
	int value_features;       /* value.features: PR_VALUE_* */
	pr_learner_opts learner;  /* learner.* (its value, reps and policy parts unused) */
	/* the experiments' option blocks, read through pr_config_opts */
	pr_config_schema schema;
	int nblocks;
	const struct pr_config_block *block[PR_CONFIG_MAXBLOCKS];
	size_t block_off[PR_CONFIG_MAXBLOCKS];
	int dropped;              /* blocks that did not fit: pr_config_validate fails */
	union {
		max_align_t align;
		unsigned char bytes[PR_CONFIG_OPTS_BYTES];
	} opts;
	char source[PR_CONFIG_SOURCE_LEN]; /* the parameter file, or "" */
	int key_line[PR_CONFIG_MAXKEYS]; /* per key: file line, -1 for --set, 0 default;
	                                  * keys left at 0 follow experiment.name */
};

/* Defaults of the modules and of every experiment of schema. */
void pr_config_init(pr_config *c, pr_config_schema schema);
/* The registry as the schema of pr_config_init: every pr_config of the CLI
 * is made with pr_config_init(&c, pr_exp_config). */
int pr_exp_config(int i, struct pr_config_exp *out);

/* ---- beside common.h ---- */

/* Escape s as pr_err does into out (size n >= 1). */
void pr_escape(const char *s, char *out, size_t n);
/* The exit code main() uses for a status: 0, 1, 2, 3, 4, or 128 + the
 * signal recorded in pr_interrupted for PR_EINTR (130 when none is). */
int pr_exit_code(int status);
/* ---- for a program's signal handler (the CLI's) ----
 * The fatal signals the CLI handles: SIGINT, SIGTERM, SIGHUP, SIGQUIT,
 * SIGPIPE, SIGXFSZ, SIGXCPU, SIGUSR1, SIGUSR2, SIGALRM, SIGVTALRM, SIGPOLL,
 * SIGPWR, SIGSTKFLT (every one whose default ends the process, but the
 * faults of a bug); terminated by 0. */
extern const int pr_fatal_signals[];
/* Remove every temporary file and staging folder the library has
 * registered, with async-signal-safe calls only. */
void pr_cleanup_run(void);
/* Set when a command's outputs are all in place (its commit point): a
 * signal after it no longer means that nothing was written. */
extern volatile sig_atomic_t pr_committed;

/* ---- beside config.h ---- */

void pr_run_opts_init(pr_run_opts *o);
/* The option block b of c (a registered experiment's), or NULL. */
const void *pr_config_opts(const pr_config *c, const struct pr_config_block *b);
/* Where key "section.key" got its value, for messages: "file:line", "--set",
 * or for a default the parameter file (or "defaults"). Returns buf. */
const char *pr_config_where(const pr_config *c, const char *key, char *buf, size_t n);
/* The first key (in table order, other than those in skip, a NULL-ended
 * list of "section.key" names, or NULL) whose value differs between a and b:
 * its name into key and both values as written by pr_config_write into va
 * and vb (each n bytes, truncated). 0 if none, -1 if out of memory. */
int pr_config_diff(const pr_config *a, const pr_config *b, const char *const *skip, char *key,
                   size_t nkey, char *va, char *vb, size_t n);
/* Write every key as INI (the effective configuration); the other friction
 * law's parameter (table.deceleration under the exponential law, table.friction
 * under the constant one) as a comment, since read back it would clash with
 * table.friction_law. */
int pr_config_write(const pr_config *c, FILE *fp);
/* List the keys of schema with default, unit and range: every key, or only
 * those in the list `only` (as pr_config_key_listed reads it). */
void pr_config_help(pr_config_schema schema, const char *only, FILE *fp);
/* 1 if "section.key" is a key of another experiment's block than the one
 * experiment.name of c names (that experiment never reads it). */
int pr_config_key_elsewhere(const pr_config *c, const char *key);
/* The index of number key "section.key" for pr_config_set_number, or a
 * negative status and err for an unknown key or one that is not a number. */
int pr_config_number_key(const pr_config *c, const char *name, char *err);
/* Sets number key i to v with --set's checks of that key (finite, in
 * range; pr_config_validate's checks across keys are the caller's), as if
 * set by --set: the same bits as "--set section.key=V" for any text V that
 * reads as v. */
int pr_config_set_number(pr_config *c, int i, double v, char *err);

/* ---- beside exp.h ---- */

/* A gsl_rng (mt19937) seeded from (seed, stream, index) by a hash, so that
 * every repetition and purpose has its own reproducible stream. Caller frees. */
gsl_rng *pr_exp_rng(unsigned long seed, unsigned long stream, unsigned long index);
/* The repetitions [*lo, *hi) this process runs (experiment.repetition). */
void pr_exp_reps(const pr_config *cfg, int *lo, int *hi);
/* The variants of cfg's experiment (n = 0 for one without); PR_EINVAL naming
 * experiment.variant when it is set but not below their count. */
int pr_exp_variants(const pr_config *cfg, pr_variants *out, char *err);
/* The i-th experiment of the registry (in its order), or NULL past the last. */
const pr_experiment *pr_exp_at(int i);
/* PR_EINVAL naming experiment.variant unless it is -1 or below n. */
int pr_exp_check_variant(const pr_config *cfg, int n, char *err);

/* ---- beside forest.h ---- */
/* Forest prediction, eq. 4.2-4.3: y (dy values) = mean over trees of leaf means. */
void pr_forest_predict(const pr_forest *f, const double *x, double *y);
/* Nodes of all trees in preorder; tree t's root is node pr_forest_tree_node0(f, t).
 * pr_forest_node gives an internal node's test [x_dim < thr] and its right
 * child (the left child is node + 1), or for a leaf dim = -1, thr = 0 and
 * right = its global leaf id. Returns PR_OK or PR_EINVAL for a bad node. */
int pr_forest_nnodes(const pr_forest *f);
int pr_forest_tree_node0(const pr_forest *f, int t);
int pr_forest_node(const pr_forest *f, int node, int *dim, double *thr, int *right);
/* Weights a user gives (`forest --weight`, the Python forest), in place:
 * w_i / max w rounded to 24 significant bits (6e-8 of each weight). The same
 * column times any factor (1e-170, 1e160) then gives the same weights bit
 * for bit, so the same trees and leaf means, except where the factor's
 * rounding moves a weight across a rounding edge of the 24 bits (about 1
 * weight in 2^25). Weights pr_forest_fit refuses (negative, not finite,
 * all 0): left as they are. */
void pr_forest_weights_canonical(double *w, int n);

/* The most trees M and random tests K a forest takes (the keys' ranges). */
#define PR_FOREST_MAX_TREES 10000
#define PR_FOREST_MAX_CUTS 10000
/* Check the options; messages name "<prefix>.<key>" (prefix NULL: the bare
 * key), e.g. "forest.cuts: must be >= 1 (got 0)". */
int pr_forest_opts_check(const pr_forest_opts *o, const char *prefix, char *err);
/* Active samples, eq. 5.6: phi (n values) = Phi^T phi(x) / M, i.e. phi[i] is
 * the fraction of trees in which sample i shares an active leaf with x.
 * Returns PR_OK, PR_EINVAL (bad dq) or PR_ENOMEM. */
int pr_forest_active_samples(const pr_forest *f, const double *x, int dq, double *phi);

/* ---- beside policy.h ---- */
/* The tree policy's forest (NULL for the other kinds); owned by the policy. */
const pr_forest *pr_policy_forest(const pr_policy *p);

/* Check the options; messages name policy.<key>. */
int pr_policy_opts_check(const pr_policy_opts *o, char *err);
/* Number of features of a kind for ds state dimensions, or -1. */
int pr_policy_features_count(int kind, int ds);
/* Fill psi (pr_policy_features_count values) for state s. */
void pr_policy_features(int kind, const double *s, int ds, double *psi);
/* The quadratic features, [1, s, s_j s_k (j <= k)]. */
void pr_policy_features_quadratic(const double *s, int ds, double *psi);
/* A linear (or Gaussian: nf = 1) policy's W (da x nf, for the features of s
 * itself: a fit's W psi(s - c) is expanded to W' psi(s)) and covariance (da x
 * da, after the floor), copied into caller buffers (either may be NULL).
 * PR_EINVAL for a tree policy. */
int pr_policy_linear_params(const pr_policy *p, double *W, double *cov, char *err);
/* Gaussian helpers on a mean and covariance from pr_policy_eval. */
int pr_policy_gauss_sample(int da, const double *mean, const double *cov, int k,
                           gsl_rng *rng, double *a, char *err);
int pr_policy_gauss_logpdf(int da, const double *mean, const double *cov,
                           const double *a, double *logpdf, char *err);

/* ---- beside reps.h ---- */
/* Importance weights for sample reuse: a window of n samples
 * drawn by npol past policies, counts[k] of them by policy k (sum = n).
 * logpi is npol x n row-major: logpi[k*n + i] = log pi_k(a_i | s_i); logcur
 * (n) holds log pi_current(a_i | s_i). In log space,
 *   log r_i = logcur_i - log sum_k (counts[k]/n) pi_k(a_i|s_i),
 * q_i = r_i / sum_j r_j. Writes q (n, sum 1), logratio (n, may be NULL) and
 * *ess = 1 / sum q_i^2 (may be NULL). Counts of 0 are allowed. */
int pr_reps_importance(int npol, int n, const double *logpi, const int *counts,
                       const double *logcur, double *q, double *logratio,
                       double *ess, char *err);

/* The dual on the returns as given (no standardisation), q normalised to
 * sum 1, plus (ridge/2)|theta|^2, at x = (log eta, theta_1..theta_d).
 * grad (d+1 values, may be NULL) receives dg/dlog eta = eta*(eps - KL) and
 * dg/dtheta = phi_hat - sum_i p_i phi_i + ridge*theta. For tests and
 * diagnostics; returns NaN for an invalid problem. */
double pr_reps_dual(const pr_reps_problem *pb, double epsilon, double ridge,
                    const double *x, double *grad);

/* ---- beside sim.h ---- */
pr_sim_trace *pr_sim_trace_new(char *err);
void pr_sim_trace_free(pr_sim_trace *tr);
long pr_sim_trace_len(const pr_sim_trace *tr);
/* The rows, owned by tr, valid until its next use or free. */
const pr_sim_trace_row *pr_sim_trace_rows(const pr_sim_trace *tr);
/* Experiment 1's data policy: the cue ball aimed at reward ball 1's centre
 * at e->aim_speed. */
int pr_sim_aim_action(const pr_expert_opts *e, const double *state, double action[2], char *err);
/* Pocket centre of pocket id (0..5): 0-2 along y = -W/2 from x = -L/2, 3-5 along y = +W/2. */
void pr_sim_pocket_xy(const pr_table *t, int id, double xy[2]);
/* PR_OK if nballs is in 1..PR_SIM_MAX_BALLS and every ball is finite, on the
 * table (centre at least R from every cushion line, 1e-12 m slack), outside
 * every pocket (centre farther than the pocket radius) and not overlapping
 * another (centre distance at least 2R, 1e-12 m slack); else PR_EINVAL and a
 * message naming the ball(s). */
int pr_sim_check_state(const pr_table *t, const double *state, int nballs, char *err);

void pr_sim_expert_opts_init(pr_expert_opts *o);
/* PR_OK if the action is finite and no faster than o->max_speed. */
int pr_sim_check_action(const pr_sim_opts *o, const double action[2], char *err);
/* Centre of the entry of pocket id's corridor. The corridor is the part of
 * the pocket's capture disc (radius pocket_radius) that a ball centre can
 * reach without touching a cushion, |x| <= L/2 - R, |y| <= W/2 - R; a ball
 * entering the pocket crosses the disc's boundary arc inside that region,
 * and the arc's midpoint is the pocket centre + pocket_radius times the unit
 * vector pointing from the pocket into the table ((-+1,-+1)/sqrt 2 at a
 * corner, (0,-+1) at a middle pocket). PR_EINVAL when the arc is empty
 * (pocket_radius <= R sqrt 2 at a corner, <= R at the middle): no ball can
 * enter; xy is filled either way. */
int pr_sim_pocket_entry(const pr_table *t, int id, double xy[2], char *err);

/* ---- beside learner.h ---- */
/* Draw from rng from now on (borrowed as in pr_learner_new). */
void pr_learner_set_rng(pr_learner *L, gsl_rng *rng);
/* pi_0 = p (dx states, da actions) instead of N(0, init_std^2 I), before
 * the first tell. The learner owns p from this call on, whether it succeeds
 * or not. A learner with such a pi_0 is not saved while pi_0 is live. */
int pr_learner_set_policy(pr_learner *L, pr_policy *p, char *err);
/* Other options before the first tell (after an ask, with the same
 * policy.cov_center, max_norm and truncation). */
int pr_learner_set_options(pr_learner *L, const pr_learner_opts *o, char *err);
/* A state's first bytes: the magic and the format version. */
#define PR_LEARNER_HEAD_LEN 21
/* PR_OK when the first len bytes of buf (PR_LEARNER_HEAD_LEN suffice)
 * begin a state this library reads; else PR_EIO (not a state, or
 * truncated) or PR_EINVAL (another format version), the message naming
 * what. Lets a reader refuse a foreign file before reading all of it. */
int pr_learner_check_head(const unsigned char *buf, size_t len, const char *what, char *err);
/* What the last ask did: actions drawn again (or clipped) for exceeding
 * max_norm, and the PR_POLICY_* flags of its queries. */
void pr_learner_ask_info(const pr_learner *L, int *redraws, int *flags);
/* PR_OK unless targets are given (given != 0) to a learner whose policy
 * would keep and ignore them; for callers that take them from a user
 * (an experiment passes them whatever the policy). */
int pr_learner_check_targets(const pr_learner *L, int given, char *err);
/* The row of the contexts (ask, mean) or episodes (tell) whose policy
 * evaluation failed the last such call, or -1 (success, or not a row's). */
int pr_learner_bad_row(const pr_learner *L);
/* A tell's episodes in full: n rows of contexts (n x dx), actions (n x
 * da) and returns; features (n x d) for value given, else NULL; targets (n
 * x dy) for policy.target = reward_state (the tree policy's forest predicts
 * them instead of the actions), else NULL (dy fixed by the first tell);
 * logq (n), log-density of each action under the distribution that drew
 * it, or NULL: from the current policy (or from the last ask). */
typedef struct {
	int n, d, dy;
	const double *contexts, *actions, *returns, *features, *targets, *logq;
} pr_learner_batch;
int pr_learner_tell_batch(pr_learner *L, const pr_learner_batch *b, char *err);
/* Names of the dx context then da action columns, kept in the saved
 * state for the caller (the command line's CSV columns); each 1 .. 255
 * bytes without a control character or a trailing blank (a CSV
 * header could not hold it), all distinct. A NULL name (or NULL
 * names) is the default s0 .. s{dx-1}, a0 .. a{da-1}, which every new
 * learner (and one loaded from a state without names) has. */
int pr_learner_set_names(pr_learner *L, const char *const *names, char *err);
const char *const *pr_learner_names(const pr_learner *L);
/* The current policy (the one ask draws from); valid until the next tell. */
const pr_policy *pr_learner_policy(const pr_learner *L);
const pr_learner_opts *pr_learner_options(const pr_learner *L);
/* log P(|a| <= vmax) for a ~ N(mean, cov), 2-D (truncation corrected): 0
 * when the disc holds the Gaussian's 8-sigma ellipse, else quadrature over
 * the directions of the whitened Gaussian, -HUGE_VAL if it holds none. */
double pr_learner_disc_logmass(const double mean[2], const double cov[4], double vmax);
/* Check the options; messages name the key (learner.window, reps.epsilon ...). */
int pr_learner_opts_check(const pr_learner_opts *o, char *err);

#endif
