/* exp_figures.c — CSV data for the simulator figures (thesis Fig. 7.1,
 * 7.2, 7.3 and 7.5); scripts/plot_sim_figures.py draws them. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <gsl/gsl_rng.h>

#include "poolreps/csvio.h"
#include "poolreps/figures.h"
#include "exp_priv.h"

#define GRID 201
#define VMAX 1.5 /* m/s: the landscape's action box, [-VMAX, VMAX]^2 */

/* Open dir/name and write its header (a comma list). */
static pr_csvw *open_csv(const char *dir, const char *name, const char *header, char *err)
{
	char path[1024];
	pr_csvw *w;

	snprintf(path, sizeof path, "%s/%s", dir, name);
	if ((w = pr_csvw_open(path, err)))
		pr_csvw_header(w, header);
	return w;
}

/* Finish the open CSV *w with status rc, then open dir/name with its
 * header: a figure's files are written one after another. */
static int next_csv(pr_csvw **w, int rc, const char *dir, const char *name, const char *header,
                    char *err)
{
	rc = pr_csvw_finish(*w, rc, err);
	*w = NULL;
	if (rc)
		return rc;
	return (*w = open_csv(dir, name, header, err)) ? PR_OK : PR_EIO;
}

/* One row of n numbers. */
static int put_row(pr_csvw *w, int n, const double *v)
{
	int i, rc = 0;

	for (i = 0; i < n && !rc; ++i)
		rc = pr_csvw_num(w, v[i]);
	return rc ? rc : pr_csvw_endrow(w);
}

static int write_trace(pr_csvw *w, double shot, const pr_sim_trace *tr, int with_shot)
{
	const pr_sim_trace_row *r = pr_sim_trace_rows(tr);
	long k;
	int rc = 0;

	for (k = 0; k < pr_sim_trace_len(tr) && !rc; ++k) {
		double v[7] = {shot, r[k].t, r[k].ball, r[k].x, r[k].y, r[k].vx, r[k].vy};
		rc = with_shot ? put_row(w, 7, v) : put_row(w, 6, v + 1);
	}
	return rc;
}

static int fig_table(const pr_config *cfg, const char *dir, gsl_rng *rng, double *st, int n, char *err)
{
	static const char *const role[] = {"cue", "reward", "obstacle"};
	const pr_table *t = &cfg->table;
	pr_csvw *w;
	int i, rc = 0;

	if (!(w = open_csv(dir, "fig7_table.csv", "length,width,ball_radius,pocket_radius", err)))
		return PR_EIO;
	{
		double v[4] = {t->length, t->width, t->ball_radius, t->pocket_radius};
		rc = put_row(w, 4, v);
	}
	if ((rc = next_csv(&w, rc, dir, "fig7_1_pockets.csv", "pocket,x,y", err)))
		return rc;
	for (i = 0; i < PR_SIM_POCKETS && !rc; ++i) {
		double v[3] = {i, 0, 0};
		pr_sim_pocket_xy(t, i, v + 1);
		rc = put_row(w, 3, v);
	}
	if ((rc = pr_csvw_finish(w, rc, err)))
		return rc;
	if ((rc = pr_sim_sample_start(t, &cfg->start, n, rng, st, err)))
		return rc;
	if (!(w = open_csv(dir, "fig7_1_balls.csv", "ball,role,x,y", err)))
		return PR_EIO;
	for (i = 0; i < n && !rc; ++i) {
		rc = pr_csvw_int(w, i);
		if (!rc)
			rc = pr_csvw_str(w, role[i == 0 ? 0 : i <= t->reward_balls ? 1 : 2]);
		if (!rc)
			rc = put_row(w, 2, st + 2 * i);
	}
	return pr_csvw_finish(w, rc, err);
}

/* Grid cell (i, j) <-> action; i runs over vx, j over vy. */
static void grid_action(int i, int j, double *a)
{
	a[0] = -VMAX + 2 * VMAX * i / (GRID - 1);
	a[1] = -VMAX + 2 * VMAX * j / (GRID - 1);
}

