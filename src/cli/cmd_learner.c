/* cmd_learner.c — `poolreps learner new|ask|tell|mean STATE`: the ask/tell
 * learner (learner.h) across processes, so that episodes can be played
 * anywhere between ask and tell.
 *
 * STATE is the learner's saved state (docs/learner.md), written by new or
 * by poolreps.Learner.save(), with the names of the context and action
 * columns (default s0 .., a0 ..); ask reads the context
 * columns by name and writes them followed by the drawn action columns;
 * tell reads the context, action and return columns (and the features or
 * targets the options need); mean writes the mean actions. ask and tell
 * rewrite STATE together with their output, each under a temporary name
 * renamed only when everything succeeded, so a failed command leaves
 * STATE and every other path as they were. The random stream is
 * mt19937 seeded with experiment.seed, as poolreps.Learner's. new, ask
 * and tell hold a lock on STATE from reading it to renaming over it, so
 * two of them on one state run one after the other.
 */
#define _DEFAULT_SOURCE /* flock */
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <sys/file.h>
#include <sys/stat.h>

#include <gsl/gsl_rng.h>

#include "poolreps/internal.h"
#include "poolreps/learner.h"
#include "cli.h"

typedef struct {
	char **ops;
	int nops;
	const char *input, *output, *context, *action, *ret, *features, *target;
} learner_args;

enum { NEW, ASK, TELL, MEAN, NVERB };
static const char *const verb_name[NVERB] = {"new", "ask", "tell", "mean"};

static int verb_of(const learner_args *a)
{
	int v;

	for (v = 0; a->nops >= 1 && v < NVERB; ++v)
		if (!strcmp(a->ops[0], verb_name[v]))
			return v;
	return -1;
}

/* An exclusive lock on the file path names, waited for: two tells of one
 * state that both read it before either renamed over it would keep only
 * the later's episodes. A file renamed over path while we waited (by the
 * holder) is locked anew. The descriptor to close, or -1 where nothing is
 * locked: no file yet (new), not a regular file (load refuses it), or a
 * file system without flock for files open for reading (NFS). */
static int lock_state(const char *path)
{
	struct stat held, now;
	int fd;

	for (;;) {
		if ((fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC)) < 0)
			return -1;
		if (fstat(fd, &held) || !S_ISREG(held.st_mode) || flock(fd, LOCK_EX)) {
			close(fd);
			return -1;
		}
		if (!stat(path, &now) && now.st_dev == held.st_dev && now.st_ino == held.st_ino)
			return fd;
		close(fd);
	}
}

/* 1 if path and STATE name one file: mean's -o would replace the learner
 * by its means (ask and tell rewrite STATE themselves: two outputs). */
static int names_state(const char *path, const char *state)
{
	struct stat a, b;

	return path && strcmp(path, "-") && !stat(path, &a) && !stat(state, &b) &&
	       a.st_dev == b.st_dev && a.st_ino == b.st_ino;
}

/* The learner saved in STATE, drawing from rng; NULL with *rc set. */
static pr_learner *load(const char *path, gsl_rng *rng, int *rc, char *err)
{
	char *buf;
	size_t len = 0;
	pr_learner *L = NULL;

	/* a foreign file is refused after its first bytes; the header decides
	 * the status (another version: PR_EINVAL), past it a load fails for a
	 * bad file or for memory */
	*rc = pr_cmd_read_whole(path, "poolreps-learner\n", ": not a poolreps learner state", &buf,
	                        &len, err);
	if (*rc == PR_OK)
		*rc = pr_learner_check_head((const unsigned char *)buf, len, path, err);
	if (*rc == PR_OK && !(L = pr_learner_load((const unsigned char *)buf, len, path, rng, err)))
		*rc = pr_out_of_memory ? PR_ENOMEM : PR_EIO;
	free(buf);
	return L;
}

