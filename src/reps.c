/* reps.c — episodic contextual REPS: the dual eq. 3.8, its gradient, the
 * L-BFGS solve with exact back-mapping of standardised returns, the checks
 * of SPEC.md §4, and importance weights for sample reuse. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_eigen.h>
#include <gsl/gsl_matrix.h>
#include <nlopt.h>

#include "poolreps/reps.h"

void pr_reps_opts_init(pr_reps_opts *o)
{
	o->epsilon = 0.5;
	o->ridge = 0.0;
	o->max_iter = 2000;
	o->eta_min = 1e-8;
}

/* Everything one dual evaluation needs; the last evaluation's weights,
 * KL(p||q) and Var_p((R - theta^T phi)/eta) stay behind for the checks. */
typedef struct {
	int n, d;
	const double *R;      /* returns (standardised by pr_reps_solve) */
	const double *q;      /* base weights, sum 1 */
	const double *phi;    /* dense features, or NULL */
	const int *rowptr, *col;
	const double *val;
	const double *phihat; /* sum_i q_i phi_i */
	double eps, ridge;
	double *A;            /* n: R_i - theta^T phi_i */
	double *p;            /* n: weights at the last evaluation */
	double kl, var;       /* KL(p||q), Var_p(A/eta) at the last evaluation */
	double amax;          /* max A_i at the last evaluation */
	int evals;
	int groups;           /* > 0: one-hot features in this many blocks (IPF path) */
	double *mx, *sm, *sv; /* IPF scratch: d, d, n */
} dual_ctx;

static double row_dot(const dual_ctx *c, int i, const double *theta)
{
	double s = 0.0;
	int j;

	if (c->d == 0)
		return 0.0;
	if (c->phi) {
		const double *r = c->phi + (size_t)i * c->d;
		for (j = 0; j < c->d; j++)
			s += r[j] * theta[j];
		return s;
	}
	/* one-hot rows (val NULL): 1.0 * theta is theta exactly */
	if (!c->val) {
		for (j = c->rowptr[i]; j < c->rowptr[i + 1]; j++)
			s += theta[c->col[j]];
		return s;
	}
	for (j = c->rowptr[i]; j < c->rowptr[i + 1]; j++)
		s += c->val[j] * theta[c->col[j]];
	return s;
}

/* acc += a * phi_i */
static void row_add(const dual_ctx *c, int i, double a, double *acc)
{
	int j;

	if (c->d == 0 || a == 0.0)
		return;
	if (c->phi) {
		const double *r = c->phi + (size_t)i * c->d;
		for (j = 0; j < c->d; j++)
			acc[j] += a * r[j];
		return;
	}
	if (!c->val) {
		for (j = c->rowptr[i]; j < c->rowptr[i + 1]; j++)
			acc[c->col[j]] += a;
		return;
	}
	for (j = c->rowptr[i]; j < c->rowptr[i + 1]; j++)
		acc[c->col[j]] += a * c->val[j];
}

/* g(eta, theta) of eq. 3.8 plus (ridge/2)|theta|^2 at x = (log eta, theta).
 * The maximum of A over samples with q_i > 0 is subtracted before exp, so
 * log sum q exp(A/eta) = amax/eta + log Zs never overflows. With
 * p_i = q_i exp((A_i - amax)/eta) / Zs:
 *   KL(p||q) = sum p_i (A_i - amax)/eta - log Zs,
 *   dg/dlog eta = eta (eps - KL), dg/dtheta = phi_hat - sum p phi + ridge theta.
 * grad may be NULL. */
static double dual_eval(dual_ctx *c, const double *x, double *grad)
{
	const double eta = exp(x[0]);
	const double *th = x + 1;
	double amax = -HUGE_VAL, zs = 0.0, eu = 0.0, eu2 = 0.0, g, th2 = 0.0;
	int i, j;

	c->evals++;
	for (i = 0; i < c->n; i++) {
		if (c->q[i] <= 0.0)
			continue;
		c->A[i] = c->R[i] - row_dot(c, i, th);
		if (c->A[i] > amax)
			amax = c->A[i];
	}
	for (i = 0; i < c->n; i++) {
		c->p[i] = c->q[i] > 0.0 ? c->q[i] * exp((c->A[i] - amax) / eta) : 0.0;
		zs += c->p[i];
	}
	for (i = 0; i < c->n; i++) {
		double u;

		if (c->q[i] <= 0.0)
			continue;
		c->p[i] /= zs;
		u = (c->A[i] - amax) / eta;
		eu += c->p[i] * u;
		eu2 += c->p[i] * u * u;
	}
	c->amax = amax;
	c->kl = eu - log(zs);
	c->var = eu2 - eu * eu;
	if (c->var < 0.0)
		c->var = 0.0;
	for (j = 0; j < c->d; j++)
		th2 += th[j] * th[j];
	g = eta * c->eps + amax + eta * log(zs) + 0.5 * c->ridge * th2;
	for (j = 0; j < c->d; j++)
		g += th[j] * c->phihat[j];
	if (grad) {
		grad[0] = eta * (c->eps - c->kl);
		for (j = 0; j < c->d; j++)
			grad[1 + j] = c->phihat[j] + c->ridge * th[j];
		for (i = 0; i < c->n; i++)
			row_add(c, i, -c->p[i], grad + 1);
	}
	return g;
}

