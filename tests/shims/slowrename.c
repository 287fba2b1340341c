/* slowrename.c — an LD_PRELOAD shim over rename(2), flock(2) and mkdir(2) that opens the commit
 * window of a command for the tests (tests/test_commit.py):
 *   RENAME_LOG=FILE       append "old new" of every rename to FILE
 *   RENAME_DELAY_MS=N     sleep N ms before every rename
 *   RENAME_MARK=FILE      create FILE just before the first rename whose new
 *                         name does not hold "/.partial-" or "/.poolreps-tmp-"
 *                         (the first move into the user's folder)
 *   RENAME_HOLD=FILE      with RENAME_MARK: after creating the mark, wait
 *                         (at most 300 s) until FILE exists, then go on: the
 *                         command is held at its commit point, staging in
 *                         place, for exactly as long as the test needs
 *   RENAME_MARK_FIRST=1   with RENAME_MARK: create the mark (and hold) right
 *                         after the first rename of all, a move inside the
 *                         staging folder: the command is held in its work,
 *                         before it locks the folder to publish
 *   RENAME_KILL_AT=K      before the K-th such rename (1-based) send
 *   RENAME_KILL_SIG=S     signal S (default SIGTERM) to this process
 *   RENAME_FAIL_AT=K      make the K-th such rename fail with EIO
 *   FLOCK_DIR_EBADF=1     flock(2) on a folder fails with EBADF, as on NFS,
 *                         where flock is emulated by byte-range locks that
 *                         need a file open for writing
 *   MKDIR_LOG=FILE        append the path of every successful mkdir(2)
 *   MKDIR_KILL_AT=K       right after the K-th successful mkdir (1-based)
 *   MKDIR_KILL_SIGS=S,..  send these signals (default SIGTERM), back to
 *                         back, to this process: the window between making
 *                         a folder and registering it for clean-up
 * Only the test builds it; it is not part of the library. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static int staged(const char *p)
{
	return strstr(p, "/.partial-") || strstr(p, ".poolreps-tmp-");
}

static void hold(const char *go)
{
	struct timespec ts = {0, 10000000L};

	for (int i = 0; go && i < 30000 && access(go, F_OK) != 0; i++)
		nanosleep(&ts, NULL);
}

static void put_mark(const char *mark)
{
	int fd = open(mark, O_WRONLY | O_CREAT, 0666);

	if (fd >= 0)
		close(fd);
	hold(getenv("RENAME_HOLD"));
}

int rename(const char *from, const char *to)
{
	static int (*real)(const char *, const char *);
	static int count, marked;
	int rc;
	const char *log = getenv("RENAME_LOG"), *delay = getenv("RENAME_DELAY_MS");
	const char *mark = getenv("RENAME_MARK"), *at = getenv("RENAME_KILL_AT");
	const char *sig = getenv("RENAME_KILL_SIG"), *fail = getenv("RENAME_FAIL_AT");

	if (!real)
		real = (int (*)(const char *, const char *))dlsym(RTLD_NEXT, "rename");
	if (mark && !marked && !getenv("RENAME_MARK_FIRST") && count == 0 && !staged(to)) {
		marked = 1;
		put_mark(mark);
	}
	if (log) {
		FILE *fp = fopen(log, "a");
		if (fp) {
			fprintf(fp, "%s %s\n", from, to);
			fclose(fp);
		}
	}
	if (!staged(to)) {
		++count;
		if (at && atoi(at) == count)
			kill(getpid(), sig ? atoi(sig) : SIGTERM);
		if (fail && atoi(fail) == count) {
			errno = EIO;
			return -1;
		}
	}
	if (delay) {
		struct timespec ts = {atoi(delay) / 1000, (long)(atoi(delay) % 1000) * 1000000L};
		nanosleep(&ts, NULL);
	}
	rc = real(from, to);
	if (mark && !marked && getenv("RENAME_MARK_FIRST")) {
		marked = 1;
		put_mark(mark);
	}
	return rc;
}

int flock(int fd, int op)
{
	static int (*real)(int, int);
	struct stat st;

	if (!real)
		real = (int (*)(int, int))dlsym(RTLD_NEXT, "flock");
	if (getenv("FLOCK_DIR_EBADF") && fstat(fd, &st) == 0 && S_ISDIR(st.st_mode)) {
		errno = EBADF;
		return -1;
	}
	return real(fd, op);
}

static void send_listed(const char *sigs)
{
	char *end;

	if (!sigs) {
		kill(getpid(), SIGTERM);
		return;
	}
	for (const char *p = sigs; *p; p = *end ? end + 1 : end) {
		long s = strtol(p, &end, 10);
		if (end == p)
			break;
		kill(getpid(), (int)s);
	}
}

int mkdir(const char *path, mode_t mode)
{
	static int (*real)(const char *, mode_t);
	static int count;
	const char *log = getenv("MKDIR_LOG"), *at = getenv("MKDIR_KILL_AT");
	int rc;

	if (!real)
		real = (int (*)(const char *, mode_t))dlsym(RTLD_NEXT, "mkdir");
	if ((rc = real(path, mode)) != 0)
		return rc;
	if (log) {
		FILE *fp = fopen(log, "a");
		if (fp) {
			fprintf(fp, "%s\n", path);
			fclose(fp);
		}
	}
	if (at && atoi(at) == ++count)
		send_listed(getenv("MKDIR_KILL_SIGS"));
	return 0;
}
