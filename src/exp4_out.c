/* exp4_out.c — Experiment 4's outputs: the raw CSVs of its runs and the
 * summaries derived from those files alone (so `poolreps merge` rebuilds
 * them byte for byte).
 *
 * Raw (Experiment 3's columns; the policy column holds the run label
 * policy.init.cov, e.g. nrvr_rs.demo.query):
 *   exp4_episodes.csv  repetition,policy,iteration,x0,y0,...,vx,vy,return,rx,ry,pocket,hit
 *   exp4_reps.csv      repetition,policy,iteration,eta,...,status (none for imitation)
 *   exp4_demo.csv      repetition,demo,x0,y0,...,expert_vx,expert_vy,vx,vy,return,rx,ry,
 *                      pocket,hit: the demonstrations (once per repetition)
 *   exp4_fit.csv       repetition,policy,x0,y0,...,expert_vx,expert_vy,mean_vx,mean_vy,
 *                      sd_major,sd_minor: the fitted pi_0 against the expert
 *   exp4_mean.csv      repetition,policy,states,mean_return,pocket_rate,hit_rate,n_min,
 *                      leaves: each run's last policy by its mean action (only with
 *                      exp4.mean_eval > 0)
 * Derived: Experiment 3's summaries under the prefix exp4 (exp4_curve.csv,
 * exp4_final.csv, exp4_pockets.csv, exp4_dist.csv, exp4_reps_summary.csv)
 * and exp4_verdict.csv.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_sort.h>
#include <gsl/gsl_statistics_double.h>

#include "poolreps/csvio.h"
#include "poolreps/sim.h"
#include "exp4_priv.h"

/* ---- raw output ---- */

static int write_runs(const pr_config *cfg, const pr_exp4_job *runs, int nruns, const char *dir,
                      char *err)
{
	char label[64];
	pr_csvw *w;
	int j, i, t, rc = PR_OK;

	if (!(w = pr_exp_csv_open(err, "%s/exp4_episodes.csv", dir)))
		return PR_EIO;
	rc |= pr_exp3_write_episode_header(w, cfg->table.balls);
	for (j = 0; rc == PR_OK && j < nruns; ++j) {
		pr_exp4_variant_label(&runs[j].var, label, sizeof label);
		for (i = 0; rc == PR_OK && i < runs[j].ep.n; ++i) {
			rc |= pr_csvw_int(w, runs[j].repetition);
			rc |= pr_csvw_str(w, label);
			rc |= pr_exp3_write_episode(w, &runs[j].ep, i);
		}
	}
	if ((rc = pr_csvw_finish(w, rc, err)))
		return rc;

	if (!(w = pr_exp_csv_open(err, "%s/exp4_reps.csv", dir)))
		return PR_EIO;
	rc = pr_csvw_header(w, "repetition,policy,iteration," PR_EXP3_ITER_COLUMNS);
	for (j = 0; rc == PR_OK && j < nruns; ++j) {
		if (runs[j].var.init == PR_EXP4_IMITATION)
			continue;
		pr_exp4_variant_label(&runs[j].var, label, sizeof label);
		for (t = 0; rc == PR_OK && t < runs[j].ep.niter; ++t) {
			rc |= pr_csvw_int(w, runs[j].repetition);
			rc |= pr_csvw_str(w, label);
			rc |= pr_csvw_int(w, t + 1);
			rc |= pr_exp3_write_iter(w, &runs[j].ep.it[t]);
		}
	}
	return pr_csvw_finish(w, rc, err);
}

/* exp4_demo.csv: each repetition's demonstrations, kept by one run (the
 * first variant that makes them, so a run split by variant writes them
 * once). */
