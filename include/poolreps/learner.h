/* learner.h — the method as an ask/tell learner for any task: value
 * features from extremely randomized trees (thesis ch. 5), episodic
 * contextual REPS (ch. 3) and a tree-LWR or linear Gaussian policy (ch. 6),
 * refitted each iteration over a window of past episodes (7.5.1).
 *
 * The loop (docs/learner.md):
 *   ask:  one action per context from the current policy pi_t;
 *   (the caller plays the episodes and measures their returns)
 *   tell: the episodes join the window (the latest `window` ones, drawn by
 *         pi_pmin .. pi_t); importance weights q = pi_t / pi_mix, pi_mix the
 *         sample-count mixture of the drawing policies; value features of
 *         the window contexts; REPS weights p with base weights q (eq.
 *         3.7-3.8); pi_{t+1} fitted to the window with weights p.
 * Told episodes count as drawn by the current policy. A tell that fails
 * leaves the learner as it was (its random stream included).
 *
 * log pi_m(a_i|s_i) never changes once both exist, so it is computed once:
 * at ask for the asked actions (kept until the next tell, which reuses them
 * for the episodes whose context and action are the asked ones, bit for
 * bit), at tell for the others and for a new policy on the window. */
#ifndef POOLREPS_LEARNER_H
#define POOLREPS_LEARNER_H
#include <stdio.h>
#include <gsl/gsl_rng.h>
#include "poolreps/common.h"
#include "poolreps/forest.h"
#include "poolreps/policy.h"
#include "poolreps/reps.h"

/* value.features: which features of the value-feature forest REPS uses. */
typedef enum {
	PR_VALUE_LEAVES = 0,   /* active leaves, one-hot (eq. 5.4) */
	PR_VALUE_SAMPLES = 1   /* active samples (eq. 5.6) */
} pr_value_features;

/* learner.value: the value features of the contexts. trees: a forest
 * contexts -> returns scored by value.score; nrvr / rvr: the same with that
 * score (thesis 7.5.1); linear: [1, s]; quadratic: [1, s, s_j s_k]; given:
 * the caller's own features, passed to tell. */
enum {
	PR_LEARNER_VALUE_TREES = 0,
	PR_LEARNER_VALUE_NRVR = 1,
	PR_LEARNER_VALUE_RVR = 2,
	PR_LEARNER_VALUE_LINEAR = 3,
	PR_LEARNER_VALUE_QUADRATIC = 4,
	PR_LEARNER_VALUE_GIVEN = 5
};
/* learner.policy: tree-LWR (ch. 6, policy.*) or linear-Gaussian on [1, s]. */
enum { PR_LEARNER_POLICY_TREE = 0, PR_LEARNER_POLICY_LINEAR = 1 };
/* learner.truncation, with learner.max_norm > 0: an action whose Euclidean
 * norm exceeds max_norm is drawn again, its density the untruncated one
 * (redraw); scaled onto the limit (clip); or drawn again with the density
 * divided by the mass inside the limit (corrected; two action dimensions). */
enum { PR_LEARNER_REDRAW = 0, PR_LEARNER_CLIP = 1, PR_LEARNER_CORRECTED = 2 };
/* learner.draw: an action from N(mean, cov) with cov decomposed at the
 * context (query), or with the eigen-decomposition the policy's fit kept
 * (fit, as pr_policy_sample; the C-REPS benchmarks draw so). The two agree
 * up to round-off. */
enum { PR_LEARNER_DRAW_QUERY = 0, PR_LEARNER_DRAW_FIT = 1 };

