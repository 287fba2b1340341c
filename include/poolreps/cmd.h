/* cmd.h — the component commands behind the CLI.
 * main.c parses the command line into pr_cmd_args and a pr_config, then
 * calls one of these. They read and write CSV; they never print to stdout
 * except CSV data when the output is "-", and never exit. */
#ifndef POOLREPS_CMD_H
#define POOLREPS_CMD_H

#include "poolreps/common.h"
#include "poolreps/config.h"
#include "poolreps/exp.h"

typedef struct {
	const char *command;   /* "run", "shoot", "forest", "reps", "policy", "merge", "config", ... */
	const char *input;     /* -i, NULL = stdin */
	const char *output;    /* -o, NULL = stdout (a directory for run) */
	int quiet;             /* -q */
	/* shoot */
	const char *trace;     /* --trace FILE */
	int keep;              /* --keep: copy the input columns in front */
	/* forest */
	const char *train, *test, *target, *weight, *leaves;
	const char *save, *load; /* --save FILE, --load FILE: a fitted forest */
	/* reps */
	const char *ret, *features, *base, *summary;
	double epsilon;        /* --epsilon, used when epsilon_set */
	int epsilon_set;
	/* policy */
	const char *state, *action;
	const char *old_mean;  /* --old-mean COLS: sampling means (policy.cov_center = old) */
	long sample;           /* --sample N, 0 = none */
	/* merge: the input directories; collect: the sweep folder */
	int ninputs;
	char **inputs;
	/* sweep */
	int ngrid;
	char **grid;           /* --grid KEY=V1,V2,... (repeatable) */
	const char *split;     /* --split repetition|variant|both, NULL = repetition */
	const char *missing;   /* --missing SWEEP_DIR: print the jobs not done */
	pr_progress progress;  /* set by main unless -q */
	char *note;            /* PR_ERRLEN bytes: a one-line remark (a warning, timings)
	                        * main prints only when the command succeeded */
	/* provenance */
	int argc;
	char **argv;
} pr_cmd_args;

int pr_cmd_run(const pr_config *cfg, const pr_cmd_args *a, char *err);
int pr_cmd_shoot(const pr_config *cfg, const pr_cmd_args *a, char *err);
int pr_cmd_forest(const pr_config *cfg, const pr_cmd_args *a, char *err);
int pr_cmd_reps(const pr_config *cfg, const pr_cmd_args *a, char *err);
int pr_cmd_policy(const pr_config *cfg, const pr_cmd_args *a, char *err);
int pr_cmd_merge(const pr_config *cfg, const pr_cmd_args *a, char *err);
/* Write a sweep folder: jobs over a grid of parameter values (or, with
 * --missing, print the commands of the jobs that did not finish). */
int pr_cmd_sweep(const pr_config *cfg, const pr_cmd_args *a, char *err);
/* Merge every grid point of a finished sweep and write sweep_summary.csv. */
int pr_cmd_collect(const pr_config *cfg, const pr_cmd_args *a, char *err);
/* The effective configuration as INI to -o (default stdout). */
int pr_cmd_config(const pr_config *cfg, const pr_cmd_args *a, char *err);

#endif