static int write_demo(const pr_config *cfg, const pr_exp4_job *runs, int nruns, const char *dir,
                      char *err)
{
	pr_csvw *w;
	int j, i, b, rc = PR_OK;

	if (!(w = pr_exp_csv_open(err, "%s/exp4_demo.csv", dir)))
		return PR_EIO;
	rc |= pr_csvw_str(w, "repetition");
	rc |= pr_csvw_str(w, "demo");
	rc |= pr_exp3_write_state_names(w, cfg->table.balls);
	rc |= pr_csvw_header(w, "expert_vx,expert_vy,vx,vy,return,rx,ry,pocket,hit");
	for (j = 0; rc == PR_OK && j < nruns; ++j) {
		const pr_exp4_demo *d = &runs[j].demo;
		for (i = 0; rc == PR_OK && i < d->n; ++i) {
			rc |= pr_csvw_int(w, runs[j].repetition);
			rc |= pr_csvw_int(w, i);
			for (b = 0; b < d->ds; ++b)
				rc |= pr_csvw_num(w, d->S[(size_t)i * d->ds + b]);
			for (b = 0; b < 2; ++b)
				rc |= pr_csvw_num(w, d->E[2 * i + b]);
			for (b = 0; b < 2; ++b)
				rc |= pr_csvw_num(w, d->A[2 * i + b]);
			rc |= pr_csvw_num(w, d->R[i]);
			rc |= pr_csvw_num(w, d->F[2 * i]);
			rc |= pr_csvw_num(w, d->F[2 * i + 1]);
			rc |= pr_csvw_int(w, d->pocket[i]);
			rc |= pr_csvw_int(w, d->hit[i]);
			rc |= pr_csvw_endrow(w);
		}
	}
	return pr_csvw_finish(w, rc, err);
}

/* exp4_fit.csv: the imitation runs' pi_0 against the expert. */
static int write_fit(const pr_config *cfg, const pr_exp4_job *runs, int nruns, const char *dir,
                     char *err)
{
	char label[64];
	pr_csvw *w;
	int j, i, b, rc = PR_OK;

	if (!(w = pr_exp_csv_open(err, "%s/exp4_fit.csv", dir)))
		return PR_EIO;
	rc |= pr_csvw_str(w, "repetition");
	rc |= pr_csvw_str(w, "policy");
	rc |= pr_exp3_write_state_names(w, cfg->table.balls);
	rc |= pr_csvw_header(w, "expert_vx,expert_vy,mean_vx,mean_vy,sd_major,sd_minor");
	for (j = 0; rc == PR_OK && j < nruns; ++j) {
		const pr_exp4_fit *f = &runs[j].fit;
		pr_exp4_variant_label(&runs[j].var, label, sizeof label);
		for (i = 0; rc == PR_OK && i < f->n; ++i) {
			rc |= pr_csvw_int(w, runs[j].repetition);
			rc |= pr_csvw_str(w, label);
			for (b = 0; b < f->ds; ++b)
				rc |= pr_csvw_num(w, f->S[(size_t)i * f->ds + b]);
			for (b = 0; b < 2; ++b)
				rc |= pr_csvw_num(w, f->E[2 * i + b]);
			for (b = 0; b < 2; ++b)
				rc |= pr_csvw_num(w, f->M[2 * i + b]);
			rc |= pr_csvw_num(w, f->sd[2 * i]);
			rc |= pr_csvw_num(w, f->sd[2 * i + 1]);
			rc |= pr_csvw_endrow(w);
		}
	}
	return pr_csvw_finish(w, rc, err);
}

/* exp4_mean.csv (exp4.mean_eval > 0): per run, its last policy's mean
 * action on the evaluation states, and that policy's forest n_min and
 * leaves (0 without a forest). */
static int write_mean(const pr_exp4_job *runs, int nruns, const char *dir, char *err)
{
	char label[64];
	pr_csvw *w;
	int j, rc;

	if (!(w = pr_exp_csv_open(err, "%s/exp4_mean.csv", dir)))
		return PR_EIO;
	rc = pr_csvw_header(w, "repetition,policy,states,mean_return,pocket_rate,hit_rate,n_min,"
	                       "leaves");
	for (j = 0; rc == PR_OK && j < nruns; ++j) {
		const pr_exp4_job *r = &runs[j];
		pr_exp4_variant_label(&r->var, label, sizeof label);
		rc |= pr_csvw_int(w, r->repetition);
		rc |= pr_csvw_str(w, label);
		rc |= pr_csvw_int(w, r->mean_n);
		rc |= pr_csvw_num(w, r->mean_sum / r->mean_n);
		rc |= pr_csvw_num(w, (double)r->mean_pocket / r->mean_n);
		rc |= pr_csvw_num(w, (double)r->mean_hit / r->mean_n);
		rc |= pr_csvw_int(w, r->n_min);
		rc |= pr_csvw_int(w, r->leaves);
		rc |= pr_csvw_endrow(w);
	}
	return pr_csvw_finish(w, rc, err);
}

