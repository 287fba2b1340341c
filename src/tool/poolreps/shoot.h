/* shoot.h — the `shoot` row filter: one simulated shot per row of a CSV,
 * read, shot and written in chunks (memory independent of the row count).
 *
 * Input columns x0,y0,...,x{n-1},y{n-1},vx,vy (any order); the ball count n
 * comes from them. Columns named section.key (number keys of table., sim.
 * and reward.) set those keys per row (shotparams.h): the row is shot as
 * with --set section.key=VALUE. Output columns x0,y0,... (final positions),
 * pocket0,..., hit, min_gap, reward, t_end, events, one row per input row;
 * with keep, the input columns as read come first and the final positions
 * are named final_x0,final_y0,..., so that a row holds a whole sample
 * (state, action, outcome). A trace file gets shot,t,ball,x,y,vx,vy (shot:
 * the 0-based input row).
 */
#ifndef POOLREPS_SHOOT_H
#define POOLREPS_SHOOT_H

#include "poolreps/common.h"
#include "poolreps/config.h"
#include "poolreps/sim.h"

typedef struct {
	const char *input;   /* NULL or "-": standard input */
	const char *output;  /* NULL or "-": standard output */
	const char *trace;   /* NULL: no trace */
	int keep;            /* copy the input columns in front */
} pr_shoot_files;

/* Shoot every row of f->input, in file order. The header is checked before
 * anything is written. Rows are handled in the order they arrive: a row that
 * fails (not a number, a ball off the table, a shot the simulator refuses)
 * stops the command with one message naming the file and line (PR_EIO,
 * PR_EINVAL, PR_ENUM), and so does a signal (PR_EINTR). Outputs go through
 * one pr_outset: a file output (and the trace) appears, atomically, only
 * when every row succeeded, and is left as it was otherwise. Standard output,
 * a pipe or a device receives the results of every complete chunk at once,
 * whole rows only: after a failure it holds exactly the rows before the
 * failing one, and the failure is the status (the caller's exit code). */
int pr_shoot_csv(const pr_config *c, const pr_shoot_files *f, char *err);

#endif
