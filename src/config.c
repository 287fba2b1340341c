/* config.c — the parameter registry, INI loading (libinih), --set and checks.
 *
 * Every key lives in one table below: its section, name, type, the field of
 * pr_config it sets, its range and unit. Defaults come from the modules'
 * _init functions, so the table never repeats a default. Loading reports the
 * first bad line as "file:line: section.key: message" and stops.
 */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <ini.h>

#include "poolreps/bench.h"
#include "poolreps/config.h"
#include "csvio_priv.h"

enum { K_DOUBLE, K_INT, K_LONG, K_ULONG, K_ENUM, K_NAME, K_NAMES, K_POCKETS, K_BOX, K_LIST, K_ILIST };
/* open bounds (key_def.lo_open) */
enum { OPEN_LO = 1, OPEN_HI = 2 };

typedef struct {
	const char *section, *key;
	int type;
	size_t off;
	double lo, hi;     /* range (for K_LIST, K_ILIST: of each element) */
	int lo_open;       /* OPEN_LO, OPEN_HI: that bound itself is excluded */
	const char *unit;  /* or, for K_ENUM/K_NAME, the choices "a|b|c" */
	const char *help;
} key_def;

#define F(field) offsetof(pr_config, field)
#define BIG 1e300

static const key_def keys[] = {
	{"experiment", "name", K_NAME, F(run.name), 0, 0, 0,
	 "figures|exp1|exp2|exp3|quadratic|sphere|rosenbrock", "what `poolreps CONFIG` runs"},
	{"experiment", "seed", K_ULONG, F(run.seed), 0, 4294967295.0, 0, "", "master seed"},
	{"experiment", "repetitions", K_INT, F(run.repetitions), 1, 10000, 0, "", "independent repetitions"},
	{"experiment", "repetition", K_INT, F(run.repetition), -1, 9999, 0, "",
	 "-1 runs all repetitions; k runs only repetition k (sweeps)"},
	{"experiment", "variant", K_INT, F(run.variant), -1, PR_VARIANTS_MAX - 1, 0, "",
	 "-1 runs all variants; v runs only variant v: exp1 setting, exp3 policy (sweeps)"},
	{"experiment", "threads", K_INT, F(run.threads), 1, 256, 0, "", "threads for repetitions"},

	{"table", "length", K_DOUBLE, F(table.length), 0, 100, 1, "m", "long side (x)"},
	{"table", "width", K_DOUBLE, F(table.width), 0, 100, 1, "m", "short side (y)"},
	{"table", "ball_radius", K_DOUBLE, F(table.ball_radius), 0, 1, 1, "m", "ball radius R"},
	{"table", "pocket_radius", K_DOUBLE, F(table.pocket_radius), 0, 1, 1, "m", "pocket radius"},
	{"table", "restitution", K_DOUBLE, F(table.restitution), 0, 1, 0, "", "cushion restitution kappa (eq. 7.4)"},
	{"table", "friction", K_DOUBLE, F(table.friction), 0, 1000, 1, "1/s", "c in v(t) = v0 exp(-c t)"},
	{"table", "stop_speed", K_DOUBLE, F(table.stop_speed), 0, 10, 1, "m/s", "slower balls stop"},
	{"table", "balls", K_INT, F(table.balls), 2, 10000, 0, "", "balls: cue + reward + obstacles"},
	{"table", "reward_balls", K_INT, F(table.reward_balls), 1, 9999, 0, "", "reward balls b"},

	{"sim", "mode", K_ENUM, F(sim.mode), 0, 0, 0, "event|stepped", "exact event-driven or the thesis's time steps"},
	{"sim", "dt", K_DOUBLE, F(sim.dt), 1e-7, 0.1, 0, "s", "stepped mode: time step"},
	{"sim", "max_time", K_DOUBLE, F(sim.max_time), 0, 1e6, 1, "s", "simulated time limit of a shot"},
	{"sim", "max_events", K_LONG, F(sim.max_events), 1, 1e9, 0, "", "event mode: events before a shot fails"},
	{"sim", "trace_dt", K_DOUBLE, F(sim.trace_dt), 0, 10, 1, "s", "stepped mode: trace interval (--trace)"},
	{"sim", "max_speed", K_DOUBLE, F(sim.max_speed), 0, 1000, 1, "m/s", "faster actions are refused"},

	{"reward", "targets", K_POCKETS, F(reward.targets), 0, 5, 0, "", "target pocket ids, e.g. 2,5"},
	{"reward", "miss_penalty", K_DOUBLE, F(reward.miss_penalty), 0, 1e6, 0, "",
	 "times the smallest cue-reward gap when the cue never hits a reward ball"},
	{"reward", "scratch_penalty", K_DOUBLE, F(reward.scratch_penalty), 0, 1e6, 0, "m",
	 "subtracted when the cue ball is pocketed"},

	{"start", "cue_box", K_BOX, F(start.cue_box), -BIG, BIG, 0, "m", "cue ball box xmin,xmax,ymin,ymax"},
	{"start", "reward_box", K_BOX, F(start.reward_box), -BIG, BIG, 0, "m",
	 "reward ball box xmin,xmax,ymin,ymax (exp3: 0.05,0.15,-0.1,0.1)"},
	{"start", "obstacle_box", K_BOX, F(start.obstacle_box), -BIG, BIG, 0, "m", "obstacle box xmin,xmax,ymin,ymax"},
	{"start", "max_tries", K_INT, F(start.max_tries), 1, 1000000, 0, "", "redraws of an overlapping start"},

	{"ghost", "arrival_speed", K_DOUBLE, F(expert.arrival_speed), 0, 10, 1, "m/s",
	 "ghost-ball expert: reward ball speed at the aim point"},
	{"ghost", "aim", K_ENUM, F(expert.aim), 0, 0, 0, "centre|corridor",
	 "ghost-ball expert: aim at the target pocket's centre or its corridor entry"},
	{"exp1", "aim_speed", K_DOUBLE, F(expert.aim_speed), 0, 100, 1, "m/s",
	 "Experiment 1 data policy: cue speed aimed at the reward ball"},
	{"exp1", "train", K_INT, F(exp1.train), 1, 10000000, 0, "", "training shots"},
	{"exp1", "test", K_INT, F(exp1.test), 1, 10000000, 0, "", "test shots"},
	{"exp1", "subset", K_INT, F(exp1.subset), 1, 10000000, 0, "", "training samples per forest"},
	{"exp1", "test_subset", K_INT, F(exp1.test_subset), 1, 10000000, 0, "", "test samples per forest"},
	{"exp1", "n_min_list", K_ILIST, F(exp1.n_min_list), 1, 10000000, 0, "", "n_min sweep (Fig. 7.4a)"},
	{"exp1", "trees_list", K_ILIST, F(exp1.trees_list), 1, 10000, 0, "", "M sweep (Fig. 7.4b)"},
	{"exp1", "cuts_list", K_ILIST, F(exp1.cuts_list), 1, 10000, 0, "", "K sweep (Fig. 7.4c)"},
	{"exp1", "map_grid", K_INT, F(exp1.map_grid), 2, 1000, 0, "", "reward map grid points per side"},

	{"exp2", "sizes", K_ILIST, F(exp2.sizes), 2, 10000000, 0, "", "training-set sizes"},
	{"exp2", "test", K_INT, F(exp2.test), 1, 10000000, 0, "", "test shots per size and policy"},
	{"exp2", "n_min_frac", K_DOUBLE, F(exp2.n_min_frac), 0, 1, 1, "", "tree policies: n_min = frac * size"},

	{"exp3", "init_samples", K_INT, F(exp3.init_samples), 1, 10000000, 0, "", "samples of the initial policy"},
	{"exp3", "init_std", K_DOUBLE, F(exp3.init_std), 1e-100, 100, 0, "m/s", "initial policy N(0, init_std^2 I)"},
	{"exp3", "iterations", K_INT, F(exp3.iterations), 0, 1000000, 0, "", "REPS iterations"},
	{"exp3", "samples", K_INT, F(exp3.samples), 1, 10000000, 0, "", "new samples per iteration"},
	{"exp3", "window", K_INT, F(exp3.window), 2, 10000000, 0, "", "latest samples REPS reuses"},
	{"exp3", "policies", K_NAMES, F(exp3.policies), 0, 0, 0,
	 "nrvr_rs|rvr_rs|nrvr_a|rvr_a|baseline|handcrafted", "comma list of variants to run"},
	{"exp3", "baseline_n_min", K_INT, F(exp3.baseline_n_min), 1, 100000000, 0, "", "n_min of the baseline policy"},
	{"exp3", "final_episodes", K_INT, F(exp3.final_episodes), 1, 100000000, 0, "",
	 "Figs. 7.8-7.10: each run's last episodes"},
	{"exp3", "handcrafted_method", K_ENUM, F(exp3.handcrafted_method), 0, 0, 0, "creps|ccmaes",
	 "hand-crafted variant: REPS + weighted ML, or contextual CMA-ES"},

	{"forest", "trees", K_INT, F(forest.trees), 1, 10000, 0, "", "M trees"},
	{"forest", "cuts", K_INT, F(forest.cuts), 1, 10000, 0, "", "K random tests per node"},
	{"forest", "n_min", K_INT, F(forest.n_min), 1, 100000000, 0, "", "split nodes with more samples"},
	{"forest", "n_c", K_INT, F(forest.n_c), 1, 100000000, 0, "", "smallest child a split may leave"},
	{"forest", "score", K_ENUM, F(forest.score), 0, 0, 0, "rvr|nrvr", "split score (eq. 4.1) or its negation"},
	{"forest", "replacement", K_ENUM, F(forest.with_replacement), 0, 0, 0, "without|with",
	 "draw the K cut dimensions with or without replacement"},
	{"forest", "outputs", K_ENUM, F(forest.outputs), 0, 0, 0, "sum|relative",
	 "several outputs: add variance reductions (eq. 6.1) or each relative to its node variance"},

	{"value", "trees", K_INT, F(value.trees), 1, 10000, 0, "", "value-feature forest: M (exp3: 10)"},
	{"value", "cuts", K_INT, F(value.cuts), 1, 10000, 0, "", "value-feature forest: K"},
	{"value", "n_min", K_INT, F(value.n_min), 1, 100000000, 0, "", "value-feature forest: n_min (exp3: 60)"},
	{"value", "n_c", K_INT, F(value.n_c), 1, 100000000, 0, "", "value-feature forest: n_c"},
	{"value", "score", K_ENUM, F(value.score), 0, 0, 0, "rvr|nrvr", "value-feature forest score (exp3: nrvr)"},
	{"value", "replacement", K_ENUM, F(value.with_replacement), 0, 0, 0, "without|with", "value-feature forest cut draws"},
	{"value", "outputs", K_ENUM, F(value.outputs), 0, 0, 0, "sum|relative", "value-feature forest: several outputs"},
	{"value", "features", K_NAME, F(value_features), 0, 0, 0, "leaves|samples",
	 "active leaves (eq. 5.4) or active samples (eq. 5.6)"},

	{"reps", "epsilon", K_DOUBLE, F(reps.epsilon), 0, 1e6, 1, "nats", "KL bound (eq. 3.2; sphere, rosenbrock: 1)"},
	{"reps", "ridge", K_DOUBLE, F(reps.ridge), 0, 1e12, 0, "", "ridge on theta in the dual"},
	{"reps", "eta_min", K_DOUBLE, F(reps.eta_min), 0, 1, OPEN_LO | OPEN_HI, "",
	 "eta (return standard deviations) below which the eta -> 0 limit decides if KL = epsilon is reachable"},
	{"reps", "max_iter", K_INT, F(reps.max_iter), 1, 10000000, 0, "", "dual evaluations per solve"},
	{"reps", "allow_failed", K_INT, F(reps.allow_failed), 0, 1, 0, "",
	 "experiments: 1 records an uncertified REPS solve (status failed) and goes on; 0 fails the run"},

	{"policy", "target", K_ENUM, F(policy.target), 0, 0, 0, "action|reward_state", "policy forest output"},
	{"policy", "lambda", K_DOUBLE, F(policy.lambda), 0, 1e12, 0, "", "ridge of eq. 6.6"},
	{"policy", "min_std", K_DOUBLE, F(policy.min_std), 1e-100, 100, 0, "m/s", "floor on action standard deviations"},
	{"policy", "trees", K_INT, F(policy.forest.trees), 1, 10000, 0, "", "policy forest: M (exp2: 30)"},
	{"policy", "cuts", K_INT, F(policy.forest.cuts), 1, 10000, 0, "", "policy forest: K (exp2: 10)"},
	{"policy", "n_min", K_INT, F(policy.forest.n_min), 1, 100000000, 0, "", "policy forest: n_min"},
	{"policy", "n_c", K_INT, F(policy.forest.n_c), 1, 100000000, 0, "", "policy forest: n_c"},
	{"policy", "score", K_ENUM, F(policy.forest.score), 0, 0, 0, "rvr|nrvr", "policy forest score"},
	{"policy", "replacement", K_ENUM, F(policy.forest.with_replacement), 0, 0, 0, "without|with", "policy forest cut draws"},
	{"policy", "outputs", K_ENUM, F(policy.forest.outputs), 0, 0, 0, "sum|relative",
	 "policy forest, two outputs: eq. 6.3 as printed (sum) or each relative to its variance"},
	{"policy", "cov", K_ENUM, F(policy.cov), 0, 0, 0, "query|residual",
	 "eq. 6.8 centred on the query mean (as printed) or on each sample's own fit"},
	{"policy", "cov_center", K_ENUM, F(policy.cov_center), 0, 0, 0, "new|old",
	 "linear weighted ML: residuals around the new mean or the sampling policy's (benchmarks: old)"},

	/* defaults of bench.* depend on experiment.name (pr_bench_opts_init), as
	 * do those in exp_defaults: the help text names them */
	{"bench", "iterations", K_INT, F(bench.iterations), 1, 1000000, 0, "", "REPS iterations (quadratic: 40)"},
	{"bench", "samples", K_INT, F(bench.samples), 2, 10000000, 0, "", "episodes per iteration"},
	{"bench", "dims", K_INT, F(bench.dims), 1, 10000, 0, "", "action (parameter) dimensions (quadratic: 1)"},
	{"bench", "context_dims", K_INT, F(bench.context_dims), 1, 100, 0, "",
	 "context dimensions k (quadratic, rosenbrock: 1)"},
	{"bench", "init_std", K_DOUBLE, F(bench.init_std), 1e-100, 1e6, 0, "", "initial policy standard deviation"},
	{"bench", "min_std", K_DOUBLE, F(bench.min_std), 1e-100, 1e6, 0, "", "floor on policy standard deviations"},
	{"bench", "value_degree", K_INT, F(bench.value_degree), 1, 2, 0, "",
	 "REPS value features: 1 = s, 2 = s and its products (quadratic: 2)"},
	{"bench", "test_contexts", K_INT, F(bench.test_contexts), 1, 1000000, 0, "",
	 "fixed contexts scoring the policy mean"},
	{"bench", "method", K_ENUM, F(bench.method), 0, 0, 0, "creps|ccmaes",
	 "contextual REPS or contextual CMA-ES"},
};

