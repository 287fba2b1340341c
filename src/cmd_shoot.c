/* cmd_shoot.c — `poolreps shoot`: one shot per input row, streamed (the
 * row filter of shoot.h). */
#include "poolreps/cmd.h"
#include "poolreps/shoot.h"

int pr_cmd_shoot(const pr_config *cfg, const pr_cmd_args *a, char *err)
{
	pr_shoot_files f = { a->input, a->output, a->trace, a->keep };

	return pr_shoot_csv(&cfg->table, &cfg->sim, &cfg->reward, &f, err);
}
