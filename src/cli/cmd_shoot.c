/* cmd_shoot.c — `poolreps shoot`: one shot per input row, streamed (the
 * row filter of shoot.h). */
#include "poolreps/shoot.h"
#include "cli.h"

int pr_cmd_shoot(const pr_config *cfg, const shoot_args *a, char *err)
{
	pr_shoot_files f = { a->input, a->output, a->trace, a->keep };

	return pr_shoot_csv(&cfg->table, &cfg->sim, &cfg->reward, &f, err);
}

static int shoot_main(const pr_config *cfg, const void *opts, char *err)
{
	return pr_cmd_shoot(cfg, opts, err);
}

static const cli_opt shoot_opts[] = {
	CLI_COMMON_C, CLI_OPT("i", CLI_STR, shoot_args, input), CLI_OPT("o", CLI_STR, shoot_args, output),
	CLI_COMMON_SET, CLI_OPT("trace", CLI_STR, shoot_args, trace),
	CLI_OPT("keep", CLI_FLAG, shoot_args, keep), CLI_END
};

const cli_command cli_shoot = {
	"shoot",
	"poolreps shoot [-c FILE] [-i IN.csv] [-o OUT.csv] [--trace TRACE.csv] [--keep]\n"
	"  One shot per input row. Input columns x0,y0,x1,y1,...,vx,vy. Output columns\n"
	"  x0,y0,... (final), pocket0,... (id or -1), hit, min_gap, reward, t_end, events.\n"
	"  --keep copies the input columns in front; the final positions are then\n"
	"  final_x0,final_y0,...",
	shoot_opts, sizeof(shoot_args), "table.,sim.,reward.", CLI_OPS_NONE, 0, NULL, shoot_main
};
