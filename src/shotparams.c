/* shotparams.c — per-row physics and reward parameters (shotparams.h). */
#include <stdlib.h>
#include <string.h>

#include "poolreps/shotparams.h"
#include "poolreps/internal.h"

/* Keys whose value pr_config_validate relates to other keys (the ball on
 * the table, the start boxes inside the cushions, the time step): a row
 * setting one of them is validated whole; for the others checking the
 * first row covers every row (the checks depend on which keys are set,
 * not on their values). */
static const char *const related[] = {
	"table.length", "table.width", "table.ball_radius", "table.mu_slide", "table.mu_roll",
	"sim.dt", "sim.max_time"
};

struct pr_shot_params {
	pr_config cfg;      /* the base configuration with the last row's values */
	pr_sim *sim;        /* the simulator for cfg */
	int nkeys, *key;    /* pr_config_number_key indices */
	double *last;       /* the values cfg holds (nkeys) */
	int validate_rows;  /* a related key is among the keys */
	int rows;           /* rows set so far */
};

static int allowed_section(const char *name)
{
	return !strncmp(name, "table.", 6) || !strncmp(name, "sim.", 4) ||
	       !strncmp(name, "reward.", 7);
}

static int find_keys(pr_shot_params *p, const char *const *keys, char *err)
{
	int i, j, k;

	for (i = 0; i < p->nkeys; ++i) {
		if (!allowed_section(keys[i]))
			return pr_err(err, PR_EINVAL, "%.80s: only table., sim. and reward. keys vary "
			              "per row", keys[i]);
		if ((k = pr_config_number_key(&p->cfg, keys[i], err)) < 0)
			return k;
		for (j = 0; j < i; ++j)
			if (p->key[j] == k)
				return pr_err(err, PR_EINVAL, "%.80s: given twice", keys[i]);
		p->key[i] = k;
		for (j = 0; j < (int)(sizeof related / sizeof *related); ++j)
			p->validate_rows |= !strcmp(keys[i], related[j]);
	}
	return PR_OK;
}

pr_shot_params *pr_shot_params_new(const pr_config *c, int nkeys, const char *const *keys,
                                   char *err)
{
	pr_shot_params *p = calloc(1, sizeof *p);

	if (!p || nkeys < 0 ||
	    !(p->key = malloc(((size_t)nkeys + 1) * sizeof *p->key)) ||
	    !(p->last = malloc(((size_t)nkeys + 1) * sizeof *p->last))) {
		pr_shot_params_free(p);
		pr_err(err, PR_ENOMEM, "shot parameters: out of memory");
		return NULL;
	}
	p->cfg = *c;
	p->nkeys = nkeys;
	if (find_keys(p, keys, err) ||
	    (nkeys == 0 && !(p->sim = pr_sim_new(&p->cfg.table, &p->cfg.sim, err)))) {
		pr_shot_params_free(p);
		return NULL;
	}
	return p;
}

void pr_shot_params_free(pr_shot_params *p)
{
	if (!p)
		return;
	pr_sim_free(p->sim);
	free(p->key);
	free(p->last);
	free(p);
}

pr_sim *pr_shot_params_row(pr_shot_params *p, const double *values, int *rc, char *err)
{
	int i;

	if (p->nkeys == 0 ||
	    (p->sim && !memcmp(values, p->last, (size_t)p->nkeys * sizeof *values)))
		return p->sim;
	pr_sim_free(p->sim);
	p->sim = NULL;
	for (i = 0; i < p->nkeys; ++i)
		if ((*rc = pr_config_set_number(&p->cfg, p->key[i], values[i], err)))
			return NULL;
	if ((p->rows == 0 || p->validate_rows) && (*rc = pr_config_validate(&p->cfg, err)))
		return NULL;
	if (!(p->sim = pr_sim_new(&p->cfg.table, &p->cfg.sim, err))) {
		*rc = strstr(err, "out of memory") ? PR_ENOMEM : PR_EINVAL;
		return NULL;
	}
	memcpy(p->last, values, (size_t)p->nkeys * sizeof *values);
	p->rows++;
	return p->sim;
}

const pr_config *pr_shot_params_config(const pr_shot_params *p)
{
	return &p->cfg;
}