#define NKEYS (sizeof keys / sizeof keys[0])
_Static_assert(NKEYS <= PR_CONFIG_MAXKEYS, "raise PR_CONFIG_MAXKEYS");

void pr_config_init(pr_config *c)
{
	memset(c, 0, sizeof *c);
	pr_run_opts_init(&c->run);
	pr_table_init(&c->table);
	pr_sim_opts_init(&c->sim);
	pr_reward_opts_init(&c->reward);
	pr_start_opts_init(&c->start);
	pr_expert_opts_init(&c->expert);
	pr_forest_opts_init(&c->forest);
	pr_reps_opts_init(&c->reps);
	pr_policy_opts_init(&c->policy);
	pr_forest_opts_init(&c->value);
	snprintf(c->value_features, sizeof c->value_features, "leaves");
	pr_exp1_opts_init(&c->exp1);
	pr_exp2_opts_init(&c->exp2);
	pr_exp3_opts_init(&c->exp3);
	pr_bench_opts_init(&c->bench, c->run.name);
}

/* Defaults that depend on experiment.name besides bench.* (which
 * pr_bench_opts_init sets by name): what data/<name>.ini states, so that a
 * parameter file naming only the experiment runs the thesis's setup. */
static const struct {
	const char *name, *key, *value;
} exp_defaults[] = {
	{"exp2", "policy.trees", "30"},
	{"exp2", "policy.cuts", "10"},
	{"exp3", "start.reward_box", "0.05,0.15,-0.1,0.1"},
	{"exp3", "value.trees", "10"},
	{"exp3", "value.n_min", "60"},
	{"exp3", "value.score", "nrvr"},
	{"sphere", "reps.epsilon", "1"},
	{"rosenbrock", "reps.epsilon", "1"},
	{"quadratic", "policy.cov_center", "old"},
	{"sphere", "policy.cov_center", "old"},
	{"rosenbrock", "policy.cov_center", "old"},
};
#define NEXPDEF (sizeof exp_defaults / sizeof exp_defaults[0])

