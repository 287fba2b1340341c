/* reps.c — episodic contextual REPS (thesis ch. 3): the dual eq. 3.8, its
 * certified solve, and importance weights for sample reuse.
 *
 * The solve works in standardised units: returns shifted by their maximum
 * and divided by their q-weighted spread (standardise), dense features
 * centred on phi_hat and divided by their largest deviation, one-hot
 * features as they are, less those whose constraint the others imply.
 *  1. joint_newton (the fast path): damped Newton on (eta, theta) from
 *     (1, 0), or on wide dense problems from the least-squares fit at q
 *     (dense_start); g is jointly convex, its Hessian is Cov_p([u, phi]) /
 *     eta with u = A / eta, A = R - theta^T phi.
 *  2. search (when eta heads below eta_min or the fast path stalls): a
 *     safeguarded Newton root search on y = log eta for KL(p_eta||q) = eps,
 *     with theta_solve (Newton on theta at fixed eta, Hessian
 *     Cov_p(phi) / eta, Jacobi-scaled with a 1e-10 shift for exactly
 *     dependent directions) at each eta. h(eta) = min_theta g is convex,
 *     h'(eta) = eps - KL, dKL/dy = -ResVar_p(u | phi) (a Schur complement of
 *     the same Hessian), and dtheta/deta = -Cov_p(phi)^-1 Cov_p(phi, u)
 *     predicts theta at the next eta.
 *  3. limit_solve (when KL < eps there): the eta -> 0 limit p_0, the
 *     maximum-entropy point (relative to q) of the optimal face of the
 *     feature-matching linear programme (GLPK). KL(p_0||q) < eps: the bound
 *     is unreachable and p_0 is the answer, at eta = 0. Otherwise the root
 *     lies below and the search goes on relative to the limit's dual.
 * Each answer then gets its certificate (reps.h): |KL - eps|, the relative
 * feature residual, and for the limit an LP gap and a bound on the mass an
 * optimal solution can put outside supp p_0, from a strictly complementary
 * dual whose reduced costs are exact to about eps^2. */
#include <float.h>
#include <limits.h>
#include <math.h>
#include <setjmp.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include <glpk.h>
#include <nlopt.h>
#include <gsl/gsl_blas.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_linalg.h>
#include <gsl/gsl_matrix.h>

#include "poolreps/reps.h"
#include "common_priv.h"
#include "reps_wide_priv.h"
#include "syrk_priv.h"

void pr_reps_opts_init(pr_reps_opts *o)
{
	o->epsilon = 0.5;
	o->ridge = 0.0;
	o->max_iter = 2000;
	o->eta_min = 1e-2;
	o->allow_failed = 0;
	o->solver = PR_REPS_SOLVER_NEWTON;
	o->threads = 0;
}

const char *pr_reps_status_name(int status)
{
	switch (status) {
	case PR_REPS_ACTIVE: return "active";
	case PR_REPS_UNREACHABLE: return "unreachable";
	default: return "failed";
	}
}

/* Inner (theta) and outer (KL) targets, well inside PR_REPS_TOL. */
#define THETA_TOL 1e-13
#define KL_TOL 1e-12
/* Below this eps, eval computes KL by kl_fine (eps 1e-4 leaves eu - log z
 * 1e-12 of it). */
#define KL_FINE_EPS 1e-4
/* The solver's target for |KL - eps|: KL_TOL, or for eps above 1 KL_TOL
 * eps, and well inside the certificate's relative tolerance for small eps. */
static double kl_tol(double eps)
{
	return fmin(KL_TOL * fmax(1.0, eps), 1e-2 * PR_REPS_TOL * eps);
}

/* A residual that stops falling counts as converged below this (well inside
 * the certificate's PR_REPS_TOL; the certificate checks it again). */
#define FLOOR_TOL 1e-10
/* Steps without halving the residual (Newton on theta) or |KL - eps| (the
 * eta search) that count as a stall. */
#define STALL_STEPS 50
/* Shift added to the Jacobi-scaled covariance (unit diagonal) before its
 * Cholesky factorisation: it bounds steps along exactly dependent feature
 * directions, which leave p unchanged. */
#define SHIFT 1e-10
/* Steps a solve took (pr_reps_result.path). */
enum { PATH_JOINT = 1, PATH_SEARCH = 2, PATH_UP = 4, PATH_LIMIT = 8, PATH_REDUCED = 16,
       PATH_NLOPT = 32, PATH_CHORD = 64, PATH_SPAN = 128, PATH_CG = 256 };
/* Rank tolerance of the reduced basis: singular values of the
 * sqrt(q)-weighted solver features below RANK_TOL of the largest are the
 * round-off of an exact dependence (1e-16 ... 1e-14 of it, whatever the
 * offsets: the features are centred first); above it a direction is a
 * constraint of its own and is kept. */
#define RANK_TOL 1e-12
/* A first answer whose last theta Hessian has a condition estimate above
 * this is solved again on the reduced basis: its features were too close
 * to dependent for the digits of psi (the pivots below 1e-8 of the largest
 * come from directions that only the last digits of the data hold). */
#define COND_RETRY 1e8
/* Directions of the wide reduced basis (prob_reduce_wide) whose singular
 * value is below this fraction of the largest are formed from the exact
 * features: a product of the rounded ones would keep fewer than 12 of
 * their digits. */
#define EXACT_BELOW 1e-4
/* The matrix-free Newton step (pr_wide_cg): relative residual, and products at
 * most (Newton's own iterations absorb an inexact step). */
#define CG_TOL 1e-12
#define CG_MAXIT 2000
/* Dense problems with at least this many free features form Cov_p(psi) as
 * a rank-k update (pr_syrk_acc_rows on the sqrt(p)-weighted rows) instead
 * of row by row: other products (sqrt p dv_j sqrt p dv_k for p dv_j dv_k),
 * so only problems this wide (none of the thesis experiments') see other
 * round-off; they also take chord steps (chord_next). */
#define BLAS_MIN_NF 32
/* Rows of Y per pr_syrk_acc_rows call: 64 rows of 200 features stay in L2. */
#define SYRK_ROWS 64
/* Multiply-adds of a Hessian below which it runs on one thread: starting
 * and joining a thread costs about as much as 1e5 of them. */
#define HESS_THREAD_WORK 2e6
/* The same for the residuals A = R - psi th, which run at every evaluation. */
#define RESID_THREAD_WORK 1e6
/* joint_newton's chord steps on wide dense problems (chord_next): from a
 * full Newton step that cut the error CHORD_FROM-fold, while each step cuts
 * it CHORD_KEEP-fold. */
#define CHORD_FROM 100.0
#define CHORD_KEEP 8.0
/* Largest move of log eta per search step before the root is bracketed. */
#define MAX_DY 5.0
/* Moves of MAX_DY up in log eta while no eta has given a theta solution. */
#define MAX_UPS 8

/* ---- the problem in solver coordinates ---- */

/* m samples (those with q > 0), nf free features. Dense features: psi
 * (m x nf) = (phi - phi_hat)/s, target 0. Binary (one-hot) features: per
 * row the free features it holds (rfp, rfi), target the leaf masses Q.
 * Features that are constant on the samples, and for one-hot blocks (one
 * leaf per tree in every row) one reference leaf per block, are not free:
 * their constraints follow from sum p = 1 and the others. */
typedef struct {
	int m, nf, bin;
	double eps;
	double *R, *q;       /* m */
	double *psi;         /* dense: m x nf */
	int *rfp, *rfi;      /* binary: m + 1, rfp[m] */
	double *tg;          /* nf: target of sum p psi */
	double *gs;          /* nf: residual scale (1 dense, max(Q, 1-Q) binary) */
	double *rw;          /* nf: ridge weight, or NULL */
	int *fr;             /* nf: the original feature of each free one */
	int *blk;            /* binary: nf, block of each free leaf (-1: none) */
	int K;               /* binary: blocks (0: not block structured) */
	int *rowid;          /* m: the original sample of each row */
} prob;

static void prob_free(prob *P)
{
	free(P->R);
	free(P->q);
	free(P->psi);
	free(P->rfp);
	free(P->rfi);
	free(P->tg);
	free(P->gs);
	free(P->rw);
	free(P->fr);
	free(P->blk);
	free(P->rowid);
	memset(P, 0, sizeof *P);
}

/* One evaluation of the dual at (eta, th). */
typedef struct {
	double *th;          /* nf */
	double *A, *p;       /* m: R - psi th; weights */
	double *g;           /* nf: dF/dtheta = tg - sum p psi + rw th */
	double F, kl, amax, res;
} point;

/* Scratch of one solver (sized for the main problem; sub-problems are smaller). */
typedef struct {
	int evals, max_evals;
	int path;            /* PATH_* steps the solve took */
	int stalled;         /* theta_solve or the search met its STALL_STEPS rule */
	int bail;            /* apply that rule: a stall ends the search, and
	                        the reduced basis is tried next */
	point pt[2];         /* current and trial */
	gsl_matrix *H;       /* nf x nf */
	double *dsc;         /* nf: Jacobi scaling 1/sqrt(H_jj), 0 = frozen */
	double *v1, *v2, *c; /* nf */
	double *dth;         /* nf: joint_newton's step in theta */
	int *iscr;           /* 3 nf */
	double *u;           /* m */
	double varu, resvar; /* Var_p(u), ResVar_p(u | psi) at the last factorisation */
	int nfp;             /* nf rounded up to PR_SYRK_W */
	double *Y, *Hp;      /* dense, nf >= BLAS_MIN_NF (else NULL): per thread
	                        SYRK_ROWS x nfp rows of sqrt(p) (psi - psi_c);
	                        nfp x nfp sums */
	int threads;         /* threads that share the rank-k update (dense) */
	int mfree;           /* matrix-free (dense, pr_wide_cg): no H, Y or Hp */
	double *ph, *pv;     /* mfree: m, the weights of the last covariances; scratch */
	double *mcv, *hdg;   /* mfree: nf, sum p (psi - psi_c); diagonal of Cov_p(psi) */
	double *cgw;         /* mfree: 4 nf, pr_wide_cg's scratch */
	double eh;           /* mfree: eta of the last factor() */
	int cref;            /* mfree: the row c of the last covariances */
} work;

static void work_free(work *w)
{
	int k;

	for (k = 0; k < 2; k++) {
		free(w->pt[k].th);
		free(w->pt[k].A);
		free(w->pt[k].p);
		free(w->pt[k].g);
	}
	gsl_matrix_free(w->H);
	free(w->Y);
	free(w->Hp);
	free(w->dsc);
	free(w->v1);
	free(w->v2);
	free(w->c);
	free(w->dth);
	free(w->u);
	free(w->iscr);
	free(w->ph);
	free(w->pv);
	free(w->mcv);
	free(w->hdg);
	free(w->cgw);
}

/* Threads for the Hessian of an m x nf dense problem: those asked for, at
 * most one per CPU (pr_cpu_count; more only share the CPUs and start more
 * threads), but one below HESS_THREAD_WORK multiply-adds per Hessian, and no
 * more than the runs of PR_SYRK_TJ rows pr_syrk_split can give. */
static int hess_threads(int asked, int m, int nfp)
{
	const int cpus = pr_cpu_count();
	int t = asked > 0 && asked < cpus ? asked : cpus;

	if ((double)m * nfp * nfp / 2 < HESS_THREAD_WORK)
		return 1;
	return t < nfp / PR_SYRK_TJ ? t : nfp / PR_SYRK_TJ;
}

static int work_alloc(work *w, const prob *P, int max_evals, int threads, int mfree)
{
	const int m = P->m, nf = P->nf;
	size_t a = (size_t)(nf > 0 ? nf : 1), b = (size_t)m;
	int k;

	memset(w, 0, sizeof *w);
	w->max_evals = max_evals;
	w->threads = 1;
	for (k = 0; k < 2; k++) {
		w->pt[k].th = calloc(a, sizeof(double));
		w->pt[k].A = calloc(b, sizeof(double));
		w->pt[k].p = calloc(b, sizeof(double));
		w->pt[k].g = calloc(a, sizeof(double));
		if (!w->pt[k].th || !w->pt[k].A || !w->pt[k].p || !w->pt[k].g)
			return PR_ENOMEM;
	}
	if (mfree) {
		w->mfree = 1;
		w->ph = malloc(b * sizeof *w->ph);
		w->pv = malloc(b * sizeof *w->pv);
		w->mcv = malloc(a * sizeof *w->mcv);
		w->hdg = malloc(a * sizeof *w->hdg);
		w->cgw = malloc(4 * a * sizeof *w->cgw);
		if (!w->ph || !w->pv || !w->mcv || !w->hdg || !w->cgw)
			return PR_ENOMEM;
	} else if (!(w->H = gsl_matrix_alloc(a, a))) {
		return PR_ENOMEM;
	}
	w->dsc = calloc(a, sizeof(double));
	w->v1 = calloc(a, sizeof(double));
	w->v2 = calloc(a, sizeof(double));
	w->c = calloc(a, sizeof(double));
	w->dth = calloc(a, sizeof(double));
	w->u = calloc(b, sizeof(double));
	w->iscr = calloc(3 * a, sizeof(int));
	if (!P->bin && nf >= BLAS_MIN_NF && !mfree) {
		w->nfp = (nf + PR_SYRK_W - 1) / PR_SYRK_W * PR_SYRK_W;
		w->threads = hess_threads(threads, m, w->nfp);
		/* a block of Y per thread (without the memory, one thread: the
		 * same bytes); calloc: the padding columns stay 0 */
		w->Y = calloc((size_t)w->threads * SYRK_ROWS * w->nfp, sizeof *w->Y);
		if (!w->Y && w->threads > 1) {
			w->threads = 1;
			w->Y = calloc((size_t)SYRK_ROWS * w->nfp, sizeof *w->Y);
		}
		w->Hp = malloc((size_t)w->nfp * w->nfp * sizeof *w->Hp);
		if (!w->Y || !w->Hp)
			return PR_ENOMEM;
	}
	return w->dsc && w->v1 && w->v2 && w->c && w->dth && w->u && w->iscr ? PR_OK : PR_ENOMEM;
}

/* Rows lo .. hi - 1 of A = R - psi th, each row's sum in column order, four
 * rows at a time (four independent chains of additions instead of one: the
 * same bits, faster). */
typedef struct {
	const prob *P;
	const double *th;
	double *A;
	int lo, hi;
} resid_part;

static void *residual_rows(void *arg)
{
	const resid_part *s = arg;
	const prob *P = s->P;
	const int nf = P->nf;
	const double *th = s->th;
	double *A = s->A;
	int i = s->lo, j;

	for (; i + 4 <= s->hi; i += 4) {
		const double *r0 = P->psi + (size_t)i * nf, *r1 = r0 + nf, *r2 = r1 + nf, *r3 = r2 + nf;
		double a0 = P->R[i], a1 = P->R[i + 1], a2 = P->R[i + 2], a3 = P->R[i + 3];

		for (j = 0; j < nf; j++) {
			a0 -= r0[j] * th[j];
			a1 -= r1[j] * th[j];
			a2 -= r2[j] * th[j];
			a3 -= r3[j] * th[j];
		}
		A[i] = a0;
		A[i + 1] = a1;
		A[i + 2] = a2;
		A[i + 3] = a3;
	}
	for (; i < s->hi; i++) {
		const double *r = P->psi + (size_t)i * nf;
		double a = P->R[i];

		for (j = 0; j < nf; j++)
			a -= r[j] * th[j];
		A[i] = a;
	}
	return NULL;
}

/* A = R - psi th on w->threads threads, each a run of rows (a row's sum is
 * one thread's, so any split gives the same bits); on one below
 * RESID_THREAD_WORK multiply-adds. */
static void dense_residuals(const prob *P, const work *w, const double *th, double *A)
{
	resid_part part[PR_MAX_THREADS];
	int t, nt = (double)P->m * P->nf < RESID_THREAD_WORK ? 1 : w->threads;

	for (t = 0; t < nt; t++)
		part[t] = (resid_part){ P, th, A, (int)((long long)P->m * t / nt),
		                        (int)((long long)P->m * (t + 1) / nt) };
	pr_run_parts(nt, residual_rows, part, sizeof *part);
}

/* The dual in solver coordinates at (eta, x->th):
 *   F = eta eps + th.tg + amax + eta log sum q exp((A - amax)/eta) + rw th^2/2,
 * A = R - psi th, amax = max A (so no exp overflows), p = q e^{u} / z with
 * u = (A - amax)/eta, KL(p||q) = sum p u - log z, g = dF/dth. */
/* KL(p||q) for small eps, where eu - log z loses the 1e-16 that log z
 * holds absolutely: with v = u - E_p[u] (E_p[v] = 0),
 * KL = -log E_q[exp(v)] = -log1p(E_q[expm1(v)]), whose terms carry their
 * own digits (the cancellation costs 1e-16 of |v|, not of 1). */
static double kl_fine(const prob *P, const double *A, double amax, double eta, double eu)
{
	double s = 0.0, qs = 0.0;
	int i;

	for (i = 0; i < P->m; i++) {
		s += P->q[i] * expm1((A[i] - amax) / eta - eu);
		qs += P->q[i];
	}
	return -log1p(s / qs);
}

static void eval(const prob *P, work *w, double eta, point *x)
{
	const int m = P->m, nf = P->nf;
	double amax = -HUGE_VAL, z = 0.0, eu = 0.0, F, th2 = 0.0;
	int i, j, k;

	w->evals++;
	if (P->bin)
		for (i = 0; i < m; i++) {
			double a = P->R[i];

			for (k = P->rfp[i]; k < P->rfp[i + 1]; k++)
				a -= x->th[P->rfi[k]];
			x->A[i] = a;
		}
	else
		dense_residuals(P, w, x->th, x->A);
	for (i = 0; i < m; i++)
		if (x->A[i] > amax)
			amax = x->A[i];
	for (i = 0; i < m; i++) {
		double u = (x->A[i] - amax) / eta;

		x->p[i] = P->q[i] * exp(u);
		z += x->p[i];
	}
	for (j = 0; j < nf; j++)
		x->g[j] = P->tg[j] + (P->rw ? P->rw[j] * x->th[j] : 0.0);
	for (i = 0; i < m; i++) {
		double pi = x->p[i] /= z;

		eu += pi * ((x->A[i] - amax) / eta);
		if (P->bin) {
			for (k = P->rfp[i]; k < P->rfp[i + 1]; k++)
				x->g[P->rfi[k]] -= pi;
		} else {
			const double *restrict r = P->psi + (size_t)i * nf;
			double *restrict g = x->g;

			for (j = 0; j < nf; j++)
				g[j] -= pi * r[j];
		}
	}
	x->amax = amax;
	x->kl = P->eps < KL_FINE_EPS ? kl_fine(P, x->A, amax, eta, eu) : eu - log(z);
	F = eta * P->eps + amax + eta * log(z);
	x->res = 0.0;
	for (j = 0; j < nf; j++) {
		F += x->th[j] * P->tg[j];
		if (P->rw)
			th2 += P->rw[j] * x->th[j] * x->th[j];
		x->res = fmax(x->res, fabs(x->g[j]) / P->gs[j]);
	}
	x->F = F + 0.5 * th2;
}

