/* cmd_util.h — the steps the table commands (forest, reps, policy) share
 * (cmd_util.c): a table's row count, its columns by name or list, a matrix
 * of selected columns, a weight column. Messages name the file, the line
 * and the column. Several outputs of one command are committed together
 * through pr_outset (csvio.h). */
#ifndef POOLREPS_CMD_UTIL_H
#define POOLREPS_CMD_UTIL_H

#include "poolreps/csvio.h"

/* Rows a table may hold: the library indexes samples with int. */
#define PR_CMD_MAX_ROWS 100000000L

/* PR_EIO unless t has 1 .. PR_CMD_MAX_ROWS data rows: "no data rows", or
 * the count over the limit. */
int pr_cmd_check_rows(const pr_csv *t, char *err);

/* The column called name, or PR_EIO "file:1: missing column 'name' (opt)". */
int pr_cmd_column(const pr_csv *t, const char *name, const char *opt, char *err);

/* The columns of list (pr_csv_select: "a,b" or a prefix "phi*") into a
 * new array *cols (caller frees); returns their count or a negative status. */
int pr_cmd_columns(const pr_csv *t, const char *list, int **cols, char *err);

/* A new n x k row-major matrix of columns cols of every row of t (n =
 * pr_csv_nrows(t), at least one row allocated); NULL and PR_ENOMEM. */
double *pr_cmd_matrix(const pr_csv *t, const int *cols, int k, char *err);

/* The weights of column col (1 for every row when col < 0) into a new
 * array *w: each >= 0 and not all zero; what names them in messages
 * ("weight", "base weight") and name is the column's option value. */
int pr_cmd_weights(const pr_csv *t, int col, const char *name, const char *what, double **w,
                   char *err);

/* PR_EINVAL if a column is in both lists a (na columns, named an in the
 * message, e.g. "a state") and b: "file: column 'x' is both a state and an action". */
int pr_cmd_disjoint(const pr_csv *t, const int *a, int na, const char *an, const int *b, int nb,
                    const char *bn, char *err);

#endif
