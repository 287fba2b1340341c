/* sim.c — the pool simulator's public face (thesis 7.1–7.4): options, the
 * simulator object, pr_sim_shoot dispatching to one of the two time-advance
 * schemes (sim_event.c, sim_stepped.c), reward, start states and scripted
 * shots. What both schemes share lies below them in sim_core.c. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sim_priv.h"

void pr_sim_table_init(pr_table *t)
{
	t->length = 1.0;
	t->width = 0.5;
	t->ball_radius = 0.015;
	t->pocket_radius = 0.03;
	t->restitution = 0.8;
	t->friction = 0.25;
	t->friction_law = 0; /* the registry's first law, the thesis's */
	t->deceleration = 0.0625; /* the stopping distance of c = 0.25 at 0.5 m/s: a = c v / 2 */
	t->mu_slide = 0.2;
	t->mu_roll = 0.01;
	t->stop_speed = 0.002;
	t->balls = 2;
	t->reward_balls = 1;
}

void pr_sim_opts_init(pr_sim_opts *o)
{
	o->mode = PR_SIM_EVENT;
	o->dt = 0.001;
	o->max_time = 120.0;
	o->max_events = 10000;
	o->max_speed = 10.0;
	o->trace_dt = 0.01;
}

void pr_sim_reward_opts_init(pr_reward_opts *o)
{
	memset(o, 0, sizeof *o);
	o->ntargets = 2;
	o->targets[0] = 2;
	o->targets[1] = 5;
	o->miss_penalty = 10.0;
	o->scratch_penalty = 0.0;
}

void pr_sim_start_opts_init(pr_start_opts *o)
{
	/* Experiments 1 and 2 (thesis 7.3.1, 7.4.1); obstacles anywhere on the default table. */
	const double cue[4] = {-0.25, -0.25, 0.0, 0.0};
	const double reward[4] = {0.05, 0.45, -0.2, 0.2};
	const double obstacle[4] = {-0.485, 0.485, -0.235, 0.235};

	memcpy(o->cue_box, cue, sizeof cue);
	memcpy(o->reward_box, reward, sizeof reward);
	memcpy(o->obstacle_box, obstacle, sizeof obstacle);
	o->max_tries = 1000;
}

void pr_sim_expert_opts_init(pr_expert_opts *o)
{
	o->arrival_speed = 0.05;
	o->aim = PR_GHOST_AIM_CENTRE;
	o->aim_speed = 0.4;
}

static int check_table(const pr_table *t, const pr_sim_opts *o, char *err)
{
	int rc;

	if (!(t->length > 0) || !(t->width > 0) || !(t->ball_radius > 0) || !(t->pocket_radius > 0))
		return pr_err(err, PR_EINVAL, "table: length, width and radii must be > 0");
	/* contact times solve |d|^2 = (2R)^2: a smaller R squares to 0 and balls pass through */
	if (!(t->ball_radius >= 1e-100))
		return pr_err(err, PR_EINVAL, "table.ball_radius: must be >= 1e-100 (got %g)", t->ball_radius);
	if (!(2 * t->ball_radius < t->width) || !(2 * t->ball_radius < t->length))
		return pr_err(err, PR_EINVAL, "table.ball_radius: the ball does not fit on the table");
	if (!(t->restitution >= 0 && t->restitution <= 1))
		return pr_err(err, PR_EINVAL, "table.restitution: must be in [0,1] (got %g)", t->restitution);
	if ((rc = pr_sim_law_check_all(t, o, err)))
		return rc;
	if (!(t->stop_speed > 0) || !isfinite(t->stop_speed))
		return pr_err(err, PR_EINVAL, "table.stop_speed: must be > 0 (got %g)", t->stop_speed);
	if (t->reward_balls < 0 || t->reward_balls >= PR_SIM_MAX_BALLS)
		return pr_err(err, PR_EINVAL, "table.reward_balls: out of range (got %d)", t->reward_balls);
	if (o->mode != PR_SIM_EVENT && o->mode != PR_SIM_STEPPED)
		return pr_err(err, PR_EINVAL, "sim.mode: unknown mode %d", o->mode);
	if (!(o->dt > 0) || !(o->max_time > 0) || !isfinite(o->max_time) || !(o->trace_dt > 0))
		return pr_err(err, PR_EINVAL, "sim: dt, max_time and trace_dt must be > 0");
	if (o->max_events < 1)
		return pr_err(err, PR_EINVAL, "sim.max_events: must be >= 1 (got %ld)", o->max_events);
	if (!(o->max_speed > 0))
		return pr_err(err, PR_EINVAL, "sim.max_speed: must be > 0 (got %g)", o->max_speed);
	return PR_OK;
}

