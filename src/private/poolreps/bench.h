/* bench.h — REPS validation problems, run as experiments
 * named by experiment.name:
 *
 *   quadratic   1-D contextual quadratic: context c ~ U[-1, 1], action x,
 *               return -(x - c)^2; optimum x*(c) = c.
 *   sphere      contextual sphere of Abdolmaleki et al., IJCAI 2017, §6.1:
 *               return -|x + G s|^2, x in R^dims, s ~ U[1, 2)^k, G a fixed
 *               dims x k matrix of N(0, 1) entries drawn per repetition;
 *               optimum x*(s) = -G s.
 *   rosenbrock  contextual Rosenbrock, same paper: return
 *               -sum_{i<dims} [100 (y_{i+1} - y_i^2)^2 + (1 - y_i)^2],
 *               y = x + G s; optimum x*(s) = 1 - G s.
 *
 * Each iteration draws bench.samples contexts, one action each from the
 * linear-Gaussian policy x ~ N(W [1, s], Sigma) (affine context features),
 * solves REPS (value features s, or s and its products for
 * bench.value_degree = 2) and refits the policy by weighted ML (eq. 3.10).
 * The initial policy is N(mu0, bench.init_std^2 I), mu0 = 0 for quadratic
 * and N(0, 1) entries otherwise. Only the latest batch is used (no reuse).
 */
#ifndef POOLREPS_BENCH_H
#define POOLREPS_BENCH_H

#include "poolreps/common.h"
#include "poolreps/config.h"
#include "poolreps/exp.h"

/* REPS validation problems (bench.h), keys bench.*; quadratic ignores dims
 * and context_dims: both are 1. */
typedef struct {
	int iterations;     /* REPS iterations */
	int samples;        /* episodes per iteration (>= 2) */
	int dims;           /* action (parameter) dimensions */
	int context_dims;   /* k */
	double init_std;    /* initial policy standard deviation */
	double min_std;     /* eigenvalue floor of the policy covariance (as a std) */
	int value_degree;   /* REPS value features: 1 = s, 2 = s and s_j s_k */
	int test_contexts;  /* fixed contexts on which the policy mean is scored */
	int method;         /* PR_METHOD_CREPS or PR_METHOD_CCMAES */
} pr_bench_opts;

/* The sphere's defaults: iterations 200, samples 50, dims 20, context_dims
 * 2, init_std 1, min_std 1e-12, value_degree 1, test_contexts 100, creps.
 * As experiments (keys bench.*), quadratic starts from iterations 40, dims 1,
 * context_dims 1, value_degree 2, and rosenbrock from context_dims 1
 * (exp_bench.c's defaults). */
void pr_bench_opts_init(pr_bench_opts *o);
int pr_bench_opts_check(const pr_bench_opts *o, char *err);

/* Run repetitions [lo, hi) of experiment.repetition(s) with the given
 * options (the REPS options come from cfg->reps, the policy ridge from
 * cfg->policy.lambda). Writes dir/bench_curve.csv: repetition, iteration,
 * samples, mean_return, test_return, test_error, mean_std, eta, kl, ess,
 * bound, policy_flags. Row (r, i) describes the policy that drew iteration
 * i's samples (mean_return is their mean return; test_return and test_error
 * the return and RMS distance to x*(s) of its mean on the fixed test
 * contexts; mean_std the root mean variance) and the REPS update computed
 * from them; policy_flags or-s the PR_POLICY_* fallbacks of that policy's
 * queries and of the fit that followed.
 * Repetition k draws only from the stream (experiment.seed, k). */
int pr_bench_run(const pr_config *cfg, const pr_bench_opts *b, const char *dir,
                 const pr_progress *prog, char *err);

/* Experiment entry points (pr_experiment.run / .summarize): pr_bench_run
 * with cfg's bench.* options (whose defaults follow experiment.name), and the derived
 * dir/bench_summary.csv (iteration, samples, then mean and std over
 * repetitions of mean_return, test_return, test_error, and the fraction of
 * updates with the KL bound active), computed from bench_curve.csv alone. */
int pr_exp_benchmark_run(const pr_config *cfg, const char *dir, const pr_progress *prog,
                         char *err);
int pr_exp_benchmark_summarize(const pr_config *cfg, const char *dir, char *err);

#endif