/* Fig. 7.2 and 7.3: the reward landscape of the fixed state, then for
 * pockets 2 and 5 the zero-reward action deepest inside its zero region
 * (most zero-reward neighbours with the same pocket, then slowest). */
static int fig_landscape(const pr_config *cfg, const char *dir, char *err)
{
	static const double state[4] = {-0.25, 0, 0.1, 0};
	static const int want[2] = {2, 5};
	pr_table t = cfg->table;
	pr_sim *sim = NULL;
	pr_sim_trace *tr = NULL;
	pr_csvw *w = NULL;
	double *rew = NULL, chosen[2][2];
	int *pk = NULL, i, j, q, rc = 0;

	t.reward_balls = 1; /* two balls: the cue ball and one reward ball */
	rew = malloc(GRID * GRID * sizeof *rew);
	pk = malloc(GRID * GRID * sizeof *pk);
	if (!rew || !pk) {
		rc = pr_err(err, PR_ENOMEM, "figures: out of memory");
		goto done;
	}
	if (!(sim = pr_sim_new(&t, &cfg->sim, err)) || !(tr = pr_sim_trace_new(err))) {
		rc = PR_EINVAL;
		goto done;
	}
	if (!(w = open_csv(dir, "fig7_2_reward.csv", "vx,vy,reward,hit,pocket1", err))) {
		rc = PR_EIO;
		goto done;
	}
	for (i = 0; i < GRID && !rc; ++i)
		for (j = 0; j < GRID && !rc; ++j) {
			double a[2], v[5];
			pr_shot r;
			grid_action(i, j, a);
			if ((rc = pr_sim_shoot(sim, state, 2, a, &r, NULL, err)))
				goto done;
			rew[i * GRID + j] = pr_sim_reward(&t, &cfg->reward, &r);
			pk[i * GRID + j] = r.pocket[1];
			v[0] = a[0];
			v[1] = a[1];
			v[2] = rew[i * GRID + j];
			v[3] = r.hit;
			v[4] = r.pocket[1];
			rc = put_row(w, 5, v);
		}
	if ((rc = next_csv(&w, rc, dir, "fig7_3_shots.csv", "shot,pocket,vx,vy,reward", err)))
		goto done;
	for (q = 0; q < 2 && !rc; ++q) {
		int best = -1, bestnb = -1;
		double bestv = HUGE_VAL, a[2];
		for (i = 0; i < GRID; ++i)
			for (j = 0; j < GRID; ++j) {
				int di, dj, nb = 0;
				if (rew[i * GRID + j] != 0 || pk[i * GRID + j] != want[q])
					continue;
				for (di = -1; di <= 1; ++di)
					for (dj = -1; dj <= 1; ++dj) {
						int ii = i + di, jj = j + dj;
						nb += ii >= 0 && ii < GRID && jj >= 0 && jj < GRID &&
						      rew[ii * GRID + jj] == 0 && pk[ii * GRID + jj] == want[q];
					}
				grid_action(i, j, a);
				if (nb > bestnb || (nb == bestnb && hypot(a[0], a[1]) < bestv)) {
					best = i * GRID + j;
					bestnb = nb;
					bestv = hypot(a[0], a[1]);
				}
			}
		if (best < 0) {
			rc = pr_err(err, PR_ENUM, "figures: no zero-reward action into pocket %d on the grid", want[q]);
			goto done;
		}
		grid_action(best / GRID, best % GRID, a);
		chosen[q][0] = a[0];
		chosen[q][1] = a[1];
		{
			double v[5] = {q, want[q], a[0], a[1], rew[best]};
			rc = put_row(w, 5, v);
		}
	}
	if ((rc = next_csv(&w, rc, dir, "fig7_3_trace.csv", "shot,t,ball,x,y,vx,vy", err)))
		goto done;
	for (q = 0; q < 2 && !rc; ++q) {
		pr_shot r;
		if (!(rc = pr_sim_shoot(sim, state, 2, chosen[q], &r, tr, err)))
			rc = write_trace(w, q, tr, 1);
	}
	rc = pr_csvw_finish(w, rc, err);
	w = NULL;
done:
	pr_csvw_abort(w);
	pr_sim_trace_free(tr);
	pr_sim_free(sim);
	free(rew);
	free(pk);
	return rc;
}

