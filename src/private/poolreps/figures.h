/* figures.h — data for the simulator figures of thesis chapter 7. */
#ifndef POOLREPS_FIGURES_H
#define POOLREPS_FIGURES_H

#include "poolreps/config.h"

/* Write into directory dir (created if missing) the CSVs that
 * scripts/plot_sim_figures.py draws:
 *   fig7_table.csv       length,width,ball_radius,pocket_radius
 *   fig7_1_pockets.csv   pocket,x,y                  (Fig. 7.1)
 *   fig7_1_balls.csv     ball,role,x,y               a start state drawn from start.*
 *   fig7_2_reward.csv    vx,vy,reward,hit,pocket1    201 x 201 actions in [-1.5,1.5]^2,
 *                        cue (-0.25,0), reward ball (0.1,0) (Fig. 7.2)
 *   fig7_3_shots.csv     shot,pocket,vx,vy,reward    two zero-reward actions of that grid,
 *   fig7_3_trace.csv     shot,t,ball,x,y,vx,vy       into pockets 2 and 5 (Fig. 7.3)
 *   fig7_5_ghost.csv     the ghost-ball geometry of one drawn state (pr_sim_ghost;
 *                        aim_x,aim_y follow ghost.aim, entry_x,entry_y are the
 *                        target pocket's corridor entry either way), and
 *   fig7_5_trace.csv     t,ball,x,y,vx,vy of that shot (Fig. 7.5)
 * The rng is gsl_rng_mt19937 seeded with cfg->run.seed. Returns PR_OK or an
 * error status with err filled; a failed run leaves no partial CSV. */
int pr_exp_figures(const pr_config *cfg, const char *dir, char *err);

#endif
