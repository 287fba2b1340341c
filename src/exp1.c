/* exp1.c — Experiment 1 (thesis 7.3): how well extra-trees forests represent
 * the reward function.
 *
 * Data: cue ball at the cue box (default (-0.25, 0)), reward ball uniform in
 * start.reward_box, the cue aimed at the reward ball's centre at
 * exp1.aim_speed; the target is the return of eq. 7.7. The
 * exp1.train training and exp1.test test shots come from streams that do not
 * depend on the repetition, so every process regenerates them identically.
 *
 * Repetition k is forest k of every setting: it trains on training rows
 * [k*subset, (k+1)*subset) and is scored on test rows [k*test_subset, ...),
 * the same rows for every setting (common random numbers). Each setting's
 * forest k draws from its own stream, so every setting is a variant that can
 * run alone (experiment.variant): variants 0.. are the settings in output
 * order, the last one is the reward map.
 * Inputs are the full state (x0,y0,x1,y1); the cue ball's fixed coordinates
 * are constant, and the forest never cuts a constant dimension.
 *
 * Outputs (raw, first column `repetition`):
 *   exp1_mse.csv  repetition,sweep,n_min,trees,cuts,mse — one row per setting
 *                 of the n_min, trees and cuts sweeps (the other two
 *                 parameters at forest.*), in list order.
 *   exp1_map.csv  repetition,x1,y1,reward,pred — the simulated return on an
 *                 exp1.map_grid^2 grid of reward-ball positions over
 *                 start.reward_box and the prediction of a forest with the
 *                 forest.* parameters trained on repetition k's subset.
 * Derived (summarize, from exp1_mse.csv alone):
 *   exp1_summary.csv  sweep,value,mean_mse,std_mse,forests — std is the
 *                 sample standard deviation over the forests (0 for one).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "poolreps/csvio.h"
#include "poolreps/forest.h"
#include "poolreps/sim.h"
#include "exp_priv.h"
#include "streams.h"

#define DX 4 /* state: cue ball and reward ball */

enum { SWEEP_NMIN, SWEEP_TREES, SWEEP_CUTS, NSWEEPS };
static const char *const sweep_name[NSWEEPS] = {"n_min", "trees", "cuts"};

void pr_exp1_opts_init(pr_exp1_opts *o)
{
	static const double nmin[] = {2, 5, 10, 20, 40, 60, 80, 100, 120, 140, 160, 180, 200};
	static const double trees[] = {1, 2, 5, 10, 15, 20, 30, 40, 50};
	static const double cuts[] = {1, 2, 3, 4, 5, 7, 10, 15, 20};
	pr_expert_opts e;

	memset(o, 0, sizeof *o);
	pr_sim_expert_opts_init(&e);
	o->aim_speed = e.aim_speed;
	o->train = 1000;
	o->test = 1000;
	o->subset = 200;
	o->test_subset = 200;
	o->n_min_list.n = (int)(sizeof nmin / sizeof nmin[0]);
	memcpy(o->n_min_list.v, nmin, sizeof nmin);
	o->trees_list.n = (int)(sizeof trees / sizeof trees[0]);
	memcpy(o->trees_list.v, trees, sizeof trees);
	o->cuts_list.n = (int)(sizeof cuts / sizeof cuts[0]);
	memcpy(o->cuts_list.v, cuts, sizeof cuts);
	o->map_grid = 41;
}

static void init_keys(void *o)
{
	pr_exp1_opts_init(o);
}

