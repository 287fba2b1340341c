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
 * vector). W is only read. Returns PR_OK, PR_ENOMEM or PR_ENUM (also when
 * OpenBLAS, libopenblas.so.0, cannot be loaded). */
int pr_wide_span(int m, int nf, const double *W, double *s, double *V);

/* C = A B (m x r row-major) for A (m x k) and B (k x r), both row-major
 * (dgemm); after a successful pr_wide_span. */
void pr_wide_mul(int m, int k, int r, const double *A, const double *B, double *C);

/* Cholesky factor of the symmetric positive definite n x n matrix whose
 * lower triangle (diagonal included) is stored row-major in H with row
 * stride td: L into that lower triangle (dpotrf), the upper one kept.
 * Returns 0 on success, else not positive definite. */
int pr_wide_cholesky(double *H, int n, size_t td);

/* Free dense features (fewer than the samples) from which REPS solves
 * matrix-free (pr_wide_cg), without forming or factorising a Hessian: from here
 * on one factorisation costs more than 1e11 multiply-adds and the matrix
 * and its padded copy a GiB. */
#define PR_MFREE_MIN 8192

/* y = A x (trans 0) or y = A^T x (trans 1) for A (m x k, row-major): dgemv
 * (plain loops when OpenBLAS cannot be loaded). */
void pr_wide_gemv(int m, int k, const double *A, int trans, const double *x, double *y);

/* Matrix-free solve of (H + shift D^-2) x = b for a symmetric positive
 * semi-definite H of order n given by its products hv(ctx, v, out):
 * conjugate gradients preconditioned by D = diag(dsc) (dsc_j = 1/sqrt(H_jj),
 * 0 = a frozen direction), from x = 0, until the preconditioned residual
 * falls to tol of b's or after maxit products. work: 4 n. Returns the
 * products taken. */
int pr_wide_cg(int n, void (*hv)(void *ctx, const double *v, double *out), void *ctx,
          const double *dsc, double shift, const double *b, double *x, double tol, int maxit,
          double *work);

/* Bytes a REPS solve of m samples and d free features allocates at its
 * peak, about (one-hot features; matrix-free; dense otherwise). */
double pr_wide_bytes(int m, int d, int bin, int mfree);

/* The memory a process may use: physical memory, or the address-space
 * limit (ulimit -v) when that is lower. */
double pr_wide_memory(void);

#endif
