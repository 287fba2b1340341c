/* cmd_forest.c — `poolreps forest`: fit extra trees on one CSV,
 * predict another.
 *
 * Inputs are every training column except the targets (--target, a comma
 * list or a prefix ending in '*') and the weight column (--weight). The test
 * CSV must hold the input columns by name; if it also holds every target,
 * the test MSE is reported. Output: one pred_<target> column per target, one
 * row per test row; --leaves FILE: columns tree0..tree{M-1}, each test row's
 * active leaf, numbered within its tree. Options come from cfg->forest and
 * the seed from cfg->run.seed. Every check runs before anything is written;
 * on an error no output file is left. The timings and the test MSE go into
 * a->note, which the CLI prints after a success. --save FILE writes the
 * fitted forest with its column names (pr_forest_save); --load FILE reads
 * one instead of fitting and finds its input columns in the test CSV.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <gsl/gsl_rng.h>

#include "poolreps/csvio.h"
#include "poolreps/forest.h"
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

static int write_pred(pr_csvw *w, const char *const *ynames, int dy, const double *P, long nt)
{
	char name[PR_CSV_MAX_FIELD + sizeof "pred_"];
	int rc = 0;

	for (int k = 0; k < dy && !rc; k++) {
		snprintf(name, sizeof name, "pred_%s", ynames[k]);
		rc = pr_csvw_str(w, name);
	}
	if (!rc)
		rc = pr_csvw_endrow(w);
	for (long i = 0; i < nt && !rc; i++) {
		for (int k = 0; k < dy && !rc; k++)
			rc = pr_csvw_num(w, P[(size_t)i * dy + k]);
		if (!rc)
			rc = pr_csvw_endrow(w);
	}
	return rc;
}

/* Each test row's active leaf per tree, as a leaf index within the tree. */
static int write_leaves(pr_csvw *w, const pr_forest *f, const double *Xt, int dx, long nt,
                        int *act)
{
	char name[32];
	int M = pr_forest_ntrees(f), rc = 0;

	for (int t = 0; t < M && !rc; t++) {
		snprintf(name, sizeof name, "tree%d", t);
		rc = pr_csvw_str(w, name);
	}
	if (!rc)
		rc = pr_csvw_endrow(w);
	for (long i = 0; i < nt && !rc; i++) {
		int c = pr_forest_active(f, Xt + (size_t)i * dx, dx, act, M);
		if (c != M)
			return PR_EINVAL;
		for (int t = 0; t < M && !rc; t++)
			rc = pr_csvw_int(w, act[t] - pr_forest_tree_leaf0(f, t));
		if (!rc)
			rc = pr_csvw_endrow(w);
	}
	return rc;
}

/* The training and test tables and the columns they play. */
typedef struct {
	pr_csv *tr, *te;
	int *tc, dy;        /* training targets */
	int *xc, dx;        /* training inputs: every other column but the weight */
	int wc;             /* training weight column, or -1 */
	int *xt, *yt;       /* the inputs and targets in the test table (yt: -1 if absent) */
	int have_y;         /* the test table holds every target */
} tables;

static void tables_free(tables *t)
{
	pr_csv_free(t->tr);
	pr_csv_free(t->te);
	free(t->tc);
	free(t->xc);
	free(t->xt);
	free(t->yt);
}

/* Read both tables and find the columns: every check before any fit. */
static int read_tables(const pr_config *cfg, const forest_args *a, tables *t, char *err)
{
	int ncol, rc;
	long n;

	if ((rc = pr_csv_read(a->train, &t->tr, err)) || (rc = pr_csv_read(a->test, &t->te, err)) ||
	    (rc = pr_cmd_check_rows(t->tr, err)))
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
	t->xt = malloc((size_t)ncol * sizeof *t->xt);
	t->yt = malloc((size_t)ncol * sizeof *t->yt);
	if (!t->xc || !t->xt || !t->yt)
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
	for (int j = 0; j < t->dx; j++) {
		t->xt[j] = pr_csv_find(t->te, pr_csv_name(t->tr, t->xc[j]));
		if (t->xt[j] < 0)
			return pr_err(err, PR_EIO, "%s:1: missing input column '%s'", pr_csv_path(t->te),
			              pr_csv_name(t->tr, t->xc[j]));
	}
	t->have_y = 1;
	for (int k = 0; k < t->dy; k++) {
		t->yt[k] = pr_csv_find(t->te, pr_csv_name(t->tr, t->tc[k]));
		t->have_y &= t->yt[k] >= 0;
	}
	return PR_OK;
}

/* The forest's timings and, when the test table holds the targets, the
 * test MSE, as the command's note. */
