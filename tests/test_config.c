/* test_config.c — parameter files, --set and validation. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "poolreps/bench.h"
#include "poolreps/config.h"
#include "poolreps/exp.h"
#include "exp_priv.h"

static char path[64];

static const pr_bench_opts *bench(const pr_config *c)
{
	return pr_config_opts(c, &pr_bench_keys);
}

static const char *write_ini(const char *text)
{
	FILE *fp;

	snprintf(path, sizeof path, "/tmp/pr_test_config_%ld.ini", (long)getpid());
	fp = fopen(path, "w");
	assert_non_null(fp);
	fputs(text, fp);
	fclose(fp);
	return path;
}

static int load(const char *text, pr_config *c, char *err)
{
	pr_config_init(c, pr_exp_config);
	return pr_config_load(c, write_ini(text), err);
}

static void test_defaults_match_spec(void **state)
{
	pr_config c;

	(void)state;
	pr_config_init(&c, pr_exp_config);
	assert_float_equal(c.table.length, 1.0, 0);
	assert_float_equal(c.table.width, 0.5, 0);
	assert_float_equal(c.table.ball_radius, 0.015, 0);
	assert_float_equal(c.table.pocket_radius, 0.03, 0);
	assert_float_equal(c.table.restitution, 0.8, 0);
	assert_float_equal(c.table.friction, 0.25, 0);
	assert_float_equal(c.table.stop_speed, 0.002, 0);
	assert_int_equal(c.table.reward_balls, 1);
	assert_int_equal(c.sim.mode, PR_SIM_EVENT);
	assert_float_equal(c.sim.dt, 0.001, 0);
	assert_float_equal(c.sim.max_time, 120, 0);
	assert_int_equal(c.sim.max_events, 10000);
	assert_int_equal(c.reward.ntargets, 2);
	assert_int_equal(c.reward.targets[0], 2);
	assert_int_equal(c.reward.targets[1], 5);
	assert_float_equal(c.reward.miss_penalty, 10, 0);
	assert_float_equal(c.reward.scratch_penalty, 0, 0);
	assert_float_equal(((const pr_exp1_opts *)pr_config_opts(&c, &pr_exp1_keys))->aim_speed, 0.4, 0);
	assert_float_equal(c.expert.arrival_speed, 0.05, 0);
	assert_float_equal(c.reps.epsilon, 0.5, 0);
	assert_float_equal(c.policy.lambda, 1e-10, 0);
	assert_int_equal(pr_config_validate(&c, NULL), PR_OK);
}

static void test_load_values(void **state)
{
	pr_config c;
	char err[PR_ERRLEN];

	(void)state;
	assert_int_equal(load("; comment\n# another\n[table]\nfriction = 0.5 ; inline\r\n"
	                      "[sim]\nmode = stepped\ndt=0.0005\n[reward]\ntargets = 0, 3\n"
	                      "[start]\nreward_box = 0.05,0.15,-0.1,0.1\n", &c, err), PR_OK);
	assert_float_equal(c.table.friction, 0.5, 0);
	assert_int_equal(c.sim.mode, PR_SIM_STEPPED);
	assert_float_equal(c.sim.dt, 0.0005, 0);
	assert_int_equal(c.reward.ntargets, 2);
	assert_int_equal(c.reward.targets[1], 3);
	assert_float_equal(c.start.reward_box[1], 0.15, 0);
}

static void expect_error(const char *text, int status, const char *needle)
{
	pr_config c;
	char err[PR_ERRLEN] = "";

	assert_int_equal(load(text, &c, err), status);
	if (!strstr(err, needle))
		fail_msg("error '%s' lacks '%s'", err, needle);
	assert_null(strchr(err, '\n'));
}

static void test_errors_name_line_and_key(void **state)
{
	(void)state;
	expect_error("[table]\nfriction = 0.5\nfrictoin = 1\n", PR_EINVAL, ":3: table.frictoin: unknown key");
	expect_error("[tabel]\nfriction = 0.5\n", PR_EINVAL, ":1: [tabel]: unknown section");
	expect_error("[table]\n\nfriction = abc\n", PR_EINVAL, ":3: table.friction: not a finite number");
	expect_error("[table]\nfriction = nan\n", PR_EINVAL, ":2: table.friction");
	expect_error("[table]\nfriction = inf\n", PR_EINVAL, ":2: table.friction");
	expect_error("[table]\nfriction = 1e999\n", PR_EINVAL, ":2: table.friction");
	expect_error("[table]\nfriction = -1\n", PR_EINVAL, ":2: table.friction: -1 out of range");
	expect_error("[forest]\ntrees = 1000000000000\n", PR_EINVAL, ":2: forest.trees");
	expect_error("[forest]\ntrees = 3.5\n", PR_EINVAL, ":2: forest.trees: not an integer");
	expect_error("[table]\nfriction = 0.3\nfriction = 0.4\n", PR_EINVAL,
	             ":3: table.friction: duplicate key (first set on line 2)");
	expect_error("friction = 0.3\n", PR_EINVAL, ":1: friction: key outside any [section]");
	expect_error("[table]\njust some words\n", PR_EINVAL, ":2: syntax error");
	expect_error("[sim]\nmode = fast\n", PR_EINVAL, ":2: sim.mode: 'fast' is not one of event|stepped");
	expect_error("[reward]\ntargets = 2,7\n", PR_EINVAL, ":2: reward.targets");
	expect_error("[start]\nreward_box = 0.1,0.05,0,0\n", PR_EINVAL, ":2: start.reward_box");
}

static void test_long_line_and_missing_file(void **state)
{
	pr_config c;
	char err[PR_ERRLEN], *text = malloc(10000);

	(void)state;
	assert_non_null(text);
	strcpy(text, "[table]\nfriction = 0.");
	memset(text + strlen(text), '1', 8000);
	strcpy(text + strlen("[table]\nfriction = 0.") + 8000, "\n");
	expect_error(text, PR_EINVAL, ":2: line longer than");
	free(text);
	pr_config_init(&c, pr_exp_config);
	assert_int_equal(pr_config_load(&c, "/nonexistent/x.ini", err), PR_EIO);
	assert_non_null(strstr(err, "/nonexistent/x.ini: cannot open"));
	assert_int_equal(pr_config_load(&c, "/tmp", err), PR_EIO);
	assert_non_null(strstr(err, "is a directory"));
}

static void test_set_and_validate(void **state)
{
	pr_config c;
	char err[PR_ERRLEN];

	(void)state;
	pr_config_init(&c, pr_exp_config);
	assert_int_equal(pr_config_set(&c, "reps.epsilon=0.25", err), PR_OK);
	assert_float_equal(c.reps.epsilon, 0.25, 0);
	assert_int_equal(pr_config_set(&c, "reps.epsilon=0", err), PR_EINVAL);
	assert_non_null(strstr(err, "--set: reps.epsilon"));
	assert_int_equal(pr_config_set(&c, "reps.epsilonx=1", err), PR_EINVAL);
	assert_int_equal(pr_config_set(&c, "noequals", err), PR_EINVAL);
	assert_int_equal(pr_config_set(&c, "table.reward_balls=2", err), PR_OK);
	assert_int_equal(pr_config_validate(&c, err), PR_EINVAL);
	assert_non_null(strstr(err, "table.reward_balls"));
	pr_config_init(&c, pr_exp_config);
	assert_int_equal(pr_config_set(&c, "start.reward_box=0.4,0.6,0,0.1", err), PR_OK);
	assert_int_equal(pr_config_validate(&c, err), PR_EINVAL);
	assert_non_null(strstr(err, "start.reward_box"));
}

/* Cross-key errors say where the offending key was set: a file line,
 * --set, or for a default the file as a whole; bench.* defaults follow
 * experiment.name unless a bench key was set. */
