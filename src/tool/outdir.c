/* outdir.c — an output folder written all or nothing: everything a run,
 * merge or sweep writes goes first into a staging folder DIR/.partial-TAG
 * and is moved into DIR only when the whole command succeeded (publish), so
 * a failed or interrupted command leaves no partial CSV behind and the
 * previous run in DIR untouched. provenance.txt lists the files a run owns;
 * the next run into DIR replaces exactly those.
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

#include "poolreps/csvio.h"
#include "poolreps/internal.h"
#include "csvio_priv.h"
#include "outdir.h"


/* Remove the folders of dir below its first keep bytes (those mkdir_p
 * created), deepest first, each only if empty. */
static void remove_created(const char *dir, size_t keep)
{
	char buf[PR_PATHLEN];
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
	char buf[PR_PATHLEN];
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
				rc = pr_err(err, pr_errno_status(), "%s: cannot create folder: %s", buf, strerror(errno));
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

/* Leftovers of runs killed with SIGKILL, provably gone (pr_owner_dead):
 * their staging folders .partial-TAG and temporary files
 * .poolreps-tmp-TAG-N. A run still alive (writing into the same folder, on
 * this node or another) keeps its own. */
void pr_outdir_sweep_stale(const char *dir)
{
	DIR *d = opendir(dir);
	struct dirent *e;
	char path[PR_PATHLEN];

	if (!d)
		return;
	while ((e = readdir(d))) {
		const char *p = NULL;
		if (strncmp(e->d_name, ".partial-", 9) == 0)
			p = e->d_name + 9;
		else if (strncmp(e->d_name, ".poolreps-tmp-", 14) == 0)
			p = e->d_name + 14;
		if (!p || !pr_owner_dead(p))
			continue;
		if (snprintf(path, sizeof path, "%s/%s", dir, e->d_name) >= (int)sizeof path)
			continue;
		if (unlink(path) != 0)
			pr_remove_tree(path);
	}
	closedir(d);
}

void pr_names_free(pr_names *l)
{
	int i;

	for (i = 0; i < l->n; ++i)
		free(l->name[i]);
	free(l->name);
	l->name = NULL;
	l->n = 0;
}

int pr_names_add(pr_names *l, const char *name, size_t len)
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

int pr_names_has(const pr_names *l, const char *name)
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

int pr_outdir_list(const char *dir, pr_names *out, char *err)
{
	DIR *d = opendir(dir);
	struct dirent *e;

	if (!d)
		return pr_err(err, pr_errno_status(), "%s: cannot read folder: %s", dir, strerror(errno));
	while ((e = readdir(d)))
		if (e->d_name[0] != '.' && pr_names_add(out, e->d_name, strlen(e->d_name))) {
			closedir(d);
			return pr_err(err, PR_ENOMEM, "out of memory");
		}
	closedir(d);
	if (out->n)
		qsort(out->name, (size_t)out->n, sizeof *out->name, cmp_name);
	return PR_OK;
}

/* The keys of provenance.txt, in the order provenance_text writes them. */
static const char *const prov_keys[] = {"version", "command", "experiment", "seed", "repetition",
                                        "parameter_file", "host", "finished", "wall_seconds",
                                        "cpu_seconds", "peak_memory_mib", "files", NULL};

/* The names of the experiments' CSVs (src/exp*.c) start with one of these. */
static const char *const csv_prefixes[] = {"exp1_", "exp2_", "exp3_", "exp4_", "bench_", "fig7_", NULL};
static const char *const fixed_names[] = {"config.ini", "provenance.txt", "jobs.txt", "slurm.sbatch",
                                          "parallel.sh", "sweep_summary.csv", NULL};

/* 1 if poolreps could have written name into a run or sweep folder: a plain
 * name (letters, digits, '_', '-', '.'; no '/', not starting with '.'),
 * one of the fixed names or an experiment's CSV. */
int pr_outdir_own_name(const char *name, size_t k)
{
	int i;

	if (!k || name[0] == '.' || strspn(name, "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
	                                        "0123456789_-.") < k)
		return 0;
	for (i = 0; fixed_names[i]; ++i)
		if (strlen(fixed_names[i]) == k && memcmp(name, fixed_names[i], k) == 0)
			return 1;
	for (i = 0; csv_prefixes[i]; ++i) {
		size_t n = strlen(csv_prefixes[i]);
		if (k > n + 4 && memcmp(name, csv_prefixes[i], n) == 0 && memcmp(name + k - 4, ".csv", 4) == 0)
			return 1;
	}
	return 0;
}

/* One line of fp into line (at most n - 1 bytes kept, the rest read and
 * checked): 0 at the end of the file, -1 for a control character or a
 * missing line end, else 1. */
static int prov_line(FILE *fp, char *line, size_t n)
{
	size_t k = 0;
	int c;

	while ((c = getc(fp)) != EOF && c != '\n') {
		if ((unsigned char)c < 0x20 || c == 0x7f)
			return -1;
		if (k + 1 < n)
			line[k++] = (char)c;
	}
	line[k] = '\0';
	if (c == EOF)
		return k ? -1 : 0;
	return 1;
}

/* The files of the "files:" line of a provenance record, every name one
 * poolreps could have written. */
static int prov_files(const char *p, pr_names *out)
{
	while (*p) {
		size_t k;
		p += strspn(p, " ");
		k = strcspn(p, " ");
		if (k && !pr_outdir_own_name(p, k))
			return PR_EINVAL;
		if (k && pr_names_add(out, p, k))
			return PR_ENOMEM;
		p += k;
	}
	return PR_OK;
}

/* See outdir.h. */
int pr_outdir_earlier_run(const char *dir, pr_names *out, char *err)
{
	enum { FILES = 11 };
	char path[PR_PATHLEN + 16], line[1 << 16];
	const char *why = NULL;
	struct stat st;
	FILE *fp;
	int rc = PR_OK, n = 1, key = 0, r;

	snprintf(path, sizeof path, "%s/provenance.txt", dir);
	/* a fixed buffer, and only a regular file: never a FIFO or /dev/zero */
	if (stat(path, &st) != 0 || !S_ISREG(st.st_mode))
		return PR_OK;
	/* unread, it would leave the run's files looking like the user's */
	if (!(fp = fopen(path, "r")))
		return pr_err(err, pr_errno_status(), "%s: cannot read: %s", path, strerror(errno));
	if (prov_line(fp, line, sizeof line) <= 0 || strncmp(line, "version: ", 9) != 0) {
		fclose(fp);
		return PR_OK;
	}
	while (!why && key != FILES) {
		const char *colon;
		int i;
		++n;
		if ((r = prov_line(fp, line, sizeof line)) <= 0) {
			why = r < 0 ? "a control character or an unfinished line" : "no files: line";
			break;
		}
		colon = strchr(line, ':');
		for (i = key + 1; colon && prov_keys[i]; ++i)
			if ((size_t)(colon - line) == strlen(prov_keys[i]) && !strncmp(line, prov_keys[i], strlen(prov_keys[i])))
				break;
		if (!colon || !prov_keys[i])
			why = "an unknown, repeated or misplaced key";
		else if ((key = i) == FILES && (rc = prov_files(colon + 1, out)) != PR_OK)
			why = "a file name poolreps does not write";
	}
	if (!why && prov_line(fp, line, sizeof line) != 0) {
		why = "more after the files: line";
		++n;
	}
	fclose(fp);
	if (rc == PR_ENOMEM)
		return pr_err(err, PR_ENOMEM, "out of memory");
	if (why) {
		pr_names_free(out);
		return pr_err(err, PR_EIO, "%s:%d: not a provenance record poolreps writes (%s): "
		              "move it away to run into %s", path, n, why, dir);
	}
	return PR_OK;
}

/* The versions of provenance record path into v (the builds that ran it:
 * the list of a merge's "(runs by A, B)", else the version), noting in
 * from[] the record k that brought the first two. */
static int record_versions(const char *path, pr_names *v, int *from, int k, char *err)
{
	char line[1024], *p, *end;
	FILE *fp = fopen(path, "r");
	int r, e;

	/* a failed open or read (out of memory, an I/O error) is not a record
	 * without a version */
	if (!fp)
		return pr_err(err, pr_errno_status(), "%s: cannot read: %s", path, strerror(errno));
	r = prov_line(fp, line, sizeof line);
	e = ferror(fp) ? errno : 0;
	fclose(fp);
	if (e) {
		errno = e;
		return pr_err(err, pr_errno_status(), "%s: cannot read: %s", path, strerror(e));
	}
	if (r <= 0 || strncmp(line, "version: ", 9) != 0)
		return pr_err(err, PR_EIO, "%s:1: no 'version:' line", path);
	p = line + 9;
	if ((end = strstr(p, " (runs by ")) && line[strlen(line) - 1] == ')') {
		p = end + 10;
		line[strlen(line) - 1] = '\0';
	} else if (end)
		*end = '\0';
	while (*p) {
		size_t n = strcspn(p, ",");
		char c = p[n];

		p[n] = '\0';
		if (!pr_names_has(v, p)) {
			if (pr_names_add(v, p, n))
				return pr_err(err, PR_ENOMEM, "out of memory");
			if (v->n <= 2)
				from[v->n - 1] = k;
		}
		p += n + (c != '\0');
		p += strspn(p, " ");
	}
	return PR_OK;
}

/* See outdir.h. */
int pr_outdir_versions(char *const *dirs, int n, int allow, char **list, char *err)
{
	pr_names v = {NULL, 0};
	char path[PR_PATHLEN + 32];
	int from[2] = {0, 0}, rc = PR_OK, k;
	size_t len = 1;

	*list = NULL;
	for (k = 0; rc == PR_OK && k < n; ++k) {
		snprintf(path, sizeof path, "%s/provenance.txt", dirs[k]);
		rc = record_versions(path, &v, from, k, err);
	}
	if (rc == PR_OK && v.n > 1 && !allow)
		rc = pr_err(err, PR_EINVAL, "%s/provenance.txt: poolreps %s, but %s/provenance.txt: poolreps %s "
		            "(runs of different builds; --allow-versions merges them and lists every version)",
		            dirs[from[1]], v.name[1], dirs[from[0]], v.name[0]);
	for (k = 0; rc == PR_OK && k < v.n; ++k)
		len += strlen(v.name[k]) + 2;
	if (rc == PR_OK && (v.n > 1 || (v.n == 1 && strcmp(v.name[0], pr_version()) != 0))) {
		if (!(*list = malloc(len)))
			rc = PR_ENOMEM;
		for (k = 0, len = 0; *list && k < v.n; ++k)
			len += (size_t)sprintf(*list + len, "%s%s", k ? ", " : "", v.name[k]);
	}
	if (rc == PR_ENOMEM)
		pr_err(err, PR_ENOMEM, "out of memory");
	pr_names_free(&v);
	return rc;
}

/* A run folder is published by renames inside it: a file there that is a
 * symbolic link would be replaced by a regular file (the link broken, its
 * target left stale), and a target in another folder or on another file
 * system escapes the all-or-nothing moves and their put-back. */
static int refuse_link(const char *path, char *err)
{
	return pr_err(err, PR_EIO, "%s: is a symbolic link: a run folder's files are not written through "
	              "links (remove the link, or write the run elsewhere and link to it)", path);
}

/* A run replaces only what an earlier run listed as its own: a file of
 * the user's (a parameter file in the folder, notes) is never overwritten. */
static int refuse_foreign(const char *path, char *err)
{
	return pr_err(err, PR_EIO, "%s: exists, and no earlier poolreps run in this folder wrote it: "
	              "the run would replace it (move it, or run into another folder)", path);
}

/* An exclusive lock on folder dir, waited for: flock on the folder itself;
 * where folders cannot be locked (NFS emulates flock with byte-range locks,
 * which need a file open for writing), an fcntl lock on DIR/.poolreps.lock,
 * created once and kept (removing it would let two processes lock two
 * files). The descriptor to close, or -1 with errno set. */
static int lock_dir(const char *dir)
{
	char path[PR_PATHLEN + 32];
	struct flock fl;
	int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC), e;

	if (fd < 0)
		return -1;
	if (flock(fd, LOCK_EX) == 0)
		return fd;
	e = errno;
	close(fd);
	if (e != EBADF && e != ENOLCK && e != EOPNOTSUPP && e != EINVAL) {
		errno = e;
		return -1;
	}
	snprintf(path, sizeof path, "%s/.poolreps.lock", dir);
	if ((fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0666)) < 0)
		return -1;
	memset(&fl, 0, sizeof fl);
	fl.l_type = F_WRLCK;
	fl.l_whence = SEEK_SET;
	if (fcntl(fd, F_SETLKW, &fl) == 0)
		return fd;
	e = errno;
	close(fd);
	errno = e;
	return -1;
}

