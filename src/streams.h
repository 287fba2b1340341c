/* streams.h — every random-stream id of the experiments, in one place.
 *
 * An experiment draws only from pr_exp_rng(experiment.seed, stream, index)
 * (exp.h): the stream id names the purpose, the index the repetition (or
 * the setting). Two purposes must never share a stream, so the ids, and the
 * ranges that an id plus an offset covers, are disjoint; a new experiment
 * takes a new range here. Changing an id changes every number of the
 * outputs that draw from it (tests/data/quick_reproduce.sha256).
 * (The simulator figures and the forest, policy and shoot commands seed one
 * mt19937 with experiment.seed itself.) */
#ifndef POOLREPS_STREAMS_H
#define POOLREPS_STREAMS_H

enum {
	/* Experiment 1 (exp1.c) */
	PR_STREAM_EXP1_TRAIN = 0x1e101,    /* index 0: the training shots */
	PR_STREAM_EXP1_TEST = 0x1e102,     /* index 0: the test shots */
	PR_STREAM_EXP1_MAP = 0x1e104,      /* index k: repetition k's map forest */
	PR_STREAM_EXP1_SETTING = 0x1e110,  /* + sweep (0..2), index k * PR_LIST_MAX +
	                                    * position in the sweep's list: forest k
	                                    * of that setting */

	/* Experiment 2 (exp2.c); index k: repetition k. Policy fits and action
	 * draws get a stream per (size, policy), so a row does not depend on
	 * which other sizes the list holds. */
	PR_STREAM_EXP2_TRAIN = 0x2e201,    /* training states */
	PR_STREAM_EXP2_TEST = 0x2e202,     /* test states */
	PR_STREAM_EXP2_FIT = 0x2e210000,   /* + 4 * size + policy: a policy's fit */
	PR_STREAM_EXP2_DRAW = 0x6e210000,  /* + 4 * size + policy: its action draws */

	/* Experiment 3 (exp3.c, exp3_learn.c); index k: repetition k */
	PR_STREAM_EXP3_START = 0x3e30,     /* start states, shared by the variants */
	PR_STREAM_EXP3_INIT = 0x3e31,      /* pi_0's actions, shared by the variants */
	PR_STREAM_EXP3_LEARN = 0x3e40,     /* + variant (0..5): forests and later actions */

	/* Experiment 4 (exp4.c); index k: repetition k. Its scratch runs draw
	 * from Experiment 3's streams; the start states always do. */
	PR_STREAM_EXP4_DEMO = 0x4e40,      /* the demonstrations */
	PR_STREAM_EXP4_FIT = 0x4e50,       /* + policy kind (0..3): pi_0's forest */
	PR_STREAM_EXP4_INIT = 0x4e60,      /* + 3 * kind + cov (0..11): pi_0's iteration 0 */
	PR_STREAM_EXP4_LEARN = 0x4e80,     /* + variant id (0..107): forests and later actions */
	PR_STREAM_EXP4_MEAN = 0x4ef0,      /* the mean-action evaluation states */
	PR_STREAM_EXP4_LEARN_RM = 0x4f00,  /* + 3 * policy + cov (0..17): refit_matched's */

	/* REPS benchmarks (exp_bench.c); index k: repetition k */
	PR_STREAM_BENCH = 0xbe4c4
};

#endif
