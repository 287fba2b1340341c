/* exp3_out.c — Experiment 3's outputs: the raw per-repetition CSVs of the
 * learners' episodes and iterations, and the summaries derived from those
 * files alone (so that `poolreps merge` rebuilds them byte for byte).
 *
 * Raw:
 *   exp3_episodes.csv  repetition,policy,iteration,x0,y0,...,vx,vy,return,rx,ry,pocket,hit
 *   exp3_reps.csv      repetition,policy,iteration,eta,kl,ess,bound,residual,q_ess,
 *                      features,dual_evals,redraws,policy_flags,kl_gap,residual_rel,status
 *   exp3_mean.csv      repetition,policy,episodes,states,mean_return,pocket_rate
 *                      (exp3.mean_eval > 0)
 * Derived: exp3_curve.csv (Fig. 7.7), exp3_final.csv (Fig. 7.8),
 * exp3_pockets.csv (Fig. 7.9), exp3_dist.csv (Fig. 7.10), exp3_reps_summary.csv.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "poolreps/csvio.h"
#include "poolreps/reps.h"
#include "poolreps/sim.h"
#include "exp3_priv.h"

#define DIST_BINS_PER_M 20 /* Fig. 7.10 histogram: 0.05 m bins */

/* ---- raw output ---- */

static int write_episodes(const pr_config *cfg, const pr_exp3_job *runs, int nruns,
                          const char *dir, char *err)
{
	pr_csvw *w;
	int j, i, rc = PR_OK;

	if (!(w = pr_exp_csv_open(err, "%s/exp3_episodes.csv", dir)))
		return PR_EIO;
	rc |= pr_exp3_write_episode_header(w, cfg->table.balls);
	for (j = 0; rc == PR_OK && j < nruns; ++j) {
		const pr_exp3_episodes *o = &runs[j].ep;
		for (i = 0; rc == PR_OK && i < o->n; ++i) {
			rc |= pr_csvw_int(w, runs[j].repetition);
			rc |= pr_csvw_str(w, pr_exp3_variant_name[runs[j].variant]);
			rc |= pr_exp3_write_episode(w, o, i);
		}
	}
	return pr_csvw_finish(w, rc, err);
}

int pr_exp3_write_state_names(pr_csvw *w, int nballs)
{
	char name[32];
	int b, rc = PR_OK;

	for (b = 0; b < nballs; ++b) {
		snprintf(name, sizeof name, "x%d", b);
		rc |= pr_csvw_str(w, name);
		snprintf(name, sizeof name, "y%d", b);
		rc |= pr_csvw_str(w, name);
	}
	return rc;
}

int pr_exp3_write_episode_header(pr_csvw *w, int nballs)
{
	int rc = pr_csvw_str(w, "repetition");

	rc |= pr_csvw_str(w, "policy");
	rc |= pr_csvw_str(w, "iteration");
	rc |= pr_exp3_write_state_names(w, nballs);
	return rc | pr_csvw_header(w, "vx,vy,return,rx,ry,pocket,hit");
}

int pr_exp3_write_episode(pr_csvw *w, const pr_exp3_episodes *o, int i)
{
	int b, rc = pr_csvw_int(w, o->iter[i]);

	for (b = 0; b < o->ds; ++b)
		rc |= pr_csvw_num(w, o->S[(size_t)i * o->ds + b]);
	rc |= pr_csvw_num(w, o->A[2 * i]);
	rc |= pr_csvw_num(w, o->A[2 * i + 1]);
	rc |= pr_csvw_num(w, o->R[i]);
	rc |= pr_csvw_num(w, o->F[2 * i]);
	rc |= pr_csvw_num(w, o->F[2 * i + 1]);
	rc |= pr_csvw_int(w, o->pocket[i]);
	rc |= pr_csvw_int(w, o->hit[i]);
	return rc | pr_csvw_endrow(w);
}

int pr_exp3_write_iter(pr_csvw *w, const pr_exp3_iter *r)
{
	int rc = pr_csvw_num(w, r->eta);

	rc |= pr_csvw_num(w, r->kl);
	rc |= pr_csvw_num(w, r->ess);
	rc |= pr_csvw_int(w, r->bound);
	rc |= pr_csvw_num(w, r->residual);
	rc |= pr_csvw_num(w, r->q_ess);
	rc |= pr_csvw_int(w, r->nfeat);
	rc |= pr_csvw_int(w, r->evals);
	rc |= pr_csvw_int(w, r->redraws);
	rc |= pr_csvw_int(w, r->flags);
	rc |= pr_csvw_num(w, r->kl_gap);
	rc |= pr_csvw_num(w, r->residual_rel);
	rc |= pr_csvw_str(w, pr_reps_status_name(r->status));
	return rc | pr_csvw_endrow(w);
}

