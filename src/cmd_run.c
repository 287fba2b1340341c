/* cmd_run.c — `poolreps CONFIG` and `poolreps merge`: run an experiment into
 * an output folder with its provenance, and merge per-process outputs.
 *
 * Everything a run writes goes first into a staging folder DIR/.partial-PID
 * and is moved into DIR only when the whole run succeeded, so a failed or
 * interrupted run leaves no partial CSV behind.
 */
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/utsname.h>
#include <time.h>
#include <unistd.h>

#include "poolreps/cmd.h"
#include "poolreps/csvio.h"
#include "poolreps/exp.h"
#include "run_priv.h"

#define PATHLEN 1024

static int mkdir_p(const char *dir, char *err)
{
	char buf[PATHLEN];
	char *p;
	struct stat st;

	if (!*dir)
		return pr_err(err, PR_EINVAL, "output folder name is empty");
	if (snprintf(buf, sizeof buf, "%s", dir) >= (int)sizeof buf)
		return pr_err(err, PR_EINVAL, "%.100s...: path too long", dir);
	for (p = buf + 1; ; ++p) {
		if (*p == '/' || *p == '\0') {
			char c = *p;
			*p = '\0';
			if (mkdir(buf, 0777) != 0 && errno != EEXIST)
				return pr_err(err, PR_EIO, "%s: cannot create folder: %s", buf, strerror(errno));
			*p = c;
			if (!c)
				break;
		}
	}
	if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode))
		return pr_err(err, PR_EIO, "%s: exists and is not a folder", dir);
	return PR_OK;
}

static void remove_tree(const char *dir)
{
	DIR *d = opendir(dir);
	struct dirent *e;
	char path[PATHLEN];

	if (!d)
		return;
	while ((e = readdir(d))) {
		if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
			continue;
		if (snprintf(path, sizeof path, "%s/%s", dir, e->d_name) < (int)sizeof path)
			unlink(path);
	}
	closedir(d);
	rmdir(dir);
}

/* Move every file of staging into dir, then remove staging. */
static int publish(const char *staging, const char *dir, char *err)
{
	DIR *d = opendir(staging);
	struct dirent *e;
	char from[PATHLEN], to[PATHLEN];
	int rc = PR_OK;

	if (!d)
		return pr_err(err, PR_EIO, "%s: cannot read: %s", staging, strerror(errno));
	while (rc == PR_OK && (e = readdir(d))) {
		if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
			continue;
		if (snprintf(from, sizeof from, "%s/%s", staging, e->d_name) >= (int)sizeof from ||
		    snprintf(to, sizeof to, "%s/%s", dir, e->d_name) >= (int)sizeof to)
			rc = pr_err(err, PR_EINVAL, "%.100s.../%.100s: path too long", dir, e->d_name);
		else if (rename(from, to) != 0)
			rc = pr_err(err, PR_EIO, "%s: cannot move into place: %s", to, strerror(errno));
	}
	closedir(d);
	remove_tree(staging);
	return rc;
}

