/* config.h — parameter files (INI, libinih), --set overrides and validation.
 *
 * Order: pr_config_init (module defaults), pr_config_load (file),
 * pr_config_set (command line), pr_config_validate (cross-key checks).
 * Every error names file:line and section.key, e.g.
 * "data/exp3.ini:12: reps.epsilon: must be > 0 (got -1)". */
#ifndef POOLREPS_CONFIG_H
#define POOLREPS_CONFIG_H

#include <stdio.h>
#include "poolreps/common.h"
#include "poolreps/sim.h"
#include "poolreps/forest.h"
#include "poolreps/reps.h"
#include "poolreps/policy.h"
#include "poolreps/exp.h"

#define PR_CONFIG_MAXKEYS 128

typedef struct pr_config {
	pr_run_opts run;          /* experiment.* */
	pr_table table;           /* table.* */
	pr_sim_opts sim;          /* sim.* */
	pr_reward_opts reward;    /* reward.* */
	pr_start_opts start;      /* start.* */
	pr_expert_opts expert;    /* ghost.arrival_speed, exp1.aim_speed */
	pr_forest_opts forest;    /* forest.* (the forest command) */
	pr_reps_opts reps;        /* reps.* */
	pr_policy_opts policy;    /* policy.* */
	pr_forest_opts value;     /* value.*: forests for REPS value features */
	char value_features[16];  /* value.features: leaves | samples */
	pr_exp1_opts exp1;        /* exp1.* */
	pr_exp2_opts exp2;        /* exp2.* */
	pr_exp3_opts exp3;        /* exp3.* */
	pr_bench_opts bench;      /* bench.*: defaults follow experiment.name */
	char source[256];         /* the parameter file, or "" */
	int key_line[PR_CONFIG_MAXKEYS]; /* per key: file line, -1 for --set, 0 default;
	                                  * keys left at 0 follow experiment.name */
} pr_config;

void pr_config_init(pr_config *c);
/* Read an INI file; the first bad line or key stops with an error. */
int pr_config_load(pr_config *c, const char *path, char *err);
/* Apply "section.key=value" from --set. */
int pr_config_set(pr_config *c, const char *assignment, char *err);
/* Checks that involve several keys (e.g. n_c <= n_min, boxes inside the table). */
int pr_config_validate(const pr_config *c, char *err);
/* Where key "section.key" got its value, for messages: "file:line", "--set",
 * or for a default the parameter file (or "defaults"). Returns buf. */
const char *pr_config_where(const pr_config *c, const char *key, char *buf, size_t n);
/* The first key (in table order, other than those in skip, a NULL-ended
 * list of "section.key" names, or NULL) whose value differs between a and b:
 * its name into key and both values as written by pr_config_write into va
 * and vb (each n bytes, truncated). 0 if none. */
int pr_config_diff(const pr_config *a, const pr_config *b, const char *const *skip, char *key,
                   size_t nkey, char *va, char *vb, size_t n);
/* Write every key as INI (the effective configuration). */
int pr_config_write(const pr_config *c, FILE *fp);
/* List every key with default, unit and range. */
void pr_config_help(FILE *fp);

#endif
