/* reps_wide_priv.h — the linear algebra of wide REPS problems (reps.c):
 * the span of the features when there are at least as many as samples,
 * and the factorisations too large for GSL's reference BLAS, through
 * LAPACK on OpenBLAS (docs/reps_policy.md). */
#ifndef POOLREPS_REPS_WIDE_PRIV_H
#define POOLREPS_REPS_WIDE_PRIV_H

#include <stddef.h>

/* Symmetric matrices of at least this order are factorised by LAPACK
 * (OpenBLAS) instead of GSL: several times the largest Hessian of any
 * experiment, so their bits stay GSL's. */
#define PR_LAPACK_MIN 1024

/* The singular values and right singular vectors of the m x nf matrix W
 * (row-major, nf >= m >= 1): Householder QR of W^T (dgeqrf), the SVD of
 * the m x m triangular factor (dgesdd), and its singular vectors mapped
 * back by the Householder reflections (dormqr), O(m^2 nf + m^3). Fills s
 * (m, descending) and V (m x nf row-major: row k is the k-th right singular
 * vector). W is only read. Returns PR_OK, PR_ENOMEM or PR_ENUM. */
int pr_wide_span(int m, int nf, const double *W, double *s, double *V);

/* C = A B (m x r row-major) for A (m x k) and B (k x r), both row-major. */
void pr_wide_mul(int m, int k, int r, const double *A, const double *B, double *C);

/* Cholesky factor of the symmetric positive definite n x n matrix whose
 * lower triangle (diagonal included) is stored row-major in H with row
 * stride td: L into that lower triangle (dpotrf), the upper one kept.
 * Returns 0 on success, else not positive definite. */
int pr_lapack_cholesky(double *H, int n, size_t td);

#endif
