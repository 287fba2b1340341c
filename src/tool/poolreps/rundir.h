/* rundir.h — runs in output folders: an experiment run into a folder with
 * its configuration and provenance, written all or nothing (rundir.c);
 * per-process runs merged into what one process would have written; sweeps
 * over a grid of parameter values and their collection (sweep.c). None of
 * these prints; a failure leaves every existing file as it was. */
#ifndef POOLREPS_RUNDIR_H
#define POOLREPS_RUNDIR_H

#include "poolreps/common.h"
#include "poolreps/config.h"
#include "poolreps/exp.h"

/* What a folder operation takes besides the configuration. */
typedef struct {
	const char *output;   /* run: the folder (NULL: results/<experiment.name>,
	                       * results/sim for the figures); merge, sweep: required */
	int ninputs;          /* merge: the run folders; collect: the sweep folder */
	char **inputs;
	int ngrid;            /* sweep: SECTION.KEY=V1,V2,... per axis */
	char **grid;
	const char *split;    /* sweep: repetition|variant|both, NULL = repetition */
	pr_progress progress; /* run: progress reports ({NULL, NULL}: none) */
	int allow_versions;   /* merge, collect: runs of different builds allowed */
	pr_provenance prov;
} pr_rundir_args;

/* Run the experiment cfg describes into a->output (CSVs, config.ini,
 * provenance.txt). */
int pr_rundir_run(const pr_config *cfg, const pr_rundir_args *a, char *err);
/* Combine the single-repetition or single-variant run folders a->inputs
 * into a->output; the inputs' own config.ini describe the merged run. */
int pr_rundir_merge(const pr_rundir_args *a, char *err);
/* The effective configuration as INI to path (NULL or "-": stdout). */
int pr_rundir_config(const pr_config *cfg, const char *path, char *err);
/* Write a sweep folder a->output: jobs over the grid a->grid (sweep.c). */
int pr_rundir_sweep(const pr_config *cfg, const pr_rundir_args *a, char *err);
/* The jobs of sweep folder dir that have not finished, one line of
 * jobs.txt each, to the file output ("-": stdout, as the caller chooses). */
int pr_rundir_missing(const char *dir, const char *output, char *err);
/* Merge every grid point of the finished sweep a->inputs[0] and write its
 * sweep_summary.csv. */
int pr_rundir_collect(const pr_rundir_args *a, char *err);

#endif