/* Fig. 7.5: the ghost-ball geometry of one state (the cue ball and first
 * reward ball of Fig. 7.1's state, redrawn until the expert has a shot). */
static int fig_ghost(const pr_config *cfg, const char *dir, gsl_rng *rng, double *st, char *err)
{
	pr_table t = cfg->table;
	pr_sim *sim = NULL;
	pr_sim_trace *tr = NULL;
	pr_csvw *w = NULL;
	pr_sim_ghost g;
	pr_shot r;
	double a[2];
	int k, rc;

	t.reward_balls = 1;
	for (k = 0;; ++k) {
		if (!(rc = pr_sim_ghost_action(&t, &cfg->sim, &cfg->reward, &cfg->expert, st, a, &g, err)))
			break;
		if (k >= cfg->start.max_tries || (rc = pr_sim_sample_start(&t, &cfg->start, 2, rng, st, err)))
			return rc;
	}
	if (!(sim = pr_sim_new(&t, &cfg->sim, err)) || !(tr = pr_sim_trace_new(err))) {
		rc = PR_EINVAL;
		goto done;
	}
	if ((rc = pr_sim_shoot(sim, st, 2, a, &r, tr, err)))
		goto done;
	if (!(w = open_csv(dir, "fig7_5_ghost.csv", "cue_x,cue_y,ball_x,ball_y,target,aim_x,aim_y,ghost_x,"
	                   "ghost_y,dir_x,dir_y,cut_deg,v_contact,v0,vx,vy,pocket1,reward,entry_x,entry_y", err))) {
		rc = PR_EIO;
		goto done;
	}
	{
		double v[20] = {st[0], st[1], st[2], st[3], g.target, g.aim[0], g.aim[1], g.ghost[0],
		                g.ghost[1], g.dir[0], g.dir[1], g.cut * 180 / acos(-1.0), g.v_contact,
		                g.v0, a[0], a[1], r.pocket[1], pr_sim_reward(&t, &cfg->reward, &r),
		                g.entry[0], g.entry[1]};
		rc = put_row(w, 20, v);
	}
	if ((rc = next_csv(&w, rc, dir, "fig7_5_trace.csv", "t,ball,x,y,vx,vy", err)))
		goto done;
	rc = pr_csvw_finish(w, write_trace(w, 0, tr, 0), err);
	w = NULL;
done:
	pr_csvw_abort(w);
	pr_sim_trace_free(tr);
	pr_sim_free(sim);
	return rc;
}

int pr_exp_figures(const pr_config *cfg, const char *dir, char *err)
{
	gsl_rng *rng;
	double *st;
	int n = cfg->table.balls, rc;

	if (mkdir(dir, 0777) && errno != EEXIST)
		return pr_err(err, pr_errno_status(), "%s: cannot create directory: %s", dir, strerror(errno));
	if (n < 2 || n > PR_SIM_MAX_BALLS)
		return pr_err(err, PR_EINVAL, "table.balls: %d, figures need 2 to %d", n, PR_SIM_MAX_BALLS);
	rng = gsl_rng_alloc(gsl_rng_mt19937);
	st = malloc((size_t)n * 2 * sizeof *st);
	if (!rng || !st) {
		gsl_rng_free(rng);
		free(st);
		return pr_err(err, PR_ENOMEM, "figures: out of memory");
	}
	gsl_rng_set(rng, cfg->run.seed);
	if (!(rc = fig_table(cfg, dir, rng, st, n, err)) && !(rc = fig_landscape(cfg, dir, err)))
		rc = fig_ghost(cfg, dir, rng, st, err);
	gsl_rng_free(rng);
	free(st);
	return rc;
}

/* The registry's entry point: no repetitions, no progress to report. */
int pr_figures_run(const pr_config *cfg, const char *dir, const pr_progress *prog, char *err)
{
	(void)prog;
	return pr_exp_figures(cfg, dir, err);
}
