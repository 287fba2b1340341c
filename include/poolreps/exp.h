/* exp.h — the experiments of thesis chapter 7 and the REPS benchmarks. */
#ifndef POOLREPS_EXP_H
#define POOLREPS_EXP_H

#include <gsl/gsl_rng.h>
#include "poolreps/common.h"
#include "poolreps/config.h"

/* Contextual policy-search methods of the REPS benchmarks and of Experiment
 * 3's hand-crafted loop: episodic contextual REPS with a weighted-ML
 * linear-Gaussian policy, or contextual CMA-ES (cmaes.h). */
enum { PR_METHOD_CREPS = 0, PR_METHOD_CCMAES = 1 };

/* Progress callback: `done` of `total` units of `what` finished. The CLI
 * draws it; the library only calls it (it may be NULL). */
typedef struct {
	void (*fn)(void *user, long done, long total, const char *what);
	void *user;
} pr_progress;

/* The variants of an experiment: parts of one repetition that draw from
 * their own streams, so each can run alone (experiment.variant = its index)
 * and write exactly the rows it writes inside the full run. */
typedef struct {
	int n;
	char name[PR_VARIANTS_MAX][32];  /* in output order */
} pr_variants;

/* An experiment writes raw per-repetition CSVs whose first column is
 * `repetition` (run), then derived CSVs computed from those alone
 * (summarize), so that `poolreps merge` can rebuild the derived files from
 * merged raw files byte for byte. Repetition k draws only from a stream
 * derived from (experiment.seed, k); within a repetition, rows come in
 * variant order. */
typedef struct {
	const char *name;
	int (*run)(const pr_config *cfg, const char *dir, const pr_progress *prog, char *err);
	int (*summarize)(const pr_config *cfg, const char *dir, char *err); /* or NULL */
	int (*variants)(const pr_config *cfg, pr_variants *out, char *err); /* or NULL: none */
	const char *summary;  /* the derived CSV `poolreps collect` tabulates, or NULL */
	/* its keys and options (config_priv.h), or NULL; experiments may share a block */
	const struct pr_config_block *keys;
	/* its defaults for keys of any section, ended by {NULL, NULL}; or NULL */
	const struct pr_config_default *defaults;
	/* another experiment's block whose keys it reads too (exp4: exp3's), or NULL */
	const struct pr_config_block *reads;
	/* what `poolreps help experiments` lists and the pipeline scripts read:
	 * the folder a run writes under results/ by default, the kind
	 * ("figures", "experiment" or "benchmark": which script draws it) and a
	 * title (no comma) */
	const char *folder;
	const char *kind;
	const char *title;
} pr_experiment;

/* The experiment called `name`, or NULL. */
const pr_experiment *pr_exp_find(const char *name);

#endif
