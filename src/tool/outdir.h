/* outdir.h — output folders written all or nothing (outdir.c), shared by
 * the operations that write a folder: run, merge, sweep (rundir.h). */
#ifndef POOLREPS_OUTDIR_H
#define POOLREPS_OUTDIR_H

#include <stddef.h>
#include <stdio.h>

#include "poolreps/config.h"
#include "common_priv.h"

/* A list of file names. */
typedef struct {
	char **name;
	int n;
} pr_names;
void pr_names_free(pr_names *l);
/* Append the first len bytes of name; PR_ENOMEM on failure. */
int pr_names_add(pr_names *l, const char *name, size_t len);
int pr_names_has(const pr_names *l, const char *name);

/* 1 if the k bytes at name are a plain file name poolreps writes into a run
 * or sweep folder (config.ini, provenance.txt, the sweep's files, an
 * experiment's CSV): the only names a later run removes. */
int pr_outdir_own_name(const char *name, size_t k);
/* The files an earlier run in dir wrote: the "files:" line of its
 * provenance.txt, read strictly (the keys poolreps writes, in its order,
 * each once, "files:" last, no control character). Nothing when dir holds
 * no poolreps run (no provenance.txt, not a regular file, or a first line
 * that is not "version: "); a record that starts like one and then departs
 * from it is refused (exit 2): it was not written by poolreps. */
int pr_outdir_earlier_run(const char *dir, pr_names *out, char *err);
/* The poolreps versions that ran the run folders dirs[0..n-1] (their
 * provenance.txt's first line; a merge's own list). More than one is
 * refused (PR_EINVAL, naming two folders) unless allow. *list: NULL when
 * the only one is this build's, else "A, B" (free()). */
int pr_outdir_versions(char *const *dirs, int n, int allow, char **list, char *err);
/* The file names of folder dir (not starting with '.'), sorted, with
 * provenance.txt last: it marks a complete run. */
int pr_outdir_list(const char *dir, pr_names *out, char *err);

/* Render text with fn into memory, then write it to path (NULL or "-":
 * stdout) through a csvio writer: atomically, or not at all. */
int pr_outdir_write_text(const char *path, void (*fn)(FILE *, const void *), const void *arg,
                         char *err);
/* Write DIR/config.ini (the effective configuration). */
int pr_outdir_write_config(const pr_config *cfg, const char *dir, char *err);
/* Write arg so that a POSIX shell reads it back as one word: provenance's
 * command line and a sweep's jobs can be pasted into a shell. */
void pr_outdir_shell_word(FILE *fp, const char *arg);
/* Move every file of each staging folder into its folder dir, all or
 * nothing across all of them: a file it replaces keeps its permission
 * bits and first gets a second link in staging (.old-N), so that a failed
 * rename puts every earlier one back; a folder or a file the user may not
 * write where a file must go is refused before anything moves. When owns,
 * dir is a run's folder: the files its earlier run listed in provenance.txt
 * and this one did not write are removed once all are in place. With lock,
 * the moves into dir are serialised with a lock on it. With make, a missing
 * dir is created inside the commit (the fatal signals blocked) and removed
 * again if the commit fails: a signal never strands it. */
typedef struct {
	const char *staging, *dir;
	int owns;
	int lock;           /* take the lock on dir (one lock can stand for all) */
	int make;
	pr_names now, old;  /* filled and freed by pr_outdir_publish */
	char *had;
	int fd, made;
} pr_outdir_pub;
int pr_outdir_publish(pr_outdir_pub *p, int n, char *err);
/* Messages name the file where it was going to be, not a staging folder
 * gone once the command failed: every staging in err becomes dir. */
void pr_outdir_unstage(char *err, const char *staging, const char *dir);
/* Remove what runs killed with SIGKILL left in dir: staging folders
 * .partial-TAG and temporary files .poolreps-tmp-TAG-N whose owner is provably
 * gone (pr_owner_dead). */
void pr_outdir_sweep_stale(const char *dir);
/* Create dir, run work into a staging folder inside it, add config.ini and
 * provenance.txt (version, command line, seed, host, timings, the files
 * the run owns), and move everything into dir only if all succeeded. */
int pr_outdir_run(const pr_config *cfg, const pr_provenance *prov, const char *dir,
                  int (*work)(const pr_config *, const char *, const void *, char *),
                  const void *arg, char *err);

#endif