#define F(field) offsetof(pr_exp1_opts, field)
static const pr_config_key key_table[] = {
	{"exp1", "aim_speed", PR_KEY_DOUBLE, F(aim_speed), 0, 100, PR_KEY_OPEN_LO, "m/s",
	 "Experiment 1 data policy: cue speed aimed at the reward ball"},
	{"exp1", "train", PR_KEY_INT, F(train), 1, 10000000, 0, "", "training shots"},
	{"exp1", "test", PR_KEY_INT, F(test), 1, 10000000, 0, "", "test shots"},
	{"exp1", "subset", PR_KEY_INT, F(subset), 1, 10000000, 0, "", "training samples per forest"},
	{"exp1", "test_subset", PR_KEY_INT, F(test_subset), 1, 10000000, 0, "", "test samples per forest"},
	{"exp1", "n_min_list", PR_KEY_ILIST, F(n_min_list), 1, 10000000, 0, "", "n_min sweep (Fig. 7.4a)"},
	{"exp1", "trees_list", PR_KEY_ILIST, F(trees_list), 1, PR_FOREST_MAX_TREES, 0, "", "M sweep (Fig. 7.4b)"},
	{"exp1", "cuts_list", PR_KEY_ILIST, F(cuts_list), 1, PR_FOREST_MAX_CUTS, 0, "", "K sweep (Fig. 7.4c)"},
	{"exp1", "map_grid", PR_KEY_INT, F(map_grid), 2, 1000, 0, "", "reward map grid points per side"},
};
#undef F

const pr_config_block pr_exp1_keys = {
	key_table, (int)(sizeof key_table / sizeof key_table[0]), sizeof(pr_exp1_opts), init_keys, NULL
};

static const pr_exp1_opts *opts_of(const pr_config *cfg)
{
	return pr_config_opts(cfg, &pr_exp1_keys);
}

/* The aim-at-ball data policy: the expert's options at exp1.aim_speed. */
static pr_expert_opts aim_policy(const pr_config *cfg)
{
	pr_expert_opts e = cfg->expert;

	e.aim_speed = opts_of(cfg)->aim_speed;
	return e;
}

/* One forest setting of a sweep. */
typedef struct {
	int sweep, pos;  /* sweep and position in its list */
	pr_forest_opts fo;
} setting;

typedef struct {
	const pr_config *cfg;
	const double *xtr, *ytr, *xte, *yte;  /* shared shots: states and returns */
	setting set[NSWEEPS * PR_LIST_MAX];
	int nset;
	int map;                              /* fit the reward map's forests */
	double cue[2];                        /* the map's cue ball position */
	const double *grid;                   /* ngrid x 3: x1, y1, simulated return */
	int ngrid;
	int lo;
	double *mse;                          /* (hi - lo) x nset */
	double *pred;                         /* (hi - lo) x ngrid */
	pr_exp_ticker tick;
} job_ctx;

/* The first n aim-at-ball shots of stream (seed, stream, 0): states and returns. */
static int make_shots(const pr_config *cfg, pr_sim *sim, unsigned long stream, int n,
                      double *x, double *y, char *err)
{
	gsl_rng *rng = pr_exp_rng(cfg->run.seed, stream, 0);
	const pr_expert_opts aim = aim_policy(cfg);
	int i, rc = PR_OK;

	if (!rng)
		return pr_err(err, PR_ENOMEM, "out of memory");
	for (i = 0; i < n && rc == PR_OK; ++i) {
		double a[2];
		pr_shot shot;
		if (pr_interrupted) {
			rc = pr_err(err, PR_EINTR, "interrupted");
			break;
		}
		if ((rc = pr_sim_sample_start(&cfg->table, &cfg->start, 2, rng, x + DX * i, err)) ||
		    (rc = pr_sim_aim_action(&aim, x + DX * i, a, err)) ||
		    (rc = pr_sim_shoot(sim, x + DX * i, 2, a, &shot, NULL, err)))
			break;
		y[i] = pr_sim_reward(&cfg->table, &cfg->reward, &shot);
	}
	gsl_rng_free(rng);
	return rc;
}

/* The reward map's grid over start.reward_box with the simulated return;
 * positions the simulator refuses (inside a pocket, on the cue ball) are left out. */