int pr_exp4_write_raw(const pr_config *cfg, const pr_exp4_job *runs, int nruns, const char *dir,
                      char *err)
{
	int rc = write_runs(cfg, runs, nruns, dir, err);

	if (rc == PR_OK)
		rc = write_demo(cfg, runs, nruns, dir, err);
	if (rc == PR_OK)
		rc = write_fit(cfg, runs, nruns, dir, err);
	if (rc == PR_OK && pr_exp4_opts_of(cfg)->mean_eval > 0)
		rc = write_mean(runs, nruns, dir, err);
	return rc;
}

/* ---- summaries ---- */

/* Per variant and repetition, over each run's last exp3.final_episodes
 * episodes: return sum and count; per variant pooled: target pockets, hits
 * and the speeds |a|. */
typedef struct {
	int nv, nr;
	long rep[PR_EXP4_REPS_MAX];
	double *sum;       /* nv x nr */
	long *cnt;         /* nv x nr */
	long *pocket, *hit, *n;   /* nv */
	long nrow;
	double *speed;     /* per raw row: |a| of a final episode */
	double *ret;       /* per raw row: its return */
	int *sv;           /* per raw row: its variant if final, else -1 */
} finals;

static void finals_free(finals *F)
{
	free(F->sum);
	free(F->cnt);
	free(F->pocket);
	free(F->hit);
	free(F->n);
	free(F->speed);
	free(F->ret);
	free(F->sv);
}

/* Index of repetition r in F->rep, added if new. */
static int rep_index(finals *F, long r, const char *path, char *err)
{
	int j;

	for (j = 0; j < F->nr; ++j)
		if (F->rep[j] == r)
			return j;
	if (F->nr == PR_EXP4_REPS_MAX)
		return pr_err(err, PR_EIO, "%s: more than %d repetitions", path, PR_EXP4_REPS_MAX);
	F->rep[F->nr] = r;
	return F->nr++;
}

