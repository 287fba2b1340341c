/* reps_wide.c — LAPACK (on OpenBLAS) for wide REPS problems: the span of
 * d >= n features, and factorisations of order PR_LAPACK_MIN and more
 * (reps_wide_priv.h). Row-major arrays are handed to the column-major
 * routines as their transposes. */
#include <dlfcn.h>
#include <pthread.h>
#include <signal.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#include "poolreps/common.h"
#include "common_priv.h"
#include "reps_wide_priv.h"

/* LAPACK and BLAS of OpenBLAS, through their Fortran entry points, loaded
 * on first use (la_load) rather than linked: OpenBLAS starts its threads
 * when it loads, and they must block the fatal signals, which the command
 * line defers around its commits by blocking them in its own threads. GSL
 * keeps its own CBLAS, so every product GSL computes keeps its bits. */
typedef void dgeqrf_t(const int *m, const int *n, double *a, const int *lda, double *tau,
                      double *work, const int *lwork, int *info);
typedef void dgesdd_t(const char *jobz, const int *m, const int *n, double *a, const int *lda,
                      double *s, double *u, const int *ldu, double *vt, const int *ldvt,
                      double *work, const int *lwork, int *iwork, int *info);
typedef void dormqr_t(const char *side, const char *trans, const int *m, const int *n,
                      const int *k, const double *a, const int *lda, const double *tau,
                      double *c, const int *ldc, double *work, const int *lwork, int *info);
typedef void dpotrf_t(const char *uplo, const int *n, double *a, const int *lda, int *info);
typedef void dgemm_t(const char *ta, const char *tb, const int *m, const int *n, const int *k,
                     const double *alpha, const double *a, const int *lda, const double *b,
                     const int *ldb, const double *beta, double *c, const int *ldc);
typedef void dgemv_t(const char *t, const int *m, const int *n, const double *alpha,
                     const double *a, const int *lda, const double *x, const int *incx,
                     const double *beta, double *y, const int *incy);

static struct {
	dgeqrf_t *geqrf;
	dgesdd_t *gesdd;
	dormqr_t *ormqr;
	dpotrf_t *potrf;
	dgemm_t *gemm;
	dgemv_t *gemv;
} la;
static pthread_once_t la_once = PTHREAD_ONCE_INIT;

/* dlsym into a function pointer through memcpy (ISO C has no cast between
 * object and function pointers) */
static void la_sym(void *h, const char *name, void *fp)
{
	void *p = h ? dlsym(h, name) : NULL;

	memcpy(fp, &p, sizeof p);
}

static void la_load(void)
{
	sigset_t old;
	void *h;

	pr_cleanup_hold(&old);
	h = dlopen("libopenblas.so.0", RTLD_NOW | RTLD_LOCAL);
	pr_cleanup_release(&old);
	la_sym(h, "dgeqrf_", &la.geqrf);
	la_sym(h, "dgesdd_", &la.gesdd);
	la_sym(h, "dormqr_", &la.ormqr);
	la_sym(h, "dpotrf_", &la.potrf);
	la_sym(h, "dgemm_", &la.gemm);
	la_sym(h, "dgemv_", &la.gemv);
}

/* 1 when OpenBLAS is loaded with every routine used here */
static int la_ready(void)
{
	pthread_once(&la_once, la_load);
	return la.geqrf && la.gesdd && la.ormqr && la.potrf && la.gemm && la.gemv;
}

/* Workspace of a LAPACK routine after its query (lwork = -1) set *w. */
static double *la_work(double w, int *lwork)
{
	*lwork = w > 1.0 ? (int)w : 1;
	return malloc((size_t)*lwork * sizeof(double));
}

