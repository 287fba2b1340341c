/* commands.c — the commands main dispatches over (cli.h), in the order
 * --help lists them; the first runs a parameter file. */
#include "cli.h"

const cli_command *const cli_commands[] = {
	&cli_run, &cli_shoot, &cli_forest, &cli_reps, &cli_policy, &cli_learner, &cli_config,
	&cli_merge, &cli_sweep, &cli_collect
};
const size_t cli_ncommands = sizeof cli_commands / sizeof cli_commands[0];