/* The state of L into path, committed with the set. */
static int add_state(pr_outset *set, const char *path, const pr_learner *L, char *err)
{
	unsigned char *buf;
	size_t len;
	pr_csvw *w;
	int rc;

	if ((rc = pr_learner_save(L, &buf, &len, err)))
		return rc;
	if ((rc = pr_outset_add(set, path, &w, err)) == PR_OK)
		rc = pr_csvw_raw(w, (const char *)buf, len);
	free(buf);
	return rc;
}

/* After a step that ended with rc: the state of L alone into path, written
 * under a temporary name and renamed (nothing written unless rc is PR_OK). */
static int commit_state(const char *path, const pr_learner *L, int rc, char *err)
{
	pr_outset *set = NULL;

	if (rc == PR_OK && !(set = pr_outset_new(err)))
		rc = PR_ENOMEM;
	if (rc == PR_OK)
		rc = add_state(set, path, L, err);
	return pr_outset_commit(set, rc, err);
}

/* A comma list of column names into names[*n] (pointers into *copy). */
static int split(const char *list, const char *opt, char **copy, const char ***names, int *n,
                 char *err)
{
	char *p;
	int k, j;

	if (!list || !*list)
		return pr_err(err, PR_EINVAL, "learner new: %s COLS is required", opt);
	if (!(*copy = strdup(list)) || !(*names = malloc((strlen(list) + 1) * sizeof **names)))
		return pr_err(err, PR_ENOMEM, "learner: out of memory");
	for (*n = 0, p = *copy;; ++p) {
		(*names)[(*n)++] = p;
		if (!(p = strchr(p, ',')))
			break;
		*p = '\0';
	}
	for (k = 0; k < *n; ++k) {
		if (!*(*names)[k])
			return pr_err(err, PR_EINVAL, "learner new: %s '%s': an empty column name", opt, list);
		for (j = 0; j < k; ++j)
			if (!strcmp((*names)[j], (*names)[k]))
				return pr_err(err, PR_EINVAL, "learner new: %s '%s': column '%s' twice", opt,
				              list, (*names)[k]);
	}
	return PR_OK;
}

static int learner_new(const pr_config *cfg, const learner_args *a, gsl_rng *rng, char *err)
{
	char *cc = NULL, *ac = NULL;
	const char **cn = NULL, **an = NULL, **all = NULL;
	int dx = 0, da = 0, rc;
	pr_learner_opts o;
	pr_learner *L = NULL;

	pr_config_learner_opts(cfg, &o);
	if (!(rc = split(a->context, "--context", &cc, &cn, &dx, err)) &&
	    !(rc = split(a->action, "--action", &ac, &an, &da, err))) {
		if (!(all = malloc((size_t)(dx + da) * sizeof *all)))
			rc = pr_err(err, PR_ENOMEM, "learner: out of memory");
		else if (!(L = pr_learner_new(&o, dx, da, rng, err)))
			rc = PR_EINVAL;
	}
	if (rc == PR_OK) {
		memcpy(all, cn, (size_t)dx * sizeof *all);
		memcpy(all + dx, an, (size_t)da * sizeof *all);
		rc = pr_learner_set_names(L, all, err);
	}
	rc = commit_state(a->ops[1], L, rc, err);
	pr_learner_free(L);
	free(cc);
	free(ac);
	free(cn);
	free(an);
	free(all);
	return rc;
}

/* The table of -i and the matrix of the named columns (n x k). */
static double *columns(const pr_csv *t, const char *const *names, int k, const char *what,
                       char *err)
{
	int *cols = malloc((size_t)k * sizeof *cols), j;
	double *m = NULL;

	if (!cols) {
		pr_err(err, PR_ENOMEM, "learner: out of memory");
		return NULL;
	}
	for (j = 0; j < k; ++j)
		if ((cols[j] = pr_cmd_column(t, names[j], what, err)) < 0)
			break;
	if (j == k)
		m = pr_cmd_matrix(t, cols, k, err);
	free(cols);
	return m;
}