static const key_def *find_dotted(const char *name);
static int set_value_raw(pr_config *c, const key_def *k, const char *value, const char *where, char *err);

static int follows_name(const key_def *k)
{
	char name[64];
	size_t j;

	if (strcmp(k->section, "bench") == 0)
		return 1;
	snprintf(name, sizeof name, "%s.%s", k->section, k->key);
	for (j = 0; j < NEXPDEF; ++j)
		if (strcmp(exp_defaults[j].key, name) == 0)
			return 1;
	return 0;
}

static size_t key_size(const key_def *k)
{
	switch (k->type) {
	case K_DOUBLE: return sizeof(double);
	case K_INT:
	case K_ENUM: return sizeof(int);
	case K_BOX: return 4 * sizeof(double);
	}
	return 0;
}

/* After experiment.name changed: every name-dependent key that was not set
 * explicitly (key_line 0) takes that experiment's default. */
static void experiment_defaults(pr_config *c)
{
	pr_config d;
	char err[PR_ERRLEN];
	size_t i, j;

	pr_config_init(&d);
	pr_bench_opts_init(&d.bench, c->run.name);
	for (j = 0; j < NEXPDEF; ++j)
		if (strcmp(exp_defaults[j].name, c->run.name) == 0)
			set_value_raw(&d, find_dotted(exp_defaults[j].key), exp_defaults[j].value, "", err);
	for (i = 0; i < NKEYS; ++i)
		if (c->key_line[i] == 0 && follows_name(&keys[i]))
			memcpy((char *)c + keys[i].off, (const char *)&d + keys[i].off, key_size(&keys[i]));
}

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