int pr_run_write_config(const pr_config *cfg, const char *dir, char *err)
{
	char path[PATHLEN], tmp[PATHLEN + 16];
	FILE *fp;
	int bad;

	snprintf(path, sizeof path, "%s/config.ini", dir);
	snprintf(tmp, sizeof tmp, "%s.tmp", path);
	fp = fopen(tmp, "w");
	if (!fp)
		return pr_err(err, PR_EIO, "%s: cannot write: %s", path, strerror(errno));
	fprintf(fp, "; effective configuration written by poolreps %s\n", pr_version());
	bad = pr_config_write(cfg, fp) != PR_OK;
	bad |= fclose(fp) != 0;
	if (bad || rename(tmp, path) != 0) {
		unlink(tmp);
		return pr_err(err, PR_EIO, "%s: write error", path);
	}
	return PR_OK;
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

int pr_run_write_provenance(const pr_config *cfg, const pr_cmd_args *a, const char *dir,
                            double wall, char *err)
{
	char path[PATHLEN], tmp[PATHLEN + 16], host[256] = "unknown", when[64];
	struct rusage ru;
	struct utsname un;
	time_t now = time(NULL);
	FILE *fp;
	int i, bad;

	snprintf(path, sizeof path, "%s/provenance.txt", dir);
	snprintf(tmp, sizeof tmp, "%s.tmp", path);
	fp = fopen(tmp, "w");
	if (!fp)
		return pr_err(err, PR_EIO, "%s: cannot write: %s", path, strerror(errno));
	gethostname(host, sizeof host - 1);
	strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", gmtime(&now));
	getrusage(RUSAGE_SELF, &ru);
	fprintf(fp, "version: %s\n", pr_version());
	fprintf(fp, "command:");
	for (i = 0; i < a->argc; ++i) {
		fputc(' ', fp);
		pr_run_shell_word(fp, a->argv[i]);
	}
	fprintf(fp, "\nexperiment: %s\nseed: %lu\nrepetition: %d\nparameter_file: %s\n",
	        cfg->run.name, cfg->run.seed, cfg->run.repetition,
	        cfg->source[0] ? cfg->source : "(none)");
	if (uname(&un) == 0)
		fprintf(fp, "host: %s (%s %s %s)\n", host, un.sysname, un.release, un.machine);
	else
		fprintf(fp, "host: %s\n", host);
	fprintf(fp, "finished: %s\nwall_seconds: %.3f\ncpu_seconds: %.3f\npeak_memory_mib: %.1f\n",
	        when, wall,
	        (double)ru.ru_utime.tv_sec + 1e-6 * (double)ru.ru_utime.tv_usec +
	        (double)ru.ru_stime.tv_sec + 1e-6 * (double)ru.ru_stime.tv_usec,
	        (double)ru.ru_maxrss / 1024.0);
	bad = ferror(fp);
	bad |= fclose(fp) != 0;
	if (bad || rename(tmp, path) != 0) {
		unlink(tmp);
		return pr_err(err, PR_EIO, "%s: write error", path);
	}
	return PR_OK;
}

static double seconds_since(const struct timespec *t0)
{
	struct timespec t1;

	clock_gettime(CLOCK_MONOTONIC, &t1);
	return (double)(t1.tv_sec - t0->tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0->tv_nsec);
}

int pr_run_staged(const pr_config *cfg, const pr_cmd_args *a, const char *dir,
                  int (*work)(const pr_config *, const char *, const pr_cmd_args *, char *),
                  char *err)
{
	char staging[PATHLEN];
	struct timespec t0;
	struct stat st;
	int rc, existed = stat(dir, &st) == 0;

	clock_gettime(CLOCK_MONOTONIC, &t0);
	if ((rc = mkdir_p(dir, err)))
		return rc;
	if (snprintf(staging, sizeof staging, "%s/.partial-%ld", dir, (long)getpid()) >= (int)sizeof staging)
		return pr_err(err, PR_EINVAL, "%.100s...: path too long", dir);
	remove_tree(staging);
	if (mkdir(staging, 0777) != 0)
		return pr_err(err, PR_EIO, "%s: cannot create folder: %s", staging, strerror(errno));
	rc = work(cfg, staging, a, err);
	if (rc == PR_OK)
		rc = pr_run_write_config(cfg, staging, err);
	if (rc == PR_OK)
		rc = pr_run_write_provenance(cfg, a, staging, seconds_since(&t0), err);
	if (rc != PR_OK || pr_interrupted) {
		remove_tree(staging);
		/* a failed run leaves no trace: drop the folder if we made it (and it is empty) */
		if (!existed)
			rmdir(dir);
		/* after a signal every failure is its echo (a fit cut short may report
		 * itself as a numerical failure): say what the user is left with */
		if (pr_interrupted)
			rc = pr_err(err, PR_EINTR, existed ?
			            "interrupted: no output written; partial files removed, %s left as it was" :
			            "interrupted: no output written; partial files and the new folder %s removed",
			            dir);
		return rc;
	}
	return publish(staging, dir, err);
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
	long order;
	char *text;
} row;

static int cmp_row(const void *x, const void *y)
{
	const row *a = x, *b = y;

	if (a->rep != b->rep)
		return a->rep < b->rep ? -1 : 1;
	if (a->var != b->var)
		return a->var < b->var ? -1 : 1;
	if (a->src != b->src)
		return a->src < b->src ? -1 : 1;
	return a->order < b->order ? -1 : a->order > b->order;
}

/* Concatenate the raw CSV `name` of every input folder, ordered by the
 * leading repetition column, then by the input's variant (var[k]); a
 * repetition of one variant present in two inputs is an error. */
static int merge_csv(const pr_cmd_args *a, const int *var, const char *name, const char *outdir,
                     char *err)
{
	row *rows = NULL;
	long n = 0, cap = 0, i;
	char path[PATHLEN], *header = NULL, *line = NULL;
	size_t lcap = 0;
	int k, rc = PR_OK;
	FILE *fp;

	for (k = 0; rc == PR_OK && k < a->ninputs; ++k) {
		long lineno = 0;
		ssize_t len;
		snprintf(path, sizeof path, "%s/%s", a->inputs[k], name);
		fp = fopen(path, "r");
		if (!fp) {
			rc = pr_err(err, PR_EIO, "%s: cannot open: %s", path, strerror(errno));
			break;
		}
		while (rc == PR_OK && (len = getline(&line, &lcap, fp)) != -1) {
			char *end;
			long rep;
			++lineno;
			if (lineno == 1) {
				if (!header)
					header = strdup(line);
				else if (strcmp(header, line) != 0)
					rc = pr_err(err, PR_EIO, "%s:1: header differs from %s/%s",
					            path, a->inputs[0], name);
				continue;
			}
			rep = strtol(line, &end, 10);
			if (end == line || *end != ',') {
				rc = pr_err(err, PR_EIO, "%s:%ld: column 'repetition': not an integer", path, lineno);
				break;
			}
			if (n == cap) {
				row *r2;
				cap = cap ? 2 * cap : 1024;
				r2 = realloc(rows, (size_t)cap * sizeof *rows);
				if (!r2) {
					rc = pr_err(err, PR_ENOMEM, "out of memory merging %s", name);
					break;
				}
				rows = r2;
			}
			rows[n].rep = rep;
			rows[n].var = var[k];
			rows[n].src = k;
			rows[n].order = lineno;
			if (!(rows[n].text = strdup(line))) {
				rc = pr_err(err, PR_ENOMEM, "out of memory merging %s", name);
				break;
			}
			++n;
		}
		fclose(fp);
	}
	if (rc == PR_OK) {
		if (n > 0)
			qsort(rows, (size_t)n, sizeof *rows, cmp_row);
		for (i = 1; i < n; ++i)
			if (rows[i].rep == rows[i - 1].rep && rows[i].src != rows[i - 1].src &&
			    (rows[i].var == rows[i - 1].var || rows[i - 1].var < 0)) {
				rc = pr_err(err, PR_EINVAL, "%s/%s and %s/%s both hold repetition %ld",
				            a->inputs[rows[i - 1].src], name, a->inputs[rows[i].src], name,
				            rows[i].rep);
				break;
			}
	}
	if (rc == PR_OK) {
		char tmp[PATHLEN + 16];
		int bad;
		snprintf(path, sizeof path, "%s/%s", outdir, name);
		snprintf(tmp, sizeof tmp, "%s.tmp", path);
		fp = fopen(tmp, "w");
		if (!fp) {
			rc = pr_err(err, PR_EIO, "%s: cannot write: %s", path, strerror(errno));
		} else {
			fputs(header ? header : "", fp);
			for (i = 0; i < n; ++i)
				fputs(rows[i].text, fp);
			bad = ferror(fp);
			bad |= fclose(fp) != 0;
			if (bad || rename(tmp, path) != 0) {
				unlink(tmp);
				rc = pr_err(err, PR_EIO, "%s: write error", path);
			}
		}
	}
	for (i = 0; i < n; ++i)
		free(rows[i].text);
	free(rows);
	free(header);
	free(line);
	return rc;
}

static int is_raw_csv(const char *dir, const char *name)
{
	char path[PATHLEN], buf[16] = "";
	size_t n = strlen(name);
	FILE *fp;

	if (n < 5 || strcmp(name + n - 4, ".csv") != 0)
		return 0;
	snprintf(path, sizeof path, "%s/%s", dir, name);
	fp = fopen(path, "r");
	if (!fp)
		return 0;
	if (!fgets(buf, sizeof buf, fp))
		buf[0] = '\0';
	fclose(fp);
	return strncmp(buf, "repetition,", 11) == 0;
}

/* Merge over variants: experiment.variant of every input, from its
 * config.ini (an experiment's rows of one repetition come in variant order). */
static int input_variants(const pr_cmd_args *a, int *var, char *err)
{
	char path[PATHLEN];
	pr_config c;
	int k, rc;

	for (k = 0; k < a->ninputs; ++k) {
		pr_config_init(&c);
		snprintf(path, sizeof path, "%s/config.ini", a->inputs[k]);
		if ((rc = pr_config_load(&c, path, err)))
			return rc;
		var[k] = c.run.variant;
	}
	return PR_OK;
}

static int merge_work(const pr_config *cfg, const char *dir, const pr_cmd_args *a, char *err)
{
	const pr_experiment *e = pr_exp_find(cfg->run.name);
	int *var = malloc((size_t)a->ninputs * sizeof *var);
	DIR *d = opendir(a->inputs[0]);
	struct dirent *ent;
	int rc = var ? input_variants(a, var, err) : pr_err(err, PR_ENOMEM, "out of memory");

	if (!d) {
		free(var);
		return pr_err(err, PR_EIO, "%s: cannot read folder: %s", a->inputs[0], strerror(errno));
	}
	while (rc == PR_OK && (ent = readdir(d)))
		if (is_raw_csv(a->inputs[0], ent->d_name))
			rc = merge_csv(a, var, ent->d_name, dir, err);
	closedir(d);
	free(var);
	if (rc == PR_OK && e && e->summarize)
		rc = e->summarize(cfg, dir, err);
	return rc;
}

int pr_cmd_merge(const pr_config *cfg0, const pr_cmd_args *a, char *err)
{
	pr_config cfg;
	char path[PATHLEN];
	int rc, k;

	(void)cfg0;
	if (!a->output)
		return pr_err(err, PR_EINVAL, "merge: -o DIR is required");
	if (a->ninputs < 1)
		return pr_err(err, PR_EINVAL, "merge: no input folders given");
	/* the merged run is described by the inputs' own configuration */
	for (k = 0; k < a->ninputs; ++k) {
		pr_config other;
		pr_config_init(k ? &other : &cfg);
		snprintf(path, sizeof path, "%s/config.ini", a->inputs[k]);
		if ((rc = pr_config_load(k ? &other : &cfg, path, err)))
			return rc;
		if (k && (strcmp(other.run.name, cfg.run.name) != 0 || other.run.seed != cfg.run.seed ||
		          other.run.repetitions != cfg.run.repetitions))
			return pr_err(err, PR_EINVAL, "%s: experiment, seed or repetitions differ from %s/config.ini",
			              path, a->inputs[0]);
	}
	cfg.run.repetition = -1;
	cfg.run.variant = -1;
	return pr_run_staged(&cfg, a, a->output, merge_work, err);
}