static void note_fit(const forest_args *a, const tables *t, const pr_forest *f, const double *P,
                     double tfit, double tpred)
{
	long nt = pr_csv_nrows(t->te);
	int len = snprintf(a->note, PR_ERRLEN, "forest: %d trees, %d leaves, fit %.3f s, predict %.3f s",
	                   pr_forest_ntrees(f), pr_forest_nleaves(f), tfit, tpred);
	double sse = 0;

	if (!t->have_y || nt == 0 || len <= 0 || len >= PR_ERRLEN)
		return;
	for (long i = 0; i < nt; i++)
		for (int k = 0; k < t->dy; k++) {
			double e = P[(size_t)i * t->dy + k] - pr_csv_get(t->te, i, t->yt[k]);
			sse += e * e;
		}
	snprintf(a->note + len, (size_t)(PR_ERRLEN - len), ", test MSE %.6g", sse / ((double)nt * t->dy));
}

/* The names of the training table's input and target columns, in the
 * forest's order (borrowed from the table). */
static const char **column_names(const tables *t, char *err)
{
	const char **nm = malloc((size_t)(t->dx + t->dy) * sizeof *nm);

	if (!nm) {
		pr_err(err, PR_ENOMEM, "forest: out of memory");
		return NULL;
	}
	for (int j = 0; j < t->dx; j++)
		nm[j] = pr_csv_name(t->tr, t->xc[j]);
	for (int k = 0; k < t->dy; k++)
		nm[t->dx + k] = pr_csv_name(t->tr, t->tc[k]);
	return nm;
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

/* The predictions (-o) and, with --leaves, the leaves, into a new set that
 * the caller commits; with save, the forest's file joins the set first. */
static int write_outputs(const forest_args *a, pr_outset **set, const pr_forest *f,
                         const char **nm, int save, const double *Xt, long nt, const double *P,
                         const char *test, char *err)
{
	const int dx = pr_forest_dx(f);
	pr_csvw *pw = NULL, *lw = NULL;
	int *act = malloc((size_t)pr_forest_ntrees(f) * sizeof *act);
	int rc;

	if (!act || !(*set = pr_outset_new(err))) {
		free(act);
		return act ? PR_ENOMEM : pr_err(err, PR_ENOMEM, "forest: out of memory");
	}
	if ((rc = pr_outset_add(*set, a->output, &pw, err)) ||
	    (a->leaves && (rc = pr_outset_add(*set, a->leaves, &lw, err))) ||
	    (save && (rc = save_forest(*set, a->save, f, nm, err)))) {
		free(act);
		return rc;
	}
	write_pred(pw, nm + dx, pr_forest_dy(f), P, nt);
	if (lw && write_leaves(lw, f, Xt, dx, nt, act) == PR_EINVAL)
		rc = pr_err(err, PR_ENUM, "%s: a test row reaches no leaf of some tree", test);
	free(act);
	return rc;
}

/* The whole of a file into memory. */
static int read_file(const char *path, char **text, size_t *len, char *err)
{
	FILE *fp = fopen(path, "rb");
	char *buf = NULL;
	size_t cap = 0, n = 0, got = 1;
	int rc = PR_OK;

	if (!fp)
		return pr_err(err, PR_EIO, "%s: cannot open: %s", path, strerror(errno));
	while (got > 0 && rc == PR_OK) {
		if (n == cap) {
			char *nb = realloc(buf, cap = cap ? 2 * cap : 65536);

			if (!nb) {
				rc = pr_err(err, PR_ENOMEM, "forest: out of memory");
				break;
			}
			buf = nb;
		}
		n += got = fread(buf + n, 1, cap - n, fp);
	}
	if (rc == PR_OK && ferror(fp))
		rc = pr_err(err, PR_EIO, "%s: cannot read", path);
	fclose(fp);
	if (rc)
		free(buf);
	*text = rc ? NULL : buf;
	*len = n;
	return rc;
}

/* --load FILE: predict the test CSV with a saved forest. */
static int forest_loaded(const forest_args *a, char *err)
{
	pr_forest *f = NULL;
	pr_csv *te = NULL;
	pr_outset *set = NULL;
	char *text = NULL, **nm = NULL;
	double *Xt = NULL, *P = NULL;
	int *xt = NULL, dx = 0, rc;
	size_t len = 0;
	long nt = 0;

	if (a->train || a->target || a->weight || a->save)
		return pr_err(err, PR_EINVAL, "forest: --load takes no --train, --target, --weight or --save");
	if (!a->test)
		return pr_err(err, PR_EINVAL, "forest: --load needs --test");
	if ((rc = read_file(a->load, &text, &len, err)))
		return rc;
	if (!(f = pr_forest_load(text, len, a->load, &nm, err))) {
		rc = pr_out_of_memory ? PR_ENOMEM : strstr(err, "format version") ? PR_EINVAL : PR_EIO;
		goto done;
	}
	dx = pr_forest_dx(f);
	if ((rc = pr_csv_read(a->test, &te, err)))
		goto done;
	nt = pr_csv_nrows(te);
	xt = malloc((size_t)dx * sizeof *xt);
	P = malloc(((size_t)nt + 1) * (size_t)pr_forest_dy(f) * sizeof *P);
	if (!xt || !P) {
		rc = pr_err(err, PR_ENOMEM, "forest: out of memory");
		goto done;
	}
	for (int j = 0; j < dx; j++)
		if ((xt[j] = pr_csv_find(te, nm[j])) < 0) {
			rc = pr_err(err, PR_EIO, "%s:1: missing input column '%s'", pr_csv_path(te), nm[j]);
			goto done;
		}
	if (!(Xt = pr_cmd_matrix(te, xt, dx, err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	pr_forest_predict_many(f, Xt, (int)nt, P);
	rc = write_outputs(a, &set, f, (const char **)nm, 0, Xt, nt, P, pr_csv_path(te), err);
done:
	rc = pr_outset_commit(set, rc, err);
	pr_forest_free(f);
	pr_csv_free(te);
	free(text);
	free(nm);
	free(Xt);
	free(P);
	free(xt);
	return rc;
}

static int pr_cmd_forest(const pr_config *cfg, const forest_args *a, char *err)
{
	tables t = { 0 };
	pr_forest *f = NULL;
	pr_outset *set = NULL;
	gsl_rng *rng = NULL;
	double *X = NULL, *Y = NULL, *W = NULL, *Xt = NULL, *P = NULL;
	const char **nm = NULL;
	int rc;
	long n, nt;
	double t0, tfit, tpred;

	if (a->load)
		return forest_loaded(a, err);
	if (!a->train || !a->test || !a->target)
		return pr_err(err, PR_EINVAL, "forest: --train, --test and --target are required");
	if ((rc = pr_forest_opts_check(&cfg->forest, "forest", err)) || (rc = read_tables(cfg, a, &t, err)))
		goto done;
	n = pr_csv_nrows(t.tr);
	nt = pr_csv_nrows(t.te);
	if (!(X = pr_cmd_matrix(t.tr, t.xc, t.dx, err)) || !(Y = pr_cmd_matrix(t.tr, t.tc, t.dy, err)) ||
	    !(Xt = pr_cmd_matrix(t.te, t.xt, t.dx, err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	if (t.wc >= 0 && (rc = pr_cmd_weights(t.tr, t.wc, a->weight, "weight", &W, err)))
		goto done;
	P = malloc(((size_t)nt + 1) * t.dy * sizeof *P);
	if (!P || !(rng = gsl_rng_alloc(gsl_rng_mt19937))) {
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
	t0 = seconds();
	pr_forest_predict_many(f, Xt, (int)nt, P);
	tpred = seconds() - t0;

	/* predictions, leaves and the forest are committed together, only if
	 * all are complete */
	if (!(nm = column_names(&t, err))) {
		rc = PR_ENOMEM;
		goto done;
	}
	if ((rc = write_outputs(a, &set, f, nm, a->save != NULL, Xt, nt, P, pr_csv_path(t.te), err)))
		goto done;
	if (!a->quiet)
		note_fit(a, &t, f, P, tfit, tpred);
done:
	rc = pr_outset_commit(set, rc, err);
	pr_forest_free(f);
	gsl_rng_free(rng);
	tables_free(&t);
	free(X);
	free(Y);
	free(W);
	free(Xt);
	free(P);
	free(nm);
	return rc;
}

static int forest_main(const pr_config *cfg, const void *opts, char *err)
{
	return pr_cmd_forest(cfg, opts, err);
}

static const cli_opt forest_opts[] = {
	CLI_COMMON_C, CLI_OPT("o", CLI_STR, forest_args, output), CLI_COMMON_SET, CLI_COMMON_SEED,
	CLI_OPT("train", CLI_STR, forest_args, train), CLI_OPT("test", CLI_STR, forest_args, test),
	CLI_OPT("target", CLI_STR, forest_args, target), CLI_OPT("weight", CLI_STR, forest_args, weight),
	CLI_OPT("leaves", CLI_STR, forest_args, leaves), CLI_OPT("save", CLI_STR, forest_args, save),
	CLI_OPT("load", CLI_STR, forest_args, load), CLI_GIVEN(CLI_QUIET, forest_args, quiet),
	CLI_GIVEN(CLI_NOTE, forest_args, note), CLI_END
};

const cli_command cli_forest = {
	"forest",
	"poolreps forest --train FILE --test FILE --target COLS [--weight COL] [--leaves FILE]\n"
	"                [--save FOREST] [-o OUT.csv] [-c FILE] [--set forest.key=value]...\n"
	"poolreps forest --load FOREST --test FILE [--leaves FILE] [-o OUT.csv]\n"
	"  --save writes the fitted forest (text, format version 1, docs/forest.md);\n"
	"  --load predicts with a saved one instead of fitting.\n"
	"  Fit extra trees on the training CSV (inputs = every other column), predict the\n"
	"  test CSV: one pred_<name> column per target. --leaves writes each test row's\n"
	"  active leaf per tree. Timings and test MSE go to stderr (not with -q).",
	forest_opts, sizeof(forest_args), "forest.,experiment.seed", CLI_OPS_NONE, 0, NULL, forest_main
};