/* Checks the problem and fills the normalised base weights qn. */
static int check_problem(const pr_reps_problem *pb, double *qn, char *err)
{
	double sq = 0.0;
	int i, j;

	if (pb->n < 1)
		return pr_err(err, PR_EINVAL, "reps: no samples");
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
		}
	}
	return PR_OK;
}

static void ctx_setup(dual_ctx *c, const pr_reps_problem *pb, const double *R,
                      const double *qn, double *phihat, double eps, double ridge)
{
	int i;

	c->n = pb->n;
	c->d = pb->d;
	c->R = R;
	c->q = qn;
	c->phi = pb->phi;
	c->rowptr = pb->rowptr;
	c->col = pb->col;
	c->val = pb->val;
	c->eps = eps;
	c->ridge = ridge;
	memset(phihat, 0, (size_t)pb->d * sizeof *phihat);
	for (i = 0; i < pb->n; i++)
		row_add(c, i, qn[i], phihat);
	c->phihat = phihat;
	c->evals = 0;
}

double pr_reps_dual(const pr_reps_problem *pb, double epsilon, double ridge,
                    const double *x, double *grad)
{
	dual_ctx c;
	double *buf, g;
	size_t n = (size_t)pb->n, d = (size_t)(pb->d > 0 ? pb->d : 0);

	buf = malloc((3 * n + d + 1) * sizeof *buf);
	if (!buf)
		return NAN;
	if (check_problem(pb, buf, NULL) != PR_OK) {
		free(buf);
		return NAN;
	}
	memset(&c, 0, sizeof c);
	c.A = buf + n;
	c.p = buf + 2 * n;
	ctx_setup(&c, pb, pb->R, buf, buf + 3 * n, epsilon, ridge);
	g = dual_eval(&c, x, grad);
	free(buf);
	return g;
}

/* Feature count up to which the Newton polish runs (O(n d^2 + d^3) a step). */
#define NEWTON_MAX_D 200

/* L-BFGS through NLopt, on x = (log eta, theta) with log eta >= ymin, or on
 * theta alone with eta fixed (fix = 1). */
typedef struct {
	dual_ctx *c;
	int fix;
	double *x, *g;   /* d+1 scratch for the fixed-eta case */
	double best_f;
	double *best;    /* best point seen, in the optimiser's coordinates */
	nlopt_opt opt;
} lbfgs_ctx;

static double lbfgs_obj(unsigned m, const double *v, double *grad, void *data)
{
	lbfgs_ctx *l = data;
	double f;

	if (l->fix) {
		memcpy(l->x + 1, v, m * sizeof *v);
		f = dual_eval(l->c, l->x, grad ? l->g : NULL);
		if (grad)
			memcpy(grad, l->g + 1, m * sizeof *grad);
	} else {
		f = dual_eval(l->c, v, grad);
	}
	if (isfinite(f) && f < l->best_f) {
		l->best_f = f;
		memcpy(l->best, v, m * sizeof *v);
	}
	if (pr_interrupted)
		nlopt_force_stop(l->opt);
	return f;
}

/* Runs L-BFGS from x and leaves the best point it saw in x (it may stop on
 * round-off, which is fine: the polish follows). Returns the NLopt code. */
