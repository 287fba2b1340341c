/* common.c — status helpers shared by every module. */
#include <stdarg.h>
#include <stdio.h>

#include "poolreps/common.h"

#ifndef PR_VERSION_STR
#define PR_VERSION_STR "0.1.0"
#endif

volatile sig_atomic_t pr_interrupted = 0;

int pr_err(char *err, int status, const char *fmt, ...)
{
	va_list ap;

	if (err) {
		va_start(ap, fmt);
		vsnprintf(err, PR_ERRLEN, fmt, ap);
		va_end(ap);
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
	case PR_EINTR: return 130;
	default: return 1;
	}
}

const char *pr_version(void)
{
	return PR_VERSION_STR;
}
