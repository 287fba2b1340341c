/* csvio_priv.h — csvio internals shared with config.c, the experiments and
 * the CLI. */
#ifndef POOLREPS_CSVIO_PRIV_H
#define POOLREPS_CSVIO_PRIV_H

#include <stddef.h>

/* Parse a finite double with optional surrounding blanks; PR_EINVAL otherwise. */
int pr_csv_parse_double(const char *s, double *v);
/* decimal.c: a plain decimal number at s, with at most 19 significant
 * digits and a modest exponent, converted exactly (the bits strtod gives):
 * 1 with *v and *end (the first byte after it) set; 0 when it must be left
 * to strtod (any other form, or a value this does not handle). */
int pr_decimal_parse(const char *s, const char **end, double *v);
/* The same where 8 bytes may be read from any byte of s up to the first
 * that cannot continue the number (a buffer padded after its text): 8
 * digits at a time. */
int pr_decimal_parse_padded(const char *s, const char **end, double *v);
/* The shortest of %.15g..%.17g that reads back exactly. */
void pr_csv_format_double(double v, char *buf, size_t n);

/* The one CSV reader behind every CSV input (numeric tables, the
 * experiments' raw tables, merge): libcsv in strict mode (a stray quote or an
 * unterminated quoted field is an error), fed in blocks, with every limit
 * applied as the bytes arrive, so memory stays bounded whatever the input
 * (/dev/zero, an endless quoted field, an endless line): a NUL byte, a field
 * over PR_CSV_MAX_FIELD bytes (csvio.h), a line or record over PR_CSV_MAX_LINE bytes,
 * more than PR_CSV_MAX_COLS fields. A UTF-8 byte-order mark is skipped. The
 * first record is the header: names are trimmed of trailing blanks and must
 * be non-empty, free of control characters and distinct. Every data record
 * must have as many fields as the header. header() is called once and row()
 * for every data record, with the fields as NUL-terminated strings (valid
 * during the call) and the file line the record ends on; a non-zero return
 * stops the scan with that status (message in err). path NULL or "-" reads
 * stdin, shown as "<stdin>". */
#define PR_CSV_MAX_LINE (1L << 24)
#define PR_CSV_MAX_COLS 100000
enum {
	PR_CSV_COMPLETE = 1,     /* flag: the last line must end with a line end */
	PR_CSV_LIBCSV_ONLY = 2   /* flag: every line through libcsv, none split directly
	                          * (the tests compare both ways) */
};
typedef int (*pr_csv_record_fn)(void *user, const char *path, long line, int n,
                                char **fields, char *err);
int pr_csv_scan(const char *path, unsigned flags, pr_csv_record_fn header,
                pr_csv_record_fn row, void *user, char *err);

/* The extended attributes of file from (ACLs, user.* notes) onto fd, the
 * file that replaces it. 0, or -1 with errno and *bad the attribute that
 * could not be kept; a file system without them has none to keep. */
int pr_csv_copy_xattrs(const char *from, int fd, char *bad, size_t nbad);

#endif
