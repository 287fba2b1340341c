/* config.c — the parameter engine: key tables, INI loading (libinih), --set,
 * checks, writing and the key list of --help.
 *
 * The modules' keys live in the table below: section, name, type, the field
 * of pr_config they set, range and unit. Defaults come from the modules'
 * _init functions, so no table repeats a default. The experiments' keys,
 * options and defaults come from the schema (config_priv.h); this file knows
 * no experiment. Key i counts the modules' keys first, then each block's.
 * Loading reports the first bad line as "file:line: section.key: message"
 * and stops.
 */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <ini.h>

#include "common_priv.h"
#include "config_priv.h"
#include "csvio_priv.h"
#include "sim_priv.h"

#define F(field) offsetof(pr_config, field)
#define NAMELEN 64        /* a section, key or "section.key" */
#define LINE_MAX_BYTES 4096 /* a parameter file's line */
/* resource limit, refused up front: past 1e9 steps one shot runs for minutes to days */
#define MAX_STEPS_PER_SHOT 1e9

static const pr_config_key core_keys[] = {
	{"experiment", "name", PR_KEY_EXPERIMENT, F(run.name), 0, 0, 0, "",
	 "what `poolreps CONFIG` runs"},
	{"experiment", "seed", PR_KEY_ULONG, F(run.seed), 0, 4294967295.0, 0, "", "master seed"},
	{"experiment", "repetitions", PR_KEY_INT, F(run.repetitions), 1, 10000, 0, "", "independent repetitions"},
	{"experiment", "repetition", PR_KEY_INT, F(run.repetition), -1, 9999, 0, "",
	 "-1 runs all repetitions; k runs only repetition k (sweeps)"},
	{"experiment", "variant", PR_KEY_INT, F(run.variant), -1, PR_VARIANTS_MAX - 1, 0, "",
	 "-1 runs all variants; v runs only variant v: exp1 setting, exp3 policy, exp4 run (sweeps)"},
	{"experiment", "threads", PR_KEY_INT, F(run.threads), 1, 256, 0, "", "threads for repetitions"},

	{"table", "length", PR_KEY_DOUBLE, F(table.length), 0, 100, PR_KEY_OPEN_LO, "m", "long side (x)"},
	{"table", "width", PR_KEY_DOUBLE, F(table.width), 0, 100, PR_KEY_OPEN_LO, "m", "short side (y)"},
	{"table", "ball_radius", PR_KEY_DOUBLE, F(table.ball_radius), 1e-100, 1, 0, "m", "ball radius R"},
	{"table", "pocket_radius", PR_KEY_DOUBLE, F(table.pocket_radius), 0, 1, PR_KEY_OPEN_LO, "m", "pocket radius"},
	{"table", "restitution", PR_KEY_DOUBLE, F(table.restitution), 0, 1, 0, "", "cushion restitution kappa (eq. 7.4)"},
	{"table", "friction", PR_KEY_DOUBLE, F(table.friction), 0, 1000, PR_KEY_OPEN_LO, "1/s",
	 "c in v' = -c v, v(t) = v0 exp(-c t)"},
	{"table", "friction_law", PR_KEY_ENUM, F(table.friction_law), 0, 0, 0, PR_FRICTION_NAMES,
	 "how a ball slows: v' = -c v (thesis), a constant deceleration (rolling resistance) or sliding, then rolling (docs/sim.md)"},
	{"table", "deceleration", PR_KEY_DOUBLE, F(table.deceleration), 0, 100, PR_KEY_OPEN_LO, "m/s^2",
	 "a = mu_r g in |v|' = -a, |v|(t) = v0 - a t (0.0625 stops as c = 0.25 does from 0.5 m/s)"},
	{"table", "mu_slide", PR_KEY_DOUBLE, F(table.mu_slide), 0, 1, PR_KEY_OPEN_LO, "",
	 "sliding friction mu_s: a sliding ball slows at mu_s g (g = 9.81 m/s^2)"},
	{"table", "mu_roll", PR_KEY_DOUBLE, F(table.mu_roll), 0, 1, PR_KEY_OPEN_LO, "",
	 "rolling resistance mu_r, below mu_s: a rolling ball slows at mu_r g"},
	{"table", "stop_speed", PR_KEY_DOUBLE, F(table.stop_speed), 0, 10, PR_KEY_OPEN_LO, "m/s", "slower balls stop"},
	{"table", "balls", PR_KEY_INT, F(table.balls), 2, 10000, 0, "", "balls: cue + reward + obstacles"},
	{"table", "reward_balls", PR_KEY_INT, F(table.reward_balls), 1, 9999, 0, "", "reward balls b"},

	{"sim", "mode", PR_KEY_ENUM, F(sim.mode), 0, 0, 0, "event|stepped", "exact event-driven or the thesis's time steps"},
	{"sim", "dt", PR_KEY_DOUBLE, F(sim.dt), 1e-7, 0.1, 0, "s", "stepped mode: time step"},
	{"sim", "max_time", PR_KEY_DOUBLE, F(sim.max_time), 0, 1e6, PR_KEY_OPEN_LO, "s", "simulated time limit of a shot"},
	{"sim", "max_events", PR_KEY_LONG, F(sim.max_events), 1, 1e9, 0, "", "event mode: events before a shot fails"},
	{"sim", "trace_dt", PR_KEY_DOUBLE, F(sim.trace_dt), 0, 10, PR_KEY_OPEN_LO, "s", "stepped mode: trace interval (--trace)"},
	{"sim", "max_speed", PR_KEY_DOUBLE, F(sim.max_speed), 0, 1000, PR_KEY_OPEN_LO, "m/s", "faster actions are refused"},

	{"reward", "targets", PR_KEY_POCKETS, F(reward), 0, 5, 0, "", "target pocket ids, e.g. 2,5"},
	{"reward", "miss_penalty", PR_KEY_DOUBLE, F(reward.miss_penalty), 0, 1e6, 0, "",
	 "times the smallest cue-reward gap when the cue never hits a reward ball"},
	{"reward", "scratch_penalty", PR_KEY_DOUBLE, F(reward.scratch_penalty), 0, 1e6, 0, "m",
	 "subtracted when the cue ball is pocketed"},

	{"start", "cue_box", PR_KEY_BOX, F(start.cue_box), -PR_KEY_UNBOUNDED, PR_KEY_UNBOUNDED, 0, "m", "cue ball box xmin,xmax,ymin,ymax"},
	{"start", "reward_box", PR_KEY_BOX, F(start.reward_box), -PR_KEY_UNBOUNDED, PR_KEY_UNBOUNDED, 0, "m",
	 "reward ball box xmin,xmax,ymin,ymax (exp3: 0.05,0.15,-0.1,0.1)"},
	{"start", "obstacle_box", PR_KEY_BOX, F(start.obstacle_box), -PR_KEY_UNBOUNDED, PR_KEY_UNBOUNDED, 0, "m", "obstacle box xmin,xmax,ymin,ymax"},
	{"start", "max_tries", PR_KEY_INT, F(start.max_tries), 1, 1000000, 0, "", "redraws of an overlapping start"},

	{"ghost", "arrival_speed", PR_KEY_DOUBLE, F(expert.arrival_speed), 0, 10, PR_KEY_OPEN_LO, "m/s",
	 "ghost-ball expert: reward ball speed at the aim point"},
	{"ghost", "aim", PR_KEY_ENUM, F(expert.aim), 0, 0, 0, "centre|corridor",
	 "ghost-ball expert: aim at the target pocket's centre or its corridor entry"},

	{"forest", "trees", PR_KEY_INT, F(forest.trees), 1, PR_FOREST_MAX_TREES, 0, "", "M trees"},
	{"forest", "cuts", PR_KEY_INT, F(forest.cuts), 1, PR_FOREST_MAX_CUTS, 0, "", "K random tests per node"},
	{"forest", "n_min", PR_KEY_INT, F(forest.n_min), 1, PR_KEY_COUNT_MAX, 0, "", "split nodes with more samples"},
	{"forest", "n_c", PR_KEY_INT, F(forest.n_c), 1, PR_KEY_COUNT_MAX, 0, "", "smallest child a split may leave"},
	{"forest", "score", PR_KEY_ENUM, F(forest.score), 0, 0, 0, "rvr|nrvr", "split score (eq. 4.1) or its negation"},
	{"forest", "replacement", PR_KEY_ENUM, F(forest.with_replacement), 0, 0, 0, "without|with",
	 "draw the K cut dimensions with or without replacement"},
	{"forest", "outputs", PR_KEY_ENUM, F(forest.outputs), 0, 0, 0, "sum|relative",
	 "several outputs: add variance reductions (eq. 6.1) or each relative to its node variance"},

	{"value", "trees", PR_KEY_INT, F(value.trees), 1, PR_FOREST_MAX_TREES, 0, "", "value-feature forest: M"},
	{"value", "cuts", PR_KEY_INT, F(value.cuts), 1, PR_FOREST_MAX_CUTS, 0, "", "value-feature forest: K"},
	{"value", "n_min", PR_KEY_INT, F(value.n_min), 1, PR_KEY_COUNT_MAX, 0, "", "value-feature forest: n_min"},
	{"value", "n_c", PR_KEY_INT, F(value.n_c), 1, PR_KEY_COUNT_MAX, 0, "", "value-feature forest: n_c"},
	{"value", "score", PR_KEY_ENUM, F(value.score), 0, 0, 0, "rvr|nrvr", "value-feature forest score (exp3: nrvr)"},
	{"value", "replacement", PR_KEY_ENUM, F(value.with_replacement), 0, 0, 0, "without|with", "value-feature forest cut draws"},
	{"value", "outputs", PR_KEY_ENUM, F(value.outputs), 0, 0, 0, "sum|relative", "value-feature forest: several outputs"},
	{"value", "features", PR_KEY_ENUM, F(value_features), 0, 0, 0, "leaves|samples",
	 "active leaves (eq. 5.4) or active samples (eq. 5.6)"},

	{"reps", "epsilon", PR_KEY_DOUBLE, F(reps.epsilon), PR_REPS_EPS_MIN, 1e6, 0, "nats", "KL bound (eq. 3.2; sphere, rosenbrock: 1)"},
	{"reps", "ridge", PR_KEY_DOUBLE, F(reps.ridge), 0, 1e12, 0, "", "ridge on theta in the dual"},
	{"reps", "eta_min", PR_KEY_DOUBLE, F(reps.eta_min), 0, 1, PR_KEY_OPEN_LO | PR_KEY_OPEN_HI, "",
	 "eta (return standard deviations) below which the eta -> 0 limit decides if KL = epsilon is reachable"},
	{"reps", "max_iter", PR_KEY_INT, F(reps.max_iter), 1, 10000000, 0, "", "dual evaluations per solve"},
	{"reps", "solver", PR_KEY_ENUM, F(reps.solver), 0, 0, 0, "newton|nlopt|cg",
	 "dual solver: Newton with the eta -> 0 limit, NLopt's L-BFGS polished by Newton, or Newton with conjugate-gradient steps (matrix-free; same certificate)"},
	{"reps", "allow_failed", PR_KEY_INT, F(reps.allow_failed), 0, 1, 0, "",
	 "experiments: 1 records an uncertified REPS solve (status failed) and goes on; 0 fails the run"},

	{"learner", "value", PR_KEY_ENUM, F(learner.value), 0, 0, 0, "trees|nrvr|rvr|linear|quadratic|given",
	 "learner: value features (a forest scored by value.score, NRVR, RVR; [1, s]; [1, s, s s]; the caller's)"},
	{"learner", "policy", PR_KEY_ENUM, F(learner.policy_type), 0, 0, 0, "tree|linear",
	 "learner: tree-LWR policy (policy.*) or linear-Gaussian on [1, s]"},
	{"learner", "window", PR_KEY_INT, F(learner.window), 0, 10000000, 0, "",
	 "learner: latest episodes REPS and the fit reuse (0: each tell's own, uniform base weights)"},
	{"learner", "init_std", PR_KEY_DOUBLE, F(learner.init_std), 1e-100, 1e6, 0, "",
	 "learner: pi_0 = N(0, init_std^2 I)"},
	{"learner", "max_norm", PR_KEY_DOUBLE, F(learner.max_norm), 0, 1e12, 0, "",
	 "learner: actions kept within this Euclidean norm (0: no limit)"},
	{"learner", "truncation", PR_KEY_ENUM, F(learner.truncation), 0, 0, 0, "redraw|clip|corrected",
	 "learner: an action beyond max_norm is drawn again, scaled onto it, or drawn again with corrected densities"},
	{"learner", "draw", PR_KEY_ENUM, F(learner.draw), 0, 0, 0, "query|fit",
	 "learner: actions from the covariance decomposed at each context, or from the decomposition the fit kept"},

	{"policy", "target", PR_KEY_ENUM, F(policy.target), 0, 0, 0, "action|reward_state", "policy forest output"},
	{"policy", "lambda", PR_KEY_DOUBLE, F(policy.lambda), 0, 1e12, 0, "", "ridge of eq. 6.6"},
	{"policy", "min_std", PR_KEY_DOUBLE, F(policy.min_std), 1e-100, 100, 0, "m/s", "floor on action standard deviations"},
	{"policy", "trees", PR_KEY_INT, F(policy.forest.trees), 1, PR_FOREST_MAX_TREES, 0, "", "policy forest: M (exp2: 30)"},
	{"policy", "cuts", PR_KEY_INT, F(policy.forest.cuts), 1, PR_FOREST_MAX_CUTS, 0, "", "policy forest: K (exp2: 10)"},
	{"policy", "n_min", PR_KEY_INT, F(policy.forest.n_min), 1, PR_KEY_COUNT_MAX, 0, "", "policy forest: n_min"},
	{"policy", "n_c", PR_KEY_INT, F(policy.forest.n_c), 1, PR_KEY_COUNT_MAX, 0, "", "policy forest: n_c"},
	{"policy", "score", PR_KEY_ENUM, F(policy.forest.score), 0, 0, 0, "rvr|nrvr", "policy forest score"},
	{"policy", "replacement", PR_KEY_ENUM, F(policy.forest.with_replacement), 0, 0, 0, "without|with", "policy forest cut draws"},
	{"policy", "outputs", PR_KEY_ENUM, F(policy.forest.outputs), 0, 0, 0, "sum|relative",
	 "policy forest, two outputs: eq. 6.3 as printed (sum) or each relative to its variance"},
	{"policy", "cov", PR_KEY_ENUM, F(policy.cov), 0, 0, 0, "query|residual",
	 "eq. 6.8 centred on the query mean (as printed) or on each sample's own fit"},
	{"policy", "cov_center", PR_KEY_ENUM, F(policy.cov_center), 0, 0, 0, "new|old",
	 "residuals (linear weighted ML; tree-LWR eq. 6.8) around the new mean or the sampling policy's (benchmarks: old)"},
};
#define NCORE ((int)(sizeof core_keys / sizeof core_keys[0]))