static int grow(pr_sim *s, int n, char *err)
{
	pr_sim_ball *b;
	double *f, *d;
	int *p, *q;

	if (n <= s->cap)
		return PR_OK;
	b = realloc(s->b, (size_t)n * sizeof *b);
	if (b)
		s->b = b;
	f = realloc(s->final, (size_t)n * 2 * sizeof *f);
	if (f)
		s->final = f;
	p = realloc(s->pocket, (size_t)n * sizeof *p);
	if (p)
		s->pocket = p;
	q = realloc(s->idx, (size_t)n * sizeof *q);
	if (q)
		s->idx = q;
	d = realloc(s->scr, (size_t)n * 2 * sizeof *d);
	if (d)
		s->scr = d;
	if (!b || !f || !p || !q || !d)
		return pr_err(err, PR_ENOMEM, "simulator: out of memory for %d balls", n);
	s->cap = n;
	return PR_OK;
}

pr_sim *pr_sim_new(const pr_table *t, const pr_sim_opts *o, char *err)
{
	pr_sim *s;
	int i;

	if (check_table(t, o, err))
		return NULL;
	s = calloc(1, sizeof *s);
	if (!s) {
		pr_err(err, PR_ENOMEM, "simulator: out of memory");
		return NULL;
	}
	s->law = pr_sim_law_get(t->friction_law);
	s->t = *t;
	s->o = *o;
	s->hx = t->length / 2 - t->ball_radius;
	s->hy = t->width / 2 - t->ball_radius;
	for (i = 0; i < PR_SIM_POCKETS; ++i) {
		double xy[2];
		pr_sim_pocket_xy(t, i, xy);
		s->px[i] = xy[0];
		s->py[i] = xy[1];
	}
	if (grow(s, t->balls > 2 && t->balls <= PR_SIM_MAX_BALLS ? t->balls : 2, err)) {
		pr_sim_free(s);
		return NULL;
	}
	return s;
}

void pr_sim_free(pr_sim *s)
{
	if (!s)
		return;
	free(s->b);
	free(s->final);
	free(s->pocket);
	free(s->idx);
	free(s->scr);
	free(s);
}

int pr_sim_shoot(pr_sim *s, const double *state, int n, const double a[2], pr_shot *res,
                 pr_sim_trace *tr, char *err)
{
	double sp;
	int i, rc;

	if (n < 1 + s->t.reward_balls)
		return pr_err(err, PR_EINVAL, "%d balls: need the cue ball and %d reward ball(s)", n,
		              s->t.reward_balls);
	if ((rc = pr_sim_check_state(&s->t, state, n, err)) || (rc = pr_sim_check_action(&s->o, a, err)))
		return rc;
	if ((rc = grow(s, n, err)))
		return rc;
	for (i = 0; i < n; ++i) {
		pr_sim_ball *b = &s->b[i];
		b->x = state[2 * i];
		b->y = state[2 * i + 1];
		b->ux = b->uy = b->sp = b->tr = 0;
		b->wx = b->wy = 0; /* a stun shot: no ball spins at the start */
		b->st = PR_BALL_REST;
		b->etype = PR_EV_NONE;
		b->et = HUGE_VAL;
		b->eother = -1;
		s->pocket[i] = -1;
	}
	sp = hypot(a[0], a[1]);
	if (sp >= s->t.stop_speed) { /* slower balls do not move at all */
		s->b[0].ux = a[0];
		s->b[0].uy = a[1];
		s->b[0].sp = sp;
		s->b[0].st = PR_BALL_MOVING;
	}
	if (tr)
		tr->n = 0;
	rc = s->o.mode == PR_SIM_EVENT ? pr_sim_run_event(s, n, res, tr, err)
	                               : pr_sim_run_stepped(s, n, res, tr, err);
	if (rc)
		return rc;
	res->nballs = n;
	res->final = s->final;
	res->pocket = s->pocket;
	return PR_OK;
}

double pr_sim_reward(const pr_table *t, const pr_reward_opts *o, const pr_shot *r)
{
	int b = t->reward_balls < r->nballs - 1 ? t->reward_balls : r->nballs - 1;
	double best = HUGE_VAL, ret;
	int i, j, in_target = 0;

	/* eq. 7.7: minimum over reward balls i and target pockets j */
	for (i = 1; i <= b; ++i)
		for (j = 0; j < o->ntargets; ++j) {
			double p[2];
			pr_sim_pocket_xy(t, o->targets[j], p);
			if (r->pocket[i] == o->targets[j])
				in_target = 1;
			best = fmin(best, hypot(r->final[2 * i] - p[0], r->final[2 * i + 1] - p[1]));
		}
	ret = in_target || b < 1 || o->ntargets < 1 ? 0.0 : -best;
	if (!r->hit && b >= 1)
		ret -= o->miss_penalty * r->min_gap;
	if (r->pocket[0] >= 0)
		ret -= o->scratch_penalty;
	return ret;
}

static double draw(gsl_rng *rng, double lo, double hi)
{
	return lo + (hi - lo) * gsl_rng_uniform(rng);
}

