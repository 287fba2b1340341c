/* exp3_opts.c — Experiment 3's keys (exp3.*), its policy variants and
 * which of them a run selects: what exp3.c runs and exp3_out.c writes read
 * from below, so that neither calls the other for them. */
#include <stdio.h>
#include <string.h>

#include "exp3_priv.h"

const char *const pr_exp3_variant_name[PR_EXP3_NVAR] = {
	"nrvr_rs", "rvr_rs", "nrvr_a", "rvr_a", "baseline", "handcrafted"
};

void pr_exp3_opts_init(pr_exp3_opts *o)
{
	memset(o, 0, sizeof *o);
	o->init_samples = 200;
	o->init_std = 0.1;
	o->iterations = 100;
	o->samples = 20;
	o->window = 200;
	snprintf(o->policies, sizeof o->policies, "nrvr_rs,rvr_rs,nrvr_a,rvr_a,baseline,handcrafted");
	o->baseline_n_min = 250;
	o->final_episodes = 500;
	o->state = PR_EXP3_STATE_VARYING;
	o->truncation = PR_EXP3_TRUNC_REDRAW;
	o->mean_eval_every = 1100;
	o->mean_eval_seed = 1000000;
}

static void init_keys(void *o)
{
	pr_exp3_opts_init(o);
}

#define F(field) offsetof(pr_exp3_opts, field)
static const pr_config_key key_table[] = {
	{"exp3", "init_samples", PR_KEY_INT, F(init_samples), 1, 10000000, 0, "", "samples of the initial policy"},
	{"exp3", "init_std", PR_KEY_DOUBLE, F(init_std), 1e-100, 100, 0, "m/s", "initial policy N(0, init_std^2 I)"},
	{"exp3", "iterations", PR_KEY_INT, F(iterations), 0, 1000000, 0, "", "REPS iterations"},
	{"exp3", "samples", PR_KEY_INT, F(samples), 1, 10000000, 0, "", "new samples per iteration"},
	{"exp3", "window", PR_KEY_INT, F(window), 2, 10000000, 0, "", "latest samples REPS reuses"},
	{"exp3", "policies", PR_KEY_NAMES, F(policies), 0, 0, 0,
	 "nrvr_rs|rvr_rs|nrvr_a|rvr_a|baseline|handcrafted", "comma list of variants to run"},
	{"exp3", "baseline_n_min", PR_KEY_INT, F(baseline_n_min), 1, PR_KEY_COUNT_MAX, 0, "", "n_min of the baseline policy"},
	{"exp3", "final_episodes", PR_KEY_INT, F(final_episodes), 1, PR_KEY_COUNT_MAX, 0, "",
	 "Figs. 7.8-7.10: each run's last episodes"},
	{"exp3", "handcrafted_method", PR_KEY_ENUM, F(handcrafted_method), 0, 0, 0, "creps|ccmaes",
	 "hand-crafted variant: REPS + weighted ML, or contextual CMA-ES"},
	{"exp3", "state", PR_KEY_ENUM, F(state), 0, 0, 0, "varying|full",
	 "learning state: the coordinates that vary, or every ball's position (eq. 7.1: 4-D)"},
	{"exp3", "truncation", PR_KEY_ENUM, F(truncation), 0, 0, 0, "redraw|clip|corrected",
	 "actions above sim.max_speed: drawn again, scaled onto the limit, or drawn again with truncated densities"},
	{"exp3", "mean_eval", PR_KEY_INT, F(mean_eval), 0, PR_KEY_COUNT_MAX, 0, "",
	 "start states the policy's mean action is shot from (exp3_mean.csv; 0: none)"},
	{"exp3", "mean_eval_every", PR_KEY_INT, F(mean_eval_every), 1, PR_KEY_COUNT_MAX, 0, "",
	 "mean-action evaluation whenever a run's episodes are a multiple of this"},
	{"exp3", "mean_eval_seed", PR_KEY_ULONG, F(mean_eval_seed), 0, 4294967295.0, 0, "",
	 "repetition k's evaluation states: GSL mt19937 set to this + k"},
};
#undef F

const pr_config_block pr_exp3_keys = {
	key_table, (int)(sizeof key_table / sizeof key_table[0]), sizeof(pr_exp3_opts), init_keys, NULL
};

/* What data/exp3.ini states: the reward ball's start box and the value
 * forests of thesis 7.5. */
const pr_config_default pr_exp3_defaults[] = {
	{"start.reward_box", "0.05,0.15,-0.1,0.1"},
	{"value.trees", "10"},
	{"value.n_min", "60"},
	{"value.score", "nrvr"},
	{NULL, NULL}
};

const pr_exp3_opts *pr_exp3_opts_of(const pr_config *cfg)
{
	return pr_config_opts(cfg, &pr_exp3_keys);
}

/* The variants of exp3.policies, in its order; a name twice is an error. */
static int parse_variants(const pr_config *cfg, int *var, int *nvar, char *err)
{
	const char *p = pr_exp3_opts_of(cfg)->policies;
	char at[PR_WHERE_LEN];

	*nvar = 0;
	do {
		size_t len = strcspn(p, ","), b = 0, e = len;
		char item[32];
		int v, j;

		while (b < e && (p[b] == ' ' || p[b] == '\t'))
			++b;
		while (e > b && (p[e - 1] == ' ' || p[e - 1] == '\t'))
			--e;
		snprintf(item, sizeof item, "%.*s", (int)(e - b < 31 ? e - b : 31), p + b);
		for (v = 0; v < PR_EXP3_NVAR && strcmp(pr_exp3_variant_name[v], item) != 0; ++v)
			;
		if (v == PR_EXP3_NVAR)
			return pr_err(err, PR_EINVAL, "%s: exp3.policies: '%s' is not one of "
			              "nrvr_rs|rvr_rs|nrvr_a|rvr_a|baseline|handcrafted",
			              pr_config_where(cfg, "exp3.policies", at, sizeof at), item);
		for (j = 0; j < *nvar; ++j)
			if (var[j] == v)
				return pr_err(err, PR_EINVAL, "%s: exp3.policies: '%s' listed twice",
				              pr_config_where(cfg, "exp3.policies", at, sizeof at), item);
		var[(*nvar)++] = v;
		p += len;
	} while (*p++ == ',');
	return PR_OK;
}

/* Each variant draws from its own stream (PR_STREAM_EXP3_LEARN + its id),
 * so alone it writes exactly its rows of the full run. */
int pr_exp3_selected(const pr_config *cfg, int *var, int *nvar, char *err)
{
	int rc;

	if ((rc = parse_variants(cfg, var, nvar, err)) || (rc = pr_exp_check_variant(cfg, *nvar, err)))
		return rc;
	if (cfg->run.variant >= 0) {
		var[0] = var[cfg->run.variant];
		*nvar = 1;
	}
	return PR_OK;
}

int pr_exp3_variants(const pr_config *cfg, pr_variants *out, char *err)
{
	int var[PR_EXP3_NVAR], j, rc;

	if ((rc = parse_variants(cfg, var, &out->n, err)))
		return rc;
	for (j = 0; j < out->n; ++j)
		snprintf(out->name[j], sizeof out->name[j], "%s", pr_exp3_variant_name[var[j]]);
	return PR_OK;
}
