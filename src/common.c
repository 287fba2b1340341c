/* common.c — status helpers shared by every module, one-line messages, and
 * the registry of temporary paths that a fatal signal removes. */
#define _GNU_SOURCE /* syscall(SYS_getdents64): listing a folder inside a signal handler;
                     * sched_getaffinity: the CPUs of pr_cpu_count */
#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <sched.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <gsl/gsl_errno.h>

#include "poolreps/common.h"
#include "common_priv.h"

#ifndef PR_VERSION_STR
#define PR_VERSION_STR "0.1.0"
#endif

volatile sig_atomic_t pr_interrupted = 0;
volatile sig_atomic_t pr_out_of_memory = 0;
volatile sig_atomic_t pr_committed = 0;

/* Length of the UTF-8 sequence at s (1..4) if it is valid and not a control
 * character, else 0. */
static int utf8_ok(const unsigned char *s)
{
	unsigned c = s[0], cp;
	int n, i;

	if (c < 0x80)
		return c >= 0x20 && c != 0x7f;
	if (c >= 0xc2 && c <= 0xdf)
		n = 2, cp = c & 0x1f;
	else if (c >= 0xe0 && c <= 0xef)
		n = 3, cp = c & 0x0f;
	else if (c >= 0xf0 && c <= 0xf4)
		n = 4, cp = c & 0x07;
	else
		return 0;
	for (i = 1; i < n; ++i) {
		if ((s[i] & 0xc0) != 0x80)
			return 0;
		cp = cp << 6 | (s[i] & 0x3f);
	}
	/* overlong forms, surrogates, beyond U+10FFFF, C1 controls */
	if ((n == 3 && cp < 0x800) || (n == 4 && (cp < 0x10000 || cp > 0x10ffff)) ||
	    (cp >= 0xd800 && cp <= 0xdfff) || (cp >= 0x80 && cp <= 0x9f))
		return 0;
	return n;
}

void pr_escape(const char *s, char *out, size_t n)
{
	const unsigned char *p = (const unsigned char *)s;
	size_t o = 0;

	while (*p) {
		int k = utf8_ok(p);
		if (k) {
			if (o + (size_t)k >= n)
				break;
			memcpy(out + o, p, (size_t)k);
			o += (size_t)k;
			p += k;
		} else {
			if (o + 4 >= n)
				break;
			snprintf(out + o, 5, "\\x%02x", *p);
			o += 4;
			++p;
		}
	}
	out[o] = '\0';
}

/* A UTF-8 character boundary at or after s (never inside a sequence). */
static const char *boundary(const char *s)
{
	while (((unsigned char)*s & 0xc0) == 0x80)
		++s;
	return s;
}

/* The jump target of this thread's guarded GSL call, or NULL. */
static _Thread_local jmp_buf *gsl_jump;

void pr_gsl_guard(jmp_buf *jb)
{
	gsl_jump = jb;
}

void pr_gsl_error_handler(const char *reason, const char *file, int line, int gsl_errno)
{
	(void)reason;
	(void)file;
	(void)line;
	if (gsl_errno == GSL_ENOMEM && gsl_jump)
		longjmp(*gsl_jump, 1);
}

int pr_err(char *err, int status, const char *fmt, ...)
{
	/* room for a message around a path of PATH_MAX bytes, each byte escaped */
	char raw[PATH_MAX + PR_ERRLEN], esc[4 * (PATH_MAX + PR_ERRLEN)];
	size_t n;
	va_list ap;

	if (status == PR_ENOMEM)
		pr_out_of_memory = 1;
	if (err) {
		va_start(ap, fmt);
		vsnprintf(raw, sizeof raw, fmt, ap);
		va_end(ap);
		pr_escape(raw, esc, sizeof esc);
		n = strlen(esc);
		if (n < PR_ERRLEN) {
			memcpy(err, esc, n + 1);
		} else {
			/* too long (a long path): keep both ends, where the reason is */
			const char *tail = boundary(esc + n - (PR_ERRLEN - 1) * 2 / 3);
			size_t head = (size_t)(boundary(esc + (PR_ERRLEN - 1) / 3 - 4) - esc);
			snprintf(err, PR_ERRLEN, "%.*s...%s", (int)head, esc, tail);
		}
	}
	return status;
}

