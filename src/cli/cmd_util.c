/* cmd_util.c — steps the table commands share (cmd_util.h). */
#include <math.h>
#include <stdlib.h>

#include "cli.h"

int pr_cmd_check_rows(const pr_csv *t, char *err)
{
	long n = pr_csv_nrows(t);

	if (n < 1)
		return pr_err(err, PR_EIO, "%s: no data rows", pr_csv_path(t));
	if (n > PR_CMD_MAX_ROWS)
		return pr_err(err, PR_EIO, "%s: %ld data rows, more than %ld", pr_csv_path(t), n,
		              PR_CMD_MAX_ROWS);
	return PR_OK;
}

int pr_cmd_column(const pr_csv *t, const char *name, const char *opt, char *err)
{
	int c = pr_csv_find(t, name);

	return c >= 0 ? c : pr_err(err, PR_EIO, "%s:1: missing column '%s' (%s)", pr_csv_path(t), name,
	                           opt);
}

int pr_cmd_columns(const pr_csv *t, const char *list, int **cols, char *err)
{
	int nc = pr_csv_ncols(t), k;

	if (!(*cols = malloc((size_t)nc * sizeof **cols)))
		return pr_err(err, PR_ENOMEM, "out of memory");
	k = pr_csv_select(t, list, *cols, nc, err);
	return k < 0 ? PR_EIO : k;
}

double *pr_cmd_matrix(const pr_csv *t, const int *cols, int k, char *err)
{
	long i, n = pr_csv_nrows(t);
	double *X = malloc(((size_t)n + 1) * (size_t)(k > 0 ? k : 1) * sizeof *X);
	int j;

	if (!X) {
		pr_err(err, PR_ENOMEM, "out of memory");
		return NULL;
	}
	for (i = 0; i < n; i++) {
		const double *row = pr_csv_row(t, i);

		for (j = 0; j < k; j++)
			X[(size_t)i * k + j] = row[cols[j]];
	}
	return X;
}

int pr_cmd_weights(const pr_csv *t, int col, const char *name, const char *what, double **w,
                   char *err)
{
	long i, n = pr_csv_nrows(t), bad;
	char why[PR_ERRLEN];

	if (!(*w = malloc(((size_t)n + 1) * sizeof **w)))
		return pr_err(err, PR_ENOMEM, "out of memory");
	for (i = 0; i < n; i++)
		(*w)[i] = col >= 0 ? pr_csv_get(t, i, col) : 1.0;
	/* the library's check, which the Python binding runs too */
	if (!pr_weights_check(*w, n, what, &bad, why))
		return PR_OK;
	if (bad >= 0)
		return pr_err(err, PR_EINVAL, "%s:%ld: column '%s': %s", pr_csv_path(t), pr_csv_line(t, bad),
		              name, why);
	return pr_err(err, PR_EINVAL, "%s: column '%s': %s", pr_csv_path(t), name, why);
}

int pr_cmd_disjoint(const pr_csv *t, const int *a, int na, const char *an, const int *b, int nb,
                    const char *bn, char *err)
{
	int i, j;

	for (i = 0; i < na; i++)
		for (j = 0; j < nb; j++)
			if (a[i] == b[j])
				return pr_err(err, PR_EINVAL, "%s: column '%s' is both %s and %s", pr_csv_path(t),
				              pr_csv_name(t, a[i]), an, bn);
	return PR_OK;
}