/* ---- the keys of a configuration ---- */

static int nkeys(const pr_config *c)
{
	int n = NCORE, b;

	for (b = 0; b < c->nblocks; ++b)
		n += c->block[b]->nkeys;
	return n;
}

/* Key i and the address of the struct its offset is into. */
static const pr_config_key *key_at(const pr_config *c, int i, char **base)
{
	int b;

	if (i < NCORE) {
		*base = (char *)c;
		return &core_keys[i];
	}
	i -= NCORE;
	for (b = 0; b < c->nblocks; ++b) {
		if (i < c->block[b]->nkeys) {
			*base = (char *)c->opts.bytes + c->block_off[b];
			return &c->block[b]->keys[i];
		}
		i -= c->block[b]->nkeys;
	}
	return NULL;
}

static int find_key(const pr_config *c, const char *section, const char *key)
{
	int i, n = nkeys(c);
	char *base;

	for (i = 0; i < n; ++i) {
		const pr_config_key *k = key_at(c, i, &base);
		if (strcmp(k->section, section) == 0 && strcmp(k->key, key) == 0)
			return i;
	}
	return -1;
}

/* The key "section.key", or -1. */
static int find_dotted(const pr_config *c, const char *name)
{
	const char *dot = strchr(name, '.');
	char section[NAMELEN];

	if (!dot || (size_t)(dot - name) >= sizeof section)
		return -1;
	memcpy(section, name, (size_t)(dot - name));
	section[dot - name] = '\0';
	return find_key(c, section, dot + 1);
}

