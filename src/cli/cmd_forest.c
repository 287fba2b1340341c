/* cmd_forest.c — `poolreps forest`: fit extra trees on one CSV,
 * predict another.
 *
 * Inputs are every training column except the targets (--target, a comma
 * list or a prefix ending in '*') and the weight column (--weight). The test
 * CSV must hold the input columns by name; if it also holds every target,
 * the test MSE is reported. Output: one pred_<target> column per target, one
 * row per test row; --leaves FILE: columns tree0..tree{M-1}, each test row's
 * active leaf, numbered within its tree. Options come from cfg->forest and
 * the seed from cfg->run.seed. The test CSV is streamed (pr_query_forest):
 * its header is checked before the fit, its rows are predicted chunk by
 * chunk after it; on an error no output file is left. The timings and the test MSE go into
 * a->note, which the CLI prints after a success. --save FILE writes the
 * fitted forest with its column names (pr_forest_save); --load FILE reads
 * one instead of fitting and finds its input columns in the test CSV.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <sys/stat.h>

#include <gsl/gsl_rng.h>

#include "poolreps/csvio.h"
#include "poolreps/forest.h"
#include "poolreps/query.h"
#include "poolreps/internal.h"
#include "cli.h"

/* The options of `poolreps forest` (its table: cli_forest below). */
typedef struct {
	const char *output, *train, *test, *target, *weight, *leaves;
	const char *save, *load; /* --save FILE, --load FILE: a fitted forest */
	int quiet;
	char *note; /* the timings and the test MSE, printed after a success */
} forest_args;