static int make_grid(const pr_config *cfg, pr_sim *sim, const double cue[2], double *grid,
                     int *ngrid, char *err)
{
	const double *b = cfg->start.reward_box;
	const pr_expert_opts aim = aim_policy(cfg);
	int g = opts_of(cfg)->map_grid, i, j, n = 0, rc;

	for (j = 0; j < g; ++j)
		for (i = 0; i < g; ++i) {
			double s[DX], a[2];
			pr_shot shot;
			s[0] = cue[0];
			s[1] = cue[1];
			s[2] = b[0] + (b[1] - b[0]) * i / (g - 1);
			s[3] = b[2] + (b[3] - b[2]) * j / (g - 1);
			if (pr_sim_check_state(&cfg->table, s, 2, NULL) != PR_OK)
				continue;
			if (pr_interrupted)
				return pr_err(err, PR_EINTR, "interrupted");
			if ((rc = pr_sim_aim_action(&aim, s, a, err)) ||
			    (rc = pr_sim_shoot(sim, s, 2, a, &shot, NULL, err)))
				return rc;
			grid[3 * n] = s[2];
			grid[3 * n + 1] = s[3];
			grid[3 * n + 2] = pr_sim_reward(&cfg->table, &cfg->reward, &shot);
			++n;
		}
	*ngrid = n;
	return PR_OK;
}

static double test_mse(const pr_forest *f, const double *x, const double *y, int n)
{
	double sum = 0;
	int i;

	for (i = 0; i < n; ++i) {
		double p;
		pr_forest_predict(f, x + DX * i, &p);
		sum += (p - y[i]) * (p - y[i]);
	}
	return sum / n;
}

/* Repetition k: forest k of every setting, then the map forest. */
static int run_rep(void *arg, int k, char *err)
{
	job_ctx *c = arg;
	const pr_exp1_opts *o = opts_of(c->cfg);
	const double *xtr = c->xtr + (size_t)DX * k * o->subset, *ytr = c->ytr + (size_t)k * o->subset;
	const double *xte = c->xte + (size_t)DX * k * o->test_subset;
	const double *yte = c->yte + (size_t)k * o->test_subset;
	double *mse = c->mse + (size_t)(k - c->lo) * c->nset;
	double *pred = c->pred + (size_t)(k - c->lo) * c->ngrid;
	gsl_rng *rng;
	pr_forest *f;
	int s, i;

	for (s = 0; s < c->nset; ++s) {
		const setting *t = &c->set[s];
		if (pr_interrupted)
			return pr_err(err, PR_EINTR, "interrupted");
		rng = pr_exp_rng(c->cfg->run.seed, PR_STREAM_EXP1_SETTING + (unsigned long)t->sweep,
		                 (unsigned long)k * PR_LIST_MAX + (unsigned long)t->pos);
		if (!rng)
			return pr_err(err, PR_ENOMEM, "out of memory");
		f = pr_forest_fit(&t->fo, xtr, o->subset, DX, ytr, 1, NULL, rng, err);
		gsl_rng_free(rng);
		if (!f)
			return PR_EINVAL;
		mse[s] = test_mse(f, xte, yte, o->test_subset);
		pr_forest_free(f);
		pr_exp_ticker_add(&c->tick, 1);
	}
	if (!c->map)
		return PR_OK;
	rng = pr_exp_rng(c->cfg->run.seed, PR_STREAM_EXP1_MAP, (unsigned long)k);
	if (!rng)
		return pr_err(err, PR_ENOMEM, "out of memory");
	f = pr_forest_fit(&c->cfg->forest, xtr, o->subset, DX, ytr, 1, NULL, rng, err);
	gsl_rng_free(rng);
	if (!f)
		return PR_EINVAL;
	for (i = 0; i < c->ngrid; ++i) {
		double s4[DX] = {c->cue[0], c->cue[1], c->grid[3 * i], c->grid[3 * i + 1]};
		pr_forest_predict(f, s4, &pred[i]);
	}
	pr_forest_free(f);
	pr_exp_ticker_add(&c->tick, 1);
	return PR_OK;
}

