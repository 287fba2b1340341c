/* bind.h — flat entry points for foreign-function interfaces (the Python
 * package python/poolreps calls them through ctypes).
 *
 * Every argument is a pointer to a row-major array, an integer, a double or
 * an opaque handle, so a binding needs no copy of any struct layout. Options
 * live in a heap pr_config that the binding fills key by key with
 * pr_config_set and checks with pr_config_validate, exactly as the CLI does
 * with --set; each call below then does what the matching CLI command does,
 * seeded the same way (a GSL mt19937 set to experiment.seed), so its numbers
 * equal the command's bit for bit.
 *
 * Functions that can fail return PR_OK or a PR_E* status and fill err
 * (PR_ERRLEN bytes). Nothing here keeps state between calls: handles may be
 * used from several threads at once, except that a gsl_rng must not be
 * shared.
 */
#ifndef POOLREPS_BIND_H
#define POOLREPS_BIND_H

#include <gsl/gsl_rng.h>
#include "poolreps/common.h"
#include "poolreps/config.h"
#include "poolreps/forest.h"
#include "poolreps/learner.h"
#include "poolreps/policy.h"
#include "poolreps/reps.h"

/* Once per process, before anything else: switches GSL's abort-on-error
 * handler off (the library checks every GSL status itself; main() does the
 * same for the CLI). Returns the library version string. */
const char *pr_bind_init(void);

/* The effective configuration as INI text (pr_config_write), NUL-terminated;
 * free it with pr_bind_free. NULL and err on failure. */
char *pr_bind_config_ini(const pr_config *c, char *err);
void pr_bind_free(void *p);

/* `poolreps shoot` on n rows: balls is n x 2*nballs (x0,y0,x1,y1,...),
 * actions n x 2. Outputs per row: final (2*nballs), pocket (nballs; id or
 * -1), hit (0/1), min_gap, reward (eq. 7.7), t_end, events. An invalid row
 * stops the batch with "row I: <the simulator's message>" (rows from 0). */
int pr_bind_shoot(const pr_config *c, long n, int nballs, const double *balls,
                  const double *actions, double *final, int *pocket, unsigned char *hit,
                  double *min_gap, double *reward, double *t_end, long *events, char *err);

/* The same for rows lo .. hi - 1 of those arrays (messages number rows
 * from 0 of the whole arrays): a binding shoots a long batch in pieces. */
int pr_bind_shoot_range(const pr_config *c, long lo, long hi, int nballs, const double *balls,
                        const double *actions, double *final, int *pocket, unsigned char *hit,
                        double *min_gap, double *reward, double *t_end, long *events, char *err);

/* The same with per-row parameters (shotparams.h): values is n x nkeys,
 * row r's values for keys[0..nkeys-1] (number keys of table., sim. and
 * reward.); row r is shot as with --set KEY=VALUE for each, bit for bit,
 * and a value --set refuses stops the batch with "row R: <message>" (the
 * first such row). The rows are split into contiguous parts on up to
 * threads threads (0: one per CPU; at least 64 rows a thread), each with
 * its own simulator: every output byte is the same whatever the count. */
int pr_bind_shoot_params(const pr_config *c, long lo, long hi, int nballs, const double *balls,
                         const double *actions, int nkeys, const char *const *keys,
                         const double *values, double *final, int *pocket, unsigned char *hit,
                         double *min_gap, double *reward, double *t_end, long *events,
                         int threads, char *err);

/* pr_sim_check_state on the configuration's table. */
int pr_bind_check_state(const pr_config *c, const double *state, int nballs, char *err);
/* n start states of table.balls balls each (eq. 7.2, keys start.*), drawn
 * from rng; states is n x 2*table.balls. */
int pr_bind_starts(const pr_config *c, gsl_rng *rng, long n, double *states, char *err);
/* One start state from each of the n generators rngs[i] into row i of
 * states (a vector environment: one stream per sub-environment). */
int pr_bind_starts_each(const pr_config *c, gsl_rng *const *rngs, long n, double *states,
                        char *err);
/* k uniform draws in [0, 1) from each of the n generators rngs[i] into
 * row i of u (n x k): per-episode parameters of a vector environment. */
void pr_bind_uniforms_each(gsl_rng *const *rngs, long n, int k, double *u);
/* A GSL mt19937 set to seed (NULL when out of memory). */
gsl_rng *pr_bind_rng_new(unsigned long seed);
void pr_bind_rng_free(gsl_rng *rng);
/* A generator's state, pr_bind_rng_size bytes at pr_bind_rng_state: copied
 * out and back, the generator continues exactly (pickling an environment). */
size_t pr_bind_rng_size(const gsl_rng *rng);
void *pr_bind_rng_state(gsl_rng *rng);

/* Experiment 3's start-state generator of repetition k for experiment.seed
 * seed: its n-th draw (pr_bind_starts) is the start state of the run's n-th
 * episode. NULL when out of memory. */
gsl_rng *pr_bind_exp3_start_rng(unsigned long seed, unsigned long repetition);
/* The trajectory of one shot (pr_sim_shoot's trace): *nrows rows of t, x, y,
 * ball into *rows, which the caller frees with pr_bind_free. */
