// util/check.h: LENSIM_CHECK aborts with the failed condition and its location, the comparison
// forms with the values compared; LENSIM_DCHECK does as configured (LENSIM_DCHECKS), and when
// off does not evaluate its operands. The build with LENSIM_DCHECKS=ON (Debug, sanitizers, or
// the option) runs the death tests of the DCHECK forms.
#include "lensim/util/check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace {

TEST(Check, FailureAbortsNamingConditionAndLocation) {
  const int three = 3;
  EXPECT_DEATH(LENSIM_CHECK(1 + 1 == three),
               "check_test\\.cpp:[0-9]+: internal error: check failed: 1 \\+ 1 == three");
  EXPECT_DEATH(CHECK(1 + 1 == three), "check failed: 1 \\+ 1 == three");  // the short name
}

TEST(Check, PassingCheckEvaluatesOnceAndContinues) {
  int evaluated = 0;
  LENSIM_CHECK(++evaluated == 1);
  EXPECT_EQ(evaluated, 1);
  LENSIM_CHECK_LT(++evaluated, 3);
  LENSIM_CHECK_EQ(evaluated, 2);
  LENSIM_CHECK_NEAR(0.1 + 0.2, 0.3, 1e-15);
  LENSIM_CHECK_FINITE(1e308);
  EXPECT_EQ(evaluated, 2);
}

TEST(Check, ComparisonNamesTheValues) {
  const double pdf = -0.25;
  EXPECT_DEATH(LENSIM_CHECK_GE(pdf, 0),
               "check_test\\.cpp:[0-9]+: internal error: check failed: pdf >= 0 "
               "\\(pdf = -0\\.25, 0 = 0\\)");
  const std::vector<int> v(3);
  const size_t i = 3;
  EXPECT_DEATH(LENSIM_CHECK_LT(i, v.size()), "check failed: i < v.size\\(\\) \\(i = 3, "
                                             "v.size\\(\\) = 3\\)");
  EXPECT_DEATH(LENSIM_CHECK_NE(i, 3u), "check failed: i != 3u \\(i = 3, 3u = 3\\)");
  const double len = 1.5;
  EXPECT_DEATH(LENSIM_CHECK_NEAR(len, 1, 1e-6),
               "check failed: \\|len - 1\\| <= 1e-6 \\(len = 1\\.5, 1 = 1\\)");
  const double x = std::numeric_limits<double>::infinity();
  EXPECT_DEATH(LENSIM_CHECK_FINITE(x), "check failed: std::isfinite\\(x\\) \\(x = inf\\)");
}

TEST(Check, NanFailsComparisons) {
  const double nan = std::nan("");
  EXPECT_DEATH(LENSIM_CHECK_GE(nan, 0), "check failed: nan >= 0 \\(nan = nan, 0 = 0\\)");
  EXPECT_DEATH(LENSIM_CHECK_LT(nan, 1), "check failed: nan < 1");
  EXPECT_DEATH(LENSIM_CHECK_NEAR(nan, 1, 1e300), "check failed");
  EXPECT_DEATH(LENSIM_CHECK_FINITE(nan), "check failed: std::isfinite\\(nan\\) \\(nan = nan\\)");
}

TEST(Check, DcheckAsConfigured) {
  int evaluated = 0;
#ifdef LENSIM_DCHECKS
  LENSIM_DCHECK(++evaluated == 1);
  LENSIM_DCHECK_EQ(++evaluated, 2);
  EXPECT_EQ(evaluated, 2);
  EXPECT_DEATH(LENSIM_DCHECK(evaluated == 3), "internal error: check failed: evaluated == 3");
  EXPECT_DEATH(LENSIM_DCHECK_GT(evaluated, 2),
               "check_test\\.cpp:[0-9]+: internal error: check failed: evaluated > 2 "
               "\\(evaluated = 2, 2 = 2\\)");
  EXPECT_DEATH(LENSIM_DCHECK_FINITE(std::nan("")), "check failed: std::isfinite");
  EXPECT_DEATH(DCHECK(evaluated == 3), "check failed: evaluated == 3");
#else
  // Off: not evaluated, so none of them can fail.
  LENSIM_DCHECK(++evaluated == 2);
  LENSIM_DCHECK_EQ(++evaluated, 5);
  LENSIM_DCHECK_LT(++evaluated, 0);
  LENSIM_DCHECK_NEAR(++evaluated, 7, 0);
  LENSIM_DCHECK_FINITE(std::nan(""));
  DCHECK(++evaluated == 2);
  EXPECT_EQ(evaluated, 0);
#endif
}

}  // namespace
