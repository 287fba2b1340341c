/* shoot.c — the `shoot` row filter (shoot.h): a pr_csv_stream in, one
 * pr_sim_shoot per row, a pr_outset out.
 *
 * Invariant: memory holds one chunk of input rows (what one read of the
 * input gave), one shot's trace and the writers' buffers, whatever the
 * number of rows. Every chunk's results are pushed to a pipe before the next
 * read, so a consumer sees them while the input still arrives.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "poolreps/csvio.h"
#include "poolreps/shoot.h"
#include "poolreps/internal.h"
#include "poolreps/shotparams.h"

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

static void get_row(const double *row, int n, const int *col, double *state, double *act)
{
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

/* keep: the input row copied in front, or NULL */
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

/* The shooter's state: options, per-row parameters, columns and writers. */
typedef struct {
	const pr_config *cfg;
	pr_shot_params *params;
	pr_sim_trace *tr;
	pr_csvw *w, *tw;
	int n, ncols, keep, *col;
	int nparam, *pcol;   /* key columns */
	const char **keys;   /* their names */
	double *state, *pval;
	long shots;          /* rows shot so far: the trace's shot index */
} shooter;

/* The key columns ("section.key": a parameter per row, shotparams.h): their
 * names into s->keys and their columns into s->pcol; returns their count. */
static int key_columns(shooter *s, const pr_csv *in)
{
	int i, k = 0;

	for (i = 0; i < s->ncols; ++i)
		if (strchr(pr_csv_name(in, i), '.')) {
			s->keys[k] = pr_csv_name(in, i);
			s->pcol[k++] = i;
		}
	return k;
}

/* The header's checks: column count, ball count, every expected name, the
 * key columns' keys. */
static int check_columns(shooter *s, const pr_csv *in, char *err)
{
	char why[PR_ERRLEN];
	int rc;

	s->ncols = pr_csv_ncols(in);
	s->keys = malloc(((size_t)s->ncols + 1) * sizeof *s->keys);
	s->pcol = malloc(((size_t)s->ncols + 1) * sizeof *s->pcol);
	s->pval = malloc(((size_t)s->ncols + 1) * sizeof *s->pval);
	if (!s->keys || !s->pcol || !s->pval)
		return pr_err(err, PR_ENOMEM, "shoot: out of memory");
	s->nparam = key_columns(s, in);
	s->n = (s->ncols - s->nparam - 2) / 2;
	if (s->ncols - s->nparam < 4 || (s->ncols - s->nparam) % 2)
		return pr_err(err, PR_EIO, "%s:1: %d columns: expected x0,y0,...,vx,vy (2 per ball plus 2) "
		              "and key columns section.key", pr_csv_path(in), s->ncols);
	if (s->n > PR_SIM_MAX_BALLS || s->n < 1 + s->cfg->table.reward_balls)
		return pr_err(err, PR_EINVAL, "%s:1: %d balls: need 1 + table.reward_balls (%d) to %d",
		              pr_csv_path(in), s->n, s->cfg->table.reward_balls, PR_SIM_MAX_BALLS);
	s->state = malloc((size_t)s->n * 2 * sizeof *s->state);
	s->col = malloc((size_t)(2 * s->n + 2) * sizeof *s->col);
	if (!s->state || !s->col)
		return pr_err(err, PR_ENOMEM, "shoot: out of memory");
	if ((rc = map_columns(in, s->n, s->col, err)))
		return rc;
	if (!(s->params = pr_shot_params_new(s->cfg, s->nparam, s->keys, why)))
		return pr_err(err, strstr(why, "out of memory") ? PR_ENOMEM : PR_EINVAL, "%s:1: %s",
		              pr_csv_path(in), why);
	return PR_OK;
}

/* Check and shoot every row of a chunk, in order; write each result. A write
 * error sticks in its writer: stop, the commit reports it. */
static int shoot_chunk(shooter *s, const pr_csv *chunk, char *err)
{
	char why[PR_ERRLEN];
	const pr_config *cfg = pr_shot_params_config(s->params);
	double act[2];
	long r, nrows = pr_csv_nrows(chunk);
	int k, rc = PR_OK;

	for (r = 0; r < nrows && !pr_csvw_status(s->w) && !(s->tw && pr_csvw_status(s->tw)); ++r) {
		const double *row = pr_csv_row(chunk, r);
		pr_sim *sim;
		pr_shot res;

		if (pr_interrupted)
			return pr_err(err, PR_EINTR, "shoot: interrupted");
		get_row(row, s->n, s->col, s->state, act);
		for (k = 0; k < s->nparam; ++k)
			s->pval[k] = row[s->pcol[k]];
		if (!(sim = pr_shot_params_row(s->params, s->pval, &rc, why)) ||
		    (rc = pr_sim_check_state(&cfg->table, s->state, s->n, why)) ||
		    (rc = pr_sim_check_action(&cfg->sim, act, why)) ||
		    (rc = pr_sim_shoot(sim, s->state, s->n, act, &res, s->tr, why)))
			return pr_err(err, rc, "%s:%ld: %s", pr_csv_path(chunk), pr_csv_line(chunk, r), why);
		write_shot(s->w, s->keep ? row : NULL, s->ncols, &res,
		           pr_sim_reward(&cfg->table, &cfg->reward, &res));
		if (s->tw)
			write_trace(s->tw, s->shots, s->tr);
		s->shots++;
	}
	pr_csvw_flush(s->w);
	if (s->tw)
		pr_csvw_flush(s->tw);
	return PR_OK;
}

/* Open the outputs of the set, write their headers, then every chunk. */
static int shoot_stream(shooter *s, pr_csv_stream *in, const pr_shoot_files *f, pr_outset *set,
                        char *err)
{
	const pr_csv *chunk;
	int rc;

	if ((rc = pr_outset_add(set, f->output, &s->w, err)) ||
	    (f->trace && (rc = pr_outset_add(set, f->trace, &s->tw, err))))
		return rc;
	write_header(s->w, f->keep ? pr_csv_stream_columns(in) : NULL, s->n);
	if (s->tw)
		pr_csvw_header(s->tw, "shot,t,ball,x,y,vx,vy");
	while (!(rc = pr_csv_stream_next(in, &chunk, err)) && chunk)
		if ((rc = shoot_chunk(s, chunk, err)))
			break;
	return rc;
}

int pr_shoot_csv(const pr_config *c, const pr_shoot_files *f, char *err)
{
	shooter s = { 0 };
	pr_csv_stream *in = NULL;
	pr_outset *set = NULL;
	int rc;

	s.cfg = c;
	s.keep = f->keep;
	if ((rc = pr_csv_stream_open(f->input, &in, err)) ||
	    (rc = check_columns(&s, pr_csv_stream_columns(in), err)))
		goto done;
	if ((f->trace && !(s.tr = pr_sim_trace_new(err))) || !(set = pr_outset_new(err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	/* output and trace are committed together, only if both are complete */
	rc = shoot_stream(&s, in, f, set, err);
done:
	rc = pr_outset_commit(set, rc, err);
	pr_sim_trace_free(s.tr);
	pr_shot_params_free(s.params);
	free(s.state);
	free(s.col);
	free(s.keys);
	free(s.pcol);
	free(s.pval);
	pr_csv_stream_free(in);
	return rc;
}
