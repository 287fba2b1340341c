/* reps_wide.c — LAPACK (on OpenBLAS) for wide REPS problems: the span of
 * d >= n features, and factorisations of order PR_LAPACK_MIN and more
 * (reps_wide_priv.h). Row-major arrays are handed to the column-major
 * routines as their transposes. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#include <lapacke.h>

#include "poolreps/common.h"
#include "common_priv.h"
#include "reps_wide_priv.h"

/* BLAS's Fortran entry point (OpenBLAS): GSL keeps the cblas_ names of its
 * own reference BLAS, so every product GSL computes keeps its bits. */
void dgemm_(const char *ta, const char *tb, const int *m, const int *n, const int *k,
            const double *alpha, const double *a, const int *lda, const double *b,
            const int *ldb, const double *beta, double *c, const int *ldc);

void dgemv_(const char *t, const int *m, const int *n, const double *alpha, const double *a,
            const int *lda, const double *x, const int *incx, const double *beta, double *y,
            const int *incy);

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

int pr_wide_cholesky(double *H, int n, size_t td)
{
	/* the row-major lower triangle is the column-major upper one: H = U^T U
	 * with U = L^T */
	return LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'U', n, H, (int)td) != 0;
}

void pr_wide_gemv(int m, int k, const double *A, int trans, const double *x, double *y)
{
	const double one = 1.0, zero = 0.0;
	const int inc = 1;

	/* the row-major A is the column-major A^T (k x m) */
	dgemv_(trans ? "N" : "T", &k, &m, &one, A, &k, x, &inc, &zero, y, &inc);
}

static double dot(int n, const double *a, const double *b)
{
	double s = 0.0;
	int j;

	for (j = 0; j < n; j++)
		s += a[j] * b[j];
	return s;
}

int pr_wide_cg(int n, void (*hv)(void *ctx, const double *v, double *out), void *ctx,
          const double *dsc, double shift, const double *b, double *x, double tol, int maxit,
          double *work)
{
	double *r = work, *z = r + n, *d = z + n, *hd = d + n, rz, rz0, a;
	int j, it;

	/* in the scaled variables y = x / dsc the matrix has unit diagonal:
	 * z = dsc^2 r is the preconditioned residual */
	for (j = 0; j < n; j++) {
		r[j] = dsc[j] > 0.0 ? b[j] : 0.0; /* before x: x may alias b */
		x[j] = 0.0;
		z[j] = dsc[j] * dsc[j] * r[j];
		d[j] = z[j];
	}
	rz = rz0 = dot(n, r, z);
	for (it = 0; it < maxit && rz > tol * tol * rz0 && rz > 0.0 && !pr_interrupted; it++) {
		hv(ctx, d, hd);
		for (j = 0; j < n; j++)
			hd[j] = dsc[j] > 0.0 ? hd[j] + shift * d[j] / (dsc[j] * dsc[j]) : 0.0;
		a = dot(n, d, hd);
		if (!(a > 0.0))
			break;
		a = rz / a;
		for (j = 0; j < n; j++) {
			x[j] += a * d[j];
			r[j] -= a * hd[j];
			z[j] = dsc[j] * dsc[j] * r[j];
		}
		a = rz;
		rz = dot(n, r, z);
		for (j = 0; j < n; j++)
			d[j] = z[j] + rz / a * d[j];
	}
	return it;
}

double pr_wide_bytes(int m, int d, int bin, int mfree)
{
	const double md = (double)m * d, dd = (double)d * d, mm = (double)m * m;

	if (bin)
		return 8.0 * (dd + 4.0 * m);
	if (mfree)
		return 8.0 * md;
	/* the span: features, their weighted copy, the QR factors and the
	 * singular vectors, T, the exact deviations; the reduced problem and
	 * its Hessians. Tall: features, Hessian and its padded copy, and the
	 * reduced basis of a retry */
	return d >= m ? 8.0 * (5.0 * md + 3.0 * mm) : 8.0 * (5.0 * md + 4.0 * dd);
}

double pr_wide_memory(void)
{
	const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
	double mem = pages > 0 && page > 0 ? (double)pages * page : 1e300;
	struct rlimit rl;

	if (getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY && (double)rl.rlim_cur < mem)
		mem = (double)rl.rlim_cur;
	return mem;
}