static int known_section(const pr_config *c, const char *section)
{
	int i, n = nkeys(c);
	char *base;

	for (i = 0; i < n; ++i)
		if (strcmp(key_at(c, i, &base)->section, section) == 0)
			return 1;
	return 0;
}

/* The schema's experiment called name (out filled), or 0. */
static int find_experiment(const pr_config *c, const char *name, pr_config_exp *out)
{
	int i;

	for (i = 0; c->schema && c->schema(i, out); ++i)
		if (strcmp(out->name, name) == 0)
			return 1;
	return 0;
}

/* The schema's experiment names as "a|b|c" into buf. */
static const char *experiment_names(const pr_config *c, char *buf, size_t n)
{
	pr_config_exp e;
	size_t len = 0;
	int i;

	buf[0] = '\0';
	for (i = 0; c->schema && c->schema(i, &e); ++i)
		if (len < n)
			len += (size_t)snprintf(buf + len, n - len, "%s%s", i ? "|" : "", e.name);
	return buf;
}

/* ---- defaults ---- */

void pr_run_opts_init(pr_run_opts *o)
{
	memset(o, 0, sizeof *o);
	snprintf(o->name, sizeof o->name, "figures");
	o->seed = 1;
	o->repetitions = 5;
	o->repetition = -1;
	o->variant = -1;
	o->threads = 1;
}

/* The modules' defaults and every block of the schema at its own defaults
 * (no experiment's overrides yet). A block that does not fit is dropped. */
static void base_init(pr_config *c, pr_config_schema schema)
{
	pr_config_exp e;
	size_t used = 0;
	int i, b, n = NCORE;

	memset(c, 0, sizeof *c);
	pr_run_opts_init(&c->run);
	pr_sim_table_init(&c->table);
	pr_sim_opts_init(&c->sim);
	pr_sim_reward_opts_init(&c->reward);
	pr_sim_start_opts_init(&c->start);
	pr_sim_expert_opts_init(&c->expert);
	pr_forest_opts_init(&c->forest);
	pr_reps_opts_init(&c->reps);
	pr_policy_opts_init(&c->policy);
	/* the value forests of thesis 7.5.1, as the learner's own defaults */
	pr_learner_opts_init(&c->learner);
	c->value = c->learner.value_forest;
	c->value_features = c->learner.value_features;
	c->schema = schema;
	for (i = 0; schema && schema(i, &e); ++i) {
		const size_t align = sizeof(max_align_t);
		if (!e.block)
			continue;
		for (b = 0; b < c->nblocks && c->block[b] != e.block; ++b)
			;
		if (b < c->nblocks)
			continue;
		if (c->nblocks == PR_CONFIG_MAXBLOCKS || n + e.block->nkeys > PR_CONFIG_MAXKEYS ||
		    e.block->size > sizeof c->opts.bytes - used) {
			c->dropped++;
			continue;
		}
		c->block[c->nblocks] = e.block;
		c->block_off[c->nblocks++] = used;
		e.block->init(c->opts.bytes + used);
		used += (e.block->size + align - 1) / align * align;
		if (used > sizeof c->opts.bytes)
			used = sizeof c->opts.bytes;
		n += e.block->nkeys;
	}
}

const void *pr_config_opts(const pr_config *c, const pr_config_block *b)
{
	int i;

	for (i = 0; i < c->nblocks; ++i)
		if (c->block[i] == b)
			return c->opts.bytes + c->block_off[i];
	return NULL;
}

static int set_value_raw(pr_config *c, int i, const char *value, const char *where, char *err);
static char *value_text(const pr_config *c, int i);

/* Experiment name's defaults on top of c. */
static int apply_defaults(pr_config *c, const char *name, char *err)
{
	pr_config_exp e;
	const pr_config_default *d;
	int rc;

	if (!find_experiment(c, name, &e) || !e.defaults)
		return PR_OK;
	for (d = e.defaults; d->key; ++d) {
		int i = find_dotted(c, d->key);
		if (i < 0)
			return pr_err(err, PR_EINVAL, "internal: default of %s: %s: unknown key", name, d->key);
		if ((rc = set_value_raw(c, i, d->value, "", err)))
			return rc;
	}
	return PR_OK;
}

void pr_config_init(pr_config *c, pr_config_schema schema)
{
	char err[PR_ERRLEN];

	base_init(c, schema);
	apply_defaults(c, c->run.name, err);
}

/* Some experiment overrides the default of key i. */
static int follows_name(const pr_config *c, int i)
{
	pr_config_exp e;
	const pr_config_default *d;
	char name[2 * NAMELEN + 1], *base;
	const pr_config_key *k = key_at(c, i, &base);
	int j;

	snprintf(name, sizeof name, "%s.%s", k->section, k->key);
	for (j = 0; c->schema && c->schema(j, &e); ++j)
		for (d = e.defaults; d && d->key; ++d)
			if (strcmp(d->key, name) == 0)
				return 1;
	return 0;
}