static const key_def *find_key(const char *section, const char *key)
{
	size_t i;

	for (i = 0; i < NKEYS; ++i)
		if (strcmp(keys[i].section, section) == 0 && strcmp(keys[i].key, key) == 0)
			return &keys[i];
	return NULL;
}

static int known_section(const char *section)
{
	size_t i;

	for (i = 0; i < NKEYS; ++i)
		if (strcmp(keys[i].section, section) == 0)
			return 1;
	return 0;
}

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

/* The key "section.key", or NULL. */
static const key_def *find_dotted(const char *name)
{
	const char *dot = strchr(name, '.');
	char section[64];

	if (!dot || (size_t)(dot - name) >= sizeof section)
		return NULL;
	memcpy(section, name, (size_t)(dot - name));
	section[dot - name] = '\0';
	return find_key(section, dot + 1);
}

static int in_range(const key_def *k, double v)
{
	return (k->lo_open & OPEN_LO ? v > k->lo : v >= k->lo) &&
	       (k->lo_open & OPEN_HI ? v < k->hi : v <= k->hi);
}

static int range_err(const key_def *k, const char *where, const char *value, char *err)
{
	char lo[40], hi[40];

	pr_csv_format_double(k->lo, lo, sizeof lo);
	pr_csv_format_double(k->hi, hi, sizeof hi);
	return pr_err(err, PR_EINVAL, "%s%s.%s: %s out of range: must be %s %s and %s %s%s",
	              where, k->section, k->key, value, k->lo_open & OPEN_LO ? ">" : ">=", lo,
	              k->lo_open & OPEN_HI ? "<" : "<=", hi,
	              k->type == K_ILIST ? ", whole numbers" : "");
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

static char *trim(char *s);

/* Callers mark the key in key_line first, so a name change keeps it. */
static int set_value(pr_config *c, const key_def *k, const char *value, const char *where, char *err)
{
	int rc = set_value_raw(c, k, value, where, err);

	if (rc == PR_OK && k->off == F(run.name))
		experiment_defaults(c);
	return rc;
}

static int set_value_raw(pr_config *c, const key_def *k, const char *value, const char *where, char *err)
{
	char *base = (char *)c + k->off;
	double v, list[PR_LIST_MAX];
	int i, n;

	switch (k->type) {
	case K_DOUBLE:
		if (pr_csv_parse_double(value, &v))
			return pr_err(err, PR_EINVAL, "%s%s.%s: not a finite number: '%.40s'",
			              where, k->section, k->key, value);
		if (!in_range(k, v))
			return range_err(k, where, value, err);
		*(double *)base = v;
		return PR_OK;
	case K_INT:
	case K_LONG:
	case K_ULONG: {
		char *end;
		long long x;
		errno = 0;
		x = strtoll(value, &end, 10);
		while (*end == ' ' || *end == '\t')
			++end;
		if (end == value || *end || errno == ERANGE)
			return pr_err(err, PR_EINVAL, "%s%s.%s: not an integer: '%.40s'",
			              where, k->section, k->key, value);
		if (!in_range(k, (double)x))
			return range_err(k, where, value, err);
		if (k->type == K_INT)
			*(int *)base = (int)x;
		else if (k->type == K_LONG)
			*(long *)base = (long)x;
		else
			*(unsigned long *)base = (unsigned long)x;
		return PR_OK;
	}
	case K_ENUM:
		i = choice_index(k->unit, value);
		if (i < 0)
			return pr_err(err, PR_EINVAL, "%s%s.%s: '%.40s' is not one of %s",
			              where, k->section, k->key, value, k->unit);
		*(int *)base = i;
		return PR_OK;
	case K_NAME:
		if (choice_index(k->unit, value) < 0)
			return pr_err(err, PR_EINVAL, "%s%s.%s: '%.40s' is not one of %s",
			              where, k->section, k->key, value, k->unit);
		snprintf(base, 32, "%s", value);
		return PR_OK;
	case K_NAMES: {
		char item[64];
		const char *p = value;
		unsigned seen = 0;
		if (strlen(value) >= 128)
			return pr_err(err, PR_EINVAL, "%s%s.%s: list too long", where, k->section, k->key);
		do {
			size_t len = strcspn(p, ",");
			int choice;
			snprintf(item, sizeof item, "%.*s", (int)(len < 63 ? len : 63), p);
			if ((choice = choice_index(k->unit, trim(item))) < 0)
				return pr_err(err, PR_EINVAL, "%s%s.%s: '%s' is not one of %s",
				              where, k->section, k->key, trim(item), k->unit);
			if (seen & 1u << choice)
				return pr_err(err, PR_EINVAL, "%s%s.%s: '%s' listed twice",
				              where, k->section, k->key, trim(item));
			seen |= 1u << choice;
			p += len;
		} while (*p++ == ',');
		snprintf(base, 128, "%s", value);
		return PR_OK;
	}
	case K_POCKETS: {
		pr_reward_opts *r = &c->reward;
		n = parse_numbers(value, list, PR_SIM_POCKETS);
		if (n < 1)
			return pr_err(err, PR_EINVAL, "%s%s.%s: expected 1 to 6 pocket ids, got '%.40s'",
			              where, k->section, k->key, value);
		for (i = 0; i < n; ++i) {
			int j;
			if (list[i] != floor(list[i]) || list[i] < 0 || list[i] > 5)
				return pr_err(err, PR_EINVAL, "%s%s.%s: pocket id must be 0..5, got '%.40s'",
				              where, k->section, k->key, value);
			for (j = 0; j < i; ++j)
				if (list[j] == list[i])
					return pr_err(err, PR_EINVAL, "%s%s.%s: pocket %d listed twice",
					              where, k->section, k->key, (int)list[i]);
			r->targets[i] = (int)list[i];
		}
		r->ntargets = n;
		return PR_OK;
	}
	case K_BOX:
		n = parse_numbers(value, list, 4);
		if (n != 4 || list[0] > list[1] || list[2] > list[3])
			return pr_err(err, PR_EINVAL, "%s%s.%s: expected xmin,xmax,ymin,ymax with "
			              "xmin <= xmax and ymin <= ymax, got '%.60s'",
			              where, k->section, k->key, value);
		memcpy(base, list, 4 * sizeof *list);
		return PR_OK;
	case K_LIST:
	case K_ILIST: {
		pr_list *l = (pr_list *)base;
		n = parse_numbers(value, list, PR_LIST_MAX);
		if (n < 1)
			return pr_err(err, PR_EINVAL, "%s%s.%s: expected a comma list of 1 to %d numbers, "
			              "got '%.40s'", where, k->section, k->key, PR_LIST_MAX, value);
		for (i = 0; i < n; ++i)
			if (!in_range(k, list[i]) || (k->type == K_ILIST && list[i] != floor(list[i])))
				return range_err(k, where, value, err);
		l->n = n;
		memcpy(l->v, list, (size_t)n * sizeof *list);
		return PR_OK;
	}
	}
	return pr_err(err, PR_EINVAL, "%s%s.%s: unsupported key type", where, k->section, k->key);
}

/* ---- INI loading ---- */

typedef struct {
	pr_config *c;
	FILE *fp;
	const char *path;
	long line;
	int status;
	char *err;
	char section[64];
	char seen[sizeof keys / sizeof keys[0]];
	long seen_line[sizeof keys / sizeof keys[0]];
	char buf[4100];    /* one line: above ini_max_line, the limit checked */
} loader;

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
	if (len >= (size_t)num - 1 || (ch != '\n' && ch != EOF)) {
		L->status = pr_err(L->err, PR_EINVAL, "%s:%ld: line longer than %d bytes",
		                   L->path, L->line, num - 2);
		return NULL;
	}
	/* binary junk, and a control character would break the one-line message */
	for (s = L->buf; *s && strcmp(s, "\n") != 0 && strcmp(s, "\r\n") != 0 && strcmp(s, "\r") != 0; ++s) {
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
			if (!known_section(trim(name))) {
				L->status = pr_err(L->err, PR_EINVAL, "%s:%ld: [%s]: unknown section",
				                   L->path, L->line, trim(name));
				return NULL;
			}
		}
	}
	memcpy(str, L->buf, len + 1);
	return str;
}

