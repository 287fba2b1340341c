/* cmd_run.c — `poolreps CONFIG` and `poolreps merge`: run an experiment into
 * an output folder with its provenance, and merge per-process outputs.
 *
 * Everything a run writes goes first into a staging folder DIR/.partial-PID
 * and is moved into DIR only when the whole run succeeded, all or nothing
 * (publish), so a failed or interrupted run leaves no partial CSV behind and
 * the previous run in DIR untouched. provenance.txt lists the files a run
 * owns; the next run into DIR replaces exactly those.
 */
#define _DEFAULT_SOURCE /* flock */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/utsname.h>
#include <time.h>
#include <unistd.h>

#include "poolreps/cmd.h"
#include "poolreps/csvio.h"
#include "poolreps/exp.h"
#include "exp_priv.h"
#include "run_priv.h"

#define PATHLEN 4096

/* Remove the folders of dir below its first keep bytes (those mkdir_p
 * created), deepest first, each only if empty. */
static void remove_created(const char *dir, size_t keep)
{
	char buf[PATHLEN];
	char *slash;

	snprintf(buf, sizeof buf, "%s", dir);
	while (strlen(buf) > keep && rmdir(buf) == 0 && (slash = strrchr(buf, '/')))
		*slash = '\0';
}

/* Create dir and its missing parents; *keep: the length of its longest
 * prefix that existed before (strlen(dir) if dir itself did). A failure
 * removes what it created. */
static int mkdir_p(const char *dir, size_t *keep, char *err)
{
	char buf[PATHLEN];
	char *p;
	struct stat st;
	int rc = PR_OK;

	*keep = strlen(dir);
	if (!*dir)
		return pr_err(err, PR_EINVAL, "output folder name is empty");
	if (snprintf(buf, sizeof buf, "%s", dir) >= (int)sizeof buf)
		return pr_err(err, PR_EINVAL, "%.100s...: path too long", dir);
	for (p = buf + 1; rc == PR_OK; ++p) {
		if (*p == '/' || *p == '\0') {
			char c = *p;
			*p = '\0';
			if (mkdir(buf, 0777) == 0) {
				if (*keep == strlen(dir))
					*keep = (size_t)(strrchr(buf, '/') ? strrchr(buf, '/') - buf : 0);
			} else if (errno != EEXIST) {
				rc = pr_err(err, PR_EIO, "%s: cannot create folder: %s", buf, strerror(errno));
			}
			*p = c;
			if (!c)
				break;
		}
	}
	if (rc == PR_OK && (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode)))
		rc = pr_err(err, PR_EIO, "%s: exists and is not a folder", dir);
	if (rc)
		remove_created(dir, *keep);
	return rc;
}

static void remove_tree(const char *dir)
{
	DIR *d = opendir(dir);
	struct dirent *e;

	if (!d)
		return;
	while ((e = readdir(d)))
		if (strcmp(e->d_name, ".") && strcmp(e->d_name, ".."))
			unlinkat(dirfd(d), e->d_name, 0);
	closedir(d);
	rmdir(dir);
}

/* Leftovers of runs killed with SIGKILL, whose PID no longer exists: their
 * staging folders .partial-PID and temporary files .poolreps-tmp-PID-N. A
 * run still alive (writing into the same folder) keeps its own. */
static void sweep_stale(const char *dir)
{
	DIR *d = opendir(dir);
	struct dirent *e;
	char path[PATHLEN];

	if (!d)
		return;
	while ((e = readdir(d))) {
		const char *p = NULL;
		char *end;
		long pid;
		if (strncmp(e->d_name, ".partial-", 9) == 0)
			p = e->d_name + 9;
		else if (strncmp(e->d_name, ".poolreps-tmp-", 14) == 0)
			p = e->d_name + 14;
		if (!p)
			continue;
		pid = strtol(p, &end, 10);
		if (end == p || (*end && *end != '-') || !pr_pid_gone(pid))
			continue;
		if (snprintf(path, sizeof path, "%s/%s", dir, e->d_name) >= (int)sizeof path)
			continue;
		if (unlink(path) != 0)
			remove_tree(path);
	}
	closedir(d);
}

/* The file names of folder dir (not starting with '.'), sorted, with
 * provenance.txt last: it marks a complete run. */
