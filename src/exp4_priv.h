/* exp4_priv.h — Experiment 4 (beyond the thesis): Experiment 3's policies
 * started by imitation of the ghost-ball expert, then trained with
 * Experiment 3's REPS loop (exp3_priv.h). exp4.c runs it, exp4_out.c writes
 * the raw CSVs and the summaries (declared in exp_priv.h with the other
 * experiments' entry points).
 *
 * A variant is (policy, init, cov): a policy of exp3.policies; how its run
 * starts (exp4.inits: scratch = Experiment 3 itself, imitation = the policy
 * fitted to the demonstrations without REPS, demo = fitted policy + REPS
 * with the demonstrations as the first window, policy = fitted policy +
 * REPS with exp3.init_samples episodes of the fitted policy as the first
 * window); and the covariance of the tree policies (exp4.covs, policy.cov),
 * "none" for the hand-crafted linear-Gaussian policy, which has no such
 * choice and runs once. */
#ifndef POOLREPS_EXP4_PRIV_H
#define POOLREPS_EXP4_PRIV_H

#include "exp3_priv.h"

/* Keys exp4.*. */
typedef struct {
	int n_demo;            /* ghost-ball demonstrations per repetition */
	double demo_noise;     /* m/s: std of Gaussian noise on each action component */
	char inits[PR_KEY_NAMES_LEN]; /* comma list of PR_EXP4_INIT_* names */
	char covs[PR_KEY_NAMES_LEN];  /* comma list of policy.cov names */
	double fit_n_min_frac; /* tree fits to the demonstrations: n_min = frac * n_demo */
	int mean_eval;         /* start states each run's last policy is evaluated on (0: none) */
} pr_exp4_opts;
void pr_exp4_opts_init(pr_exp4_opts *o);
const pr_exp4_opts *pr_exp4_opts_of(const pr_config *cfg);

/* The controls refit (the policy start without REPS: pi_t refitted to the
 * window with the importance weights alone, at policy.n_min), matched
 * (the policy start with REPS, the tree policies refitted at pi_0's
 * resolution: n_min = fit_n_min_frac x exp3.window, as many leaves per
 * tree as pi_0 has) and refit_matched (refit at matched's resolution: what
 * matched is without REPS)
 * come after the four inits, so the others keep their stream ids. */
enum { PR_EXP4_SCRATCH, PR_EXP4_IMITATION, PR_EXP4_DEMO, PR_EXP4_POLICY, PR_EXP4_REFIT,
       PR_EXP4_MATCHED, PR_EXP4_REFIT_MATCHED, PR_EXP4_NINIT };
extern const char *const pr_exp4_init_name[PR_EXP4_NINIT];
/* Covariances: PR_COV_QUERY, PR_COV_RESIDUAL (policy.h), and none. */
enum { PR_EXP4_COV_NONE = 2, PR_EXP4_NCOV };
extern const char *const pr_exp4_cov_name[PR_EXP4_NCOV];

#define PR_EXP4_NVAR (PR_EXP3_NVAR * PR_EXP4_NINIT * PR_EXP4_NCOV)
typedef struct {
	int policy, init, cov;  /* PR_EXP3_*, PR_EXP4_INIT index, PR_COV_* or PR_EXP4_COV_NONE */
} pr_exp4_variant;

/* The indices in names[0..n) of the comma list s (checked by its key) into
 * out; returns their count. */
int pr_exp4_name_indices(const char *s, const char *const *names, int n, int *out);
/* Every variant of cfg in output order (policies, then covariances, then
 * inits); or, with experiment.variant = v >= 0, only variant v. */
int pr_exp4_list(const pr_config *cfg, int selected, pr_exp4_variant *var, int *nvar, char *err);
/* "nrvr_rs.demo.query" */
void pr_exp4_variant_label(const pr_exp4_variant *v, char *buf, size_t n);

/* The demonstrations of one repetition. */
typedef struct {
	int n, ds;
	double *S;        /* n x ds start states */
	double *A;        /* n x 2 actions shot (expert + noise) */
	double *E;        /* n x 2 the expert's actions */
	double *R;        /* n returns */
	double *F;        /* n x 2 final reward-ball positions */
	int *pocket, *hit;
} pr_exp4_demo;
void pr_exp4_demo_free(pr_exp4_demo *d);

/* The fitted policy against the expert on the evaluation states (the
 * repetition's first exp3.init_samples start states). */
typedef struct {
	int n, ds;
	double *S;        /* n x ds states */
	double *E;        /* n x 2 expert's actions */
	double *M;        /* n x 2 the fitted policy's mean actions */
	double *sd;       /* n x 2 its standard deviations along its principal axes, major first */
} pr_exp4_fit;
void pr_exp4_fit_free(pr_exp4_fit *f);

/* One (repetition, variant) run: its episodes (and REPS iterations, none
 * for imitation), the repetition's demonstrations if this run writes them
 * (the first variant that makes them), the fit rows if it is an imitation
 * run. */
typedef struct {
	int repetition;
	pr_exp4_variant var;
	pr_exp3_episodes ep;
	pr_exp4_demo demo;
	pr_exp4_fit fit;
	/* exp4.mean_eval > 0: the last policy's mean action on those states */
	int mean_n, mean_pocket, mean_hit; /* states, target pockets, hits */
	double mean_sum;       /* sum of their returns */
	int n_min, leaves;     /* the last policy's forest n_min and leaves (0: no forest) */
} pr_exp4_job;

/* Repetitions a summary tells apart. */
#define PR_EXP4_REPS_MAX 1000

/* Raw exp4_episodes.csv, exp4_reps.csv, exp4_demo.csv and exp4_fit.csv. */
int pr_exp4_write_raw(const pr_config *cfg, const pr_exp4_job *runs, int nruns, const char *dir,
                      char *err);

#endif
