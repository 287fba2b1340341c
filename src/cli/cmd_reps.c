/* cmd_reps.c — `poolreps reps`: REPS weights for a table of
 * samples.
 *
 * Input: one row per sample, with the return column (--return), the state
 * feature columns (--features, a comma list or a prefix ending in '*';
 * omitted = no features) and optionally base weights (--base). Output:
 * one column p, one row per input row, in input order. --summary FILE
 * writes one row eta,dual,kl,ess,bound,residual,iterations,kl_gap,
 * residual_rel,status (the certificate, reps.h), then rank,cond,path (the
 * solver path). A solve that cannot be
 * certified exits 3 with one line naming what failed (e.g. the feature
 * residual). Features that are all 0 or 1 take the solver's one-hot path
 * (reps.h). Every input check runs before anything is written;
 * on an error no file is left. An unreachable KL bound is no error: it is
 * said in a->note, which the CLI prints after a success.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "poolreps/csvio.h"
#include "poolreps/reps.h"
#include "cli.h"

/* The options of `poolreps reps` (its table: cli_reps below). */
typedef struct {
	const char *input, *output, *ret, *features, *base, *summary;
	double epsilon; /* --epsilon, used when epsilon_set */
	int epsilon_set;
	double threads; /* --threads, used when threads_set */
	int threads_set;
	char *note;     /* a remark (the KL bound unreachable) printed after a success */
} reps_args;

static int write_weights(pr_csvw *w, const pr_reps_result *r)
{
	int i, rc = pr_csvw_str(w, "p");

	if (!rc)
		rc = pr_csvw_endrow(w);
	for (i = 0; i < r->n && !rc; i++) {
		rc = pr_csvw_num(w, r->p[i]);
		if (!rc)
			rc = pr_csvw_endrow(w);
	}
	return rc;
}

static int write_summary(pr_csvw *w, const pr_reps_result *r)
{
	int rc = pr_csvw_header(w, "eta,dual,kl,ess,bound,residual,iterations,kl_gap,residual_rel,"
	                           "status,rank,cond,path");

	rc |= pr_csvw_num(w, r->eta);
	rc |= pr_csvw_num(w, r->dual);
	rc |= pr_csvw_num(w, r->kl);
	rc |= pr_csvw_num(w, r->ess);
	rc |= pr_csvw_int(w, r->bound);
	rc |= pr_csvw_num(w, r->residual);
	rc |= pr_csvw_int(w, r->iterations);
	rc |= pr_csvw_num(w, r->kl_gap);
	rc |= pr_csvw_num(w, r->residual_rel);
	rc |= pr_csvw_str(w, pr_reps_status_name(r->status));
	rc |= pr_csvw_int(w, r->rank);
	rc |= pr_csvw_num(w, r->cond);
	rc |= pr_csvw_str(w, r->path);
	return rc ? rc : pr_csvw_endrow(w);
}

/* The arrays of a REPS problem read from a table. */
typedef struct {
	double *R, *q, *phi;
	int *fc;            /* feature columns */
} arrays;

/* The REPS problem of table in: returns, base weights and features. */
static int read_problem(const reps_args *a, const pr_csv *in, pr_reps_problem *pb, arrays *m,
                        char *err)
{
	int rcol, bcol = -1, d = 0, j, rc;

	if ((rc = pr_cmd_check_rows(in, err)) || (rcol = pr_cmd_column(in, a->ret, "--return", err)) < 0)
		return rc ? rc : rcol;
	if (a->base && (bcol = pr_cmd_column(in, a->base, "--base", err)) < 0)
		return bcol;
	if (a->features && (d = pr_cmd_columns(in, a->features, &m->fc, err)) < 0)
		return d;
	for (j = 0; j < d; j++)
		if (m->fc[j] == rcol || m->fc[j] == bcol)
			return pr_err(err, PR_EINVAL, "%s: column '%s' is both a feature and the %s",
			              pr_csv_path(in), pr_csv_name(in, m->fc[j]),
			              m->fc[j] == rcol ? "return" : "base weight");
	if (!(m->R = pr_cmd_matrix(in, &rcol, 1, err)) ||
	    (d > 0 && !(m->phi = pr_cmd_matrix(in, m->fc, d, err))))
		return PR_ENOMEM;
	if ((rc = pr_cmd_weights(in, bcol, a->base, "base weight", &m->q, err)))
		return rc;
	pb->n = (int)pr_csv_nrows(in);
	pb->d = d;
	pb->R = m->R;
	pb->q = m->q;
	pb->phi = m->phi;
	return PR_OK;
}

