/* reps_wide.c — LAPACK (on OpenBLAS) for wide REPS problems: the span of
 * d >= n features, and factorisations of order PR_LAPACK_MIN and more
 * (reps_wide_priv.h). Row-major arrays are handed to the column-major
 * routines as their transposes. */
#include <stdlib.h>
#include <string.h>

#include <lapacke.h>

#include "poolreps/common.h"
#include "reps_wide_priv.h"

/* BLAS's Fortran entry point (OpenBLAS): GSL keeps the cblas_ names of its
 * own reference BLAS, so every product GSL computes keeps its bits. */
void dgemm_(const char *ta, const char *tb, const int *m, const int *n, const int *k,
            const double *alpha, const double *a, const int *lda, const double *b,
            const int *ldb, const double *beta, double *c, const int *ldc);

int pr_wide_span(int m, int nf, const double *W, double *s, double *V)
{
	/* W's buffer is W^T in column-major order: nf x m, leading dimension nf */
	double *A = malloc((size_t)m * nf * sizeof *A), *tau = malloc((size_t)m * sizeof *tau);
	double *R = calloc((size_t)m * m, sizeof *R), *U = malloc((size_t)m * m * sizeof *U);
	double *Vt = malloc((size_t)m * m * sizeof *Vt);
	int i, j, st = PR_ENOMEM;

	if (!A || !tau || !R || !U || !Vt)
		goto done;
	memcpy(A, W, (size_t)m * nf * sizeof *A);
	st = PR_ENUM;
	if (LAPACKE_dgeqrf(LAPACK_COL_MAJOR, nf, m, A, nf, tau) != 0)
		goto done;
	/* W^T = Q R and R = U S Vt: W = Vt^T S (Q U)^T, so W's right singular
	 * vectors are Q U, formed by orthogonal transformations (accurate to
	 * round-off in every direction, however small its singular value) */
	for (j = 0; j < m; j++)
		for (i = 0; i <= j; i++)
			R[i + (size_t)j * m] = A[i + (size_t)j * nf];
	if (LAPACKE_dgesdd(LAPACK_COL_MAJOR, 'S', m, m, R, m, s, U, m, Vt, m) != 0)
		goto done;
	memset(V, 0, (size_t)m * nf * sizeof *V);
	for (j = 0; j < m; j++)
		memcpy(V + (size_t)j * nf, U + (size_t)j * m, (size_t)m * sizeof *V);
	if (LAPACKE_dormqr(LAPACK_COL_MAJOR, 'L', 'N', nf, m, m, A, nf, tau, V, nf) != 0)
		goto done;
	st = PR_OK;
done:
	free(A);
	free(tau);
	free(R);
	free(U);
	free(Vt);
	return st;
}

void pr_wide_mul(int m, int k, int r, const double *A, const double *B, double *C)
{
	const double one = 1.0, zero = 0.0;

	/* column-major: C^T (r x m) = B^T (r x k) A^T (k x m) */
	if (r > 0)
		dgemm_("N", "N", &r, &m, &k, &one, B, &r, A, &k, &zero, C, &r);
}

int pr_lapack_cholesky(double *H, int n, size_t td)
{
	/* the row-major lower triangle is the column-major upper one: H = U^T U
	 * with U = L^T */
	return LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'U', n, H, (int)td) != 0;
}
