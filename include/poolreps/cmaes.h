/* cmaes.h — contextual CMA-ES (Abdolmaleki, Price, Lau, Reis, Neumann,
 * "Contextual Covariance Matrix Adaptation Evolutionary Strategies", IJCAI
 * 2017): a contextual search distribution
 *
 *   x ~ N(W psi(s), sigma^2 C),   psi = hand-made context features (affine),
 *
 * updated once per generation of n samples from their returns alone:
 *   1. a baseline V(s) = beta^T b(s) fitted to the returns by ridge least
 *      squares on caller-given features b (quadratic in s in the paper);
 *   2. the samples ranked by their advantage R_i - V(s_i); the best
 *      mu = floor(n/2) get the weights d_i ∝ log(mu + 1/2) - log(rank_i),
 *      the rest 0;
 *   3. the new mean by weighted linear regression of x on psi(s) with d;
 *   4. cumulative step-size adaptation and the rank-one and contextual
 *      rank-mu covariance updates around the OLD mean W_old psi(s_i).
 * Equations and constants: docs/policies.md and the comments in cmaes.c.
 * The module draws nothing: pr_cmaes_policy gives the search distribution
 * as a pr_policy, which samples with the caller's gsl_rng.
 */
#ifndef POOLREPS_CMAES_H
#define POOLREPS_CMAES_H

#include "poolreps/common.h"
#include "poolreps/policy.h"

typedef struct pr_cmaes pr_cmaes;

/* A search distribution over da parameters for ds context dimensions, mean
 * features `features` (PR_FEATURES_*), initial mean W0 (da x nf row-major,
 * nf = pr_policy_features_count(features, ds)), step size sigma0 > 0, C = I.
 * lambda >= 0 is the ridge of both regressions (mean and baseline). NULL on
 * error (err filled). */
pr_cmaes *pr_cmaes_new(int features, int ds, int da, const double *W0, double sigma0,
                       double lambda, char *err);
void pr_cmaes_free(pr_cmaes *c);

/* One generation, drawn from the current distribution. Arrays are only read. */
typedef struct {
	int n;            /* samples, >= 2 */
	int nb;           /* baseline features per sample, >= 1 */
	const double *S;  /* n x ds contexts */
	const double *X;  /* n x da parameters */
	const double *R;  /* n returns (larger is better) */
	const double *B;  /* n x nb baseline features b(s_i) */
} pr_cmaes_batch;

/* What one update did. */
typedef struct {
	double mueff;     /* 1 / sum d_i^2, the selection's effective sample size */
	double sigma;     /* step size after the update */
	double ps_norm;   /* |p_sigma| after the update */
	int hsig;         /* 1: the rank-one path was fed this generation */
	int flags;        /* PR_POLICY_* flags of the mean regression */
} pr_cmaes_info;

/* Update mean, paths, covariance and step size from one generation. info
 * may be NULL. PR_EINVAL for bad input (non-finite values, sizes), PR_ENUM
 * when a regression or eigen-decomposition fails or the state stops being
 * finite, PR_ENOMEM; the state is unchanged on error. */
int pr_cmaes_update(pr_cmaes *c, const pr_cmaes_batch *b, pr_cmaes_info *info, char *err);

/* The current search distribution N(W psi(s), sigma^2 C) as a new linear
 * policy (caller frees), eigenvalues of sigma^2 C floored at min_std^2
 * (min_std > 0); *floored (may be NULL) is set to 1 when the floor acted. */
pr_policy *pr_cmaes_policy(const pr_cmaes *c, double min_std, int *floored, char *err);

double pr_cmaes_sigma(const pr_cmaes *c);
/* Copies of the mean coefficients W (da x nf) and of C (da x da). */
void pr_cmaes_state(const pr_cmaes *c, double *W, double *C);

#endif
