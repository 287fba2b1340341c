/* reps.h — episodic contextual REPS (thesis ch. 3, SPEC.md §4).
 *
 * One call, pr_reps_solve, minimises the dual eq. 3.8
 *
 *   g(eta, theta) = eta*eps + theta^T phi_hat
 *                 + eta * log sum_i q_i exp((R_i - theta^T phi_i) / eta),
 *   phi_hat = sum_i q_i phi_i,
 *
 * over x = (log eta, theta) with NLopt's L-BFGS and the analytic gradient,
 * on returns standardised by their q-weighted mean and std (eta and theta
 * are mapped back exactly: eta = s*eta', theta = s*theta', g = m + s*g').
 * The weights p_i ∝ q_i exp((R_i - theta^T phi_i)/eta) (eq. 3.7) already
 * contain q: a policy fit must not multiply by q again.
 */
#ifndef POOLREPS_REPS_H
#define POOLREPS_REPS_H

#include "poolreps/common.h"

/* REPS parameters (keys reps.*). */
typedef struct {
	double epsilon;  /* KL bound, eq. 3.2; > 0 */
	double ridge;    /* ridge (ridge/2)|theta'|^2 on theta in standardised
	                    return units (so it does not depend on the return
	                    scale); 0 = none */
	int max_iter;    /* L-BFGS dual evaluations (or IPF sweeps) per solve */
	double eta_min;  /* lower bound on eta in units of the return std */
} pr_reps_opts;
void pr_reps_opts_init(pr_reps_opts *o);

/* The |KL - eps| tolerance that makes the bound count as met. */
#define PR_REPS_KL_TOL 1e-6

/* A REPS problem over n samples with d state features. Features are dense
 * (phi, n x d row-major) or sparse in CSR form (rowptr n+1 entries, col and
 * val rowptr[n] entries; val NULL means every stored value is 1, i.e. the
 * one-hot active-leaf features of thesis eq. 5.4). d = 0: no features. The
 * arrays belong to the caller and are only read. */
typedef struct {
	int n, d;
	const double *R;       /* n returns */
	const double *q;       /* n base weights >= 0, not all 0; NULL = uniform */
	const double *phi;     /* dense features or NULL */
	const int *rowptr;     /* sparse features (used when phi is NULL and d > 0) */
	const int *col;
	const double *val;
} pr_reps_problem;

/* Result of one solve. Owned by the caller: pr_reps_result_free. */
typedef struct {
	int n, d;
	double *p;         /* n weights, sum 1; include q; 0 where q_i = 0 */
	double *theta;     /* d value-function parameters, return units */
	double eta;        /* temperature, return units (0 when returns are constant) */
	double dual;       /* g(eta, theta) of eq. 3.8 without the ridge term */
	double kl;         /* KL(p || q) */
	double residual;   /* |sum_i p_i phi_i - phi_hat|_2 */
	double ess;        /* effective sample size 1 / sum_i p_i^2 */
	int bound;         /* 1: the KL bound is active, |kl - eps| <= PR_REPS_KL_TOL;
	                      0: "KL bound inactive": eta sits at its lower bound
	                      and kl < eps (features rich enough to pin p near q,
	                      or returns constant) */
	int constant;      /* 1: all returns equal; p = q, eta = 0, theta = 0 */
	int iterations;    /* dual evaluations (L-BFGS, Newton, IPF sweeps, polish) */
	int solver;        /* NLopt's result code (nlopt_result) */
} pr_reps_result;

/* Solve the dual: L-BFGS, a Newton polish (d <= 200), and a 1-D root find
 * on eta for the final theta. When L-BFGS ends at the eta bound or with
 * theta unconverged, a continuation in eta with warm-started theta solves
 * decides whether the bound is active (exact block updates for one-hot
 * features in blocks, i.e. CSR rows whose j-th entry is a leaf of tree j).
 * The KL check is enforced: when eta is above its lower bound the result
 * satisfies |kl - eps| <= PR_REPS_KL_TOL; otherwise bound = 0. Check
 * `residual` for the feature match.
 * Errors: PR_EINVAL (bad options, non-finite data, negative or all-zero q,
 * naming the sample), PR_ENOMEM, PR_ENUM (solver failure). *out is set only
 * on success. */
int pr_reps_solve(const pr_reps_opts *o, const pr_reps_problem *pb,
                  pr_reps_result **out, char *err);
void pr_reps_result_free(pr_reps_result *r);

/* The dual on the returns as given (no standardisation), q normalised to
 * sum 1, plus (ridge/2)|theta|^2, at x = (log eta, theta_1..theta_d).
 * grad (d+1 values, may be NULL) receives dg/dlog eta = eta*(eps - KL) and
 * dg/dtheta = phi_hat - sum_i p_i phi_i + ridge*theta. For tests and
 * diagnostics; returns NaN for an invalid problem. */
double pr_reps_dual(const pr_reps_problem *pb, double epsilon, double ridge,
                    const double *x, double *grad);

/* Importance weights for sample reuse (SPEC.md §4): a window of n samples
 * drawn by npol past policies, counts[k] of them by policy k (sum = n).
 * logpi is npol x n row-major: logpi[k*n + i] = log pi_k(a_i | s_i); logcur
 * (n) holds log pi_current(a_i | s_i). In log space,
 *   log r_i = logcur_i - log sum_k (counts[k]/n) pi_k(a_i|s_i),
 * q_i = r_i / sum_j r_j. Writes q (n, sum 1), logratio (n, may be NULL) and
 * *ess = 1 / sum q_i^2 (may be NULL). Counts of 0 are allowed. */
int pr_reps_importance(int npol, int n, const double *logpi, const int *counts,
                       const double *logcur, double *q, double *logratio,
                       double *ess, char *err);

#endif
