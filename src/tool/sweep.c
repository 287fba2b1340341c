/* sweep.c — what `poolreps sweep` and `poolreps collect` do (rundir.h): a
 * grid of parameter values split into self-contained jobs for a Slurm array
 * or GNU Parallel, and the jobs' outputs merged back into one table over the
 * grid.
 *
 * SWEEP_DIR as `sweep` writes it (staged, published only when complete):
 *   manifest.csv        one row per job: job,point,<grid keys>,repetition,
 *                       variant,variant_name,output (-1 and "all": not split
 *                       that way; output is relative to SWEEP_DIR)
 *   jobs.txt            line j + 1 is job j: one sh command, absolute paths
 *   slurm.sbatch        a Slurm array over jobs.txt (logs/ for its output)
 *   parallel.sh         the GNU Parallel command line over jobs.txt
 *   config.ini, provenance.txt  the base configuration and how it was made
 * Job j is `poolreps run config.ini --set KEY=VALUE...` with the values of
 * its grid point P, restricted to one repetition and/or one variant, into
 * point-P/runs/NAME, which the job creates: setting up a sweep writes these
 * few files whatever the grid's size (no folder per point). A run publishes its folder
 * only when it succeeded, provenance.txt with it: that file marks a job done.
 * Every job draws only from the streams of its own (repetition, variant), so
 * the bytes do not depend on where, when or in which order jobs run.
 *
 * `collect` merges each point's job folders through `poolreps merge` (its
 * checks included) into point-P/merged, and writes sweep_summary.csv: the
 * grid values, then every row of the experiment's summary CSV. All of it is
 * staged in SWEEP_DIR/.partial-TAG and moved into place only at the end.
 */
#define _XOPEN_SOURCE 700 /* realpath */
#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "poolreps/config.h"
#include "poolreps/csvio.h"
#include "poolreps/exp.h"
#include "poolreps/rundir.h"
#include "csvio_priv.h"
#include "exp_priv.h"
#include "outdir.h"

#define ROOTMAX 480  /* a sweep folder's path; names below it: NAMEMAX */
#define NAMEMAX 400
#define MAX_AXES 16
#define MAX_JOBS 1000000L
#define JOBLINE (3 * PR_PATHLEN) /* a line of jobs.txt, its newline included */

enum { SPLIT_REP = 1, SPLIT_VAR = 2 };
enum { JOB_DONE, JOB_MISSING, JOB_FAILED };

/* One --grid KEY=V1,V2,...: values point into text. */
typedef struct {
	char key[64];
	char *text;
	char **value;
	int n;
} axis;

typedef struct {
	axis ax[MAX_AXES];
	int nax;
	long npoints;
	int split;
} grid;

static void grid_free(grid *g)
{
	int i;

	for (i = 0; i < g->nax; ++i) {
		free(g->ax[i].text);
		free(g->ax[i].value);
	}
}

/* snprintf into buf[n] for paths below a sweep folder: checked lengths
 * (ROOTMAX, NAMEMAX) make them fit PR_PATHLEN. */
static void fmt(char *buf, size_t n, const char *f, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 3, 4)))
#endif
	;
static void fmt(char *buf, size_t n, const char *f, ...)
{
	va_list ap;

	va_start(ap, f);
	vsnprintf(buf, n, f, ap);
	va_end(ap);
}

static int exists(const char *path)
{
	struct stat st;

	return stat(path, &st) == 0;
}

static void point_name(char *buf, size_t n, long p, long npoints)
{
	int width = 1;
	long m;

	for (m = npoints - 1; m >= 10; m /= 10)
		++width;
	fmt(buf, n, "point-%0*ld", width, p);
}

/* ---- sweep ---- */

static int parse_split(const char *s, int *split, char *err)
{
	if (!s || strcmp(s, "repetition") == 0)
		*split = SPLIT_REP;
	else if (strcmp(s, "variant") == 0)
		*split = SPLIT_VAR;
	else if (strcmp(s, "both") == 0)
		*split = SPLIT_REP | SPLIT_VAR;
	else
		return pr_err(err, PR_EINVAL, "--split %.40s: must be repetition, variant or both", s);
	return PR_OK;
}

/* Blanks (spaces, tabs) at both ends of s[0..n) cut: *s and n updated. */
static void cut_blanks(const char **s, size_t *n)
{
	while (*n && (**s == ' ' || **s == '\t'))
		++*s, --*n;
	while (*n && ((*s)[*n - 1] == ' ' || (*s)[*n - 1] == '\t'))
		--*n;
}

/* The key of "KEY=..." as pr_config_set reads it, blanks around the section
 * and the name dropped: "forest . trees " is forest.trees. */
static int axis_key(const char *arg, const char *eq, char *key, size_t size)
{
	const char *dot = memchr(arg, '.', (size_t)(eq - arg)), *sec = arg, *name;
	size_t ns, nn;

	if (!dot)
		return -1;
	ns = (size_t)(dot - arg);
	name = dot + 1;
	nn = (size_t)(eq - name);
	cut_blanks(&sec, &ns);
	cut_blanks(&name, &nn);
	if (!ns || !nn || ns + nn + 1 >= size)
		return -1;
	snprintf(key, size, "%.*s.%.*s", (int)ns, sec, (int)nn, name);
	return 0;
}

/* A grid value as the key it sets: two values set it alike when they are
 * the same text once blanks are cut, or the same number (10 and 010, 1e1). */
typedef struct {
	int num;          /* a number (then x), else the text s[0..n) */
	double x;
	const char *s;
	size_t n;
	int at;           /* its place in the list */
} grid_value;

static grid_value value_key(const char *s, int at)
{
	grid_value v = {0, 0.0, s, strlen(s), at};
	char buf[64];

	cut_blanks(&v.s, &v.n);
	if (v.n < sizeof buf) {
		snprintf(buf, sizeof buf, "%.*s", (int)v.n, v.s);
		/* NaN equals nothing, as before: it stays text */
		v.num = pr_csv_parse_double(buf, &v.x) == 0 && v.x == v.x;
	}
	return v;
}