int pr_exit_code(int status)
{
	switch (status) {
	case PR_OK: return 0;
	case PR_EINVAL: return 1;
	case PR_EIO: return 2;
	case PR_ENUM: return 3;
	case PR_ENOMEM: return 4;
	case PR_EINTR: return 128 + (pr_interrupted > 0 ? pr_interrupted : SIGINT);
	default: return 1;
	}
}

const char *pr_version(void)
{
	return PR_VERSION_STR;
}

/* ---- clean-up registry ---- */

/* every signal whose default action ends the process, except the faults a
 * bug raises (SIGSEGV and the like, which the sanitizers report) */
const int pr_fatal_signals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE, SIGXFSZ, SIGXCPU,
                                SIGUSR1, SIGUSR2, SIGALRM, SIGVTALRM, SIGPOLL, SIGPWR,
                                SIGSTKFLT, 0};

#define MAX_TRACKED 64
static char tracked[MAX_TRACKED][PATH_MAX];
/* staging folders, nested (collect stages the merges it runs): at most 2 */
#define MAX_STAGING 2
static char staging_dir[MAX_STAGING][PATH_MAX], created_dir[MAX_STAGING][PATH_MAX];
static size_t created_keep[MAX_STAGING];
static volatile sig_atomic_t nstaging;
static pthread_mutex_t tracked_mu = PTHREAD_MUTEX_INITIALIZER;

void pr_cleanup_add_file(const char *path)
{
	int i;

	pthread_mutex_lock(&tracked_mu);
	for (i = 0; i < MAX_TRACKED; ++i)
		if (!tracked[i][0]) {
			snprintf(tracked[i], sizeof tracked[i], "%s", path);
			break;
		}
	pthread_mutex_unlock(&tracked_mu);
}

void pr_cleanup_remove_file(const char *path)
{
	int i;

	pthread_mutex_lock(&tracked_mu);
	for (i = 0; i < MAX_TRACKED; ++i)
		if (strcmp(tracked[i], path) == 0) {
			tracked[i][0] = '\0';
			break;
		}
	pthread_mutex_unlock(&tracked_mu);
}

/* The handler never sees an entry half written: the signals wait. */
void pr_cleanup_set_dir(const char *staging, const char *dir, size_t keep)
{
	int k = nstaging < MAX_STAGING ? nstaging : MAX_STAGING - 1;
	sigset_t old;

	pr_cleanup_hold(&old);
	snprintf(created_dir[k], sizeof created_dir[k], "%s", dir);
	created_keep[k] = keep;
	snprintf(staging_dir[k], sizeof staging_dir[k], "%s", staging);
	nstaging = k + 1;
	pr_cleanup_release(&old);
}

void pr_cleanup_clear_dir(void)
{
	sigset_t old;

	pr_cleanup_hold(&old);
	if (nstaging > 0) {
		int k = nstaging - 1;
		nstaging = k;
		staging_dir[k][0] = '\0';
		created_dir[k][0] = '\0';
	}
	pr_cleanup_release(&old);
}

struct dirent64_raw {
	uint64_t ino;
	int64_t off;
	unsigned short reclen;
	unsigned char type;
	char name[];
};

/* Remove name (in folder parent) and everything below it, depth folders
 * deep, with async-signal-safe calls only. Another thread may still add a
 * file: list again until the folder is gone. */
static void remove_dir_at(int parent, const char *name, int depth)
{
	long buf[512];
	int pass, fd;

	for (pass = 0; pass < 8; ++pass) {
		long n;
		if ((fd = openat(parent, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC)) < 0)
			return;
		while ((n = syscall(SYS_getdents64, fd, buf, sizeof buf)) > 0) {
			long off = 0;
			while (off < n) {
				const struct dirent64_raw *d = (const void *)((const char *)buf + off);
				off += d->reclen;
				if (strcmp(d->name, ".") && strcmp(d->name, "..") &&
				    unlinkat(fd, d->name, 0) != 0 && errno == EISDIR && depth > 0)
					remove_dir_at(fd, d->name, depth - 1);
			}
		}
		close(fd);
		if (unlinkat(parent, name, AT_REMOVEDIR) == 0 || errno != ENOTEMPTY)
			return;
	}
}

