/* shotparams.h — physics and reward parameters that vary from shot to shot.
 *
 * A batch of shots (pr_bind_shoot_params, `poolreps shoot` with key
 * columns) may give number keys of the sections table, sim and reward one
 * value per row: row r is shot as if those keys had been set with --set to
 * its values, bit for bit, and refused as --set would refuse them. The
 * values go into a copy of the configuration (a parameter struct per row);
 * the simulator is rebuilt only when a row's values differ from the
 * previous row's, so the engines never see per-row parameters.
 */
#ifndef POOLREPS_SHOTPARAMS_H
#define POOLREPS_SHOTPARAMS_H

#include "poolreps/config.h"
#include "poolreps/sim.h"

typedef struct pr_shot_params pr_shot_params;

/* Per-row values for the nkeys keys ("section.key"); nkeys may be 0 (every
 * row shot with c). NULL and err for a key that is unknown, not a number,
 * outside table., sim. and reward., or given twice, and for a c the
 * simulator refuses. */
pr_shot_params *pr_shot_params_new(const pr_config *c, int nkeys, const char *const *keys,
                                   char *err);
void pr_shot_params_free(pr_shot_params *p);
/* The simulator for one row's values (nkeys numbers in the order of keys;
 * ignored when nkeys is 0), owned by p and valid until the next call; NULL
 * and err (the status in *rc) for a value --set would refuse. */
pr_sim *pr_shot_params_row(pr_shot_params *p, const double *values, int *rc, char *err);
/* The configuration of the last row (its table and reward keys). */
const pr_config *pr_shot_params_config(const pr_shot_params *p);

#endif
