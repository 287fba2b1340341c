/* shoot.c — shoot a batch of shots with the poolreps simulator.
 *
 * Draws n start states from Experiment 3's start region (cue ball at
 * (-0.25, 0), reward ball in [0.05,0.15] x [-0.1,0.1]) and actions from
 * N(0, 0.3^2 I), simulates each shot in event mode, and prints one CSV row
 * per shot: the start, the action, reward ball 1's pocket and the reward.
 *
 *   cc shoot.c $(pkg-config --cflags --libs poolreps) -o shoot && ./shoot 5
 */
#include <stdio.h>
#include <stdlib.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "poolreps/sim.h"

int main(int argc, char **argv)
{
	int n = argc > 1 ? atoi(argv[1]) : 10, i;
	char err[PR_ERRLEN];
	pr_table table;
	pr_sim_opts opts;
	pr_reward_opts reward;
	pr_start_opts start;
	pr_sim *sim;
	gsl_rng *rng;

	gsl_set_error_handler_off(); /* the library checks every GSL status itself */

	/* defaults first (every option struct has an _init), then what differs */
	pr_sim_table_init(&table);
	pr_sim_opts_init(&opts);
	pr_sim_reward_opts_init(&reward);
	pr_sim_start_opts_init(&start);
	start.reward_box[0] = 0.05, start.reward_box[1] = 0.15;
	start.reward_box[2] = -0.1, start.reward_box[3] = 0.1;

	/* one simulator per thread: it owns a workspace reused by every shot */
	if (!(sim = pr_sim_new(&table, &opts, err)) || !(rng = gsl_rng_alloc(gsl_rng_mt19937))) {
		fprintf(stderr, "shoot: %s\n", sim ? "out of memory" : err);
		return 1;
	}
	gsl_rng_set(rng, 1); /* every random draw comes from a generator you seed */

	printf("x0,y0,x1,y1,vx,vy,pocket1,hit,reward\n");
	for (i = 0; i < n; i++) {
		double state[4], action[2];
		pr_shot shot;

		if (pr_sim_sample_start(&table, &start, 2, rng, state, err))
			break;
		action[0] = gsl_ran_gaussian(rng, 0.3);
		action[1] = gsl_ran_gaussian(rng, 0.3);
		/* a failed call returns a status and leaves a one-line message */
		if (pr_sim_shoot(sim, state, 2, action, &shot, NULL, err))
			break;
		printf("%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%d,%d,%.17g\n", state[0], state[1],
		       state[2], state[3], action[0], action[1], shot.pocket[1], shot.hit,
		       pr_sim_reward(&table, &reward, &shot));
	}
	pr_sim_free(sim);
	gsl_rng_free(rng);
	if (i < n) {
		fprintf(stderr, "shoot: shot %d: %s\n", i, err);
		return 1;
	}
	return 0;
}
