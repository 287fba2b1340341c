/* exp_priv.h — internals shared by the experiments (src/exp*.c): their
 * entry points for the registry in exp.c, a repetition thread pool,
 * thread-safe progress and a reader for raw CSVs with text columns. */
#ifndef POOLREPS_EXP_PRIV_H
#define POOLREPS_EXP_PRIV_H

#include <pthread.h>

#include "poolreps/config.h"
#include "poolreps/exp.h"

/* ---- entry points (pr_experiment.run / .summarize) ---- */

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

#endif