static int write_reps(const pr_exp3_job *runs, int nruns, const char *dir, char *err)
{
	pr_csvw *w;
	int j, t, rc = PR_OK;

	if (!(w = pr_exp_csv_open(err, "%s/exp3_reps.csv", dir)))
		return PR_EIO;
	rc = pr_csvw_header(w, "repetition,policy,iteration," PR_EXP3_ITER_COLUMNS);
	for (j = 0; rc == PR_OK && j < nruns; ++j)
		for (t = 0; rc == PR_OK && t < runs[j].ep.niter; ++t) {
			rc |= pr_csvw_int(w, runs[j].repetition);
			rc |= pr_csvw_str(w, pr_exp3_variant_name[runs[j].variant]);
			rc |= pr_csvw_int(w, t + 1);
			rc |= pr_exp3_write_iter(w, &runs[j].ep.it[t]);
		}
	return pr_csvw_finish(w, rc, err);
}

/* exp3_mean.csv (exp3.mean_eval > 0): per run and evaluation, the episodes
 * played so far and the mean action's mean return and target-pocket rate. */
static int write_mean(const pr_exp3_opts *e, const pr_exp3_job *runs, int nruns,
                      const char *dir, char *err)
{
	pr_csvw *w;
	int j, i, rc;

	if (!(w = pr_exp_csv_open(err, "%s/exp3_mean.csv", dir)))
		return PR_EIO;
	rc = pr_csvw_header(w, "repetition,policy,episodes,states,mean_return,pocket_rate");
	for (j = 0; rc == PR_OK && j < nruns; ++j)
		for (i = 0; rc == PR_OK && i < runs[j].nmean; ++i) {
			rc |= pr_csvw_int(w, runs[j].repetition);
			rc |= pr_csvw_str(w, pr_exp3_variant_name[runs[j].variant]);
			rc |= pr_csvw_int(w, runs[j].mean_eps[i]);
			rc |= pr_csvw_int(w, e->mean_eval);
			rc |= pr_csvw_num(w, runs[j].mean_ret[i]);
			rc |= pr_csvw_num(w, runs[j].mean_pocket[i]);
			rc |= pr_csvw_endrow(w);
		}
	return pr_csvw_finish(w, rc, err);
}

int pr_exp3_write_raw(const pr_config *cfg, const pr_exp3_job *runs, int nruns, const char *dir,
                      char *err)
{
	const pr_exp3_opts *e = pr_exp3_opts_of(cfg);
	int rc = write_episodes(cfg, runs, nruns, dir, err);

	if (rc == PR_OK)
		rc = write_reps(runs, nruns, dir, err);
	if (rc == PR_OK && e->mean_eval > 0)
		rc = write_mean(e, runs, nruns, dir, err);
	return rc;
}

/* ---- summaries (from the raw CSVs on disk only) ---- */

/* The raw episodes, parsed. */
typedef struct {
	long n;
	int nv, nr, T;     /* labels (in their order), repetitions found, iterations */
	long *rep;         /* nr sorted repetition numbers */
	int *v, *r, *it;   /* per row: variant, repetition index, iteration */
	int *pocket;
	double *ret, *dist;
} episodes;

static void episodes_free(episodes *E)
{
	free(E->rep);
	free(E->v);
	free(E->r);
	free(E->it);
	free(E->pocket);
	free(E->ret);
	free(E->dist);
}

static int cmp_long(const void *a, const void *b)
{
	long x = *(const long *)a, y = *(const long *)b;

	return (x > y) - (x < y);
}

int pr_exp3_is_target(const pr_reward_opts *ro, int pocket)
{
	int j;

	for (j = 0; j < ro->ntargets; ++j)
		if (ro->targets[j] == pocket)
			return 1;
	return 0;
}

/* Index of a label within lb, or -1. */
static int variant_of(const char *name, const pr_exp3_labels *lb)
{
	int j;

	for (j = 0; j < lb->n; ++j)
		if (strcmp(lb->name[j], name) == 0)
			return j;
	return -1;
}