/* Rows of names[0..k) from the matrices X (n x dx) then Y (n x dy). */
static int write_rows(pr_csvw *w, const char *const *names, const double *X, int dx,
                      const double *Y, int dy, long n)
{
	long i;
	int j;

	for (j = 0; j < dx + dy; ++j)
		pr_csvw_str(w, names[j]);
	pr_csvw_endrow(w);
	for (i = 0; i < n; ++i) {
		for (j = 0; j < dx; ++j)
			pr_csvw_num(w, X[i * dx + j]);
		for (j = 0; j < dy; ++j)
			pr_csvw_num(w, Y[i * dy + j]);
		pr_csvw_endrow(w);
	}
	return pr_csvw_status(w);
}

/* After a call that ended with rc: a failure at a row of t (contexts X)
 * names the file and line, and the row's context of largest magnitude (one
 * far beyond the fitted ones makes the policy's weights or covariance
 * overflow), before the message. */
static int name_row(const pr_learner *L, const pr_csv *t, const double *X, int rc, char *err)
{
	const int i = pr_learner_bad_row(L), dx = pr_learner_context_dim(L);
	char msg[PR_ERRLEN];
	int big = 0, j;

	if (rc == PR_OK || i < 0)
		return rc;
	const double *x = X + (size_t)i * dx;
	for (j = 1; j < dx; ++j)
		if (fabs(x[j]) > fabs(x[big]))
			big = j;
	snprintf(msg, sizeof msg, "%s", err);
	return pr_err(err, rc, "%s:%ld: context %s = %.17g: %s", pr_csv_path(t), pr_csv_line(t, i),
	              pr_learner_names(L)[big], x[big], msg);
}

/* ask or mean: actions for the contexts of -i into -o (ask: STATE too). */
static int learner_act(const learner_args *a, const pr_csv *t, int verb, pr_learner *L,
                       char *err)
{
	const int dx = pr_learner_context_dim(L), da = pr_learner_action_dim(L);
	const char *const *names = pr_learner_names(L);
	pr_outset *set = NULL;
	pr_csvw *w = NULL;
	double *X = NULL, *A = NULL;
	const long n = pr_csv_nrows(t);
	int rc = PR_OK;

	if (!(X = columns(t, names, dx, "a context column of the learner", err)))
		rc = PR_EIO;
	else if (!(A = malloc((size_t)n * da * sizeof *A)))
		rc = pr_err(err, PR_ENOMEM, "learner: out of memory");
	if (rc == PR_OK)
		rc = name_row(L, t, X, verb == ASK ? pr_learner_ask(L, (int)n, X, A, err)
		                                   : pr_learner_mean(L, (int)n, X, A, err), err);
	if (rc == PR_OK && !(set = pr_outset_new(err)))
		rc = PR_ENOMEM;
	if (rc == PR_OK && !(rc = pr_outset_add(set, a->output, &w, err)))
		rc = write_rows(w, names, X, dx, A, da, n);
	if (rc == PR_OK && verb == ASK)
		rc = add_state(set, a->ops[1], L, err);
	rc = pr_outset_commit(set, rc, err);
	free(X);
	free(A);
	return rc;
}

/* The optional columns of a tell: --features (value given; the return
 * column rcol among them would hand REPS its answer, as reps refuses),
 * --target. */