/* Numbers before texts, numbers by value, texts by bytes, then by place. */
static int value_cmp(const void *pa, const void *pb)
{
	const grid_value *a = pa, *b = pb;
	int c;

	if (a->num != b->num)
		return b->num - a->num;
	if (a->num)
		c = (a->x > b->x) - (a->x < b->x);
	else if (!(c = memcmp(a->s, b->s, a->n < b->n ? a->n : b->n)))
		c = (a->n > b->n) - (a->n < b->n);
	return c ? c : a->at - b->at;
}

/* The first value (in list order) that repeats an earlier one, and that
 * earlier one: sorted, the equal values are neighbours (n log n, where
 * comparing each with all before it took 17 s for 20,000 values). *i = -1
 * when none repeats. */
static int first_repeat(char *const *value, int n, int *i, int *j)
{
	grid_value *v = malloc(((size_t)n + 1) * sizeof *v);
	int k;

	if (!v)
		return PR_ENOMEM;
	for (k = 0; k < n; ++k)
		v[k] = value_key(value[k], k);
	qsort(v, (size_t)n, sizeof *v, value_cmp);
	*i = *j = -1;
	for (k = 1; k < n; ++k) {
		grid_value a = v[k - 1], b = v[k];

		a.at = b.at = 0;
		/* the first of a run of equal values is where the run started */
		if (value_cmp(&a, &b) == 0 && (*i < 0 || v[k].at < *i)) {
			int first = k - 1;
			while (first > 0 && (a = v[first - 1], a.at = 0, value_cmp(&a, &b) == 0))
				--first;
			*i = v[k].at;
			*j = v[first].at;
		}
	}
	free(v);
	return PR_OK;
}

/* Split "KEY=V1,V2,..." into ax; the values are checked per point. */
static int parse_axis(const char *arg, axis *ax, const grid *g, char *err)
{
	const char *eq = strchr(arg, '=');
	char *p;
	int i, j;

	memset(ax, 0, sizeof *ax);
	if (!eq || eq == arg || axis_key(arg, eq, ax->key, sizeof ax->key) != 0)
		return pr_err(err, PR_EINVAL, "--grid %.80s: expected section.key=value1,value2,...", arg);
	if (strcmp(ax->key, "experiment.name") == 0 || strcmp(ax->key, "experiment.repetition") == 0 ||
	    strcmp(ax->key, "experiment.variant") == 0)
		return pr_err(err, PR_EINVAL, "--grid %s: a sweep keeps one experiment and chooses "
		              "repetitions and variants itself (--split)", ax->key);
	for (i = 0; i < g->nax; ++i)
		if (strcmp(g->ax[i].key, ax->key) == 0)
			return pr_err(err, PR_EINVAL, "--grid %s: key given twice", ax->key);
	ax->text = strdup(eq + 1);
	ax->value = malloc((strlen(eq + 1) / 2 + 1) * sizeof *ax->value);
	if (!ax->text || !ax->value)
		return pr_err(err, PR_ENOMEM, "out of memory");
	for (p = ax->text;; ++p) {
		ax->value[ax->n++] = p;
		p += strcspn(p, ",");
		if (!*p)
			break;
		*p = '\0';
	}
	for (i = 0; i < ax->n; ++i)
		if (!*ax->value[i])
			return pr_err(err, PR_EINVAL, "--grid %.80s: empty value", arg);
	if (first_repeat(ax->value, ax->n, &i, &j))
		return pr_err(err, PR_ENOMEM, "out of memory");
	if (i >= 0)
		return pr_err(err, PR_EINVAL, "--grid %s: value '%.40s' listed twice (as '%.40s')",
		              ax->key, ax->value[i], ax->value[j]);
	return PR_OK;
}

static int parse_grid(const pr_rundir_args *a, grid *g, char *err)
{
	int i, rc;

	memset(g, 0, sizeof *g);
	if ((rc = parse_split(a->split, &g->split, err)))
		return rc;
	if (a->ngrid > MAX_AXES)
		return pr_err(err, PR_EINVAL, "--grid: at most %d keys", MAX_AXES);
	g->npoints = 1;
	for (i = 0; i < a->ngrid; ++i) {
		rc = parse_axis(a->grid[i], &g->ax[g->nax], g, err);
		g->nax++;
		if (rc)
			return rc;
		g->npoints *= g->ax[i].n;
		if (g->npoints > MAX_JOBS)
			return pr_err(err, PR_EINVAL, "--grid: more than %ld grid points", MAX_JOBS);
	}
	return PR_OK;
}

/* Value index of axis i at point p: the last key varies fastest. */
static int value_index(const grid *g, long p, int i)
{
	int j;

	for (j = g->nax - 1; j > i; --j)
		p /= g->ax[j].n;
	return (int)(p % g->ax[i].n);
}

/* The configuration of point p: the base with the point's values, checked. */
/* Value v of axis ax into pt, a failure named as the --grid's. */
static int set_value(pr_config *pt, const axis *ax, int v, char *err)
{
	char set[PR_PATHLEN], inner[PR_ERRLEN];
	int rc;

	snprintf(set, sizeof set, "%s=%s", ax->key, ax->value[v]);
	if (!(rc = pr_config_set(pt, set, err)))
		return PR_OK;
	snprintf(inner, sizeof inner, "%s", strncmp(err, "--set: ", 7) ? err : err + 7);
	return pr_err(err, rc, "--grid %.300s", inner);
}

static int point_config(const pr_config *base, const grid *g, long p, pr_config *pt, char *err)
{
	int i, rc;

	*pt = *base;
	for (i = 0; i < g->nax; ++i)
		if ((rc = set_value(pt, &g->ax[i], value_index(g, p, i), err)))
			return rc;
	return pr_config_validate(pt, err);
}

/* Every value alone, before any point is written: a bad last value of a
 * long axis is refused at once, not after every point before it. */
static int check_values(const pr_config *base, const grid *g, char *err)
{
	pr_config pt;
	int i, v, rc = PR_OK;

	for (i = 0; rc == PR_OK && i < g->nax; ++i)
		for (v = 0; rc == PR_OK && v < g->ax[i].n; ++v) {
			pt = *base;
			rc = set_value(&pt, &g->ax[i], v, err);
		}
	return rc;
}

