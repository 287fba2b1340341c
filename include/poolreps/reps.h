/* reps.h — episodic contextual REPS (thesis ch. 3).
 *
 * One call, pr_reps_solve, minimises the dual eq. 3.8
 *
 *   g(eta, theta) = eta*eps + theta^T phi_hat
 *                 + eta * log sum_i q_i exp((R_i - theta^T phi_i) / eta),
 *   phi_hat = sum_i q_i phi_i,
 *
 * and certifies the answer. The weights p_i ∝ q_i exp((R_i - theta^T phi_i)/eta)
 * (eq. 3.7) already contain q: a policy fit must not multiply by q again.
 *
 * The dual minimised over theta, h(eta), is convex with h'(eta) = eps - KL(p_eta||q),
 * and KL(p_eta||q) rises monotonically as eta falls, towards KL(p_0||q), where p_0
 * is the eta -> 0 limit: among the solutions of the feature-matching linear
 * programme (maximise sum p R subject to sum p phi = phi_hat, sum p = 1, p >= 0,
 * p = 0 where q = 0) the one closest to q in KL. So either the bound is met at a
 * unique eta > 0 (status active), or eps >= KL(p_0||q) and the answer is p_0
 * itself at eta = 0 (status unreachable).
 */
#ifndef POOLREPS_REPS_H
#define POOLREPS_REPS_H

#include "poolreps/common.h"

/* REPS parameters (keys reps.*). */
typedef struct {
	double epsilon;   /* KL bound, eq. 3.2; >= PR_REPS_EPS_MIN */
	double ridge;     /* ridge (ridge/2)|theta'|^2 on theta in standardised
	                     return units (so it does not depend on the return
	                     scale); 0 = none. With features the eta -> 0 limit
	                     exists only without it (an unreachable bound is then
	                     "failed") */
	int max_iter;     /* dual evaluations per solve before it gives up */
	double eta_min;   /* eta, in return standard deviations, below which the
	                     solver consults the eta -> 0 limit (a linear
	                     programme) to decide whether the bound is reachable */
	int allow_failed; /* experiments: 1 = record a failed certificate and go
	                     on; 0 (default) = a failed solve fails the run */
	int solver;       /* PR_REPS_SOLVER_NEWTON (default), PR_REPS_SOLVER_NLOPT or
	                     PR_REPS_SOLVER_CG */
	int threads;      /* threads for a wide dense problem's Hessian, 0 .. 64
	                     (default 0: one per CPU the process may run on, and
	                     never more than that; any count gives the same bits;
	                     a Hessian of fewer than 2e6 multiply-adds runs on
	                     one) */
} pr_reps_opts;
/* reps.solver: newton = the Newton path and eta -> 0 limit described at
 * pr_reps_solve (matrix-free, as cg, on dense features once there are
 * 8192 free ones and more samples); cg = the same path with each Newton
 * step solved by conjugate gradients on Hessian-vector products (dense
 * features; one-hot ones take the newton path), memory O(n d), no reduced
 * basis: nearly dependent features fail the certificate; nlopt = NLopt's
 * L-BFGS on the dual over (log eta, theta) first, then the Newton search
 * (and limit) from NLopt's answer instead of from (1, 0): an answer is
 * returned only with Newton's certificate. */
enum { PR_REPS_SOLVER_NEWTON = 0, PR_REPS_SOLVER_NLOPT = 1, PR_REPS_SOLVER_CG = 2 };
void pr_reps_opts_init(pr_reps_opts *o);

/* Certificate tolerance: |KL - eps| / min(1, eps), the relative feature
 * residual, and the distance of p to the eta -> 0 solution must each be
 * within it. */
#define PR_REPS_TOL 1e-9
/* The smallest KL bound accepted: KL = E_p[u] - log sum q exp(u) loses
 * about 1e-16 sqrt(eps) to cancellation, 1e-10 of eps here, which the
 * relative tolerance still holds. */
#define PR_REPS_EPS_MIN 1e-12

/* Certificate status of a solve. */
enum {
	PR_REPS_ACTIVE = 0,      /* |KL - eps| <= PR_REPS_TOL min(1, eps), residual <= PR_REPS_TOL */
	PR_REPS_UNREACHABLE = 1, /* eta = 0 (its floor), KL < eps, p = the eta -> 0
	                            solution within PR_REPS_TOL, residual <= PR_REPS_TOL */
	PR_REPS_FAILED = 2       /* neither could be certified; `reason` says why */
};
/* "active", "unreachable" or "failed". */
const char *pr_reps_status_name(int status);

