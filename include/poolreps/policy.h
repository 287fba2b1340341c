/* policy.h — tree-based locally weighted regression Gaussian policy
 * (thesis ch. 6) and a linear-Gaussian baseline.
 *
 * One opaque pr_policy covers three kinds with the same mean / sample /
 * log-density interface:
 *   PR_POLICY_GAUSSIAN  a fixed N(mu0, Sigma0), whatever the state (the
 *                       initial policy);
 *   PR_POLICY_LINEAR    a = W psi(s) + N(0, Sigma) on hand-made features psi
 *                       (affine [1, s] or quadratic), fitted by weighted
 *                       maximum likelihood (eq. 3.10);
 *   PR_POLICY_TREE      the tree-LWR policy of eq. 6.4-6.9 over a forest built
 *                       with the weighted score eq. 6.3.
 * Actions are da-dimensional, states ds-dimensional. Weights are REPS
 * weights p (they already contain the base weights q; never multiply again).
 */
#ifndef POOLREPS_POLICY_H
#define POOLREPS_POLICY_H

#include <gsl/gsl_rng.h>
#include "poolreps/common.h"
#include "poolreps/forest.h"

enum { PR_TARGET_ACTION = 0, PR_TARGET_REWARD_STATE = 1 };

/* Centre of the covariance eq. 6.8 under PR_COV_CENTER_NEW: the query mean
 * mu(s_hat) as printed in the thesis, or the query's local fit at each
 * sample's state (residual covariance). No effect under PR_COV_CENTER_OLD. */
enum { PR_COV_QUERY = 0, PR_COV_RESIDUAL = 1 };

/* Centre of the residuals of a weighted-ML covariance (key policy.cov_center):
 *   PR_COV_CENTER_NEW  the newly fitted mean, Sigma = sum w_i (a_i - W psi_i)(.)^T
 *                      (textbook weighted ML, eq. 3.10; the thesis's rule), and
 *                      for the tree-LWR policy eq. 6.8 as policy.cov says;
 *   PR_COV_CENTER_OLD  the mean m_i of the policy that drew sample i, at that
 *                      sample's state, Sigma = sum w_i (a_i - m_i)(.)^T (the
 *                      rank-mu form of CMA-ES: keeps the spread along the step);
 *                      for the tree-LWR policy, with eq. 6.4's weights w^_i(s)
 *                      and eq. 6.9's Z at the query s:
 *                      Sigma(s) = sum w^_i (a_i - m_i)(.)^T / Z.
 * Both fits need pr_policy_data.M for PR_COV_CENTER_OLD. */
enum { PR_COV_CENTER_NEW = 0, PR_COV_CENTER_OLD = 1 };

/* Policy parameters (keys policy.*). */
typedef struct {
	int target;            /* forest output: actions or final reward-ball positions */
	double lambda;         /* ridge of eq. 6.6, read in centred, standardised
	                          coordinates: on the slopes measured in weighted
	                          standard deviations of the states, not on the
	                          intercept, with eq. 6.6's raw weights */
	double min_std;        /* floor on each action standard deviation, m/s */
	pr_forest_opts forest; /* policy.trees, policy.cuts, policy.n_min, ... */
	int cov;               /* PR_COV_QUERY (eq. 6.8 as printed) or PR_COV_RESIDUAL */
	int cov_center;        /* PR_COV_CENTER_NEW or PR_COV_CENTER_OLD */
} pr_policy_opts;
/* Defaults: target action, lambda 1e-10 (thesis 6.3), min_std 1e-3 m/s,
 * forest M = 10, K = 20, n_min = 75 (Experiment 3, thesis 7.5.1), n_c and
 * the rest from pr_forest_opts_init, score RVR, cov PR_COV_QUERY,
 * cov_center PR_COV_CENTER_NEW. */
void pr_policy_opts_init(pr_policy_opts *o);

enum { PR_POLICY_GAUSSIAN = 0, PR_POLICY_LINEAR = 1, PR_POLICY_TREE = 2 };

/* Hand-made state features for the linear policy. */
enum {
	PR_FEATURES_CONST = 0,     /* [1] */
	PR_FEATURES_AFFINE = 1,    /* [1, s] */
	PR_FEATURES_QUADRATIC = 2  /* [1, s, s_j s_k for j <= k] */
};