/* Do all free leaves keep a mass of at least 1e-6 outside them (P < 1 - 1e-6)? */
static int plain_ok(const prob *P, const point *x)
{
	int j;

	for (j = 0; j < P->nf; j++)
		if (!(P->tg[j] - x->g[j] + (P->rw ? P->rw[j] * x->th[j] : 0.0) < 1.0 - 1e-6))
			return 0;
	return 1;
}

/* Rows i0 .. i0 + mr - 1 of Y = diag(sqrt p) (psi - psi_c) into Y (from
 * its row 0); with vu, their moments are also added to mc = sum p (psi -
 * psi_c), w->c = sum p (psi - psi_c)(u - mu) and *vu = sum p (u - mu)^2, in
 * row order; without, only columns from on (the others are not read). */
static void fill_rows(const prob *P, work *w, const point *x, const double *rc, double mu,
                      int i0, int mr, double *Y, double *vu, int from)
{
	const int nf = P->nf, nfp = w->nfp;
	double *restrict mc = w->v1, *restrict cu = w->c;
	int i, j;

	for (i = 0; i < mr; i++) {
		const double pi = x->p[i0 + i], du = w->u[i0 + i] - mu, sp = sqrt(pi);
		const double *restrict r = P->psi + (size_t)(i0 + i) * nf;
		double *restrict y = Y + (size_t)i * nfp;

		if (!vu) {
			for (j = from; j < nf; j++)
				y[j] = sp * (r[j] - rc[j]);
			continue;
		}
		*vu += pi * du * du;
		for (j = 0; j < nf; j++) {
			const double dv = r[j] - rc[j];

			y[j] = sp * dv;
			mc[j] += pi * dv;
			cu[j] += pi * dv * du;
		}
	}
}

/* One thread's share of Hp += Y^T Y over all m rows: rows jlo..jhi-1 of
 * Hp, from blocks of SYRK_ROWS rows of Y that the thread makes in its own
 * buffer (they stay in its cache); the part with vu also sums the moments
 * (fill_rows). Every entry gets the sums of one thread in row order, so
 * any split gives the bits of one thread. */
typedef struct {
	const prob *P;
	work *w;
	const point *x;
	const double *rc;
	double mu, *Y, *vu;
	int jlo, jhi;
} hess_part;

static void *hess_part_run(void *arg)
{
	const hess_part *a = arg;
	const int m = a->P->m;
	int i0;

	for (i0 = 0; i0 < m; i0 += SYRK_ROWS) {
		const int mr = m - i0 < SYRK_ROWS ? m - i0 : SYRK_ROWS;

		/* pr_syrk_acc_rows reads no column below jlo's run of PR_SYRK_W */
		fill_rows(a->P, a->w, a->x, a->rc, a->mu, i0, mr, a->Y, a->vu,
		          a->jlo / PR_SYRK_W * PR_SYRK_W);
		pr_syrk_acc_rows(a->Y, mr, a->w->nfp, a->w->Hp, a->jlo, a->jhi);
	}
	return NULL;
}

/* covariances() for wide dense problems: the moments about row c, with
 * sum p (psi - psi_c)(psi - psi_c)^T as Y^T Y, Y = diag(sqrt p) (psi -
 * psi_c), by pr_syrk_acc_rows on w->threads threads, each its own rows of
 * Hp (split by pr_syrk_split for equal work) and its own blocks of Y; the
 * first part, which also sums the moments, runs here, and so does a part
 * whose thread cannot start. w->u and mu are set, H's upper triangle and
 * w->c, w->v1 zeroed by the caller. */
static void covariances_blas(const prob *P, work *w, const point *x, int c, double mu)
{
	const int nf = P->nf, nfp = w->nfp, nt = w->threads; /* <= PR_MAX_THREADS: check_opts */
	/* mc is not restrict: fill_rows adds to it through w->v1 */
	const double *mc = w->v1;
	double *H = w->H->data, vu = 0.0;
	const size_t td = w->H->tda;
	hess_part part[PR_MAX_THREADS];
	int t, j, k;

	memset(w->Hp, 0, (size_t)nfp * nfp * sizeof *w->Hp);
	for (t = 0; t < nt; t++)
		part[t] = (hess_part){ P, w, x, P->psi + (size_t)c * nf, mu,
		                       w->Y + (size_t)t * SYRK_ROWS * nfp, t == 0 ? &vu : NULL,
		                       pr_syrk_split(nfp, nt, t), pr_syrk_split(nfp, nt, t + 1) };
	pr_run_parts(nt, hess_part_run, part, sizeof *part);
	for (j = 0; j < nf; j++)
		for (k = j; k < nf; k++)
			H[(size_t)j * td + k] = w->Hp[(size_t)j * nfp + k] - mc[j] * mc[k];
	w->varu = vu;
}

/* covariances() without the matrix (matrix-free, dense): the weights and
 * the row c kept for hprod, the diagonal of Cov_p(psi) (w->hdg, for the
 * preconditioner), sum p (psi - psi_c) (w->mcv), Cov_p(psi, u) (w->c) and
 * Var_p(u), in O(m nf). */
static void moments_mfree(const prob *P, work *w, const point *x, int c, double mu)
{
	const int m = P->m, nf = P->nf;
	const double *rc = P->psi + (size_t)c * nf;
	double vu = 0.0;
	int i, j;

	memset(w->mcv, 0, (size_t)nf * sizeof *w->mcv);
	memset(w->hdg, 0, (size_t)nf * sizeof *w->hdg);
	memset(w->c, 0, (size_t)nf * sizeof *w->c);
	for (i = 0; i < m; i++) {
		const double pi = x->p[i], du = w->u[i] - mu, *r = P->psi + (size_t)i * nf;

		vu += pi * du * du;
		w->ph[i] = pi;
		for (j = 0; j < nf; j++) {
			const double dv = r[j] - rc[j];

			w->mcv[j] += pi * dv;
			w->c[j] += pi * dv * du;
			w->hdg[j] += pi * dv * dv;
		}
	}
	for (j = 0; j < nf; j++)
		w->hdg[j] -= w->mcv[j] * w->mcv[j];
	w->varu = vu;
	w->cref = c;
}

/* Cov_p(psi) (free features) into the upper triangle of w->H, Cov_p(psi, u)
 * into w->c and Var_p(u) into w->varu, at the weights of x. The moments are
 * taken about the row c with the largest weight,
 *   Cov = sum p (psi - psi_c)(psi - psi_c)^T - (m - psi_c)(m - psi_c)^T,
 * so nothing cancels when p concentrates on a few rows (small eta). For
 * one-hot rows psi_i - psi_c is +1 on the leaves only i holds and -1 on
 * those only c holds. */
static void covariances(const prob *P, work *w, double eta, const point *x)
{
	const int m = P->m, nf = P->nf;
	double *H = w->H ? w->H->data : NULL, *mc = w->v1, *dv = w->v2, mu = 0.0, vu = 0.0;
	double pmax = -1.0;
	const size_t td = w->H ? w->H->tda : 0;
	int *dj = w->iscr, *inc = w->iscr + nf, *ini = w->iscr + 2 * (size_t)nf;
	int i, j, k, l, c = 0, nd;

	for (i = 0; i < m; i++) {
		w->u[i] = (x->A[i] - x->amax) / eta;
		mu += x->p[i] * w->u[i];
		if (x->p[i] > pmax) {
			pmax = x->p[i];
			c = i;
		}
	}
	if (w->mfree) {
		moments_mfree(P, w, x, c, mu);
		return;
	}
	for (j = 0; j < nf; j++) {
		memset(H + (size_t)j * td + j, 0, (size_t)(nf - j) * sizeof *H);
		w->c[j] = 0.0;
		mc[j] = 0.0;
		inc[j] = ini[j] = 0;
	}
	/* one-hot rows whose leaves all keep some mass away from them: the
	 * moments about 0 (the mass of each leaf pair) lose at most
	 * eps / (1 - P_leaf) of Cov's diagonal, and cost half as much */
	if (P->bin && plain_ok(P, x)) {
		for (i = 0; i < m; i++) {
			const double pi = x->p[i], du = w->u[i] - mu;
			const int *f = P->rfi + P->rfp[i], nk = P->rfp[i + 1] - P->rfp[i];

			vu += pi * du * du;
			for (k = 0; k < nk; k++) {
				double *hr = H + (size_t)f[k] * td;

				w->c[f[k]] += pi * du;
				mc[f[k]] += pi;
				for (l = 0; l < nk; l++)
					if (f[l] >= f[k])
						hr[f[l]] += pi;
			}
		}
		for (j = 0; j < nf; j++)
			for (k = j; k < nf; k++)
				H[(size_t)j * td + k] -= mc[j] * mc[k];
		w->varu = vu;
		return;
	}
	if (w->Y) {
		covariances_blas(P, w, x, c, mu);
		return;
	}
	if (P->bin)
		for (k = P->rfp[c]; k < P->rfp[c + 1]; k++)
			inc[P->rfi[k]] = 1;
	for (i = 0; i < m; i++) {
		const double pi = x->p[i], du = w->u[i] - mu;

		vu += pi * du * du;
		if (pi == 0.0 || i == c)
			continue;
		/* the nonzero entries of psi_i - psi_c: indices dj, values dv */
		nd = 0;
		if (P->bin) {
			for (k = P->rfp[i]; k < P->rfp[i + 1]; k++) {
				ini[P->rfi[k]] = 1;
				if (!inc[P->rfi[k]]) {
					dj[nd] = P->rfi[k];
					dv[nd++] = 1.0;
				}
			}
			for (k = P->rfp[c]; k < P->rfp[c + 1]; k++)
				if (!ini[P->rfi[k]]) {
					dj[nd] = P->rfi[k];
					dv[nd++] = -1.0;
				}
			for (k = P->rfp[i]; k < P->rfp[i + 1]; k++)
				ini[P->rfi[k]] = 0;
		} else {
			const double *r = P->psi + (size_t)i * nf, *rc = P->psi + (size_t)c * nf;

			for (j = 0; j < nf; j++)
				if (r[j] != rc[j]) {
					dj[nd] = j;
					dv[nd++] = r[j] - rc[j];
				}
		}
		/* upper triangle through raw row pointers: O(nd^2) per row */
		for (k = 0; k < nd; k++) {
			const double pv = pi * dv[k];
			double *hr = H + (size_t)dj[k] * td;

			mc[dj[k]] += pv;
			w->c[dj[k]] += pv * du;
			for (l = 0; l < nd; l++)
				if (dj[l] >= dj[k])
					hr[dj[l]] += pv * dv[l];
		}
	}
	for (j = 0; j < nf; j++)
		for (k = j; k < nf; k++)
			H[(size_t)j * td + k] -= mc[j] * mc[k];
	w->varu = vu;
}

/* Factorises the symmetric positive semi-definite matrix held in the upper
 * triangle of H (n x n, diagonal included) after Jacobi scaling to unit
 * diagonal, with SHIFT added; rows whose diagonal is not above 1e-150 (near
 * underflow, where products lose their relative accuracy) and 1e-30 of the
 * largest have nothing left to fit and are frozen (dsc = 0).
 * The lower triangle and diagonal receive the Cholesky factor, the upper
 * triangle is kept. Returns PR_OK or PR_ENUM. */
static int psd_factor(gsl_matrix *H, int n, double *dsc)
{
	const size_t td = H->tda;
	double *h = H->data, dmax = 0.0, shift;
	gsl_matrix_view hv;
	int j, k, tries;

	if (n == 0)
		return PR_OK;
	for (j = 0; j < n; j++)
		dmax = fmax(dmax, h[(size_t)j * td + j]);
	for (j = 0; j < n; j++) {
		double d = h[(size_t)j * td + j];

		dsc[j] = d > 1e-150 && d > 1e-30 * dmax ? 1.0 / sqrt(d) : 0.0;
	}
	hv = gsl_matrix_submatrix(H, 0, 0, (size_t)n, (size_t)n);
	for (tries = 0, shift = SHIFT; tries < 4; tries++, shift *= 100.0) {
		for (j = 0; j < n; j++) {
			for (k = 0; k < j; k++)
				h[(size_t)j * td + k] = h[(size_t)k * td + j] * dsc[j] * dsc[k];
			h[(size_t)j * td + j] = 1.0 + shift;
		}
		if (n >= PR_LAPACK_MIN ? !pr_wide_cholesky(h, n, td) :
		    gsl_linalg_cholesky_decomp1(&hv.matrix) == GSL_SUCCESS)
			return PR_OK;
	}
	return PR_ENUM;
}

/* x = M^-1 b with the factor of psd_factor (x may alias b). */
static void psd_solve(gsl_matrix *H, int n, const double *dsc, const double *b, double *x)
{
	gsl_matrix_view hv;
	gsl_vector_view xv;
	int j;

	if (n == 0)
		return;
	hv = gsl_matrix_submatrix(H, 0, 0, (size_t)n, (size_t)n);
	xv = gsl_vector_view_array(x, (size_t)n);
	for (j = 0; j < n; j++)
		x[j] = b[j] * dsc[j];
	gsl_linalg_cholesky_svx(&hv.matrix, &xv.vector);
	for (j = 0; j < n; j++)
		x[j] *= dsc[j];
}

/* Matrix-free: only the Jacobi scaling of H = Cov/eta + diag(rw), with
 * psd_factor's rule for frozen rows; hsolve solves by pr_wide_cg. */
static int factor_mfree(const prob *P, work *w, double eta)
{
	double dmax = 0.0;
	int j;

	w->eh = eta;
	for (j = 0; j < P->nf; j++) {
		w->dsc[j] = w->hdg[j] / eta + (P->rw ? P->rw[j] : 0.0);
		dmax = fmax(dmax, w->dsc[j]);
	}
	for (j = 0; j < P->nf; j++) {
		const double d = w->dsc[j];

		w->dsc[j] = d > 1e-150 && d > 1e-30 * dmax ? 1.0 / sqrt(d) : 0.0;
	}
	return PR_OK;
}

/* H v for the matrix-free solve: (sum p d (psi - psi_c) - mc (mc.v)) / eta
 * + rw v with d = (psi - psi_c) v, at the weights of the last covariances
 * (two products with psi, dgemv). */
typedef struct {
	const prob *P;
	work *w;
} hprod_ctx;

static void hprod(void *ctx, const double *v, double *out)
{
	const hprod_ctx *h = ctx;
	const prob *P = h->P;
	work *w = h->w;
	const int m = P->m, nf = P->nf;
	const double *rc = P->psi + (size_t)w->cref * nf;
	double tc = 0.0, mv = 0.0, sd = 0.0;
	int i, j;

	pr_wide_gemv(m, nf, P->psi, 0, v, w->pv);
	for (j = 0; j < nf; j++) {
		tc += rc[j] * v[j];
		mv += w->mcv[j] * v[j];
	}
	for (i = 0; i < m; i++) {
		w->pv[i] = w->ph[i] * (w->pv[i] - tc);
		sd += w->pv[i];
	}
	pr_wide_gemv(m, nf, P->psi, 1, w->pv, out);
	for (j = 0; j < nf; j++)
		out[j] = (out[j] - sd * rc[j] - w->mcv[j] * mv) / w->eh + (P->rw ? P->rw[j] * v[j] : 0.0);
}

/* Factorises H = Cov/eta + diag(rw) (Cov in the upper triangle of w->H). */
static int factor(const prob *P, work *w, double eta)
{
	const size_t td = w->mfree ? 0 : w->H->tda;
	double *H = w->mfree ? NULL : w->H->data;
	int j, k;

	if (w->mfree)
		return factor_mfree(P, w, eta);
	for (j = 0; j < P->nf; j++) {
		for (k = j; k < P->nf; k++)
			H[(size_t)j * td + k] /= eta;
		if (P->rw)
			H[(size_t)j * td + j] += P->rw[j];
	}
	return psd_factor(w->H, P->nf, w->dsc);
}

/* x = H^-1 b with the factorisation of factor() (x may alias b). */
static void hsolve(const prob *P, work *w, const double *b, double *x)
{
	hprod_ctx h = {P, w};

	if (w->mfree)
		pr_wide_cg(P->nf, hprod, &h, w->dsc, SHIFT, b, x, CG_TOL, CG_MAXIT, w->cgw);
	else
		psd_solve(w->H, P->nf, w->dsc, b, x);
}

/* After a factorisation at x: the regression of u on the features,
 * w->v2 = Cov^-1 Cov(psi, u) (= -dtheta/dy / eta), and
 * w->resvar = Var(u) - Cov(u, psi) v2 = -dKL/dlog eta (no ridge). */
static void regress_u(const prob *P, work *w, double eta)
{
	double s = 0.0;
	int j;

	if (P->nf == 0) {
		w->resvar = w->varu;
		return;
	}
	for (j = 0; j < P->nf; j++)
		w->v1[j] = w->c[j] / eta;
	hsolve(P, w, w->v1, w->v2);
	for (j = 0; j < P->nf; j++)
		s += w->c[j] * w->v2[j];
	w->resvar = fmax(w->varu - s, 0.0);
}

/* (max L_jj / min L_jj)^2 over the rows psd_factor did not freeze. */
static double hess_cond(const work *w, int nf)
{
	double lo = HUGE_VAL, hi = 0.0;
	int j;

	for (j = 0; j < nf && !w->mfree; j++)
		if (w->dsc[j] > 0.0) {
			double l = gsl_matrix_get(w->H, (size_t)j, (size_t)j);

			lo = fmin(lo, l);
			hi = fmax(hi, l);
		}
	return hi > 0.0 && lo > 0.0 ? (hi / lo) * (hi / lo) : 1.0;
}

/* Newton's method on theta at fixed eta, from w->pt[0].th. Leaves pt[0]
 * evaluated at the last accepted theta. Returns 1 if res <= tol, or if the
 * residual stopped falling at its round-off floor below FLOOR_TOL, with H
 * factorised at pt[0] (and Cov_p(psi, u) for regress_u); 0 if it stalled,
 * ran out of evaluations or met an indefinite Hessian; PR_EINTR. */
