/* sim_law.c — the registry of friction laws: table.friction_law's value to
 * its table of functions (sim_priv.h), each law in a file of its own. A new
 * law adds its file, a line here and its name to PR_FRICTION_NAMES. */
#include <string.h>

#include "sim_priv.h"

extern const pr_sim_law pr_sim_law_exp, pr_sim_law_const, pr_sim_law_slide;

/* in PR_FRICTION_* order */
static const pr_sim_law *const laws[] = {&pr_sim_law_exp, &pr_sim_law_const, &pr_sim_law_slide};
/* each law's own table.* keys, in the same order */
static const char *const law_keys[][3] = {{"friction"}, {"deceleration"}, {"mu_slide", "mu_roll"}};
#define NLAWS ((int)(sizeof laws / sizeof laws[0]))

const pr_sim_law *pr_sim_law_get(int law)
{
	return law >= 0 && law < NLAWS ? laws[law] : NULL;
}

int pr_sim_law_check_all(const pr_table *t, const pr_sim_opts *o, char *err)
{
	int i, rc;

	if (!pr_sim_law_get(t->friction_law))
		return pr_err(err, PR_EINVAL, "table.friction_law: unknown law %d", t->friction_law);
	for (i = 0; i < NLAWS; ++i)
		if ((rc = laws[i]->check(t, o, i == t->friction_law, err)))
			return rc;
	return PR_OK;
}

int pr_sim_law_idle_key(int law, const char *key)
{
	int i, j, own = 0, other = 0;

	for (i = 0; i < NLAWS; ++i)
		for (j = 0; j < 3 && law_keys[i][j]; ++j)
			if (strcmp(law_keys[i][j], key) == 0) {
				own |= i == law;
				other |= i != law;
			}
	return other && !own;
}