typedef struct {
	char **name;
	int n;
} names;

static void names_free(names *l)
{
	int i;

	for (i = 0; i < l->n; ++i)
		free(l->name[i]);
	free(l->name);
	l->name = NULL;
	l->n = 0;
}

static int names_add(names *l, const char *name, size_t len)
{
	char **g = realloc(l->name, (size_t)(l->n + 1) * sizeof *g);

	if (!g)
		return PR_ENOMEM;
	l->name = g;
	if (!(l->name[l->n] = strndup(name, len)))
		return PR_ENOMEM;
	l->n++;
	return PR_OK;
}

static int names_has(const names *l, const char *name)
{
	int i;

	for (i = 0; i < l->n; ++i)
		if (strcmp(l->name[i], name) == 0)
			return 1;
	return 0;
}

static int cmp_name(const void *x, const void *y)
{
	const char *a = *(char *const *)x, *b = *(char *const *)y;
	int pa = strcmp(a, "provenance.txt") == 0, pb = strcmp(b, "provenance.txt") == 0;

	return pa != pb ? pa - pb : strcmp(a, b);
}

static int list_files(const char *dir, names *out, char *err)
{
	DIR *d = opendir(dir);
	struct dirent *e;

	if (!d)
		return pr_err(err, PR_EIO, "%s: cannot read folder: %s", dir, strerror(errno));
	while ((e = readdir(d)))
		if (e->d_name[0] != '.' && names_add(out, e->d_name, strlen(e->d_name))) {
			closedir(d);
			return pr_err(err, PR_ENOMEM, "out of memory");
		}
	closedir(d);
	if (out->n)
		qsort(out->name, (size_t)out->n, sizeof *out->name, cmp_name);
	return PR_OK;
}

/* The files an earlier run in dir wrote: the "files:" line of its
 * provenance.txt. Nothing when dir holds no poolreps run. */
static int earlier_run(const char *dir, names *out)
{
	char path[PATHLEN + 16], line[1 << 16];
	struct stat st;
	FILE *fp;
	int rc = PR_OK, n = 0;

	snprintf(path, sizeof path, "%s/provenance.txt", dir);
	/* a fixed buffer, and only a regular file: never a FIFO or /dev/zero */
	if (stat(path, &st) != 0 || !S_ISREG(st.st_mode) || !(fp = fopen(path, "r")))
		return PR_OK;
	while (rc == PR_OK && n++ < 64 && fgets(line, sizeof line, fp)) {
		const char *p;
		if (n == 1 && strncmp(line, "version: ", 9) != 0)
			break;
		if (strncmp(line, "files:", 6) != 0)
			continue;
		for (p = line + 6; *p && rc == PR_OK;) {
			size_t k;
			p += strspn(p, " \n");
			k = strcspn(p, " \n");
			/* only plain names in dir itself */
			if (k && *p != '.' && !memchr(p, '/', k))
				rc = names_add(out, p, k);
			p += k;
		}
		break;
	}
	fclose(fp);
	return rc;
}

/* Move every file of staging into dir, all or nothing: each file that will
 * be replaced first gets a second hard link inside staging, so that a
 * failed rename can put every earlier one back. Files of the earlier run in
 * dir that the new run did not write are removed once all are in place.
 * Publishes into one folder are serialised with a lock on the folder. */