static int theta_solve(const prob *P, work *w, double eta, double tol)
{
	point *x = &w->pt[0], *t = &w->pt[1], tmp;
	double best = HUGE_VAL, ref = HUGE_VAL;
	int j, k, since = 0, tiny = 0, slow = 0;

	eval(P, w, eta, x);
	for (;;) {
		double dec = 0.0, step = 1.0;
		int ok = 0;

		if (pr_interrupted)
			return PR_EINTR;
		covariances(P, w, eta, x);
		/* a Hessian that round-off made indefinite: this start is useless */
		if (factor(P, w, eta) != PR_OK)
			return 0;
		if (x->res <= tol || P->nf == 0)
			return 1;
		/* the residual's round-off floor (at small eta the weights carry
		 * round-off of eps |A / eta|): 4 steps in a row whose decrease of F
		 * drowned in round-off, without halving the residual */
		if (tiny && !(x->res < 0.5 * best)) {
			if (++since >= 4)
				return x->res <= FLOOR_TOL;
		} else {
			since = 0;
		}
		best = fmin(best, x->res);
		/* Newton that does not halve the residual in STALL_STEPS steps has
		 * stalled on features too close to dependent for their digits: when
		 * the reduced basis can take over (bail), the evaluations are its */
		if (x->res < 0.5 * ref) {
			ref = x->res;
			slow = 0;
		} else if (w->bail && ++slow >= STALL_STEPS) {
			w->stalled = 1;
			return 0;
		}
		if (w->evals >= w->max_evals)
			return 0;
		hsolve(P, w, x->g, w->v2);
		for (j = 0; j < P->nf; j++)
			dec += x->g[j] * w->v2[j];
		for (k = 0; k < 40 && w->evals < w->max_evals; k++, step *= 0.5) {
			for (j = 0; j < P->nf; j++)
				t->th[j] = x->th[j] - step * w->v2[j];
			eval(P, w, eta, t);
			/* Armijo; near the optimum the decrease drowns in the round-off
			 * of F: then a step that shrinks the residual is progress */
			if (t->F <= x->F - 1e-4 * step * dec ||
			    (dec <= 1e-12 * (1.0 + fabs(x->F)) && t->res < x->res)) {
				ok = 1;
				break;
			}
		}
		if (!ok)
			return 0;
		tiny = dec <= 1e-12 * (1.0 + fabs(x->F));
		tmp = *x;
		*x = *t;
		*t = tmp;
	}
}

/* ---- building the problem ---- */

/* One-hot blocks: every row holds K entries and its j-th entry is always a
 * feature of block j (the active leaves of a forest, one per tree). Fills
 * blk (d) and returns K, or 0 when the rows are not built that way. */
static int find_blocks(const pr_reps_problem *pb, const int *rows, int m, int *blk)
{
	int i, j, K;

	K = pb->rowptr[rows[0] + 1] - pb->rowptr[rows[0]];
	if (K < 1)
		return 0;
	for (j = 0; j < pb->d; j++)
		blk[j] = -1;
	for (i = 0; i < m; i++) {
		const int *c = pb->col + pb->rowptr[rows[i]];

		if (pb->rowptr[rows[i] + 1] - pb->rowptr[rows[i]] != K)
			return 0;
		for (j = 0; j < K; j++) {
			if (blk[c[j]] < 0)
				blk[c[j]] = j;
			else if (blk[c[j]] != j)
				return 0;
		}
	}
	return K;
}

/* Value of feature j of sample i (original data). */
static double feat_sparse(const pr_reps_problem *pb, int i, int j)
{
	int k;

	for (k = pb->rowptr[i]; k < pb->rowptr[i + 1]; k++)
		if (pb->col[k] == j)
			return pb->val ? pb->val[k] : 1.0;
	return 0.0;
}

/* (inline: the dense case is one load, in loops over every entry) */
static inline double feat(const pr_reps_problem *pb, int i, int j)
{
	return pb->phi ? pb->phi[(size_t)i * pb->d + j] : feat_sparse(pb, i, j);
}

/* Feature summaries of the original problem over the rows with q > 0:
 * phat (d) = sum q phi (centred twice for accuracy), fs (d) = the largest
 * deviation from it. Binary features are summed sparsely. */
static void feature_stats(const pr_reps_problem *pb, const int *rows, const double *q, int m,
                          double *phat, double *fs)
{
	const int d = pb->d;
	int i, j, k;

	memset(phat, 0, (size_t)d * sizeof *phat);
	if (!pb->phi && !pb->val) {
		for (i = 0; i < m; i++)
			for (k = pb->rowptr[rows[i]]; k < pb->rowptr[rows[i] + 1]; k++)
				phat[pb->col[k]] += q[i];
		/* a leaf holds every sample or none of them exactly when its
		 * deviation is 0: count the rows to decide that without round-off */
		memset(fs, 0, (size_t)d * sizeof *fs);
		for (i = 0; i < m; i++)
			for (k = pb->rowptr[rows[i]]; k < pb->rowptr[rows[i] + 1]; k++)
				fs[pb->col[k]] += 1.0;
		for (j = 0; j < d; j++)
			fs[j] = fs[j] == 0.0 || fs[j] == (double)m ? 0.0 : fmax(phat[j], 1.0 - phat[j]);
		return;
	}
	/* row by row (the rows are contiguous), each column's sum still in row
	 * order: fs first holds the correction sum q (phi - phat) */
	for (i = 0; i < m; i++)
		for (j = 0; j < d; j++)
			phat[j] += q[i] * feat(pb, rows[i], j);
	memset(fs, 0, (size_t)d * sizeof *fs);
	for (i = 0; i < m; i++)
		for (j = 0; j < d; j++)
			fs[j] += q[i] * (feat(pb, rows[i], j) - phat[j]);
	for (j = 0; j < d; j++) {
		phat[j] += fs[j];
		fs[j] = 0.0;
	}
	/* a comparison, not fmax (a call per value): the values are finite */
	for (i = 0; i < m; i++)
		for (j = 0; j < d; j++) {
			const double a = fabs(feat(pb, rows[i], j) - phat[j]);

			if (a > fs[j])
				fs[j] = a;
		}
}

/* Allocates the solver-coordinate arrays of P for m rows and nf free features. */
static int prob_alloc(prob *P, int m, int nf, int bin, int nnz, int ridge)
{
	size_t a = (size_t)(nf > 0 ? nf : 1);

	P->m = m;
	P->nf = nf;
	P->bin = bin;
	P->R = malloc((size_t)m * sizeof *P->R);
	P->q = malloc((size_t)m * sizeof *P->q);
	P->rowid = malloc((size_t)m * sizeof *P->rowid);
	P->tg = calloc(a, sizeof *P->tg);
	P->gs = calloc(a, sizeof *P->gs);
	P->fr = calloc(a, sizeof *P->fr);
	P->blk = calloc(a, sizeof *P->blk);
	P->rw = ridge ? calloc(a, sizeof *P->rw) : NULL;
	if (bin) {
		P->rfp = malloc(((size_t)m + 1) * sizeof *P->rfp);
		P->rfi = malloc((size_t)(nnz > 0 ? nnz : 1) * sizeof *P->rfi);
	} else {
		P->psi = malloc((size_t)m * a * sizeof *P->psi);
	}
	if (!P->R || !P->q || !P->rowid || !P->tg || !P->gs || !P->fr || !P->blk ||
	    (ridge && !P->rw) || (bin ? !P->rfp || !P->rfi : !P->psi))
		return PR_ENOMEM;
	return PR_OK;
}

/* The main problem: rows with q > 0 (rows[], q[] normalised, Rs the
 * standardised returns), features summarised by phat, fs. */
static int prob_main(prob *P, const pr_reps_problem *pb, const int *rows, const double *qn,
                     const double *Rs, int m, const double *phat, const double *fs, double eps,
                     double ridge, int *fx)
{
	const int d = pb->d, bin = d > 0 && !pb->phi && !pb->val;
	int *blk = NULL, *ref = NULL, K = 0, nf = 0, nnz = 0, i, j, k, st;

	if (bin) {
		blk = malloc((size_t)d * sizeof *blk);
		ref = malloc((size_t)d * sizeof *ref);
		if (!blk || !ref) {
			free(blk);
			free(ref);
			return PR_ENOMEM;
		}
		K = ridge > 0.0 ? 0 : find_blocks(pb, rows, m, blk);
		/* the reference leaf of a block: its largest leaf */
		for (j = 0; j < K; j++)
			ref[j] = -1;
		for (j = 0; K > 0 && j < d; j++)
			if (blk[j] >= 0 && fs[j] > 0.0 && (ref[blk[j]] < 0 || phat[j] > phat[ref[blk[j]]]))
				ref[blk[j]] = j;
	}
	for (j = 0; j < d; j++) {
		fx[j] = -1;
		if (fs[j] > 0.0 && !(K > 0 && blk[j] >= 0 && ref[blk[j]] == j))
			fx[j] = nf++;
	}
	if (bin)
		for (i = 0; i < m; i++)
			for (k = pb->rowptr[rows[i]]; k < pb->rowptr[rows[i] + 1]; k++)
				nnz += fx[pb->col[k]] >= 0;
	st = prob_alloc(P, m, nf, bin, nnz, ridge > 0.0);
	if (st == PR_OK) {
		P->eps = eps;
		P->K = K;
		for (j = 0; j < d; j++) {
			int f = fx[j];

			if (f < 0)
				continue;
			P->fr[f] = j;
			P->tg[f] = bin ? phat[j] : 0.0;
			P->gs[f] = bin ? fs[j] : 1.0;
			P->blk[f] = K > 0 ? blk[j] : -1;
			if (P->rw)
				P->rw[f] = bin ? ridge : ridge / (fs[j] * fs[j]);
		}
		memcpy(P->R, Rs, (size_t)m * sizeof *Rs);
		memcpy(P->q, qn, (size_t)m * sizeof *qn);
		memcpy(P->rowid, rows, (size_t)m * sizeof *rows);
		if (bin) {
			P->rfp[0] = 0;
			for (i = 0, nnz = 0; i < m; i++) {
				for (k = pb->rowptr[rows[i]]; k < pb->rowptr[rows[i] + 1]; k++)
					if (fx[pb->col[k]] >= 0)
						P->rfi[nnz++] = fx[pb->col[k]];
				P->rfp[i + 1] = nnz;
			}
		} else {
			for (i = 0; i < m; i++)
				for (j = 0; j < d; j++)
					if (fx[j] >= 0)
						P->psi[(size_t)i * nf + fx[j]] =
							(feat(pb, rows[i], j) - phat[j]) / fs[j];
		}
	}
	free(blk);
	free(ref);
	return st;
}

/* The maximum-entropy problem on the face: rows S (indices into P's rows,
 * ns of them), R = 0, the base weights q restricted to S, the targets of P.
 * Free: P's free features that vary on S, less one reference leaf per
 * block (P's own reference if S meets it, else S's largest leaf). */
static int prob_face(prob *F, const prob *P, const int *S, int ns)
{
	const int nf = P->nf;
	double *cnt = calloc((size_t)(nf > 0 ? nf : 1), sizeof *cnt);
	double *mass = calloc((size_t)(nf > 0 ? nf : 1), sizeof *mass);
	double *bc = calloc((size_t)(P->K > 0 ? P->K : 1), sizeof *bc);
	int *fx = malloc((size_t)(nf > 0 ? nf : 1) * sizeof *fx), *bref = NULL;
	int i, j, k, n2 = 0, nnz = 0, st = PR_ENOMEM;

	if (!cnt || !mass || !bc || !fx)
		goto done;
	if (!(bref = malloc((size_t)(P->K > 0 ? P->K : 1) * sizeof *bref)))
		goto done;
	for (j = 0; j < nf; j++)
		fx[j] = -1;
	if (P->bin) {
		for (i = 0; i < ns; i++)
			for (k = P->rfp[S[i]]; k < P->rfp[S[i] + 1]; k++) {
				cnt[P->rfi[k]] += 1.0;
				mass[P->rfi[k]] += P->q[S[i]];
			}
		/* rows of S in P's reference leaf of block b: those in no free leaf of b */
		for (j = 0; j < nf; j++)
			if (P->blk[j] >= 0)
				bc[P->blk[j]] += cnt[j];
		for (k = 0; k < P->K; k++)
			bref[k] = bc[k] < (double)ns ? -2 : -1; /* -2: P's reference is in S */
		for (j = 0; j < nf; j++) {
			int b = P->blk[j];

			if (cnt[j] == 0.0 || cnt[j] == (double)ns)
				continue;
			if (b >= 0 && bref[b] != -2 && (bref[b] < 0 || mass[j] > mass[bref[b]]))
				bref[b] = j;
		}
		for (j = 0; j < nf; j++)
			if (cnt[j] > 0.0 && cnt[j] < (double)ns && !(P->blk[j] >= 0 && bref[P->blk[j]] == j))
				fx[j] = n2++;
		for (i = 0; i < ns; i++)
			for (k = P->rfp[S[i]]; k < P->rfp[S[i] + 1]; k++)
				nnz += fx[P->rfi[k]] >= 0;
	} else {
		for (j = 0; j < nf; j++)
			for (i = 1; i < ns; i++)
				if (P->psi[(size_t)S[i] * nf + j] != P->psi[(size_t)S[0] * nf + j]) {
					fx[j] = n2++;
					break;
				}
	}
	if ((st = prob_alloc(F, ns, n2, P->bin, nnz, 0)) != PR_OK)
		goto done;
	F->eps = 0.0;
	F->K = P->K;
	for (j = 0; j < nf; j++)
		if (fx[j] >= 0) {
			F->fr[fx[j]] = j; /* a free index of P */
			F->tg[fx[j]] = P->tg[j];
			F->gs[fx[j]] = P->gs[j];
			F->blk[fx[j]] = P->blk[j];
		}
	if (P->bin)
		F->rfp[0] = 0;
	for (i = 0, nnz = 0; i < ns; i++) {
		F->R[i] = 0.0;
		F->q[i] = P->q[S[i]];
		F->rowid[i] = S[i];
		if (P->bin) {
			for (k = P->rfp[S[i]]; k < P->rfp[S[i] + 1]; k++)
				if (fx[P->rfi[k]] >= 0)
					F->rfi[nnz++] = fx[P->rfi[k]];
			F->rfp[i + 1] = nnz;
		} else {
			for (j = 0; j < nf; j++)
				if (fx[j] >= 0)
					F->psi[(size_t)i * n2 + fx[j]] = P->psi[(size_t)S[i] * nf + j];
		}
	}
done:
	free(cnt);
	free(mass);
	free(bc);
	free(fx);
	free(bref);
	return st;
}

/* ---- the eta -> 0 limit ---- */

/* What the limit solve leaves for the result, in solver units. */
typedef struct {
	double *p;        /* m: p_0 on P's rows */
	double *th;       /* nf: an optimal dual solution of the LP (free features) */
	double *lam;      /* nf: the face's max-entropy multipliers: theta(eta) is
	                     th + eta lam + o(eta) as eta -> 0 */
	double *rr;       /* m: the reduced costs R_i - psi_i th - const <= 0 (0 on
	                     the face), to round-off of the result */
	int shifted;      /* the search continued on R = rr, theta - th */
	double kl;        /* KL(p_0 || q) */
	double value;     /* the dual value at eta = 0: th.tg + max_i (R_i - psi_i th) */
	double gap;       /* value - sum p_0 R: how far p_0 is from optimal */
	double outside;   /* the largest mass an optimal solution can put outside supp p_0 */
	double tie;       /* how far the reduced costs on supp p_0 fall below the
	                     face's beyond their tolerance (TIE_ROUND, TIE_REL): > 0
	                     when supp p_0 holds a near tie, not a face (the root may
	                     lie below) */
	int ok;           /* 0: the limit could not be computed (reason set) */
} limit_t;

/* Column i of the LP's constraint matrix (free features, then sum p = 1)
 * times the row vector y (nf + 1): a_i . y, and sum |a_ik y_k| in *mag. */
static double col_dot(const prob *P, int i, const double *y, double *mag)
{
	double s = y[P->nf], a = fabs(y[P->nf]);
	int e;

	if (P->bin) {
		for (e = P->rfp[i]; e < P->rfp[i + 1]; e++) {
			s += y[P->rfi[e]];
			a += fabs(y[P->rfi[e]]);
		}
	} else {
		const double *r = P->psi + (size_t)i * P->nf;

		for (e = 0; e < P->nf; e++) {
			s += r[e] * y[e];
			a += fabs(r[e] * y[e]);
		}
	}
	if (mag)
		*mag = a;
	return s;
}

/* Compensated t - a_i . (y + ylo) (Ogita, Rump and Oishi's Dot2: error-free
 * products by fma and sums by TwoSum; ylo, the low part of a double-double
 * y, may be NULL), so that the result is within 2 eps |result| +
 * 2 (k eps)^2 mag of the exact value, k = 2 col_nnz + 1. */
static double rr_exact(const prob *P, int i, double t, const double *y, const double *ylo,
                       double *mag)
{
	double s = t, c = 0.0, a = fabs(t);
	int e, nk = P->bin ? P->rfp[i + 1] - P->rfp[i] : P->nf, lo;

	for (lo = 0; lo < (ylo ? 2 : 1); lo++) {
		const double *v = lo ? ylo : y;

		for (e = -1; e < nk; e++) {
			double f = e < 0 || P->bin ? 1.0 : P->psi[(size_t)i * P->nf + e], pr, pe, sn, z;
			int k = e < 0 ? P->nf : P->bin ? P->rfi[P->rfp[i] + e] : e;

			pr = -f * v[k];
			pe = fma(-f, v[k], -pr);
			sn = s + pr;
			z = sn - s;
			c += (s - (sn - z)) + (pr - z) + pe;
			s = sn;
			a += fabs(pr);
		}
	}
	if (mag)
		*mag = a;
	return s + c;
}

/* Entries of column i of the constraint matrix. */
static int col_nnz(const prob *P, int i)
{
	return (P->bin ? P->rfp[i + 1] - P->rfp[i] : P->nf) + 1;
}

/* acc (nf + 1) += v a_i. */
static void col_add(const prob *P, int i, double v, double *acc)
{
	int e;

	if (P->bin) {
		for (e = P->rfp[i]; e < P->rfp[i + 1]; e++)
			acc[P->rfi[e]] += v;
	} else {
		for (e = 0; e < P->nf; e++)
			acc[e] += v * P->psi[(size_t)i * P->nf + e];
	}
	acc[P->nf] += v;
}

/* Adds column i of the constraint matrix to GLPK's triplets (1-based rows,
 * column `c`, starting after entry *nnz). */
