/* config_priv.h — the key tables behind pr_config, for the modules' keys
 * (config.c) and the experiments' (src/exp*.c).
 *
 * An experiment brings a pr_config_block: its options struct (size, init,
 * check) and the table of its keys, whose offsets are into that struct. Its
 * registry entry (exp.c) names the block and the experiment's defaults for
 * keys of any section: rows "section.key" = "value" that replace the
 * defaults while experiment.name names it (what data/<name>.ini states), so
 * that a file naming only the experiment runs its setup. A key that some
 * experiment overrides follows experiment.name until it is set explicitly. */
#ifndef POOLREPS_CONFIG_PRIV_H
#define POOLREPS_CONFIG_PRIV_H

#include <stddef.h>

#include "poolreps/config.h"

/* Value types of a key. */
enum {
	PR_KEY_DOUBLE,     /* double */
	PR_KEY_INT,        /* int */
	PR_KEY_LONG,       /* long */
	PR_KEY_ULONG,      /* unsigned long */
	PR_KEY_ENUM,       /* int: index of the value in unit "a|b|c" */
	PR_KEY_NAMES,      /* char[PR_KEY_NAMES_LEN]: comma list of distinct names of unit */
	PR_KEY_POCKETS,    /* pr_reward_opts: targets and ntargets */
	PR_KEY_BOX,        /* double[4]: xmin,xmax,ymin,ymax */
	PR_KEY_LIST,       /* pr_list of numbers in [lo, hi] */
	PR_KEY_ILIST,      /* pr_list of whole numbers in [lo, hi] */
	PR_KEY_EXPERIMENT  /* pr_run_opts.name: a name of the schema */
};
#define PR_KEY_NAMES_LEN 128

/* Open bounds (pr_config_key.open): that bound itself is excluded. */
enum { PR_KEY_OPEN_LO = 1, PR_KEY_OPEN_HI = 2 };

/* A bound that leaves a value unlimited (boxes). */
#define PR_KEY_UNBOUNDED 1e300
/* The largest sample count a key or a raw CSV may give (n_min, sizes). */
#define PR_KEY_COUNT_MAX 100000000

typedef struct {
	const char *section, *key;
	int type;          /* PR_KEY_* */
	size_t off;        /* offset of the field in its block's options struct */
	double lo, hi;     /* range (for lists: of each element) */
	int open;          /* PR_KEY_OPEN_* */
	const char *unit;  /* or, for PR_KEY_ENUM and PR_KEY_NAMES, the choices "a|b|c" */
	const char *help;  /* one line; a default that depends on the experiment is named */
} pr_config_key;

/* An experiment's options. */
typedef struct pr_config_block {
	const pr_config_key *keys;
	int nkeys;
	size_t size;                                 /* of the options struct */
	void (*init)(void *opts);                    /* its defaults */
	int (*check)(const void *opts, char *err);   /* or NULL; "section.key: ..." */
} pr_config_block;

/* A default of one experiment: "section.key" and its value as in a file. */
typedef struct pr_config_default {
	const char *key, *value;
} pr_config_default;

/* One experiment of the schema. */
typedef struct pr_config_exp {
	const char *name;                   /* experiment.name */
	const pr_config_block *block;       /* or NULL; several may share one */
	const pr_config_default *defaults;  /* ended by {NULL, NULL}; or NULL */
	const pr_config_block *reads;       /* another block it reads too, or NULL */
} pr_config_exp;

#endif
