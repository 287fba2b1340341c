/* forest.h — extremely randomized trees (thesis ch. 4, 5.2, 6.1). */
#ifndef POOLREPS_FOREST_H
#define POOLREPS_FOREST_H

#include <gsl/gsl_rng.h>
#include "poolreps/common.h"

enum { PR_SCORE_RVR = 0, PR_SCORE_NRVR = 1 };

/* Forest parameters (keys forest.*, and the same fields under value.* and policy.*). */
typedef struct {
	int trees;            /* M */
	int cuts;             /* K random tests per node */
	int n_min;            /* split nodes holding more than n_min samples */
	int n_c;              /* drop splits leaving a child with fewer than n_c */
	int score;            /* PR_SCORE_RVR (eq. 4.1) or PR_SCORE_NRVR (7.5.1) */
	int with_replacement; /* 1: cut dimensions drawn with replacement */
} pr_forest_opts;
void pr_forest_opts_init(pr_forest_opts *o);

#endif