static int on_pair(void *user, const char *section_raw, const char *name, const char *value)
{
	loader *L = user;
	char where[320], buf[64];
	const char *section;
	const key_def *k;
	size_t i;

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
	k = find_key(section, name);
	if (!k) {
		L->status = pr_err(L->err, PR_EINVAL, "%s%s.%s: unknown key", where, section, name);
		return 0;
	}
	i = (size_t)(k - keys);
	if (L->seen[i]) {
		L->status = pr_err(L->err, PR_EINVAL, "%s%s.%s: duplicate key (first set on line %ld)",
		                   where, section, name, L->seen_line[i]);
		return 0;
	}
	L->seen[i] = 1;
	L->seen_line[i] = L->line;
	L->c->key_line[i] = L->line > INT_MAX ? INT_MAX : (int)L->line;
	L->status = set_value(L->c, k, value, where, L->err);
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
		return pr_err(err, PR_EIO, "%s: cannot open parameter file: %s", path, strerror(errno));
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
	ini_max_line = 4096;
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
	char section[64], key[64];
	const char *eq = strchr(assignment, '='), *dot = strchr(assignment, '.');
	const key_def *k;
	size_t n;

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
	k = find_key(trim(section), trim(key));
	if (!k)
		return pr_err(err, PR_EINVAL, "--set: %s.%s: unknown key", section, key);
	c->key_line[k - keys] = -1;
	return set_value(c, k, eq + 1, "--set: ", err);
}