/* point-P/runs/NAME of a job: its repetition and variant, where split. */
static void job_output(char *buf, size_t n, const char *point, int rep, const char *variant)
{
	if (rep >= 0 && variant)
		fmt(buf, n, "%s/runs/rep-%d-%s", point, rep, variant);
	else if (rep >= 0)
		fmt(buf, n, "%s/runs/rep-%d", point, rep);
	else
		fmt(buf, n, "%s/runs/%s", point, variant);
}

/* root/name, as sh reads it back as one word. */
static void put_path(FILE *fp, const char *root, const char *name)
{
	char path[PR_PATHLEN];

	fmt(path, sizeof path, "%s/%s", root, name);
	pr_outdir_shell_word(fp, path);
}

/* Job line of point p into fp: the base configuration with the point's
 * values (as set_value sets them), its repetition and variant, its output. */
static void write_job(FILE *fp, const char *exe, const char *root, const grid *g, long p, int rep,
                      int var, const char *out)
{
	char set[PR_PATHLEN];
	int i;

	pr_outdir_shell_word(fp, exe);
	fputs(" run -q ", fp);
	put_path(fp, root, "config.ini");
	for (i = 0; i < g->nax; ++i) {
		fmt(set, sizeof set, "%s=%s", g->ax[i].key, g->ax[i].value[value_index(g, p, i)]);
		fputs(" --set ", fp);
		pr_outdir_shell_word(fp, set);
	}
	if (rep >= 0)
		fprintf(fp, " --set experiment.repetition=%d", rep);
	if (var >= 0)
		fprintf(fp, " --set experiment.variant=%d", var);
	fputs(" -o ", fp);
	put_path(fp, root, out);
	fputc('\n', fp);
}

static FILE *open_text(const char *dir, const char *name, char *path, char *err)
{
	FILE *fp;

	fmt(path, PR_PATHLEN, "%s/%s", dir, name);
	if (!(fp = fopen(path, "w")))
		pr_err(err, pr_errno_status(), "%s: cannot write: %s", path, strerror(errno));
	return fp;
}

/* The reason of a failed write: the flush of what is left fails again
 * (ENOSPC) and sets errno; a stream whose error has no errno left says EIO. */
static int close_text(FILE *fp, const char *path, char *err)
{
	int bad, e;

	errno = 0;
	bad = fflush(fp) != 0 || ferror(fp);
	e = errno;
	if (fclose(fp) != 0 && !bad) {
		bad = 1;
		e = errno;
	}
	if (!bad)
		return PR_OK;
	errno = e ? e : EIO;
	return pr_err(err, pr_errno_status(), "%s: write error: %s", path, strerror(errno));
}

/* Slurm's --output: '%' in the folder's own name is written as "%%", a
 * literal '%' to Slurm, which expands only the %A_%a of the log name; a
 * backslash as two, since Slurm's #SBATCH parser reads one as an escape,
 * even inside quotes (the line is a comment to sh). */
static void slurm_log_path(FILE *fp, const char *root)
{
	char path[PR_PATHLEN];
	size_t n = 0;
	const char *c;

	for (c = root; *c && n + 3 < sizeof path; ++c) {
		if (*c == '%' || *c == '\\')
			path[n++] = *c;
		path[n++] = *c;
	}
	path[n] = '\0';
	put_path(fp, path, "logs/%A_%a.out");
}

/* slurm.sbatch and parallel.sh: the two ways to run jobs.txt. */
static int write_runners(const char *dir, const char *root, long njobs, int threads, char *err)
{
	char path[PR_PATHLEN];
	FILE *fp;
	int rc;

	if (!(fp = open_text(dir, "slurm.sbatch", path, err)))
		return PR_EIO;
	fputs("#!/bin/sh\n"
	      "# Slurm array over the jobs of this sweep (written by poolreps sweep): task i\n"
	      "# runs line i + 1 of JOBS, by default jobs.txt beside this script.\n"
	      "#   sbatch slurm.sbatch                       every job\n"
	      "#   poolreps sweep --missing DIR > retry.txt  after a failure, the jobs not done:\n"
	      "#   sbatch --array=0-$(( $(wc -l < retry.txt) - 1 )) slurm.sbatch retry.txt\n"
	      "# Above the cluster's MaxArraySize, submit slices: task i then runs line\n"
	      "# POOLREPS_OFFSET + i + 1, e.g. --array=0-999 --export=ALL,POOLREPS_OFFSET=1000\n"
	      "#SBATCH --job-name=poolreps-sweep\n", fp);
	fprintf(fp, "#SBATCH --array=0-%ld\n#SBATCH --cpus-per-task=%d\n#SBATCH --output=", njobs - 1,
	        threads);
	slurm_log_path(fp, root);
	fputs("\nset -e\njobs=${1:-", fp);
	put_path(fp, root, "jobs.txt");
	fputs("}\n"
	      "line=$(sed -n \"$((SLURM_ARRAY_TASK_ID + ${POOLREPS_OFFSET:-0} + 1))p\" \"$jobs\")\n"
	      "[ -n \"$line\" ] || {\n"
	      "\techo \"slurm.sbatch: no job $SLURM_ARRAY_TASK_ID in $jobs\" >&2\n"
	      "\texit 1\n"
	      "}\n"
	      "exec sh -c \"$line\"\n", fp);
	if ((rc = close_text(fp, path, err)))
		return rc;
	if (!(fp = open_text(dir, "parallel.sh", path, err)))
		return PR_EIO;
	fputs("#!/bin/sh\n"
	      "# GNU Parallel over the jobs of this sweep (written by poolreps sweep); options\n"
	      "# go to parallel:\n"
	      "#   sh parallel.sh                              this machine, one job per CPU\n"
	      "#   sh parallel.sh -j 4                         four at a time\n"
	      "#   sh parallel.sh --sshlogin 8/host1,8/host2   over ssh: this folder and poolreps\n"
	      "#                                               at the same paths on every host\n"
	      "# parallel.log records each job's host, times and exit status.\n"
	      "exec parallel --joblog ", fp);
	put_path(fp, root, "parallel.log");
	fputs(" \"$@\" < ", fp);
	put_path(fp, root, "jobs.txt");
	fputc('\n', fp);
	return close_text(fp, path, err);
}