/* The extended attributes of file old onto file path, which replaces it. */
static int keep_xattrs(const char *old, const char *path, char *bad, size_t nbad)
{
	int fd = open(path, O_RDONLY | O_CLOEXEC), rc, e;

	if (fd < 0)
		return -1;
	rc = pr_csv_copy_xattrs(old, fd, bad, nbad);
	e = errno;
	close(fd);
	errno = e;
	return rc;
}

/* Put back what the renames of sets [0, s] moved, the files of set s
 * below i: an earlier file from its second link, a new one removed. */
static void put_back(pr_outdir_pub *p, int s, int i)
{
	char to[2 * PR_PATHLEN], bak[2 * PR_PATHLEN];
	int k, j;

	for (k = 0; k <= s; ++k)
		for (j = 0; j < (k < s ? p[k].now.n : i); ++j) {
			snprintf(to, sizeof to, "%s/%s", p[k].dir, p[k].now.name[j]);
			snprintf(bak, sizeof bak, "%s/.old-%d", p[k].staging, j);
			if (p[k].had[j])
				rename(bak, to);
			else
				unlink(to);
		}
}

int pr_outdir_publish(pr_outdir_pub *p, int n, char *err)
{
	char from[2 * PR_PATHLEN], to[2 * PR_PATHLEN], bak[2 * PR_PATHLEN], xa[256] = "";
	struct stat st;
	sigset_t mask;
	int rc = PR_OK, s, i, held = 0;

	for (s = 0; s < n; ++s) {
		memset(&p[s].now, 0, sizeof p[s].now);
		memset(&p[s].old, 0, sizeof p[s].old);
		p[s].had = NULL;
		p[s].fd = -1;
		p[s].made = 0;
	}
	for (s = 0; s < n && rc == PR_OK; ++s) {
		if ((rc = pr_outdir_list(p[s].staging, &p[s].now, err)))
			break;
		if (p[s].lock && (p[s].fd = lock_dir(p[s].dir)) < 0)
			rc = pr_err(err, pr_errno_status(), "%s: cannot lock folder: %s", p[s].dir, strerror(errno));
		else if (p[s].owns && (rc = pr_outdir_earlier_run(p[s].dir, &p[s].old, err)))
			break;
		else if (!(p[s].had = calloc((size_t)p[s].now.n + 1, 1)))
			rc = pr_err(err, PR_ENOMEM, "out of memory");
	}
	if (rc == PR_OK) {
		pr_cleanup_hold(&mask);
		held = 1;
		/* a signal while waiting for the lock: nothing has moved yet */
		if (pr_interrupted)
			rc = pr_err(err, PR_EINTR, "interrupted (signal %d) before publishing: %s left as it was",
			            (int)pr_interrupted, p[0].dir);
	}
	for (s = 0; s < n && rc == PR_OK; ++s)
		if (p[s].make && mkdir(p[s].dir, 0777) == 0)
			p[s].made = 1;
		else if (p[s].make && errno != EEXIST)
			rc = pr_err(err, pr_errno_status(), "%s: cannot create folder: %s", p[s].dir, strerror(errno));
	for (s = 0; s < n && rc == PR_OK; ++s)
		for (i = 0; i < p[s].now.n && rc == PR_OK; ++i) {
			snprintf(to, sizeof to, "%s/%s", p[s].dir, p[s].now.name[i]);
			snprintf(from, sizeof from, "%s/%s", p[s].staging, p[s].now.name[i]);
			snprintf(bak, sizeof bak, "%s/.old-%d", p[s].staging, i);
			if (lstat(to, &st) != 0)
				continue;
			if (S_ISDIR(st.st_mode))
				rc = pr_err(err, PR_EIO, "%s: is a folder: cannot replace it with the run's file", to);
			else if (S_ISLNK(st.st_mode))
				rc = refuse_link(to, err);
			/* like any output: a file the (non-root) user may not write stays */
			else if (S_ISREG(st.st_mode) && faccessat(AT_FDCWD, to, W_OK, AT_EACCESS) != 0)
				rc = pr_err(err, pr_errno_status(), "%s: cannot write: %s", to, strerror(errno));
			/* the new file keeps the permission bits (and for root the owner) of the one it replaces */
			else if (S_ISREG(st.st_mode) && (chmod(from, st.st_mode & 07777) != 0 ||
			                                 (geteuid() == 0 && chown(from, st.st_uid, st.st_gid) != 0)))
				rc = pr_err(err, pr_errno_status(), "%s: cannot keep its permissions: %s", to, strerror(errno));
			/* and its extended attributes (after the owner: a chown drops some) */
			else if (S_ISREG(st.st_mode) && keep_xattrs(to, from, xa, sizeof xa) != 0)
				rc = pr_err(err, pr_errno_status(), "%s: cannot keep its extended attribute %s: %s", to,
				            xa, strerror(errno));
			else if (link(to, bak) != 0)
				rc = pr_err(err, pr_errno_status(), "%s: cannot keep the earlier file while replacing it: %s",
				            to, strerror(errno));
			else
				p[s].had[i] = 1;
		}
	/* after the links and folders above, which a run never replaces either */
	for (s = 0; s < n && rc == PR_OK; ++s)
		for (i = 0; i < p[s].now.n && rc == PR_OK; ++i)
			if (p[s].owns && p[s].had[i] && !pr_names_has(&p[s].old, p[s].now.name[i])) {
				snprintf(to, sizeof to, "%s/%s", p[s].dir, p[s].now.name[i]);
				rc = refuse_foreign(to, err);
			}
	for (s = 0; s < n && rc == PR_OK; ++s)
		for (i = 0; i < p[s].now.n && rc == PR_OK; ++i) {
			snprintf(from, sizeof from, "%s/%s", p[s].staging, p[s].now.name[i]);
			snprintf(to, sizeof to, "%s/%s", p[s].dir, p[s].now.name[i]);
			if (rename(from, to) == 0)
				continue;
			rc = pr_err(err, pr_errno_status(), "%s: cannot move into place: %s; every file left as it was",
			            to, strerror(errno));
			put_back(p, s, i);
		}
	for (s = 0; s < n && rc == PR_OK; ++s)
		for (i = 0; i < p[s].old.n; ++i)
			if (!pr_names_has(&p[s].now, p[s].old.name[i]) &&
			    snprintf(to, sizeof to, "%s/%s", p[s].dir, p[s].old.name[i]) < (int)sizeof to &&
			    lstat(to, &st) == 0 && S_ISREG(st.st_mode))
				unlink(to);
	for (s = 0; s < n && rc != PR_OK; ++s)
		if (p[s].made)
			rmdir(p[s].dir);
	if (held)
		pr_commit_end(&mask, rc, p[0].dir);
	for (s = 0; s < n; ++s) {
		if (p[s].fd >= 0)
			close(p[s].fd);
		free(p[s].had);
		pr_names_free(&p[s].now);
		pr_names_free(&p[s].old);
	}
	return rc;
}