static int lbfgs(dual_ctx *c, double *x, double ymin, int fix, int max_iter)
{
	const size_t nx = (size_t)c->d + 1, m = fix ? nx - 1 : nx;
	double *buf, *start = fix ? x + 1 : x, f;
	lbfgs_ctx l;
	nlopt_result nr;
	size_t j;

	if (m == 0)
		return NLOPT_SUCCESS;
	buf = malloc(5 * nx * sizeof *buf);
	l.opt = buf ? nlopt_create(NLOPT_LD_LBFGS, (unsigned)m) : NULL;
	if (!l.opt) {
		free(buf);
		return NLOPT_OUT_OF_MEMORY;
	}
	l.c = c;
	l.fix = fix;
	l.x = buf;
	l.g = buf + nx;
	l.best = buf + 2 * nx;
	l.best_f = HUGE_VAL;
	memcpy(l.x, x, nx * sizeof *x);
	memcpy(l.best, start, m * sizeof *x);
	memcpy(buf + 3 * nx, start, m * sizeof *x);
	for (j = 0; j < m; j++)
		buf[4 * nx + j] = -HUGE_VAL;
	if (!fix)
		buf[4 * nx] = ymin;
	if (nlopt_set_min_objective(l.opt, lbfgs_obj, &l) < 0 ||
	    nlopt_set_lower_bounds(l.opt, buf + 4 * nx) < 0 ||
	    nlopt_set_ftol_rel(l.opt, 1e-15) < 0 ||
	    nlopt_set_xtol_rel(l.opt, 1e-12) < 0 ||
	    nlopt_set_maxeval(l.opt, max_iter) < 0 ||
	    /* NLopt's default keeps about 4 MB / dim correction pairs: with
	     * thousands of features every step then costs O(steps x dim) */
	    nlopt_set_vector_storage(l.opt, 50) < 0)
		nr = NLOPT_INVALID_ARGS;
	else
		nr = nlopt_optimize(l.opt, buf + 3 * nx, &f);
	if (isfinite(l.best_f))
		memcpy(start, l.best, m * sizeof *x);
	if (!fix && x[0] < ymin)
		x[0] = ymin;
	nlopt_destroy(l.opt);
	free(buf);
	return nr;
}

/* Newton's method after L-BFGS, to bring the gradient to round-off so that
 * the weights do not depend on where L-BFGS stopped. The Hessian of eq. 3.8
 * in (eta, theta) is (1/eta) Cov_p(v) with v_i = (A_i/eta, phi_i), plus the
 * ridge on the theta block; it is positive semi-definite, and singular
 * directions (e.g. a constant feature) are dropped by an eigenvalue
 * pseudo-inverse. Armijo backtracking keeps g decreasing and eta above
 * eta_min. fix = 1: theta only. Returns PR_OK or PR_ENOMEM. */