/* Everything a sweep writes, into the staging folder dir of SWEEP_DIR. */
typedef struct {
	const pr_config *cfg;
	const grid *g;
	const char *dir;
	char root[PR_PATHLEN];  /* SWEEP_DIR, absolute */
	char exe[PR_PATHLEN];   /* this poolreps, absolute */
	FILE *jobs;
	FILE *line;          /* a job's line, rendered into buf first */
	char buf[JOBLINE];
	pr_csvw *man;
	long njobs;
	int cpus;            /* threads a job can use: Slurm's --cpus-per-task */
} sweep_out;

static int manifest_header(sweep_out *s, char *err)
{
	char path[PR_PATHLEN];
	int i;

	fmt(path, sizeof path, "%s/manifest.csv", s->dir);
	if (!(s->man = pr_csvw_open(path, err)))
		return PR_EIO;
	pr_csvw_str(s->man, "job");
	pr_csvw_str(s->man, "point");
	for (i = 0; i < s->g->nax; ++i)
		pr_csvw_str(s->man, s->g->ax[i].key);
	pr_csvw_header(s->man, "repetition,variant,variant_name,output");
	return PR_OK;
}

/* Point p: its folder with config.ini, and one job per repetition x
 * variant that the split separates. */
static int sweep_point(sweep_out *s, long p, char *err)
{
	const grid *g = s->g;
	pr_config pt;
	pr_variants *vl = malloc(sizeof *vl);
	char point[64], out[PR_PATHLEN];
	int r, v, i, nr, nv, units, rc;

	if (!vl)
		return pr_err(err, PR_ENOMEM, "out of memory");
	point_name(point, sizeof point, p, g->npoints);
	rc = point_config(s->cfg, g, p, &pt, err);
	if (rc == PR_OK)
		rc = pr_exp_variants(&pt, vl, err);
	if (rc == PR_OK && (g->split & SPLIT_VAR) && vl->n == 0)
		rc = pr_err(err, PR_EINVAL, "--split %s: %s has no variants (exp1, exp3 and exp4 have)",
		            s->g->split & SPLIT_REP ? "both" : "variant", pt.run.name);
	if (rc != PR_OK) {
		free(vl);
		return rc;
	}
	nr = g->split & SPLIT_REP ? pt.run.repetitions : 1;
	nv = g->split & SPLIT_VAR ? vl->n : 1;
	/* a job's threads share its repetitions x variants */
	units = (g->split & SPLIT_REP ? 1 : pt.run.repetitions) *
	        (g->split & SPLIT_VAR || !vl->n ? 1 : vl->n);
	if (units > pt.run.threads)
		units = pt.run.threads;
	if (rc == PR_OK && units > s->cpus)
		s->cpus = units;
	if (rc == PR_OK && s->njobs + (long)nr * nv > MAX_JOBS)
		rc = pr_err(err, PR_EINVAL, "sweep: more than %ld jobs", MAX_JOBS);
	for (r = 0; rc == PR_OK && r < nr; ++r)
		for (v = 0; rc == PR_OK && v < nv; ++v) {
			int rep = g->split & SPLIT_REP ? r : -1, var = g->split & SPLIT_VAR ? v : -1;
			long len;
			job_output(out, sizeof out, point, rep, var >= 0 ? vl->name[var] : NULL);
			rewind(s->line);
			write_job(s->line, s->exe, s->root, g, p, rep, var, out);
			/* sweep --missing reads a line into JOBLINE bytes */
			if (fflush(s->line) != 0 || (len = ftell(s->line)) < 0 || len >= JOBLINE - 1) {
				rc = pr_err(err, PR_EINVAL, "sweep: job %ld: its line of jobs.txt is longer than "
				            "%d bytes (grid values or paths too long)", s->njobs, JOBLINE - 2);
				break;
			}
			fwrite(s->buf, 1, (size_t)len, s->jobs);
			pr_csvw_int(s->man, s->njobs++);
			pr_csvw_int(s->man, p);
			for (i = 0; i < g->nax; ++i)
				pr_csvw_str(s->man, g->ax[i].value[value_index(g, p, i)]);
			pr_csvw_int(s->man, rep);
			pr_csvw_int(s->man, var);
			pr_csvw_str(s->man, var >= 0 ? vl->name[var] : "all");
			pr_csvw_str(s->man, out);
			rc = pr_csvw_endrow(s->man);
		}
	free(vl);
	return rc;
}

/* pr_outdir_run's work: dir is SWEEP_DIR/.partial-TAG. A failure removes
 * what this wrote below dir; pr_outdir_run removes dir itself. */
static int sweep_work(const pr_config *cfg, const char *dir, const void *arg, char *err)
{
	const pr_rundir_args *a = arg;
	sweep_out s;
	grid g;
	char path[PR_PATHLEN], *slash;
	ssize_t n;
	long p;
	int rc;

	memset(&s, 0, sizeof s);
	s.cfg = cfg;
	s.g = &g;
	s.dir = dir;
	rc = parse_grid(a, &g, err);
	if (rc == PR_OK)
		rc = check_values(cfg, &g, err);
	if (rc == PR_OK && !realpath(dir, s.root))
		rc = pr_err(err, pr_errno_status(), "%s: cannot resolve: %s", dir, strerror(errno));
	if (rc == PR_OK && (slash = strrchr(s.root, '/')))
		*slash = '\0';
	if (rc == PR_OK && strlen(s.root) > ROOTMAX)
		rc = pr_err(err, PR_EINVAL, "%.100s...: path too long", s.root);
	/* the jobs run this very binary, by its absolute path */
	if (rc == PR_OK && (n = readlink("/proc/self/exe", s.exe, sizeof s.exe - 1)) < 0)
		rc = pr_err(err, pr_errno_status(), "/proc/self/exe: cannot find this executable: %s", strerror(errno));
	else if (rc == PR_OK)
		s.exe[n] = '\0';
	/* jobs.txt holds one job a line, and slurm.sbatch reads it with sed */
	if (rc == PR_OK && (strchr(s.root, '\n') || strchr(s.exe, '\n')))
		rc = pr_err(err, PR_EINVAL, "%s: a line break in the path of the %s: jobs.txt holds one "
		            "job a line", strchr(s.root, '\n') ? s.root : s.exe,
		            strchr(s.root, '\n') ? "sweep folder" : "poolreps executable");
	if (rc == PR_OK && !(s.line = fmemopen(s.buf, sizeof s.buf, "w")))
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	if (rc == PR_OK && !(s.jobs = open_text(dir, "jobs.txt", path, err)))
		rc = PR_EIO;
	if (rc == PR_OK)
		rc = manifest_header(&s, err);
	for (p = 0; rc == PR_OK && p < g.npoints; ++p) {
		if (pr_interrupted)
			rc = pr_err(err, PR_EINTR, "interrupted");
		else
			rc = sweep_point(&s, p, err);
	}
	if (s.line)
		fclose(s.line);
	if (s.jobs && rc == PR_OK)
		rc = close_text(s.jobs, path, err);
	else if (s.jobs)
		fclose(s.jobs);
	if (s.man)
		rc = pr_csvw_finish(s.man, rc, err);
	fmt(path, sizeof path, "%s/logs", dir);
	if (rc == PR_OK && mkdir(path, 0777) != 0)
		rc = pr_err(err, pr_errno_status(), "%s: cannot create folder: %s", path, strerror(errno));
	if (rc == PR_OK)
		rc = write_runners(dir, s.root, s.njobs, s.cpus, err);
	if (rc != PR_OK) {
		fmt(path, sizeof path, "%s/logs", dir);
		rmdir(path);
	}
	grid_free(&g);
	return rc;
}