static void test_where_and_bench_defaults(void **state)
{
	pr_config c;
	char err[PR_ERRLEN], at[320], want[320];

	(void)state;
	assert_int_equal(load("[experiment]\nname = quadratic\n\n[table]\nreward_balls = 2\n", &c, err),
	                 PR_OK);
	assert_int_equal(bench(&c)->iterations, 40);
	assert_int_equal(bench(&c)->dims, 1);
	snprintf(want, sizeof want, "%s:5", path);
	assert_string_equal(pr_config_where(&c, "table.reward_balls", at, sizeof at), want);
	assert_string_equal(pr_config_where(&c, "table.balls", at, sizeof at), path);
	assert_int_equal(pr_config_validate(&c, err), PR_EINVAL);
	snprintf(want, sizeof want, "%s:5: table.reward_balls", path);
	assert_non_null(strstr(err, want));
	assert_int_equal(pr_config_set(&c, "table.reward_balls=1", err), PR_OK);
	assert_string_equal(pr_config_where(&c, "table.reward_balls", at, sizeof at), "--set");
	assert_int_equal(pr_config_set(&c, "bench.iterations=7", err), PR_OK);
	assert_int_equal(pr_config_set(&c, "experiment.name=rosenbrock", err), PR_OK);
	assert_int_equal(bench(&c)->iterations, 7);
	assert_int_equal(bench(&c)->dims, 20);
	assert_int_equal(bench(&c)->context_dims, 1);
	pr_config_init(&c, pr_exp_config);
	assert_string_equal(pr_config_where(&c, "sim.dt", at, sizeof at), "defaults");
}

