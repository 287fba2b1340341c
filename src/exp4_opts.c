/* exp4_opts.c — Experiment 4's keys (exp4.*), its variants (policy, init,
 * covariance) with their labels, and which of them a run selects: what
 * exp4.c runs and exp4_out.c writes read from below. */
#include <stdio.h>
#include <string.h>

#include "exp4_priv.h"

const char *const pr_exp4_init_name[PR_EXP4_NINIT] = {"scratch", "imitation", "demo", "policy",
                                                       "refit", "matched", "refit_matched"};
const char *const pr_exp4_cov_name[PR_EXP4_NCOV] = {"query", "residual", "none"};

void pr_exp4_opts_init(pr_exp4_opts *o)
{
	memset(o, 0, sizeof *o);
	o->n_demo = 50;
	o->demo_noise = 0.0;
	snprintf(o->inits, sizeof o->inits, "scratch,imitation,demo,policy");
	snprintf(o->covs, sizeof o->covs, "query,residual");
	o->fit_n_min_frac = 0.1;
	o->mean_eval = 0;
}

static void init_keys(void *o)
{
	pr_exp4_opts_init(o);
}

#define F(field) offsetof(pr_exp4_opts, field)
static const pr_config_key key_table[] = {
	{"exp4", "n_demo", PR_KEY_INT, F(n_demo), 2, PR_KEY_COUNT_MAX, 0, "",
	 "ghost-ball demonstrations per repetition"},
	{"exp4", "demo_noise", PR_KEY_DOUBLE, F(demo_noise), 0, 100, 0, "m/s",
	 "std of Gaussian noise added to each component of the expert's action"},
	{"exp4", "inits", PR_KEY_NAMES, F(inits), 0, 0, 0,
	 "scratch|imitation|demo|policy|refit|matched|refit_matched",
	 "how runs start: Exp. 3 from scratch, the fitted policy alone, or it + REPS with the "
	 "demonstrations or its own episodes as first window; controls of policy: refit (no REPS, "
	 "refitted with the importance weights), matched (REPS, tree policies at n_min = "
	 "exp4.fit_n_min_frac * exp3.window: pi_0's resolution), refit_matched (refit at matched's "
	 "resolution)"},
	{"exp4", "covs", PR_KEY_NAMES, F(covs), 0, 0, 0, "query|residual",
	 "policy.cov of the tree and baseline runs, one run each (policy.cov is not read)"},
	{"exp4", "fit_n_min_frac", PR_KEY_DOUBLE, F(fit_n_min_frac), 0, 1, PR_KEY_OPEN_LO, "",
	 "fit to the demonstrations: tree n_min = frac * exp4.n_demo"},
	{"exp4", "mean_eval", PR_KEY_INT, F(mean_eval), 0, PR_KEY_COUNT_MAX, 0, "",
	 "start states each run's last policy is evaluated on by its mean action "
	 "(exp4_mean.csv; 0: none)"},
};
#undef F

const pr_config_block pr_exp4_keys = {
	key_table, (int)(sizeof key_table / sizeof key_table[0]), sizeof(pr_exp4_opts), init_keys, NULL
};

const pr_exp4_opts *pr_exp4_opts_of(const pr_config *cfg)
{
	return pr_config_opts(cfg, &pr_exp4_keys);
}

/* ---- variants ---- */

/* The indices in names[0..n) of the comma list s (checked by the key). */
int pr_exp4_name_indices(const char *s, const char *const *names, int n, int *out)
{
	int m = 0;

	do {
		size_t len = strcspn(s, ","), b = 0, e = len;
		int j;

		while (b < e && (s[b] == ' ' || s[b] == '\t'))
			++b;
		while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t'))
			--e;
		for (j = 0; j < n; ++j)
			if (strlen(names[j]) == e - b && strncmp(names[j], s + b, e - b) == 0)
				out[m++] = j;
		s += len;
	} while (*s++ == ',');
	return m;
}

void pr_exp4_variant_label(const pr_exp4_variant *v, char *buf, size_t n)
{
	snprintf(buf, n, "%s.%s.%s", pr_exp3_variant_name[v->policy], pr_exp4_init_name[v->init],
	         pr_exp4_cov_name[v->cov]);
}

int pr_exp4_list(const pr_config *cfg, int selected, pr_exp4_variant *var, int *nvar, char *err)
{
	const pr_exp4_opts *e4 = pr_exp4_opts_of(cfg);
	pr_variants pv;
	int pol[PR_EXP3_NVAR], init[PR_EXP4_NINIT], cov[PR_EXP4_NCOV], ni, nc, i, j, c, rc;

	if ((rc = pr_exp3_variants(cfg, &pv, err)))
		return rc;
	for (i = 0; i < pv.n; ++i)
		pr_exp4_name_indices(pv.name[i], pr_exp3_variant_name, PR_EXP3_NVAR, &pol[i]);
	ni = pr_exp4_name_indices(e4->inits, pr_exp4_init_name, PR_EXP4_NINIT, init);
	nc = pr_exp4_name_indices(e4->covs, pr_exp4_cov_name, PR_EXP4_COV_NONE, cov);
	*nvar = 0;
	for (i = 0; i < pv.n; ++i) {
		const int hc = pol[i] == PR_EXP3_HANDCRAFTED;
		for (c = 0; c < (hc ? 1 : nc); ++c)
			for (j = 0; j < ni; ++j) {
				/* the baseline and hand-crafted policies have one resolution */
				if (init[j] >= PR_EXP4_MATCHED && (hc || pol[i] == PR_EXP3_BASELINE))
					continue;
				var[*nvar].policy = pol[i];
				var[*nvar].init = init[j];
				var[*nvar].cov = hc ? PR_EXP4_COV_NONE : cov[c];
				++*nvar;
			}
	}
	if (!selected)
		return PR_OK;
	if ((rc = pr_exp_check_variant(cfg, *nvar, err)))
		return rc;
	if (cfg->run.variant >= 0) {
		var[0] = var[cfg->run.variant];
		*nvar = 1;
	}
	return PR_OK;
}

int pr_exp4_variants(const pr_config *cfg, pr_variants *out, char *err)
{
	pr_exp4_variant var[PR_EXP4_NVAR];
	int j, rc;

	if ((rc = pr_exp4_list(cfg, 0, var, &out->n, err)))
		return rc;
	for (j = 0; j < out->n; ++j)
		pr_exp4_variant_label(&var[j], out->name[j], sizeof out->name[j]);
	return PR_OK;
}