double pr_exp3_target_distance(const pr_config *cfg, int pocket, double rx, double ry)
{
	double best = HUGE_VAL, p[2];
	int j;

	if (pr_exp3_is_target(&cfg->reward, pocket))
		return 0.0;
	for (j = 0; j < cfg->reward.ntargets; ++j) {
		double d;
		pr_sim_pocket_xy(&cfg->table, cfg->reward.targets[j], p);
		d = hypot(rx - p[0], ry - p[1]);
		if (d < best)
			best = d;
	}
	return best;
}

static int read_episodes(const pr_config *cfg, const char *dir, const pr_exp3_labels *lb,
                         episodes *E, char *err)
{
	enum { C_REP, C_POL, C_IT, C_RET, C_RX, C_RY, C_POCKET, NC };
	static const char *const cname[NC] = {
		"repetition", "policy", "iteration", "return", "rx", "ry", "pocket"
	};
	char path[PR_PATHLEN];
	pr_exp_table *t = NULL;
	int col[NC], c, rc;
	long i, j, x;

	memset(E, 0, sizeof *E);
	E->nv = lb->n;
	E->T = pr_exp3_opts_of(cfg)->iterations;
	snprintf(path, sizeof path, "%s/%s_episodes.csv", dir, lb->prefix);
	if ((rc = pr_exp_table_read(path, &t, err)))
		return rc;
	for (c = 0; c < NC; ++c)
		if ((col[c] = pr_exp_table_col(t, cname[c], err)) < 0) {
			pr_exp_table_free(t);
			return col[c];
		}
	E->n = pr_exp_table_nrows(t);
	E->rep = malloc(((size_t)E->n + 1) * sizeof *E->rep);
	E->v = malloc(((size_t)E->n + 1) * sizeof *E->v);
	E->r = malloc(((size_t)E->n + 1) * sizeof *E->r);
	E->it = malloc(((size_t)E->n + 1) * sizeof *E->it);
	E->pocket = malloc(((size_t)E->n + 1) * sizeof *E->pocket);
	E->ret = malloc(((size_t)E->n + 1) * sizeof *E->ret);
	E->dist = malloc(((size_t)E->n + 1) * sizeof *E->dist);
	if (!E->rep || !E->v || !E->r || !E->it || !E->pocket || !E->ret || !E->dist) {
		pr_exp_table_free(t);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	for (i = 0; rc == PR_OK && i < E->n; ++i) {
		double rx, ry;
		if ((rc = pr_exp_table_int(t, i, col[C_REP], 0, 9999, &E->rep[i], err)) ||
		    (rc = pr_exp_table_int(t, i, col[C_IT], 0, E->T, &x, err)))
			break;
		E->it[i] = (int)x;
		if ((rc = pr_exp_table_int(t, i, col[C_POCKET], -1, PR_SIM_POCKETS - 1, &x, err)))
			break;
		E->pocket[i] = (int)x;
		if ((rc = pr_exp_table_num(t, i, col[C_RET], &E->ret[i], err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_RX], &rx, err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_RY], &ry, err)))
			break;
		E->dist[i] = pr_exp3_target_distance(cfg, E->pocket[i], rx, ry);
		if ((E->v[i] = variant_of(pr_exp_table_str(t, i, col[C_POL]), lb)) < 0)
			rc = pr_err(err, PR_EIO, "%s: row %ld: policy '%.40s' is not in %s",
			            path, i + 2, pr_exp_table_str(t, i, col[C_POL]), lb->key);
	}
	pr_exp_table_free(t);
	if (rc)
		return rc;
	if (E->n == 0)
		return pr_err(err, PR_EIO, "%s: no episodes", path);
	/* repetition numbers -> indices 0..nr-1 */
	for (i = 0; i < E->n; ++i)
		E->r[i] = 0;
	{
		long *sorted = malloc((size_t)E->n * sizeof *sorted);
		if (!sorted)
			return pr_err(err, PR_ENOMEM, "out of memory");
		memcpy(sorted, E->rep, (size_t)E->n * sizeof *sorted);
		qsort(sorted, (size_t)E->n, sizeof *sorted, cmp_long);
		for (i = 0, j = 0; i < E->n; ++i)
			if (i == 0 || sorted[i] != sorted[j - 1])
				sorted[j++] = sorted[i];
		E->nr = (int)j;
		for (i = 0; i < E->n; ++i) {
			const long *hit = bsearch(&E->rep[i], sorted, (size_t)E->nr, sizeof *sorted, cmp_long);
			E->r[i] = (int)(hit - sorted);
		}
		memcpy(E->rep, sorted, (size_t)E->nr * sizeof *sorted);
		free(sorted);
	}
	return PR_OK;
}