/* A REPS problem over n samples with d state features. Features are dense
 * (phi, n x d row-major) or sparse in CSR form (rowptr n+1 entries, col and
 * val rowptr[n] entries; val NULL means every stored value is 1, i.e. the
 * one-hot active-leaf features of thesis eq. 5.4). Features whose values
 * are all 0 or 1, dense or sparse, are solved by the one-hot path (exact
 * counts), so both storages give the same bits. d = 0: no features. The
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
	double *p;           /* n weights, sum 1; include q; 0 where q_i = 0 */
	double *theta;       /* d value-function parameters, return units */
	double eta;          /* temperature, return units; 0 when the bound is
	                        unreachable (the eta -> 0 limit) */
	double dual;         /* g(eta, theta) of eq. 3.8 without the ridge term
	                        (at eta = 0: the linear programme's dual value) */
	double kl;           /* KL(p || q) */
	double kl_gap;       /* |kl - epsilon| */
	double residual;     /* |sum_i p_i (phi_i - phi_hat)|_2, feature units */
	double residual_rel; /* max_j |sum_i p_i (phi_ij - phi_hat_j)| / s_j,
	                        s_j = max_{i: q_i > 0} |phi_ij - phi_hat_j| (0/0 = 0);
	                        with a ridge, of sum p phi - phi_hat + ridge theta' */
	double ess;          /* effective sample size 1 / sum_i p_i^2 */
	int status;          /* PR_REPS_ACTIVE, PR_REPS_UNREACHABLE or PR_REPS_FAILED */
	int bound;           /* 1 exactly when status is PR_REPS_ACTIVE */
	int constant;        /* 1: all returns with q_i > 0 are equal; p = q, eta = 0 */
	int iterations;      /* dual evaluations (Newton steps and line-search trials) */
	char reason[160];    /* status failed: what could not be certified */
	/* The solver path, for diagnostics (reps --summary): */
	int rank;            /* feature directions the solver used (after dropping
	                        constant features, reference leaves and, on the
	                        reduced basis, numerically dependent directions) */
	double cond;         /* (max L_jj / min L_jj)^2 of the Cholesky factor L of
	                        the last Jacobi-scaled theta Hessian: a lower
	                        estimate of its condition number (1 without features,
	                        on the matrix-free path and for a full span) */
	char path[48];       /* steps taken, joined by '+': joint (the joint Newton
	                        fast path), chord (steps that reused the last
	                        Hessian near the root; wide dense problems), search
	                        (the root search on log eta), up (eta raised before
	                        any theta solve worked), limit (the eta -> 0 limit),
	                        reduced (a second attempt on a well-conditioned
	                        basis after the first failed), nlopt (reps.solver =
	                        nlopt), span (dense features at least as many
	                        as the samples: solved on their span, of
	                        dimension below n, from the start), cg (the
	                        matrix-free Newton steps) */
} pr_reps_result;

/* Solve the dual and certify the result (see the file comment): Newton's
 * method on theta for fixed eta with the exact Hessian (the p-weighted
 * covariance of the features), a safeguarded root search on log eta for
 * KL = eps, and, when eta falls below eta_min with KL < eps, the eta -> 0
 * limit by a linear programme (GLPK) and a maximum-entropy solve on its
 * optimal face. Returns are standardised first (shift by their maximum,
 * divide by their q-weighted spread, both without overflow or underflow),
 * so the answer is invariant to affine changes of the returns.
 * A result that cannot be certified is returned with status
 * PR_REPS_FAILED and PR_OK: the caller decides (the CLI exits 3).
 * Errors: PR_EINVAL (fewer than 2 samples, bad options, non-finite data, negative or all-zero q,
 * naming the sample), PR_ENOMEM, PR_ENUM (returns so far apart that the
 * back-mapped eta or theta overflows), PR_EINTR. *out is set only on
 * success. */
int pr_reps_solve(const pr_reps_opts *o, const pr_reps_problem *pb,
                  pr_reps_result **out, char *err);
void pr_reps_result_free(pr_reps_result *r);


#endif
