/* cmd_run.c — the commands that write output folders: `poolreps CONFIG`
 * (run), config, merge, sweep and collect, each a table of its options over
 * the library's rundir.h. */
#include <stddef.h>
#include <stdio.h>

#include "poolreps/exp.h"
#include "poolreps/rundir.h"
#include "poolreps/internal.h"
#include "cli.h"

static int run_main(const pr_config *cfg, const void *opts, char *err)
{
	return pr_rundir_run(cfg, opts, err);
}

static const cli_opt run_opts[] = {
	CLI_COMMON_C,
	CLI_OPT("o", "DIR", pr_rundir_args, output,
	        "the output folder (default results/<experiment.name>;\nfigures: results/sim)"),
	CLI_COMMON_SET, CLI_COMMON_SEED, CLI_COMMON_PROGRESS, CLI_GIVEN(CLI_PROGRESS, pr_rundir_args, progress),
	CLI_GIVEN(CLI_PROV, pr_rundir_args, prov), CLI_END
};

const cli_command cli_run = {
	"run",
	"poolreps [run] CONFIG [-o DIR] [--set section.key=value]... [--seed N] [-q]\n"
	"  Run the experiment a parameter file describes; write CSVs, figures' data and\n"
	"  provenance into DIR.",
	run_opts, sizeof(pr_rundir_args), NULL, CLI_OPS_CONFIG,
	CLI_GRACEFUL | CLI_EXPERIMENT | CLI_DONE_LINE, NULL, run_main
};

typedef struct {
	const char *output;
} config_args;

/* config refuses what a run would: a variant the experiment does not have */
static int config_main(const pr_config *cfg, const void *opts, char *err)
{
	const config_args *a = opts;
	pr_variants variants;
	int rc = pr_exp_variants(cfg, &variants, err);

	return rc ? rc : pr_rundir_config(cfg, a->output, err);
}

static const cli_opt config_opts[] = {
	CLI_COMMON_C, CLI_OPT("o", "FILE", config_args, output, "the INI (default stdout)"),
	CLI_COMMON_SET, CLI_COMMON_SEED, CLI_END
};

const cli_command cli_config = {
	"config",
	"poolreps config [-c FILE] [--set section.key=value]... [--seed N] [-o FILE]\n"
	"  Write the effective configuration (defaults, file, overrides) as INI.",
	config_opts, sizeof(config_args), NULL, CLI_OPS_NONE, 0, NULL, config_main
};

static int merge_main(const pr_config *cfg, const void *opts, char *err)
{
	(void)cfg;
	return pr_rundir_merge(opts, err);
}

/* collect takes what merge takes but -o: the tail of this table */
static const cli_opt merge_opts[] = {
	CLI_OPT("o", "DIR", pr_rundir_args, output, "the merged output folder"),
	CLI_OPT_FLAG("allow-versions", pr_rundir_args, allow_versions,
	             "combine runs of different poolreps builds (the\nprovenance lists every version)"),
	CLI_GIVEN_LIST(CLI_OPERANDS, pr_rundir_args, inputs, ninputs),
	CLI_GIVEN(CLI_PROV, pr_rundir_args, prov), CLI_END
};

const cli_command cli_merge = {
	"merge",
	"poolreps merge [--allow-versions] -o DIR RUN_DIR...\n"
	"  Combine single-repetition or single-variant outputs into what one process\n"
	"  would have written.",
	merge_opts, sizeof(pr_rundir_args), "", CLI_OPS_ALL, CLI_GRACEFUL, NULL, merge_main
};

typedef struct {
	pr_rundir_args r;
	const char *missing; /* --missing SWEEP_DIR: print the jobs not done */
} sweep_args;

/* sweep --missing only reads SWEEP_DIR: every other option would be ignored */
static int sweep_check(const void *opts, const cli_common *c, char *msg)
{
	const sweep_args *a = opts;

	if (a->missing && (a->r.output || a->r.ngrid || c->nsets || c->seed || a->r.split)) {
		snprintf(msg, CLI_MSGLEN, "sweep: --missing takes no other option (%s given)",
		         a->r.output ? "-o" : a->r.ngrid ? "--grid" : c->nsets ? "--set" :
		         c->seed ? "--seed" : "--split");
		return 1;
	}
	return 0;
}

static int sweep_main(const pr_config *cfg, const void *opts, char *err)
{
	const sweep_args *a = opts;

	return a->missing ? pr_rundir_missing(a->missing, "-", err) : pr_rundir_sweep(cfg, &a->r, err);
}

static const cli_opt sweep_opts[] = {
	CLI_OPT("o", "SWEEP_DIR", sweep_args, r.output, "the folder of the jobs"),
	CLI_COMMON_SET, CLI_COMMON_SEED,
	CLI_OPT_LIST("grid", "SECTION.KEY=V1,V2,...", sweep_args, r.grid, r.ngrid,
	             "a key and the values it takes (repeatable)"),
	CLI_OPT("split", "repetition|variant|both", sweep_args, r.split,
	        "one job per repetition (default), per variant\n(all repetitions) or per both"),
	CLI_OPT("missing", "SWEEP_DIR", sweep_args, missing,
	        "print the jobs that have not finished, to run again"),
	CLI_GIVEN(CLI_PROV, sweep_args, r.prov), CLI_END
};

const cli_command cli_sweep = {
	"sweep",
	"poolreps sweep CONFIG [--grid SECTION.KEY=V1,V2,...]... [--split repetition|variant|both]\n"
	"               -o SWEEP_DIR      |      poolreps sweep --missing SWEEP_DIR\n"
	"  Write jobs over every combination of the grid values: one `poolreps run` per\n"
	"  grid point and repetition and/or variant (exp1: setting, exp3: policy, exp4:\n"
	"  policy, start and covariance), listed in SWEEP_DIR/jobs.txt and manifest.csv,\n"
	"  with slurm.sbatch and parallel.sh to run them; a job sets its grid point's\n"
	"  values on SWEEP_DIR/config.ini with --set.",
	sweep_opts, sizeof(sweep_args), NULL, CLI_OPS_SWEEP, CLI_GRACEFUL | CLI_EXPERIMENT,
	sweep_check, sweep_main
};

static int collect_main(const pr_config *cfg, const void *opts, char *err)
{
	(void)cfg;
	return pr_rundir_collect(opts, err);
}

const cli_command cli_collect = {
	"collect",
	"poolreps collect [--allow-versions] SWEEP_DIR\n"
	"  Merge every grid point's jobs into point-N/merged (as `merge` does) and write\n"
	"  SWEEP_DIR/sweep_summary.csv: the grid values and the experiment's summary rows.\n"
	"  Names the jobs not done if there are any.",
	merge_opts + 1, sizeof(pr_rundir_args), "", CLI_OPS_ALL, CLI_GRACEFUL, NULL, collect_main
};
