/* bench_sim.c — simulator throughput (shots per second), single thread.
 *
 *   bench_sim --mode event|stepped --actions gauss|uniform [--dt S] [--shots N]
 *             [--runs K] [--seed S] [--law exponential|constant|slide_roll]
 *
 * Two-ball shots from Experiment 3's start region (cue ball at (-0.25, 0),
 * reward ball uniform in [0.05,0.15]x[-0.1,0.1]). Actions: "gauss" draws
 * N(0, 0.1^2 I), Experiment 3's initial policy; "uniform" a uniform
 * direction and a speed uniform in [0, 1.5] m/s. States and actions are drawn
 * before the clock starts (a pool of 65536 shots, reused cyclically), no
 * trace is recorded, and the result is only summed so the work is not
 * optimised away. --law picks table.friction_law (each law at its default
 * coefficients). Prints one line of key=value pairs with the median of the
 * runs. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "poolreps/sim.h"
#include "bench_util.h"

#define POOL 65536

static const char *const laws[] = {"exponential", "constant", "slide_roll"}; /* PR_FRICTION_* */

/* PR_FRICTION_* of name; the exponential law if it is none */
static int law_id(const char *name)
{
	int i;

	for (i = 0; i < (int)(sizeof laws / sizeof *laws); ++i)
		if (!strcmp(name, laws[i]))
			return i;
	return PR_FRICTION_EXPONENTIAL;
}

static const char *law_name(int id)
{
	return laws[id];
}

int main(int argc, char **argv)
{
	static const struct option opts[] = {
		{"mode", required_argument, NULL, 'm'}, {"actions", required_argument, NULL, 'a'},
		{"dt", required_argument, NULL, 'd'},   {"shots", required_argument, NULL, 'n'},
		{"runs", required_argument, NULL, 'r'}, {"seed", required_argument, NULL, 's'},
		{"law", required_argument, NULL, 'l'},  {NULL, 0, NULL, 0}};
	pr_table t;
	pr_sim_opts o;
	pr_start_opts so;
	pr_sim *sim;
	gsl_rng *rng;
	char err[PR_ERRLEN];
	const char *actions = "gauss";
	long shots = 1000000, i, events = 0;
	int runs = 5, k, c;
	unsigned long seed = 1;
	double *st, *act, *rate, sink = 0;

	pr_sim_table_init(&t);
	pr_sim_opts_init(&o);
	pr_sim_start_opts_init(&so);
	while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
		switch (c) {
		case 'm': o.mode = strcmp(optarg, "stepped") ? PR_SIM_EVENT : PR_SIM_STEPPED; break;
		case 'a': actions = optarg; break;
		case 'd': o.dt = strtod(optarg, NULL); break;
		case 'n': shots = strtol(optarg, NULL, 10); break;
		case 'r': runs = (int)strtol(optarg, NULL, 10); break;
		case 's': seed = strtoul(optarg, NULL, 10); break;
		case 'l':
			t.friction_law = law_id(optarg);
			break;
		default: return 1;
		}
	}
	if (shots < 1 || runs < 1)
		return 1;
	gsl_set_error_handler_off();
	so.reward_box[0] = 0.05;
	so.reward_box[1] = 0.15;
	so.reward_box[2] = -0.1;
	so.reward_box[3] = 0.1;
	rng = gsl_rng_alloc(gsl_rng_mt19937);
	sim = pr_sim_new(&t, &o, err);
	st = malloc(POOL * 4 * sizeof *st);
	act = malloc(POOL * 2 * sizeof *act);
	rate = malloc((size_t)runs * sizeof *rate);
	if (!rng || !sim || !st || !act || !rate) {
		fprintf(stderr, "bench_sim: %s\n", sim ? "out of memory" : err);
		return 1;
	}
	gsl_rng_set(rng, seed);
	for (i = 0; i < POOL; ++i) {
		if (pr_sim_sample_start(&t, &so, 2, rng, st + 4 * i, err)) {
			fprintf(stderr, "bench_sim: %s\n", err);
			return 1;
		}
		if (!strcmp(actions, "uniform")) {
			double ang = 6.283185307179586 * gsl_rng_uniform(rng), v = 1.5 * gsl_rng_uniform(rng);
			act[2 * i] = v * cos(ang);
			act[2 * i + 1] = v * sin(ang);
		} else {
			act[2 * i] = gsl_ran_gaussian(rng, 0.1);
			act[2 * i + 1] = gsl_ran_gaussian(rng, 0.1);
		}
	}
	for (k = 0; k < runs; ++k) {
		double t0 = bench_now();
		events = 0;
		for (i = 0; i < shots; ++i) {
			pr_shot r;
			long j = i % POOL;
			if (pr_sim_shoot(sim, st + 4 * j, 2, act + 2 * j, &r, NULL, err)) {
				fprintf(stderr, "bench_sim: shot %ld: %s\n", j, err);
				return 1;
			}
			sink += r.final[2];
			events += r.events;
		}
		rate[k] = (double)shots / (bench_now() - t0);
	}
	qsort(rate, (size_t)runs, sizeof *rate, bench_cmp);
	printf("mode=%s law=%s actions=%s dt=%g shots=%ld runs=%d median_shots_per_s=%.0f min=%.0f max=%.0f "
	       "events_per_shot=%.2f checksum=%.6g\n", o.mode == PR_SIM_EVENT ? "event" : "stepped",
	       law_name(t.friction_law), actions, o.dt, shots, runs, rate[runs / 2], rate[0], rate[runs - 1],
	       (double)events / (double)shots, sink);
	pr_sim_free(sim);
	gsl_rng_free(rng);
	free(st);
	free(act);
	free(rate);
	return 0;
}