/* An existing SWEEP_DIR must be empty: a sweep never mixes with other files. */
static int check_empty(const char *dir, char *err)
{
	DIR *d = opendir(dir);
	struct dirent *e;
	int rc = PR_OK;

	if (!d)
		return errno == ENOENT ? PR_OK : pr_err(err, pr_errno_status(), "%s: cannot read folder: %s", dir,
		                                        strerror(errno));
	while (rc == PR_OK && (e = readdir(d)))
		if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0)
			rc = pr_err(err, PR_EIO, "%s: folder is not empty (it holds %.100s): a sweep "
			            "needs a new or empty folder", dir, e->d_name);
	closedir(d);
	return rc;
}

/* ---- the manifest of a written sweep ---- */

typedef struct {
	pr_exp_table *t;
	int nax;            /* grid key columns 2 .. 1 + nax */
	int c_rep, c_name, c_out;
	long njobs, npoints;
	int *state;         /* JOB_* per job */
} manifest;

static void manifest_free(manifest *m)
{
	pr_exp_table_free(m->t);
	free(m->state);
}

static int manifest_read(const char *root, manifest *m, char *err)
{
	static const char *const tail[] = {"repetition", "variant", "variant_name", "output"};
	char path[PR_PATHLEN];
	long i, v;
	int nc, j, rc;

	memset(m, 0, sizeof *m);
	if (strlen(root) > ROOTMAX)
		return pr_err(err, PR_EINVAL, "%.100s...: path too long", root);
	fmt(path, sizeof path, "%s/manifest.csv", root);
	if ((rc = pr_exp_table_read(path, &m->t, err)))
		return rc;
	nc = pr_exp_table_ncols(m->t);
	m->nax = nc - 6;
	if (m->nax < 0 || strcmp(pr_exp_table_name(m->t, 0), "job") != 0 ||
	    strcmp(pr_exp_table_name(m->t, 1), "point") != 0)
		return pr_err(err, PR_EIO, "%s:1: not a sweep manifest: expected job,point,<grid keys>,"
		              "repetition,variant,variant_name,output", path);
	for (j = 0; j < 4; ++j)
		if (strcmp(pr_exp_table_name(m->t, nc - 4 + j), tail[j]) != 0)
			return pr_err(err, PR_EIO, "%s:1: column %d: expected '%s'", path, nc - 3 + j, tail[j]);
	m->c_rep = nc - 4;
	m->c_name = nc - 2;
	m->c_out = nc - 1;
	m->njobs = pr_exp_table_nrows(m->t);
	if (m->njobs == 0)
		return pr_err(err, PR_EIO, "%s: no jobs", path);
	if (!(m->state = malloc((size_t)m->njobs * sizeof *m->state)))
		return pr_err(err, PR_ENOMEM, "out of memory");
	for (i = 0; i < m->njobs; ++i) {
		char dir[PR_PATHLEN], file[PR_PATHLEN];
		if (strlen(pr_exp_table_str(m->t, i, m->c_out)) > NAMEMAX)
			return pr_err(err, PR_EIO, "%s:%ld: column 'output': path too long", path,
			              pr_exp_table_line(m->t, i));
		if ((rc = pr_exp_table_int(m->t, i, 0, i, i, &v, err)) ||
		    (rc = pr_exp_table_int(m->t, i, 1, m->npoints ? m->npoints - 1 : 0, m->npoints, &v, err)))
			return rc;
		m->npoints = v + 1;
		fmt(dir, sizeof dir, "%s/%s", root, pr_exp_table_str(m->t, i, m->c_out));
		fmt(file, sizeof file, "%s/provenance.txt", dir);
		m->state[i] = exists(file) ? JOB_DONE : exists(dir) ? JOB_FAILED : JOB_MISSING;
	}
	return PR_OK;
}

/* The one-line error naming the jobs not done (as many as fit). */
static int not_done(const char *root, const manifest *m, long nbad, char *err)
{
	char buf[PR_ERRLEN];
	size_t len;
	long i, named = 0;

	len = (size_t)snprintf(buf, sizeof buf, "%.120s: %ld of %ld jobs not done (poolreps sweep "
	                       "--missing prints them):", root, nbad, m->njobs);
	for (i = 0; i < m->njobs; ++i) {
		const char *rep = pr_exp_table_str(m->t, i, m->c_rep);
		const char *var = pr_exp_table_str(m->t, i, m->c_name);
		char one[256];
		if (m->state[i] == JOB_DONE)
			continue;
		snprintf(one, sizeof one, "%s job %ld (point %s%s%s%s%s) %s%.80s", named ? ";" : "", i,
		         pr_exp_table_str(m->t, i, 1), strcmp(rep, "-1") ? ", repetition " : "",
		         strcmp(rep, "-1") ? rep : "", strcmp(var, "all") ? ", variant " : "",
		         strcmp(var, "all") ? var : "",
		         m->state[i] == JOB_MISSING ? "missing" : "failed: incomplete folder ",
		         m->state[i] == JOB_MISSING ? "" : pr_exp_table_str(m->t, i, m->c_out));
		if (len + strlen(one) + 24 >= sizeof buf)
			break;
		len += (size_t)snprintf(buf + len, sizeof buf - len, "%s", one);
		++named;
	}
	if (named < nbad)
		snprintf(buf + len, sizeof buf - len, "; and %ld more", nbad - named);
	return pr_err(err, PR_EIO, "%s", buf);
}