/* After experiment.name changed: every name-dependent key that was not set
 * explicitly (key_line 0) takes that experiment's default. */
static int experiment_defaults(pr_config *c, char *err)
{
	pr_config d;
	int i, n = nkeys(c), rc;

	base_init(&d, c->schema);
	rc = apply_defaults(&d, c->run.name, err);
	for (i = 0; rc == PR_OK && i < n; ++i)
		if (c->key_line[i] == 0 && follows_name(c, i)) {
			char *v = value_text(&d, i);
			rc = v ? set_value_raw(c, i, v, "", err) : pr_err(err, PR_ENOMEM, "out of memory");
			free(v);
		}
	return rc;
}

/* ---- values ---- */

/* Index of value in "a|b|c", or -1. */
static int choice_index(const char *choices, const char *value)
{
	const char *p = choices;
	size_t n = strlen(value);
	int i = 0;

	while (*p) {
		const char *q = strchr(p, '|');
		size_t len = q ? (size_t)(q - p) : strlen(p);
		if (len == n && strncmp(p, value, n) == 0)
			return i;
		if (!q)
			break;
		p = q + 1;
		++i;
	}
	return -1;
}

static int in_range(const pr_config_key *k, double v)
{
	return (k->open & PR_KEY_OPEN_LO ? v > k->lo : v >= k->lo) &&
	       (k->open & PR_KEY_OPEN_HI ? v < k->hi : v <= k->hi);
}

/* A bad value's error, prefixed "WHERE section.key: " as every key's is. The
 * buffer holds what pr_err's does, so a long message is cut where it was. */
#if defined(__GNUC__)
__attribute__((format(printf, 4, 5)))
#endif
static int key_err(const pr_config_key *k, const char *where, char *err, const char *fmt, ...)
{
	char msg[PATH_MAX + PR_ERRLEN];
	va_list ap;

	va_start(ap, fmt);
	vsnprintf(msg, sizeof msg, fmt, ap);
	va_end(ap);
	return pr_err(err, PR_EINVAL, "%s%s.%s: %s", where, k->section, k->key, msg);
}

static int range_err(const pr_config_key *k, const char *where, const char *value, char *err)
{
	char lo[40], hi[40];

	pr_csv_format_double(k->lo, lo, sizeof lo);
	pr_csv_format_double(k->hi, hi, sizeof hi);
	return key_err(k, where, err, "%s out of range: must be %s %s and %s %s%s", value,
	               k->open & PR_KEY_OPEN_LO ? ">" : ">=", lo,
	               k->open & PR_KEY_OPEN_HI ? "<" : "<=", hi,
	               k->type == PR_KEY_ILIST ? ", whole numbers" : "");
}

/* Split a comma list of finite numbers into v (capacity cap); returns count or -1. */
static int parse_numbers(const char *s, double *v, int cap)
{
	char buf[64];
	int n = 0;

	while (1) {
		const char *q = strchr(s, ',');
		size_t len = q ? (size_t)(q - s) : strlen(s);
		if (len >= sizeof buf || n >= cap)
			return -1;
		memcpy(buf, s, len);
		buf[len] = '\0';
		if (pr_csv_parse_double(buf, &v[n++]))
			return -1;
		if (!q)
			return n;
		s = q + 1;
	}
}

/* Whether list[i] repeats an earlier entry: a list names each pocket or
 * setting once (a repeated setting would run twice under one name). */
static int listed_before(const double *list, int i)
{
	int j;

	for (j = 0; j < i; ++j)
		if (list[j] == list[i])
			return 1;
	return 0;
}

