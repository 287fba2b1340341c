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
	int variant;          /* -1: all; v: only variant v (sweeps; pr_exp_variants) */
	int threads;          /* repetitions run on this many threads */
} pr_run_opts;
void pr_run_opts_init(pr_run_opts *o);

/* Experiment 1 (thesis 7.3, keys exp1.*). Forests per setting =
 * experiment.repetitions; repetition k trains on training rows
 * [k*subset, (k+1)*subset) and tests on test rows [k*test_subset, ...). */
typedef struct {
	int train, test;       /* shots simulated for training and testing */
	int subset;            /* training samples per forest */
	int test_subset;       /* test samples per forest */
	pr_list n_min_list;    /* Fig. 7.4a sweep (K, M at forest.* values) */
	pr_list trees_list;    /* Fig. 7.4b sweep */
	pr_list cuts_list;     /* Fig. 7.4c sweep */
	int map_grid;          /* predicted-vs-simulated reward map: grid points per side */
} pr_exp1_opts;
void pr_exp1_opts_init(pr_exp1_opts *o);

/* Experiment 2 (thesis 7.4, keys exp2.*). */
typedef struct {
	pr_list sizes;         /* training-set sizes */
	int test;              /* test shots per size and policy */
	double n_min_frac;     /* tree policies: n_min = frac * training size */
} pr_exp2_opts;
void pr_exp2_opts_init(pr_exp2_opts *o);

/* Contextual policy-search methods of the REPS benchmarks and of Experiment
 * 3's hand-crafted loop: episodic contextual REPS with a weighted-ML
 * linear-Gaussian policy, or contextual CMA-ES (cmaes.h). */
enum { PR_METHOD_CREPS = 0, PR_METHOD_CCMAES = 1 };

/* Experiment 3 (thesis 7.5, keys exp3.*). */
typedef struct {
	int init_samples;      /* samples of the initial policy */
	double init_std;       /* initial policy N(0, init_std^2 I), m/s */
	int iterations;        /* REPS iterations */
	int samples;           /* new samples per iteration */
	int window;            /* samples REPS reuses, importance weighted */
	char policies[128];    /* comma list of variants */
	int baseline_n_min;    /* n_min of the single-node baseline policy */
	int final_episodes;    /* Figs. 7.8-7.10 use each run's last episodes */
	int handcrafted_method; /* PR_METHOD_*: the hand-crafted variant's learner */
} pr_exp3_opts;
void pr_exp3_opts_init(pr_exp3_opts *o);

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

/* Progress callback: `done` of `total` units of `what` finished. The CLI
 * draws it; the library only calls it (it may be NULL). */
typedef struct {
	void (*fn)(void *user, long done, long total, const char *what);
	void *user;
} pr_progress;

struct pr_config;

/* The variants of an experiment: parts of one repetition that draw from
 * their own streams, so each can run alone (experiment.variant = its index)
 * and write exactly the rows it writes inside the full run. */
#define PR_VARIANTS_MAX (3 * PR_LIST_MAX + 1)
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
	int (*run)(const struct pr_config *cfg, const char *dir, const pr_progress *prog, char *err);
	int (*summarize)(const struct pr_config *cfg, const char *dir, char *err); /* or NULL */
	int (*variants)(const struct pr_config *cfg, pr_variants *out, char *err); /* or NULL: none */
	const char *summary;  /* the derived CSV `poolreps collect` tabulates, or NULL */
} pr_experiment;

/* The experiment called `name`, or NULL. */
const pr_experiment *pr_exp_find(const char *name);

/* A gsl_rng (mt19937) seeded from (seed, stream, index) by a hash, so that
 * every repetition and purpose has its own reproducible stream. Caller frees. */
gsl_rng *pr_exp_rng(unsigned long seed, unsigned long stream, unsigned long index);

/* The repetitions [*lo, *hi) this process runs (experiment.repetition). */
void pr_exp_reps(const struct pr_config *cfg, int *lo, int *hi);

/* The variants of cfg's experiment (n = 0 for one without); PR_EINVAL naming
 * experiment.variant when it is set but not below their count. */
int pr_exp_variants(const struct pr_config *cfg, pr_variants *out, char *err);

/* PR_EINVAL naming experiment.variant unless it is -1 or below n. */
int pr_exp_check_variant(const struct pr_config *cfg, int n, char *err);

#endif