/* The settings of the three sweeps, each varying one forest.* parameter. */
static int make_settings(const pr_config *cfg, job_ctx *c, char *err)
{
	const pr_exp1_opts *o = opts_of(cfg);
	const pr_list *lists[NSWEEPS] = {&o->n_min_list, &o->trees_list, &o->cuts_list};
	static const char *const keys[NSWEEPS] = {"exp1.n_min_list", "exp1.trees_list",
	                                          "exp1.cuts_list"};
	int v[PR_LIST_MAX], s, i, rc;

	c->nset = 0;
	for (s = 0; s < NSWEEPS; ++s) {
		if ((rc = pr_exp_int_list(lists[s], keys[s], v, err)))
			return rc;
		for (i = 0; i < lists[s]->n; ++i) {
			setting *t = &c->set[c->nset++];
			t->sweep = s;
			t->pos = i;
			t->fo = cfg->forest;
			if (s == SWEEP_NMIN)
				t->fo.n_min = v[i];
			else if (s == SWEEP_TREES)
				t->fo.trees = v[i];
			else
				t->fo.cuts = v[i];
			if ((rc = pr_forest_opts_check(&t->fo, keys[s], err)))
				return rc;
		}
	}
	return PR_OK;
}

/* The settings and the map this process runs: all, or the variant
 * experiment.variant picks (settings first, the map last). */
static int select_variant(const pr_config *cfg, job_ctx *c, char *err)
{
	int v = cfg->run.variant, rc;

	if ((rc = pr_exp_check_variant(cfg, c->nset + 1, err)))
		return rc;
	c->map = v < 0 || v == c->nset;
	if (v >= 0) {
		if (v < c->nset)
			c->set[0] = c->set[v];
		c->nset = v < c->nset;
	}
	return PR_OK;
}

int pr_exp1_variants(const pr_config *cfg, pr_variants *out, char *err)
{
	job_ctx *c = calloc(1, sizeof *c);
	int s, rc;

	if (!c)
		return pr_err(err, PR_ENOMEM, "out of memory");
	rc = make_settings(cfg, c, err);
	for (s = 0; rc == PR_OK && s < c->nset; ++s) {
		const setting *t = &c->set[s];
		const pr_forest_opts *fo = &t->fo;
		snprintf(out->name[s], sizeof out->name[s], "%s=%d", sweep_name[t->sweep],
		         t->sweep == SWEEP_NMIN ? fo->n_min : t->sweep == SWEEP_TREES ? fo->trees : fo->cuts);
	}
	if (rc == PR_OK) {
		snprintf(out->name[c->nset], sizeof out->name[c->nset], "map");
		out->n = c->nset + 1;
	}
	free(c);
	return rc;
}

static int check_opts(const pr_config *cfg, char *err)
{
	const pr_exp1_opts *o = opts_of(cfg);
	long r = cfg->run.repetitions;
	char at[PR_WHERE_LEN];

	if (cfg->table.balls != 2)
		return pr_err(err, PR_EINVAL, "%s: table.balls: Experiment 1 uses 2 balls (got %d)",
		              pr_config_where(cfg, "table.balls", at, sizeof at), cfg->table.balls);
	if (r * o->subset > o->train)
		return pr_err(err, PR_EINVAL, "%s: exp1.train: %d shots, but %ld repetitions x "
		              "exp1.subset %d need %ld", pr_config_where(cfg, "exp1.train", at, sizeof at),
		              o->train, r, o->subset, r * o->subset);
	if (r * o->test_subset > o->test)
		return pr_err(err, PR_EINVAL, "%s: exp1.test: %d shots, but %ld repetitions x "
		              "exp1.test_subset %d need %ld", pr_config_where(cfg, "exp1.test", at, sizeof at),
		              o->test, r, o->test_subset, r * o->test_subset);
	return pr_forest_opts_check(&cfg->forest, "forest", err);
}

static int write_mse(const char *dir, const job_ctx *c, int lo, int hi, char *err)
{
	pr_csvw *w;
	int k, s;

	if (!(w = pr_exp_csv_open(err, "%s/exp1_mse.csv", dir)))
		return PR_EIO;
	pr_csvw_header(w, "repetition,sweep,n_min,trees,cuts,mse");
	for (k = lo; k < hi; ++k)
		for (s = 0; s < c->nset; ++s) {
			const setting *t = &c->set[s];
			pr_csvw_int(w, k);
			pr_csvw_str(w, sweep_name[t->sweep]);
			pr_csvw_int(w, t->fo.n_min);
			pr_csvw_int(w, t->fo.trees);
			pr_csvw_int(w, t->fo.cuts);
			pr_csvw_num(w, c->mse[(size_t)(k - lo) * c->nset + s]);
			pr_csvw_endrow(w);
		}
	return pr_csvw_close(w, err);
}