static int newton(dual_ctx *c, double *x, double ymin, int fix)
{
	const int nx = c->d + 1, off = fix ? 1 : 0, m = nx - off;
	gsl_matrix *H, *V;
	gsl_vector *ev;
	gsl_eigen_symmv_workspace *ws;
	double *b, *g, *v, *mean, *step, *xt;
	int it, i, j, k, st = PR_OK;

	if (m == 0)
		return PR_OK;
	H = gsl_matrix_alloc((size_t)m, (size_t)m);
	V = gsl_matrix_alloc((size_t)m, (size_t)m);
	ev = gsl_vector_alloc((size_t)m);
	ws = gsl_eigen_symmv_alloc((size_t)m);
	b = malloc((size_t)(5 * nx) * sizeof *b);
	if (!H || !V || !ev || !ws || !b) {
		st = PR_ENOMEM;
		goto done;
	}
	g = b;
	v = g + nx;
	mean = v + nx;
	step = mean + nx;
	xt = step + nx;
	for (it = 0; it < 50; it++) {
		double eta = exp(x[0]), f, ft, gmax = 0.0, lmax = 0.0, slope = 0.0, t;
		int ok = 0;

		f = dual_eval(c, x, g);
		for (j = off; j < nx; j++)
			gmax = fmax(gmax, fabs(g[j]));
		if (gmax <= 1e-14)
			break;
		g[0] /= eta; /* d/deta from d/dlog eta */
		/* Cov_p(v), v_i = ((A_i - amax)/eta, phi_i); the shift does not matter */
		gsl_matrix_set_zero(H);
		memset(mean, 0, (size_t)nx * sizeof *mean);
		for (i = 0; i < c->n; i++) {
			if (c->p[i] <= 0.0)
				continue;
			mean[0] += c->p[i] * (c->A[i] - c->amax) / eta;
			row_add(c, i, c->p[i], mean + 1);
		}
		for (i = 0; i < c->n; i++) {
			if (c->p[i] <= 0.0)
				continue;
			memset(v + 1, 0, (size_t)c->d * sizeof *v);
			row_add(c, i, 1.0, v + 1);
			v[0] = (c->A[i] - c->amax) / eta;
			for (j = off; j < nx; j++)
				v[j] -= mean[j];
			for (j = off; j < nx; j++) {
				/* the upper triangle of row j - off, through a raw pointer:
				 * this loop is O(n d^2) per Newton step */
				double pv = c->p[i] * v[j] / eta, *hrow = H->data + (size_t)(j - off) * H->tda;

				if (pv == 0.0)
					continue;
				for (k = j; k < nx; k++)
					hrow[k - off] += pv * v[k];
			}
		}
		for (j = 0; j < m; j++) {
			if (j + off > 0)
				*gsl_matrix_ptr(H, (size_t)j, (size_t)j) += c->ridge;
			for (k = j + 1; k < m; k++)
				gsl_matrix_set(H, (size_t)k, (size_t)j, gsl_matrix_get(H, (size_t)j, (size_t)k));
		}
		if (gsl_eigen_symmv(H, ev, V, ws) != GSL_SUCCESS)
			break;
		for (k = 0; k < m; k++)
			lmax = fmax(lmax, gsl_vector_get(ev, (size_t)k));
		memset(step, 0, (size_t)nx * sizeof *step);
		for (k = 0; k < m; k++) {
			double lk = gsl_vector_get(ev, (size_t)k), pk = 0.0;

			if (!(lk > 1e-12 * lmax))
				continue;
			for (j = 0; j < m; j++)
				pk += gsl_matrix_get(V, (size_t)j, (size_t)k) * g[j + off];
			for (j = 0; j < m; j++)
				step[j + off] -= pk / lk * gsl_matrix_get(V, (size_t)j, (size_t)k);
		}
		for (j = off; j < nx; j++)
			slope += g[j] * step[j];
		if (!(slope < 0.0))
			break;
		for (t = 1.0; t > 1e-12; t *= 0.5) {
			double en = eta + t * step[0];

			if (!(en > 0.0) || log(en) < ymin)
				continue;
			xt[0] = log(en);
			for (j = 1; j < nx; j++)
				xt[j] = x[j] + t * step[j];
			ft = dual_eval(c, xt, t == 1.0 ? v : NULL);
			if (ft <= f + 1e-4 * t * slope) {
				ok = 1;
				break;
			}
			/* Near the optimum the decrease drowns in round-off of g:
			 * take the full step if it halves the gradient. */
			if (t == 1.0 && ft <= f + 1e-12 * (1.0 + fabs(f))) {
				double gn = 0.0;

				for (j = off; j < nx; j++)
					gn = fmax(gn, fabs(v[j]));
				if (gn < 0.5 * gmax) {
					ok = 1;
					break;
				}
			}
		}
		if (!ok)
			break;
		memcpy(x, xt, (size_t)nx * sizeof *x);
	}
done:
	gsl_matrix_free(H);
	gsl_matrix_free(V);
	gsl_vector_free(ev);
	gsl_eigen_symmv_free(ws);
	free(b);
	return st;
}

/* Is dg/dtheta at x small enough to trust theta (feature units)? */
static int theta_converged(dual_ctx *c, const double *x, double *g)
{
	double fs = 1.0;
	int j;

	dual_eval(c, x, g);
	for (j = 0; j < c->d; j++)
		fs = fmax(fs, fabs(c->phihat[j]));
	for (j = 1; j <= c->d; j++)
		if (!(fabs(g[j]) <= 1e-7 * fs))
			return 0;
	return 1;
}

/* theta*(eta) for the eta in x[0], warm-started from x; returns PR_OK,
 * PR_ENOMEM or PR_EINTR and leaves KL at the solution in c->kl. */
static int ipf(dual_ctx *c, double *x, int max_sweeps);

static int theta_solve(dual_ctx *c, double *x, int max_iter)
{
	int nr;

	if (c->groups > 0)
		return ipf(c, x, max_iter);
	nr = lbfgs(c, x, 0.0, 1, max_iter);

	if (nr == NLOPT_OUT_OF_MEMORY)
		return PR_ENOMEM;
	if (nr == NLOPT_FORCED_STOP && pr_interrupted)
		return PR_EINTR;
	if (c->d <= NEWTON_MAX_D && newton(c, x, 0.0, 1) != PR_OK)
		return PR_ENOMEM;
	dual_eval(c, x, NULL);
	return PR_OK;
}

/* One-hot features that come in blocks, each block a partition of the
 * samples (the active leaves of a state forest, eq. 5.4: one leaf per tree):
 * returns the block count K when row i's j-th stored feature always belongs
 * to block j, else 0. */