/* Fallbacks and adjustments made by one query or fit (bit set; 0 = none). */
enum {
	PR_POLICY_GLOBAL = 1,   /* no weight around the query: global weighted fit used */
	PR_POLICY_PINV = 2,     /* rank-deficient standardised weighted design (a state
	                           coordinate without spread, or collinear ones):
	                           minimum-norm slopes in standardised units, i.e.
	                           slope 0 along the directions the data do not span */
	PR_POLICY_MEANONLY = 4, /* fewer weighted samples than ds + 1, or no weighted
	                           state spread: weighted mean only */
	PR_POLICY_COVFALL = 8,  /* Z <= 0 (one effective sample): covariance of the
	                           global weights, or min_std^2 I if that fails too */
	PR_POLICY_FLOOR = 16    /* min_std raised some variance (eigenvalue floor) */
};

/* Weighted samples to fit from. The arrays are copied where needed. */
typedef struct {
	int n, ds, da, dy;
	const double *S;  /* n x ds states, row-major */
	const double *A;  /* n x da actions */
	const double *Y;  /* n x dy final reward-ball positions (target reward_state), or NULL */
	const double *w;  /* n REPS weights >= 0, not all 0; NULL = unit weights */
	const double *M;  /* n x da means of the policies that drew each sample, at
	                     that sample's state (PR_COV_CENTER_OLD, both fits), or NULL */
} pr_policy_data;

typedef struct pr_policy pr_policy;

/* N(mean, cov) in da dimensions for any state of ds dimensions; cov (da x da)
 * must be symmetric positive definite. */
pr_policy *pr_policy_gaussian_new(int ds, int da, const double *mean, const double *cov,
                                  char *err);

/* Weighted ML (eq. 3.10) of a = W psi(s - c) + N(0, Sigma), c the weighted
 * mean state (the same model as W psi(s), with features that offsets do not
 * swamp): W by weighted least squares in centred, standardised coordinates
 * (SVD of the weighted design; ridge lambda on the coefficients of the
 * non-constant features in units of their weighted standard deviations,
 * weights normalised to sum 1, intercept free), Sigma = sum_i w_i r_i r_i^T /
 * sum_i w_i with r_i = a_i - W psi(s_i - c) (cov_center PR_COV_CENTER_NEW) or
 * r_i = a_i - M_i (PR_COV_CENTER_OLD, which needs d->M), eigenvalues floored
 * at min_std^2. *flags (may be NULL) receives PR_POLICY_* bits. */
pr_policy *pr_policy_linear_fit(int features, const pr_policy_data *d, double lambda,
                                double min_std, int cov_center, int *flags, char *err);

/* The linear-Gaussian policy N(W psi(s), cov) with W (da x nf, row-major,
 * nf = pr_policy_features_count(features, ds)) and a symmetric positive
 * definite cov (da x da), both copied. */
pr_policy *pr_policy_linear_new(int features, int ds, int da, const double *W,
                                const double *cov, char *err);

/* The tree-LWR policy: fits the forest (inputs S; outputs A for target
 * action, Y for target reward_state) with weights w (eq. 6.3), keeps copies
 * of S, A and w (and of A - M for cov_center PR_COV_CENTER_OLD, which needs
 * d->M). One draw from rng seeds the forest. */
pr_policy *pr_policy_tree_fit(const pr_policy_opts *o, const pr_policy_data *d,
                              gsl_rng *rng, char *err);

void pr_policy_free(pr_policy *p);

int pr_policy_ds(const pr_policy *p);
int pr_policy_da(const pr_policy *p);

/* Scratch space for queries, so hot loops do not allocate. One per thread;
 * fits the policy it was made for (or any policy of the same n, ds, da). */
typedef struct pr_policy_work pr_policy_work;
pr_policy_work *pr_policy_work_new(const pr_policy *p, char *err);
void pr_policy_work_free(pr_policy_work *w);

/* Mean (da values) and covariance (da x da row-major, symmetric positive
 * definite) at state s. ws may be NULL (allocated per call). flags may be
 * NULL. Never produces NaN: degenerate cases fall back and set flags. */
int pr_policy_eval(const pr_policy *p, const double *s, double *mean, double *cov,
                   int *flags, pr_policy_work *ws, char *err);
/* k draws (k x da row-major) from pi(.|s). */
int pr_policy_sample(const pr_policy *p, const double *s, int k, gsl_rng *rng,
                     double *a, int *flags, pr_policy_work *ws, char *err);
/* log pi(a|s). */
int pr_policy_logpdf(const pr_policy *p, const double *s, const double *a,
                     double *logpdf, int *flags, pr_policy_work *ws, char *err);

#endif