static int write_map(const char *dir, const job_ctx *c, int lo, int hi, char *err)
{
	pr_csvw *w;
	int k, i;

	if (!(w = pr_exp_csv_open(err, "%s/exp1_map.csv", dir)))
		return PR_EIO;
	pr_csvw_header(w, "repetition,x1,y1,reward,pred");
	for (k = lo; k < hi; ++k)
		for (i = 0; i < c->ngrid; ++i) {
			pr_csvw_int(w, k);
			pr_csvw_num(w, c->grid[3 * i]);
			pr_csvw_num(w, c->grid[3 * i + 1]);
			pr_csvw_num(w, c->grid[3 * i + 2]);
			pr_csvw_num(w, c->pred[(size_t)(k - lo) * c->ngrid + i]);
			pr_csvw_endrow(w);
		}
	return pr_csvw_close(w, err);
}

int pr_exp1_run(const pr_config *cfg, const char *dir, const pr_progress *prog, char *err)
{
	const pr_exp1_opts *o = opts_of(cfg);
	job_ctx *c;
	pr_sim *sim = NULL;
	double *xtr = NULL, *ytr = NULL, *xte = NULL, *yte = NULL, *grid = NULL;
	int lo, hi, rc;

	if ((rc = check_opts(cfg, err)))
		return rc;
	pr_exp_reps(cfg, &lo, &hi);
	c = calloc(1, sizeof *c);
	if (!c)
		return pr_err(err, PR_ENOMEM, "out of memory");
	if ((rc = make_settings(cfg, c, err)) || (rc = select_variant(cfg, c, err)))
		goto done;
	xtr = malloc((size_t)o->train * DX * sizeof *xtr);
	ytr = malloc((size_t)o->train * sizeof *ytr);
	xte = malloc((size_t)o->test * DX * sizeof *xte);
	yte = malloc((size_t)o->test * sizeof *yte);
	grid = malloc((size_t)o->map_grid * o->map_grid * 3 * sizeof *grid);
	if (!xtr || !ytr || !xte || !yte || !grid) {
		rc = pr_err(err, PR_ENOMEM, "out of memory");
		goto done;
	}
	/* the map's cue ball sits at the centre of the cue box (a point by default) */
	c->cue[0] = 0.5 * (cfg->start.cue_box[0] + cfg->start.cue_box[1]);
	c->cue[1] = 0.5 * (cfg->start.cue_box[2] + cfg->start.cue_box[3]);
	if (!(sim = pr_sim_new(&cfg->table, &cfg->sim, err))) {
		rc = PR_EINVAL;
		goto done;
	}
	if ((rc = make_shots(cfg, sim, PR_STREAM_EXP1_TRAIN, o->train, xtr, ytr, err)) ||
	    (rc = make_shots(cfg, sim, PR_STREAM_EXP1_TEST, o->test, xte, yte, err)) ||
	    (c->map && (rc = make_grid(cfg, sim, c->cue, grid, &c->ngrid, err))))
		goto done;
	c->cfg = cfg;
	c->xtr = xtr;
	c->ytr = ytr;
	c->xte = xte;
	c->yte = yte;
	c->grid = grid;
	c->lo = lo;
	c->mse = malloc(((size_t)(hi - lo) * c->nset + 1) * sizeof *c->mse);
	c->pred = malloc(((size_t)(hi - lo) * c->ngrid + 1) * sizeof *c->pred);
	if (!c->mse || !c->pred) {
		rc = pr_err(err, PR_ENOMEM, "out of memory");
		goto done;
	}
	pr_exp_ticker_init(&c->tick, prog, (long)(hi - lo) * (c->nset + c->map), "exp1");
	rc = pr_exp_parallel(lo, hi, cfg->run.threads, run_rep, c, err);
	pr_exp_ticker_destroy(&c->tick);
	if (rc == PR_OK)
		rc = write_mse(dir, c, lo, hi, err);
	if (rc == PR_OK)
		rc = write_map(dir, c, lo, hi, err);
done:
	pr_sim_free(sim);
	free(xtr);
	free(ytr);
	free(xte);
	free(yte);
	free(grid);
	free(c->mse);
	free(c->pred);
	free(c);
	return rc;
}