static int tell_extra(const learner_args *a, const pr_csv *t, int rcol, pr_learner_batch *b,
                      double **G, double **Y, char *err)
{
	int *cols = NULL, rc = PR_OK;

	if (a->features && (b->d = pr_cmd_columns(t, a->features, &cols, err)) < 0)
		return b->d;
	if (a->features &&
	    !(rc = pr_cmd_disjoint(t, cols, b->d, "a feature", &rcol, 1, "the return", err)) &&
	    !(*G = pr_cmd_matrix(t, cols, b->d, err)))
		rc = PR_ENOMEM;
	free(cols);
	cols = NULL;
	if (rc == PR_OK && a->target && (b->dy = pr_cmd_columns(t, a->target, &cols, err)) < 0)
		rc = b->dy;
	else if (rc == PR_OK && a->target && !(*Y = pr_cmd_matrix(t, cols, b->dy, err)))
		rc = PR_ENOMEM;
	free(cols);
	b->features = *G;
	b->targets = *Y;
	return rc;
}

/* The column of --return, or a status: a column of its own, since a
 * context or action column named by --return is a slip the numbers would
 * not show (as reps refuses a feature that is the return). */
static int return_column(const pr_csv *t, const char *ret, const char *const *names, int n,
                         int dx, char *err)
{
	int j, c = pr_cmd_column(t, ret, "--return", err);

	for (j = 0; c >= 0 && j < n; ++j)
		if (pr_csv_find(t, names[j]) == c)
			return pr_err(err, PR_EINVAL, "%s: column '%s' is both %s column of the learner "
			              "and --return", pr_csv_path(t), names[j], j < dx ? "a context" : "an action");
	return c;
}

static int learner_tell(const learner_args *a, const pr_csv *t, pr_learner *L, char *err)
{
	const int dx = pr_learner_context_dim(L), da = pr_learner_action_dim(L);
	const char *const *names = pr_learner_names(L);
	pr_learner_batch b;
	double *X = NULL, *A = NULL, *R = NULL, *G = NULL, *Y = NULL;
	int rc, rcol = -1;

	memset(&b, 0, sizeof b);
	if ((rc = pr_learner_check_targets(L, a->target != NULL, err)))
		return rc;
	if (!(X = columns(t, names, dx, "a context column of the learner", err)) ||
	    !(A = columns(t, names + dx, da, "an action column of the learner", err)))
		rc = PR_EIO;
	else if ((rcol = return_column(t, a->ret, names, dx + da, dx, err)) < 0)
		rc = rcol;
	else if (!(R = pr_cmd_matrix(t, &rcol, 1, err)))
		rc = PR_ENOMEM;
	else
		rc = tell_extra(a, t, rcol, &b, &G, &Y, err);
	if (rc == PR_OK) {
		b.n = (int)pr_csv_nrows(t);
		b.contexts = X;
		b.actions = A;
		b.returns = R;
		rc = name_row(L, t, X, pr_learner_tell_batch(L, &b, err), err);
	}
	rc = commit_state(a->ops[1], L, rc, err);
	free(X);
	free(A);
	free(R);
	free(G);
	free(Y);
	return rc;
}

/* 1 if a parameter file, --set or --seed was given. */
static int config_given(const pr_config *cfg)
{
	int i;

	for (i = 0; i < PR_CONFIG_MAXKEYS; ++i)
		if (cfg->key_line[i])
			return 1;
	return cfg->source[0] != '\0';
}

/* The verb and STATE; the options each verb takes. */
static int check_verb(const pr_config *cfg, const learner_args *a, int verb, char *err)
{
	if (a->nops != 2 || verb < 0)
		return pr_err(err, PR_EINVAL, "learner: usage: poolreps learner new|ask|tell|mean STATE "
		              "[options]");
	if (!strcmp(a->ops[1], "-") || !*a->ops[1])
		return pr_err(err, PR_EINVAL, "learner: STATE must name a file");
	if (verb != NEW && (config_given(cfg) || a->context || a->action))
		return pr_err(err, PR_EINVAL, "learner %s: -c, --set, --seed, --context and --action "
		              "belong to learner new (STATE holds them)", verb_name[verb]);
	if (verb == NEW && (a->input || a->output || a->ret || a->features || a->target))
		return pr_err(err, PR_EINVAL, "learner new: -i, -o, --return, --features and --target "
		              "belong to ask, tell and mean");
	if (verb != TELL && (a->ret || a->features || a->target))
		return pr_err(err, PR_EINVAL, "learner %s: --return, --features and --target belong to "
		              "learner tell", verb_name[verb]);
	if (verb == TELL && a->output)
		return pr_err(err, PR_EINVAL, "learner tell: writes only STATE (no -o)");
	if (verb == TELL && !a->ret)
		return pr_err(err, PR_EINVAL, "learner tell: --return COL is required");
	return PR_OK;
}

