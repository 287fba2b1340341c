/* cmd_shoot.c — `poolreps shoot`: one shot per input row.
 *
 * Input columns x0,y0,...,x{n-1},y{n-1},vx,vy (any order, no others); the
 * ball count n comes from them. Every row is checked before anything is
 * written, so a bad row leaves no output. Output columns x0,y0,... (final),
 * pocket0,..., hit, min_gap, reward, t_end, events; --trace FILE writes
 * shot,t,ball,x,y,vx,vy. --keep copies the input columns, as read, in front
 * of the results and names the final positions final_x0,final_y0,..., so
 * that the output holds whole samples (state, action, outcome) for the
 * other commands.
 */
#include <stdio.h>
#include <stdlib.h>

#include "poolreps/csvio.h"
#include "poolreps/sim.h"
#include "cli.h"

/* Column of each expected name, or an error naming the first missing one. */
static int map_columns(const pr_csv *in, int n, int *col, char *err)
{
	char name[32];
	int i;

	for (i = 0; i < 2 * n + 2; ++i) {
		if (i < 2 * n)
			snprintf(name, sizeof name, "%c%d", i % 2 ? 'y' : 'x', i / 2);
		else
			snprintf(name, sizeof name, "%s", i == 2 * n ? "vx" : "vy");
		col[i] = pr_csv_find(in, name);
		if (col[i] < 0)
			return pr_err(err, PR_EIO, "%s:1: missing column '%s': expected x0,y0,...,x%d,y%d,vx,vy",
			              pr_csv_path(in), name, n - 1, n - 1);
	}
	return PR_OK;
}

static void get_row(const pr_csv *in, long r, int n, const int *col, double *state, double *act)
{
	const double *row = pr_csv_row(in, r);
	int i;

	for (i = 0; i < 2 * n; ++i)
		state[i] = row[col[i]];
	act[0] = row[col[2 * n]];
	act[1] = row[col[2 * n + 1]];
}

static int write_header(pr_csvw *w, const pr_csv *keep, int n)
{
	char name[40];
	int i, rc = 0;
	static const char *const tail[] = {"hit", "min_gap", "reward", "t_end", "events"};

	for (i = 0; keep && i < pr_csv_ncols(keep) && !rc; ++i)
		rc = pr_csvw_str(w, pr_csv_name(keep, i));
	for (i = 0; i < 2 * n && !rc; ++i) {
		snprintf(name, sizeof name, "%s%c%d", keep ? "final_" : "", i % 2 ? 'y' : 'x', i / 2);
		rc = pr_csvw_str(w, name);
	}
	for (i = 0; i < n && !rc; ++i) {
		snprintf(name, sizeof name, "pocket%d", i);
		rc = pr_csvw_str(w, name);
	}
	for (i = 0; i < 5 && !rc; ++i)
		rc = pr_csvw_str(w, tail[i]);
	return rc ? rc : pr_csvw_endrow(w);
}

/* keep: the input row copied in front (--keep), or NULL */
static int write_shot(pr_csvw *w, const double *keep, int nkeep, const pr_shot *r, double reward)
{
	int i, rc = 0;

	for (i = 0; keep && i < nkeep && !rc; ++i)
		rc = pr_csvw_num(w, keep[i]);
	for (i = 0; i < 2 * r->nballs && !rc; ++i)
		rc = pr_csvw_num(w, r->final[i]);
	for (i = 0; i < r->nballs && !rc; ++i)
		rc = pr_csvw_int(w, r->pocket[i]);
	if (!rc)
		rc = pr_csvw_int(w, r->hit);
	if (!rc)
		rc = pr_csvw_num(w, r->min_gap);
	if (!rc)
		rc = pr_csvw_num(w, reward);
	if (!rc)
		rc = pr_csvw_num(w, r->t_end);
	if (!rc)
		rc = pr_csvw_int(w, r->events);
	return rc ? rc : pr_csvw_endrow(w);
}

static int write_trace(pr_csvw *w, long shot, const pr_sim_trace *tr)
{
	const pr_sim_trace_row *row = pr_sim_trace_rows(tr);
	long k, len = pr_sim_trace_len(tr);
	int rc = 0;

	for (k = 0; k < len && !rc; ++k) {
		rc = pr_csvw_int(w, shot);
		if (!rc)
			rc = pr_csvw_num(w, row[k].t);
		if (!rc)
			rc = pr_csvw_int(w, row[k].ball);
		if (!rc)
			rc = pr_csvw_num(w, row[k].x);
		if (!rc)
			rc = pr_csvw_num(w, row[k].y);
		if (!rc)
			rc = pr_csvw_num(w, row[k].vx);
		if (!rc)
			rc = pr_csvw_num(w, row[k].vy);
		if (!rc)
			rc = pr_csvw_endrow(w);
	}
	return rc;
}

