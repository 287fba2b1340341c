/* common_priv.h — library internals shared by every module: path buffers
 * and the clean-up of temporary files and staging folders on fatal signals
 * (common.c). POSIX types (sigset_t) stay out of the public headers. */
#ifndef POOLREPS_COMMON_PRIV_H
#define POOLREPS_COMMON_PRIV_H

#include <setjmp.h>
#include <signal.h>
#include <stddef.h>

#include "poolreps/common.h"
#include "poolreps/internal.h"

/* Arms pr_gsl_error_handler for this thread: a GSL allocation failure
 * jumps to jb; NULL disarms it. */
void pr_gsl_guard(jmp_buf *jb);

/* ---- threads ----
 * The CPUs this process may run on (its affinity mask, as taskset or a
 * Slurm allocation set it; the online CPUs if that is unknown), 1 ..
 * PR_MAX_THREADS: what threads = 0 means. */
#define PR_MAX_THREADS 64
int pr_cpu_count(void);
/* Runs fn on nt parts (each `size` bytes from parts, nt <= PR_MAX_THREADS):
 * part 0 in the calling thread, the others on threads of their own; a part
 * whose thread cannot start runs in the calling thread too. Returns when
 * all have run. */
void pr_run_parts(int nt, void *(*fn)(void *), void *parts, size_t size);

/* A file or folder path the library builds (PATH_MAX on Linux). */
#define PR_PATHLEN 4096

/* ---- clean-up on fatal signals ----
 * Temporary files and staging folders are registered while they exist; a
 * signal handler calls pr_cleanup_run (common.h), which removes them using only
 * async-signal-safe calls. pr_cleanup_hold blocks the fatal signals in the
 * calling thread around a step that must not be cut in half (renaming a set
 * of finished files into place); pr_cleanup_release delivers them after. */
void pr_cleanup_add_file(const char *path);
void pr_cleanup_remove_file(const char *path);
/* A staging folder (everything in it, then itself), then the output folder
 * dir and its parents below its first keep bytes (those the run created),
 * each removed only if empty. Stagings nest (collect stages the merges it
 * runs, two deep): pr_cleanup_clear_dir forgets the last one set. */
void pr_cleanup_set_dir(const char *staging, const char *dir, size_t keep);
void pr_cleanup_clear_dir(void);
/* Remove dir and everything below it (8 folders deep; symlinks themselves,
 * never their targets) with system calls only: no allocation, so it works
 * when memory ran out and inside a signal handler. */
void pr_remove_tree(const char *dir);
void pr_cleanup_hold(sigset_t *old);
void pr_cleanup_release(const sigset_t *old);
/* 1 if path lies inside a registered staging folder (not yet the user's). */
int pr_cleanup_staged(const char *path);
/* The commit point: the renames that put a command's outputs where the user
 * asked (target: one of them) ran with the signals held; when they all
 * succeeded and target is not inside a staging folder, pr_committed is set
 * before the signals are released, so that a signal that arrived meanwhile
 * no longer claims that nothing was written: the outputs are complete. */
void pr_commit_end(const sigset_t *old, int rc, const char *target);
/* pr_committed, pr_fatal_signals and pr_cleanup_run: common.h */
/* The status of a failed system call by errno: PR_ENOMEM for ENOMEM (the
 * kernel or the C library ran out of memory: exit 4), else PR_EIO. */
int pr_errno_status(void);
/* 1 if process pid no longer exists (a staging folder or temporary file
 * named after it is left over from a killed run). */
int pr_pid_gone(long pid);
/* The owner tag that names this process's staging folders and temporary
 * files: "PID-START-NS-BOOT", its PID, start time (clock ticks since boot),
 * PID namespace inode and the first 12 hex digits of the machine's boot id. */
const char *pr_owner_tag(void);
/* 1 only if the process an owner tag (at the start of tag) names is provably
 * gone: same boot of this machine, same PID namespace, and its PID no longer
 * exists or now belongs to a process that started at another time. A tag of
 * another node sharing the file system, another namespace or an older
 * format is never dead: what it names is left alone. */
int pr_owner_dead(const char *tag);

#endif