static void col_triplets(const prob *P, int i, int c, int *ia, int *ja, double *ar, int *nnz)
{
	int e;

	if (P->bin) {
		for (e = P->rfp[i]; e < P->rfp[i + 1]; e++) {
			++*nnz;
			ia[*nnz] = P->rfi[e] + 1;
			ja[*nnz] = c;
			ar[*nnz] = 1.0;
		}
	} else {
		for (e = 0; e < P->nf; e++)
			if (P->psi[(size_t)i * P->nf + e] != 0.0) {
				++*nnz;
				ia[*nnz] = e + 1;
				ja[*nnz] = c;
				ar[*nnz] = P->psi[(size_t)i * P->nf + e];
			}
	}
	++*nnz;
	ia[*nnz] = P->nf + 1;
	ja[*nnz] = c;
	ar[*nnz] = 1.0;
}

/* Solves lp by the simplex method, GLPK's output off; 1 if optimal. */
static int lp_solve(glp_prob *lp)
{
	glp_smcp parm;

	glp_init_smcp(&parm);
	parm.msg_lev = GLP_MSG_OFF;
	parm.presolve = GLP_OFF;
	glp_scale_prob(lp, GLP_SF_AUTO);
	glp_adv_basis(lp, 0);
	/* tight tolerances first: base weights span many decades, and a sample
	 * whose leaf pins it to a mass of 1e-11 must not be rounded to 0; if
	 * the simplex method cannot work to them, GLPK's defaults, from where
	 * it stopped (the certificate judges the result either way) */
	parm.tol_bnd = 1e-13;
	parm.tol_dj = 1e-13;
	/* tight tolerances can make a degenerate problem cycle: a budget */
	parm.it_lim = 50 * (glp_get_num_rows(lp) + glp_get_num_cols(lp));
	if (glp_simplex(lp, &parm) == 0 && glp_get_status(lp) == GLP_OPT)
		return 1;
	glp_init_smcp(&parm);
	parm.msg_lev = GLP_MSG_OFF;
	parm.presolve = GLP_OFF;
	parm.it_lim = 50 * (glp_get_num_rows(lp) + glp_get_num_cols(lp));
	return glp_simplex(lp, &parm) == 0 && glp_get_status(lp) == GLP_OPT;
}

/* GLPK ends the process (abort) when it runs out of memory: its error hook
 * jumps back to the solver instead (lp_guard before the setjmp, lp_unguard
 * after), which frees GLPK's memory with its environment and returns
 * PR_ENOMEM; its terminal output goes nowhere, so no message of its own. */
static void lp_abort(void *jb)
{
	longjmp(*(jmp_buf *)jb, 1);
}

/* GLPK's terminal output, even its error message: swallowed */
static int lp_quiet(void *info, const char *s)
{
	(void)info;
	(void)s;
	return 1;
}

/* PR_ENOMEM if GLPK's environment cannot be made (any other GLPK call
 * would abort then) */
static int lp_guard(jmp_buf *jb)
{
	if (glp_init_env() > 1)
		return PR_ENOMEM;
	glp_term_hook(lp_quiet, NULL);
	glp_error_hook(lp_abort, jb);
	return PR_OK;
}

/* LP_DONE: unhook; LP_JUMPED: free GLPK's environment after its error;
 * LP_NONE: GLPK was not reached. Frees the triplets; returns ok, or
 * PR_ENOMEM after a jump. */
enum { LP_DONE, LP_JUMPED, LP_NONE };
static int lp_unguard(int ok, int *ia, int *ja, double *ar, int how)
{
	if (how == LP_JUMPED)
		glp_free_env();
	else if (how == LP_DONE)
		glp_error_hook(NULL, NULL);
	free(ia);
	free(ja);
	free(ar);
	return how == LP_JUMPED ? PR_ENOMEM : ok;
}

/* Triplet storage for nnz entries (1-based, as GLPK wants). */
static int triplets(size_t nnz, int **ia, int **ja, double **ar)
{
	*ia = malloc((nnz + 1) * sizeof **ia);
	*ja = malloc((nnz + 1) * sizeof **ja);
	*ar = malloc((nnz + 1) * sizeof **ar);
	return *ia && *ja && *ar ? PR_OK : PR_ENOMEM;
}

static size_t lp_nnz(const prob *P)
{
	return P->bin ? (size_t)P->rfp[P->m] + (size_t)P->m : (size_t)P->m * ((size_t)P->nf + 1);
}

static int cmp_double(const void *a, const void *b)
{
	const double x = *(const double *)a, y = *(const double *)b;

	return (x > y) - (x < y);
}

/* The power of two by which lp_match scales the returns: GLPK's reduced-cost
 * tolerances are relative to the objective's terms, so when the median gap
 * below the largest return is under 2^-20 of the returns' spread (one return
 * far below the others, in standardised units) the other gaps are brought
 * to about 1, and returns below -2^30 there are clipped to it (the far
 * return's terms would swamp them), where GLPK resolves them; otherwise 0
 * (no scaling). The face is judged on the exact reduced costs of the
 * returns as they are (limit_face, limit_certificate). */
static int lp_unit(const prob *P)
{
	double *g = malloc((size_t)P->m * sizeof *g), hi = -HUGE_VAL, lo = HUGE_VAL, med;
	int i, k = 0, e = 0;

	if (!g)
		return 0;
	for (i = 0; i < P->m; i++) {
		hi = fmax(hi, P->R[i]);
		lo = fmin(lo, P->R[i]);
	}
	for (i = 0; i < P->m; i++)
		if (P->R[i] < hi)
			g[k++] = hi - P->R[i];
	if (k > 0) {
		qsort(g, (size_t)k, sizeof *g, cmp_double);
		med = g[(k - 1) / 2];
		if (med < ldexp(hi - lo, -20))
			frexp(med, &e);
	}
	free(g);
	return -e;
}

/* The feature-matching LP: maximise sum p R subject to the free features'
 * targets and sum p = 1, p >= 0. Fills x (m), the row duals y (nf + 1);
 * returns 1 if optimal, 0 if not, PR_ENOMEM. */
static int lp_match(const prob *P, double *x, double *y)
{
	const int nr = P->nf + 1;
	int *ia, *ja, nnz = 0, i, ok, e = lp_unit(P);
	double *ar;
	glp_prob *lp;
	jmp_buf jb;

	if (triplets(lp_nnz(P), &ia, &ja, &ar) != PR_OK || lp_guard(&jb) != PR_OK)
		return lp_unguard(PR_ENOMEM, ia, ja, ar, LP_NONE);
	if (setjmp(jb))
		return lp_unguard(0, ia, ja, ar, LP_JUMPED);
	lp = glp_create_prob();
	glp_set_obj_dir(lp, GLP_MAX);
	glp_add_rows(lp, nr);
	for (i = 0; i < nr; i++) {
		double b = i < P->nf ? P->tg[i] : 1.0;

		glp_set_row_bnds(lp, i + 1, GLP_FX, b, b);
	}
	glp_add_cols(lp, P->m);
	for (i = 0; i < P->m; i++) {
		glp_set_col_bnds(lp, i + 1, GLP_LO, 0.0, 0.0);
		glp_set_obj_coef(lp, i + 1, e > 0 ? fmax(ldexp(P->R[i], e), -0x1p30) : P->R[i]);
		col_triplets(P, i, i + 1, ia, ja, ar, &nnz);
	}
	glp_load_matrix(lp, nnz, ia, ja, ar);
	ok = lp_solve(lp);
	for (i = 0; ok && i < P->m; i++)
		x[i] = glp_get_col_prim(lp, i + 1);
	for (i = 0; ok && i < nr; i++)
		y[i] = ldexp(glp_get_row_dual(lp, i + 1), -e);
	glp_delete_prob(lp);
	return lp_unguard(ok, ia, ja, ar, LP_DONE);
}

/* Which columns of Z (nz of them, zero reduced cost) some optimal p uses,
 * beyond those marked in sup (the vertex's support, which it uses), and a
 * certificate for the others: maximise sum_k s_k over a row vector w
 * (nf + 1, free) and 0 <= s <= 1 (s = 0 on sup) with a_i . w >= s_k on Z
 * and w . b = 0.
 * For every feasible p on Z, sum p_i a_i . w = w . b = 0 with every term
 * >= 0, so p vanishes where a_i . w > 0; by Farkas' lemma the optimum has
 * s_k = 1 exactly there. Marks the used columns in sup, fills w; returns 1,
 * 0 (LP failure) or PR_ENOMEM. */
static int lp_support(const prob *P, const int *Z, int nz, char *sup, double *w)
{
	const int nr = P->nf + 1;
	int *ia, *ja, nnz = 0, i, k, ok;
	double *ar;
	glp_prob *lp;
	jmp_buf jb;

	if (triplets(lp_nnz(P) + (size_t)nz + (size_t)nr, &ia, &ja, &ar) != PR_OK || lp_guard(&jb) != PR_OK)
		return lp_unguard(PR_ENOMEM, ia, ja, ar, LP_NONE);
	if (setjmp(jb))
		return lp_unguard(0, ia, ja, ar, LP_JUMPED);
	/* rows 1..nz: a_i . w - s_k >= 0; row nz + 1: w . b = 0.
	 * columns 1..nr: w; nr + 1..nr + nz: s. Built as the transpose of
	 * col_triplets' (row, column) pairs. */
	lp = glp_create_prob();
	glp_set_obj_dir(lp, GLP_MAX);
	glp_add_rows(lp, nz + 1);
	glp_add_cols(lp, nr + nz);
	for (k = 0; k < nz; k++) {
		int from = nnz;

		glp_set_row_bnds(lp, k + 1, GLP_LO, 0.0, 0.0);
		col_triplets(P, Z[k], k + 1, ia, ja, ar, &nnz);
		for (i = from + 1; i <= nnz; i++) {
			int t = ia[i];

			ia[i] = ja[i];
			ja[i] = t;
		}
		++nnz;
		ia[nnz] = k + 1;
		ja[nnz] = nr + k + 1;
		ar[nnz] = -1.0;
		/* the vertex's support is used (by the vertex): s = 0 there */
		if (sup[Z[k]])
			glp_set_col_bnds(lp, nr + k + 1, GLP_FX, 0.0, 0.0);
		else
			glp_set_col_bnds(lp, nr + k + 1, GLP_DB, 0.0, 1.0);
		glp_set_obj_coef(lp, nr + k + 1, 1.0);
	}
	glp_set_row_bnds(lp, nz + 1, GLP_FX, 0.0, 0.0);
	for (i = 0; i < nr; i++) {
		double b = i < P->nf ? P->tg[i] : 1.0;

		glp_set_col_bnds(lp, i + 1, GLP_FR, 0.0, 0.0);
		if (b != 0.0) {
			++nnz;
			ia[nnz] = nz + 1;
			ja[nnz] = i + 1;
			ar[nnz] = b;
		}
	}
	glp_load_matrix(lp, nnz, ia, ja, ar);
	ok = lp_solve(lp);
	for (k = 0; ok && k < nz; k++)
		sup[Z[k]] = sup[Z[k]] || glp_get_col_prim(lp, nr + k + 1) < 0.5;
	for (i = 0; ok && i < nr; i++)
		w[i] = glp_get_col_prim(lp, i + 1);
	glp_delete_prob(lp);
	return lp_unguard(ok, ia, ja, ar, LP_DONE);
}

/* Least squares over the rows S: y (nf + 1) += the minimiser of
 * sum_i (t_i - a_i . y)^2, a_i = (psi_i, 1), by the normal equations
 * (Jacobi-scaled, shifted Cholesky) and refinement with compensated
 * residuals while they halve. With ylo (may be NULL) the refinements after
 * the first go there: y + ylo is a double-double, whose residuals fall to
 * about eps^2 of the terms. With t = R it polishes the LP's row duals so
 * that the reduced costs vanish on S. */
static int lsq_fit(const prob *P, const int *S, int ns, const double *t, double *y, double *ylo,
                   gsl_matrix *N, double *dsc, double *rhs, double *dy, double *a)
{
	const int nr = P->nf + 1;
	const size_t td = N->tda;
	double last = HUGE_VAL;
	int round, i, j, k;

	for (j = 0; j < nr; j++)
		memset(N->data + (size_t)j * td, 0, (size_t)nr * sizeof *N->data);
	for (i = 0; i < ns; i++) {
		/* the dense column a of row S[i] */
		memset(a, 0, (size_t)nr * sizeof *a);
		col_add(P, S[i], 1.0, a);
		for (j = 0; j < nr; j++)
			if (a[j] != 0.0)
				for (k = j; k < nr; k++)
					N->data[(size_t)j * td + k] += a[j] * a[k];
	}
	if (psd_factor(N, nr, dsc) != PR_OK)
		return PR_ENUM;
	for (round = 0; round < 12; round++) {
		double worst = 0.0, *to = round > 0 && ylo ? ylo : y;

		memset(rhs, 0, (size_t)nr * sizeof *rhs);
		for (i = 0; i < ns; i++) {
			double r = rr_exact(P, S[i], t[S[i]], y, ylo, NULL);

			worst = fmax(worst, fabs(r));
			memset(a, 0, (size_t)nr * sizeof *a);
			col_add(P, S[i], r, a);
			for (j = 0; j < nr; j++)
				rhs[j] += a[j];
		}
		if (!(worst < 0.5 * last))
			break;
		last = worst;
		psd_solve(N, nr, dsc, rhs, dy);
		for (j = 0; j < nr; j++)
			to[j] += dy[j];
	}
	return PR_OK;
}

/* Scratch of limit_solve (m rows, nr = nf + 1 LP rows). */
typedef struct {
	int *S, *Z;          /* m: the face's support; Z, then indices into S */
	double *rr, *x, *mag, *err; /* m: reduced costs, LP vertex, |terms|, round-off */
	double *y, *wv, *dsc, *rhs, *dy, *acol, *ylo; /* nr each, in one block from y */
	char *sup;           /* m: row in the face's support */
	gsl_matrix *N;       /* nr x nr: lsq_fit's normal equations */
	int ns, nb;          /* |S|; rows of Z in the vertex's support */
	double rmax;         /* the largest reduced cost */
	double tmax;         /* its terms' magnitude (limit_face) */
} limit_ws;

static void limit_ws_free(limit_ws *s)
{
	gsl_matrix_free(s->N);
	free(s->S);
	free(s->Z);
	free(s->rr);
	free(s->x);
	free(s->mag);
	free(s->err);
	free(s->y);
	free(s->sup);
}

static int limit_ws_alloc(limit_ws *s, int m, int nr)
{
	memset(s, 0, sizeof *s);
	s->S = malloc((size_t)m * sizeof *s->S);
	s->Z = malloc((size_t)m * sizeof *s->Z);
	s->rr = malloc((size_t)m * sizeof *s->rr);
	s->x = malloc((size_t)m * sizeof *s->x);
	s->mag = malloc((size_t)m * sizeof *s->mag);
	s->err = malloc((size_t)m * sizeof *s->err);
	s->y = calloc(7 * (size_t)nr, sizeof *s->y);
	s->sup = calloc((size_t)m, 1);
	s->N = gsl_matrix_alloc((size_t)nr, (size_t)nr);
	if (!s->S || !s->Z || !s->rr || !s->x || !s->mag || !s->err || !s->y || !s->sup || !s->N)
		return PR_ENOMEM;
	s->wv = s->y + nr;
	s->dsc = s->wv + nr;
	s->rhs = s->dsc + nr;
	s->dy = s->rhs + nr;
	s->acol = s->dy + nr;
	s->ylo = s->acol + nr;
	return PR_OK;
}

/* A reduced cost on supp p_0 counts as 0 (the face's) within TIE_ROUND
 * times its round-off bound plus TIE_REL of its terms and the largest
 * one's: the digits of the LP's duals on which limit_face decides (on_top);
 * without features only exact ties count (the terms are the returns, 0 at
 * the largest). */
#define TIE_ROUND 1024.0
#define TIE_REL 1e-11

/* Whether row i's reduced cost is the largest within the round-off of the
 * LP's duals: 1e-11 of the terms of its own and of the largest one, row by
 * row (a far return's terms would merge rows whose gaps are 1e-12 of it);
 * without features (no duals) exactly. */
static int on_top(const limit_ws *s, int i, int nf)
{
	return s->rr[i] - s->rmax >= (nf > 0 ? -TIE_REL * (s->mag[i] + s->tmax) : 0.0);
}

/* The optimal face of the feature-matching LP (see limit_solve): LP duals
 * y, reduced costs rr, Z, and the support S (s->ns rows; 0 with reason set
 * when an LP did not solve or the face came out empty); y shifted to a
 * strictly complementary dual when S misses part of Z. PR_OK or a status. */
static int limit_face(const prob *P, limit_ws *s, char *reason, size_t rlen)
{
	const int m = P->m, nf = P->nf, nr = nf + 1;
	double *rr = s->rr, *y = s->y;
	int i, k, nz = 0, rc;

	/* GLPK's output is swallowed by lp_guard's hook */
	if (nf > 0 && (rc = lp_match(P, s->x, y)) <= 0) {
		if (rc == 0)
			snprintf(reason, rlen, "the eta -> 0 linear programme did not solve");
		return rc;
	}
	/* reduced costs; without features the face is the largest returns */
	s->rmax = -HUGE_VAL;
	for (i = 0; i < m; i++) {
		rr[i] = P->R[i] - col_dot(P, i, y, &s->mag[i]);
		s->mag[i] += fabs(P->R[i]);
		if (rr[i] > s->rmax) {
			s->rmax = rr[i];
			s->tmax = s->mag[i];
		}
	}
	for (i = 0; i < m; i++)
		if (on_top(s, i, nf)) {
			s->Z[nz++] = i;
			if (nf == 0 || s->x[i] > 1e-15) {
				s->sup[i] = 1;
				s->nb++;
			}
		}
	if (s->nb < nz) {
		double cmin = HUGE_VAL, delta = 1.0;

		if ((rc = lp_support(P, s->Z, nz, s->sup, s->wv)) <= 0) {
			if (rc == 0)
				snprintf(reason, rlen, "the largest-support linear programme did not solve");
			return rc;
		}
		/* delta: keep the rows off Z strictly below the face: the largest
		 * smallest margin, min(delta c_min on Z \ S, rmax - rr_i + delta c_i
		 * off Z), capped at 1 */
		for (i = 0; i < m; i++)
			if (s->sup[i] == 0 && on_top(s, i, nf))
				cmin = fmin(cmin, col_dot(P, i, s->wv, NULL));
		for (i = 0; i < m; i++) {
			double c = col_dot(P, i, s->wv, NULL);

			if (!on_top(s, i, nf) && c < 0.0)
				delta = fmin(delta, (s->rmax - rr[i]) / (cmin - c));
		}
		for (k = 0; k < nr; k++)
			y[k] += delta * s->wv[k];
	}
	for (i = 0; i < m; i++)
		if (s->sup[i])
			s->S[s->ns++] = i;
	if (s->ns == 0)
		snprintf(reason, rlen, "the eta -> 0 face came out empty");
	return PR_OK;
}

