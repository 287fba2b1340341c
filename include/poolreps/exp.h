/* exp.h — the experiments of thesis chapter 7 and the REPS benchmarks. */
#ifndef POOLREPS_EXP_H
#define POOLREPS_EXP_H

#include <gsl/gsl_rng.h>
#include "poolreps/common.h"

#define PR_LIST_MAX 64

/* A list-valued key such as "10,20,50". */
typedef struct {
	int n;
	double v[PR_LIST_MAX];
} pr_list;

/* Keys experiment.*: which experiment a parameter file runs. */
typedef struct {
	char name[32];        /* exp1, exp2, exp3, figures, quadratic, sphere, rosenbrock */
	unsigned long seed;   /* master seed; --seed overrides */
	int repetitions;      /* independent repetitions */
	int repetition;       /* -1: all; k: only repetition k (sweeps) */
	int threads;          /* repetitions run on this many threads */
} pr_run_opts;
void pr_run_opts_init(pr_run_opts *o);

/* Progress callback: `done` of `total` units of `what` finished. The CLI
 * draws it; the library only calls it (it may be NULL). */
typedef struct {
	void (*fn)(void *user, long done, long total, const char *what);
	void *user;
} pr_progress;

struct pr_config;

/* An experiment writes raw per-repetition CSVs whose first column is
 * `repetition` (run), then derived CSVs computed from those alone
 * (summarize), so that `poolreps merge` can rebuild the derived files from
 * merged raw files byte for byte. Repetition k draws only from a stream
 * derived from (experiment.seed, k). */
typedef struct {
	const char *name;
	int (*run)(const struct pr_config *cfg, const char *dir, const pr_progress *prog, char *err);
	int (*summarize)(const struct pr_config *cfg, const char *dir, char *err); /* or NULL */
} pr_experiment;

/* The experiment called `name`, or NULL. */
const pr_experiment *pr_exp_find(const char *name);

/* A gsl_rng (mt19937) seeded from (seed, stream, index) by a hash, so that
 * every repetition and purpose has its own reproducible stream. Caller frees. */
gsl_rng *pr_exp_rng(unsigned long seed, unsigned long stream, unsigned long index);

/* The repetitions [*lo, *hi) this process runs (experiment.repetition). */
void pr_exp_reps(const struct pr_config *cfg, int *lo, int *hi);

#endif
