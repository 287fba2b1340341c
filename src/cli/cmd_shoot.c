/* cmd_shoot.c — `poolreps shoot`: one shot per input row, streamed (the
 * row filter of shoot.h). */
#include "poolreps/shoot.h"
#include "cli.h"

int pr_cmd_shoot(const pr_config *cfg, const shoot_args *a, char *err)
{
	pr_shoot_files f = { a->input, a->output, a->trace, a->keep };

	return pr_shoot_csv(cfg, &f, err);
}

static int shoot_main(const pr_config *cfg, const void *opts, char *err)
{
	return pr_cmd_shoot(cfg, opts, err);
}

static const cli_opt shoot_opts[] = {
	CLI_COMMON_C, CLI_OPT("i", "IN.csv", shoot_args, input, "the shots, one per row (default stdin)"),
	CLI_OPT("o", "OUT.csv", shoot_args, output, "their outcomes (default stdout)"),
	CLI_COMMON_SET,
	CLI_OPT("trace", "TRACE.csv", shoot_args, trace, "every ball's path: shot,t,ball,x,y,vx,vy"),
	CLI_OPT_FLAG("keep", shoot_args, keep, "input columns first; final positions final_x0,..."),
	CLI_END
};

const cli_command cli_shoot = {
	"shoot",
	"poolreps shoot [-c FILE] [-i IN.csv] [-o OUT.csv] [--trace TRACE.csv] [--keep]\n"
	"  One shot per input row. Input columns x0,y0,x1,y1,...,vx,vy, any table.*, sim.*, reward.* number key (--set per row).\n"
	"  Output columns x0,y0,... (final), pocket0,... (id or -1), hit, min_gap, reward, t_end, events.",
	shoot_opts, sizeof(shoot_args), "table.,sim.,reward.", CLI_OPS_NONE, 0, NULL, shoot_main
};