static int one_hot_blocks(const pr_reps_problem *pb, int *pos)
{
	int i, j, K;

	if (pb->phi || pb->val || pb->d < 1)
		return 0;
	K = pb->rowptr[1] - pb->rowptr[0];
	if (K < 1)
		return 0;
	for (j = 0; j < pb->d; j++)
		pos[j] = -1;
	for (i = 0; i < pb->n; i++) {
		if (pb->rowptr[i + 1] - pb->rowptr[i] != K)
			return 0;
		for (j = 0; j < K; j++) {
			int f = pb->col[pb->rowptr[i] + j];

			if (pos[f] < 0)
				pos[f] = j;
			else if (pos[f] != j)
				return 0;
		}
	}
	return K;
}

/* theta*(eta) for block one-hot features by iterative proportional fitting:
 * with the other blocks fixed, the dual's optimum over one block's leaves is
 * closed-form (each leaf's p-mass must equal its q-mass, phi_hat):
 *   theta_l = eta log( sum_{i in l} q_i exp(u_i) / Q_l ),
 *   u_i = (R_i - sum of the other blocks' theta at i) / eta,
 * so sweeping over the blocks is exact block-coordinate descent on the
 * convex dual. Stops when every leaf mass matches to 1e-11 or after
 * max_sweeps sweeps. Leaves without q-mass keep theta = 0. */
static int ipf(dual_ctx *c, double *x, int max_sweeps)
{
	const double eta = exp(x[0]);
	double *th = x + 1;
	int sweep, t, i, j, K = c->groups;

	for (i = 0; i < c->n; i++) {
		c->sv[i] = 0.0;
		for (j = c->rowptr[i]; j < c->rowptr[i + 1]; j++)
			c->sv[i] += th[c->col[j]];
	}
	for (sweep = 0; sweep < max_sweeps; sweep++) {
		double gmax = 0.0;

		if (pr_interrupted)
			return PR_EINTR;
		for (t = 0; t < K; t++) {
			for (i = 0; i < c->n; i++) {
				int f = c->col[c->rowptr[i] + t];

				c->mx[f] = -HUGE_VAL;
				c->sm[f] = 0.0;
			}
			/* u_i kept in A (free here: dual_eval refills it) */
			for (i = 0; i < c->n; i++) {
				int f = c->col[c->rowptr[i] + t];
				double u = (c->R[i] - c->sv[i] + th[f]) / eta;

				c->A[i] = u;
				if (c->q[i] > 0.0 && u > c->mx[f])
					c->mx[f] = u;
			}
			for (i = 0; i < c->n; i++) {
				int f = c->col[c->rowptr[i] + t];

				if (c->q[i] > 0.0)
					c->sm[f] += c->q[i] * exp(c->A[i] - c->mx[f]);
			}
			/* new theta per leaf (sm < 0 marks a leaf already updated) */
			for (i = 0; i < c->n; i++) {
				int f = c->col[c->rowptr[i] + t];

				if (c->sm[f] > 0.0 && c->phihat[f] > 0.0) {
					double nt = eta * (c->mx[f] + log(c->sm[f]) - log(c->phihat[f]));

					c->mx[f] = nt - th[f];
					th[f] = nt;
					c->sm[f] = -1.0;
				} else if (c->sm[f] >= 0.0) {
					c->mx[f] = 0.0;
					c->sm[f] = -1.0;
				}
				c->sv[i] += c->mx[f];
			}
		}
		dual_eval(c, x, c->sv + c->n);
		for (j = 1; j <= c->d; j++)
			gmax = fmax(gmax, fabs(c->sv[c->n + j]));
		if (gmax <= 1e-11)
			break;
		for (i = 0; i < c->n; i++) {
			c->sv[i] = 0.0;
			for (j = c->rowptr[i]; j < c->rowptr[i + 1]; j++)
				c->sv[i] += th[c->col[j]];
		}
	}
	dual_eval(c, x, NULL);
	return PR_OK;
}

/* Sets x[0] = log eta so that KL(p||q) = eps for the fixed theta in x. KL
 * falls monotonically with eta (dKL/dlog eta = -Var_p(A/eta)), so a
 * safeguarded Newton iteration on log eta inside a bracket converges. When
 * even eta_min gives KL < eps there is no root: x[0] = log eta_min and the
 * function returns 0 (bound inactive), else 1. */