/* A file naming only the experiment gets that experiment's setup (what
 * data/<name>.ini states); a key given anywhere, before or after the name,
 * keeps its value; renaming restores the other defaults. */
static void test_experiment_defaults(void **state)
{
	pr_config c;
	char err[PR_ERRLEN];

	(void)state;
	assert_int_equal(load("[start]\ncue_box = -0.2,-0.2,0,0\n[value]\nn_min = 33\n"
	                      "[experiment]\nname = exp3\n", &c, err), PR_OK);
	assert_float_equal(c.start.reward_box[1], 0.15, 0);
	assert_float_equal(c.start.reward_box[2], -0.1, 0);
	assert_float_equal(c.start.cue_box[0], -0.2, 0);
	assert_int_equal(c.value.trees, 10);
	assert_int_equal(c.value.n_min, 33);
	assert_int_equal(c.value.score, PR_SCORE_NRVR);
	assert_int_equal(c.policy.forest.trees, 10);
	assert_int_equal(pr_config_set(&c, "experiment.name=exp2", err), PR_OK);
	assert_float_equal(c.start.reward_box[1], 0.45, 0);
	assert_int_equal(c.value.score, PR_SCORE_RVR);
	assert_int_equal(c.value.n_min, 33);
	assert_int_equal(c.policy.forest.trees, 30);
	assert_int_equal(c.policy.forest.cuts, 10);
	assert_int_equal(pr_config_set(&c, "experiment.name=sphere", err), PR_OK);
	assert_float_equal(c.reps.epsilon, 1, 0);
	assert_int_equal(c.policy.forest.trees, 10);
}

static void test_write_round_trip(void **state)
{
	pr_config a, b;
	char err[PR_ERRLEN];
	FILE *fp;

	(void)state;
	pr_config_init(&a, pr_exp_config);
	assert_int_equal(pr_config_set(&a, "table.friction=0.123456789012345", err), PR_OK);
	assert_int_equal(pr_config_set(&a, "policy.target=reward_state", err), PR_OK);
	snprintf(path, sizeof path, "/tmp/pr_test_config_rt_%ld.ini", (long)getpid());
	fp = fopen(path, "w");
	assert_non_null(fp);
	assert_int_equal(pr_config_write(&a, fp), PR_OK);
	fclose(fp);
	pr_config_init(&b, pr_exp_config);
	assert_int_equal(pr_config_load(&b, path, err), PR_OK);
	unlink(path);
	assert_float_equal(b.table.friction, 0.123456789012345, 0);
	assert_int_equal(b.policy.target, PR_TARGET_REWARD_STATE);
	assert_memory_equal(&a.reward, &b.reward, sizeof a.reward);
	assert_memory_equal(&a.start, &b.start, sizeof a.start);
}