/* y polished so that rr = 0 on S (lsq_fit), the exact reduced costs, and
 * the dual side of L: value, rr, th. */
static int limit_dual(const prob *P, limit_ws *s, limit_t *L)
{
	const int m = P->m, nf = P->nf;
	int i, k, st;

	if (nf > 0 && (st = lsq_fit(P, s->S, s->ns, P->R, s->y, s->ylo, s->N, s->dsc, s->rhs, s->dy,
	                            s->acol)) != PR_OK)
		return st;
	s->rmax = -HUGE_VAL;
	for (i = 0; i < m; i++) {
		s->rr[i] = rr_exact(P, i, P->R[i], s->y, s->ylo, &s->mag[i]);
		s->rmax = fmax(s->rmax, s->rr[i]);
	}
	L->value = s->rmax + s->y[nf];
	for (i = 0; i < m; i++)
		L->rr[i] = s->rr[i] - s->rmax;
	for (k = 0; k < nf; k++) {
		L->th[k] = s->y[k];
		L->value += s->y[k] * P->tg[k];
	}
	return PR_OK;
}

/* p_0, the maximum-entropy point of the face (theta_solve at eta = 1 on
 * the face's problem F, R = 0), into L->p, lam and kl; *res its residual. */
static int limit_primal(const prob *P, limit_ws *s, int max_evals, limit_t *L, double *res)
{
	const int m = P->m, nf = P->nf, ns = s->ns;
	prob F;
	work w;
	int i, k, st;

	memset(&F, 0, sizeof F);
	memset(&w, 0, sizeof w);
	if ((st = prob_face(&F, P, s->S, ns)) != PR_OK ||
	    (st = work_alloc(&w, &F, max_evals, 1, 0)) != PR_OK)
		goto done;
	if (ns == s->nb && F.nf > 0) {
		/* the face is the vertex's support: start from the weights that fit
		 * the vertex x best in the exponential family q exp(-psi theta),
		 * which reaches x itself when the face is that one point */
		for (i = 0; i < ns; i++) {
			s->Z[i] = i;
			s->err[i] = -log(s->x[s->S[i]] / F.q[i]); /* err is free until the certificate */
		}
		memset(s->wv, 0, (size_t)(nf + 1) * sizeof *s->wv);
		if ((st = lsq_fit(&F, s->Z, ns, s->err, s->wv, NULL, s->N, s->dsc, s->rhs, s->dy,
		                  s->acol)) != PR_OK)
			goto done;
		memcpy(w.pt[0].th, s->wv, (size_t)F.nf * sizeof *s->wv);
	}
	if ((st = theta_solve(&F, &w, 1.0, THETA_TOL)) < 0)
		goto done;
	st = PR_OK;
	memset(L->p, 0, (size_t)m * sizeof *L->p);
	memset(L->lam, 0, (size_t)(nf > 0 ? nf : 1) * sizeof *L->lam);
	for (k = 0; k < F.nf; k++)
		L->lam[F.fr[k]] = w.pt[0].th[k];
	L->kl = 0.0;
	for (i = 0; i < F.m; i++) {
		double pi = w.pt[0].p[i];

		L->p[F.rowid[i]] = pi;
		if (pi > 0.0)
			L->kl += pi * log(pi / F.q[i]);
	}
	*res = w.pt[0].res;
done:
	prob_free(&F);
	work_free(&w);
	return st;
}

/* Certificate, for the problem whose targets are the features p_0
 * matches, b' = A p_0 (they differ from phi_hat by p_0's residual, which
 * the certificate reports and bounds separately). For every p feasible
 * there, sum p_i (rmax - rr_i) = y.b' + rmax - sum p R exactly, so every
 * optimal p satisfies sum p_i (rmax - rr_i) <= gap, the same sum for p_0
 * (with e_i, the bound on the round-off of rr_i from rr_exact, added), and
 * puts at most gap / (rmax - rr_i - e_i - e_max) on a row i outside S. */
static void limit_certificate(const prob *P, limit_ws *s, limit_t *L)
{
	const double *rr = s->rr, rmax = s->rmax;
	double emax = 0.0, tmax = 0.0, *err = s->err;
	int i;

	L->gap = 0.0;
	for (i = 0; i < P->m; i++) {
		double nk = 2.0 * col_nnz(P, i) + 1.0;

		err[i] = 2.0 * DBL_EPSILON * fabs(rr[i]) + 2.0 * nk * nk * DBL_EPSILON * DBL_EPSILON * s->mag[i];
		if (rr[i] == rmax) {
			emax = fmax(emax, err[i]);
			tmax = fmax(tmax, s->mag[i]);
		}
	}
	L->tie = 0.0;
	for (i = 0; i < P->m; i++)
		if (L->p[i] > 0.0) {
			L->gap += L->p[i] * (rmax - rr[i] + err[i] + emax);
			L->tie = fmax(L->tie, rmax - rr[i] - TIE_ROUND * (err[i] + emax) -
			                      TIE_REL * (s->mag[i] + tmax));
		}
	L->outside = 0.0;
	for (i = 0; i < P->m; i++)
		if (L->p[i] == 0.0) {
			double margin = rmax - rr[i] - err[i] - emax;

			L->outside = fmax(L->outside, margin > 0.0 ? L->gap / margin : HUGE_VAL);
		}
}

/* The eta -> 0 limit of P (no ridge): p_0 maximises entropy relative to q
 * on the optimal face of the feature-matching LP.
 *  - LP (GLPK) -> row duals y, reduced costs rr_i = R_i - a_i.y - v <= 0
 *    with v their maximum (so y is exactly dual feasible). Every optimal p
 *    vanishes where rr_i < 0; Z = {rr_i >= -1e-11 of the terms}.
 *  - The face's support S: the vertex's support, or, if that misses part
 *    of Z, lp_support, whose w shifts y by delta w so that the reduced
 *    costs on Z \ S become negative too (a strictly complementary dual).
 *  - lsq_fit polishes y, as a double-double, so that rr = 0 on S to about
 *    eps^2; value = y.b + v.
 *  - p_0: theta_solve at eta = 1 with R = 0 on S (the max-entropy problem).
 * Certificate: gap = value - sum p_0 R (p_0 is optimal within gap), and
 * outside = max over the rows where p_0 = 0 of (gap+ + round-off)/|rr_i|:
 * since sum p_i (-rr_i) = value - sum p R <= gap for every optimal p,
 * no optimal p puts more than that on a row outside S. */
static int limit_solve(const prob *P, int max_evals, limit_t *L, char *reason, size_t rlen)
{
	limit_ws s;
	double res = HUGE_VAL;
	int st;

	L->ok = 0;
	if ((st = limit_ws_alloc(&s, P->m, P->nf + 1)) == PR_OK &&
	    (st = limit_face(P, &s, reason, rlen)) == PR_OK && s.ns > 0 &&
	    (st = limit_dual(P, &s, L)) == PR_OK &&
	    (st = limit_primal(P, &s, max_evals, L, &res)) == PR_OK) {
		limit_certificate(P, &s, L);
		L->ok = res <= PR_REPS_TOL;
		if (!L->ok)
			snprintf(reason, rlen, "the maximum-entropy point of the eta -> 0 face did not "
			         "converge (residual %.3g)", res);
	}
	/* GLPK keeps a per-thread environment: release it */
	glp_free_env();
	limit_ws_free(&s);
	return st;
}

/* ---- the search for eta ---- */

/* Solver verdicts. */
enum { V_ACTIVE = PR_REPS_ACTIVE, V_UNREACHABLE = PR_REPS_UNREACHABLE, V_FAILED = PR_REPS_FAILED };

/* joint_newton's start on wide dense problems (without ridge): theta the
 * q-weighted least-squares fit of R on psi, the optimum's limit as eta ->
 * infinity (where p -> q), and eta where KL's expansion there,
 * ResVar_q(R | psi) / (2 eta^2), meets eps (not below eta_min). It costs
 * one Hessian, at q; from (1, 0) a small eps takes about one Newton step
 * per doubling of eta. Leaves (1, 0) if the fit has no residual. */
static void dense_start(const prob *P, work *w, double eta_min, double *eta)
{
	point *x = &w->pt[0];
	int i;

	x->amax = -HUGE_VAL;
	for (i = 0; i < P->m; i++) {
		x->p[i] = P->q[i];
		x->A[i] = P->R[i];
		x->amax = fmax(x->amax, P->R[i]);
	}
	covariances(P, w, 1.0, x);
	if (factor(P, w, 1.0) != PR_OK)
		return;
	regress_u(P, w, 1.0);
	if (!(w->resvar > 0.0))
		return;
	memcpy(x->th, w->v2, (size_t)P->nf * sizeof *x->th);
	*eta = fmax(sqrt(w->resvar / (2.0 * P->eps)), eta_min);
}

/* Whether joint_newton's next step keeps the Hessian of this one (a chord
 * step; wide dense problems only, where forming it is most of the work):
 * after a full step from x to t that cut err = max(residual, |KL - eps|)
 * CHORD_FROM-fold (Newton has reached its fast local phase, where the
 * Hessian hardly moves), and then for as long as each full step cuts it
 * CHORD_KEEP-fold. */
static int chord_next(const prob *P, const work *w, const point *x, const point *t, double step,
                      int chord)
{
	const double err = fmax(x->res, fabs(P->eps - x->kl)), next = fmax(t->res, fabs(P->eps - t->kl));

	return w->Y && step == 1.0 && next * (chord ? CHORD_KEEP : CHORD_FROM) <= err;
}

/* The fast path: damped Newton on (eta, theta) jointly, from eta = 1 and
 * theta = 0 (wide dense problems: from dense_start's point). g is jointly
 * convex with Hessian Cov_p([u, psi]) / eta (plus the ridge), solved through
 * the theta block's factorisation and its Schur complement ResVar_p(u |
 * psi) / eta; Armijo steps keep eta > 0. Wide dense problems take chord
 * steps near the root (chord_next), back to a fresh Hessian when a chord
 * step finds no descent. Returns 1 at the root (|KL - eps| <= KL_TOL,
 * residual <= THETA_TOL), 0 if eta heads below eta_min or it does not
 * converge in 50 steps (the search takes over from pt[0] at *eta), or a
 * negative error. */
static int joint_newton(const prob *P, work *w, double eta_min, double *eta)
{
	const int nf = P->nf;
	const double ktol = kl_tol(P->eps);
	point *x = &w->pt[0], *t = &w->pt[1], tmp;
	double *v1 = w->v1, *v2 = w->v2, *dth = w->dth, eh = 1.0;
	int it, j, k, chord = 0;

	*eta = 1.0;
	memset(x->th, 0, (size_t)(nf > 0 ? nf : 1) * sizeof *x->th);
	if (w->Y && !P->rw)
		dense_start(P, w, eta_min, eta);
	eval(P, w, *eta, x);
	for (it = 0; it < 50 && w->evals < w->max_evals; it++) {
		double ge = P->eps - x->kl, cv1 = 0.0, cv2 = 0.0, schur, de, dec = 0.0, step = 1.0;
		int ok = 0;

		if (pr_interrupted)
			return PR_EINTR;
		/* wide dense problems: the root needs no Hessian of its own (the
		 * last step's factorisation stands for it, cond included) */
		if (w->Y && it > 0 && fabs(ge) <= ktol && x->res <= THETA_TOL)
			return 1;
		if (!chord) {
			covariances(P, w, *eta, x);
			if (factor(P, w, *eta) != PR_OK)
				return 0;
			eh = *eta;
		}
		if (fabs(ge) <= ktol && x->res <= THETA_TOL)
			return 1;
		/* C = Cov/eta + ridge factorised; b = Cov(psi, u)/eta, at eta = eh
		 * where they were formed */
		hsolve(P, w, x->g, v1);
		for (j = 0; j < nf; j++)
			dth[j] = w->c[j] / eh;
		hsolve(P, w, dth, v2);
		for (j = 0; j < nf; j++) {
			cv1 += dth[j] * v1[j];
			cv2 += dth[j] * v2[j];
		}
		schur = w->varu / eh - cv2;
		if (!(schur > 1e-14 * w->varu / eh))
			return 0;
		de = (-ge + cv1) / schur;
		for (j = 0; j < nf; j++)
			dth[j] = -v1[j] - v2[j] * de;
		dec = -ge * de;
		for (j = 0; j < nf; j++)
			dec -= x->g[j] * dth[j];
		/* stay inside eta > 0 */
		if (*eta + de <= 0.0)
			step = 0.5 * *eta / -de;
		for (k = 0; k < 40 && w->evals < w->max_evals; k++, step *= 0.5) {
			double en = *eta + step * de;

			for (j = 0; j < nf; j++)
				t->th[j] = x->th[j] + step * dth[j];
			eval(P, w, en, t);
			if (t->F <= x->F - 1e-4 * step * dec ||
			    (dec <= 1e-12 * (1.0 + fabs(x->F)) && t->res <= x->res &&
			     fabs(P->eps - t->kl) < fabs(ge))) {
				ok = 1;
				*eta = en;
				break;
			}
		}
		/* a chord step that found no descent: this point's own Hessian */
		if (!ok && chord) {
			chord = 0;
			continue;
		}
		if (!ok)
			return 0;
		if (chord)
			w->path |= PATH_CHORD;
		chord = chord_next(P, w, x, t, step, chord);
		tmp = *x;
		*x = *t;
		*t = tmp;
		if (*eta < eta_min)
			return 0;
	}
	return 0;
}

/* The search's next y from the Newton target yt: bisection once the root
 * is bracketed in (ylo, yhi) unless yt lies inside and halves the last
 * step; before, steps of at most MAX_DY (and at least 1) towards it. */
static double next_y(double y, double yt, double ylo, double yhi, double dyold)
{
	if (ylo > -HUGE_VAL && yhi < HUGE_VAL) {
		if (!(yt > ylo && yt < yhi) || fabs(yt - y) > 0.5 * dyold)
			yt = 0.5 * (ylo + yhi);
	} else if (ylo == -HUGE_VAL) {
		yt = yt >= y - MAX_DY ? yt : y - MAX_DY;
		if (!(yt < y))
			yt = y - 1.0;
	} else {
		yt = yt <= y + MAX_DY ? yt : y + MAX_DY;
		if (!(yt > y))
			yt = y + 1.0;
	}
	return yt;
}

/* The eta -> 0 limit, consulted once by search when KL < eps near eta_min:
 * V_UNREACHABLE when KL(p_0||q) < eps, V_FAILED (reason said) when the
 * limit cannot be had or certified, a negative error, or V_ACTIVE when the
 * root lies below: the search then goes on relative to the limit's dual
 * (P's returns become its exact reduced costs, the saved theta thg is
 * shifted by its dual solution, L->shifted). */
static int consult_limit(prob *P, work *w, limit_t *L, double kl, double *thg, char *reason,
                         size_t rlen)
{
	int j, st;

	/* without free features the ridge has nothing to act on: the limit stands */
	if (P->rw && P->nf > 0) {
		snprintf(reason, rlen, "KL = %.6g < epsilon at eta near reps.eta_min, and with "
		         "reps.ridge > 0 there is no eta -> 0 limit to certify", kl);
		return V_FAILED;
	}
	w->path |= PATH_LIMIT;
	if ((st = limit_solve(P, w->max_evals, L, reason, rlen)) != PR_OK)
		return st;
	if (!L->ok)
		return V_FAILED;
	if (L->kl < P->eps)
		return V_UNREACHABLE;
	L->shifted = 1;
	memcpy(P->R, L->rr, (size_t)P->m * sizeof *P->R);
	for (j = 0; j < P->nf; j++)
		thg[j] -= L->th[j];
	return V_ACTIVE;
}

/* The state of the root search on y = log eta. */
typedef struct {
	double y, ylo, yhi;   /* current y and the bracket of KL = eps */
	double ygood, etagood; /* the last eta whose theta solve converged */
	double dyold;         /* the last move of y */
	double *thg, *bg;     /* nf: theta there and -dtheta/deta */
	int limited, good, retries, ups;
} search_t;

/* Theta's start at eta: the first-order predictor in eta (dtheta/deta =
 * -b stays bounded as eta -> 0), or, once the limit is known, its
 * asymptote th + eta lam if that has the lower dual value. */
static void search_start(const prob *P, work *w, const limit_t *L, const search_t *S, double eta)
{
	const int nf = P->nf;
	int j;

	if (S->good)
		for (j = 0; j < nf; j++)
			w->pt[0].th[j] = S->thg[j] - S->bg[j] * (eta - S->etagood);
	if (S->limited && nf > 0) {
		for (j = 0; j < nf; j++)
			w->pt[1].th[j] = eta * L->lam[j];
		eval(P, w, eta, &w->pt[1]);
		eval(P, w, eta, &w->pt[0]);
		if (w->pt[1].F < w->pt[0].F)
			memcpy(w->pt[0].th, w->pt[1].th, (size_t)nf * sizeof *S->thg);
	}
}

/* After a theta solve at eta that did not converge: 1 to go on from a new
 * y, 0 to stop (reason and *eta_out set). */
static int search_retreat(const prob *P, work *w, search_t *S, double eta, double *eta_out,
                          char *reason, size_t rlen)
{
	if (!S->good && ++S->ups <= MAX_UPS) {
		/* no eta has worked yet (one extreme return makes p at eta = 1
		 * a point mass): a larger eta brings p towards q, where the
		 * theta problem is well conditioned; bracket from there */
		S->y += MAX_DY;
		w->path |= PATH_UP;
		memset(w->pt[0].th, 0, (size_t)(P->nf > 0 ? P->nf : 1) * sizeof *S->thg);
		return 1;
	}
	/* theta did not converge from this start: retreat towards the last eta
	 * that did, and come back in smaller steps */
	if (!S->good || ++S->retries > 60) {
		snprintf(reason, rlen, "Newton's method on theta stalled at eta = %.3g "
		         "(feature residual %.3g)", eta, w->pt[0].res);
		*eta_out = eta;
		return 0;
	}
	S->y = 0.5 * (S->y + S->ygood);
	return 1;
}

/* After a converged theta solve at eta with KL = kl off eps: the bracket,
 * the eta -> 0 limit when KL stays below eps near eta_min, and the next y.
 * 1 to go on; 0 to stop with the verdict in *st (and *eta_out, reason). */
