/* forest.h — extremely randomized trees (thesis ch. 4, 5.2, 6.1). */
#ifndef POOLREPS_FOREST_H
#define POOLREPS_FOREST_H

#include <stdio.h>

#include <gsl/gsl_rng.h>
#include "poolreps/common.h"

enum { PR_SCORE_RVR = 0, PR_SCORE_NRVR = 1 };
/* Several outputs: eq. 6.1/6.3 add the variance reductions as they are
 * (sum); relative divides each by its own node variance first. */
enum { PR_OUTPUTS_SUM = 0, PR_OUTPUTS_RELATIVE = 1 };

/* Forest parameters (keys forest.*, and the same fields under value.* and policy.*). */
typedef struct {
	int trees;            /* M */
	int cuts;             /* K random tests per node */
	int n_min;            /* split nodes holding more than n_min samples */
	int n_c;              /* drop splits leaving a child with fewer than n_c */
	int score;            /* PR_SCORE_RVR (eq. 4.1) or PR_SCORE_NRVR (7.5.1) */
	int with_replacement; /* 1: cut dimensions drawn with replacement */
	int outputs;          /* PR_OUTPUTS_SUM (eq. 6.1, 6.3) or PR_OUTPUTS_RELATIVE */
} pr_forest_opts;
void pr_forest_opts_init(pr_forest_opts *o);

typedef struct pr_forest pr_forest;

/* Fit M trees on n samples: X is n x dx and Y n x dy, row-major; w holds n
 * non-negative weights (eq. 6.2-6.3) or is NULL for unit weights. The forest
 * keeps sample indices per leaf, not copies of X. One draw from rng seeds the
 * forest; tree t's stream derives from (that draw, t). Caller frees.
 * NULL with a message in err for bad options or data (non-finite values,
 * negative weights or weights summing to 0, n < n_c), out of memory, or
 * when pr_interrupted is set. Safe to call from several threads.
 * The weights' scale does not matter: they are used times the power of two
 * that brings the largest into [0.5, 1), exactly. */
pr_forest *pr_forest_fit(const pr_forest_opts *o, const double *X, int n, int dx,
                         const double *Y, int dy, const double *w, gsl_rng *rng,
                         char *err);
void pr_forest_free(pr_forest *f);

int pr_forest_ntrees(const pr_forest *f);
int pr_forest_nleaves(const pr_forest *f);   /* n_F, all trees */
int pr_forest_nsamples(const pr_forest *f);
int pr_forest_dx(const pr_forest *f);
int pr_forest_dy(const pr_forest *f);

/* Forest prediction, eq. 4.2-4.3, for nq row-major inputs X (nq x dx) into
 * Y (nq x dy): the mean over trees of leaf means (tree-major order keeps
 * each tree in cache). */
void pr_forest_predict_many(const pr_forest *f, const double *X, int nq, double *Y);

/* Active leaves (eq. 5.1-5.4) of an input with dq <= dx leading dimensions;
 * a test on a dimension >= dq sends x down both branches (state-only query
 * of a state-action forest). Writes global leaf ids (0..n_F-1, tree-major)
 * into leaves (capacity cap) and returns their count, or a negative status
 * (PR_EINVAL for dq outside 0..dx or more than cap active leaves, PR_ENOMEM
 * for a stack deeper than 64 levels that cannot be allocated; cap =
 * pr_forest_nleaves always suffices, and M when dq = dx). Within a tree the
 * ids come in increasing order. */
int pr_forest_active(const pr_forest *f, const double *x, int dq, int *leaves, int cap);

/* Training samples in global leaf `leaf`: returns the count and points *idx
 * at the forest's own index array (valid until pr_forest_free). */
int pr_forest_leaf_samples(const pr_forest *f, int leaf, const int **idx);

/* Inspection. Tree t owns global leaves pr_forest_tree_leaf0(f, t) up to
 * pr_forest_tree_leaf0(f, t + 1) - 1 (t = M gives n_F), numbered left to
 * right; the local leaf index is the global id minus the first. */
int pr_forest_tree_leaf0(const pr_forest *f, int t);
/* The dy leaf values of a global leaf (eq. 4.2; weighted mean when fitted
 * with weights). Owned by the forest. */
const double *pr_forest_leaf_mean(const pr_forest *f, int leaf);

/* Saving and loading a fitted forest (docs/forest.md, "File format"): a
 * text format whose first line is "poolreps-forest V"; numbers are written
 * as C99 hexadecimal floats, so a loaded forest predicts bit for bit as the
 * saved one. PR_FOREST_FORMAT is the version this library writes and the
 * only one it reads. */
#define PR_FOREST_FORMAT 1
/* Write f to fp. names: NULL (then x0.., y0..) or dx + dy column names,
 * inputs then outputs, none empty or holding a line break. PR_OK, PR_EINVAL
 * (a bad name) or PR_EIO (a write error). */
int pr_forest_save(const pr_forest *f, FILE *fp, const char *const *names, char *err);
/* The same into a new buffer: *text (*len bytes, NUL-terminated; free()). */
int pr_forest_to_text(const pr_forest *f, const char *const *names, char **text, size_t *len,
                      char *err);
/* A forest from len bytes of text in that format; `what` names it in
 * messages ("FILE:LINE: ..."). With names not NULL, *names receives the
 * dx + dy column names in one allocation (free() it). NULL with err:
 * PR_EINVAL "WHAT: forest format version V, this library reads version
 * PR_FOREST_FORMAT" for another version, PR_EIO for malformed text (every
 * index is checked: a loaded forest is safe to query), PR_ENOMEM. */
pr_forest *pr_forest_load(const char *text, size_t len, const char *what, char ***names,
                          char *err);

#endif
