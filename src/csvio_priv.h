/* csvio_priv.h — csvio internals shared with config.c and the CLI. */
#ifndef POOLREPS_CSVIO_PRIV_H
#define POOLREPS_CSVIO_PRIV_H

#include <stddef.h>

/* Parse a finite double with optional surrounding blanks; PR_EINVAL otherwise. */
int pr_csv_parse_double(const char *s, double *v);
/* The shortest of %.15g..%.17g that reads back exactly. */
void pr_csv_format_double(double v, char *buf, size_t n);
/* Remove every temporary output file still open (async-signal-safe:
 * unlink only). Returns how many were removed. */
int pr_csvw_cleanup(void);

#endif