/* sweep --missing SWEEP_DIR: the lines of jobs.txt whose jobs are not
 * done, written to output (the command passes "-", like a CSV to stdout). */
int pr_rundir_missing(const char *root, const char *output, char *err)
{
	manifest m;
	char path[PR_PATHLEN], line[3 * PR_PATHLEN]; /* a job: three paths and options */
	long i = 0;
	size_t len;
	FILE *fp = NULL;
	pr_csvw *w = NULL;
	int rc;

	rc = manifest_read(root, &m, err);
	fmt(path, sizeof path, "%s/jobs.txt", root);
	if (rc == PR_OK && !(fp = fopen(path, "r")))
		rc = pr_err(err, pr_errno_status(), "%s: cannot open: %s", path, strerror(errno));
	if (rc == PR_OK && !(w = pr_csvw_open(output, err)))
		rc = PR_EIO;
	/* read in a fixed buffer: memory stays bounded whatever jobs.txt holds */
	while (rc == PR_OK && fgets(line, sizeof line, fp)) {
		len = strlen(line);
		if (len == 0 || (line[len - 1] != '\n' && !feof(fp)))
			rc = pr_err(err, PR_EIO, "%s:%ld: NUL byte or line longer than %zu bytes", path, i + 1,
			            sizeof line - 2);
		else if (i >= m.njobs)
			rc = pr_err(err, PR_EIO, "%s:%ld: more jobs than manifest.csv lists", path, i + 1);
		else if (m.state[i++] != JOB_DONE)
			pr_csvw_raw(w, line, len);
	}
	if (rc == PR_OK && i < m.njobs)
		rc = pr_err(err, PR_EIO, "%s: %ld jobs, but manifest.csv lists %ld", path, i, m.njobs);
	if (w)
		rc = pr_csvw_finish(w, rc, err);
	if (fp)
		fclose(fp);
	manifest_free(&m);
	return rc;
}

int pr_rundir_sweep(const pr_config *cfg, const pr_rundir_args *a, char *err)
{
	const pr_experiment *e = pr_exp_find(cfg->run.name);
	char at[PR_WHERE_LEN];
	int rc;

	if (!cfg->source[0])
		return pr_err(err, PR_EINVAL, "sweep: no parameter file given (poolreps sweep CONFIG "
		              "--grid ... -o DIR)");
	if (!a->output)
		return pr_err(err, PR_EINVAL, "sweep: -o SWEEP_DIR is required");
	if (!e || !e->summary)
		return pr_err(err, PR_EINVAL, "%s: experiment.name: %s has no summary table to sweep",
		              pr_config_where(cfg, "experiment.name", at, sizeof at), cfg->run.name);
	if (cfg->run.repetition >= 0 || cfg->run.variant >= 0)
		return pr_err(err, PR_EINVAL, "%s: experiment.%s: must be -1: a sweep chooses "
		              "repetitions and variants itself (--split)",
		              pr_config_where(cfg, cfg->run.repetition >= 0 ? "experiment.repetition" :
		                              "experiment.variant", at, sizeof at),
		              cfg->run.repetition >= 0 ? "repetition" : "variant");
	/* what a sweep killed with SIGKILL left is no content */
	pr_outdir_sweep_stale(a->output);
	if ((rc = check_empty(a->output, err)))
		return rc;
	return pr_outdir_run(cfg, &a->prov, a->output, sweep_work, a, err);
}

/* ---- collect ---- */

/* PR_EINVAL unless the base configuration (root's config.ini, read into
 * base) with point p's grid values is the one its jobs ran (ran): every key
 * but the grid's, which check_grid_value checks against the manifest. */
static int same_config(const pr_config *base, const manifest *m, long first, const pr_config *ran,
                       const char *root, long p, char *err)
{
	pr_config *pt = malloc(sizeof *pt);
	char key[64], va[160], vb[160], set[PR_ERRLEN];
	int rc = PR_OK, d, j;

	if (!pt)
		return pr_err(err, PR_ENOMEM, "out of memory");
	*pt = *base;
	for (j = 0; rc == PR_OK && j < m->nax; ++j) {
		snprintf(set, sizeof set, "%s=%s", pr_exp_table_name(m->t, 2 + j),
		         pr_exp_table_str(m->t, first, 2 + j));
		rc = pr_config_set(pt, set, err);
	}
	d = rc == PR_OK ? pr_config_diff(pt, ran, NULL, key, sizeof key, va, vb, sizeof va) : 0;
	if (d < 0)
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	else if (d)
		rc = pr_err(err, PR_EINVAL, "%s/config.ini: differs from the configuration the jobs of point "
		            "%ld ran with (%s = %s, jobs: %s)", root, p, key, va, vb);
	free(pt);
	return rc;
}

typedef struct {
	const pr_rundir_args *a;
	const char *root;
	const manifest *m;
	pr_config base;     /* root's config.ini: each point's jobs add its values */
	char stage[PR_PATHLEN];
	pr_csvw *w;
	int ncols;          /* summary columns, once the first point is read */
	const char *summary;
	char names[PR_ERRLEN];  /* the summary header, comma-joined */
} collector;