static int search_advance(prob *P, work *w, const pr_reps_opts *o, limit_t *L, search_t *S,
                          double eta, double kl, int *st, double *eta_out, char *reason,
                          size_t rlen)
{
	const double y = S->y, f = kl - P->eps;
	double yt;

	regress_u(P, w, eta);
	memcpy(S->thg, w->pt[0].th, (size_t)P->nf * sizeof *S->thg);
	memcpy(S->bg, w->v2, (size_t)P->nf * sizeof *S->bg);
	S->ygood = y;
	S->etagood = eta;
	S->good = 1;
	if (f > 0.0)
		S->ylo = y;
	else
		S->yhi = y;
	yt = kl > 0.0 && w->resvar > 0.0 ? y + (log(kl) - log(P->eps)) * kl / w->resvar : NAN;
	if (f < 0.0 && S->ylo == -HUGE_VAL && !S->limited && !(yt >= log(o->eta_min))) {
		if ((*st = consult_limit(P, w, L, kl, S->thg, reason, rlen)) != V_ACTIVE) {
			if (P->rw)
				*eta_out = eta;
			return 0;
		}
		*st = V_FAILED;
		S->limited = 1;
	}
	if (S->ylo > -HUGE_VAL && S->yhi < HUGE_VAL &&
	    S->yhi - S->ylo <= 4.0 * DBL_EPSILON * fmax(1.0, fabs(y))) {
		/* eta is pinned to round-off: the certificate judges */
		*eta_out = eta;
		*st = V_ACTIVE;
		return 0;
	}
	yt = next_y(y, yt, S->ylo, S->yhi, S->dyold);
	S->dyold = fabs(yt - y);
	S->y = yt;
	if (S->y < log(DBL_MIN) + 50.0 || S->y > 700.0) {
		snprintf(reason, rlen, "eta left the floating-point range (KL = %.6g)", kl);
		*eta_out = eta;
		return 0;
	}
	return 1;
}

/* The root of KL(p_eta||q) = eps in y = log eta (eta in solver units), from
 * y = 0 and theta = 0: Newton on log KL, whose slope is
 * dKL/dy / KL = -ResVar_p(u|psi) / KL, safeguarded by bisection once the
 * root is bracketed and by steps of at most MAX_DY before. Each new eta
 * starts from the first-order predictor theta - Cov^-1 Cov(psi,u) deta.
 * When KL < eps and the next eta would lie below eta_min (or Newton has no
 * slope), the eta -> 0 limit is consulted once: KL(p_0) < eps means no root
 * exists (unreachable). Otherwise the root lies below, where A / eta would
 * carry the round-off of A = R - psi theta magnified by 1/eta: the search
 * goes on with theta - th on the returns rr = R - psi th - const, the
 * limit's exact reduced costs (0 on the face), so A is small where p is
 * not negligible (L->shifted). Returns the verdict, with pt[0] at the
 * answer and *eta_out set for V_ACTIVE, or a negative error. With from,
 * the fast path is skipped and the search starts at *eta_out and pt[0]'s
 * theta (another solver's answer, which it polishes). */
static int search(prob *P, work *w, const pr_reps_opts *o, limit_t *L, int from, double *eta_out,
                  char *reason, size_t rlen)
{
	const double ktol = kl_tol(P->eps);
	const size_t nf1 = (size_t)(P->nf > 0 ? P->nf : 1);
	search_t S = { 0.0, -HUGE_VAL, HUGE_VAL, 0.0, 1.0, HUGE_VAL, NULL, NULL, 0, 0, 0, 0 };
	double gap = HUGE_VAL;
	int it, st, slow;

	if (!(S.thg = malloc(2 * nf1 * sizeof *S.thg)))
		return PR_ENOMEM;
	S.bg = S.thg + nf1;
	snprintf(reason, rlen, "the search for eta did not converge");
	st = from ? 0 : joint_newton(P, w, o->eta_min, eta_out);
	if (st != 0) {
		free(S.thg);
		w->path |= PATH_JOINT;
		return st < 0 ? st : V_ACTIVE;
	}
	w->path |= PATH_SEARCH;
	/* take over where the fast path stopped, if that is usable */
	st = V_FAILED;
	if (*eta_out >= o->eta_min && *eta_out < 1e300)
		S.y = log(*eta_out);
	else
		memset(w->pt[0].th, 0, nf1 * sizeof *S.thg);
	for (it = 0, slow = 0; it < 400; it++) {
		double eta = exp(S.y), kl;
		int conv;

		search_start(P, w, L, &S, eta);
		conv = theta_solve(P, w, eta, THETA_TOL);
		if (conv < 0) {
			st = conv;
			break;
		}
		kl = w->pt[0].kl;
		if (fabs(kl - P->eps) <= ktol && conv == 1) {
			*eta_out = eta;
			st = V_ACTIVE;
			break;
		}
		/* the same rule for the search itself: STALL_STEPS etas in a row
		 * that do not halve |KL - eps| */
		if (fabs(kl - P->eps) < 0.5 * gap) {
			gap = fabs(kl - P->eps);
			slow = 0;
		} else if (w->bail && ++slow >= STALL_STEPS) {
			w->stalled = 1;
		}
		if (w->evals >= w->max_evals) {
			snprintf(reason, rlen, "reps.max_iter = %d dual evaluations used up (KL = %.6g, "
			         "residual %.3g)", w->max_evals, kl, w->pt[0].res);
			*eta_out = eta;
			break;
		}
		if (w->stalled) {
			snprintf(reason, rlen, "stalled at eta = %.6g on a Hessian of condition %.3g "
			         "(KL = %.6g, residual %.3g)", eta, hess_cond(w, P->nf), kl, w->pt[0].res);
			*eta_out = eta;
			break;
		}
		if (conv == 0 ? !search_retreat(P, w, &S, eta, eta_out, reason, rlen)
		              : !search_advance(P, w, o, L, &S, eta, kl, &st, eta_out, reason, rlen))
			break;
	}
	free(S.thg);
	return st;
}

/* ---- the result ---- */

static pr_reps_result *result_new(int n, int d)
{
	pr_reps_result *r = calloc(1, sizeof *r);

	if (!r)
		return NULL;
	r->n = n;
	r->d = d;
	r->p = calloc((size_t)n, sizeof *r->p);
	r->theta = calloc((size_t)(d > 0 ? d : 1), sizeof *r->theta);
	if (!r->p || !r->theta) {
		pr_reps_result_free(r);
		return NULL;
	}
	return r;
}

void pr_reps_result_free(pr_reps_result *r)
{
	if (!r)
		return;
	free(r->p);
	free(r->theta);
	free(r);
}

/* The certificate's feature part, in feature units, from r->p and r->theta:
 * residual = |sum p (phi - phi_hat)|_2, residual_rel = the largest
 * |sum p (phi_j - phi_hat_j) - ridge theta'_j| / fs_j, and the ESS.
 * corr (d, or NULL): subtracted from sum p (phi - phat) per feature (see
 * certify). tmp: d scratch. */
static void certify_features(const pr_reps_problem *pb, const int *rows, int m,
                             const double *phat, const double *fs, const double *corr,
                             double ridge_over_s, pr_reps_result *r, double *tmp)
{
	const int d = pb->d;
	double s2 = 0.0, sp = 0.0;
	int i, j, k;

	memset(tmp, 0, (size_t)d * sizeof *tmp);
	for (i = 0; i < m; i++) {
		const double pi = r->p[rows[i]];

		sp += pi;
		s2 += pi * pi;
		if (d == 0 || pi == 0.0)
			continue;
		if (!pb->phi && !pb->val) {
			for (k = pb->rowptr[rows[i]]; k < pb->rowptr[rows[i] + 1]; k++)
				tmp[pb->col[k]] += pi;
		} else {
			for (j = 0; j < d; j++)
				tmp[j] += pi * (feat(pb, rows[i], j) - phat[j]);
		}
	}
	r->residual = r->residual_rel = 0.0;
	for (j = 0; j < d; j++) {
		double v = !pb->phi && !pb->val ? tmp[j] - phat[j] * sp : tmp[j];

		if (corr)
			v -= sp * corr[j];

		r->residual += v * v;
		if (fs[j] > 0.0)
			r->residual_rel = fmax(r->residual_rel, fabs(v - ridge_over_s * r->theta[j]) / fs[j]);
	}
	r->residual = sqrt(r->residual);
	r->ess = 1.0 / s2;
}

static int check_opts(const pr_reps_opts *o, char *err)
{
	if (!(o->epsilon >= PR_REPS_EPS_MIN) || !isfinite(o->epsilon))
		return pr_err(err, PR_EINVAL, "reps.epsilon: must be >= %g (got %g)", PR_REPS_EPS_MIN,
		              o->epsilon);
	if (!(o->ridge >= 0.0) || !isfinite(o->ridge))
		return pr_err(err, PR_EINVAL, "reps.ridge: must be >= 0 (got %g)", o->ridge);
	if (o->max_iter < 1)
		return pr_err(err, PR_EINVAL, "reps.max_iter: must be >= 1 (got %d)", o->max_iter);
	if (!(o->eta_min > 0.0 && o->eta_min <= 1.0))
		return pr_err(err, PR_EINVAL, "reps.eta_min: must be in (0, 1] (got %g)", o->eta_min);
	if (o->threads < 0 || o->threads > PR_MAX_THREADS)
		return pr_err(err, PR_EINVAL, "reps: threads must be in 0 .. %d (got %d)", PR_MAX_THREADS,
		              o->threads);
	return PR_OK;
}

/* Checks the problem and fills the normalised base weights qn (n). */
static int check_problem(const pr_reps_problem *pb, double *qn, char *err)
{
	double sq = 0.0;
	int i, j;

	if (pb->n < 2)
		return pr_err(err, PR_EINVAL, "reps: need at least 2 samples (got %d)", pb->n);
	if (pb->d < 0)
		return pr_err(err, PR_EINVAL, "reps: negative feature count %d", pb->d);
	if (!pb->R)
		return pr_err(err, PR_EINVAL, "reps: no returns");
	if (pb->d > 0 && !pb->phi && (!pb->rowptr || !pb->col))
		return pr_err(err, PR_EINVAL, "reps: %d features but no feature data", pb->d);
	for (i = 0; i < pb->n; i++) {
		double qi = pb->q ? pb->q[i] : 1.0;

		if (!isfinite(pb->R[i]))
			return pr_err(err, PR_EINVAL, "reps: sample %d: return is not finite", i);
		if (!isfinite(qi) || qi < 0.0)
			return pr_err(err, PR_EINVAL,
			              "reps: sample %d: base weight must be finite and >= 0 (got %g)",
			              i, qi);
		qn[i] = qi;
		sq += qi;
	}
	if (!(sq > 0.0) || !isfinite(sq))
		return pr_err(err, PR_EINVAL, "reps: base weights are all zero");
	for (i = 0; i < pb->n; i++)
		qn[i] /= sq;
	if (pb->d == 0)
		return PR_OK;
	if (pb->phi) {
		for (i = 0; i < pb->n; i++)
			for (j = 0; j < pb->d; j++)
				if (!isfinite(pb->phi[(size_t)i * pb->d + j]))
					return pr_err(err, PR_EINVAL,
					              "reps: sample %d: feature %d is not finite", i, j);
		return PR_OK;
	}
	if (pb->rowptr[0] != 0)
		return pr_err(err, PR_EINVAL, "reps: sparse features: rowptr[0] must be 0");
	for (i = 0; i < pb->n; i++) {
		if (pb->rowptr[i + 1] < pb->rowptr[i])
			return pr_err(err, PR_EINVAL, "reps: sparse features: rowptr decreases at %d", i);
		for (j = pb->rowptr[i]; j < pb->rowptr[i + 1]; j++) {
			if (pb->col[j] < 0 || pb->col[j] >= pb->d)
				return pr_err(err, PR_EINVAL,
				              "reps: sample %d: feature index %d outside 0..%d",
				              i, pb->col[j], pb->d - 1);
			if (pb->val && !isfinite(pb->val[j]))
				return pr_err(err, PR_EINVAL, "reps: sample %d: feature value not finite", i);
			if (!pb->val) {
				int k;

				/* one-hot rows must not repeat a feature (its value would be 2) */
				for (k = pb->rowptr[i]; k < j; k++)
					if (pb->col[k] == pb->col[j])
						return pr_err(err, PR_EINVAL,
						              "reps: sample %d: feature %d appears twice", i, pb->col[j]);
			}
		}
	}
	return PR_OK;
}

/* Standardises the returns of the rows with q > 0 without overflow or
 * underflow: Rs = (R - Rmax) / scale with scale = 2^e0 2^e1 sd, where
 * 2^e0 brings the largest |R| into [0.5, 1), 2^e1 the largest deviation
 * from Rmax, and sd is the q-weighted standard deviation of what is left.
 * Scaling by powers of two is exact, and IEEE subtraction is correctly
 * rounded, so exact shifts and power-of-two scalings of the returns give
 * bit-identical Rs. Returns 0 when the returns are all equal. */
static int standardise(const double *R, const int *rows, const double *q, int m, double *Rs,
                       double *rmax, double *scale)
{
	double hi = -HUGE_VAL, lo = HUGE_VAL, mean = 0.0, var = 0.0, sd;
	int i, e0 = 0, e1 = 0;

	for (i = 0; i < m; i++) {
		hi = fmax(hi, R[rows[i]]);
		lo = fmin(lo, R[rows[i]]);
	}
	*rmax = hi;
	if (hi == lo)
		return 0;
	frexp(fmax(fabs(hi), fabs(lo)), &e0);
	for (i = 0; i < m; i++)
		Rs[i] = ldexp(R[rows[i]], -e0) - ldexp(hi, -e0);
	frexp(-(ldexp(lo, -e0) - ldexp(hi, -e0)), &e1);
	for (i = 0; i < m; i++) {
		Rs[i] = ldexp(Rs[i], -e1);
		mean += q[i] * Rs[i];
	}
	for (i = 0; i < m; i++)
		var += q[i] * (Rs[i] - mean) * (Rs[i] - mean);
	sd = sqrt(var);
	if (!(sd > 0.0))
		sd = 1.0; /* the spread sits on weights below DBL_MIN: any unit works */
	for (i = 0; i < m; i++)
		Rs[i] /= sd;
	*scale = ldexp(sd, e0 + e1);
	return 1;
}

/* A row whose return lies below the largest (rmax) but whose standardised
 * return underflowed to 0 or a subnormal: it would tie with the largest,
 * although the answer can hinge on that gap (its eta -> 0 face). Its index
 * into rows, or -1. */
static int lost_gap(const double *R, const int *rows, const double *Rs, int m, double rmax)
{
	int i;

	for (i = 0; i < m; i++)
		if (R[rows[i]] < rmax && Rs[i] > -DBL_MIN)
			return i;
	return -1;
}

/* The answer in feature and return units: p on all n samples, theta from
 * the free features, eta, dual, KL. */
static void map_back(const pr_reps_problem *pb, const prob *P, const double *p,
                     const double *th, const double *fs, double rmax, double scale,
                     double eta, double dual, double kl, pr_reps_result *r)
{
	int i, f;

	memset(r->p, 0, (size_t)pb->n * sizeof *r->p);
	for (i = 0; i < P->m; i++)
		r->p[P->rowid[i]] = p[i];
	memset(r->theta, 0, (size_t)(pb->d > 0 ? pb->d : 1) * sizeof *r->theta);
	for (f = 0; f < P->nf; f++) {
		int j = P->fr[f];

		r->theta[j] = scale * (P->bin ? th[f] : th[f] / fs[j]);
	}
	r->eta = scale * eta;
	r->dual = rmax + scale * dual;
	r->kl = kl > 0.0 ? kl : 0.0;
}

/* p finite, >= 0 and summing to 1 within the round-off of the sum. */
static int weights_ok(const double *p, int n)
{
	double sum = 0.0;
	int i;

	for (i = 0; i < n; i++) {
		if (!(p[i] >= 0.0) || !isfinite(p[i]))
			return 0;
		sum += p[i];
	}
	return fabs(sum - 1.0) <= 4.0 * n * DBL_EPSILON;
}

static int solve(const pr_reps_opts *o, const pr_reps_problem *pb, pr_reps_result **out,
                 char *err);

/* Dense features that are all 0 or 1 as CSR (the ones' columns, row by
 * row): 1 with *rowptr and *col allocated, 0 when some value is neither or
 * there are more than INT_MAX ones (nothing kept), PR_ENOMEM. One pass
 * without branches on the values: a dense matrix of other values stops
 * after its first row. */
static int dense_binary(const pr_reps_problem *pb, int **rowptr, int **col)
{
	const size_t n = (size_t)pb->n, d = (size_t)pb->d;
	size_t i, j, nnz = 0, cap = n * d < ((size_t)1 << 22) ? n * d : (size_t)1 << 22;
	int *rp = malloc((n + 1) * sizeof *rp), *c = malloc(cap * sizeof *c), ok = 1, st = 1;

	for (i = 0; i < n && ok && rp && c; i++) {
		const double *r = pb->phi + i * d;

		if (nnz + d > cap) {
			int *t = realloc(c, 2 * (nnz + d) * sizeof *c);
			if (!t)
				break;
			c = t;
			cap = 2 * (nnz + d);
		}
		rp[i] = (int)nnz;
		for (j = 0; j < d; j++) {
			ok &= (r[j] == 0.0) | (r[j] == 1.0);
			c[nnz] = (int)j;
			nnz += r[j] == 1.0;
		}
		ok &= nnz <= (size_t)INT_MAX;
	}
	if (!ok || i < n) {
		st = ok ? PR_ENOMEM : 0;
		free(rp);
		free(c);
		return st;
	}
	rp[n] = (int)nnz;
	*rowptr = rp;
	*col = c;
	return st;
}

/* Features that are all 0 or 1 take the one-hot (sparse, exact-count) path
 * whatever their storage, so that dense and sparse copies of one problem
 * give the same bits. */
int pr_reps_solve(const pr_reps_opts *o, const pr_reps_problem *pb,
                  pr_reps_result **out, char *err)
{
	pr_reps_problem b = *pb;
	size_t i;
	int *rowptr = NULL, *col = NULL, st;

	if (pb->d > 0 && pb->n > 0 && !pb->phi && pb->val && pb->rowptr && pb->col &&
	    pb->rowptr[pb->n] >= 0) {
		for (i = 0; i < (size_t)pb->rowptr[pb->n] && pb->val[i] == 1.0; i++)
			;
		if (i == (size_t)pb->rowptr[pb->n])
			b.val = NULL;
	}
	if (pb->d > 0 && pb->n > 0 && pb->phi) {
		if ((st = dense_binary(pb, &rowptr, &col)) == PR_ENOMEM)
			return pr_err(err, PR_ENOMEM, "reps: out of memory");
		if (st) {
			b.phi = NULL;
			b.rowptr = rowptr;
			b.col = col;
			b.val = NULL;
		}
	}
	st = solve(o, &b, out, err);
	free(rowptr);
	free(col);
	return st;
}