/* Sample standard deviation (n - 1) of x[0..n) around mean m; 0 for n < 2. */
static double sample_std(double ss, long n)
{
	return n > 1 ? sqrt(ss / (double)(n - 1)) : 0.0;
}

/* exp3_curve.csv: per policy and iteration, the mean and std over the
 * repetitions of the iteration's average return (Fig. 7.7). */
static int write_curve(const pr_config *cfg, const episodes *E, const pr_exp3_labels *lb,
                       const char *dir, char *err)
{
	const pr_exp3_opts *e = pr_exp3_opts_of(cfg);
	size_t cells = (size_t)E->nv * E->nr * (E->T + 1);
	double *sum = calloc(cells, sizeof *sum);
	long *cnt = calloc(cells, sizeof *cnt), i;
	pr_csvw *w = NULL;
	int v, r, t, rc = PR_OK;

	if (!sum || !cnt) {
		free(sum);
		free(cnt);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	for (i = 0; i < E->n; ++i) {
		size_t c = ((size_t)E->v[i] * E->nr + E->r[i]) * (E->T + 1) + E->it[i];
		sum[c] += E->ret[i];
		cnt[c]++;
	}
	for (v = 0; rc == PR_OK && v < E->nv; ++v)
		for (r = 0; rc == PR_OK && r < E->nr; ++r)
			for (t = 0; t <= E->T; ++t)
				if (!cnt[((size_t)v * E->nr + r) * (E->T + 1) + t]) {
					rc = pr_err(err, PR_EIO, "%s/%s_episodes.csv: policy %s, repetition %ld: "
					            "no episodes of iteration %d", dir, lb->prefix, lb->name[v], E->rep[r], t);
					break;
				}
	if (rc == PR_OK && !(w = pr_exp_csv_open(err, "%s/%s_curve.csv", dir, lb->prefix)))
		rc = PR_EIO;
	if (rc == PR_OK) {
		pr_csvw_str(w, "policy");
		pr_csvw_str(w, "iteration");
		pr_csvw_str(w, "episodes");
		pr_csvw_str(w, "mean_return");
		pr_csvw_str(w, "std_return");
		rc = pr_csvw_str(w, "repetitions");
		pr_csvw_endrow(w);
	}
	for (v = 0; rc == PR_OK && v < E->nv; ++v)
		for (t = 0; rc == PR_OK && t <= E->T; ++t) {
			double m = 0.0, ss = 0.0;
			for (r = 0; r < E->nr; ++r) {
				size_t c = ((size_t)v * E->nr + r) * (E->T + 1) + t;
				m += sum[c] / (double)cnt[c];
			}
			m /= E->nr;
			for (r = 0; r < E->nr; ++r) {
				size_t c = ((size_t)v * E->nr + r) * (E->T + 1) + t;
				double dv = sum[c] / (double)cnt[c] - m;
				ss += dv * dv;
			}
			pr_csvw_str(w, lb->name[v]);
			pr_csvw_int(w, t);
			pr_csvw_int(w, (long)lb->n0[v] + (long)t * e->samples);
			pr_csvw_num(w, m);
			pr_csvw_num(w, sample_std(ss, E->nr));
			pr_csvw_int(w, E->nr);
			rc = pr_csvw_endrow(w);
		}
	free(sum);
	free(cnt);
	if (!w)
		return rc;
	return pr_csvw_finish(w, rc, err);
}

/* Mark each run's last `last` episodes (rows are in episode order within a
 * run). fin[i] = 1 for the rows Figs. 7.8-7.10 use. */
static int mark_final(const episodes *E, long last, char *fin, char *err)
{
	size_t runs = (size_t)E->nv * E->nr;
	long *tot = calloc(runs, sizeof *tot), *seen = calloc(runs, sizeof *seen), i;

	if (!tot || !seen) {
		free(tot);
		free(seen);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	for (i = 0; i < E->n; ++i)
		tot[(size_t)E->v[i] * E->nr + E->r[i]]++;
	for (i = 0; i < E->n; ++i) {
		size_t c = (size_t)E->v[i] * E->nr + E->r[i];
		fin[i] = seen[c]++ >= tot[c] - last;
	}
	free(tot);
	free(seen);
	return PR_OK;
}

/* exp3_final.csv: the last episodes of each run (Fig. 7.8), one row per
 * policy and repetition and a pooled row with repetition -1. */
static int write_final(const pr_config *cfg, const episodes *E, const pr_exp3_labels *lb, const char *fin,
                       const char *dir, char *err)
{
	pr_csvw *w;
	int v, r, rc = PR_OK;

	if (!(w = pr_exp_csv_open(err, "%s/%s_final.csv", dir, lb->prefix)))
		return PR_EIO;
	rc = pr_csvw_header(w, "policy,repetition,episodes,mean_return,std_return,pocketed_target,"
	                       "pocketed_other,mean_distance");
	for (v = 0; rc == PR_OK && v < E->nv; ++v)
		for (r = 0; rc == PR_OK && r <= E->nr; ++r) {
			/* r == nr: all repetitions pooled */
			double s = 0.0, ss = 0.0, ds = 0.0, m;
			long i, n = 0, tgt = 0, other = 0;
			for (i = 0; i < E->n; ++i)
				if (fin[i] && E->v[i] == v && (r == E->nr || E->r[i] == r)) {
					s += E->ret[i];
					ds += E->dist[i];
					n++;
					if (E->pocket[i] >= 0)
						*(pr_exp3_is_target(&cfg->reward, E->pocket[i]) ? &tgt : &other) += 1;
				}
			m = s / (double)n;
			for (i = 0; i < E->n; ++i)
				if (fin[i] && E->v[i] == v && (r == E->nr || E->r[i] == r))
					ss += (E->ret[i] - m) * (E->ret[i] - m);
			pr_csvw_str(w, lb->name[v]);
			pr_csvw_int(w, r == E->nr ? -1 : E->rep[r]);
			pr_csvw_int(w, n);
			pr_csvw_num(w, m);
			pr_csvw_num(w, sample_std(ss, n));
			pr_csvw_int(w, tgt);
			pr_csvw_int(w, other);
			pr_csvw_num(w, ds / (double)n);
			rc = pr_csvw_endrow(w);
		}
	return pr_csvw_finish(w, rc, err);
}

/* exp3_pockets.csv (Fig. 7.9) and exp3_dist.csv (Fig. 7.10) over the last
 * episodes of every repetition. */
static int write_pockets_dist(const pr_config *cfg, const episodes *E, const pr_exp3_labels *lb,
                              const char *fin, const char *dir, char *err)
{
	int nbins = (int)ceil(hypot(cfg->table.length, cfg->table.width) * DIST_BINS_PER_M);
	long *hist = calloc((size_t)nbins + 1, sizeof *hist), pk[PR_SIM_POCKETS + 1], tot, i;
	pr_csvw *w;
	int v, b, rc = PR_OK;

	if (!hist)
		return pr_err(err, PR_ENOMEM, "out of memory");
	if (!(w = pr_exp_csv_open(err, "%s/%s_pockets.csv", dir, lb->prefix))) {
		free(hist);
		return PR_EIO;
	}
	rc = pr_csvw_header(w, "policy,pocket,target,count,fraction");
	for (v = 0; rc == PR_OK && v < E->nv; ++v) {
		memset(pk, 0, sizeof pk);
		for (i = 0, tot = 0; i < E->n; ++i)
			if (fin[i] && E->v[i] == v) {
				pk[E->pocket[i] + 1]++;
				tot++;
			}
		for (b = -1; b < PR_SIM_POCKETS; ++b) {
			pr_csvw_str(w, lb->name[v]);
			pr_csvw_int(w, b);
			pr_csvw_int(w, pr_exp3_is_target(&cfg->reward, b));
			pr_csvw_int(w, pk[b + 1]);
			pr_csvw_num(w, (double)pk[b + 1] / (double)tot);
			rc = pr_csvw_endrow(w);
		}
	}
	if ((rc = pr_csvw_finish(w, rc, err))) {
		free(hist);
		return rc;
	}

	if (!(w = pr_exp_csv_open(err, "%s/%s_dist.csv", dir, lb->prefix))) {
		free(hist);
		return PR_EIO;
	}
	rc = pr_csvw_header(w, "policy,bin_lo,bin_hi,count,fraction");
	for (v = 0; rc == PR_OK && v < E->nv; ++v) {
		memset(hist, 0, ((size_t)nbins + 1) * sizeof *hist);
		for (i = 0, tot = 0; i < E->n; ++i)
			if (fin[i] && E->v[i] == v) {
				b = (int)floor(E->dist[i] * DIST_BINS_PER_M);
				hist[b < nbins ? b : nbins - 1]++;
				tot++;
			}
		for (b = 0; b < nbins; ++b) {
			pr_csvw_str(w, lb->name[v]);
			pr_csvw_num(w, (double)b / DIST_BINS_PER_M);
			pr_csvw_num(w, (double)(b + 1) / DIST_BINS_PER_M);
			pr_csvw_int(w, hist[b]);
			pr_csvw_num(w, (double)hist[b] / (double)tot);
			rc = pr_csvw_endrow(w);
		}
	}
	free(hist);
	return pr_csvw_finish(w, rc, err);
}

/* exp3_reps_summary.csv: per policy, how often the KL bound was active,
 * mean KL, the largest feature-expectation residual |sum p phi - phi_hat|,
 * ESS of p and of the importance weights, the iterations in which
 * min_std floored a policy variance or a policy fit or query fell back
 * (PR_POLICY_* flags), the actions drawn again for exceeding
 * sim.max_speed, and the REPS certificates: solves that were unreachable
 * (eta = 0, the eta -> 0 limit) or failed, and the largest relative
 * feature residual. */
static int write_reps_summary(const pr_exp3_labels *lb, const char *dir, char *err)
{
	enum { C_POL, C_KL, C_ESS, C_BOUND, C_QESS, C_FEAT, C_REDRAW, C_FLAGS, C_RES, C_RREL, C_ST, NC };
	static const char *const cname[NC] = {
		"policy", "kl", "ess", "bound", "q_ess", "features", "redraws", "policy_flags", "residual",
		"residual_rel", "status"
	};
	char path[PR_PATHLEN];
	pr_exp_table *t = NULL;
	pr_csvw *w = NULL;
	double (*acc)[5] = calloc((size_t)lb->n, sizeof *acc);
	double *maxres = calloc(2 * (size_t)lb->n, sizeof *maxres);
	long (*cnt)[7] = calloc((size_t)lb->n, sizeof *cnt), i, x, nr;
	int col[NC], c, v, rc;

	if (!acc || !cnt || !maxres) {
		free(acc);
		free(cnt);
		free(maxres);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	snprintf(path, sizeof path, "%s/%s_reps.csv", dir, lb->prefix);
	rc = pr_exp_table_read(path, &t, err);
	for (c = 0; rc == PR_OK && c < NC; ++c)
		if ((col[c] = pr_exp_table_col(t, cname[c], err)) < 0)
			rc = col[c];
	for (i = 0; rc == PR_OK && i < pr_exp_table_nrows(t); ++i) {
		double kl, ess, qess, nf, res, rrel;
		const char *st;
		long bound;
		if ((v = variant_of(pr_exp_table_str(t, i, col[C_POL]), lb)) < 0) {
			rc = pr_err(err, PR_EIO, "%s: row %ld: policy '%.40s' is not in %s",
			            path, i + 2, pr_exp_table_str(t, i, col[C_POL]), lb->key);
			break;
		}
		if ((rc = pr_exp_table_num(t, i, col[C_KL], &kl, err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_ESS], &ess, err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_QESS], &qess, err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_FEAT], &nf, err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_RES], &res, err)) ||
		    (rc = pr_exp_table_num(t, i, col[C_RREL], &rrel, err)) ||
		    (rc = pr_exp_table_int(t, i, col[C_BOUND], 0, 1, &bound, err)) ||
		    (rc = pr_exp_table_int(t, i, col[C_REDRAW], 0, 1000000000L, &nr, err)) ||
		    (rc = pr_exp_table_int(t, i, col[C_FLAGS], 0, 1 << 20, &x, err)))
			break;
		st = pr_exp_table_str(t, i, col[C_ST]);
		if (strcmp(st, pr_reps_status_name(PR_REPS_ACTIVE)) != 0 &&
		    strcmp(st, pr_reps_status_name(PR_REPS_UNREACHABLE)) != 0 &&
		    strcmp(st, pr_reps_status_name(PR_REPS_FAILED)) != 0) {
			rc = pr_err(err, PR_EIO, "%s: row %ld: status '%.40s' is not active, unreachable "
			            "or failed", path, i + 2, st);
			break;
		}
		cnt[v][5] += strcmp(st, pr_reps_status_name(PR_REPS_UNREACHABLE)) == 0;
		cnt[v][6] += strcmp(st, pr_reps_status_name(PR_REPS_FAILED)) == 0;
		acc[v][0] += kl;
		maxres[v] = fmax(maxres[v], res);
		maxres[lb->n + v] = fmax(maxres[lb->n + v], rrel);
		acc[v][1] += ess;
		acc[v][2] += qess;
		acc[v][3] += nf;
		cnt[v][0]++;
		cnt[v][1] += bound;
		cnt[v][2] += (x & PR_POLICY_FLOOR) != 0;
		cnt[v][3] += (x & ~(long)PR_POLICY_FLOOR) != 0;
		cnt[v][4] += nr;
	}
	pr_exp_table_free(t);
	if (rc == PR_OK && !(w = pr_exp_csv_open(err, "%s/%s_reps_summary.csv", dir, lb->prefix)))
		rc = PR_EIO;
	if (rc == PR_OK) {
		rc = pr_csvw_header(w, "policy,solves,bound_active,bound_inactive,mean_kl,max_residual,"
		                    "mean_ess,mean_q_ess,mean_features,floor_iterations,"
		                    "fallback_iterations,redraws,unreachable,failed,max_residual_rel");
	}
	for (v = 0; rc == PR_OK && v < lb->n; ++v) {
		double n = cnt[v][0] > 0 ? (double)cnt[v][0] : 1.0;
		pr_csvw_str(w, lb->name[v]);
		pr_csvw_int(w, cnt[v][0]);
		pr_csvw_int(w, cnt[v][1]);
		pr_csvw_int(w, cnt[v][0] - cnt[v][1]);
		pr_csvw_num(w, acc[v][0] / n);
		pr_csvw_num(w, maxres[v]);
		pr_csvw_num(w, acc[v][1] / n);
		pr_csvw_num(w, acc[v][2] / n);
		pr_csvw_num(w, acc[v][3] / n);
		pr_csvw_int(w, cnt[v][2]);
		pr_csvw_int(w, cnt[v][3]);
		pr_csvw_int(w, cnt[v][4]);
		pr_csvw_int(w, cnt[v][5]);
		pr_csvw_int(w, cnt[v][6]);
		pr_csvw_num(w, maxres[lb->n + v]);
		rc = pr_csvw_endrow(w);
	}
	free(acc);
	free(cnt);
	free(maxres);
	if (!w)
		return rc;
	return pr_csvw_finish(w, rc, err);
}