static int learner_main(const pr_config *cfg, const void *opts, char *err)
{
	const learner_args *a = opts;
	const int verb = verb_of(a);
	gsl_rng *rng;
	pr_learner *L = NULL;
	pr_csv *t = NULL;
	int rc = check_verb(cfg, a, verb, err), lock;

	if (rc)
		return rc;
	if (verb == MEAN && names_state(a->output, a->ops[1]))
		return pr_err(err, PR_EINVAL, "learner mean: -o %s is STATE: the means would replace "
		              "the learner", a->output);
	if (!(rng = gsl_rng_alloc(gsl_rng_mt19937)))
		return pr_err(err, PR_ENOMEM, "learner: out of memory");
	gsl_rng_set(rng, cfg->run.seed);
	/* -i is read whole before STATE is locked: in `learner ask S | play |
	 * learner tell S` the tell waits for the ask's end, not the ask for the
	 * tell's lock, and then reads the state the ask left */
	if (verb != NEW && !(rc = pr_csv_read(a->input, &t, err)))
		rc = pr_cmd_check_rows(t, err);
	lock = rc || verb == MEAN ? -1 : lock_state(a->ops[1]);
	if (rc == PR_OK && verb == NEW)
		rc = learner_new(cfg, a, rng, err);
	else if (rc == PR_OK && (L = load(a->ops[1], rng, &rc, err)))
		rc = verb == TELL ? learner_tell(a, t, L, err) : learner_act(a, t, verb, L, err);
	if (lock >= 0)
		close(lock);
	pr_learner_free(L);
	pr_csv_free(t);
	gsl_rng_free(rng);
	return rc;
}

static const cli_opt learner_opts[] = {
	CLI_COMMON_C,
	CLI_OPT("i", "IN.csv", learner_args, input,
	        "contexts (ask, mean) or episodes (tell); default stdin"),
	CLI_OPT("o", "OUT.csv", learner_args, output,
	        "contexts then actions (ask, mean); default stdout"),
	CLI_COMMON_SET, CLI_COMMON_SEED,
	CLI_OPT("context", "COLS", learner_args, context, "new: the context columns (comma list)"),
	CLI_OPT("action", "COLS", learner_args, action, "new: the action columns (comma list)"),
	CLI_OPT("return", "COL", learner_args, ret, "tell: the return column"),
	CLI_OPT("features", "COLS", learner_args, features,
	        "tell: value features (learner.value = given)"),
	CLI_OPT("target", "COLS", learner_args, target,
	        "tell: policy targets (policy.target = reward_state)"),
	CLI_GIVEN_LIST(CLI_OPERANDS, learner_args, ops, nops),
	CLI_END
};

/* --set takes the keys one tunes most; a parameter file (-c) sets any key */
const cli_command cli_learner = {
	"learner",
	"poolreps learner new|ask|tell|mean STATE [options]\n"
	"  The ask/tell learner kept in STATE: new makes it (-c FILE sets any key),\n"
	"  ask draws an action per context, tell (--return COL) is one iteration,\n"
	"  mean gives the mean actions.",
	learner_opts, sizeof(learner_args),
	"learner.,experiment.seed,reps.epsilon,value.trees,value.n_min,policy.trees,policy.n_min,"
	"policy.lambda,policy.min_std",
	CLI_OPS_ALL, 0, NULL, learner_main
};