/* ---- the second solver: NLopt on the same dual ---- */

typedef struct {
	const prob *P;
	work *w;
} nl_data;

/* F and its gradient at x = (log eta, theta) (solver coordinates). */
static double nl_dual(unsigned n, const double *x, double *grad, void *data)
{
	nl_data *d = data;
	point *pt = &d->w->pt[0];
	const double eta = exp(x[0]);

	if (pr_interrupted)
		return HUGE_VAL;
	memcpy(pt->th, x + 1, (size_t)(n - 1) * sizeof *x);
	eval(d->P, d->w, eta, pt);
	if (grad) {
		grad[0] = eta * (d->P->eps - pt->kl);
		memcpy(grad + 1, pt->g, (size_t)(n - 1) * sizeof *x);
	}
	return pt->F;
}

/* Minimises the dual with NLopt's L-BFGS from (log eta, theta) = (0, 0),
 * at most w->max_evals evaluations, until the relative change of x falls
 * to round-off. Leaves pt[0] at the best point, *eta there, and returns 0
 * (the search polishes it and decides), or a negative error on interrupt
 * or memory. */
static int nlopt_dual(const prob *P, work *w, double *eta, char *reason, size_t rlen)
{
	const unsigned n = (unsigned)P->nf + 1;
	double *x = calloc(n, sizeof *x), *lo = malloc(n * sizeof *lo), f = 0.0;
	nlopt_opt opt = nlopt_create(NLOPT_LD_LBFGS, n);
	nl_data d = {P, w};
	nlopt_result rc;
	unsigned j;

	w->path |= PATH_NLOPT;
	if (!x || !lo || !opt) {
		free(x);
		free(lo);
		nlopt_destroy(opt);
		return PR_ENOMEM;
	}
	/* eta within the range where exp and the weights stay finite */
	lo[0] = log(DBL_MIN) + 50.0;
	for (j = 1; j < n; j++)
		lo[j] = -HUGE_VAL;
	nlopt_set_lower_bounds(opt, lo);
	nlopt_set_min_objective(opt, nl_dual, &d);
	nlopt_set_xtol_rel(opt, 1e-15);
	nlopt_set_maxeval(opt, w->max_evals);
	rc = nlopt_optimize(opt, x, &f);
	nlopt_destroy(opt);
	if (pr_interrupted) {
		free(x);
		free(lo);
		return PR_EINTR;
	}
	*eta = exp(x[0]);
	nl_dual(n, x, NULL, &d);
	snprintf(reason, rlen, "NLopt L-BFGS stopped with code %d", (int)rc);
	free(x);
	free(lo);
	return 0;
}

/* What the attempts of one solve share: the problem, its rows with q > 0,
 * the feature summaries and the return standardisation. */
typedef struct {
	const pr_reps_opts *o;
	const pr_reps_problem *pb;
	const int *rows;
	int m;
	const double *qn, *phat, *fs;
	double rmax, scale;
	double *tmp;         /* d + nf scratch */
	double *corr;        /* dense features: d, sum q (phi - phat) (certify); else NULL */
	int span;            /* the reduced basis is solve_wide's (path "span") */
	int mfree;           /* solve matrix-free (path "cg") */
} ctx_t;

/* Column r of Q less mean, and its target sum q zeta_r, which p = q meets. */
static void centre_column(const prob *P, prob *Q, int r, double mean)
{
	int i;

	for (i = 0; i < P->m; i++) {
		Q->psi[(size_t)i * Q->nf + r] -= mean;
		Q->tg[r] += P->q[i] * Q->psi[(size_t)i * Q->nf + r];
	}
}

/* Column r of Q: z_i = sum_j (phi_ij - phat_j) t_j, centred on its q-mean,
 * which is its target. phi - phat is exact as xh + xl, and the sum is
 * Dot2 (error-free products by fma, sums by TwoSum): a direction in which
 * two columns differ by 1e-10 of their spread keeps its digits, where a
 * product of the rounded psi would keep 1e-16 / 1e-10 of them. */
static void reduced_column(const prob *P, const double *xh, const double *xl, const double *t,
                           prob *Q, int r)
{
	const int m = P->m, nf = P->nf;
	double mean = 0.0;
	int i, j, h;

	for (i = 0; i < m; i++) {
		double s = 0.0, e = 0.0;

		for (j = 0; j < nf; j++)
			for (h = 0; h < 2; h++) {
				const double x = (h ? xl : xh)[(size_t)i * nf + j];
				const double pr = x * t[j], pe = fma(x, t[j], -pr), sn = s + pr, z = sn - s;

				e += (s - (sn - z)) + (pr - z) + pe;
				s = sn;
			}
		Q->psi[(size_t)i * Q->nf + r] = s + e;
		mean += P->q[i] * (s + e);
	}
	centre_column(P, Q, r, mean);
}

/* gsl_linalg_SV_decomp: PR_OK, PR_ENUM, or PR_ENOMEM when it ran out of
 * memory inside, where GSL does not check its own allocations (GSL 2.7's
 * bidiagonalisation) and pr_gsl_error_handler jumps back here. (GSL's
 * one-sided Jacobi SVD allocates nothing but stops short of convergence
 * beyond about 100 columns, saying nothing.) */
static int svd_guarded(gsl_matrix *A, gsl_matrix *V, gsl_vector *S, gsl_vector *wk)
{
	jmp_buf jb;
	int st;

	if (setjmp(jb)) {
		pr_gsl_guard(NULL);
		return PR_ENOMEM;
	}
	pr_gsl_guard(&jb);
	st = gsl_linalg_SV_decomp(A, V, S, wk) == GSL_SUCCESS ? PR_OK : PR_ENUM;
	pr_gsl_guard(NULL);
	return st;
}

/* phi - phat exactly as xh + xl (TwoSum), m x nf, for P's rows and features. */
static void exact_deviations(const prob *P, const ctx_t *c, double *xh, double *xl)
{
	const int m = P->m, nf = P->nf;
	int i, j;

	for (i = 0; i < m; i++)
		for (j = 0; j < nf; j++) {
			const int f = P->fr[j];
			const double a = feat(c->pb, P->rowid[i], f), b = -c->phat[f];
			double h = a + b, z = h - a;

			xh[(size_t)i * nf + j] = h;
			xl[(size_t)i * nf + j] = (a - (h - z)) + (b - z);
		}
}

/* Q with P's rows, returns and weights and r dense features (unit
 * residual scale, no blocks), and T (P->nf x r) zeroed. */
static int reduced_alloc(prob *Q, const prob *P, int r, double **T)
{
	const int m = P->m;
	int k;

	if (prob_alloc(Q, m, r, 0, 0, 0) != PR_OK ||
	    !(*T = calloc((size_t)P->nf * (r > 0 ? r : 1), sizeof **T)))
		return PR_ENOMEM;
	Q->eps = P->eps;
	memcpy(Q->R, P->R, (size_t)m * sizeof *Q->R);
	memcpy(Q->q, P->q, (size_t)m * sizeof *Q->q);
	memcpy(Q->rowid, P->rowid, (size_t)m * sizeof *Q->rowid);
	for (k = 0; k < r; k++) {
		Q->fr[k] = k;
		Q->gs[k] = 1.0;
		Q->blk[k] = -1;
	}
	return PR_OK;
}

/* W = diag(sqrt q) (psi - mu), mu = sum q psi (m x nf, row-major). */
static void weighted_centred(const prob *P, double *mu, double *W)
{
	const int m = P->m, nf = P->nf;
	int i, j;

	for (i = 0; i < m; i++)
		for (j = 0; j < nf; j++)
			mu[j] += P->q[i] * P->psi[(size_t)i * nf + j];
	for (i = 0; i < m; i++)
		for (j = 0; j < nf; j++)
			W[(size_t)i * nf + j] = sqrt(P->q[i]) * (P->psi[(size_t)i * nf + j] - mu[j]);
}

/* A well-conditioned basis of P's dense features: W = diag(sqrt q) (psi -
 * sum q psi) = U S V^T (Golub-Reinsch SVD, GSL); directions with singular
 * value below RANK_TOL of the largest are dropped, and Q's features are
 * zeta = (psi - sum q psi) V_r S_r^-1 = diag(1/sqrt q) U_r (so sum q zeta
 * zeta^T = I), computed from the original features (reduced_column), with
 * target sum q zeta, which p = q meets. Errors of V only mix the kept
 * directions, which leaves the constraints' span as it is. T (P->nf x r)
 * maps theta back: psi T = zeta + const, so P's theta is T theta_zeta.
 * *cond = s_1 / s_r. */
static int prob_reduce(prob *Q, const prob *P, const ctx_t *c, double **T, double *cond)
{
	const int m = P->m, nf = P->nf;
	double *xh = malloc((size_t)m * nf * sizeof *xh), *xl = malloc((size_t)m * nf * sizeof *xl);
	double *t = malloc((size_t)nf * sizeof *t);
	gsl_matrix *A = gsl_matrix_alloc((size_t)m, (size_t)nf);
	gsl_matrix *B = gsl_matrix_alloc((size_t)nf, (size_t)nf);
	gsl_vector *S = gsl_vector_alloc((size_t)nf), *wk = gsl_vector_alloc((size_t)nf);
	double *mu = calloc((size_t)nf, sizeof *mu), smax = 0.0, smin = HUGE_VAL;
	int j, k, r = 0, st = PR_ENOMEM;

	*T = NULL;
	if (!A || !B || !S || !wk || !mu || !xh || !xl || !t)
		goto done;
	exact_deviations(P, c, xh, xl);
	weighted_centred(P, mu, A->data);
	if ((st = svd_guarded(A, B, S, wk)) != PR_OK)
		goto done;
	for (k = 0; k < nf; k++)
		smax = fmax(smax, gsl_vector_get(S, (size_t)k));
	for (k = 0; k < nf; k++)
		r += gsl_vector_get(S, (size_t)k) > RANK_TOL * smax;

	if ((st = reduced_alloc(Q, P, r, T)) != PR_OK)
		goto done;
	/* W = A S B^T: U = A, V = B */
	for (k = 0, r = 0; k < nf; k++) {
		const double sk = gsl_vector_get(S, (size_t)k);

		if (!(sk > RANK_TOL * smax))
			continue;
		smin = fmin(smin, sk);
		for (j = 0; j < nf; j++) {
			(*T)[(size_t)j * Q->nf + r] = gsl_matrix_get(B, (size_t)j, (size_t)k) / sk;
			t[j] = (*T)[(size_t)j * Q->nf + r] / c->fs[P->fr[j]];
		}
		reduced_column(P, xh, xl, t, Q, r);
		r++;
	}
	*cond = r > 0 ? smax / smin : 1.0;
	st = PR_OK;
done:
	gsl_matrix_free(A);
	gsl_matrix_free(B);
	gsl_vector_free(S);
	gsl_vector_free(wk);
	free(mu);
	free(xh);
	free(xl);
	free(t);
	return st;
}

/* prob_reduce for nf >= m (the primary path of wide dense problems): the
 * span of W = diag(sqrt q) (psi - mu) = U S V^T from LAPACK
 * (pr_wide_span), at O(m^2 nf + m^3) instead of a Newton step's O(m nf^2 +
 * nf^3); rank as prob_reduce. T = V_r S_r^-1, and Q's features zeta = psi
 * T, centred: combinations of the features themselves, so errors of V only
 * mix the kept directions. A product of the rounded psi keeps about 1e-16
 * s_1 / s_k of direction k's digits: below EXACT_BELOW s_1, zeta is formed
 * from the exact features as in prob_reduce (reduced_column). */
static int prob_reduce_wide(prob *Q, const prob *P, const ctx_t *c, double **T, double *cond)
{
	const int m = P->m, nf = P->nf;
	double *W = malloc((size_t)m * nf * sizeof *W), *V = malloc((size_t)m * nf * sizeof *V);
	double *s = malloc((size_t)m * sizeof *s), *mu = calloc((size_t)nf, sizeof *mu);
	double *xh = NULL, *xl = NULL, *t = NULL;
	int i, j, k, r = 0, st = PR_ENOMEM;

	*T = NULL;
	if (!W || !V || !s || !mu)
		goto done;
	weighted_centred(P, mu, W);
	if ((st = pr_wide_span(m, nf, W, s, V)) != PR_OK)
		goto done;
	free(W);
	W = NULL;
	while (r < m && s[r] > RANK_TOL * s[0])
		r++;
	if ((st = reduced_alloc(Q, P, r, T)) != PR_OK)
		goto done;
	for (j = 0; j < nf; j++)
		for (k = 0; k < r; k++)
			(*T)[(size_t)j * r + k] = V[(size_t)k * nf + j] / s[k];
	pr_wide_mul(m, nf, r, P->psi, *T, Q->psi);
	if (r > 0 && s[r - 1] < EXACT_BELOW * s[0]) {
		xh = malloc((size_t)m * nf * sizeof *xh);
		xl = malloc((size_t)m * nf * sizeof *xl);
		t = malloc((size_t)nf * sizeof *t);
		st = PR_ENOMEM;
		if (!xh || !xl || !t)
			goto done;
		exact_deviations(P, c, xh, xl);
	}
	for (k = 0; k < r; k++) {
		double mean = 0.0;

		if (s[k] < EXACT_BELOW * s[0]) {
			for (j = 0; j < nf; j++)
				t[j] = (*T)[(size_t)j * r + k] / c->fs[P->fr[j]];
			reduced_column(P, xh, xl, t, Q, k);
			continue;
		}
		for (i = 0; i < m; i++)
			mean += P->q[i] * Q->psi[(size_t)i * r + k];
		centre_column(P, Q, k, mean);
	}
	*cond = r > 0 ? s[0] / s[r - 1] : 1.0;
	st = PR_OK;
done:
	free(W);
	free(V);
	free(s);
	free(mu);
	free(xh);
	free(xl);
	free(t);
	return st;
}

static void path_name(int path, char *buf, size_t len)
{
	static const struct { int bit; const char *word; } step[] = {
		{PATH_JOINT, "joint"}, {PATH_CHORD, "chord"}, {PATH_SEARCH, "search"}, {PATH_UP, "up"},
		{PATH_LIMIT, "limit"}, {PATH_REDUCED, "reduced"}, {PATH_NLOPT, "nlopt"},
		{PATH_SPAN, "span"}, {PATH_CG, "cg"}};
	size_t k, at = 0;

	buf[0] = '\0';
	for (k = 0; k < sizeof step / sizeof *step; k++)
		if (path & step[k].bit && at < len)
			at += (size_t)snprintf(buf + at, len - at, "%s%s", at ? "+" : "", step[k].word);
}

/* The certificate of r (reps.h) for the solver's verdict. c->corr (dense
 * features): sum q (phi - phat) per feature, the part of the exact target
 * sum q phi that phat, a double, does not hold. The reported residual is
 * measured against the exact target when exact is set (the reduced
 * attempt, which solves for it), else against phat; either way the
 * residual against the exact target must be within PR_REPS_TOL too. */
static void certify(const ctx_t *c, const limit_t *L, int verdict, int exact, pr_reps_result *r)
{
	const pr_reps_opts *o = c->o;
	double res_exact = 0.0, ktol;

	r->status = verdict;
	if (!weights_ok(r->p, c->pb->n)) {
		/* nothing usable came out: the base weights stand in for p */
		r->status = PR_REPS_FAILED;
		snprintf(r->reason, sizeof r->reason, "the weights do not sum to 1 (p = q returned)");
		memcpy(r->p, c->qn, (size_t)c->pb->n * sizeof *r->p);
		r->kl = 0.0;
	}
	r->kl_gap = fabs(r->kl - o->epsilon);
	ktol = PR_REPS_TOL * fmin(1.0, o->epsilon);
	if (c->corr) {
		certify_features(c->pb, c->rows, c->m, c->phat, c->fs, c->corr, o->ridge / c->scale, r,
		                 c->tmp);
		res_exact = r->residual_rel;
	}
	if (!exact)
		certify_features(c->pb, c->rows, c->m, c->phat, c->fs, NULL, o->ridge / c->scale, r,
		                 c->tmp);
	if (r->status == PR_REPS_FAILED) {
		/* said above or by the search */
	} else if (!(res_exact <= PR_REPS_TOL)) {
		r->status = PR_REPS_FAILED;
		snprintf(r->reason, sizeof r->reason, "feature residual %.3g against the exact sum q phi "
		         "(tolerance %g)", res_exact, PR_REPS_TOL);
	} else if (r->status == PR_REPS_FAILED) {
		/* said above or by the search */
	} else if (verdict == V_ACTIVE && !(r->kl_gap <= ktol && r->residual_rel <= PR_REPS_TOL)) {
		r->status = PR_REPS_FAILED;
		snprintf(r->reason, sizeof r->reason, "|KL - epsilon| = %.3g (tolerance %.3g), feature "
		         "residual %.3g (tolerance %g)", r->kl_gap, ktol, r->residual_rel, PR_REPS_TOL);
	} else if (verdict == V_UNREACHABLE &&
	           !(r->residual_rel <= PR_REPS_TOL && L->gap <= PR_REPS_TOL &&
	             L->outside <= PR_REPS_TOL && L->tie <= 0.0)) {
		r->status = PR_REPS_FAILED;
		snprintf(r->reason, sizeof r->reason, "eta -> 0 limit not certified: feature residual "
		         "%.3g, LP gap %.3g, mass outside the face up to %.3g (tolerance %g), "
		         "near tie %.3g", r->residual_rel, L->gap, L->outside, PR_REPS_TOL, L->tie);
	}
	if (r->status == PR_REPS_ACTIVE)
		r->reason[0] = '\0';
	r->bound = r->status == PR_REPS_ACTIVE;
}

/* One attempt: the search on P, the answer mapped back into r and
 * certified. P's features are those of P0 times T (P0->nf x P->nf) when T
 * is given (the reduced basis), else P0 = P. With bail, a stall ends it
 * early (*bailed set). Returns PR_OK or an error. */