static char *trim(char *s)
{
	char *e;

	while (*s == ' ' || *s == '\t')
		++s;
	e = s + strlen(s);
	while (e > s && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r' || e[-1] == '\n'))
		*--e = '\0';
	return s;
}

/* Callers mark the key in key_line first, so a name change keeps it. */
static int set_value(pr_config *c, int i, const char *value, const char *where, char *err)
{
	char *base;
	int rc = set_value_raw(c, i, value, where, err);

	if (rc == PR_OK && key_at(c, i, &base)->type == PR_KEY_EXPERIMENT)
		rc = experiment_defaults(c, err);
	return rc;
}

/* An integer key (int, long or unsigned long) from value. */
static int set_integer(const pr_config_key *k, char *base, const char *value, const char *where,
                       char *err)
{
	char *end;
	long long x;

	errno = 0;
	x = strtoll(value, &end, 10);
	while (*end == ' ' || *end == '\t')
		++end;
	if (end == value || *end || errno == ERANGE)
		return key_err(k, where, err, "not an integer: '%.40s'", value);
	if (!in_range(k, (double)x))
		return range_err(k, where, value, err);
	if (k->type == PR_KEY_INT)
		*(int *)base = (int)x;
	else if (k->type == PR_KEY_LONG)
		*(long *)base = (long)x;
	else
		*(unsigned long *)base = (unsigned long)x;
	return PR_OK;
}

/* A comma list of distinct names of the key's choices. */
static int set_names(const pr_config_key *k, char *base, const char *value, const char *where,
                     char *err)
{
	char item[NAMELEN];
	const char *p = value;
	unsigned seen = 0;

	if (strlen(value) >= PR_KEY_NAMES_LEN)
		return key_err(k, where, err, "list too long");
	do {
		size_t len = strcspn(p, ",");
		int choice;
		snprintf(item, sizeof item, "%.*s", (int)(len < NAMELEN - 1 ? len : NAMELEN - 1), p);
		if ((choice = choice_index(k->unit, trim(item))) < 0)
			return key_err(k, where, err, "'%s' is not one of %s", trim(item), k->unit);
		if (seen & 1u << choice)
			return key_err(k, where, err, "'%s' listed twice", trim(item));
		seen |= 1u << choice;
		p += len;
	} while (*p++ == ',');
	snprintf(base, PR_KEY_NAMES_LEN, "%s", value);
	return PR_OK;
}

/* The target pockets: 1 to 6 distinct ids 0..5. */
static int set_pockets(const pr_config_key *k, char *base, const char *value, const char *where,
                       char *err)
{
	pr_reward_opts *r = (pr_reward_opts *)base;
	double list[PR_LIST_MAX];
	int i, n = parse_numbers(value, list, PR_SIM_POCKETS);

	if (n < 1)
		return key_err(k, where, err, "expected 1 to 6 pocket ids, got '%.40s'", value);
	for (i = 0; i < n; ++i) {
		if (list[i] != floor(list[i]) || list[i] < 0 || list[i] > 5)
			return key_err(k, where, err, "pocket id must be 0..5, got '%.40s'", value);
		if (listed_before(list, i))
			return key_err(k, where, err, "pocket %d listed twice", (int)list[i]);
		r->targets[i] = (int)list[i];
	}
	r->ntargets = n;
	return PR_OK;
}

/* A comma list of 1 to PR_LIST_MAX distinct numbers in the key's range
 * (integers for PR_KEY_ILIST). */
static int set_list(const pr_config_key *k, char *base, const char *value, const char *where,
                    char *err)
{
	pr_list *l = (pr_list *)base;
	double list[PR_LIST_MAX];
	int i, n = parse_numbers(value, list, PR_LIST_MAX);

	if (n < 1)
		return key_err(k, where, err, "expected a comma list of 1 to %d numbers, "
		               "got '%.40s'", PR_LIST_MAX, value);
	for (i = 0; i < n; ++i) {
		if (!in_range(k, list[i]) || (k->type == PR_KEY_ILIST && list[i] != floor(list[i])))
			return range_err(k, where, value, err);
		if (listed_before(list, i))
			return key_err(k, where, err, "%.15g listed twice", list[i]);
	}
	l->n = n;
	memcpy(l->v, list, (size_t)n * sizeof *list);
	return PR_OK;
}

static int set_value_raw(pr_config *c, int ki, const char *value, const char *where, char *err)
{
	char *base, names[PR_ERRLEN];
	const pr_config_key *k = key_at(c, ki, &base);
	double v, list[PR_LIST_MAX];
	int i, n;

	base += k->off;
	switch (k->type) {
	case PR_KEY_DOUBLE:
		if (pr_csv_parse_double(value, &v))
			return key_err(k, where, err, "not a finite number: '%.40s'", value);
		if (!in_range(k, v))
			return range_err(k, where, value, err);
		*(double *)base = v;
		return PR_OK;
	case PR_KEY_INT:
	case PR_KEY_LONG:
	case PR_KEY_ULONG:
		return set_integer(k, base, value, where, err);
	case PR_KEY_ENUM:
		i = choice_index(k->unit, value);
		if (i < 0)
			return key_err(k, where, err, "'%.40s' is not one of %s", value, k->unit);
		*(int *)base = i;
		return PR_OK;
	case PR_KEY_EXPERIMENT: {
		pr_config_exp e;
		if (!find_experiment(c, value, &e))
			return key_err(k, where, err, "'%.40s' is not one of %s", value,
			               experiment_names(c, names, sizeof names));
		snprintf(base, sizeof c->run.name, "%s", value);
		return PR_OK;
	}
	case PR_KEY_NAMES:
		return set_names(k, base, value, where, err);
	case PR_KEY_POCKETS:
		return set_pockets(k, base, value, where, err);
	case PR_KEY_BOX:
		n = parse_numbers(value, list, 4);
		if (n != 4 || list[0] > list[1] || list[2] > list[3])
			return key_err(k, where, err, "expected xmin,xmax,ymin,ymax with "
			               "xmin <= xmax and ymin <= ymax, got '%.60s'", value);
		memcpy(base, list, 4 * sizeof *list);
		return PR_OK;
	case PR_KEY_LIST:
	case PR_KEY_ILIST:
		return set_list(k, base, value, where, err);
	}
	return key_err(k, where, err, "unsupported key type");
}

/* ---- INI loading ---- */

typedef struct {
	pr_config *c;
	FILE *fp;
	const char *path;
	long line;
	int status;
	char *err;
	char section[NAMELEN];
	char seen[PR_CONFIG_MAXKEYS];
	long seen_line[PR_CONFIG_MAXKEYS];
	char buf[LINE_MAX_BYTES + 4];    /* one line: above ini_max_line, the limit checked */
} loader;

/* One physical line per call, so inih's line numbers and ours agree; also
 * catches long lines, NUL bytes and unknown sections at their line. Bytes are
 * read one by one into a buffer of the line limit, so no input (/dev/zero, an
 * endless line) makes it grow. */
static char *read_line(char *str, int num, void *stream)
{
	loader *L = stream;
	size_t len = 0;
	int ch = EOF;
	char *s;

	if (L->status)
		return NULL;
	while (len + 1 < sizeof L->buf && (ch = getc(L->fp)) != EOF) {
		if (ch == '\0') {
			L->status = pr_err(L->err, PR_EINVAL, "%s:%ld: NUL byte in parameter file",
			                   L->path, L->line + 1);
			return NULL;
		}
		L->buf[len++] = (char)ch;
		if (ch == '\n')
			break;
	}
	L->buf[len] = '\0';
	if (len == 0)
		return NULL;
	L->line++;
	/* the limit counts the bytes before the line end ("\n" or "\r\n") */
	if (len && L->buf[len - 1] == '\n')
		L->buf[--len] = '\0';
	if (len && L->buf[len - 1] == '\r')
		L->buf[--len] = '\0';
	if (len > (size_t)num - 2 || (ch != '\n' && ch != EOF)) {
		L->status = pr_err(L->err, PR_EINVAL, "%s:%ld: line longer than %d bytes",
		                   L->path, L->line, num - 2);
		return NULL;
	}
	/* binary junk, and a control character would break the one-line message */
	for (s = L->buf; *s; ++s) {
		if (((unsigned char)*s < 0x20 && *s != '\t') || *s == 0x7f) {
			L->status = pr_err(L->err, PR_EINVAL, "%s:%ld: control character 0x%02x in parameter file",
			                   L->path, L->line, (unsigned)(unsigned char)*s);
			return NULL;
		}
	}
	s = trim(L->buf);
	if (*s == '[') {
		char *e = strchr(s, ']');
		if (e) {
			size_t n = (size_t)(e - s - 1);
			char name[64];
			if (n >= sizeof name) {
				L->status = pr_err(L->err, PR_EINVAL, "%s:%ld: section name too long",
				                   L->path, L->line);
				return NULL;
			}
			memcpy(name, s + 1, n);
			name[n] = '\0';
			/* after the ']' only blanks and a ';' comment: junk is not dropped silently */
			e = trim(e + 1);
			if (*e && *e != ';') {
				L->status = pr_err(L->err, PR_EINVAL, "%s:%ld: [%s]: unexpected text after the ']'",
				                   L->path, L->line, trim(name));
				return NULL;
			}
			if (!known_section(L->c, trim(name))) {
				L->status = pr_err(L->err, PR_EINVAL, "%s:%ld: [%s]: unknown section",
				                   L->path, L->line, trim(name));
				return NULL;
			}
		}
	}
	memcpy(str, L->buf, len + 1);
	str[len] = '\n';
	str[len + 1] = '\0';
	return str;
}

static int on_pair(void *user, const char *section_raw, const char *name, const char *value)
{
	loader *L = user;
	char where[PR_WHERE_LEN], buf[NAMELEN];
	const char *section;
	int i;

	if (L->status)
		return 0;
	/* inih keeps the blanks of "[ table ]"; read_line accepted it trimmed */
	snprintf(buf, sizeof buf, "%s", section_raw);
	section = trim(buf);
	snprintf(where, sizeof where, "%s:%ld: ", L->path, L->line);
	if (!*section) {
		L->status = pr_err(L->err, PR_EINVAL, "%s%s: key outside any [section]", where, name);
		return 0;
	}
	i = find_key(L->c, section, name);
	if (i < 0) {
		L->status = pr_err(L->err, PR_EINVAL, "%s%s.%s: unknown key", where, section, name);
		return 0;
	}
	if (L->seen[i]) {
		L->status = pr_err(L->err, PR_EINVAL, "%s%s.%s: duplicate key (first set on line %ld)",
		                   where, section, name, L->seen_line[i]);
		return 0;
	}
	L->seen[i] = 1;
	L->seen_line[i] = L->line;
	L->c->key_line[i] = L->line > INT_MAX ? INT_MAX : (int)L->line;
	L->status = set_value(L->c, i, value, where, L->err);
	return L->status == PR_OK;
}

int pr_config_load(pr_config *c, const char *path, char *err)
{
	loader L;
	struct stat st;
	int rc;

	memset(&L, 0, sizeof L);
	L.c = c;
	L.path = path;
	L.err = err;
	L.fp = fopen(path, "rb");
	if (!L.fp)
		return pr_err(err, pr_errno_status(), "%s: cannot open parameter file: %s", path, strerror(errno));
	if (fstat(fileno(L.fp), &st) == 0 && S_ISDIR(st.st_mode)) {
		fclose(L.fp);
		return pr_err(err, PR_EIO, "%s: is a directory, not a parameter file", path);
	}
	ini_allow_multiline = false;
	ini_stop_on_first_error = true;
	/* Debian's libinih: a stack line buffer of ini_max_line bytes; the heap
	 * buffer without realloc would stay at 200 bytes */
	ini_use_stack = true;
	ini_allow_realloc = false;
	ini_max_line = LINE_MAX_BYTES;
	rc = ini_parse_stream(read_line, &L, on_pair, &L);
	if (!L.status && ferror(L.fp))
		L.status = pr_err(err, PR_EIO, "%s: read error", path);
	fclose(L.fp);
	if (L.status)
		return L.status;
	if (rc == -2)
		return pr_err(err, PR_ENOMEM, "%s: out of memory", path);
	if (rc > 0)
		return pr_err(err, PR_EINVAL, "%s:%d: syntax error: expected 'key = value' or '[section]'",
		              path, rc);
	if (rc < 0)
		return pr_err(err, PR_EIO, "%s: cannot read parameter file", path);
	if (!memchr(L.seen, 1, sizeof L.seen))
		return pr_err(err, PR_EINVAL, "%s: no parameters: the file sets no key (empty or truncated?)", path);
	snprintf(c->source, sizeof c->source, "%s", path);
	return PR_OK;
}

int pr_config_set(pr_config *c, const char *assignment, char *err)
{
	char section[NAMELEN], key[NAMELEN];
	const char *eq = strchr(assignment, '='), *dot = strchr(assignment, '.');
	size_t n;
	int i;

	/* the messages quote the argument: keep them one line */
	for (n = 0; assignment[n]; ++n)
		if (((unsigned char)assignment[n] < 0x20 && assignment[n] != '\t') || assignment[n] == 0x7f)
			return pr_err(err, PR_EINVAL, "--set %.*s: control character 0x%02x",
			              (int)(n < 80 ? n : 80), assignment, (unsigned)(unsigned char)assignment[n]);
	if (!eq || !dot || dot > eq || dot == assignment)
		return pr_err(err, PR_EINVAL, "--set %.80s: expected section.key=value", assignment);
	n = (size_t)(dot - assignment);
	if (n >= sizeof section || (size_t)(eq - dot - 1) >= sizeof key)
		return pr_err(err, PR_EINVAL, "--set %.80s: name too long", assignment);
	memcpy(section, assignment, n);
	section[n] = '\0';
	n = (size_t)(eq - dot - 1);
	memcpy(key, dot + 1, n);
	key[n] = '\0';
	i = find_key(c, trim(section), trim(key));
	if (i < 0)
		return pr_err(err, PR_EINVAL, "--set: %s.%s: unknown key", section, key);
	c->key_line[i] = -1;
	return set_value(c, i, eq + 1, "--set: ", err);
}

/* ---- one key by name (the public accessors) ---- */

int pr_config_set_string(pr_config *c, const char *key, const char *value, char *err)
{
	size_t nk = strlen(key), nv = strlen(value);
	char *a;
	int rc;

	/* "key=value" through the --set path: the same checks and messages */
	if (strchr(key, '='))
		return pr_err(err, PR_EINVAL, "--set: %.80s: unknown key", key);
	a = malloc(nk + nv + 2);
	if (!a)
		return pr_err(err, PR_ENOMEM, "config: out of memory");
	memcpy(a, key, nk);
	a[nk] = '=';
	memcpy(a + nk + 1, value, nv + 1);
	rc = pr_config_set(c, a, err);
	free(a);
	return rc;
}

int pr_config_set_double(pr_config *c, const char *key, double v, char *err)
{
	char text[40];

	if (!isfinite(v))
		return pr_err(err, PR_EINVAL, "--set: %.80s: not a finite number", key);
	pr_csv_format_double(v, text, sizeof text);
	return pr_config_set_string(c, key, text, err);
}

/* The key "section.key" or an error naming it. */
static int known_key(const pr_config *c, const char *key, char *err)
{
	int i = find_dotted(c, key);

	return i >= 0 ? i : pr_err(err, PR_EINVAL, "%.80s: unknown key", key);
}

int pr_config_get_string(const pr_config *c, const char *key, char *buf, size_t n, char *err)
{
	int i = known_key(c, key, err);
	char *text;

	if (i < 0)
		return i;
	text = value_text(c, i);
	if (!text)
		return pr_err(err, PR_ENOMEM, "config: out of memory");
	if (strlen(text) >= n) {
		free(text);
		return pr_err(err, PR_EINVAL, "%.80s: the value does not fit in %zu bytes", key, n);
	}
	memcpy(buf, text, strlen(text) + 1);
	free(text);
	return PR_OK;
}

int pr_config_get_double(const pr_config *c, const char *key, double *v, char *err)
{
	int i = known_key(c, key, err);
	const pr_config_key *k;
	char *base;

	if (i < 0)
		return i;
	k = key_at(c, i, &base);
	base += k->off;
	/* whole-number keys are exact: their ranges end below 2^53 */
	switch (k->type) {
	case PR_KEY_DOUBLE: *v = *(const double *)base; return PR_OK;
	case PR_KEY_INT: *v = *(const int *)base; return PR_OK;
	case PR_KEY_LONG: *v = (double)*(const long *)base; return PR_OK;
	case PR_KEY_ULONG: *v = (double)*(const unsigned long *)base; return PR_OK;
	default: return pr_err(err, PR_EINVAL, "%.80s: not a number key (read it as text)", key);
	}
}

const char *pr_config_where(const pr_config *c, const char *key, char *buf, size_t n)
{
	const char *src = c->source[0] ? c->source : "defaults";
	int i = find_dotted(c, key);

	if (i >= 0 && c->key_line[i] > 0)
		snprintf(buf, n, "%s:%d", src, c->key_line[i]);
	else if (i >= 0 && c->key_line[i] < 0)
		snprintf(buf, n, "--set");
	else
		snprintf(buf, n, "%s", src);
	return buf;
}

/* Where a check across keys[0..] failed, blaming the first of them the
 * user set (a check of keys[0] that table.length, set by the user, broke
 * names table.length, not the default of keys[0]): "WHERE" when that is
 * keys[0] itself (or none was set), else "WHERE: KEY"; the message goes on
 * with keys[0]. */
static const char *where_blamed(const pr_config *c, const char *const *keys, char *buf, size_t n)
{
	char at[PR_WHERE_LEN];

	for (int k = 0; keys[k]; ++k) {
		int i = find_dotted(c, keys[k]);

		if (i < 0 || c->key_line[i] == 0)
			continue;
		if (k == 0)
			break;
		snprintf(buf, n, "%s: %s", pr_config_where(c, keys[k], at, sizeof at), keys[k]);
		return buf;
	}
	return pr_config_where(c, keys[0], buf, n);
}

static int box_inside(const pr_config *c, const double *b, const char *name, char *err)
{
	double hx = c->table.length / 2 - c->table.ball_radius;
	double hy = c->table.width / 2 - c->table.ball_radius;
	char key[NAMELEN], at[PR_WHERE_LEN + NAMELEN];
	const char *keys[] = {key, "table.length", "table.width", "table.ball_radius", NULL};

	snprintf(key, sizeof key, "start.%s", name);
	if (b[0] < -hx || b[1] > hx || b[2] < -hy || b[3] > hy)
		return pr_err(err, PR_EINVAL, "%s: %s: box reaches beyond the cushions "
		              "(|x| <= %g, |y| <= %g)", where_blamed(c, keys, at, sizeof at), key, hx, hy);
	return PR_OK;
}

/* Whether key k is a parameter of another friction law than table.friction_law's only. */
static int idle_law_key(const pr_config *c, const pr_config_key *k)
{
	return strcmp(k->section, "table") == 0 && pr_sim_law_idle_key(c->table.friction_law, k->key);
}

/* The start of choice i in "a|b|c" (its length: strcspn(p, "|")), or NULL. */
static const char *choice_at(const char *choices, int i)
{
	const char *p = choices;

	for (; i > 0 && p; --i) {
		p = strchr(p, '|');
		if (p)
			++p;
	}
	return p;
}

/* Another law's parameter set together with a law chosen explicitly would
 * be ignored silently: refused. */
static int friction_keys(const pr_config *c, char *err)
{
	char at[PR_WHERE_LEN], name[2 * NAMELEN + 1];
	const char *law = choice_at(PR_FRICTION_NAMES, c->table.friction_law);
	int li = find_dotted(c, "table.friction_law"), i, n = nkeys(c);
	char *base;

	if (li < 0 || c->key_line[li] == 0)
		return PR_OK;
	for (i = 0; i < n; ++i) {
		const pr_config_key *k = key_at(c, i, &base);
		if (c->key_line[i] == 0 || !idle_law_key(c, k))
			continue;
		snprintf(name, sizeof name, "%s.%s", k->section, k->key);
		return pr_err(err, PR_EINVAL, "%s: %s: not used with table.friction_law = %.*s",
		              pr_config_where(c, name, at, sizeof at), name,
		              law ? (int)strcspn(law, "|") : 0, law ? law : "");
	}
	return PR_OK;
}

int pr_config_validate(const pr_config *c, char *err)
{
	static const char *const balls[] = {"table.reward_balls", "table.balls", NULL},
	                         *radius[] = {"table.ball_radius", "table.width", "table.length", NULL},
	                         *dt[] = {"sim.dt", "sim.max_time", "sim.mode", NULL},
	                         *rep[] = {"experiment.repetition", "experiment.repetitions", NULL},
	                         *mu[] = {"table.mu_roll", "table.mu_slide", NULL};
	char at[PR_WHERE_LEN + NAMELEN], msg[PR_ERRLEN];
	int rc, b;

#define AT(key) pr_config_where(c, key, at, sizeof at)
#define BLAME(keys) where_blamed(c, keys, at, sizeof at)
	if ((rc = friction_keys(c, err)))
		return rc;
	/* the law's own check: the keys' ranges leave it mu_roll < mu_slide to refuse */
	if ((rc = pr_sim_law_check_all(&c->table, &c->sim, err))) {
		snprintf(msg, sizeof msg, "%s", err);
		return pr_err(err, rc, "%s: %s", BLAME(mu), msg);
	}
	if (c->table.reward_balls > c->table.balls - 1)
		return pr_err(err, PR_EINVAL, "%s: table.reward_balls: %d, but only %d balls besides the cue ball",
		              BLAME(balls), c->table.reward_balls, c->table.balls - 1);
	if (2 * c->table.ball_radius >= c->table.width || 2 * c->table.ball_radius >= c->table.length)
		return pr_err(err, PR_EINVAL, "%s: table.ball_radius: the ball does not fit on the table",
		              BLAME(radius));
	if ((rc = box_inside(c, c->start.cue_box, "cue_box", err)) ||
	    (rc = box_inside(c, c->start.reward_box, "reward_box", err)) ||
	    (rc = box_inside(c, c->start.obstacle_box, "obstacle_box", err)))
		return rc;
	if (c->sim.mode == PR_SIM_STEPPED && c->sim.dt >= c->sim.max_time)
		return pr_err(err, PR_EINVAL, "%s: sim.dt: must be smaller than sim.max_time", BLAME(dt));
	if (c->sim.mode == PR_SIM_STEPPED && c->sim.max_time / c->sim.dt > MAX_STEPS_PER_SHOT)
		return pr_err(err, PR_EINVAL, "%s: sim.dt: sim.max_time / sim.dt = %.3g steps per shot, "
		              "at most 1e9", BLAME(dt), c->sim.max_time / c->sim.dt);
	if (c->run.repetition >= c->run.repetitions)
		return pr_err(err, PR_EINVAL, "%s: experiment.repetition: %d, but there are only %d repetitions",
		              BLAME(rep), c->run.repetition, c->run.repetitions);
	/* the modules' own checks, so that `config` refuses what a run would,
	 * naming where the key was set */
	rc = pr_forest_opts_check(&c->forest, "forest", err);
	if (rc == PR_OK)
		rc = pr_forest_opts_check(&c->value, "value", err);
	if (rc == PR_OK)
		rc = pr_policy_opts_check(&c->policy, err);
	for (b = 0; rc == PR_OK && b < c->nblocks; ++b)
		if (c->block[b]->check)
			rc = c->block[b]->check(c->opts.bytes + c->block_off[b], err);
	if (rc) {
		char key[NAMELEN];
		snprintf(key, sizeof key, "%.*s", (int)strcspn(err, ":"), err);
		snprintf(msg, sizeof msg, "%s", err);
		return pr_err(err, rc, "%s: %s", AT(key), msg);
	}
#undef AT
#undef BLAME
	if (c->dropped)
		return pr_err(err, PR_EINVAL, "internal: %d experiments' options do not fit in "
		              "PR_CONFIG_MAXBLOCKS, PR_CONFIG_MAXKEYS or PR_CONFIG_OPTS_BYTES", c->dropped);
	return PR_OK;
}

static void write_value(const pr_config *c, int ki, FILE *fp)
{
	char *base, buf[40];
	const pr_config_key *k = key_at(c, ki, &base);
	int i;

	base += k->off;
	switch (k->type) {
	case PR_KEY_DOUBLE:
		pr_csv_format_double(*(const double *)base, buf, sizeof buf);
		fputs(buf, fp);
		break;
	case PR_KEY_INT: fprintf(fp, "%d", *(const int *)base); break;
	case PR_KEY_LONG: fprintf(fp, "%ld", *(const long *)base); break;
	case PR_KEY_ULONG: fprintf(fp, "%lu", *(const unsigned long *)base); break;
	case PR_KEY_ENUM: {
		const char *p = choice_at(k->unit, *(const int *)base);
		if (p)
			fprintf(fp, "%.*s", (int)strcspn(p, "|"), p);
		break;
	}
	case PR_KEY_EXPERIMENT:
	case PR_KEY_NAMES: fputs(base, fp); break;
	case PR_KEY_POCKETS: {
		const pr_reward_opts *r = (const pr_reward_opts *)base;
		for (i = 0; i < r->ntargets; ++i)
			fprintf(fp, "%s%d", i ? "," : "", r->targets[i]);
		break;
	}
	case PR_KEY_BOX:
		for (i = 0; i < 4; ++i) {
			pr_csv_format_double(((const double *)base)[i], buf, sizeof buf);
			fprintf(fp, "%s%s", i ? "," : "", buf);
		}
		break;
	case PR_KEY_LIST:
	case PR_KEY_ILIST: {
		const pr_list *l = (const pr_list *)base;
		for (i = 0; i < l->n; ++i) {
			pr_csv_format_double(l->v[i], buf, sizeof buf);
			fprintf(fp, "%s%s", i ? "," : "", buf);
		}
		break;
	}
	}
}

/* The value of key i as pr_config_write writes it, malloc'd (NULL: no memory). */
static char *value_text(const pr_config *c, int i)
{
	char *buf = NULL;
	size_t n = 0;
	FILE *fp = open_memstream(&buf, &n);

	if (!fp)
		return NULL;
	write_value(c, i, fp);
	if (fclose(fp) != 0) {
		free(buf);
		return NULL;
	}
	return buf;
}

int pr_config_diff(const pr_config *a, const pr_config *b, const char *const *skip, char *key,
                   size_t nkey, char *va, char *vb, size_t n)
{
	int i, j, nk = nkeys(a);
	char *base;

	for (i = 0; i < nk; ++i) {
		const pr_config_key *k = key_at(a, i, &base);
		char *x, *y;
		int differ;
		snprintf(key, nkey, "%s.%s", k->section, k->key);
		for (j = 0; skip && skip[j] && strcmp(key, skip[j]) != 0; ++j)
			;
		if (skip && skip[j])
			continue;
		x = value_text(a, i);
		y = value_text(b, i);
		if (!x || !y) {
			free(x);
			free(y);
			return -1;
		}
		differ = strcmp(x, y) != 0;
		snprintf(va, n, "%s", x ? x : "?");
		snprintf(vb, n, "%s", y ? y : "?");
		free(x);
		free(y);
		if (differ)
			return 1;
	}
	return 0;
}

int pr_config_write(const pr_config *c, FILE *fp)
{
	const char *section = "";
	char *base;
	int i, n = nkeys(c);

	for (i = 0; i < n; ++i) {
		const pr_config_key *k = key_at(c, i, &base);
		char name[2 * NAMELEN + 1];
		snprintf(name, sizeof name, "%s.%s", k->section, k->key);
		if (strcmp(section, k->section) != 0) {
			section = k->section;
			fprintf(fp, "%s[%s]\n", i ? "\n" : "", section);
		}
		/* another law's key as a comment: read back, it would clash with
		 * table.friction_law */
		fprintf(fp, "%s%s = ", idle_law_key(c, k) ? "; " : "", k->key);
		write_value(c, i, fp);
		fputc('\n', fp);
	}
	return ferror(fp) ? PR_EIO : PR_OK;
}

int pr_config_key_elsewhere(const pr_config *c, const char *key)
{
	pr_config_exp e;
	int i = find_dotted(c, key), b, first = NCORE;

	if (i < NCORE || !find_experiment(c, c->run.name, &e))
		return 0;
	for (b = 0; b < c->nblocks && i >= first + c->block[b]->nkeys; ++b)
		first += c->block[b]->nkeys;
	return b < c->nblocks && c->block[b] != e.block && c->block[b] != e.reads;
}

int pr_config_key_listed(const char *list, const char *key)
{
	while (*list) {
		size_t n = strcspn(list, ",");
		if (n && (list[n - 1] == '.' ? strncmp(key, list, n) == 0
		                             : strlen(key) == n && strncmp(key, list, n) == 0))
			return 1;
		list += n + (list[n] == ',');
	}
	return 0;
}

void pr_config_help(pr_config_schema schema, const char *only, FILE *fp)
{
	pr_config c;
	char lo[40], hi[40], names[PR_ERRLEN], *base;
	int i, n;

	pr_config_init(&c, schema);
	n = nkeys(&c);
	fprintf(fp, "Parameter keys (section.key = default [unit] range: meaning):\n");
	for (i = 0; i < n; ++i) {
		const pr_config_key *k = key_at(&c, i, &base);
		char name[2 * NAMELEN];
		snprintf(name, sizeof name, "%s.%s", k->section, k->key);
		if (only && !pr_config_key_listed(only, name))
			continue;
		fprintf(fp, "  %-26s = ", name);
		write_value(&c, i, fp);
		if (k->type == PR_KEY_EXPERIMENT) {
			fprintf(fp, "  {%s}", experiment_names(&c, names, sizeof names));
		} else if (k->type == PR_KEY_ENUM || k->type == PR_KEY_NAMES) {
			fprintf(fp, "  {%s}", k->unit);
		} else if (k->type != PR_KEY_POCKETS && k->type != PR_KEY_BOX) {
			pr_csv_format_double(k->lo, lo, sizeof lo);
			pr_csv_format_double(k->hi, hi, sizeof hi);
			if (k->unit[0])
				fprintf(fp, " %s", k->unit);
			fprintf(fp, "  %s%s..%s%s%s", k->open & PR_KEY_OPEN_LO ? "(" : "[", lo, hi,
			        k->open & PR_KEY_OPEN_HI ? ")" : "]", k->type == PR_KEY_ILIST ? " whole numbers" : "");
		} else if (k->unit[0]) {
			fprintf(fp, " %s", k->unit);
		}
		fprintf(fp, ": %s\n", k->help);
	}
}

/* ---- numbers set per row (shotparams.c) ---- */

int pr_config_number_key(const pr_config *c, const char *name, char *err)
{
	char *base;
	int i = find_dotted(c, name);

	if (i < 0)
		return pr_err(err, PR_EINVAL, "%.80s: unknown key", name);
	if (key_at(c, i, &base)->type != PR_KEY_DOUBLE)
		return pr_err(err, PR_EINVAL, "%.80s: not a number key (only numbers vary per row)",
		              name);
	return i;
}

int pr_config_set_number(pr_config *c, int i, double v, char *err)
{
	char *base = NULL, text[40];
	const pr_config_key *k = key_at(c, i, &base);

	if (!isfinite(v))
		return pr_err(err, PR_EINVAL, "%s.%s: not a finite number", k->section, k->key);
	if (!in_range(k, v)) {
		pr_csv_format_double(v, text, sizeof text);
		return range_err(k, "", text, err);
	}
	*(double *)(base + k->off) = v;
	c->key_line[i] = -1;
	return PR_OK;
}

void pr_config_learner_opts(const pr_config *c, pr_learner_opts *o)
{
	*o = c->learner;
	o->value_forest = c->value;
	o->value_features = c->value_features;
	o->reps = c->reps;
	o->policy = c->policy;
}