void pr_remove_tree(const char *dir)
{
	remove_dir_at(AT_FDCWD, dir, 8);
}

void pr_cleanup_run(void)
{
	int i, k, saved = errno;

	for (i = 0; i < MAX_TRACKED; ++i)
		if (tracked[i][0]) {
			unlink(tracked[i]);
			tracked[i][0] = '\0';
		}
	/* the innermost staging folder first */
	for (k = nstaging - 1; k >= 0; --k) {
		char *created = created_dir[k];
		if (staging_dir[k][0])
			remove_dir_at(AT_FDCWD, staging_dir[k], 8);
		/* the folders the run created, deepest first, each if empty */
		while (created[0] && strlen(created) > created_keep[k] && rmdir(created) == 0) {
			char *slash = strrchr(created, '/');
			if (!slash)
				break;
			*slash = '\0';
		}
		staging_dir[k][0] = created[0] = '\0';
	}
	nstaging = 0;
	errno = saved;
}

void pr_cleanup_hold(sigset_t *old)
{
	sigset_t set;
	int i;

	sigemptyset(&set);
	for (i = 0; pr_fatal_signals[i]; ++i)
		sigaddset(&set, pr_fatal_signals[i]);
	pthread_sigmask(SIG_BLOCK, &set, old);
}

void pr_cleanup_release(const sigset_t *old)
{
	pthread_sigmask(SIG_SETMASK, old, NULL);
}

int pr_cleanup_staged(const char *path)
{
	int k;

	for (k = 0; k < nstaging; ++k) {
		size_t n = strlen(staging_dir[k]);
		if (n && strncmp(path, staging_dir[k], n) == 0 && (path[n] == '/' || path[n] == '\0'))
			return 1;
	}
	return 0;
}

void pr_commit_end(const sigset_t *old, int rc, const char *target)
{
	/* set while the signals are still blocked: the handler sees it first */
	if (rc == PR_OK && !pr_cleanup_staged(target))
		pr_committed = 1;
	pr_cleanup_release(old);
}

int pr_errno_status(void)
{
	return errno == ENOMEM ? PR_ENOMEM : PR_EIO;
}

int pr_pid_gone(long pid)
{
	return pid > 0 && pid != (long)getpid() && kill((pid_t)pid, 0) != 0 && errno == ESRCH;
}

/* ---- who owns a staging folder or temporary file ---- */

/* The PID /proc/self names: getpid() only when /proc is this namespace's. */
static long proc_self_pid(void)
{
	char buf[32];
	ssize_t n = readlink("/proc/self", buf, sizeof buf - 1);

	if (n <= 0)
		return -1;
	buf[n] = '\0';
	return strtol(buf, NULL, 10);
}

/* Field 22 of /proc/PID/stat (PID 0: self): the start time in clock ticks
 * since boot; 0 when unknown. */
static unsigned long long start_time(long pid)
{
	char path[64], buf[1024], *p;
	unsigned long long t = 0;
	ssize_t n;
	int fd, i;

	snprintf(path, sizeof path, pid ? "/proc/%ld/stat" : "/proc/self/stat", pid);
	if ((fd = open(path, O_RDONLY | O_CLOEXEC)) < 0)
		return 0;
	n = read(fd, buf, sizeof buf - 1);
	close(fd);
	if (n <= 0)
		return 0;
	buf[n] = '\0';
	/* the command name in parentheses may hold blanks: count from its end */
	if (!(p = strrchr(buf, ')')))
		return 0;
	for (i = 2; i < 22 && p; ++i)
		p = strchr(p + 1, ' ');
	if (p)
		t = strtoull(p + 1, NULL, 10);
	return t;
}

/* This process's place: the first 12 hex digits of the boot id (one per
 * boot of one machine) and the inode of its PID namespace. */