static int read_finals(const pr_config *cfg, const char (*name)[32], int nv, const char *dir,
                       finals *F, char *err)
{
	enum { C_REP, C_POL, C_VX, C_VY, C_RET, C_POCKET, C_HIT, NC };
	static const char *const cname[NC] = {
		"repetition", "policy", "vx", "vy", "return", "pocket", "hit"
	};
	const long last = pr_exp3_opts_of(cfg)->final_episodes;
	char path[PR_PATHLEN];
	pr_exp_table *t = NULL;
	long i, nrow, *tot = NULL, *seen = NULL, x, pk, hit;
	int col[NC], c, v, r, rc;

	memset(F, 0, sizeof *F);
	F->nv = nv;
	snprintf(path, sizeof path, "%s/exp4_episodes.csv", dir);
	if ((rc = pr_exp_table_read(path, &t, err)))
		return rc;
	for (c = 0; rc == PR_OK && c < NC; ++c)
		if ((col[c] = pr_exp_table_col(t, cname[c], err)) < 0)
			rc = col[c];
	nrow = pr_exp_table_nrows(t);
	F->sum = calloc((size_t)nv * PR_EXP4_REPS_MAX, sizeof *F->sum);
	F->cnt = calloc((size_t)nv * PR_EXP4_REPS_MAX, sizeof *F->cnt);
	F->pocket = calloc((size_t)nv, sizeof *F->pocket);
	F->hit = calloc((size_t)nv, sizeof *F->hit);
	F->n = calloc((size_t)nv, sizeof *F->n);
	F->nrow = nrow;
	F->speed = malloc(((size_t)nrow + 1) * sizeof *F->speed);
	F->ret = malloc(((size_t)nrow + 1) * sizeof *F->ret);
	F->sv = malloc(((size_t)nrow + 1) * sizeof *F->sv);
	tot = calloc((size_t)nv * PR_EXP4_REPS_MAX, sizeof *tot);
	seen = calloc((size_t)nv * PR_EXP4_REPS_MAX, sizeof *seen);
	if (rc == PR_OK && (!F->sum || !F->cnt || !F->pocket || !F->hit || !F->n || !F->speed || !F->ret || !F->sv ||
	                    !tot || !seen))
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	/* two passes: count each run's episodes, then keep its last ones */
	for (c = 0; c < 2 && rc == PR_OK; ++c)
		for (i = 0; rc == PR_OK && i < nrow; ++i) {
			const char *lab = pr_exp_table_str(t, i, col[C_POL]);
			double vx, vy, ret;
			size_t cell;
			for (v = 0; v < nv && strcmp(name[v], lab) != 0; ++v)
				;
			if (v == nv) {
				rc = pr_err(err, PR_EIO, "%s: row %ld: policy '%.40s' is not a variant of "
				            "exp3.policies, exp4.inits and exp4.covs", path, i + 2, lab);
				break;
			}
			if ((rc = pr_exp_table_int(t, i, col[C_REP], 0, 9999, &x, err)) ||
			    (r = rep_index(F, x, path, err)) < 0) {
				rc = rc ? rc : r;
				break;
			}
			cell = (size_t)v * PR_EXP4_REPS_MAX + r;
			F->sv[i] = -1;
			if (c == 0) {
				tot[cell]++;
				continue;
			}
			if (seen[cell]++ < tot[cell] - last)
				continue;
			if ((rc = pr_exp_table_num(t, i, col[C_VX], &vx, err)) ||
			    (rc = pr_exp_table_num(t, i, col[C_VY], &vy, err)) ||
			    (rc = pr_exp_table_num(t, i, col[C_RET], &ret, err)) ||
			    (rc = pr_exp_table_int(t, i, col[C_POCKET], -1, PR_SIM_POCKETS - 1, &pk, err)) ||
			    (rc = pr_exp_table_int(t, i, col[C_HIT], 0, 1, &hit, err)))
				break;
			F->sum[cell] += ret;
			F->cnt[cell]++;
			F->pocket[v] += pk >= 0 && pr_exp3_is_target(&cfg->reward, (int)pk);
			F->hit[v] += hit;
			F->speed[i] = hypot(vx, vy);
			F->ret[i] = ret;
			F->sv[i] = v;
			F->n[v]++;
		}
	if (rc == PR_OK && nrow == 0)
		rc = pr_err(err, PR_EIO, "%s: no episodes", path);
	free(tot);
	free(seen);
	pr_exp_table_free(t);
	return rc;
}

/* Mean and standard error over the repetitions of x[0..n). */
static void mean_se(const double *x, int n, double *m, double *se)
{
	*m = gsl_stats_mean(x, 1, (size_t)n);
	*se = n > 1 ? gsl_stats_sd_m(x, 1, (size_t)n, *m) / sqrt((double)n) : 0.0;
}

/* x[i] of variant v's final rows, sorted, into buf (*n of them); their median. */
static double median_of(const finals *F, const double *x, int v, double *buf, size_t *n)
{
	size_t m = 0;
	long i;

	for (i = 0; i < F->nrow; ++i)
		if (F->sv[i] == v)
			buf[m++] = x[i];
	gsl_sort(buf, 1, m);
	if (n)
		*n = m;
	return gsl_stats_median_from_sorted_data(buf, 1, m);
}

/* exp4_verdict.csv: per variant, the mean over the repetitions of the mean
 * return of each run's last episodes and its standard error; the paired
 * difference to the same policy and covariance from scratch (repetitions
 * both have) and its standard error (empty without a scratch run); the
 * target-pocket rate, hit rate and median cue speed over those episodes,
 * and quantiles of their returns (GSL's interpolated quantiles). */
