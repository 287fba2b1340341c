/* common.h — status codes and error-buffer helpers shared by every module.
 *
 * Library functions that can fail return an int status (PR_OK or a negative
 * PR_E* code) and write a one-line message into a caller-owned buffer of
 * PR_ERRLEN bytes. Constructors return NULL on failure and fill the buffer.
 * The library never prints and never exits; only main() does. These
 * headers need nothing beyond C11 (compile with -std=c11).
 */
#ifndef POOLREPS_COMMON_H
#define POOLREPS_COMMON_H

#include <signal.h>
#include <stddef.h>

#define PR_ERRLEN 512

enum {
	PR_OK = 0,
	PR_EINVAL = -1,   /* bad parameter or input value   -> exit 1 */
	PR_EIO = -2,      /* file missing, unreadable, malformed CSV -> exit 2 */
	PR_ENUM = -3,     /* numerical failure (solver, event limit) -> exit 3 */
	PR_ENOMEM = -4,   /* allocation failed               -> exit 4 */
	PR_EINTR = -5     /* stopped by a signal             -> exit 128 + signal */
};

/* printf into err (may be NULL); returns status, so `return pr_err(...)` works.
 * The message is always one line of valid UTF-8: control characters and
 * bytes that are not UTF-8 (from echoed paths, columns and values) are
 * written as \xHH. A PR_ENOMEM report also sets pr_out_of_memory. */
int pr_err(char *err, int status, const char *fmt, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 3, 4)))
#endif
	;

/* The version string: git describe at build time, or the tarball version. */
const char *pr_version(void);

/* Weights w[0..n-1] (sample or base weights) as every reader checks them:
 * PR_OK, or PR_EINVAL with err "WHAT must be >= 0 (got V)" (*bad: its
 * index), "WHATs are all zero" or "the WHATs sum past the largest number:
 * scale them down" (*bad = -1); callers prefix where the weights came from.
 * Only their ratios matter, but a sum that overflows makes every share 0. */
int pr_weights_check(const double *w, long n, const char *what, long *bad, char *err);

/* A GSL error handler for programs that use poolreps (the command line and
 * the Python binding install it with gsl_set_error_handler): it ignores
 * GSL's errors, as gsl_set_error_handler_off does (poolreps checks every
 * status), except an allocation failure inside a GSL routine that poolreps
 * guards because GSL does not check it there (the SVD of REPS's reduced
 * basis): then poolreps reports out of memory instead of GSL going on with
 * a null vector. GSL's own allocations in that routine are not freed. */
void pr_gsl_error_handler(const char *reason, const char *file, int line, int gsl_errno);

/* The command line an output folder's provenance.txt records, as typed. */
typedef struct {
	int argc;
	char **argv;
	const char *versions; /* merge: the versions that ran the inputs, when not
	                       * only this one ("A, B"); else NULL */
} pr_provenance;

/* Set by the CLI's signal handler to the signal number; long loops poll it
 * and return PR_EINTR. */
extern volatile sig_atomic_t pr_interrupted;
/* Set once any allocation failure was reported (through pr_err with
 * PR_ENOMEM, in any thread): the command's failure is then out of memory,
 * whatever status the code above it turned the report into. */
extern volatile sig_atomic_t pr_out_of_memory;

#endif
