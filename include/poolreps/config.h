/* config.h — parameter files (INI, libinih), --set overrides and validation.
 *
 * A pr_config holds the options of the library's modules (table, sim, reward,
 * start, ghost, forest, value, reps, policy) and the experiment.* keys, plus
 * one block of options per experiment. config.c knows no experiment: the
 * experiments' keys, options and per-experiment defaults come from the
 * experiment registry (exp.h).
 *
 * Order: pr_config_new (defaults), pr_config_load (file), pr_config_set
 * (command line), pr_config_validate (cross-key checks). Every error names
 * file:line and section.key, e.g.
 * "data/exp3.ini:12: reps.epsilon: must be > 0 (got -1)". */
#ifndef POOLREPS_CONFIG_H
#define POOLREPS_CONFIG_H

#include <stddef.h>
#include <stdio.h>
#include "poolreps/common.h"
#include "poolreps/sim.h"
#include "poolreps/forest.h"
#include "poolreps/reps.h"
#include "poolreps/policy.h"
#include "poolreps/learner.h"

#define PR_LIST_MAX 64

/* Variants of one experiment at most (experiment.variant is below this). */
#define PR_VARIANTS_MAX (3 * PR_LIST_MAX + 1)

/* A configuration: opaque, so that its limits may change without breaking
 * the ABI. */
typedef struct pr_config pr_config;

/* Every default of the modules and of every registered experiment (exp.h),
 * on the heap; NULL when out of memory. pr_config_free(NULL) does nothing. */
pr_config *pr_config_new(void);
void pr_config_free(pr_config *c);
/* Read an INI file; the first bad line or key stops with an error. */
int pr_config_load(pr_config *c, const char *path, char *err);
/* Apply "section.key=value" from --set. */
int pr_config_set(pr_config *c, const char *assignment, char *err);
/* One key ("section.key") set as --set sets it, with the same checks: a
 * string in the file's form, or a number (for a whole-number key it must be
 * whole and in range). */
int pr_config_set_string(pr_config *c, const char *key, const char *value, char *err);
int pr_config_set_double(pr_config *c, const char *key, double v, char *err);
/* One key's value: as text in the file's form (into buf of n bytes; too
 * long is an error), or as a number for a number key (whole-number keys
 * included: their ranges make them exact). */
int pr_config_get_string(const pr_config *c, const char *key, char *buf, size_t n, char *err);
int pr_config_get_double(const pr_config *c, const char *key, double *v, char *err);
/* The options of a learner: learner.*, value.*, reps.* and policy.*. */
void pr_config_learner_opts(const pr_config *c, pr_learner_opts *o);
/* Checks that involve several keys (e.g. n_c <= n_min, boxes inside the table). */
int pr_config_validate(const pr_config *c, char *err);

/* 1 if key ("section.key") is in list, a comma list of whole names and of
 * sections ending in '.': "forest.,experiment.seed". */
int pr_config_key_listed(const char *list, const char *key);

#endif
