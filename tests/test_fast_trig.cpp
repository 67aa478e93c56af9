// sin_cos (core/fast_trig.hpp) against glibc's long double sinl and cosl.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "core/fast_trig.hpp"

using namespace ringsim;

namespace {

// The error budget of fast_trig.hpp: reduction <= 0.5 ulp of |r| <= pi/4
// (2^-54) plus ~5e-21 from k P2; the polynomial sums ~1 ulp of the result
// (<= 2^-53 for |result| <= 1): in all below 2^-52 absolute. Relative: 1.5
// ulp of the result within |x| <= pi/4, where the reduction is exact (near a
// zero at large |x| only the absolute bound holds).
constexpr double kAbsBound = 0x1p-52;

double ulp_error(double got, long double ref) {
  const double r = std::abs(static_cast<double>(ref));
  const double ulp = std::nextafter(r, std::numeric_limits<double>::infinity()) - r;
  return static_cast<double>(std::abs(static_cast<long double>(got) - ref) / ulp);
}

}  // namespace

TEST(FastTrig, WithinTheErrorBudgetOverTheFastRange) {
  std::mt19937_64 rng(7);
  for (const double range : {M_PI / 4, 10.0, 1e3, 1e5, kFastTrigLimit}) {
    std::uniform_real_distribution<double> u(-range, range);
    double worst_abs = 0.0, worst_ulp = 0.0;
    for (int n = 0; n < 200000; ++n) {
      const double x = u(rng);
      double s, c;
      sin_cos(x, &s, &c);
      const long double rs = sinl(x), rc = cosl(x);
      worst_abs = std::max({worst_abs, static_cast<double>(std::abs(s - rs)), static_cast<double>(std::abs(c - rc))});
      worst_ulp = std::max({worst_ulp, ulp_error(s, rs), ulp_error(c, rc)});
    }
    EXPECT_LE(worst_abs, kAbsBound) << "range " << range;
    if (range <= M_PI / 4) EXPECT_LE(worst_ulp, 1.5) << "range " << range;
  }
}

TEST(FastTrig, QuadrantsSignsAndBoundaries) {
  // Near every multiple of pi/4 up to +-40 quadrants, on both sides, where the
  // reduction switches quadrant or polynomial roles.
  for (int m = -160; m <= 160; ++m) {
    const double centre = m * (M_PI / 4);
    for (const double d : {-1e-9, -1e-15, 0.0, 1e-15, 1e-9}) {
      const double x = centre + d;
      double s, c;
      sin_cos(x, &s, &c);
      EXPECT_NEAR(s, static_cast<double>(sinl(x)), kAbsBound) << x;
      EXPECT_NEAR(c, static_cast<double>(cosl(x)), kAbsBound) << x;
    }
  }
  double s, c;
  sin_cos(0.0, &s, &c);
  EXPECT_EQ(s, 0.0);
  EXPECT_EQ(c, 1.0);
  sin_cos(1e-300, &s, &c);  // tiny arguments: sin x = x exactly
  EXPECT_EQ(s, 1e-300);
  EXPECT_EQ(c, 1.0);
  sin_cos(-0.5, &s, &c);  // odd and even
  double s2, c2;
  sin_cos(0.5, &s2, &c2);
  EXPECT_EQ(s, -s2);
  EXPECT_EQ(c, c2);
}

TEST(FastTrig, OutsideTheFastRangeIsGlibc) {
  for (const double x : {std::nextafter(kFastTrigLimit, 1e300), -1e6, 1e300, 12345678.9}) {
    double s, c;
    sin_cos(x, &s, &c);
    EXPECT_EQ(s, std::sin(x)) << x;
    EXPECT_EQ(c, std::cos(x)) << x;
  }
  double s, c;
  sin_cos(std::numeric_limits<double>::quiet_NaN(), &s, &c);
  EXPECT_TRUE(std::isnan(s) && std::isnan(c));
  sin_cos(std::numeric_limits<double>::infinity(), &s, &c);
  EXPECT_TRUE(std::isnan(s) && std::isnan(c));
}