/* The summary header of t as one comma list; PR_EIO if it differs from the first point's. */
static int check_header(collector *c, const pr_exp_table *t, char *err)
{
	char names[PR_ERRLEN] = "";
	size_t len = 0;
	int j;

	for (j = 0; j < pr_exp_table_ncols(t); ++j)
		len += (size_t)snprintf(names + len, len < sizeof names ? sizeof names - len : 0, "%s%s",
		                        j ? "," : "", pr_exp_table_name(t, j));
	if (c->ncols && strcmp(names, c->names) != 0)
		return pr_err(err, PR_EIO, "%s:1: columns differ from the first grid point's",
		              pr_exp_table_path(t));
	if (!c->ncols) {
		int i;
		c->ncols = pr_exp_table_ncols(t);
		snprintf(c->names, sizeof c->names, "%s", names);
		for (i = 0; i < c->m->nax; ++i)
			pr_csvw_str(c->w, pr_exp_table_name(c->m->t, 2 + i));
		return pr_csvw_header(c->w, names);
	}
	return PR_OK;
}

/* Row i of the manifest names in grid column j the value the jobs of point
 * p ran with (ran): a wrong one would label the point's rows wrongly. */
static int check_grid_value(const collector *c, long i, int j, const pr_config *pt, long p,
                            char *err)
{
	const manifest *m = c->m;
	const char *name = pr_exp_table_name(m->t, 2 + j), *value = pr_exp_table_str(m->t, i, 2 + j);
	pr_config *v = malloc(sizeof *v);
	char set[PR_ERRLEN], key[64], va[160], vb[160];
	int rc = PR_OK, d;

	if (!v)
		return pr_err(err, PR_ENOMEM, "out of memory");
	*v = *pt;
	snprintf(set, sizeof set, "%s=%s", name, value);
	if (pr_config_set(v, set, err) != PR_OK) {
		const char *why = strncmp(err, "--set: ", 7) == 0 ? err + 7 : err;
		snprintf(set, sizeof set, "%s", why);
		rc = pr_err(err, PR_EIO, "%s/manifest.csv:%ld: %s", c->root, pr_exp_table_line(m->t, i), set);
	} else if ((d = pr_config_diff(pt, v, NULL, key, sizeof key, va, vb, sizeof va)) < 0) {
		rc = pr_err(err, PR_ENOMEM, "out of memory");
	} else if (d) {
		rc = pr_err(err, PR_EIO, "%s/manifest.csv:%ld: column '%s': '%.60s', but the jobs of point "
		            "%ld ran %s = %s", c->root, pr_exp_table_line(m->t, i), name, value, p, key, va);
	}
	free(v);
	return rc;
}

