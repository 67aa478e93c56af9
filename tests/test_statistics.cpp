// Summary statistics against hand-computed values.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "analysis/statistics.hpp"

namespace ringsim {
namespace {

TEST(Statistics, StudentTIntervalOfOneToFive) {
  // mean 3, sample variance 2.5, t_{0.975, 4} = 2.7764451 (tables),
  // half-width 2.7764451 * sqrt(2.5 / 5) = 1.9632432.
  const Summary s = summarize({1, 2, 3, 4, 5});
  EXPECT_EQ(s.n, 5);
  EXPECT_EQ(s.n_undefined, 0);
  EXPECT_DOUBLE_EQ(s.mean, 3.0);
  EXPECT_NEAR(s.std, std::sqrt(2.5), 1e-15);
  EXPECT_NEAR(student_t_quantile(0.95, 4), 2.7764451, 1e-7);
  EXPECT_NEAR(s.ci95, 1.9632432, 1e-7);
}

TEST(Statistics, UndefinedValuesAreCountedNotUsed) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Summary s = summarize({nan, 2.0, 4.0, nan});
  EXPECT_EQ(s.n, 2);
  EXPECT_EQ(s.n_undefined, 2);
  EXPECT_DOUBLE_EQ(s.mean, 3.0);
  // t_{0.975, 1} = 12.7062047; std = sqrt(2); half-width = 12.7062047 * sqrt(2) / sqrt(2)
  EXPECT_NEAR(s.ci95, 12.7062047, 1e-6);
}

TEST(Statistics, TooFewValues) {
  EXPECT_TRUE(std::isnan(summarize({}).mean));
  const Summary one = summarize({7.0});
  EXPECT_DOUBLE_EQ(one.mean, 7.0);
  EXPECT_TRUE(std::isnan(one.ci95));
}

}  // namespace
}  // namespace ringsim
