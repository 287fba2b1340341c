/* config.h — parameter files (INI, libinih), --set overrides and validation.
 *
 * A pr_config holds the options of the library's modules (table, sim, reward,
 * start, ghost, forest, value, reps, policy) and the experiment.* keys, plus
 * one block of options per experiment. config.c knows no experiment: the
 * experiments' keys, options and per-experiment defaults come from a schema,
 * the experiment registry's pr_exp_config (exp.h), handed to pr_config_init.
 *
 * Order: pr_config_init (defaults), pr_config_load (file), pr_config_set
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

#define PR_CONFIG_MAXKEYS 128       /* keys of the modules and every experiment */
#define PR_CONFIG_MAXBLOCKS 16      /* experiments' option blocks */
#define PR_CONFIG_OPTS_BYTES 8192   /* room for the experiments' option blocks */
#define PR_CONFIG_SOURCE_LEN 256    /* the parameter file's name */
#define PR_WHERE_LEN 320            /* pr_config_where's answer: "file:line" */

#define PR_LIST_MAX 64

/* A list-valued key such as "10,20,50". */
typedef struct {
	int n;
	double v[PR_LIST_MAX];
} pr_list;

/* Variants of one experiment at most (experiment.variant is below this). */
#define PR_VARIANTS_MAX (3 * PR_LIST_MAX + 1)

/* Keys experiment.*: which experiment a parameter file runs. */
typedef struct {
	char name[32];        /* a registered experiment (pr_exp_find) */
	unsigned long seed;   /* master seed; --seed overrides */
	int repetitions;      /* independent repetitions */
	int repetition;       /* -1: all; k: only repetition k (sweeps) */
	int variant;          /* -1: all; v: only variant v (sweeps; pr_exp_variants) */
	int threads;          /* repetitions run on this many threads */
} pr_run_opts;


/* An experiment's option block and per-experiment defaults (config_priv.h). */
struct pr_config_block;
struct pr_config_exp;
/* The schema: fills *out with the i-th experiment and returns 1, or returns
 * 0 past the last one. The experiments' keys follow the modules' keys, block
 * by block in this order (a block shared by several experiments once). */
typedef int (*pr_config_schema)(int i, struct pr_config_exp *out);

typedef struct pr_config {
	pr_run_opts run;          /* experiment.* */
	pr_table table;           /* table.* */
	pr_sim_opts sim;          /* sim.* */
	pr_reward_opts reward;    /* reward.* */
	pr_start_opts start;      /* start.* */
	pr_expert_opts expert;    /* ghost.* */
	pr_forest_opts forest;    /* forest.* (the forest command) */
	pr_reps_opts reps;        /* reps.* */
	pr_policy_opts policy;    /* policy.* */
	pr_forest_opts value;     /* value.*: forests for REPS value features */
	int value_features;       /* value.features: PR_VALUE_* */
	pr_learner_opts learner;  /* learner.* (its value, reps and policy parts unused) */
	/* the experiments' option blocks, read through pr_config_opts */
	pr_config_schema schema;
	int nblocks;
	const struct pr_config_block *block[PR_CONFIG_MAXBLOCKS];
	size_t block_off[PR_CONFIG_MAXBLOCKS];
	int dropped;              /* blocks that did not fit: pr_config_validate fails */
	union {
		max_align_t align;
		unsigned char bytes[PR_CONFIG_OPTS_BYTES];
	} opts;
	char source[PR_CONFIG_SOURCE_LEN]; /* the parameter file, or "" */
	int key_line[PR_CONFIG_MAXKEYS]; /* per key: file line, -1 for --set, 0 default;
	                                  * keys left at 0 follow experiment.name */
} pr_config;

/* Defaults of the modules and of every experiment of schema. */
void pr_config_init(pr_config *c, pr_config_schema schema);
/* Read an INI file; the first bad line or key stops with an error. */
int pr_config_load(pr_config *c, const char *path, char *err);
/* Apply "section.key=value" from --set. */
int pr_config_set(pr_config *c, const char *assignment, char *err);
/* The options of a learner: learner.*, value.*, reps.* and policy.*. */
void pr_config_learner_opts(const pr_config *c, pr_learner_opts *o);
/* Checks that involve several keys (e.g. n_c <= n_min, boxes inside the table). */
int pr_config_validate(const pr_config *c, char *err);

/* 1 if key ("section.key") is in list, a comma list of whole names and of
 * sections ending in '.': "forest.,experiment.seed". */
int pr_config_key_listed(const char *list, const char *key);

#endif
