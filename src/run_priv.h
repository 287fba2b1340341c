/* run_priv.h — output-folder helpers shared by the commands. */
#ifndef POOLREPS_RUN_PRIV_H
#define POOLREPS_RUN_PRIV_H

#include <stdio.h>

#include "poolreps/cmd.h"

/* Write DIR/config.ini (the effective configuration). */
int pr_run_write_config(const pr_config *cfg, const char *dir, char *err);
/* Write DIR/provenance.txt: version, command line, seed, host, timings. */
int pr_run_write_provenance(const pr_config *cfg, const pr_cmd_args *a, const char *dir,
                            double wall, char *err);
/* Write arg so that a POSIX shell reads it back as one word: provenance's
 * command line and a sweep's jobs can be pasted into a shell. */
void pr_run_shell_word(FILE *fp, const char *arg);
/* Create dir, run work into a staging folder inside it, add config.ini and
 * provenance.txt, and move everything into dir only if all succeeded. */
int pr_run_staged(const pr_config *cfg, const pr_cmd_args *a, const char *dir,
                  int (*work)(const pr_config *, const char *, const pr_cmd_args *, char *),
                  char *err);

#endif
