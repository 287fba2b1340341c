/* reps.h — episodic contextual REPS (thesis ch. 3, SPEC.md §4). */
#ifndef POOLREPS_REPS_H
#define POOLREPS_REPS_H

#include "poolreps/common.h"

/* REPS parameters (keys reps.*). */
typedef struct {
	double epsilon;  /* KL bound, eq. 3.2 */
	double ridge;    /* ridge on theta, 0 = none */
	int max_iter;    /* L-BFGS evaluations */
} pr_reps_opts;
void pr_reps_opts_init(pr_reps_opts *o);

#endif