int pr_bind_trace(const pr_config *c, int nballs, const double *state, const double *action,
                  double **rows, long *nrows, char *err);

/* `poolreps forest`'s fit: keys forest.*, seed experiment.seed. X is n x dx,
 * Y n x dy, w n weights or NULL. *out is set on success. */
int pr_bind_forest_fit(const pr_config *c, int n, int dx, int dy, const double *X,
                       const double *Y, const double *w, pr_forest **out, char *err);
/* `--leaves`: each row's active leaf per tree, numbered within its tree
 * (n x ntrees). Prediction is pr_forest_predict_many. */
int pr_bind_forest_apply(const pr_forest *f, long n, const double *X, int *leaves, char *err);

/* `poolreps reps`: keys reps.* (--epsilon is reps.epsilon). R has n returns,
 * q n base weights or NULL. Features: dense phi (n x d), or CSR
 * rowptr/col/val (val NULL: every stored value is 1), or d = 0. */
int pr_bind_reps(const pr_config *c, int n, int d, const double *R, const double *q,
                 const double *phi, const int *rowptr, const int *col, const double *val,
                 pr_reps_result **out, char *err);
/* An answer whose certificate is "failed" is the error PR_ENUM ("reps: no
 * certified answer: REASON") unless reps.allow_failed = 1. */
/* The result's scalar fields by name, so that bindings copy no struct
 * layout: field i's name and kind ('d' double, 'i' integer, 's' text),
 * NULL past the last; its value as a double (the status code for status, 0
 * for reason), and for 's' fields the text (status: "active",
 * "unreachable" or "failed"; reason: why a failed answer is not certified).
 * The weights are pr_bind_reps_p (n values) and pr_bind_reps_theta (d
 * values). */
const char *pr_bind_reps_field(int i, char *kind);
double pr_bind_reps_value(const pr_reps_result *r, int i);
const char *pr_bind_reps_text(const pr_reps_result *r, int i);
const double *pr_bind_reps_p(const pr_reps_result *r);
const double *pr_bind_reps_theta(const pr_reps_result *r);

/* `poolreps policy`'s fit: keys policy.*, seed experiment.seed. S is n x ds,
 * A n x da, w n weights or NULL, Y n x dy (needed when policy.target =
 * reward_state, else NULL with dy = 0). */
int pr_bind_policy_fit(const pr_config *c, int n, int ds, int da, int dy, const double *S,
                       const double *A, const double *w, const double *Y, pr_policy **out,
                       char *err);
/* Per query state (nq rows of ds): mean (da), covariance (da x da) and the
 * PR_POLICY_* status bits. */
int pr_bind_policy_eval(const pr_policy *p, long nq, const double *S, double *mean,
                        double *cov, int *status, char *err);
/* k draws per query state (nq x k x da) from a GSL mt19937 set to seed, the
 * stream `poolreps policy --seed SEED --sample K` draws from after its fit. */
int pr_bind_policy_sample(const pr_policy *p, long nq, const double *S, int k,
                          unsigned long seed, double *draws, int *status, char *err);
/* The same draws in pieces: a generator as the command's after its fit
 * (seeded with seed, one draw taken), then calls on consecutive rows. */
gsl_rng *pr_bind_policy_rng_new(unsigned long seed);
int pr_bind_policy_sample_rng(const pr_policy *p, long nq, const double *S, int k,
                              gsl_rng *rng, double *draws, int *status, char *err);
/* log pi(a|s) per row (nq states S, nq actions A). */
int pr_bind_policy_logpdf(const pr_policy *p, long nq, const double *S, const double *A,
                          double *logpdf, int *status, char *err);

/* The ask/tell learner (learner.h) with the options of c (learner.*,
 * value.*, reps.*, policy.*), contexts of dx and actions of da dimensions,
 * the dx + da column names of `poolreps learner` (NULL ones: s0 .., a0 ..),
 * pi_0's mean init_mean (da; NULL: 0; a learner with one is saved only
 * once pi_0's episodes have left the window),
 * drawing from rng (pr_bind_rng_new(experiment.seed) gives the stream of
 * `poolreps learner new`). NULL and err on failure. */
pr_learner *pr_bind_learner_new(const pr_config *c, int dx, int da, const char *const *names,
                                const double *init_mean, gsl_rng *rng, char *err);
/* pr_learner_tell_batch with flat arguments (G n x d or NULL, Y n x dy or NULL). */
int pr_bind_learner_tell(pr_learner *L, int n, const double *X, const double *A, const double *R,
                         const double *G, int d, const double *Y, int dy, char *err);
/* The last tell's summary: d[0..6] = eta, kl, ess, q_ess, residual, kl_gap,
 * residual_rel; i[0..6] = iteration, n, bound, features, dual evaluations,
 * status, flags; the reason text (empty unless status is failed). names,
 * unless NULL: the dx + da column names (valid while L lives). */
const char *pr_bind_learner_summary(const pr_learner *L, double *d, int *i, const char **names);

#endif