static int polish_eta(dual_ctx *c, double *x, double ymin)
{
	double lo, hi, y = x[0], f, step;
	int it;

	dual_eval(c, x, NULL);
	f = c->kl - c->eps;
	if (fabs(f) <= 1e-13)
		return 1;
	if (f > 0.0) {
		/* KL too large: eta must grow. */
		lo = y;
		for (step = 1.0;; step *= 2.0) {
			x[0] = y + step;
			dual_eval(c, x, NULL);
			if (c->kl - c->eps <= 0.0 || step > 1e3)
				break;
			lo = x[0];
		}
		hi = x[0];
	} else {
		hi = y;
		x[0] = ymin;
		dual_eval(c, x, NULL);
		if (c->kl - c->eps < -PR_REPS_KL_TOL)
			return 0;
		if (c->kl - c->eps <= 0.0)
			return 1;
		lo = ymin;
	}
	/* Invariant: KL(lo) > eps >= KL(hi). */
	y = 0.5 * (lo + hi);
	for (it = 0; it < 200; it++) {
		double ynew;

		x[0] = y;
		dual_eval(c, x, NULL);
		f = c->kl - c->eps;
		if (fabs(f) <= 1e-13 || hi - lo <= 1e-15 * (1.0 + fabs(y)))
			break;
		if (f > 0.0)
			lo = y;
		else
			hi = y;
		ynew = c->var > 0.0 ? y + f / c->var : 0.5 * (lo + hi);
		if (!(ynew > lo && ynew < hi))
			ynew = 0.5 * (lo + hi);
		y = ynew;
	}
	return 1;
}

/* The robust path, used when L-BFGS on (log eta, theta) ended at the eta
 * bound or with theta unconverged (rich features make the dual very stiff
 * at small eta). The dual minimised over theta, h(eta) = min g(eta, .), is
 * convex with h'(eta) = eps - KL(eta, theta*(eta)), so KL along theta*(eta)
 * falls with eta. Walk eta down a decade at a time from 1 (returns are
 * standardised) with warm-started theta solves until KL >= eps; if eta_min
 * is reached first the bound is inactive (returns 0 with x at eta_min).
 * Otherwise an Illinois root search on log eta meets KL = eps (returns 1).
 * A negative return is an error status. */
static int continuation(dual_ctx *c, double *x, double ymin, int max_iter)
{
	const int nx = c->d + 1;
	double *th_lo, *th_hi, ylo, yhi, flo, fhi, y, f;
	int it, st, side = 0;

	th_lo = malloc(2 * (size_t)nx * sizeof *th_lo);
	if (!th_lo)
		return PR_ENOMEM;
	th_hi = th_lo + nx;
	memset(x, 0, (size_t)nx * sizeof *x);
	if ((st = theta_solve(c, x, max_iter)) != PR_OK)
		goto done;
	f = c->kl - c->eps;
	if (f > 0.0) {
		/* KL too large already at eta = 1: go up. */
		memcpy(th_lo, x, (size_t)nx * sizeof *x);
		flo = f;
		for (it = 0; it < 40 && f > 0.0; it++) {
			x[0] += log(10.0);
			if ((st = theta_solve(c, x, max_iter)) != PR_OK)
				goto done;
			f = c->kl - c->eps;
			if (f > 0.0) {
				memcpy(th_lo, x, (size_t)nx * sizeof *x);
				flo = f;
			}
		}
		memcpy(th_hi, x, (size_t)nx * sizeof *x);
		fhi = f;
	} else {
		memcpy(th_hi, x, (size_t)nx * sizeof *x);
		fhi = f;
		while (f <= 0.0) {
			if (x[0] <= ymin) {
				st = 0;
				goto done;
			}
			x[0] = fmax(x[0] - log(10.0), ymin);
			if ((st = theta_solve(c, x, max_iter)) != PR_OK)
				goto done;
			f = c->kl - c->eps;
			if (f <= 0.0) {
				memcpy(th_hi, x, (size_t)nx * sizeof *x);
				fhi = f;
			}
		}
		memcpy(th_lo, x, (size_t)nx * sizeof *x);
		flo = f;
	}
	/* Illinois on log eta: KL(ylo) > eps >= KL(yhi). */
	ylo = th_lo[0];
	yhi = th_hi[0];
	for (it = 0; it < 100 && fabs(fhi) > 1e-10; it++) {
		y = (ylo * fhi - yhi * flo) / (fhi - flo);
		if (!(y > ylo && y < yhi))
			y = 0.5 * (ylo + yhi);
		memcpy(x, fabs(y - ylo) < fabs(y - yhi) ? th_lo : th_hi, (size_t)nx * sizeof *x);
		x[0] = y;
		if ((st = theta_solve(c, x, max_iter)) != PR_OK)
			goto done;
		f = c->kl - c->eps;
		if (f > 0.0) {
			memcpy(th_lo, x, (size_t)nx * sizeof *x);
			ylo = y;
			flo = f;
			if (side == -1)
				fhi *= 0.5;
			side = -1;
		} else {
			memcpy(th_hi, x, (size_t)nx * sizeof *x);
			yhi = y;
			fhi = f;
			if (side == 1)
				flo *= 0.5;
			side = 1;
		}
		if (yhi - ylo <= 1e-14 * (1.0 + fabs(yhi)))
			break;
	}
	memcpy(x, th_hi, (size_t)nx * sizeof *x);
	st = 1;
done:
	free(th_lo);
	return st;
}

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