const char *pr_config_where(const pr_config *c, const char *key, char *buf, size_t n)
{
	const char *src = c->source[0] ? c->source : "defaults";
	const key_def *k = find_dotted(key);

	if (k && c->key_line[k - keys] > 0)
		snprintf(buf, n, "%s:%d", src, c->key_line[k - keys]);
	else if (k && c->key_line[k - keys] < 0)
		snprintf(buf, n, "--set");
	else
		snprintf(buf, n, "%s", src);
	return buf;
}

static int box_inside(const pr_config *c, const double *b, const char *name, char *err)
{
	double hx = c->table.length / 2 - c->table.ball_radius;
	double hy = c->table.width / 2 - c->table.ball_radius;
	char key[32], at[320];

	snprintf(key, sizeof key, "start.%s", name);
	if (b[0] < -hx || b[1] > hx || b[2] < -hy || b[3] > hy)
		return pr_err(err, PR_EINVAL, "%s: %s: box reaches beyond the cushions "
		              "(|x| <= %g, |y| <= %g)", pr_config_where(c, key, at, sizeof at), key, hx, hy);
	return PR_OK;
}

int pr_config_validate(const pr_config *c, char *err)
{
	char at[320];
	int rc;

#define AT(key) pr_config_where(c, key, at, sizeof at)
	if (c->table.reward_balls > c->table.balls - 1)
		return pr_err(err, PR_EINVAL, "%s: table.reward_balls: %d, but only %d balls besides the cue ball",
		              AT("table.reward_balls"), c->table.reward_balls, c->table.balls - 1);
	if (2 * c->table.ball_radius >= c->table.width || 2 * c->table.ball_radius >= c->table.length)
		return pr_err(err, PR_EINVAL, "%s: table.ball_radius: the ball does not fit on the table",
		              AT("table.ball_radius"));
	if ((rc = box_inside(c, c->start.cue_box, "cue_box", err)) ||
	    (rc = box_inside(c, c->start.reward_box, "reward_box", err)) ||
	    (rc = box_inside(c, c->start.obstacle_box, "obstacle_box", err)))
		return rc;
	if (c->sim.mode == PR_SIM_STEPPED && c->sim.dt >= c->sim.max_time)
		return pr_err(err, PR_EINVAL, "%s: sim.dt: must be smaller than sim.max_time", AT("sim.dt"));
	/* resource limit, refused up front: past 1e9 steps one shot runs for minutes to days */
	if (c->sim.mode == PR_SIM_STEPPED && c->sim.max_time / c->sim.dt > 1e9)
		return pr_err(err, PR_EINVAL, "%s: sim.dt: sim.max_time / sim.dt = %.3g steps per shot, "
		              "at most 1e9", AT("sim.dt"), c->sim.max_time / c->sim.dt);
	if (c->run.repetition >= c->run.repetitions)
		return pr_err(err, PR_EINVAL, "%s: experiment.repetition: %d, but there are only %d repetitions",
		              AT("experiment.repetition"), c->run.repetition, c->run.repetitions);
	/* the modules' own checks, so that `config` refuses what a run would,
	 * naming where the key was set */
	if ((rc = pr_forest_opts_check(&c->forest, "forest", err)) ||
	    (rc = pr_forest_opts_check(&c->value, "value", err)) ||
	    (rc = pr_policy_opts_check(&c->policy, err)) ||
	    (rc = pr_bench_opts_check(&c->bench, err))) {
		char key[64], msg[PR_ERRLEN];
		snprintf(key, sizeof key, "%.*s", (int)strcspn(err, ":"), err);
		snprintf(msg, sizeof msg, "%s", err);
		return pr_err(err, rc, "%s: %s", AT(key), msg);
	}
#undef AT
	return PR_OK;
}