int pr_cmd_shoot(const pr_config *cfg, const shoot_args *a, char *err)
{
	pr_csv *in = NULL;
	pr_sim *sim = NULL;
	pr_sim_trace *tr = NULL;
	pr_outset *set = NULL;
	pr_csvw *w = NULL, *tw = NULL;
	double *state = NULL, act[2];
	int *col = NULL, n, rc;
	char why[PR_ERRLEN];
	long r, nrows;

	if ((rc = pr_csv_read(a->input, &in, err)))
		return rc;
	n = (pr_csv_ncols(in) - 2) / 2;
	if (pr_csv_ncols(in) < 4 || pr_csv_ncols(in) % 2) {
		rc = pr_err(err, PR_EIO, "%s:1: %d columns: expected x0,y0,...,vx,vy (2 per ball plus 2)",
		            pr_csv_path(in), pr_csv_ncols(in));
		goto done;
	}
	if (n > PR_SIM_MAX_BALLS || n < 1 + cfg->table.reward_balls) {
		rc = pr_err(err, PR_EINVAL, "%s:1: %d balls: need 1 + table.reward_balls (%d) to %d",
		            pr_csv_path(in), n, cfg->table.reward_balls, PR_SIM_MAX_BALLS);
		goto done;
	}
	state = malloc((size_t)n * 2 * sizeof *state);
	col = malloc((size_t)(2 * n + 2) * sizeof *col);
	if (!state || !col) {
		rc = pr_err(err, PR_ENOMEM, "shoot: out of memory");
		goto done;
	}
	if ((rc = map_columns(in, n, col, err)))
		goto done;
	/* check every row before writing anything */
	nrows = pr_csv_nrows(in);
	for (r = 0; r < nrows; ++r) {
		get_row(in, r, n, col, state, act);
		if ((rc = pr_sim_check_state(&cfg->table, state, n, why)) ||
		    (rc = pr_sim_check_action(&cfg->sim, act, why))) {
			rc = pr_err(err, rc, "%s:%ld: %s", pr_csv_path(in), pr_csv_line(in, r), why);
			goto done;
		}
	}
	if (!(sim = pr_sim_new(&cfg->table, &cfg->sim, err))) {
		rc = PR_EINVAL;
		goto done;
	}
	if (a->trace && !(tr = pr_sim_trace_new(err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	/* output and trace are committed together, only if both are complete */
	if (!(set = pr_outset_new(err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	if ((rc = pr_outset_add(set, a->output, &w, err)) ||
	    (a->trace && (rc = pr_outset_add(set, a->trace, &tw, err))))
		goto done;
	write_header(w, a->keep ? in : NULL, n);
	if (tw)
		pr_csvw_header(tw, "shot,t,ball,x,y,vx,vy");
	/* a write error sticks in its writer: stop, the commit reports it */
	for (r = 0; r < nrows && !pr_csvw_status(w) && !(tw && pr_csvw_status(tw)); ++r) {
		pr_shot res;
		if (pr_interrupted) {
			rc = pr_err(err, PR_EINTR, "shoot: interrupted");
			goto done;
		}
		get_row(in, r, n, col, state, act);
		if ((rc = pr_sim_shoot(sim, state, n, act, &res, tr, why))) {
			rc = pr_err(err, rc, "%s:%ld: %s", pr_csv_path(in), pr_csv_line(in, r), why);
			goto done;
		}
		write_shot(w, a->keep ? pr_csv_row(in, r) : NULL, pr_csv_ncols(in), &res,
		           pr_sim_reward(&cfg->table, &cfg->reward, &res));
		if (tw)
			write_trace(tw, r, tr);
	}
done:
	rc = pr_outset_commit(set, rc, err);
	pr_sim_trace_free(tr);
	pr_sim_free(sim);
	free(state);
	free(col);
	pr_csv_free(in);
	return rc;
}

static int shoot_main(const pr_config *cfg, const void *opts, char *err)
{
	return pr_cmd_shoot(cfg, opts, err);
}

static const cli_opt shoot_opts[] = {
	CLI_COMMON_C, CLI_OPT("i", CLI_STR, shoot_args, input), CLI_OPT("o", CLI_STR, shoot_args, output),
	CLI_COMMON_SET, CLI_OPT("trace", CLI_STR, shoot_args, trace),
	CLI_OPT("keep", CLI_FLAG, shoot_args, keep), CLI_END
};

const cli_command cli_shoot = {
	"shoot",
	"poolreps shoot [-c FILE] [-i IN.csv] [-o OUT.csv] [--trace TRACE.csv] [--keep]\n"
	"  One shot per input row. Input columns x0,y0,x1,y1,...,vx,vy. Output columns\n"
	"  x0,y0,... (final), pocket0,... (id or -1), hit, min_gap, reward, t_end, events.\n"
	"  --keep copies the input columns in front; the final positions are then\n"
	"  final_x0,final_y0,...",
	shoot_opts, sizeof(shoot_args), "table.,sim.,reward.", CLI_OPS_NONE, 0, NULL, shoot_main
};