static double seconds(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The training and test tables and the columns they play. */
typedef struct {
	pr_csv *tr;
	pr_query *te;       /* the test rows, streamed */
	int *tc, dy;        /* training targets */
	int *xc, dx;        /* training inputs: every other column but the weight */
	int wc;             /* training weight column, or -1 */
	const char **nm;    /* the input and target names, in the forest's order */
} tables;

static void tables_free(tables *t)
{
	pr_csv_free(t->tr);
	pr_query_free(t->te);
	free(t->tc);
	free(t->xc);
	free(t->nm);
}

/* Read both tables and find the columns: every check before any fit. */
static int read_tables(const pr_config *cfg, const forest_args *a, tables *t, char *err)
{
	int ncol, rc;
	long n;

	if ((rc = pr_csv_read(a->train, &t->tr, err)) || (rc = pr_cmd_check_rows(t->tr, err)))
		return rc;
	n = pr_csv_nrows(t->tr);
	ncol = pr_csv_ncols(t->tr);
	if (n < cfg->forest.n_c)
		return pr_err(err, PR_EINVAL, "%s: %ld rows, fewer than forest.n_c = %d",
		              pr_csv_path(t->tr), n, cfg->forest.n_c);
	if ((long long)n * cfg->forest.trees >= 2147483647LL)
		return pr_err(err, PR_EINVAL, "%s: %ld rows x forest.trees = %d is too large",
		              pr_csv_path(t->tr), n, cfg->forest.trees);
	if ((t->dy = pr_cmd_columns(t->tr, a->target, &t->tc, err)) < 0)
		return t->dy;
	for (int k = 0; k < t->dy; k++)
		for (int q = 0; q < k; q++)
			if (t->tc[q] == t->tc[k])
				return pr_err(err, PR_EINVAL, "%s: target column '%s' given twice",
				              pr_csv_path(t->tr), pr_csv_name(t->tr, t->tc[k]));
	t->wc = -1;
	if (a->weight && (t->wc = pr_cmd_column(t->tr, a->weight, "--weight", err)) < 0)
		return t->wc;
	for (int k = 0; k < t->dy; k++)
		if (t->tc[k] == t->wc)
			return pr_err(err, PR_EINVAL, "%s: column '%s' is both a target and the weight",
			              pr_csv_path(t->tr), a->weight);
	t->xc = malloc((size_t)ncol * sizeof *t->xc);
	t->nm = malloc((size_t)ncol * sizeof *t->nm);
	if (!t->xc || !t->nm)
		return pr_err(err, PR_ENOMEM, "forest: out of memory");
	for (int j = 0; j < ncol; j++) {
		int used = j == t->wc;
		for (int k = 0; k < t->dy; k++)
			used |= t->tc[k] == j;
		if (!used)
			t->xc[t->dx++] = j;
	}
	if (t->dx == 0)
		return pr_err(err, PR_EINVAL, "%s: no input columns besides the targets and weight",
		              pr_csv_path(t->tr));
	for (int j = 0; j < t->dx; j++)
		t->nm[j] = pr_csv_name(t->tr, t->xc[j]);
	for (int k = 0; k < t->dy; k++)
		t->nm[t->dx + k] = pr_csv_name(t->tr, t->tc[k]);
	return pr_query_open(a->test, t->nm, t->dx, "input", &t->te, err);
}

/* The forest's timings and, when the test table holds the targets, the
 * test MSE, as the command's note. */
static void note_fit(const forest_args *a, const pr_forest *f, const pr_query_stats *st, double tfit)
{
	int len = snprintf(a->note, PR_ERRLEN, "forest: %d trees, %d leaves, fit %.3f s, predict %.3f s",
	                   pr_forest_ntrees(f), pr_forest_nleaves(f), tfit, st->seconds);

	if (!st->have_y || st->rows == 0 || len <= 0 || len >= PR_ERRLEN)
		return;
	snprintf(a->note + len, (size_t)(PR_ERRLEN - len), ", test MSE %.6g", st->mse);
}

/* --save: the forest's text into its own output of the set. */
static int save_forest(pr_outset *set, const char *path, const pr_forest *f, const char **nm,
                       char *err)
{
	char *text = NULL;
	size_t len = 0;
	pr_csvw *w = NULL;
	int rc = pr_forest_to_text(f, nm, &text, &len, err);

	if (!rc && !(rc = pr_outset_add(set, path, &w, err)))
		rc = pr_csvw_raw(w, text, len);
	free(text);
	return rc;
}

/* The predictions (-o) and, with --leaves, the leaves of every test row,
 * into a new set that the caller commits; with save, the forest's file
 * joins the set first. */
static int write_outputs(const forest_args *a, pr_outset **set, const pr_forest *f,
                         const char **nm, int save, pr_query *te, pr_query_stats *st, char *err)
{
	pr_csvw *pw = NULL, *lw = NULL;
	int rc;

	if (!(*set = pr_outset_new(err)))
		return PR_ENOMEM;
	if ((rc = pr_outset_add(*set, a->output, &pw, err)) ||
	    (a->leaves && (rc = pr_outset_add(*set, a->leaves, &lw, err))) ||
	    (save && (rc = save_forest(*set, a->save, f, nm, err))))
		return rc;
	return pr_query_forest(te, f, nm + pr_forest_dx(f), pw, lw, st, err);
}

/* --load FILE: predict the test CSV with a saved forest. */
static int forest_loaded(const forest_args *a, char *err)
{
	pr_forest *f = NULL;
	pr_query *te = NULL;
	pr_query_stats st;
	pr_outset *set = NULL;
	char *text = NULL, **nm = NULL;
	size_t len = 0;
	int rc;

	if (a->train || a->target || a->weight || a->save)
		return pr_err(err, PR_EINVAL, "forest: --load takes no --train, --target, --weight or --save");
	if (!a->test)
		return pr_err(err, PR_EINVAL, "forest: --load needs --test");
	if ((rc = pr_cmd_read_whole(a->load, "poolreps-forest ", ":1: not a poolreps forest file",
	                             &text, &len, err)))
		return rc;
	if (!(f = pr_forest_load(text, len, a->load, &nm, err))) {
		rc = pr_out_of_memory ? PR_ENOMEM : strstr(err, "format version") ? PR_EINVAL : PR_EIO;
		goto done;
	}
	if (!(rc = pr_query_open(a->test, (const char *const *)nm, pr_forest_dx(f), "input", &te, err)))
		rc = write_outputs(a, &set, f, (const char **)nm, 0, te, &st, err);
done:
	rc = pr_outset_commit(set, rc, err);
	pr_forest_free(f);
	pr_query_free(te);
	free(text);
	free(nm);
	return rc;
}

static int pr_cmd_forest(const pr_config *cfg, const forest_args *a, char *err)
{
	tables t = { 0 };
	pr_forest *f = NULL;
	pr_outset *set = NULL;
	gsl_rng *rng = NULL;
	pr_query_stats st;
	double *X = NULL, *Y = NULL, *W = NULL;
	int rc;
	long n;
	double t0, tfit;

	if (a->load)
		return forest_loaded(a, err);
	if (!a->train || !a->test || !a->target)
		return pr_err(err, PR_EINVAL, "forest: --train, --test and --target are required");
	if ((rc = pr_forest_opts_check(&cfg->forest, "forest", err)) || (rc = read_tables(cfg, a, &t, err)))
		goto done;
	n = pr_csv_nrows(t.tr);
	if (!(X = pr_cmd_matrix(t.tr, t.xc, t.dx, err)) || !(Y = pr_cmd_matrix(t.tr, t.tc, t.dy, err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	if (t.wc >= 0 && (rc = pr_cmd_weights(t.tr, t.wc, a->weight, "weight", &W, err)))
		goto done;
	if (W)
		pr_forest_weights_canonical(W, (int)n);
	if (!(rng = gsl_rng_alloc(gsl_rng_mt19937))) {
		rc = pr_err(err, PR_ENOMEM, "forest: out of memory");
		goto done;
	}
	gsl_rng_set(rng, cfg->run.seed);
	t0 = seconds();
	f = pr_forest_fit(&cfg->forest, X, (int)n, t.dx, Y, t.dy, W, rng, err);
	tfit = seconds() - t0;
	if (!f) {
		/* the options and data were checked above: what is left is memory
		 * or an interruption */
		rc = pr_interrupted ? PR_EINTR : PR_ENOMEM;
		goto done;
	}
	/* predictions, leaves and the forest are committed together, only if
	 * all are complete */
	if ((rc = write_outputs(a, &set, f, t.nm, a->save != NULL, t.te, &st, err)))
		goto done;
	if (!a->quiet)
		note_fit(a, f, &st, tfit);
done:
	rc = pr_outset_commit(set, rc, err);
	pr_forest_free(f);
	gsl_rng_free(rng);
	tables_free(&t);
	free(X);
	free(Y);
	free(W);
	return rc;
}

static int forest_main(const pr_config *cfg, const void *opts, char *err)
{
	return pr_cmd_forest(cfg, opts, err);
}

static const cli_opt forest_opts[] = {
	CLI_COMMON_C, CLI_OPT("o", "OUT.csv", forest_args, output, "the predictions (default stdout)"),
	CLI_COMMON_SET, CLI_COMMON_SEED,
	CLI_OPT("train", "FILE", forest_args, train, "the training CSV"),
	CLI_OPT("test", "FILE", forest_args, test,
	        "the rows to predict: the input columns by name\n"
	        "(and, for the test MSE, every target)"),
	CLI_OPT("target", "COLS", forest_args, target,
	        "the targets: a comma list or a prefix ending in '*'"),
	CLI_OPT("weight", "COL", forest_args, weight, "the training rows' weights (default 1)"),
	CLI_OPT("leaves", "FILE", forest_args, leaves, "each test row's active leaf per tree"),
	CLI_OPT("save", "FOREST", forest_args, save,
	        "write the fitted forest (text, format version 1,\ndocs/forest.md)"),
	CLI_OPT("load", "FOREST", forest_args, load, "predict with a saved forest instead of fitting"),
	CLI_GIVEN(CLI_QUIET, forest_args, quiet), CLI_GIVEN(CLI_NOTE, forest_args, note), CLI_END
};

const cli_command cli_forest = {
	"forest",
	"poolreps forest --train FILE --test FILE --target COLS [--weight COL] [--leaves FILE]\n"
	"                [--save FOREST] [-o OUT.csv] [-c FILE] [--set forest.key=value]...\n"
	"  or:  poolreps forest --load FOREST --test FILE [--leaves FILE] [-o OUT.csv]\n"
	"  Fit extra trees on the training CSV (inputs = every other column), predict the\n"
	"  test CSV: one pred_<name> column per target. Timings and test MSE go to stderr\n"
	"  (not with -q).",
	forest_opts, sizeof(forest_args), "forest.,experiment.seed", CLI_OPS_NONE, 0, NULL, forest_main
};