static int publish(const char *staging, const char *dir, char *err)
{
	names now = {NULL, 0}, old = {NULL, 0};
	char from[2 * PATHLEN], to[2 * PATHLEN], bak[2 * PATHLEN];
	char *had = NULL;
	struct stat st;
	sigset_t mask;
	int rc, i, j, lock;

	if ((rc = list_files(staging, &now, err)))
		return rc;
	if ((lock = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC)) < 0 || flock(lock, LOCK_EX) != 0) {
		rc = pr_err(err, PR_EIO, "%s: cannot lock folder: %s", dir, strerror(errno));
		goto out;
	}
	if (earlier_run(dir, &old) || !(had = calloc((size_t)now.n + 1, 1))) {
		rc = pr_err(err, PR_ENOMEM, "out of memory");
		goto out;
	}
	pr_cleanup_hold(&mask);
	for (i = 0; i < now.n && rc == PR_OK; ++i) {
		snprintf(to, sizeof to, "%s/%s", dir, now.name[i]);
		snprintf(bak, sizeof bak, "%s/.old-%d", staging, i);
		if (lstat(to, &st) != 0)
			continue;
		if (S_ISDIR(st.st_mode))
			rc = pr_err(err, PR_EIO, "%s: is a folder: cannot replace it with the run's file", to);
		/* like any output: a file the (non-root) user may not write stays */
		else if (S_ISREG(st.st_mode) && faccessat(AT_FDCWD, to, W_OK, AT_EACCESS) != 0)
			rc = pr_err(err, PR_EIO, "%s: cannot write: %s", to, strerror(errno));
		else if (link(to, bak) != 0)
			rc = pr_err(err, PR_EIO, "%s: cannot keep the earlier file while replacing it: %s",
			            to, strerror(errno));
		else
			had[i] = 1;
	}
	for (i = 0; i < now.n && rc == PR_OK; ++i) {
		snprintf(from, sizeof from, "%s/%s", staging, now.name[i]);
		snprintf(to, sizeof to, "%s/%s", dir, now.name[i]);
		if (rename(from, to) == 0)
			continue;
		rc = pr_err(err, PR_EIO, "%s: cannot move into place: %s", to, strerror(errno));
		for (j = 0; j < i; ++j) {
			snprintf(to, sizeof to, "%s/%s", dir, now.name[j]);
			snprintf(bak, sizeof bak, "%s/.old-%d", staging, j);
			if (had[j])
				rename(bak, to);
			else
				unlink(to);
		}
	}
	for (i = 0; i < old.n && rc == PR_OK; ++i)
		if (!names_has(&now, old.name[i]) &&
		    snprintf(to, sizeof to, "%s/%s", dir, old.name[i]) < (int)sizeof to &&
		    lstat(to, &st) == 0 && !S_ISDIR(st.st_mode))
			unlink(to);
	pr_cleanup_release(&mask);
out:
	if (lock >= 0)
		close(lock);
	free(had);
	names_free(&now);
	names_free(&old);
	return rc;
}