static void write_value(const pr_config *c, const key_def *k, FILE *fp)
{
	const char *base = (const char *)c + k->off;
	char buf[40];
	int i;

	switch (k->type) {
	case K_DOUBLE:
		pr_csv_format_double(*(const double *)base, buf, sizeof buf);
		fputs(buf, fp);
		break;
	case K_INT: fprintf(fp, "%d", *(const int *)base); break;
	case K_LONG: fprintf(fp, "%ld", *(const long *)base); break;
	case K_ULONG: fprintf(fp, "%lu", *(const unsigned long *)base); break;
	case K_ENUM: {
		const char *p = k->unit;
		for (i = *(const int *)base; i > 0 && p; --i) {
			p = strchr(p, '|');
			if (p)
				++p;
		}
		if (p)
			fprintf(fp, "%.*s", (int)strcspn(p, "|"), p);
		break;
	}
	case K_NAME:
	case K_NAMES: fputs(base, fp); break;
	case K_POCKETS:
		for (i = 0; i < c->reward.ntargets; ++i)
			fprintf(fp, "%s%d", i ? "," : "", c->reward.targets[i]);
		break;
	case K_BOX:
		for (i = 0; i < 4; ++i) {
			pr_csv_format_double(((const double *)base)[i], buf, sizeof buf);
			fprintf(fp, "%s%s", i ? "," : "", buf);
		}
		break;
	case K_LIST:
	case K_ILIST: {
		const pr_list *l = (const pr_list *)base;
		for (i = 0; i < l->n; ++i) {
			pr_csv_format_double(l->v[i], buf, sizeof buf);
			fprintf(fp, "%s%s", i ? "," : "", buf);
		}
		break;
	}
	}
}