/* The public accessors: the checks and messages of --set, exact numbers. */
static void test_accessors_by_key(void **state)
{
	pr_config *c = pr_config_new(), *d = pr_config_new();
	char err[PR_ERRLEN], want[PR_ERRLEN], buf[64], where[PR_WHERE_LEN];
	double v;

	(void)state;
	assert_non_null(c);
	assert_non_null(d);
	assert_int_equal(pr_config_get_double(c, "reps.epsilon", &v, err), PR_OK);
	assert_true(v == c->reps.epsilon);
	assert_int_equal(pr_config_set_double(c, "reps.epsilon", 0.1 + 0.2, err), PR_OK);
	assert_true(c->reps.epsilon == 0.1 + 0.2);
	assert_int_equal(pr_config_get_double(c, "reps.epsilon", &v, err), PR_OK);
	assert_true(v == 0.1 + 0.2);
	assert_string_equal(pr_config_where(c, "reps.epsilon", where, sizeof where), "--set");
	/* a bad value: --set's status and message, the value unchanged */
	assert_int_equal(pr_config_set_double(c, "reps.epsilon", -1, err), PR_EINVAL);
	assert_int_equal(pr_config_set(d, "reps.epsilon=-1", want), PR_EINVAL);
	assert_string_equal(err, want);
	assert_true(c->reps.epsilon == 0.1 + 0.2);
	assert_int_equal(pr_config_set_double(c, "table.balls", 2.5, err), PR_EINVAL);
	assert_int_equal(pr_config_set(d, "table.balls=2.5", want), PR_EINVAL);
	assert_string_equal(err, want);
	assert_int_equal(pr_config_set_double(c, "reps.epsilon", 1.0 / 0.0, err), PR_EINVAL);
	assert_non_null(strstr(err, "reps.epsilon: not a finite number"));
	assert_int_equal(pr_config_set_double(c, "table.balls", 3, err), PR_OK);
	assert_int_equal(c->table.balls, 3);
	/* text keys, and numbers read as text in the file's form */
	assert_int_equal(pr_config_set_string(c, "sim.mode", "stepped", err), PR_OK);
	assert_int_equal(pr_config_get_string(c, "sim.mode", buf, sizeof buf, err), PR_OK);
	assert_string_equal(buf, "stepped");
	assert_int_equal(pr_config_get_double(c, "sim.mode", &v, err), PR_EINVAL);
	assert_non_null(strstr(err, "sim.mode: not a number key"));
	assert_int_equal(pr_config_set_string(c, "sim.mode", "fast", err), PR_EINVAL);
	assert_int_equal(pr_config_set(d, "sim.mode=fast", want), PR_EINVAL);
	assert_string_equal(err, want);
	assert_int_equal(pr_config_get_string(c, "reps.epsilon", buf, sizeof buf, err), PR_OK);
	assert_string_equal(buf, "0.30000000000000004");
	assert_int_equal(pr_config_get_string(c, "sim.mode", buf, 7, err), PR_EINVAL);
	assert_non_null(strstr(err, "does not fit"));
	/* whole numbers, as numbers and as text */
	assert_int_equal(pr_config_set_string(c, "experiment.seed", "4294967295", err), PR_OK);
	assert_int_equal(pr_config_get_double(c, "experiment.seed", &v, err), PR_OK);
	assert_true(v == 4294967295.0);
	assert_int_equal(pr_config_set_double(c, "sim.max_events", 1e9, err), PR_OK);
	assert_int_equal(pr_config_get_string(c, "sim.max_events", buf, sizeof buf, err), PR_OK);
	assert_string_equal(buf, "1000000000");
	assert_int_equal(pr_config_set_double(c, "experiment.seed", 4294967296.0, err), PR_EINVAL);
	assert_int_equal(pr_config_set(d, "experiment.seed=4294967296", want), PR_EINVAL);
	assert_string_equal(err, want);
	/* unknown keys, also one that would split into another assignment */
	assert_int_equal(pr_config_get_double(c, "reps.nope", &v, err), PR_EINVAL);
	assert_non_null(strstr(err, "reps.nope: unknown key"));
	assert_int_equal(pr_config_get_string(c, "nodot", buf, sizeof buf, err), PR_EINVAL);
	assert_int_equal(pr_config_set_string(c, "sim.mode=stepped", "x", err), PR_EINVAL);
	assert_int_equal(pr_config_set_string(c, "sim.nope", "1", err), PR_EINVAL);
	assert_int_equal(pr_config_validate(c, err), PR_OK);
	pr_config_free(c);
	pr_config_free(d);
	pr_config_free(NULL);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_defaults_match_spec),
		cmocka_unit_test(test_load_values),
		cmocka_unit_test(test_errors_name_line_and_key),
		cmocka_unit_test(test_long_line_and_missing_file),
		cmocka_unit_test(test_set_and_validate),
		cmocka_unit_test(test_where_and_bench_defaults),
		cmocka_unit_test(test_experiment_defaults),
		cmocka_unit_test(test_write_round_trip),
		cmocka_unit_test(test_accessors_by_key),
	};
	int rc = cmocka_run_group_tests(tests, NULL, NULL);
	unlink(path);
	return rc;
}