int pr_exp3_summaries(const pr_config *cfg, const pr_exp3_labels *lb, const char *dir, char *err)
{
	episodes E;
	char *fin = NULL;
	int rc = read_episodes(cfg, dir, lb, &E, err);

	if (rc == PR_OK)
		rc = write_curve(cfg, &E, lb, dir, err);
	if (rc == PR_OK && !(fin = malloc((size_t)E.n)))
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	if (rc == PR_OK)
		rc = mark_final(&E, pr_exp3_opts_of(cfg)->final_episodes, fin, err);
	if (rc == PR_OK)
		rc = write_final(cfg, &E, lb, fin, dir, err);
	if (rc == PR_OK)
		rc = write_pockets_dist(cfg, &E, lb, fin, dir, err);
	if (rc == PR_OK)
		rc = write_reps_summary(lb, dir, err);
	free(fin);
	episodes_free(&E);
	return rc;
}

int pr_exp3_summarize(const pr_config *cfg, const char *dir, char *err)
{
	char name[PR_EXP3_NVAR][32];
	int var[PR_EXP3_NVAR], n0[PR_EXP3_NVAR], nvar, v, rc;
	pr_exp3_labels lb = {"exp3", "exp3.policies", 0, name, n0};

	if ((rc = pr_exp3_selected(cfg, var, &nvar, err)))
		return rc;
	for (v = 0; v < nvar; ++v) {
		snprintf(name[v], sizeof name[v], "%s", pr_exp3_variant_name[var[v]]);
		n0[v] = pr_exp3_opts_of(cfg)->init_samples;
	}
	lb.n = nvar;
	return pr_exp3_summaries(cfg, &lb, dir, err);
}