static void where_am_i(char boot[13], unsigned long long *ns)
{
	char buf[64];
	struct stat st;
	ssize_t n;
	int fd, i, k = 0;

	memset(boot, '0', 12);
	boot[12] = '\0';
	if ((fd = open("/proc/sys/kernel/random/boot_id", O_RDONLY | O_CLOEXEC)) >= 0) {
		n = read(fd, buf, sizeof buf - 1);
		close(fd);
		for (i = 0; i < n && k < 12; ++i)
			if (isxdigit((unsigned char)buf[i]))
				boot[k++] = (char)tolower((unsigned char)buf[i]);
	}
	*ns = stat("/proc/self/ns/pid", &st) == 0 ? (unsigned long long)st.st_ino : 0;
}

static char owner[96];
static pthread_once_t owner_once = PTHREAD_ONCE_INIT;

static void make_owner(void)
{
	char boot[13];
	unsigned long long ns;

	where_am_i(boot, &ns);
	snprintf(owner, sizeof owner, "%ld-%llu-%llu-%s", (long)getpid(), start_time(0), ns, boot);
}

const char *pr_owner_tag(void)
{
	pthread_once(&owner_once, make_owner);
	return owner;
}

int pr_owner_dead(const char *tag)
{
	char boot[13], *end;
	unsigned long long ns, start, their_ns, now;
	long pid;
	size_t k;

	where_am_i(boot, &ns);
	errno = 0;
	pid = strtol(tag, &end, 10);
	if (end == tag || *end != '-' || pid <= 0 || errno)
		return 0;
	start = strtoull(end + 1, &end, 10);
	if (*end != '-')
		return 0;
	their_ns = strtoull(end + 1, &end, 10);
	if (*end != '-')
		return 0;
	++end;
	k = strspn(end, "0123456789abcdef");
	/* another machine, another boot or another PID namespace: its PID says nothing here */
	if (k != 12 || (end[12] && end[12] != '-') || memcmp(end, boot, 12) != 0 ||
	    strcmp(boot, "000000000000") == 0 || !ns || their_ns != ns)
		return 0;
	if (pr_pid_gone(pid))
		return 1;
	/* the PID lives again in another process (our /proc shows our namespace) */
	now = pid == (long)getpid() ? 0 : start_time(pid);
	return start && now && now != start && start_time(0) && (long)getpid() == proc_self_pid();
}

/* ---- threads ---- */

int pr_cpu_count(void)
{
	cpu_set_t set;
	long n;

	if (sched_getaffinity(0, sizeof set, &set) == 0)
		n = CPU_COUNT(&set);
	else
		n = sysconf(_SC_NPROCESSORS_ONLN);
	return n < 1 ? 1 : n > PR_MAX_THREADS ? PR_MAX_THREADS : (int)n;
}

void pr_run_parts(int nt, void *(*fn)(void *), void *parts, size_t size)
{
	pthread_t tid[PR_MAX_THREADS];
	int started[PR_MAX_THREADS], t;

	for (t = 1; t < nt; t++)
		started[t] = pthread_create(&tid[t], NULL, fn, (char *)parts + t * size) == 0;
	for (t = 0; t < nt; t++)
		if (t == 0 || !started[t])
			fn((char *)parts + t * size);
	for (t = 1; t < nt; t++)
		if (started[t])
			pthread_join(tid[t], NULL);
}

int pr_weights_check(const double *w, long n, const char *what, long *bad, char *err)
{
	double s = 0.0;
	long i;

	*bad = -1;
	for (i = 0; i < n; i++) {
		if (!(w[i] >= 0.0)) {
			*bad = i;
			return pr_err(err, PR_EINVAL, "%s must be >= 0 (got %g)", what, w[i]);
		}
		s += w[i];
	}
	if (!(s > 0.0))
		return pr_err(err, PR_EINVAL, "%ss are all zero", what);
	if (!isfinite(s))
		return pr_err(err, PR_EINVAL, "the %ss sum past the largest number: scale them down", what);
	return PR_OK;
}
