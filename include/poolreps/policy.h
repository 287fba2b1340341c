/* policy.h — tree-based locally weighted regression Gaussian policy
 * (thesis ch. 6, SPEC.md §5) and a linear-Gaussian baseline. */
#ifndef POOLREPS_POLICY_H
#define POOLREPS_POLICY_H

#include <gsl/gsl_rng.h>
#include "poolreps/common.h"
#include "poolreps/forest.h"

enum { PR_TARGET_ACTION = 0, PR_TARGET_REWARD_STATE = 1 };

/* Policy parameters (keys policy.*). */
typedef struct {
	int target;            /* forest output: actions or final reward-ball positions */
	double lambda;         /* ridge of eq. 6.6 */
	double min_std;        /* floor on each action standard deviation, m/s */
	pr_forest_opts forest; /* policy.trees, policy.cuts, policy.n_min, ... */
} pr_policy_opts;
void pr_policy_opts_init(pr_policy_opts *o);

#endif