static int pr_cmd_reps(const pr_config *cfg, const reps_args *a, char *err)
{
	pr_reps_opts o = cfg->reps;
	pr_reps_problem pb = { 0 };
	pr_reps_result *r = NULL;
	pr_csv *in = NULL;
	pr_outset *set = NULL;
	pr_csvw *w = NULL, *sw = NULL;
	arrays m = { NULL, NULL, NULL, NULL };
	int rc;

	if (a->epsilon_set) {
		o.epsilon = a->epsilon;
		if (!(o.epsilon >= PR_REPS_EPS_MIN) || !isfinite(o.epsilon))
			return pr_err(err, PR_EINVAL, "--epsilon (reps.epsilon): must be >= %g (got %g)",
			              PR_REPS_EPS_MIN, o.epsilon);
	}
	if (a->threads_set)
		o.threads = (int)a->threads;
	if (!a->ret)
		return pr_err(err, PR_EINVAL, "reps: --return COL is required");
	if ((rc = pr_csv_read(a->input, &in, err)) || (rc = read_problem(a, in, &pb, &m, err)) ||
	    (rc = pr_reps_solve(&o, &pb, &r, err)))
		goto done;
	if (r->status == PR_REPS_FAILED) {
		rc = pr_err(err, PR_ENUM, "reps: %s: no certified answer: %s", pr_csv_path(in), r->reason);
		goto done;
	}
	if (r->status == PR_REPS_UNREACHABLE)
		pr_err(a->note, PR_OK, "reps: KL bound unreachable: %s (KL = %.6g < epsilon = %g, eta = 0)",
		       r->constant ? "all returns are equal" :
		       "p is the eta -> 0 limit, the feature-matching solution closest to q",
		       r->kl, o.epsilon);
	/* weights and summary are committed together, only if both are complete */
	if (!(set = pr_outset_new(err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	if ((rc = pr_outset_add(set, a->output, &w, err)) ||
	    (a->summary && (rc = pr_outset_add(set, a->summary, &sw, err))))
		goto done;
	write_weights(w, r);
	if (sw)
		write_summary(sw, r);
done:
	rc = pr_outset_commit(set, rc, err);
	pr_reps_result_free(r);
	pr_csv_free(in);
	free(m.fc);
	free(m.R);
	free(m.q);
	free(m.phi);
	return rc;
}

static int reps_main(const pr_config *cfg, const void *opts, char *err)
{
	return pr_cmd_reps(cfg, opts, err);
}

/* --epsilon E: a number in [PR_REPS_EPS_MIN, 1e6] */
static const char *parse_epsilon(const char *arg, void *target)
{
	double *v = target;
	char *end;

	*v = strtod(arg, &end);
	return end == arg || *end || !(*v >= PR_REPS_EPS_MIN) || *v > 1e6 ?
	       "a number >= 1e-12 (reps.epsilon's least) and <= 1e6" : NULL;
}

/* --threads N: decimal digits only, 0 .. 64 */
static const char *parse_threads(const char *arg, void *target)
{
	double *v = target;
	const char *c;

	for (c = arg; *c >= '0' && *c <= '9'; c++)
		;
	if (c == arg || *c || c - arg > 2)
		return "an integer in 0 .. 64";
	*v = (double)atoi(arg);
	return *v > 64 ? "an integer in 0 .. 64" : NULL;
}

static const cli_opt reps_opts[] = {
	CLI_COMMON_C, CLI_OPT("i", "IN.csv", reps_args, input, "the samples (default stdin)"),
	CLI_OPT("o", "OUT.csv", reps_args, output, "column p, one row per input row (default stdout)"),
	CLI_COMMON_SET, CLI_OPT("return", "COL", reps_args, ret, "the returns"),
	CLI_OPT("features", "LIST", reps_args, features,
	        "the state features: a comma list of columns or a\n"
	        "prefix ending in '*' (none if omitted)"),
	CLI_OPT("base", "COL", reps_args, base, "base weights q (default 1)"),
	CLI_OPT_NUMBER("epsilon", "E", reps_args, epsilon, epsilon_set, parse_epsilon,
	               "the KL bound, > 0 and <= 1e6 (default reps.epsilon)"),
	CLI_OPT_NUMBER("threads", "N", reps_args, threads, threads_set, parse_threads,
	               "threads for a large problem's residuals and\n"
	               "for a wide dense problem's Hessian, 0 .. 64\n"
	               "(default 0: one per CPU, and no more than that;\n"
	               "the same bits for any N)"),
	CLI_OPT("summary", "FILE", reps_args, summary,
	        "one row eta,dual,kl,ess,bound,residual,iterations,\n"
	        "kl_gap,residual_rel,status,rank,cond,path"),
	CLI_GIVEN(CLI_NOTE, reps_args, note), CLI_END
};

const cli_command cli_reps = {
	"reps",
	"poolreps reps --return COL --features LIST [--base COL] [--epsilon E]\n"
	"              [--threads N] [--summary FILE] [-i IN.csv] [-o OUT.csv]\n"
	"  REPS weights p for every input row. The summary is the certificate: status is\n"
	"  active (|KL - epsilon| and the relative feature residual <= 1e-9), unreachable\n"
	"  (eta = 0: p is the eta -> 0 limit, KL < epsilon) or failed, which exits 3; rank,\n"
	"  cond and path say what the solver did (feature directions used, condition\n"
	"  estimate of its last Hessian, steps taken).",
	reps_opts, sizeof(reps_args), "reps.", CLI_OPS_NONE, 0, NULL, reps_main
};
