/* bench_bind.c — pr_bind_shoot throughput from C: the loop poolreps.shoot
 * (Python) calls, without Python.
 *
 *   bench_bind [--shots N] [--runs K] [--seed S]
 *
 * The workload of bench_sim.c --mode event --actions gauss, drawn the same
 * way (the same 65536 shots for the same seed), tiled to N rows; each run is
 * one pr_bind_shoot call on all N rows (the simulator, the reward of
 * eq. 7.7, the outputs) into output arrays written once before the clock
 * starts (a C caller reusing its buffers; poolreps.shoot allocates new ones).
 * Prints one line of key=value pairs with the median of the runs, as
 * bench_sim does. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_randist.h>

#include "poolreps/bind.h"
#include "poolreps/internal.h"
#include "poolreps/sim.h"
#include "bench_util.h"

#define POOL 65536

int main(int argc, char **argv)
{
	static const struct option opts[] = {
		{"shots", required_argument, NULL, 'n'}, {"runs", required_argument, NULL, 'r'},
		{"seed", required_argument, NULL, 's'}, {NULL, 0, NULL, 0}};
	char err[PR_ERRLEN];
	pr_config *c = pr_config_new();
	gsl_rng *rng;
	long shots = 1000000, i, events = 0;
	int runs = 5, k, ch;
	unsigned long seed = 1;
	double *st, *act, *fin, *gap, *rew, *tend, *rate;
	int *pocket;
	unsigned char *hit;
	long *ev;

	while ((ch = getopt_long(argc, argv, "", opts, NULL)) != -1) {
		switch (ch) {
		case 'n': shots = strtol(optarg, NULL, 10); break;
		case 'r': runs = (int)strtol(optarg, NULL, 10); break;
		case 's': seed = strtoul(optarg, NULL, 10); break;
		default: return 1;
		}
	}
	pr_bind_init();
	/* Experiment 3's start boxes, as bench_sim.c sets them */
	if (!c || shots < 1 || runs < 1 || pr_config_set(c, "experiment.name=exp3", err))
		return 1;
	rng = pr_bind_rng_new(seed);
	st = malloc((size_t)shots * 4 * sizeof *st);
	act = malloc((size_t)shots * 2 * sizeof *act);
	fin = malloc((size_t)shots * 4 * sizeof *fin);
	gap = malloc((size_t)shots * sizeof *gap);
	rew = malloc((size_t)shots * sizeof *rew);
	tend = malloc((size_t)shots * sizeof *tend);
	pocket = malloc((size_t)shots * 2 * sizeof *pocket);
	hit = malloc((size_t)shots);
	ev = malloc((size_t)shots * sizeof *ev);
	rate = malloc((size_t)runs * sizeof *rate);
	if (!rng || !st || !act || !fin || !gap || !rew || !tend || !pocket || !hit || !ev || !rate)
		return 1;
	for (i = 0; i < shots; ++i) {
		if (i < POOL) { /* bench_sim.c's draws, in its order */
			if (pr_sim_sample_start(&c->table, &c->start, 2, rng, st + 4 * i, err)) {
				fprintf(stderr, "bench_bind: %s\n", err);
				return 1;
			}
			act[2 * i] = gsl_ran_gaussian(rng, 0.1);
			act[2 * i + 1] = gsl_ran_gaussian(rng, 0.1);
		} else {
			memcpy(st + 4 * i, st + 4 * (i % POOL), 4 * sizeof *st);
			memcpy(act + 2 * i, act + 2 * (i % POOL), 2 * sizeof *act);
		}
	}
	memset(fin, 0, (size_t)shots * 4 * sizeof *fin);
	memset(gap, 0, (size_t)shots * sizeof *gap);
	memset(rew, 0, (size_t)shots * sizeof *rew);
	memset(tend, 0, (size_t)shots * sizeof *tend);
	memset(pocket, 0, (size_t)shots * 2 * sizeof *pocket);
	memset(hit, 0, (size_t)shots);
	memset(ev, 0, (size_t)shots * sizeof *ev);
	for (k = 0; k < runs; ++k) {
		double t0 = bench_now();
		if (pr_bind_shoot(c, shots, 2, st, act, fin, pocket, hit, gap, rew, tend, ev, err)) {
			fprintf(stderr, "bench_bind: %s\n", err);
			return 1;
		}
		rate[k] = (double)shots / (bench_now() - t0);
	}
	for (i = 0; i < shots; ++i)
		events += ev[i];
	qsort(rate, (size_t)runs, sizeof *rate, bench_cmp);
	printf("mode=event actions=gauss shots=%ld runs=%d median_shots_per_s=%.0f min=%.0f max=%.0f "
	       "events_per_shot=%.2f\n", shots, runs, rate[runs / 2], rate[0], rate[runs - 1],
	       (double)events / (double)shots);
	pr_config_free(c);
	pr_bind_rng_free(rng);
	free(st), free(act), free(fin), free(gap), free(rew), free(tend), free(pocket), free(hit);
	free(ev), free(rate);
	return 0;
}
