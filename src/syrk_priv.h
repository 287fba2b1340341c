/* syrk_priv.h — the rank-k update behind the dense REPS Hessian (reps.c). */
#ifndef POOLREPS_SYRK_PRIV_H
#define POOLREPS_SYRK_PRIV_H

/* Width to which pr_syrk_acc_rows's rows are padded (with zeros). */
#define PR_SYRK_W 16

/* A multiple of every tile's height (8 or 4 rows of H): pr_syrk_acc_rows's
 * row bounds are multiples of it. */
#define PR_SYRK_TJ 8

/* H += Y^T Y over the mr rows of Y (row-major, nfp columns, nfp a multiple
 * of PR_SYRK_W), on rows jlo <= j < jhi of H only (multiples of PR_SYRK_TJ,
 * or jhi = nfp); H is nfp x nfp row-major and receives the upper triangle
 * of those rows (and a few entries below the diagonal, in the tiles the
 * diagonal crosses); it reads no column of Y below jlo rounded down to a
 * multiple of PR_SYRK_W. Every H_jk gets y_0j y_0k, y_1j y_1k, ... added in row
 * order, one rounded product and one rounded sum at a time: the bits of the
 * plain triple loop, whatever vector width the CPU offers, whatever split
 * of the rows of Y into calls, and whatever split of H's rows between
 * threads. */
void pr_syrk_acc_rows(const double *Y, int mr, int nfp, double *H, int jlo, int jhi);

/* The first row of part t of `parts` (t = parts gives nfp) that split
 * H's rows into runs of about equal work, each a multiple of PR_SYRK_TJ. */
int pr_syrk_split(int nfp, int parts, int t);

#endif
