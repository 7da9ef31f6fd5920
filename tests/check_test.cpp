// util/check.h: CHECK aborts with the failed condition and its location; DCHECK does as
// configured (LENSIM_DCHECKS), and when off does not evaluate its condition.
#include "lensim/util/check.h"

#include <gtest/gtest.h>

namespace {

TEST(Check, FailureAbortsNamingConditionAndLocation) {
  const int three = 3;
  EXPECT_DEATH(CHECK(1 + 1 == three),
               "check_test\\.cpp:[0-9]+: internal error: check failed: 1 \\+ 1 == three");
}

TEST(Check, PassingCheckEvaluatesOnceAndContinues) {
  int evaluated = 0;
  CHECK(++evaluated == 1);
  EXPECT_EQ(evaluated, 1);
}

TEST(Check, DcheckAsConfigured) {
  int evaluated = 0;
#ifdef LENSIM_DCHECKS
  DCHECK(++evaluated == 1);
  EXPECT_EQ(evaluated, 1);
  EXPECT_DEATH(DCHECK(evaluated == 2), "internal error: check failed: evaluated == 2");
#else
  DCHECK(++evaluated == 2);  // off: not evaluated, so it cannot fail
  EXPECT_EQ(evaluated, 0);
#endif
}

}  // namespace
