/* exp.c — the experiment registry and per-repetition random streams. */
#include <stdio.h>
#include <string.h>

#include "poolreps/bench.h"
#include "poolreps/config.h"
#include "poolreps/figures.h"
#include "poolreps/exp.h"
#include "exp_priv.h"

/* The simulator figures have no repetitions and no progress to report. */
static int figures_run(const pr_config *cfg, const char *dir, const pr_progress *prog, char *err)
{
	(void)prog;
	return pr_exp_figures(cfg, dir, err);
}

static const pr_experiment experiments[] = {
	{"figures", figures_run, NULL, NULL, NULL},
	{"exp1", pr_exp1_run, pr_exp1_summarize, pr_exp1_variants, "exp1_summary.csv"},
	{"exp2", pr_exp2_run, pr_exp2_summarize, NULL, "exp2_summary.csv"},
	{"exp3", pr_exp3_run, pr_exp3_summarize, pr_exp3_variants, "exp3_final.csv"},
	{"quadratic", pr_exp_benchmark_run, pr_exp_benchmark_summarize, NULL, "bench_summary.csv"},
	{"sphere", pr_exp_benchmark_run, pr_exp_benchmark_summarize, NULL, "bench_summary.csv"},
	{"rosenbrock", pr_exp_benchmark_run, pr_exp_benchmark_summarize, NULL, "bench_summary.csv"},
};

const pr_experiment *pr_exp_find(const char *name)
{
	size_t i;

	for (i = 0; i < sizeof experiments / sizeof experiments[0]; ++i)
		if (strcmp(experiments[i].name, name) == 0)
			return &experiments[i];
	return NULL;
}

/* splitmix64 finaliser: decorrelates nearby (seed, stream, index) triples. */
static unsigned long long mix(unsigned long long z)
{
	z += 0x9e3779b97f4a7c15ULL;
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
	return z ^ (z >> 31);
}

gsl_rng *pr_exp_rng(unsigned long seed, unsigned long stream, unsigned long index)
{
	gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
	unsigned long long h;

	if (!r)
		return NULL;
	h = mix(mix(mix((unsigned long long)seed) ^ (unsigned long long)stream) ^ (unsigned long long)index);
	/* mt19937 takes a 32-bit seed; 0 would select GSL's default seed */
	h &= 0xffffffffULL;
	gsl_rng_set(r, h ? (unsigned long)h : 1UL);
	return r;
}

void pr_exp_reps(const pr_config *cfg, int *lo, int *hi)
{
	if (cfg->run.repetition >= 0) {
		*lo = cfg->run.repetition;
		*hi = cfg->run.repetition + 1;
	} else {
		*lo = 0;
		*hi = cfg->run.repetitions;
	}
}

int pr_exp_check_variant(const pr_config *cfg, int n, char *err)
{
	char at[320];

	if (cfg->run.variant < n)
		return PR_OK;
	pr_config_where(cfg, "experiment.variant", at, sizeof at);
	if (n == 0)
		return pr_err(err, PR_EINVAL, "%s: experiment.variant: %d, but %s has no variants",
		              at, cfg->run.variant, cfg->run.name);
	return pr_err(err, PR_EINVAL, "%s: experiment.variant: %d, but %s has %d variants (0..%d)",
	              at, cfg->run.variant, cfg->run.name, n, n - 1);
}

int pr_exp_variants(const pr_config *cfg, pr_variants *out, char *err)
{
	const pr_experiment *e = pr_exp_find(cfg->run.name);
	int rc;

	out->n = 0;
	if (e && e->variants && (rc = e->variants(cfg, out, err)))
		return rc;
	return pr_exp_check_variant(cfg, out->n, err);
}