/* Merge point p's job folders into stage/point-P, add its summary rows. */
static int collect_point(collector *c, long p, long first, long last, char *err)
{
	const manifest *m = c->m;
	pr_rundir_args ma;
	pr_config *ran = malloc(sizeof *ran);
	pr_exp_table *t = NULL;
	const pr_experiment *e;
	char point[64], out[PR_PATHLEN], path[PR_PATHLEN], **in;
	long i, r;
	int j, rc = PR_OK;

	point_name(point, sizeof point, p, m->npoints);
	if (!ran || !(in = calloc((size_t)(last - first), sizeof *in))) {
		free(ran);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	for (i = first; rc == PR_OK && i < last; ++i)
		if (!(in[i - first] = malloc(PR_PATHLEN)))
			rc = pr_err(err, PR_ENOMEM, "out of memory");
		else
			fmt(in[i - first], PR_PATHLEN, "%s/%s", c->root, pr_exp_table_str(m->t, i, m->c_out));
	fmt(out, sizeof out, "%s/%s", c->stage, point);
	memset(&ma, 0, sizeof ma);
	ma.output = out;
	ma.ninputs = (int)(last - first);
	ma.inputs = in;
	ma.prov = c->a->prov;
	ma.allow_versions = c->a->allow_versions;
	if (rc == PR_OK)
		rc = pr_rundir_merge(&ma, err);
	/* what the jobs ran, read like any parameter file: memory stays
	 * bounded whatever the files hold */
	fmt(path, sizeof path, "%s/config.ini", out);
	pr_config_init(ran, pr_exp_config);
	if (rc == PR_OK)
		rc = pr_config_load(ran, path, err);
	for (i = first; rc == PR_OK && i < last; ++i)
		for (j = 0; rc == PR_OK && j < m->nax; ++j)
			rc = check_grid_value(c, i, j, ran, p, err);
	if (rc == PR_OK)
		rc = same_config(&c->base, m, first, ran, c->root, p, err);
	if (rc == PR_OK && (!(e = pr_exp_find(ran->run.name)) || !e->summary))
		rc = pr_err(err, PR_EINVAL, "%s: experiment.name: %s has no summary table", path, ran->run.name);
	if (rc == PR_OK) {
		fmt(path, sizeof path, "%s/%s", out, e->summary);
		rc = pr_exp_table_read(path, &t, err);
	}
	if (rc == PR_OK)
		rc = check_header(c, t, err);
	for (r = 0; rc == PR_OK && r < pr_exp_table_nrows(t); ++r) {
		for (j = 0; j < m->nax; ++j)
			pr_csvw_str(c->w, pr_exp_table_str(m->t, first, 2 + j));
		for (j = 0; j < c->ncols; ++j)
			pr_csvw_str(c->w, pr_exp_table_str(t, r, j));
		rc = pr_csvw_endrow(c->w);
	}
	pr_exp_table_free(t);
	for (i = 0; i < last - first; ++i)
		free(in[i]);
	free(in);
	free(ran);
	return rc;
}

/* Every stage/point-P into point-P/merged and stage/summary/sweep_summary.csv
 * into SWEEP_DIR, all or nothing (pr_outdir_publish): a merged folder is a
 * run folder (files poolreps did not write stay), a file where it must go is
 * refused before anything moves, and a failure leaves every one as it was. */
static int publish_collected(const collector *c, char *err)
{
	const long np = c->m->npoints;
	pr_outdir_pub *pub = calloc((size_t)np + 1, sizeof *pub);
	char point[64], path[PR_PATHLEN];
	struct stat st;
	long p;
	int rc = pub ? PR_OK : pr_err(err, PR_ENOMEM, "out of memory");

	for (p = 0; rc == PR_OK && p <= np; ++p) {
		point_name(point, sizeof point, p, np);
		if (p < np)
			fmt(path, sizeof path, "%s/%s", c->stage, point);
		else
			fmt(path, sizeof path, "%s/summary", c->stage);
		pub[p].staging = strdup(path);
		if (p < np)
			fmt(path, sizeof path, "%s/%s/merged", c->root, point);
		pub[p].dir = p < np ? strdup(path) : c->root;
		pub[p].owns = pub[p].make = p < np;
		/* one lock on SWEEP_DIR serialises collects of one sweep */
		pub[p].lock = p == np;
		if (!pub[p].staging || !pub[p].dir)
			rc = pr_err(err, PR_ENOMEM, "out of memory");
		else if (p < np && stat(path, &st) == 0 && !S_ISDIR(st.st_mode))
			rc = pr_err(err, PR_EIO, "%s: exists and is not a folder", path);
	}
	if (rc == PR_OK)
		rc = pr_outdir_publish(pub, (int)np + 1, err);
	for (p = 0; pub && p <= np; ++p) {
		free((char *)pub[p].staging);
		if (p < np)
			free((char *)pub[p].dir);
	}
	free(pub);
	return rc;
}

/* A failed collect's message names where the file was going (point-P/merged/
 * or SWEEP_DIR itself), not the staging folder it has removed. Point names
 * have one width: none is a prefix of another. */
static void unstage_collect(const collector *c, char *err)
{
	char from[PR_PATHLEN], to[PR_PATHLEN], point[64];
	long p;

	for (p = 0; p < c->m->npoints; ++p) {
		point_name(point, sizeof point, p, c->m->npoints);
		fmt(from, sizeof from, "%s/%s/", c->stage, point);
		fmt(to, sizeof to, "%s/%s/merged/", c->root, point);
		pr_outdir_unstage(err, from, to);
		fmt(from, sizeof from, "%s/%s", c->stage, point);
		fmt(to, sizeof to, "%s/%s/merged", c->root, point);
		pr_outdir_unstage(err, from, to);
	}
	fmt(from, sizeof from, "%s/summary", c->stage);
	pr_outdir_unstage(err, from, c->root);
	pr_outdir_unstage(err, c->stage, c->root);
}

/* Every job of the sweep ran by one build (each point's merge checks its
 * own jobs; this checks them across points), unless a->allow_versions. */
static int same_builds(const pr_rundir_args *a, const manifest *m, char *err)
{
	char **dirs = calloc((size_t)m->njobs + 1, sizeof *dirs), *list = NULL;
	long i;
	int rc = dirs ? PR_OK : pr_err(err, PR_ENOMEM, "out of memory");

	for (i = 0; rc == PR_OK && i < m->njobs; ++i)
		if (!(dirs[i] = malloc(PR_PATHLEN)))
			rc = pr_err(err, PR_ENOMEM, "out of memory");
		else
			fmt(dirs[i], PR_PATHLEN, "%s/%s", a->inputs[0], pr_exp_table_str(m->t, i, m->c_out));
	if (rc == PR_OK)
		rc = pr_outdir_versions(dirs, (int)m->njobs, a->allow_versions, &list, err);
	for (i = 0; dirs && i < m->njobs; ++i)
		free(dirs[i]);
	free(dirs);
	free(list);
	return rc;
}

int pr_rundir_collect(const pr_rundir_args *a, char *err)
{
	collector c;
	manifest m;
	char path[PR_PATHLEN];
	long i, first, nbad = 0;
	int rc;

	if (a->ninputs != 1)
		return pr_err(err, PR_EINVAL, "collect: give exactly one sweep folder");
	if ((rc = manifest_read(a->inputs[0], &m, err))) {
		manifest_free(&m);
		return rc;
	}
	for (i = 0; i < m.njobs; ++i)
		nbad += m.state[i] != JOB_DONE;
	if (nbad)
		rc = not_done(a->inputs[0], &m, nbad, err);
	else
		rc = same_builds(a, &m, err);
	if (rc) {
		manifest_free(&m);
		return rc;
	}
	memset(&c, 0, sizeof c);
	c.a = a;
	c.root = a->inputs[0];
	c.m = &m;
	fmt(path, sizeof path, "%s/config.ini", c.root);
	pr_config_init(&c.base, pr_exp_config);
	if ((rc = pr_config_load(&c.base, path, err))) {
		manifest_free(&m);
		return rc;
	}
	/* staged like a run's folder: a signal removes it, and the next collect
	 * one left by SIGKILL */
	fmt(c.stage, sizeof c.stage, "%s/.partial-%s", c.root, pr_owner_tag());
	pr_outdir_sweep_stale(c.root);
	pr_remove_tree(c.stage);
	fmt(path, sizeof path, "%s/summary", c.stage);
	/* registered first: a signal right after the mkdir finds it */
	pr_cleanup_set_dir(c.stage, c.root, strlen(c.root));
	if (mkdir(c.stage, 0777) != 0 || mkdir(path, 0777) != 0)
		rc = pr_err(err, pr_errno_status(), "%s: cannot create folder: %s", c.stage, strerror(errno));
	fmt(path, sizeof path, "%s/summary/sweep_summary.csv", c.stage);
	if (rc == PR_OK && !(c.w = pr_csvw_open(path, err)))
		rc = PR_EIO;
	/* jobs are listed point by point */
	for (i = 0, first = 0; rc == PR_OK && i <= m.njobs; ++i) {
		if (i < m.njobs && strcmp(pr_exp_table_str(m.t, i, 1), pr_exp_table_str(m.t, first, 1)) == 0)
			continue;
		if (pr_interrupted)
			rc = PR_EINTR;
		else
			rc = collect_point(&c, strtol(pr_exp_table_str(m.t, first, 1), NULL, 10), first, i, err);
		first = i;
	}
	if (c.w)
		rc = pr_csvw_finish(c.w, rc, err);
	if (rc == PR_OK && pr_interrupted)
		rc = PR_EINTR;
	if (rc == PR_OK)
		rc = publish_collected(&c, err);
	else if (pr_interrupted)
		rc = pr_err(err, PR_EINTR, "interrupted: nothing collected, %s left as it was", c.root);
	pr_remove_tree(c.stage);
	pr_cleanup_clear_dir();
	if (rc != PR_OK)
		unstage_collect(&c, err);
	manifest_free(&m);
	return rc;
}