int pr_sim_sample_start(const pr_table *t, const pr_start_opts *o, int n, gsl_rng *rng,
                        double *st, char *err)
{
	char why[PR_ERRLEN] = "";
	int k, i;

	if (n < 1 || n > PR_SIM_MAX_BALLS)
		return pr_err(err, PR_EINVAL, "%d balls: must be 1 to %d", n, PR_SIM_MAX_BALLS);
	/* eq. 7.2, redrawn as a whole while the balls overlap or sit in a pocket */
	for (k = 0; k < o->max_tries; ++k) {
		for (i = 0; i < n; ++i) {
			const double *box = i == 0 ? o->cue_box
			                  : i <= t->reward_balls ? o->reward_box : o->obstacle_box;
			st[2 * i] = draw(rng, box[0], box[1]);
			st[2 * i + 1] = draw(rng, box[2], box[3]);
		}
		if (pr_sim_check_state(t, st, n, why) == PR_OK)
			return PR_OK;
	}
	return pr_err(err, PR_EINVAL, "start state: no valid draw of %d balls in %d tries (last: %s)",
	              n, o->max_tries, why);
}

int pr_sim_aim_action(const pr_expert_opts *e, const double *st, double a[2], char *err)
{
	double dx = st[2] - st[0], dy = st[3] - st[1], d = hypot(dx, dy);

	if (!(d > 0))
		return pr_err(err, PR_EINVAL, "aim shot: cue and reward ball coincide");
	a[0] = e->aim_speed * dx / d;
	a[1] = e->aim_speed * dy / d;
	return PR_OK;
}

int pr_sim_ghost_action(const pr_table *t, const pr_sim_opts *o, const pr_reward_opts *ro,
                        const pr_expert_opts *e, const double *st, double a[2],
                        pr_sim_ghost *geom, char *err)
{
	double c[2] = {st[0], st[1]}, r[2] = {st[2], st[3]};
	double best = HUGE_VAL, p[2] = {0, 0}, u[2], g[2], dir[2], sr, sc, cosc, vc, v0;
	double entry[2];
	const pr_sim_law *law;
	int j, rc, target = -1;

	if (ro->ntargets < 1)
		return pr_err(err, PR_EINVAL, "ghost ball: no target pockets");
	/* the target pocket nearest the reward ball */
	for (j = 0; j < ro->ntargets; ++j) {
		double q[2], d;
		pr_sim_pocket_xy(t, ro->targets[j], q);
		d = hypot(q[0] - r[0], q[1] - r[1]);
		if (d < best) {
			best = d;
			target = ro->targets[j];
			p[0] = q[0];
			p[1] = q[1];
		}
	}
	/* aim at its centre, or at its corridor entry (thesis Fig. 7.5's caption) */
	rc = pr_sim_pocket_entry(t, target, entry, e->aim == PR_GHOST_AIM_CORRIDOR ? err : NULL);
	if (e->aim == PR_GHOST_AIM_CORRIDOR) {
		if (rc)
			return rc;
		p[0] = entry[0];
		p[1] = entry[1];
	}
	sr = hypot(p[0] - r[0], p[1] - r[1]);
	if (!(sr > 0))
		return pr_err(err, PR_EINVAL, "ghost ball: the reward ball already sits at the aim point");
	u[0] = (p[0] - r[0]) / sr;
	u[1] = (p[1] - r[1]) / sr;
	g[0] = r[0] - 2 * t->ball_radius * u[0];
	g[1] = r[1] - 2 * t->ball_radius * u[1];
	sc = hypot(g[0] - c[0], g[1] - c[1]);
	if (!(sc > 0))
		return pr_err(err, PR_EINVAL, "ghost ball: the cue ball already sits at the ghost position");
	dir[0] = (g[0] - c[0]) / sc;
	dir[1] = (g[1] - c[1]) / sc;
	/* at contact the normal is u: the reward ball gets the cue speed times cos(cut) */
	cosc = dir[0] * u[0] + dir[1] * u[1];
	if (!(cosc > 0))
		return pr_err(err, PR_EINVAL, "ghost ball: cut angle %.1f deg >= 90 deg, the ghost "
		              "position cannot be reached", acos(fmax(-1, fmin(1, cosc))) * 180 / acos(-1.0));
	law = pr_sim_law_get(t->friction_law);
	if (!law)
		return pr_err(err, PR_EINVAL, "table.friction_law: unknown law %d", t->friction_law);
	vc = law->speed_for(t, e->arrival_speed, sr) / cosc;
	v0 = law->speed_for(t, vc, sc);
	if (v0 > o->max_speed)
		return pr_err(err, PR_EINVAL, "ghost ball: needs %g m/s > sim.max_speed = %g", v0, o->max_speed);
	a[0] = v0 * dir[0];
	a[1] = v0 * dir[1];
	if (geom) {
		geom->target = target;
		geom->aim[0] = p[0];
		geom->aim[1] = p[1];
		geom->entry[0] = entry[0];
		geom->entry[1] = entry[1];
		geom->ghost[0] = g[0];
		geom->ghost[1] = g[1];
		geom->dir[0] = u[0];
		geom->dir[1] = u[1];
		geom->cut = acos(fmin(1, cosc));
		geom->v_contact = vc;
		geom->v0 = v0;
	}
	return PR_OK;
}