static int write_verdict(const pr_config *cfg, const pr_exp4_variant *var, const char (*name)[32],
                         int nv, const char *dir, char *err)
{
	finals F;
	double m[PR_EXP4_REPS_MAX], d[PR_EXP4_REPS_MAX], *sp = NULL;
	pr_csvw *w = NULL;
	static const double quant[5] = {0.05, 0.25, 0.5, 0.75, 0.95};
	size_t ns;
	int v, s, r, q, nm, nd, rc = read_finals(cfg, name, nv, dir, &F, err);

	if (rc == PR_OK && !(sp = malloc(((size_t)F.nrow + 1) * sizeof *sp)))
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	if (rc == PR_OK && !(w = pr_exp_csv_open(err, "%s/exp4_verdict.csv", dir)))
		rc = PR_EIO;
	if (rc == PR_OK)
		rc = pr_csvw_header(w, "variant,policy,init,cov,repetitions,episodes,mean_return,"
		                       "se_return,diff_scratch,se_diff,pocket_rate,hit_rate,median_speed,"
		                       "q05_return,q25_return,median_return,q75_return,q95_return");
	for (v = 0; rc == PR_OK && v < nv; ++v) {
		double mr, ser, md, sed;
		for (s = 0; s < nv; ++s)
			if (var[s].init == PR_EXP4_SCRATCH && var[s].policy == var[v].policy &&
			    var[s].cov == var[v].cov)
				break;
		for (r = 0, nm = 0, nd = 0; r < F.nr; ++r) {
			size_t c = (size_t)v * PR_EXP4_REPS_MAX + r, cs = (size_t)s * PR_EXP4_REPS_MAX + r;
			if (!F.cnt[c])
				continue;
			m[nm++] = F.sum[c] / (double)F.cnt[c];
			if (s < nv && F.cnt[cs])
				d[nd++] = m[nm - 1] - F.sum[cs] / (double)F.cnt[cs];
		}
		if (nm == 0) {
			rc = pr_err(err, PR_EIO, "%s/exp4_episodes.csv: no episodes of %s", dir, name[v]);
			break;
		}
		mean_se(m, nm, &mr, &ser);
		pr_csvw_str(w, name[v]);
		pr_csvw_str(w, pr_exp3_variant_name[var[v].policy]);
		pr_csvw_str(w, pr_exp4_init_name[var[v].init]);
		pr_csvw_str(w, pr_exp4_cov_name[var[v].cov]);
		pr_csvw_int(w, nm);
		pr_csvw_int(w, F.n[v]);
		pr_csvw_num(w, mr);
		pr_csvw_num(w, ser);
		if (nd > 0) {
			mean_se(d, nd, &md, &sed);
			pr_csvw_num(w, md);
			pr_csvw_num(w, sed);
		} else {
			pr_csvw_str(w, "");
			pr_csvw_str(w, "");
		}
		pr_csvw_num(w, (double)F.pocket[v] / (double)F.n[v]);
		pr_csvw_num(w, (double)F.hit[v] / (double)F.n[v]);
		pr_csvw_num(w, median_of(&F, F.speed, v, sp, NULL));
		median_of(&F, F.ret, v, sp, &ns);
		for (q = 0; q < 5; ++q)
			pr_csvw_num(w, gsl_stats_quantile_from_sorted_data(sp, 1, (size_t)ns, quant[q]));
		rc = pr_csvw_endrow(w);
	}
	free(sp);
	finals_free(&F);
	if (!w)
		return rc;
	return pr_csvw_finish(w, rc, err);
}

int pr_exp4_summarize(const pr_config *cfg, const char *dir, char *err)
{
	const pr_exp3_opts *e3 = pr_exp3_opts_of(cfg);
	pr_exp4_variant var[PR_EXP4_NVAR];
	char name[PR_EXP4_NVAR][32];
	int n0[PR_EXP4_NVAR], nv, v, rc;
	pr_exp3_labels lb = {"exp4", "exp3.policies, exp4.inits and exp4.covs", 0, name, n0};

	if ((rc = pr_exp4_list(cfg, 1, var, &nv, err)))
		return rc;
	for (v = 0; v < nv; ++v) {
		pr_exp4_variant_label(&var[v], name[v], sizeof name[v]);
		n0[v] = var[v].init == PR_EXP4_DEMO ? pr_exp4_opts_of(cfg)->n_demo : e3->init_samples;
	}
	lb.n = nv;
	if ((rc = pr_exp3_summaries(cfg, &lb, dir, err)))
		return rc;
	return write_verdict(cfg, var, name, nv, dir, err);
}