/* Render text with fn into a memory stream, then write it to path. */
int pr_outdir_write_text(const char *path, void (*fn)(FILE *, const void *), const void *arg,
                         char *err)
{
	char *buf = NULL;
	size_t n = 0;
	FILE *fp = open_memstream(&buf, &n);
	pr_outset *set;
	pr_csvw *w;
	int rc;

	if (!fp)
		return pr_err(err, PR_ENOMEM, "out of memory");
	fn(fp, arg);
	if (fclose(fp) != 0) {
		free(buf);
		return pr_err(err, PR_ENOMEM, "out of memory");
	}
	/* a set of one: a refused name keeps its own status (an empty one is 1) */
	if (!(set = pr_outset_new(err))) {
		free(buf);
		return PR_ENOMEM;
	}
	if ((rc = pr_outset_add(set, path, &w, err)) == PR_OK)
		pr_csvw_raw(w, buf, n);
	free(buf);
	return pr_outset_commit(set, rc, err);
}

static void config_file_text(FILE *fp, const void *cfg)
{
	fprintf(fp, "; effective configuration written by poolreps %s\n", pr_version());
	pr_config_write(cfg, fp);
}

int pr_outdir_write_config(const pr_config *cfg, const char *dir, char *err)
{
	char path[2 * PR_PATHLEN];

	snprintf(path, sizeof path, "%s/config.ini", dir);
	return pr_outdir_write_text(path, config_file_text, cfg, err);
}