/* The value of key k as pr_config_write writes it, malloc'd (NULL: no memory). */
static char *value_text(const pr_config *c, const key_def *k)
{
	char *buf = NULL;
	size_t n = 0;
	FILE *fp = open_memstream(&buf, &n);

	if (!fp)
		return NULL;
	write_value(c, k, fp);
	if (fclose(fp) != 0) {
		free(buf);
		return NULL;
	}
	return buf;
}

int pr_config_diff(const pr_config *a, const pr_config *b, const char *const *skip, char *key,
                   size_t nkey, char *va, char *vb, size_t n)
{
	size_t i, j;

	for (i = 0; i < NKEYS; ++i) {
		char *x, *y;
		int differ;
		snprintf(key, nkey, "%s.%s", keys[i].section, keys[i].key);
		for (j = 0; skip && skip[j] && strcmp(key, skip[j]) != 0; ++j)
			;
		if (skip && skip[j])
			continue;
		x = value_text(a, &keys[i]);
		y = value_text(b, &keys[i]);
		differ = !x || !y || strcmp(x, y) != 0;
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
	size_t i;

	for (i = 0; i < NKEYS; ++i) {
		if (strcmp(section, keys[i].section) != 0) {
			section = keys[i].section;
			fprintf(fp, "%s[%s]\n", i ? "\n" : "", section);
		}
		fprintf(fp, "%s = ", keys[i].key);
		write_value(c, &keys[i], fp);
		fputc('\n', fp);
	}
	return ferror(fp) ? PR_EIO : PR_OK;
}

void pr_config_help(FILE *fp)
{
	pr_config c;
	char lo[40], hi[40];
	size_t i;

	pr_config_init(&c);
	fprintf(fp, "Parameter keys (section.key = default [unit] range: meaning):\n");
	for (i = 0; i < NKEYS; ++i) {
		const key_def *k = &keys[i];
		char name[64];
		snprintf(name, sizeof name, "%s.%s", k->section, k->key);
		fprintf(fp, "  %-26s = ", name);
		write_value(&c, k, fp);
		if (k->type == K_ENUM || k->type == K_NAME || k->type == K_NAMES) {
			fprintf(fp, "  {%s}", k->unit);
		} else if (k->type != K_POCKETS && k->type != K_BOX) {
			pr_csv_format_double(k->lo, lo, sizeof lo);
			pr_csv_format_double(k->hi, hi, sizeof hi);
			if (k->unit[0])
				fprintf(fp, " %s", k->unit);
			fprintf(fp, "  %s%s..%s%s%s", k->lo_open & OPEN_LO ? "(" : "[", lo, hi,
			        k->lo_open & OPEN_HI ? ")" : "]", k->type == K_ILIST ? " whole numbers" : "");
		} else if (k->unit[0]) {
			fprintf(fp, " %s", k->unit);
		}
		fprintf(fp, ": %s\n", k->help);
	}
}
