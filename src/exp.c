/* exp.c — the experiment registry: name, entry points, derived summary,
 * key block and defaults of every experiment. It is also the schema of
 * every configuration (pr_exp_config): the keys of the experiments follow
 * the modules' keys in the order of this table. */
#include <stdlib.h>
#include <string.h>

#include "poolreps/bench.h"
#include "poolreps/exp.h"
#include "exp_priv.h"

static const pr_experiment experiments[] = {
	{"figures", pr_figures_run, NULL, NULL, NULL, NULL, NULL, NULL, "sim", "figures",
	 "the simulator figures of chapter 7"},
	{"exp1", pr_exp1_run, pr_exp1_summarize, pr_exp1_variants, "exp1_summary.csv", &pr_exp1_keys, NULL,
	 NULL, "exp1", "experiment", "Experiment 1: representing the reward function (thesis 7.3)"},
	{"exp2", pr_exp2_run, pr_exp2_summarize, NULL, "exp2_summary.csv", &pr_exp2_keys, pr_exp2_defaults,
	 NULL, "exp2", "experiment", "Experiment 2: representing an optimal policy (thesis 7.4)"},
	{"exp3", pr_exp3_run, pr_exp3_summarize, pr_exp3_variants, "exp3_final.csv", &pr_exp3_keys,
	 pr_exp3_defaults, NULL,
	 "exp3", "experiment", "Experiment 3: learning to pocket a ball with REPS (thesis 7.5)"},
	/* Experiment 3's task and learner: its defaults and its exp3.* keys */
	{"exp4", pr_exp4_run, pr_exp4_summarize, pr_exp4_variants, "exp4_verdict.csv", &pr_exp4_keys,
	 pr_exp3_defaults, &pr_exp3_keys,
	 "exp4", "experiment", "Experiment 4: REPS from an imitated policy (beyond the thesis)"},
	{"quadratic", pr_exp_benchmark_run, pr_exp_benchmark_summarize, NULL, "bench_summary.csv",
	 &pr_bench_keys, pr_quadratic_defaults, NULL,
	 "quadratic", "benchmark", "REPS on the contextual quadratic"},
	{"sphere", pr_exp_benchmark_run, pr_exp_benchmark_summarize, NULL, "bench_summary.csv",
	 &pr_bench_keys, pr_sphere_defaults, NULL,
	 "sphere", "benchmark", "REPS on the contextual sphere"},
	{"rosenbrock", pr_exp_benchmark_run, pr_exp_benchmark_summarize, NULL, "bench_summary.csv",
	 &pr_bench_keys, pr_rosenbrock_defaults, NULL,
	 "rosenbrock", "benchmark", "REPS on the contextual Rosenbrock function"},
};
#define NEXP ((int)(sizeof experiments / sizeof experiments[0]))

const pr_experiment *pr_exp_find(const char *name)
{
	int i;

	for (i = 0; i < NEXP; ++i)
		if (strcmp(experiments[i].name, name) == 0)
			return &experiments[i];
	return NULL;
}

const pr_experiment *pr_exp_at(int i)
{
	return i >= 0 && i < NEXP ? &experiments[i] : NULL;
}

int pr_exp_config(int i, pr_config_exp *out)
{
	if (i < 0 || i >= NEXP)
		return 0;
	out->name = experiments[i].name;
	out->block = experiments[i].keys;
	out->defaults = experiments[i].defaults;
	out->reads = experiments[i].reads;
	return 1;
}

pr_config *pr_config_new(void)
{
	pr_config *c = malloc(sizeof *c);

	if (c)
		pr_config_init(c, pr_exp_config);
	return c;
}

void pr_config_free(pr_config *c)
{
	free(c);
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
