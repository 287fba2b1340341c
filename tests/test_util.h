/* test_util.h — helpers shared by the cmocka tests (include after cmocka.h). */
#ifndef POOLREPS_TEST_UTIL_H
#define POOLREPS_TEST_UTIL_H

#include <math.h>

/* |a - b| <= tol in double (cmocka's assert_float_equal works in float);
 * a failure prints both values and the tolerance. NaN fails. */
#define assert_near(a, b, tol)                                                         \
	do {                                                                           \
		double a_ = (a), b_ = (b), tol_ = (tol);                               \
		if (!(fabs(a_ - b_) <= tol_))                                          \
			fail_msg("%s = %.17g, expected %s = %.17g +- %g (off by %g)", #a, a_, \
			         #b, b_, tol_, fabs(a_ - b_));                         \
	} while (0)

#endif
