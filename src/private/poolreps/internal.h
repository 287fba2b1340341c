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
/* 1 if key ("section.key") is in list, a comma list of whole names and of
 * sections ending in '.': "forest.,experiment.seed". */
int pr_config_key_listed(const char *list, const char *key);
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

/* Check the options; messages name "<prefix>.<key>" (prefix NULL: the bare
 * key), e.g. "forest.cuts: must be >= 1 (got 0)". */
int pr_forest_opts_check(const pr_forest_opts *o, const char *prefix, char *err);
/* Active samples, eq. 5.6: phi (n values) = Phi^T phi(x) / M, i.e. phi[i] is
 * the fraction of trees in which sample i shares an active leaf with x.
 * Returns PR_OK, PR_EINVAL (bad dq) or PR_ENOMEM. */
int pr_forest_active_samples(const pr_forest *f, const double *x, int dq, double *phi);

/* ---- beside policy.h ---- */

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

/* The dual on the returns as given (no standardisation), q normalised to
 * sum 1, plus (ridge/2)|theta|^2, at x = (log eta, theta_1..theta_d).
 * grad (d+1 values, may be NULL) receives dg/dlog eta = eta*(eps - KL) and
 * dg/dtheta = phi_hat - sum_i p_i phi_i + ridge*theta. For tests and
 * diagnostics; returns NaN for an invalid problem. */
double pr_reps_dual(const pr_reps_problem *pb, double epsilon, double ridge,
                    const double *x, double *grad);

/* ---- beside sim.h ---- */

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

#endif
