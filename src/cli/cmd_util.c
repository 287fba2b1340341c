/* cmd_util.c — steps the table commands share (cmd_util.h). */
#define _POSIX_C_SOURCE 200809L /* O_CLOEXEC */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <sys/stat.h>

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

/* n bytes of fd into buf, retrying short reads; the count read. */
static size_t read_full(int fd, char *buf, size_t n)
{
	size_t got = 0;
	ssize_t k;

	while (got < n && ((k = read(fd, buf + got, n - got)) > 0 || (k < 0 && errno == EINTR)))
		got += k > 0 ? (size_t)k : 0;
	return got;
}

/* A regular file only (a device or a FIFO would be read without end, and
 * opening a FIFO would wait), its size taken once, and another file given
 * by mistake refused after its first bytes: neither read whole nor
 * allocated for (a sparse terabyte of zeros is refused at once). */
int pr_cmd_read_whole(const char *path, const char *magic, const char *not_it, char **text,
                      size_t *len, char *err)
{
	int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
	size_t n = 0, nm = strlen(magic);
	struct stat st;
	char *buf = NULL, head[64], extra;
	int rc = PR_OK;

	*text = NULL;
	*len = 0;
	if (fd < 0)
		return pr_err(err, PR_EIO, "%s: cannot open: %s", path, strerror(errno));
	if (nm > sizeof head)
		rc = pr_err(err, PR_EINVAL, "%s: magic longer than %zu bytes", path, sizeof head);
	else if (fstat(fd, &st) != 0)
		rc = pr_err(err, PR_EIO, "%s: cannot read: %s", path, strerror(errno));
	else if (!S_ISREG(st.st_mode))
		rc = pr_err(err, PR_EIO, "%s: not a regular file", path);
	else if ((n = read_full(fd, head, nm < (size_t)st.st_size ? nm : (size_t)st.st_size)) < nm ||
	         memcmp(head, magic, n))
		rc = pr_err(err, PR_EIO, "%s%s", path, not_it);
	else if (!(buf = malloc((size_t)st.st_size + 1)))
		rc = pr_err(err, PR_ENOMEM, "%s: out of memory", path);
	else if (memcpy(buf, head, n),
	         (n += read_full(fd, buf + n, (size_t)st.st_size - n)) != (size_t)st.st_size ||
	         read_full(fd, &extra, 1))
		rc = pr_err(err, PR_EIO, "%s: cannot read: the file changed while it was read", path);
	close(fd);
	if (rc)
		free(buf);
	else {
		*text = buf;
		*len = n;
	}
	return rc;
}