static int attempt(const ctx_t *c, prob *P, const prob *P0, const double *T, int bail,
                   int *bailed, pr_reps_result *r)
{
	work w;
	limit_t L;
	double eta = 0.0, *th, *th0 = c->tmp + (c->pb->d > 0 ? c->pb->d : 0), dual, kl;
	const double *p;
	int verdict, j, k, st = PR_ENOMEM;

	memset(&L, 0, sizeof L);
	if (work_alloc(&w, P, c->o->max_iter, c->o->threads, c->mfree) != PR_OK)
		goto done;
	w.bail = bail;
	L.p = malloc((size_t)P->m * sizeof *L.p);
	L.th = calloc((size_t)(P->nf > 0 ? P->nf : 1), sizeof *L.th);
	L.lam = calloc((size_t)(P->nf > 0 ? P->nf : 1), sizeof *L.lam);
	L.rr = malloc((size_t)P->m * sizeof *L.rr);
	if (!L.p || !L.th || !L.lam || !L.rr)
		goto done;
	/* NLopt's answer is polished by the search from where it stopped: an
	 * answer gets Newton's certificate, and its Hessian's condition, or none */
	verdict = c->o->solver == PR_REPS_SOLVER_NLOPT ?
	          nlopt_dual(P, &w, &eta, r->reason, sizeof r->reason) : 0;
	if (verdict >= 0)
		verdict = search(P, &w, c->o, &L, c->o->solver == PR_REPS_SOLVER_NLOPT, &eta, r->reason,
		                 sizeof r->reason);
	if ((st = verdict) < 0)
		goto done;
	st = PR_OK;
	if (verdict == V_UNREACHABLE) {
		p = L.p;
		th = L.th;
		dual = L.value;
		kl = L.kl;
		eta = 0.0;
	} else {
		point *x = &w.pt[0];
		double rterm = 0.0;

		for (j = 0; j < P->nf && P->rw; j++)
			rterm += 0.5 * P->rw[j] * x->th[j] * x->th[j];
		if (L.shifted) {
			/* back from theta - th on R = rr: g gains the limit's value */
			for (j = 0; j < P->nf; j++)
				x->th[j] += L.th[j];
			rterm -= L.value;
		}
		p = x->p;
		th = x->th;
		dual = x->F - rterm;
		kl = x->kl;
	}
	if (T) {
		for (j = 0; j < P0->nf; j++)
			for (th0[j] = 0.0, k = 0; k < P->nf; k++)
				th0[j] += T[(size_t)j * P->nf + k] * th[k];
		th = th0;
	}
	map_back(c->pb, P0, p, th, c->fs, c->rmax, c->scale, eta, dual, kl, r);
	r->iterations += w.evals;
	r->rank = P->nf;
	r->cond = hess_cond(&w, P->nf);
	path_name(w.path | (w.mfree ? PATH_CG : 0) | (T ? (c->span ? PATH_SPAN : PATH_REDUCED) : 0),
	          r->path, sizeof r->path);
	certify(c, &L, verdict, T != NULL, r);
	if (bailed)
		*bailed = verdict == V_FAILED && w.stalled;
done:
	work_free(&w);
	free(L.p);
	free(L.th);
	free(L.lam);
	free(L.rr);
	return st;
}

/* The second attempt, after the first failed on dense features or left a
 * Hessian too ill-conditioned to trust its digits (cond > COND_RETRY): the
 * same problem on the reduced basis (prob_reduce), measured against the
 * exact target. Replaces *r when it certifies. */
static int retry_reduced(const ctx_t *c, const prob *P, pr_reps_result **r)
{
	const pr_reps_problem *pb = c->pb;
	pr_reps_result *r2 = result_new(pb->n, pb->d);
	double *T = NULL, cond = 1.0;
	prob Q;
	int st;

	memset(&Q, 0, sizeof Q);
	st = !r2 ? PR_ENOMEM : P->nf >= P->m ? prob_reduce_wide(&Q, P, c, &T, &cond) :
	     prob_reduce(&Q, P, c, &T, &cond);
	if (st == PR_OK) {
		r2->iterations = (*r)->iterations;
		st = attempt(c, &Q, P, T, 0, NULL, r2);
	}
	if (st == PR_OK && r2->status != PR_REPS_FAILED) {
		pr_reps_result_free(*r);
		*r = r2;
		r2 = NULL;
	} else if (st == PR_OK && (*r)->status == PR_REPS_FAILED) {
		size_t l = strlen((*r)->reason);

		snprintf((*r)->reason + l, sizeof (*r)->reason - l, "; on a reduced basis (rank %d, "
		         "condition %.3g): %s", Q.nf, cond, r2->reason);
		(*r)->iterations = r2->iterations;
	}
	pr_reps_result_free(r2);
	prob_free(&Q);
	free(T);
	return st;
}

/* p = q for returns that are all equal (on q > 0): every p with matched
 * features earns the same, and q is the closest to q. */
static void solve_constant(const ctx_t *c, pr_reps_result *r)
{
	memcpy(r->p, c->qn, (size_t)c->pb->n * sizeof *r->p);
	r->dual = c->rmax;
	r->constant = 1;
	r->status = PR_REPS_UNREACHABLE;
	r->kl_gap = c->o->epsilon;
	r->cond = 1.0;
	snprintf(r->path, sizeof r->path, "constant");
	certify_features(c->pb, c->rows, c->m, c->phat, c->fs, NULL, 0.0, r, c->tmp);
	if (!(r->residual_rel <= PR_REPS_TOL)) {
		r->status = PR_REPS_FAILED;
		snprintf(r->reason, sizeof r->reason, "feature residual %.3g > %g", r->residual_rel,
		         PR_REPS_TOL);
	}
}

/* A span of every centred direction (rank m - 1): sum p zeta = sum q zeta
 * and sum p = 1 leave p = q alone, the linear programme's one feasible
 * point, so the eta -> 0 limit is q (KL 0 < eps, unreachable) with LP gap
 * and outside mass 0, and theta the LP dual whose reduced costs all vanish:
 * R - zeta th constant, th = sum q zeta (R - sum q R) (zeta is
 * q-orthonormal). Certified on the original features as any answer. */
static int span_full(const ctx_t *c, const prob *Q, const prob *P, const double *T,
                     pr_reps_result *r)
{
	double *th = calloc((size_t)Q->nf, sizeof *th), *th0 = c->tmp + c->pb->d, rq = 0.0;
	limit_t L;
	int i, j, k;

	if (!th)
		return PR_ENOMEM;
	memset(&L, 0, sizeof L);
	for (i = 0; i < Q->m; i++)
		rq += Q->q[i] * Q->R[i];
	for (i = 0; i < Q->m; i++)
		for (k = 0; k < Q->nf; k++)
			th[k] += Q->q[i] * Q->psi[(size_t)i * Q->nf + k] * (Q->R[i] - rq);
	for (j = 0; j < P->nf; j++)
		for (th0[j] = 0.0, k = 0; k < Q->nf; k++)
			th0[j] += T[(size_t)j * Q->nf + k] * th[k];
	free(th);
	map_back(c->pb, P, Q->q, th0, c->fs, c->rmax, c->scale, 0.0, rq, 0.0, r);
	r->rank = Q->nf;
	r->cond = 1.0;
	path_name(PATH_LIMIT | PATH_SPAN, r->path, sizeof r->path);
	certify(c, &L, V_UNREACHABLE, 1, r);
	return PR_OK;
}

/* Dense features at least as many as the samples: the dual lives on
 * their span, of dimension below m, so the reduced basis of
 * prob_reduce_wide is the one attempt (the span first, not a retry after a
 * Hessian of order nf). */
static int solve_wide(ctx_t *c, const prob *P, pr_reps_result *r)
{
	double *T = NULL, cond = 1.0;
	prob Q;
	int st;

	memset(&Q, 0, sizeof Q);
	c->span = 1;
	st = prob_reduce_wide(&Q, P, c, &T, &cond);
	if (st == PR_OK && Q.nf == Q.m - 1)
		st = span_full(c, &Q, P, T, r);
	else if (st == PR_OK)
		st = attempt(c, &Q, P, T, 0, NULL, r);
	prob_free(&Q);
	free(T);
	return st;
}

/* The attempt on P's own features, then the reduced basis if it failed or
 * left a Hessian too ill-conditioned to trust (cond > COND_RETRY) on dense
 * features (retry). With retry, the first attempt also gives up when it
 * stalls (*bailed): that is where it would spend reps.max_iter in vain. */
static int two_attempts(ctx_t *c, prob *P, int retry, int *bailed, pr_reps_result **r)
{
	int st;

	*bailed = 0;
	if (c->mfree)
		return attempt(c, P, P, NULL, 0, NULL, *r);
	/* NLopt keeps its own path: it has no eta -> 0 limit to certify */
	if (retry && P->nf >= P->m && c->o->solver == PR_REPS_SOLVER_NEWTON)
		return solve_wide(c, P, *r);
	st = attempt(c, P, P, NULL, retry, bailed, *r);
	if (st == PR_OK && ((*r)->status == PR_REPS_FAILED || (*r)->cond > COND_RETRY) && retry) {
		/* standardise again: the search shifted P's returns */
		standardise(c->pb->R, c->rows, P->q, c->m, P->R, &c->rmax, &c->scale);
		st = retry_reduced(c, P, r);
	}
	return st;
}

/* PR_ENOMEM, before the solver allocates more than P's features, when its
 * peak (pr_wide_bytes) exceeds the memory the process may use. */
static int fits_memory(const prob *P, int mfree, char *err)
{
	const double need = pr_wide_bytes(P->m, P->nf, P->bin, mfree), have = pr_wide_memory();

	if (need <= have)
		return PR_OK;
	return pr_err(err, PR_ENOMEM, "reps: %d samples x %d free features need about %.3g GiB, "
	              "more than the %.3g GiB of memory", P->m, P->nf, need / 1073741824.0,
	              have / 1073741824.0);
}

static int solve(const pr_reps_opts *o, const pr_reps_problem *pb, pr_reps_result **out,
                 char *err)
{
	pr_reps_result *r = NULL;
	prob P;
	ctx_t c;
	double *qn = NULL, *Rs, *qs, *phat, *fs;
	int *rows = NULL, *fx, m = 0, i, j, st, retry, bailed;
	size_t n, d;

	memset(&P, 0, sizeof P);
	if ((st = check_opts(o, err)) != PR_OK)
		return st;
	if (pb->n < 2)
		return pr_err(err, PR_EINVAL, "reps: need at least 2 samples (got %d)", pb->n);
	n = (size_t)pb->n;
	d = (size_t)(pb->d > 0 ? pb->d : 0);
	qn = malloc((3 * n + 5 * d + 2) * sizeof *qn);
	rows = malloc((n + d + 1) * sizeof *rows);
	r = result_new(pb->n, pb->d);
	if (!qn || !rows || !r) {
		st = pr_err(err, PR_ENOMEM, "reps: out of memory");
		goto done;
	}
	Rs = qn + n;
	qs = Rs + n;
	phat = qs + n;
	fs = phat + d;
	fx = rows + n;
	if ((st = check_problem(pb, qn, err)) != PR_OK)
		goto done;
	for (i = 0; i < pb->n; i++)
		if (qn[i] > 0.0) {
			qs[m] = qn[i];
			rows[m++] = i;
		}
	if (d > 0)
		feature_stats(pb, rows, qs, m, phat, fs);
	c = (ctx_t){o, pb, rows, m, qn, phat, fs, 0.0, 1.0, fs + d, NULL, 0, 0};
	if (d > 0 && (pb->phi || pb->val)) {
		/* dense features: what phat, a double, leaves of sum q phi */
		c.corr = fs + 3 * d + 2;
		memset(c.corr, 0, d * sizeof *c.corr);
		for (i = 0; i < m; i++)
			for (j = 0; j < pb->d; j++)
				c.corr[j] += qs[i] * (feat(pb, rows[i], j) - phat[j]);
	}
	if (!standardise(pb->R, rows, qs, m, Rs, &c.rmax, &c.scale)) {
		solve_constant(&c, r);
		*out = r;
		r = NULL;
		goto done;
	}
	if ((i = lost_gap(pb->R, rows, Rs, m, c.rmax)) >= 0) {
		st = pr_err(err, PR_ENUM, "reps: sample %d: its return %.17g lies below the largest, "
		            "%.17g, by less than 2^-1022 of the returns' spread: no unit of a double "
		            "holds both", rows[i] + 1, pb->R[rows[i]], c.rmax);
		goto done;
	}
	if ((st = prob_main(&P, pb, rows, qs, Rs, m, phat, fs, o->epsilon, o->ridge, fx)) != PR_OK) {
		st = pr_err(err, PR_ENOMEM, "reps: out of memory");
		goto done;
	}
	retry = !P.bin && P.nf > 0 && !P.rw;
	/* wide problems (nf >= m) always have dependent directions: the span */
	c.mfree = !P.bin && P.nf > 0 && (o->solver == PR_REPS_SOLVER_CG ||
	                                 (P.nf < P.m && P.nf >= PR_MFREE_MIN));
	if ((st = fits_memory(&P, c.mfree, err)) != PR_OK)
		goto done;
	st = two_attempts(&c, &P, retry, &bailed, &r);
	if (st == PR_OK && bailed && r->status == PR_REPS_FAILED) {
		/* cut short, and the reduced basis did not certify either: the
		 * first attempt in full after all, on P built afresh */
		prob_free(&P);
		pr_reps_result_free(r);
		r = result_new(pb->n, pb->d);
		st = !r || prob_main(&P, pb, rows, qs, Rs, m, phat, fs, o->epsilon, o->ridge, fx) != PR_OK ?
		     PR_ENOMEM : two_attempts(&c, &P, 0, &bailed, &r);
	}
	if (st < 0) {
		st = pr_err(err, st, st == PR_EINTR ? "reps: interrupted" :
		            st == PR_ENOMEM ? "reps: out of memory" :
		            "reps: the Hessian of the dual could not be factorised");
		goto done;
	}
	if (!isfinite(r->dual) || !isfinite(r->eta))
		st = pr_err(err, PR_ENUM, "reps: returns too far apart: eta or the dual overflows");
	/* theta_j is in return units per feature unit: far returns or a feature
	 * of tiny spread (a subnormal one) overflow it */
	for (j = 0; st == PR_OK && j < pb->d; j++)
		if (!isfinite(r->theta[j]))
			st = pr_err(err, PR_ENUM, "reps: feature %d: theta overflows: returns spread %.3g "
			            "per feature spread %.3g is beyond a double", j, c.scale, fs[j]);
	if (st == PR_OK) {
		*out = r;
		r = NULL;
	}
done:
	pr_reps_result_free(r);
	prob_free(&P);
	free(qn);
	free(rows);
	return st;
}

/* ---- the dual as given, for tests ---- */

double pr_reps_dual(const pr_reps_problem *pb, double epsilon, double ridge,
                    const double *x, double *grad)
{
	const double eta = exp(x[0]);
	const int n = pb->n, d = pb->d > 0 ? pb->d : 0;
	double *qn = malloc((size_t)(n > 0 ? n : 1) * sizeof *qn);
	double *A = malloc((size_t)(n > 0 ? n : 1) * sizeof *A);
	double amax = -HUGE_VAL, z = 0.0, eu = 0.0, g, kl;
	int i, j;

	if (!qn || !A || check_problem(pb, qn, NULL) != PR_OK) {
		free(qn);
		free(A);
		return NAN;
	}
	for (i = 0; i < n; i++) {
		A[i] = pb->R[i];
		for (j = 0; j < d; j++)
			A[i] -= x[1 + j] * feat(pb, i, j);
		if (qn[i] > 0.0 && A[i] > amax)
			amax = A[i];
	}
	for (i = 0; i < n; i++)
		if (qn[i] > 0.0)
			z += qn[i] * exp((A[i] - amax) / eta);
	g = eta * epsilon + amax + eta * log(z);
	for (j = 0; j < d; j++) {
		g += 0.5 * ridge * x[1 + j] * x[1 + j];
		if (grad)
			grad[1 + j] = ridge * x[1 + j];
	}
	for (i = 0; i < n; i++) {
		double pi = qn[i] > 0.0 ? qn[i] * exp((A[i] - amax) / eta) / z : 0.0;

		if (pi > 0.0)
			eu += pi * (A[i] - amax) / eta;
		for (j = 0; j < d; j++) {
			double f = feat(pb, i, j);

			g += x[1 + j] * qn[i] * f;
			if (grad)
				grad[1 + j] += (qn[i] - pi) * f;
		}
	}
	kl = eu - log(z);
	if (grad)
		grad[0] = eta * (epsilon - kl);
	free(qn);
	free(A);
	return g;
}

/* ---- importance weights ---- */

int pr_reps_importance(int npol, int n, const double *logpi, const int *counts,
                       const double *logcur, double *q, double *logratio,
                       double *ess, char *err)
{
	long total = 0;
	double lmax = -HUGE_VAL, sum = 0.0, s2 = 0.0;
	int i, k;

	if (npol < 1 || n < 1)
		return pr_err(err, PR_EINVAL, "importance weights: need >= 1 policy and sample");
	for (k = 0; k < npol; k++) {
		if (counts[k] < 0)
			return pr_err(err, PR_EINVAL, "importance weights: policy %d: negative count", k);
		total += counts[k];
	}
	if (total != n)
		return pr_err(err, PR_EINVAL,
		              "importance weights: counts sum to %ld, window holds %d samples",
		              total, n);
	for (i = 0; i < n; i++) {
		double mx = -HUGE_VAL, se = 0.0, lr;

		if (isnan(logcur[i]) || logcur[i] == HUGE_VAL)
			return pr_err(err, PR_EINVAL, "importance weights: sample %d: bad current log-density", i);
		/* log pi_mix = log sum_k exp(log(c_k/n) + log pi_k), max subtracted;
		 * log(c_k/n) is exactly 0 for a single drawing policy, so then r_i = 1. */
		for (k = 0; k < npol; k++) {
			double v = logpi[(size_t)k * n + i];

			if (isnan(v) || v == HUGE_VAL)
				return pr_err(err, PR_EINVAL,
				              "importance weights: sample %d, policy %d: bad log-density", i, k);
			if (counts[k] > 0 && log((double)counts[k] / n) + v > mx)
				mx = log((double)counts[k] / n) + v;
		}
		if (mx == -HUGE_VAL)
			return pr_err(err, PR_EINVAL,
			              "importance weights: sample %d has zero density under every drawing policy",
			              i);
		for (k = 0; k < npol; k++)
			if (counts[k] > 0)
				se += exp(log((double)counts[k] / n) + logpi[(size_t)k * n + i] - mx);
		lr = logcur[i] - (mx + log(se));
		q[i] = lr;
		if (lr > lmax)
			lmax = lr;
	}
	if (lmax == -HUGE_VAL)
		return pr_err(err, PR_EINVAL, "importance weights: the current policy gives every sample zero density");
	for (i = 0; i < n; i++) {
		if (logratio)
			logratio[i] = q[i];
		q[i] = exp(q[i] - lmax);
		sum += q[i];
	}
	for (i = 0; i < n; i++) {
		q[i] /= sum;
		s2 += q[i] * q[i];
	}
	if (ess)
		*ess = 1.0 / s2;
	return PR_OK;
}