/* Render text with fn into a memory stream, then write it to path. */
static int write_text(const char *path, void (*fn)(FILE *, const void *), const void *arg,
                      char *err)
{
	char *buf = NULL;
	size_t n = 0;
	FILE *fp = open_memstream(&buf, &n);
	pr_csvw *w;
	int rc;

	if (!fp)
		return pr_err(err, PR_ENOMEM, "out of memory");
	fn(fp, arg);
	if (fclose(fp) != 0) {
		free(buf);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	if (!(w = pr_csvw_open(path, err))) {
		free(buf);
		return PR_EIO;
	}
	pr_csvw_raw(w, buf, n);
	free(buf);
	rc = pr_csvw_close(w, err);
	return rc;
}

static void config_text(FILE *fp, const void *cfg)
{
	pr_config_write(cfg, fp);
}

static void config_file_text(FILE *fp, const void *cfg)
{
	fprintf(fp, "; effective configuration written by poolreps %s\n", pr_version());
	pr_config_write(cfg, fp);
}

int pr_cmd_config(const pr_config *cfg, const pr_cmd_args *a, char *err)
{
	return write_text(a->output, config_text, cfg, err);
}

int pr_run_write_config(const pr_config *cfg, const char *dir, char *err)
{
	char path[2 * PATHLEN];

	snprintf(path, sizeof path, "%s/config.ini", dir);
	return write_text(path, config_file_text, cfg, err);
}

void pr_run_shell_word(FILE *fp, const char *arg)
{
	const char *c;

	if (*arg && strspn(arg, "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
	                        "0123456789_@%+=:,./-") == strlen(arg)) {
		fputs(arg, fp);
		return;
	}
	fputc('\'', fp);
	for (c = arg; *c; ++c) {
		if (*c == '\'')
			fputs("'\\''", fp);
		else
			fputc(*c, fp);
	}
	fputc('\'', fp);
}

typedef struct {
	const pr_config *cfg;
	const pr_cmd_args *a;
	const names *files;
	double wall;
} provenance;

static void provenance_text(FILE *fp, const void *arg)
{
	const provenance *p = arg;
	char host[256] = "unknown", when[64];
	struct rusage ru;
	struct utsname un;
	time_t now = time(NULL);
	int i;

	gethostname(host, sizeof host - 1);
	strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", gmtime(&now));
	getrusage(RUSAGE_SELF, &ru);
	fprintf(fp, "version: %s\n", pr_version());
	fprintf(fp, "command:");
	for (i = 0; i < p->a->argc; ++i) {
		fputc(' ', fp);
		pr_run_shell_word(fp, p->a->argv[i]);
	}
	fprintf(fp, "\nexperiment: %s\nseed: %lu\nrepetition: %d\nparameter_file: %s\n",
	        p->cfg->run.name, p->cfg->run.seed, p->cfg->run.repetition,
	        p->cfg->source[0] ? p->cfg->source : "(none)");
	if (uname(&un) == 0)
		fprintf(fp, "host: %s (%s %s %s)\n", host, un.sysname, un.release, un.machine);
	else
		fprintf(fp, "host: %s\n", host);
	fprintf(fp, "finished: %s\nwall_seconds: %.3f\ncpu_seconds: %.3f\npeak_memory_mib: %.1f\n",
	        when, p->wall,
	        (double)ru.ru_utime.tv_sec + 1e-6 * (double)ru.ru_utime.tv_usec +
	        (double)ru.ru_stime.tv_sec + 1e-6 * (double)ru.ru_stime.tv_usec,
	        (double)ru.ru_maxrss / 1024.0);
	/* what this run owns in its folder: a later run into it replaces these */
	fprintf(fp, "files:");
	for (i = 0; i < p->files->n; ++i)
		fprintf(fp, " %s", p->files->name[i]);
	fprintf(fp, " provenance.txt\n");
}

int pr_run_write_provenance(const pr_config *cfg, const pr_cmd_args *a, const char *dir,
                            double wall, char *err)
{
	char path[2 * PATHLEN];
	names files = {NULL, 0};
	provenance p = {cfg, a, &files, wall};
	int rc;

	if ((rc = list_files(dir, &files, err)))
		return rc;
	snprintf(path, sizeof path, "%s/provenance.txt", dir);
	rc = write_text(path, provenance_text, &p, err);
	names_free(&files);
	return rc;
}

static double seconds_since(const struct timespec *t0)
{
	struct timespec t1;

	clock_gettime(CLOCK_MONOTONIC, &t1);
	return (double)(t1.tv_sec - t0->tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0->tv_nsec);
}

/* Messages name the file where it was going to be, not the staging folder. */
static void unstage(char *err, const char *staging, const char *dir)
{
	char out[PR_ERRLEN], *p;
	size_t n = strlen(staging);

	while ((p = strstr(err, staging))) {
		snprintf(out, sizeof out, "%.*s%s%s", (int)(p - err), err, dir, p + n);
		memcpy(err, out, strlen(out) + 1);
	}
}

int pr_run_staged(const pr_config *cfg, const pr_cmd_args *a, const char *dir,
                  int (*work)(const pr_config *, const char *, const pr_cmd_args *, char *),
                  char *err)
{
	char staging[PATHLEN];
	struct timespec t0;
	size_t keep;
	int rc;

	clock_gettime(CLOCK_MONOTONIC, &t0);
	if ((rc = mkdir_p(dir, &keep, err)))
		return rc;
	if (snprintf(staging, sizeof staging, "%s/.partial-%ld", dir, (long)getpid()) >= (int)sizeof staging)
		return pr_err(err, PR_EINVAL, "%.100s...: path too long", dir);
	sweep_stale(dir);
	remove_tree(staging);
	if (mkdir(staging, 0777) != 0) {
		rc = pr_err(err, PR_EIO, "%s: cannot write into the folder: %s", dir, strerror(errno));
		remove_created(dir, keep);
		return rc;
	}
	pr_cleanup_set_dir(staging, dir, keep);
	rc = work(cfg, staging, a, err);
	if (rc == PR_OK)
		rc = pr_run_write_config(cfg, staging, err);
	if (rc == PR_OK)
		rc = pr_run_write_provenance(cfg, a, staging, seconds_since(&t0), err);
	if (rc == PR_OK && !pr_interrupted)
		rc = publish(staging, dir, err);
	remove_tree(staging);
	pr_cleanup_clear_dir();
	if (rc == PR_OK && !pr_interrupted)
		return PR_OK;
	/* a failed run leaves no trace: drop the folders it made (if empty) */
	remove_created(dir, keep);
	unstage(err, staging, dir);
	/* after a signal every failure is its echo (a fit cut short may report
	 * itself as a numerical failure): say what the user is left with */
	if (pr_interrupted)
		rc = pr_err(err, PR_EINTR, keep == strlen(dir) ?
		            "interrupted: no output written (signal %d); partial files removed, %s left as it was" :
		            "interrupted: no output written (signal %d); partial files and the new folders of %s removed",
		            (int)pr_interrupted, dir);
	return rc;
}

static int run_work(const pr_config *cfg, const char *dir, const pr_cmd_args *a, char *err)
{
	const pr_experiment *e = pr_exp_find(cfg->run.name);
	pr_variants variants;
	char at[320];
	int rc;

	if (!e)
		return pr_err(err, PR_EINVAL, "%s: experiment.name: '%s' is not available",
		              pr_config_where(cfg, "experiment.name", at, sizeof at), cfg->run.name);
	if ((rc = pr_exp_variants(cfg, &variants, err)))
		return rc;
	rc = e->run(cfg, dir, &a->progress, err);
	if (rc == PR_OK && e->summarize)
		rc = e->summarize(cfg, dir, err);
	return rc;
}

int pr_cmd_run(const pr_config *cfg, const pr_cmd_args *a, char *err)
{
	char dir[PATHLEN];

	if (a->output && snprintf(dir, sizeof dir, "%s", a->output) >= (int)sizeof dir)
		return pr_err(err, PR_EINVAL, "%.100s...: path too long", a->output);
	/* the simulator figures' data goes to results/sim: results/figures is
	 * where `make reproduce` gathers the drawn figures */
	if (!a->output)
		snprintf(dir, sizeof dir, "results/%s",
		         strcmp(cfg->run.name, "figures") ? cfg->run.name : "sim");
	return pr_run_staged(cfg, a, dir, run_work, err);
}

/* ---- merge ---- */

typedef struct {
	long rep;
	int var;  /* experiment.variant of the input, -1 for all */
	int src;
	long row;
} mrow;

static int cmp_mrow(const void *x, const void *y)
{
	const mrow *a = x, *b = y;

	if (a->rep != b->rep)
		return a->rep < b->rep ? -1 : 1;
	if (a->var != b->var)
		return a->var < b->var ? -1 : 1;
	if (a->src != b->src)
		return a->src < b->src ? -1 : 1;
	return a->row < b->row ? -1 : a->row > b->row;
}

/* Where each row of a merged raw CSV came from, so that an error a summary
 * reports at a line of the merged file names the source file and line. */
typedef struct {
	char *name;
	long n;
	int *src;
	long *line;
} origin;

typedef struct {
	const pr_cmd_args *a;
	origin *o;
	int no;
	int nrep;          /* experiment.repetitions */
	int *rep;          /* per input: the repetition its config.ini holds, -1 all */
	int *var;          /* per input: its experiment.variant, -1 all */
} merge_ctx;

/* Input k's config.ini into c. */
static int input_config(const pr_cmd_args *a, int k, pr_config *c, char *err)
{
	char path[PATHLEN + 16];
	struct stat st;

	pr_config_init(c);
	snprintf(path, sizeof path, "%s/config.ini", a->inputs[k]);
	/* a run folder holds a plain file: a FIFO would block the read */
	if (stat(path, &st) == 0 && !S_ISREG(st.st_mode))
		return pr_err(err, PR_EIO, "%s: not a regular file", path);
	return pr_config_load(c, path, err);
}

/* Read the raw CSV `name` of every input folder (complete files, one header,
 * consistent field counts: the one reader), order the rows by the leading
 * repetition column and write them; a repetition in two inputs is an error. */
static int merge_csv(merge_ctx *m, const char *name, const char *outdir, char *err)
{
	const pr_cmd_args *a = m->a;
	pr_exp_table **t = calloc((size_t)a->ninputs, sizeof *t);
	mrow *rows = NULL;
	origin *o = &m->o[m->no];
	long n = 0, i;
	char path[PATHLEN];
	int k, j, rc = PR_OK;
	pr_csvw *w = NULL;

	if (!t)
		return pr_err(err, PR_ENOMEM, "out of memory merging %s", name);
	for (k = 0; rc == PR_OK && k < a->ninputs; ++k) {
		snprintf(path, sizeof path, "%s/%s", a->inputs[k], name);
		if ((rc = pr_exp_table_read(path, &t[k], err)))
			break;
		if (pr_exp_table_ncols(t[k]) != pr_exp_table_ncols(t[0]))
			rc = pr_err(err, PR_EIO, "%s:1: header differs from %s/%s", path, a->inputs[0], name);
		for (j = 0; rc == PR_OK && j < pr_exp_table_ncols(t[k]); ++j)
			if (strcmp(pr_exp_table_name(t[k], j), pr_exp_table_name(t[0], j)) != 0)
				rc = pr_err(err, PR_EIO, "%s:1: header differs from %s/%s", path, a->inputs[0], name);
		n += pr_exp_table_nrows(t[k]);
	}
	if (rc == PR_OK && !(rows = malloc((size_t)(n ? n : 1) * sizeof *rows)))
		rc = pr_err(err, PR_ENOMEM, "out of memory merging %s", name);
	for (n = 0, k = 0; rc == PR_OK && k < a->ninputs; ++k)
		for (i = 0; rc == PR_OK && i < pr_exp_table_nrows(t[k]); ++i, ++n) {
			rows[n].src = k;
			rows[n].var = m->var[k];
			rows[n].row = i;
			rc = pr_exp_table_int(t[k], i, 0, 0, m->nrep - 1, &rows[n].rep, err);
			/* a run of one repetition holds only that one's rows */
			if (rc == PR_OK && m->rep[k] >= 0 && rows[n].rep != m->rep[k])
				rc = pr_err(err, PR_EIO, "%s/%s:%ld: repetition %ld, but %s/config.ini ran "
				            "only repetition %d", a->inputs[k], name, pr_exp_table_line(t[k], i),
				            rows[n].rep, a->inputs[k], m->rep[k]);
		}
	if (rc == PR_OK && n > 0)
		qsort(rows, (size_t)n, sizeof *rows, cmp_mrow);
	/* inputs split by variant share repetitions, each its own rows */
	for (i = 1; rc == PR_OK && i < n; ++i)
		if (rows[i].rep == rows[i - 1].rep && rows[i].src != rows[i - 1].src &&
		    (rows[i].var == rows[i - 1].var || rows[i - 1].var < 0))
			rc = pr_err(err, PR_EINVAL, "%s/%s and %s/%s both hold repetition %ld",
			            a->inputs[rows[i - 1].src], name, a->inputs[rows[i].src], name,
			            rows[i].rep);
	if (rc == PR_OK) {
		o->name = strdup(name);
		o->src = malloc((size_t)(n ? n : 1) * sizeof *o->src);
		o->line = malloc((size_t)(n ? n : 1) * sizeof *o->line);
		m->no++;
		if (!o->name || !o->src || !o->line)
			rc = pr_err(err, PR_ENOMEM, "out of memory merging %s", name);
	}
	if (rc == PR_OK) {
		snprintf(path, sizeof path, "%s/%s", outdir, name);
		if (!(w = pr_csvw_open(path, err)))
			rc = PR_EIO;
	}
	if (rc == PR_OK) {
		for (j = 0; j < pr_exp_table_ncols(t[0]); ++j)
			pr_csvw_str(w, pr_exp_table_name(t[0], j));
		pr_csvw_endrow(w);
		for (i = 0; i < n; ++i) {
			const pr_exp_table *src = t[rows[i].src];
			for (j = 0; j < pr_exp_table_ncols(src); ++j)
				pr_csvw_str(w, pr_exp_table_str(src, rows[i].row, j));
			pr_csvw_endrow(w);
			o->src[i] = rows[i].src;
			o->line[i] = pr_exp_table_line(src, rows[i].row);
		}
		o->n = n;
		rc = pr_csvw_close(w, err);
	}
	for (k = 0; k < a->ninputs; ++k)
		pr_exp_table_free(t[k]);
	free(t);
	free(rows);
	return rc;
}

static int is_raw_csv(const char *dir, const char *name)
{
	char path[PATHLEN], buf[16] = "";
	size_t n = strlen(name);
	struct stat st;
	FILE *fp;

	if (n < 5 || strcmp(name + n - 4, ".csv") != 0)
		return 0;
	snprintf(path, sizeof path, "%s/%s", dir, name);
	/* a FIFO would block the open */
	if (stat(path, &st) != 0 || !S_ISREG(st.st_mode))
		return 0;
	fp = fopen(path, "r");
	if (!fp)
		return 0;
	if (!fgets(buf, sizeof buf, fp))
		buf[0] = '\0';
	fclose(fp);
	return strncmp(buf, "repetition,", 11) == 0;
}

/* The raw CSVs (leading repetition column) of folder dir. */
static int raw_csvs(const char *dir, names *out, char *err)
{
	names all = {NULL, 0};
	int i, rc = list_files(dir, &all, err);

	for (i = 0; rc == PR_OK && i < all.n; ++i)
		if (is_raw_csv(dir, all.name[i]) && names_add(out, all.name[i], strlen(all.name[i])))
			rc = pr_err(err, PR_ENOMEM, "out of memory");
	names_free(&all);
	return rc;
}

/* An error at "<dir>/<name>:<line>:" of a merged file: name the source. */
static void to_source(char *err, const merge_ctx *m, const char *dir)
{
	char out[PR_ERRLEN], *end;
	size_t n = strlen(dir);
	long line, i;
	int k;

	if (strncmp(err, dir, n) != 0 || err[n] != '/')
		return;
	for (k = 0; k < m->no; ++k) {
		size_t len = strlen(m->o[k].name);
		if (strncmp(err + n + 1, m->o[k].name, len) != 0 || err[n + 1 + len] != ':')
			continue;
		line = strtol(err + n + 2 + len, &end, 10);
		i = line - 2; /* line 1 is the header */
		if (*end != ':' || i < 0 || i >= m->o[k].n)
			return;
		snprintf(out, sizeof out, "%s/%s:%ld%s", m->a->inputs[m->o[k].src[i]], m->o[k].name,
		         m->o[k].line[i], end);
		memcpy(err, out, strlen(out) + 1);
		return;
	}
}

static int merge_work(const pr_config *cfg, const char *dir, const pr_cmd_args *a, char *err)
{
	const pr_experiment *e = pr_exp_find(cfg->run.name);
	names raw = {NULL, 0}, other = {NULL, 0};
	merge_ctx m = {a, NULL, 0, cfg->run.repetitions, NULL, NULL};
	pr_config c;
	int rc = PR_OK, i, k;

	m.rep = malloc((size_t)a->ninputs * sizeof *m.rep);
	m.var = malloc((size_t)a->ninputs * sizeof *m.var);
	if (!m.rep || !m.var)
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	for (k = 0; rc == PR_OK && k < a->ninputs; ++k)
		if ((rc = input_config(a, k, &c, err)) == PR_OK) {
			m.rep[k] = c.run.repetition;
			m.var[k] = c.run.variant;
		}
	if (rc == PR_OK)
		rc = raw_csvs(a->inputs[0], &raw, err);
	/* every input holds the same raw CSVs */
	for (k = 1; rc == PR_OK && k < a->ninputs; ++k) {
		rc = raw_csvs(a->inputs[k], &other, err);
		for (i = 0; rc == PR_OK && i < raw.n + other.n; ++i) {
			const char *nm = i < raw.n ? raw.name[i] : other.name[i - raw.n];
			if (!names_has(i < raw.n ? &other : &raw, nm))
				rc = pr_err(err, PR_EIO, "%s/%s: %s, but not in %s", i < raw.n ? a->inputs[0] : a->inputs[k],
				            nm, "a raw CSV of this run", i < raw.n ? a->inputs[k] : a->inputs[0]);
		}
		names_free(&other);
	}
	if (rc == PR_OK && raw.n && !(m.o = calloc((size_t)raw.n, sizeof *m.o)))
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	for (i = 0; rc == PR_OK && i < raw.n; ++i)
		rc = merge_csv(&m, raw.name[i], dir, err);
	if (rc == PR_OK && e && e->summarize && (rc = e->summarize(cfg, dir, err)))
		to_source(err, &m, dir);
	for (i = 0; i < m.no; ++i) {
		free(m.o[i].name);
		free(m.o[i].src);
		free(m.o[i].line);
	}
	free(m.o);
	free(m.rep);
	free(m.var);
	names_free(&raw);
	return rc;
}

/* Which input holds each (repetition, variant) cell of the merged run: every
 * cell by exactly one input, as one process would have written it. nv is
 * the experiment's variant count (0: it has none). */
static int check_cells(const pr_cmd_args *a, const pr_config *cfg, int nv, char *err)
{
	const int nc = nv > 0 ? nv : 1, nrep = cfg->run.repetitions;
	int *held = calloc((size_t)nrep * (size_t)nc, sizeof *held);
	pr_config c;
	int rc = held ? PR_OK : pr_err(err, PR_ENOMEM, "out of memory"), k, r, v;

	for (k = 0; rc == PR_OK && k < a->ninputs; ++k) {
		int r0, v0;

		if ((rc = input_config(a, k, &c, err)))
			break;
		r0 = c.run.repetition;
		v0 = c.run.variant;
		for (r = r0 < 0 ? 0 : r0; rc == PR_OK && r < (r0 < 0 ? nrep : r0 + 1); ++r)
			for (v = v0 < 0 ? 0 : v0; rc == PR_OK && v < (v0 < 0 ? nc : v0 + 1); ++v) {
				int *h = &held[(size_t)r * (size_t)nc + (size_t)v];
				if (*h)
					rc = nv ? pr_err(err, PR_EINVAL, "%s and %s both hold repetition %d of variant %d",
					                 a->inputs[*h - 1], a->inputs[k], r, v)
					        : pr_err(err, PR_EINVAL, "%s and %s both hold repetition %d",
					                 a->inputs[*h - 1], a->inputs[k], r);
				*h = k + 1;
			}
	}
	for (r = 0; rc == PR_OK && r < nrep; ++r)
		for (v = 0; rc == PR_OK && v < nc; ++v)
			if (!held[(size_t)r * (size_t)nc + (size_t)v])
				rc = nv ? pr_err(err, PR_EINVAL, "merge: no input ran repetition %d of variant %d "
				                 "(experiment.repetitions = %d, %d variants)", r, v, nrep, nv)
				        : pr_err(err, PR_EINVAL, "merge: no input ran repetition %d "
				                 "(experiment.repetitions = %d)", r, nrep);
	free(held);
	return rc;
}

int pr_cmd_merge(const pr_config *cfg0, const pr_cmd_args *a, char *err)
{
	static const char *const may_differ[] = {"experiment.repetition", "experiment.variant", NULL};
	pr_config cfg, other;
	pr_variants variants;
	char key[64], va[160], vb[160];
	char *out, *in;
	int rc, k;

	(void)cfg0;
	if (!a->output)
		return pr_err(err, PR_EINVAL, "merge: -o DIR is required");
	if (a->ninputs < 1)
		return pr_err(err, PR_EINVAL, "merge: no input folders given");
	/* the merged run is described by the inputs' own configuration, which
	 * must agree in everything but the repetition and the variant */
	if ((rc = input_config(a, 0, &cfg, err)))
		return rc;
	for (k = 1; rc == PR_OK && k < a->ninputs; ++k)
		if ((rc = input_config(a, k, &other, err)) == PR_OK &&
		    pr_config_diff(&cfg, &other, may_differ, key, sizeof key, va, vb, sizeof va))
			rc = pr_err(err, PR_EINVAL, "%s/config.ini: %s = %s, but %s/config.ini has %s (merged "
			            "runs may differ only in experiment.repetition and experiment.variant)",
			            a->inputs[k], key, vb, a->inputs[0], va);
	cfg.run.variant = -1;
	if (rc == PR_OK)
		rc = pr_exp_variants(&cfg, &variants, err);
	if (rc == PR_OK)
		rc = check_cells(a, &cfg, variants.n, err);
	if (rc)
		return rc;
	/* writing into one of the inputs would replace what is being read */
	out = realpath(a->output, NULL);
	for (k = 0; out && k < a->ninputs; ++k) {
		in = realpath(a->inputs[k], NULL);
		rc = in && strcmp(in, out) == 0;
		free(in);
		if (rc) {
			free(out);
			return pr_err(err, PR_EINVAL, "merge: -o %s is also an input folder", a->output);
		}
	}
	free(out);
	cfg.run.repetition = -1;
	cfg.run.variant = -1;
	return pr_run_staged(&cfg, a, a->output, merge_work, err);
}