int pr_wide_span(int m, int nf, const double *W, double *s, double *V)
{
	/* W's buffer is W^T in column-major order: nf x m, leading dimension nf */
	double *A = malloc((size_t)m * nf * sizeof *A), *tau = malloc((size_t)m * sizeof *tau);
	double *R = calloc((size_t)m * m, sizeof *R), *U = malloc((size_t)m * m * sizeof *U);
	double *Vt = malloc((size_t)m * m * sizeof *Vt), *wk = NULL, q;
	int *iw = malloc(8 * (size_t)m * sizeof *iw), i, j, lw, info, mone = -1, st = PR_ENOMEM;

	if (!A || !tau || !R || !U || !Vt || !iw)
		goto done;
	st = PR_ENUM;
	if (!la_ready())
		goto done;
	memcpy(A, W, (size_t)m * nf * sizeof *A);
	la.geqrf(&nf, &m, A, &nf, tau, &q, &mone, &info);
	st = PR_ENOMEM;
	if (info != 0 || !(wk = la_work(q, &lw)))
		goto done;
	la.geqrf(&nf, &m, A, &nf, tau, wk, &lw, &info);
	free(wk);
	wk = NULL;
	st = PR_ENUM;
	if (info != 0)
		goto done;
	/* W^T = Q R and R = U S Vt: W = Vt^T S (Q U)^T, so W's right singular
	 * vectors are Q U, formed by orthogonal transformations (accurate to
	 * round-off in every direction, however small its singular value) */
	for (j = 0; j < m; j++)
		for (i = 0; i <= j; i++)
			R[i + (size_t)j * m] = A[i + (size_t)j * nf];
	la.gesdd("S", &m, &m, R, &m, s, U, &m, Vt, &m, &q, &mone, iw, &info);
	st = PR_ENOMEM;
	if (info != 0 || !(wk = la_work(q, &lw)))
		goto done;
	la.gesdd("S", &m, &m, R, &m, s, U, &m, Vt, &m, wk, &lw, iw, &info);
	free(wk);
	wk = NULL;
	st = PR_ENUM;
	if (info != 0)
		goto done;
	memset(V, 0, (size_t)m * nf * sizeof *V);
	for (j = 0; j < m; j++)
		memcpy(V + (size_t)j * nf, U + (size_t)j * m, (size_t)m * sizeof *V);
	la.ormqr("L", "N", &nf, &m, &m, A, &nf, tau, V, &nf, &q, &mone, &info);
	st = PR_ENOMEM;
	if (info != 0 || !(wk = la_work(q, &lw)))
		goto done;
	la.ormqr("L", "N", &nf, &m, &m, A, &nf, tau, V, &nf, wk, &lw, &info);
	st = info == 0 ? PR_OK : PR_ENUM;
done:
	free(A);
	free(tau);
	free(R);
	free(U);
	free(Vt);
	free(iw);
	free(wk);
	return st;
}

void pr_wide_mul(int m, int k, int r, const double *A, const double *B, double *C)
{
	const double one = 1.0, zero = 0.0;

	/* column-major: C^T (r x m) = B^T (r x k) A^T (k x m); OpenBLAS is
	 * loaded: pr_wide_span ran first */
	if (r > 0)
		la.gemm("N", "N", &r, &m, &k, &one, B, &r, A, &k, &zero, C, &r);
}

int pr_wide_cholesky(double *H, int n, size_t td)
{
	const int ld = (int)td;
	int info = 1;

	/* the row-major lower triangle is the column-major upper one: H = U^T U
	 * with U = L^T */
	if (la_ready())
		la.potrf("U", &n, H, &ld, &info);
	return info != 0;
}

void pr_wide_gemv(int m, int k, const double *A, int trans, const double *x, double *y)
{
	const double one = 1.0, zero = 0.0;
	const int inc = 1;

	int i, j;

	/* the row-major A is the column-major A^T (k x m) */
	if (la_ready()) {
		la.gemv(trans ? "N" : "T", &k, &m, &one, A, &k, x, &inc, &zero, y, &inc);
		return;
	}
	/* without OpenBLAS: the same products in plain loops */
	memset(y, 0, (size_t)(trans ? k : m) * sizeof *y);
	for (i = 0; i < m; i++)
		for (j = 0; j < k; j++) {
			if (trans)
				y[j] += A[(size_t)i * k + j] * x[i];
			else
				y[i] += A[(size_t)i * k + j] * x[j];
		}
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