/* |sum p phi - phi_hat| and 1/sum p^2 for the weights in r. */
static void finish_checks(const dual_ctx *c, pr_reps_result *r, double *tmp)
{
	double s = 0.0;
	int i, j;

	for (j = 0; j < c->d; j++)
		tmp[j] = -c->phihat[j];
	for (i = 0; i < c->n; i++)
		row_add(c, i, r->p[i], tmp);
	for (j = 0; j < c->d; j++)
		s += tmp[j] * tmp[j];
	r->residual = sqrt(s);
	s = 0.0;
	for (i = 0; i < c->n; i++)
		s += r->p[i] * r->p[i];
	r->ess = 1.0 / s;
}

static int check_opts(const pr_reps_opts *o, char *err)
{
	if (!(o->epsilon > 0.0) || !isfinite(o->epsilon))
		return pr_err(err, PR_EINVAL, "reps.epsilon: must be > 0 (got %g)", o->epsilon);
	if (!(o->ridge >= 0.0) || !isfinite(o->ridge))
		return pr_err(err, PR_EINVAL, "reps.ridge: must be >= 0 (got %g)", o->ridge);
	if (o->max_iter < 1)
		return pr_err(err, PR_EINVAL, "reps.max_iter: must be >= 1 (got %d)", o->max_iter);
	if (!(o->eta_min > 0.0 && o->eta_min < 1.0))
		return pr_err(err, PR_EINVAL, "reps.eta_min: must be in (0, 1) (got %g)", o->eta_min);
	return PR_OK;
}

/* The solve runs on R' = (R - m)/s with m, s the q-weighted mean and std.
 * Then p is unchanged, eta = s eta', theta = s theta' and
 * g(eta, theta; R) = m + s g'(eta', theta'; R') exactly (eq. 3.8 is
 * positively homogeneous in (R, eta, theta) and shifts with R). */
