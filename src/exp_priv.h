/* exp_priv.h — internals shared by the experiments (src/exp*.c): what
 * each brings to the registry in exp.c (entry points, key block, defaults),
 * a repetition thread pool, thread-safe progress and a reader for raw CSVs
 * with text columns.
 *
 * Adding an experiment: a source file with its options struct and _init,
 * its key table and pr_config_block (config_priv.h), its defaults for other
 * sections, run/summarize (and variants if it has any), declared here; its
 * random streams in streams.h; one line in exp.c's registry. */
#ifndef POOLREPS_EXP_PRIV_H
#define POOLREPS_EXP_PRIV_H

#include <pthread.h>

#include "poolreps/config.h"
#include "poolreps/csvio.h"
#include "poolreps/exp.h"
#include "common_priv.h"
#include "config_priv.h"

/* ---- options ---- */

/* Experiment 1 (thesis 7.3, keys exp1.*). Forests per setting =
 * experiment.repetitions; repetition k trains on training rows
 * [k*subset, (k+1)*subset) and tests on test rows [k*test_subset, ...). */
typedef struct {
	double aim_speed;      /* m/s: the data policy's cue speed, aimed at the reward ball */
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

/* The key blocks (cfg's options: pr_config_opts(cfg, &block)) and the
 * defaults each experiment sets for other sections. Experiment 3's options
 * are in exp3_priv.h. */
extern const pr_config_block pr_exp1_keys, pr_exp2_keys, pr_exp3_keys, pr_exp4_keys,
	pr_bench_keys;
extern const pr_config_default pr_exp2_defaults[], pr_exp3_defaults[];
extern const pr_config_default pr_quadratic_defaults[], pr_sphere_defaults[],
	pr_rosenbrock_defaults[];

/* ---- entry points (pr_experiment.run / .summarize) ---- */

/* The simulator figures (figures.h): no repetitions, no progress. */
int pr_figures_run(const pr_config *cfg, const char *dir, const pr_progress *prog, char *err);

/* Experiment 1 (thesis 7.3): raw exp1_mse.csv, exp1_map.csv; derived exp1_summary.csv. */
int pr_exp1_run(const pr_config *cfg, const char *dir, const pr_progress *prog, char *err);
int pr_exp1_summarize(const pr_config *cfg, const char *dir, char *err);
/* Variants: every setting of the n_min, trees and cuts sweeps ("n_min=20"),
 * then the reward map ("map"). */
int pr_exp1_variants(const pr_config *cfg, pr_variants *out, char *err);
/* Experiment 2 (thesis 7.4): raw exp2_returns.csv; derived exp2_summary.csv. */
int pr_exp2_run(const pr_config *cfg, const char *dir, const pr_progress *prog, char *err);
int pr_exp2_summarize(const pr_config *cfg, const char *dir, char *err);
/* Experiment 3 (thesis 7.5): raw exp3_episodes.csv, exp3_reps.csv; derived
 * exp3_curve.csv, exp3_final.csv, exp3_pockets.csv, exp3_dist.csv,
 * exp3_reps_summary.csv. */
int pr_exp3_run(const pr_config *cfg, const char *dir, const pr_progress *prog, char *err);
int pr_exp3_summarize(const pr_config *cfg, const char *dir, char *err);
/* Variants: the policies of exp3.policies, in its order. */
int pr_exp3_variants(const pr_config *cfg, pr_variants *out, char *err);
/* Experiment 4 (beyond the thesis: imitation, then Experiment 3's REPS):
 * raw exp4_episodes.csv, exp4_reps.csv, exp4_demo.csv, exp4_fit.csv;
 * derived exp4_curve.csv, exp4_final.csv, exp4_pockets.csv, exp4_dist.csv,
 * exp4_reps_summary.csv, exp4_verdict.csv. */
int pr_exp4_run(const pr_config *cfg, const char *dir, const pr_progress *prog, char *err);
int pr_exp4_summarize(const pr_config *cfg, const char *dir, char *err);
/* Variants: policy.init.cov labels (exp3.policies x exp4.covs x exp4.inits). */
int pr_exp4_variants(const pr_config *cfg, pr_variants *out, char *err);

/* ---- repetitions on threads ---- */

/* Thread-safe progress: workers add finished units; the callback runs under
 * a mutex, so it is never entered by two threads at once. */
typedef struct {
	const pr_progress *prog;  /* may be NULL */
	const char *what;
	long done, total;
	pthread_mutex_t mu;
} pr_exp_ticker;
void pr_exp_ticker_init(pr_exp_ticker *t, const pr_progress *prog, long total, const char *what);
void pr_exp_ticker_add(pr_exp_ticker *t, long units);
void pr_exp_ticker_destroy(pr_exp_ticker *t);

/* Run job(ctx, k, err) for every repetition k in [lo, hi) on `threads`
 * threads (1: in the calling thread). Repetition k is handed to the next free
 * thread, so jobs must write only their own per-repetition results. After a
 * failure no new repetition starts. Returns PR_OK or the status of the
 * lowest failing repetition, with its message in err. */
int pr_exp_parallel(int lo, int hi, int threads, int (*job)(void *ctx, int k, char *err),
                    void *ctx, char *err);

/* An experiment's output CSV at the path fmt formats (e.g. "%s/exp1_mse.csv"
 * with the folder), opened for writing; NULL with err set if it cannot be. */
pr_csvw *pr_exp_csv_open(char *err, const char *fmt, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 2, 3)))
#endif
	;

/* ---- raw CSVs with text columns ---- */

/* A CSV read as text: a header row and rows of equally many fields. */
typedef struct pr_exp_table pr_exp_table;
/* Read path (it must end with a line end); errors name file and line.
 * *out is owned by the caller. */
int pr_exp_table_read(const char *path, pr_exp_table **out, char *err);
void pr_exp_table_free(pr_exp_table *t);
long pr_exp_table_nrows(const pr_exp_table *t);
int pr_exp_table_ncols(const pr_exp_table *t);
/* Name of column j (the header row), owned by t. */
const char *pr_exp_table_name(const pr_exp_table *t, int j);
const char *pr_exp_table_path(const pr_exp_table *t);
/* The file line of data row i, for messages. */
long pr_exp_table_line(const pr_exp_table *t, long i);
/* Column index of name, or PR_EIO and "path: no column 'name'". */
int pr_exp_table_col(const pr_exp_table *t, const char *name, char *err);
/* Field (row i, column j) as text, owned by t. */
const char *pr_exp_table_str(const pr_exp_table *t, long i, int j);
/* Field as a finite number; PR_EIO naming file, line and column otherwise. */
int pr_exp_table_num(const pr_exp_table *t, long i, int j, double *v, char *err);
/* Field as an integer in [lo, hi]; PR_EIO otherwise. */
int pr_exp_table_int(const pr_exp_table *t, long i, int j, long lo, long hi, long *v, char *err);

/* A list key whose values must be integers >= 1 (counts such as n_min). */
int pr_exp_int_list(const pr_list *l, const char *key, int *out, char *err);

/* A start state of nballs balls (s, 2 * nballs values) where the ghost-ball
 * expert (pr_sim_ghost_action) has a shot, and that shot: states where it
 * has none are drawn again, at most start.max_tries times. */
int pr_exp_expert_state(const pr_config *cfg, int nballs, gsl_rng *rng, double *s, double a[2],
                        char *err);

#endif