/* A control character as \xHH: a record keeps one line per key. */
static void put_escaped(FILE *fp, int c, int escape)
{
	if (escape && ((unsigned char)c < 0x20 || c == 0x7f))
		fprintf(fp, "\\x%02x", (unsigned char)c);
	else
		fputc(c, fp);
}

static void shell_word(FILE *fp, const char *arg, int escape)
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
			put_escaped(fp, *c, escape);
	}
	fputc('\'', fp);
}

void pr_outdir_shell_word(FILE *fp, const char *arg)
{
	shell_word(fp, arg, 0);
}

static void put_record(FILE *fp, const char *s)
{
	for (; *s; ++s)
		put_escaped(fp, *s, 1);
}

typedef struct {
	const pr_config *cfg;
	const pr_provenance *prov;
	const pr_names *files;
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
	fprintf(fp, "version: %s", pr_version());
	if (p->prov->versions)
		fprintf(fp, " (runs by %s)", p->prov->versions);
	fputc('\n', fp);
	fprintf(fp, "command:");
	/* control characters escaped: an argument never starts a line of its own */
	for (i = 0; i < p->prov->argc; ++i) {
		fputc(' ', fp);
		shell_word(fp, p->prov->argv[i], 1);
	}
	fprintf(fp, "\nexperiment: %s\nseed: %lu\nrepetition: %d\nparameter_file: ",
	        p->cfg->run.name, p->cfg->run.seed, p->cfg->run.repetition);
	put_record(fp, p->cfg->source[0] ? p->cfg->source : "(none)");
	fputs("\nhost: ", fp);
	put_record(fp, host);
	if (uname(&un) == 0)
		fprintf(fp, " (%s %s %s)", un.sysname, un.release, un.machine);
	fputc('\n', fp);
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

static int write_provenance(const pr_config *cfg, const pr_provenance *prov, const char *dir,
                            double wall, char *err)
{
	char path[2 * PR_PATHLEN];
	pr_names files = {NULL, 0};
	provenance p = {cfg, prov, &files, wall};
	int rc;

	if ((rc = pr_outdir_list(dir, &files, err)))
		return rc;
	snprintf(path, sizeof path, "%s/provenance.txt", dir);
	rc = pr_outdir_write_text(path, provenance_text, &p, err);
	pr_names_free(&files);
	return rc;
}

static double seconds_since(const struct timespec *t0)
{
	struct timespec t1;

	clock_gettime(CLOCK_MONOTONIC, &t1);
	return (double)(t1.tv_sec - t0->tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0->tv_nsec);
}

void pr_outdir_unstage(char *err, const char *staging, const char *dir)
{
	char out[PR_ERRLEN], *p;
	size_t n = strlen(staging);

	while ((p = strstr(err, staging))) {
		snprintf(out, sizeof out, "%.*s%s%s", (int)(p - err), err, dir, p + n);
		memcpy(err, out, strlen(out) + 1);
	}
}

int pr_outdir_run(const pr_config *cfg, const pr_provenance *prov, const char *dir,
                  int (*work)(const pr_config *, const char *, const void *, char *),
                  const void *arg, char *err)
{
	char staging[PR_PATHLEN];
	struct timespec t0;
	pr_names old = {NULL, 0};
	sigset_t held;
	size_t keep;
	int rc, i, published = 0;

	clock_gettime(CLOCK_MONOTONIC, &t0);
	if (snprintf(staging, sizeof staging, "%s/.partial-%s", dir, pr_owner_tag()) >= (int)sizeof staging)
		return pr_err(err, PR_EINVAL, "%.100s...: path too long", dir);
	/* a signal between a mkdir and its registration would strand the folder */
	pr_cleanup_hold(&held);
	if ((rc = mkdir_p(dir, &keep, err)) == PR_OK)
		pr_cleanup_set_dir(staging, dir, keep);
	pr_cleanup_release(&held);
	if (rc)
		return rc;
	pr_outdir_sweep_stale(dir);
	pr_remove_tree(staging);
	/* a record poolreps did not write is refused before any work */
	rc = pr_outdir_earlier_run(dir, &old, err);
	for (i = 0; rc == PR_OK && i < old.n; ++i) {
		struct stat st;
		char path[2 * PR_PATHLEN];
		snprintf(path, sizeof path, "%s/%s", dir, old.name[i]);
		if (lstat(path, &st) == 0 && S_ISLNK(st.st_mode))
			rc = refuse_link(path, err);
	}
	/* the two files every run writes: refused before the work, not after */
	for (i = 0; rc == PR_OK && i < 2; ++i) {
		const char *own = i ? "config.ini" : "provenance.txt";
		struct stat st;
		char path[2 * PR_PATHLEN];
		snprintf(path, sizeof path, "%s/%s", dir, own);
		if (lstat(path, &st) != 0)
			continue;
		if (S_ISLNK(st.st_mode))
			rc = refuse_link(path, err);
		else if (S_ISREG(st.st_mode) && !pr_names_has(&old, own))
			rc = refuse_foreign(path, err);
	}
	pr_names_free(&old);
	if (rc == PR_OK && mkdir(staging, 0777) != 0)
		rc = pr_err(err, pr_errno_status(), "%s: cannot write into the folder: %s", dir, strerror(errno));
	if (rc != PR_OK) {
		pr_cleanup_clear_dir();
		remove_created(dir, keep);
		return rc;
	}
	rc = work(cfg, staging, arg, err);
	if (rc == PR_OK)
		rc = pr_outdir_write_config(cfg, staging, err);
	if (rc == PR_OK)
		rc = write_provenance(cfg, prov, staging, seconds_since(&t0), err);
	if (rc == PR_OK && !pr_interrupted) {
		pr_outdir_pub pub = {staging, dir, 1, 1, 0, {NULL, 0}, {NULL, 0}, NULL, -1, 0};
		rc = pr_outdir_publish(&pub, 1, err);
		published = rc == PR_OK;
	}
	pr_remove_tree(staging);
	pr_cleanup_clear_dir();
	/* published: the run is complete, whatever signal came during the moves */
	if (published || (rc == PR_OK && !pr_interrupted))
		return rc;
	/* a failed run leaves no trace: drop the folders it made (if empty) */
	remove_created(dir, keep);
	if (rc != PR_OK)
		pr_outdir_unstage(err, staging, dir);
	/* after a signal every failure is its echo (a fit cut short may report
	 * itself as a numerical failure): say what the user is left with */
	if (pr_interrupted)
		rc = pr_err(err, PR_EINTR, keep == strlen(dir) ?
		            "interrupted: no output written (signal %d); partial files removed, %s left as it was" :
		            "interrupted: no output written (signal %d); partial files and the new folders of %s removed",
		            (int)pr_interrupted, dir);
	return rc;
}