/* ---- summary ---- */

typedef struct {
	int sweep;
	long value;
	int n;
	double sum, ss;
} group;

static int find_group(group *g, int *ng, int sweep, long value)
{
	int i;

	for (i = 0; i < *ng; ++i)
		if (g[i].sweep == sweep && g[i].value == value)
			return i;
	if (*ng == NSWEEPS * PR_LIST_MAX)
		return -1;
	memset(&g[*ng], 0, sizeof g[*ng]);
	g[*ng].sweep = sweep;
	g[*ng].value = value;
	return (*ng)++;
}

/* Accumulate exp1_mse.csv into groups (sweep, value), in order of first
 * appearance: pass 0 sums, pass 1 squared deviations from the means. */
static int accumulate(const pr_exp_table *t, int pass, group *g, int *ng, char *err)
{
	int col[NSWEEPS], csweep, cmse, i;
	long r;

	for (i = 0; i < NSWEEPS; ++i)
		if ((col[i] = pr_exp_table_col(t, sweep_name[i], err)) < 0)
			return col[i];
	if ((csweep = pr_exp_table_col(t, "sweep", err)) < 0)
		return csweep;
	if ((cmse = pr_exp_table_col(t, "mse", err)) < 0)
		return cmse;
	for (r = 0; r < pr_exp_table_nrows(t); ++r) {
		const char *s = pr_exp_table_str(t, r, csweep);
		long value;
		double mse;
		int sw, k, rc;
		for (sw = 0; sw < NSWEEPS && strcmp(s, sweep_name[sw]) != 0; ++sw)
			;
		if (sw == NSWEEPS)
			return pr_err(err, PR_EIO, "%s:%ld: column 'sweep': '%.40s' is not n_min, trees or cuts",
			              pr_exp_table_path(t), pr_exp_table_line(t, r), s);
		if ((rc = pr_exp_table_int(t, r, col[sw], 1, PR_KEY_COUNT_MAX, &value, err)) ||
		    (rc = pr_exp_table_num(t, r, cmse, &mse, err)))
			return rc;
		if ((k = find_group(g, ng, sw, value)) < 0)
			return pr_err(err, PR_EIO, "%s: more than %d settings", pr_exp_table_path(t),
			              NSWEEPS * PR_LIST_MAX);
		if (pass == 0) {
			g[k].n++;
			g[k].sum += mse;
		} else {
			double d = mse - g[k].sum / g[k].n;
			g[k].ss += d * d;
		}
	}
	return PR_OK;
}

int pr_exp1_summarize(const pr_config *cfg, const char *dir, char *err)
{
	char path[PR_PATHLEN];
	pr_exp_table *t = NULL;
	group g[NSWEEPS * PR_LIST_MAX];
	int ng = 0, i, rc;
	pr_csvw *w;

	(void)cfg;
	snprintf(path, sizeof path, "%s/exp1_mse.csv", dir);
	if ((rc = pr_exp_table_read(path, &t, err)))
		return rc;
	rc = accumulate(t, 0, g, &ng, err);
	if (rc == PR_OK)
		rc = accumulate(t, 1, g, &ng, err);
	pr_exp_table_free(t);
	if (rc)
		return rc;
	if (!(w = pr_exp_csv_open(err, "%s/exp1_summary.csv", dir)))
		return PR_EIO;
	pr_csvw_header(w, "sweep,value,mean_mse,std_mse,forests");
	for (i = 0; i < ng; ++i) {
		pr_csvw_str(w, sweep_name[g[i].sweep]);
		pr_csvw_int(w, g[i].value);
		pr_csvw_num(w, g[i].sum / g[i].n);
		pr_csvw_num(w, g[i].n > 1 ? sqrt(g[i].ss / (g[i].n - 1)) : 0.0);
		pr_csvw_int(w, g[i].n);
		pr_csvw_endrow(w);
	}
	return pr_csvw_close(w, err);
}