int pr_reps_solve(const pr_reps_opts *o, const pr_reps_problem *pb,
                  pr_reps_result **out, char *err)
{
	dual_ctx c;
	pr_reps_result *r = NULL;
	double *buf = NULL, *ipfbuf = NULL, *qn, *Rs, *phihat, *x, *tmp;
	double m = 0.0, s = 0.0, rmin = HUGE_VAL, rmax = -HUGE_VAL, amax = 0.0, f, ymin;
	size_t n, d;
	int i, st, nx, active, nr;

	st = check_opts(o, err);
	if (st != PR_OK)
		return st;
	if (pb->n < 1)
		return pr_err(err, PR_EINVAL, "reps: no samples");
	n = (size_t)pb->n;
	d = (size_t)(pb->d > 0 ? pb->d : 0);
	nx = (int)d + 1;
	buf = malloc((4 * n + 3 * d + 2) * sizeof *buf);
	r = result_new(pb->n, pb->d);
	if (!buf || !r) {
		st = pr_err(err, PR_ENOMEM, "reps: out of memory");
		goto done;
	}
	qn = buf;
	Rs = qn + n;
	memset(&c, 0, sizeof c);
	c.A = Rs + n;
	c.p = c.A + n;
	tmp = c.p + n;       /* d + 1 */
	phihat = tmp + d + 1;
	x = phihat + d;      /* d + 1 */
	st = check_problem(pb, qn, err);
	if (st != PR_OK)
		goto done;

	for (i = 0; i < pb->n; i++) {
		if (qn[i] <= 0.0)
			continue;
		m += qn[i] * pb->R[i];
		if (pb->R[i] < rmin)
			rmin = pb->R[i];
		if (pb->R[i] > rmax)
			rmax = pb->R[i];
		if (fabs(pb->R[i]) > amax)
			amax = fabs(pb->R[i]);
	}
	for (i = 0; i < pb->n; i++)
		if (qn[i] > 0.0)
			s += qn[i] * (pb->R[i] - m) * (pb->R[i] - m);
	s = sqrt(s);
	ctx_setup(&c, pb, Rs, qn, phihat, o->epsilon, o->ridge);

	/* Returns equal up to rounding: every eta gives p = q. */
	if (rmax - rmin <= 8.0 * DBL_EPSILON * amax || !(s > 0.0)) {
		memcpy(r->p, qn, n * sizeof *qn);
		r->eta = 0.0;
		r->dual = m;
		r->kl = 0.0;
		r->bound = 0;
		r->constant = 1;
		finish_checks(&c, r, tmp);
		*out = r;
		free(buf);
		return PR_OK;
	}
	for (i = 0; i < pb->n; i++)
		Rs[i] = (pb->R[i] - m) / s;

	ymin = log(o->eta_min);
	memset(x, 0, (size_t)nx * sizeof *x);
	active = -1;
	if (!pb->phi && !pb->val && o->ridge == 0.0) {
		int *pos = malloc(d * sizeof *pos);

		if (!pos) {
			st = pr_err(err, PR_ENOMEM, "reps: out of memory");
			goto done;
		}
		c.groups = one_hot_blocks(pb, pos);
		free(pos);
	}
	if (c.groups > 0) {
		/* Block one-hot features: when L-BFGS crawls on the stiff dual,
		 * the continuation below uses exact block updates (IPF) instead. */
		ipfbuf = malloc((3 * d + n + 1) * sizeof *ipfbuf);
		if (!ipfbuf) {
			st = pr_err(err, PR_ENOMEM, "reps: out of memory");
			goto done;
		}
		c.mx = ipfbuf;
		c.sm = ipfbuf + d;
		c.sv = ipfbuf + 2 * d;
	}
	nr = lbfgs(&c, x, ymin, 0, c.groups > 0 && o->max_iter > 300 ? 300 : o->max_iter);
	r->solver = nr;
	if (nr == NLOPT_FORCED_STOP && pr_interrupted) {
		st = pr_err(err, PR_EINTR, "reps: interrupted");
		goto done;
	}
	if (nr == NLOPT_OUT_OF_MEMORY || nr == NLOPT_INVALID_ARGS) {
		st = pr_err(err, PR_ENUM, "reps: L-BFGS failed (NLopt status %d)", nr);
		goto done;
	}
	if (x[0] > ymin + 1e-9) {
		if (pb->d <= NEWTON_MAX_D && newton(&c, x, ymin, 0) != PR_OK) {
			st = pr_err(err, PR_ENOMEM, "reps: out of memory");
			goto done;
		}
		if (x[0] > ymin + 1e-9 && theta_converged(&c, x, tmp) && polish_eta(&c, x, ymin))
			active = 1;
	}
	if (active < 0) {
		active = continuation(&c, x, ymin, o->max_iter);
		if (active < 0) {
			st = pr_err(err, active, active == PR_EINTR ? "reps: interrupted"
			                                            : "reps: out of memory");
			goto done;
		}
		if (active) {
			if (!c.groups && pb->d <= NEWTON_MAX_D && newton(&c, x, ymin, 0) != PR_OK) {
				st = pr_err(err, PR_ENOMEM, "reps: out of memory");
				goto done;
			}
			active = polish_eta(&c, x, ymin);
		}
	}

	/* Final evaluation without the ridge term for the reported dual. */
	c.ridge = 0.0;
	f = dual_eval(&c, x, NULL);
	memcpy(r->p, c.p, n * sizeof *c.p);
	r->kl = c.kl > 0.0 ? c.kl : 0.0;
	r->eta = s * exp(x[0]);
	for (i = 0; i < (int)d; i++)
		r->theta[i] = s * x[1 + i];
	r->dual = m + s * f;
	r->iterations = c.evals;
	r->bound = fabs(c.kl - o->epsilon) <= PR_REPS_KL_TOL;
	if (active && !r->bound) {
		st = pr_err(err, PR_ENUM, "reps: KL(p||q) = %.9g misses epsilon = %g after the solve",
		            c.kl, o->epsilon);
		goto done;
	}
	finish_checks(&c, r, tmp);
	if (!isfinite(r->dual) || !isfinite(r->eta) || !isfinite(r->ess)) {
		st = pr_err(err, PR_ENUM, "reps: non-finite result");
		goto done;
	}
	*out = r;
	r = NULL;
	st = PR_OK;
done:
	pr_reps_result_free(r);
	free(buf);
	free(ipfbuf);
	return st;
}

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