typedef struct {
	int value;             /* PR_LEARNER_VALUE_* */
	int policy_type;       /* PR_LEARNER_POLICY_* */
	int window;            /* episodes REPS and the fit reuse, >= 2; 0: each tell's
	                        * own alone, base weights uniform (C-REPS) */
	double init_std;       /* pi_0 = N(0, init_std^2 I) */
	double max_norm;       /* > 0: actions are kept within this norm; 0: no limit */
	int truncation;        /* PR_LEARNER_REDRAW, _CLIP or _CORRECTED */
	int draw;              /* PR_LEARNER_DRAW_QUERY or _FIT */
	int refit;             /* 1: no REPS, p = q (a control: pi refitted to its own samples) */
	pr_forest_opts value_forest; /* value.* */
	int value_features;    /* value.features: PR_VALUE_* */
	pr_reps_opts reps;     /* reps.* */
	pr_policy_opts policy; /* policy.* */
} pr_learner_opts;
/* Defaults: trees, tree policy, window 400, init_std 1, no norm limit,
 * the value forests of thesis 7.5.1 (M 10, K 10, n_min 60) and the module
 * defaults of reps.* and policy.*. */
void pr_learner_opts_init(pr_learner_opts *o);

/* The last tell's REPS certificate and fit. */
typedef struct {
	int iteration;   /* tells so far */
	int n;           /* episodes in the window */
	double eta, kl, ess, q_ess, residual, kl_gap, residual_rel;
	int bound;       /* the KL bound is active */
	int nfeat;       /* value features */
	int evals;       /* dual evaluations */
	int status;      /* PR_REPS_* (PR_REPS_ACTIVE before the first tell and under refit) */
	int flags;       /* PR_POLICY_* of the fit and the window's densities, or-ed */
	char reason[160];
} pr_learner_summary;

typedef struct pr_learner pr_learner;

/* A learner of contexts of 1 .. 100000 and actions of 1 .. 64 dimensions. It
 * draws actions and forests from rng, which it borrows (the caller frees it
 * after pr_learner_free). NULL with err on bad options. */
pr_learner *pr_learner_new(const pr_learner_opts *o, int dx, int da, gsl_rng *rng, char *err);
void pr_learner_free(pr_learner *L);


/* One action per context: contexts n x dx, actions n x da, row-major. */
int pr_learner_ask(pr_learner *L, int n, const double *contexts, double *actions, char *err);
/* The mean action of the current policy at n contexts (no sampling, no
 * norm limit applied). */
int pr_learner_mean(pr_learner *L, int n, const double *contexts, double *actions, char *err);

/* One iteration: n episodes (contexts n x dx, actions n x da, returns n),
 * features n x d for value given (else NULL; d fixed by the first tell).
 * PR_EINVAL for bad shapes or non-finite values, naming the argument and
 * row; PR_ENUM for an uncertified REPS solve unless reps.allow_failed. */
int pr_learner_tell(pr_learner *L, int n, const double *contexts, const double *actions,
                    const double *returns, const double *features, int d, char *err);


int pr_learner_iteration(const pr_learner *L);
int pr_learner_context_dim(const pr_learner *L);
int pr_learner_action_dim(const pr_learner *L);
const pr_learner_summary *pr_learner_last(const pr_learner *L);


/* Saving and loading (docs/learner.md, "State file"): a byte format that
 * starts "poolreps-learner\n" and a version; everything little-endian. It
 * holds the options, the window, the last ask, the random stream's state
 * and each live policy's fit (refitted on load, bit for bit).
 * PR_LEARNER_FORMAT is the version this library writes and the only one it
 * reads. */
#define PR_LEARNER_FORMAT 2
/* The state into a new buffer *buf of *len bytes (free()). */
int pr_learner_save(const pr_learner *L, unsigned char **buf, size_t *len, char *err);
/* A learner from len bytes in that format, drawing from rng, whose state is
 * set to the saved one (same generator type); `what` names the source in
 * messages. NULL with err: PR_EINVAL for another version, PR_EIO for a
 * truncated or malformed state, PR_ENOMEM. */
pr_learner *pr_learner_load(const unsigned char *buf, size_t len, const char *what, gsl_rng *rng,
                            char *err);
#endif
