// MSER / MSER-m steady-state detection against hand-computed series, an
// independent O(n^2) evaluation of the definition, the steady-state monitor
// and the `ringsim mser` command.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis/mser.hpp"

namespace ringsim {
namespace {

// ---- helpers ---------------------------------------------------------------

// Deterministic uniform noise in [-1, 1) (splitmix64; no std distributions,
// whose output differs between standard libraries).
struct Noise {
  std::uint64_t state;
  double operator()() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return 2.0 * (static_cast<double>(z >> 11) * 0x1.0p-53) - 1.0;
  }
};

// The definition evaluated directly, O(n^2), independently of mser():
// batch means by direct sums, then for every candidate d in [0, k-2] the mean
// and the sum of squares of the retained means by direct sums; first minimum wins.
struct BruteForce {
  std::size_t truncation;
  std::size_t d;
  std::size_t k;
  double statistic;
};
BruteForce brute_force_mser(const std::vector<double>& y, std::size_t m) {
  const std::size_t k = y.size() / m;
  std::vector<double> x(k);
  for (std::size_t j = 0; j < k; ++j) {
    double s = 0.0;
    for (std::size_t i = 0; i < m; ++i) s += y[j * m + i];
    x[j] = s / static_cast<double>(m);
  }
  BruteForce best{0, 0, k, std::numeric_limits<double>::infinity()};
  for (std::size_t d = 0; d + 2 <= k; ++d) {
    double mean = 0.0;
    for (std::size_t j = d; j < k; ++j) mean += x[j];
    mean /= static_cast<double>(k - d);
    double ss = 0.0;
    for (std::size_t j = d; j < k; ++j) ss += (x[j] - mean) * (x[j] - mean);
    const double stat = ss / (static_cast<double>(k - d) * static_cast<double>(k - d));
    if (stat < best.statistic) best = BruteForce{m * d, d, k, stat};
  }
  return best;
}

std::vector<double> step_series(double noise_amplitude) {
  // 20 values of 10, then 80 values of 0, plus +-a alternating: +a at even i.
  std::vector<double> y;
  for (int i = 0; i < 100; ++i) y.push_back((i < 20 ? 10.0 : 0.0) + (i % 2 == 0 ? noise_amplitude : -noise_amplitude));
  return y;
}

// ---- tiny exact examples, batch 1 ------------------------------------------

TEST(Mser, TinyExampleWarmUpOfOne) {
  // y = 6 0 2 0 2, k = 5, candidates d = 0..3:
  //   d=0: mean 2,   SS = 16+4+0+4+0 = 24,           MSER = 24/25 = 0.96
  //   d=1: mean 1,   SS = 1+1+1+1 = 4,               MSER = 4/16  = 0.25   <- min
  //   d=2: mean 4/3, SS = 4/9+16/9+4/9 = 8/3,        MSER = 8/27  = 0.296
  //   d=3: mean 1,   SS = 1+1 = 2,                   MSER = 2/4   = 0.5
  // d* = 1; steady since 2*1 <= 5.
  const MserResult r = mser({6, 0, 2, 0, 2});
  EXPECT_EQ(r.truncation, 1u);
  EXPECT_EQ(r.batches, 5u);
  EXPECT_TRUE(r.steady);
  EXPECT_NEAR(r.statistic, 0.25, 1e-15);
}

TEST(Mser, TinyExampleTruncationExactlyHalfIsSteady) {
  // y = 0 10 3 3, k = 4, d = 0..2:
  //   d=0: mean 4,    SS = 16+36+1+1 = 54,            MSER = 54/16 = 3.375
  //   d=1: mean 16/3, SS = (14/3)^2 + 2 (7/3)^2 = 294/9, MSER = 294/81 = 3.63
  //   d=2: 3 3 -> SS = 0,                              MSER = 0      <- min
  // d* = 2 = k/2: steady (boundary of 2 d* <= k). Note that with k <= 4 every
  // candidate d <= k-2 satisfies 2 d <= k: such short series are always "steady"
  // (why SteadyStateMonitor requires at least 5 batches).
  const MserResult r = mser({0, 10, 3, 3});
  EXPECT_EQ(r.truncation, 2u);
  EXPECT_EQ(r.batches, 4u);
  EXPECT_TRUE(r.steady);
  EXPECT_EQ(r.statistic, 0.0);
}

TEST(Mser, TinyExampleOddKBoundary) {
  // y = 9 9 0 1 0, k = 5, d = 0..3:
  //   d=0: mean 19/5 = 3.8, SS = 2*5.2^2 + 3.8^2 + 2.8^2 + 3.8^2 = 54.08+14.44+7.84+14.44 = 90.8, MSER = 3.632
  //   d=1: mean 2.5, SS = 42.25+6.25+2.25+6.25 = 57,   MSER = 57/16 = 3.5625
  //   d=2: mean 1/3, SS = 1/9+4/9+1/9 = 2/3,           MSER = 2/27 = 0.0741  <- min
  //   d=3: mean 1/2, SS = 1/2,                         MSER = 1/8  = 0.125
  // d* = 2 and 2*2 = 4 <= 5: steady.
  const MserResult r = mser({9, 9, 0, 1, 0});
  EXPECT_EQ(r.truncation, 2u);
  EXPECT_TRUE(r.steady);
  EXPECT_NEAR(r.statistic, 2.0 / 27.0, 1e-15);
}

TEST(Mser, TinyExampleStillRisingIsNotSteady) {
  // y = 1 2 3 4 4, k = 5, d = 0..3:
  //   d=0: mean 2.8,  SS = 3.24+0.64+0.04+1.44+1.44 = 6.8,  MSER = 6.8/25 = 0.272
  //   d=1: mean 3.25, SS = 1.5625+0.0625+0.5625+0.5625 = 2.75, MSER = 2.75/16 = 0.171875
  //   d=2: mean 11/3, SS = 4/9+1/9+1/9 = 2/3,          MSER = 2/27 = 0.074
  //   d=3: 4 4 -> 0                                     <- min
  // d* = 3 and 2*3 = 6 > 5: not steady.
  const MserResult r = mser({1, 2, 3, 4, 4});
  EXPECT_EQ(r.truncation, 3u);
  EXPECT_FALSE(r.steady);
  EXPECT_EQ(r.statistic, 0.0);
}

TEST(Mser, TiesGoToTheSmallestTruncation) {
  // y = 5 0 0 0 0: d=0: mean 1, SS = 16+4 = 20, MSER = 0.8; d = 1, 2, 3 all give 0.
  const MserResult r = mser({5, 0, 0, 0, 0});
  EXPECT_EQ(r.truncation, 1u);
  EXPECT_TRUE(r.steady);
  // A constant series: every candidate gives exactly 0, so d* = 0.
  const MserResult c = mser({0.1, 0.1, 0.1, 0.1, 0.1, 0.1});
  EXPECT_EQ(c.truncation, 0u);
  EXPECT_EQ(c.statistic, 0.0);
  EXPECT_TRUE(c.steady);
}

TEST(Mser, BatchingDropsTheRemainder) {
  // n = 13, m = 3: k = floor(13/3) = 4 batch means, the 13th value (1000) is dropped.
  //   batches (9 6 6) (1 2 3) (4 2 3) (3 1 2) -> means 7 2 3 2
  //   d=0: mean 3.5, SS = 12.25+2.25+0.25+2.25 = 17, MSER = 17/16 = 1.0625
  //   d=1: mean 7/3, SS = 1/9+4/9+1/9 = 2/3,       MSER = 2/27         <- min
  //   d=2: mean 2.5, SS = 0.5,                      MSER = 0.125
  // d* = 1 batch -> truncation 3 raw observations; steady (2 <= 4).
  const std::vector<double> y{9, 6, 6, 1, 2, 3, 4, 2, 3, 3, 1, 2, 1000};
  const MserResult r = mser(y, 3);
  EXPECT_EQ(r.batches, 4u);
  EXPECT_EQ(r.truncation, 3u);
  EXPECT_TRUE(r.steady);
  EXPECT_NEAR(r.statistic, 2.0 / 27.0, 1e-15);
  const MserResult without(mser(std::vector<double>(y.begin(), y.end() - 1), 3));
  EXPECT_EQ(without.truncation, r.truncation);
  EXPECT_EQ(without.statistic, r.statistic);

  // Same data, m = 5: k = floor(13/5) = 2 (the last 3 values dropped); the only
  // candidate is d = 0 (2 batches must remain).
  const MserResult r5 = mser(y, 5);
  EXPECT_EQ(r5.batches, 2u);
  EXPECT_EQ(r5.truncation, 0u);
  EXPECT_TRUE(r5.steady);
  // Means (9+6+6+1+2)/5 = 4.8 and (3+4+2+3+3)/5 = 3: mean 3.9, SS = 2*0.81, MSER = 1.62/4.
  EXPECT_NEAR(r5.statistic, 0.405, 1e-14);
}

TEST(Mser, RejectsBadInput) {
  EXPECT_THROW(mser({1, 2, 3}, 0), std::invalid_argument);
  EXPECT_THROW(mser({1}), std::invalid_argument);                 // 1 batch
  EXPECT_THROW(mser({1, 2, 3, 4, 5, 6, 7, 8, 9}, 5), std::invalid_argument);  // 1 batch of 5
  EXPECT_NO_THROW(mser({1, 2, 3, 4, 5, 6, 7, 8, 9, 10}, 5));     // 2 batches
  EXPECT_THROW(mser({1, std::nan(""), 3}), std::invalid_argument);
}

// ---- step ------------------------------------------------------------------

TEST(Mser, StepIsCutAtTheStep) {
  // 20 x 10 then 80 x 0. Batch 1: any retained part holding a 10 has SS > 0,
  // every d in [20, 98] gives SS = 0, so d* = 20 (smallest of the ties).
  // Batch 5: means 4 x 10 then 16 x 0, k = 20, d* = 4 -> 20 raw observations.
  const std::vector<double> y = step_series(0.0);
  const MserResult r1 = mser(y, 1);
  EXPECT_EQ(r1.truncation, 20u);
  EXPECT_EQ(r1.batches, 100u);
  EXPECT_TRUE(r1.steady);
  const MserResult r5 = mser(y, 5);
  EXPECT_EQ(r5.truncation, 20u);
  EXPECT_EQ(r5.batches, 20u);
  EXPECT_TRUE(r5.steady);
  EXPECT_EQ(r5.statistic, 0.0);
}

TEST(Mser, StepWithAlternatingNoiseIsCutAtTheStep) {
  // Add +-a alternating (a = 0.01). For d >= 20 the c = 100 - d retained values
  // alternate +-a: c even -> mean 0, SS = c a^2, MSER = a^2 / c; c odd -> mean
  // +-a/c, SS = a^2 (c - 1/c), MSER = a^2 (1/c - 1/c^3). Both grow as c shrinks:
  // MSER(20) = a^2/80 = 1.25e-6 < MSER(21) = a^2 (1/79 - 1/79^3) = 1.2656e-6.
  // For d < 20 a value 10 apart from ~80 others adds ~ 100 * 80/81 to SS:
  // MSER >= ~0.0098. Hence d* = 20, statistic a^2/80.
  const double a = 0.01;
  const MserResult r1 = mser(step_series(a), 1);
  EXPECT_EQ(r1.truncation, 20u);
  EXPECT_NEAR(r1.statistic, a * a / 80.0, 1e-18);
  // Batch 5: batch j starts at index 5 j, even for even j, so its mean is
  // +a/5 for even j and -a/5 for odd j: batches 4..19 alternate +-a' with
  // a' = a/5 = 0.002, the same situation with k = 20. MSER(4) = a'^2/16 (c = 16)
  // < MSER(5) = a'^2 (1/15 - 1/15^3) = 0.06637 a'^2; d < 4 keeps a batch near 10.
  const MserResult r5 = mser(step_series(a), 5);
  EXPECT_EQ(r5.truncation, 20u);
  EXPECT_TRUE(r5.steady);
  EXPECT_NEAR(r5.statistic, (a / 5) * (a / 5) / 16.0, 1e-18);
}

// ---- ramp + noise settling to a constant --------------------------------------
//
// With noise, a single MSER evaluation has a known artefact: MSER(d) for d
// near k-2 rests on 2-3 retained values, and when those happen to be close
// together it undercuts sigma^2 / (k - d) of the whole steady part, putting d*
// in the last few batches (so "not steady"). Measured with this generator:
// ~5 % (m = 1) and ~8-12 % (m = 5) of iid series of 1000; the monitor's
// repeated checks absorb it. The tests below therefore check every series
// against the brute-force definition and, series by series, that d* is
// either at the warm-up (steady) or in the last 10 batches (the artefact).

TEST(Mser, RampPlusNoiseMatchesBruteForceAndIsCutNearTheRampEnd) {
  // y_i = 20 (1 - i/40) for i < 40, then 0; plus uniform noise in [-1, 1)
  // (sigma = 0.577), n = 400. Heuristic location: a value with bias b enters
  // the retained set when b^2 < ~2 sigma^2 (MSER decreases when a point is
  // added), i.e. b < 0.82 for m = 1: about 2 points before the ramp end (slope 0.5);
  // for m = 5 the batch-mean noise is sigma/sqrt(5) = 0.26, so the cut is at
  // the batch boundary 40. Later cuts come from noise-driven minima (MSER's
  // cut is the minimizer of a random walk, Wang & Glynn 2016).
  const std::size_t n = 400, ramp_end = 40;
  for (std::size_t m : {1u, 5u}) {
    std::vector<std::size_t> steady_cuts;
    for (std::uint64_t seed = 1; seed <= 100; ++seed) {
      Noise noise{seed};
      std::vector<double> y;
      for (std::size_t i = 0; i < n; ++i)
        y.push_back((i < ramp_end ? 20.0 * (1.0 - static_cast<double>(i) / ramp_end) : 0.0) + noise());
      const MserResult r = mser(y, m);
      const BruteForce b = brute_force_mser(y, m);
      EXPECT_EQ(r.truncation, b.truncation) << "seed " << seed << " batch " << m;
      EXPECT_NEAR(r.statistic, b.statistic, 1e-12 * b.statistic) << "seed " << seed << " batch " << m;
      EXPECT_EQ(r.batches, b.k);
      EXPECT_EQ(r.steady, 2 * b.d <= b.k);
      if (r.steady) {
        steady_cuts.push_back(r.truncation);
        EXPECT_GE(r.truncation, ramp_end - 5) << "seed " << seed << " batch " << m;
        EXPECT_LE(r.truncation, m == 1 ? ramp_end + 10 : ramp_end + 80) << "seed " << seed << " batch " << m;
      } else {
        EXPECT_GE(r.truncation, n - 10 * m) << "seed " << seed << " batch " << m;  // end artefact only
      }
    }
    // Most series are steady (measured 86 and 79 of 100), and the typical cut is at the ramp end.
    EXPECT_GE(steady_cuts.size(), m == 1 ? 75u : 70u);
    std::sort(steady_cuts.begin(), steady_cuts.end());
    const std::size_t median = steady_cuts[steady_cuts.size() / 2];
    EXPECT_GE(median, ramp_end - 3) << "batch " << m;
    EXPECT_LE(median, ramp_end + 5) << "batch " << m;
  }
}

TEST(Mser, LargeOffsetDoesNotCostAccuracy) {
  // The same ramp + noise shifted by 1e9: the truncation must not change
  // (a naive sum of squares minus squared sum would cancel catastrophically:
  // squares ~1e18 against a spread ~0.3, below double resolution).
  Noise noise{7};
  std::vector<double> y, shifted;
  for (std::size_t i = 0; i < 400; ++i) {
    const double v = (i < 40 ? 20.0 * (1.0 - i / 40.0) : 0.0) + noise();
    y.push_back(v);
    shifted.push_back(v + 1e9);
  }
  const MserResult r = mser(y, 5), s = mser(shifted, 5);
  EXPECT_EQ(s.truncation, r.truncation);
  EXPECT_NEAR(s.statistic, r.statistic, 1e-5 * r.statistic);
}

TEST(Mser, ExtremeMagnitudesGiveTheTruncationOfTheUnscaledData) {
  // Multiplying the data by 2^p multiplies every MSER(d) by 2^(2p) exactly and
  // changes nothing else, so d* must not move. Near 1e308 the squared
  // deviations overflow, near 1e-300 they underflow to 0 (every candidate a tie
  // at 0, d* = 0): the evaluation must not inherit either from the data's range.
  // The statistic is reported in squared units of the data, so it is inf (or 0)
  // only when MSER(d*) itself lies outside the double range (p = 1000, -600, -1000).
  const std::vector<double> y = step_series(0.01);
  for (std::size_t m : {1u, 5u}) {
    const MserResult r = mser(y, m);
    ASSERT_EQ(r.truncation, 20u);
    for (int p : {-1000, -600, 520, 1000}) {
      std::vector<double> scaled;
      for (double v : y) scaled.push_back(std::ldexp(v, p));
      const MserResult s = mser(scaled, m);
      EXPECT_EQ(s.truncation, r.truncation) << "scale 2^" << p << ", batch " << m;
      EXPECT_EQ(s.steady, r.steady) << "scale 2^" << p << ", batch " << m;
      EXPECT_EQ(s.statistic, std::ldexp(r.statistic, 2 * p)) << "scale 2^" << p << ", batch " << m;
    }
  }
}

// ---- stationary noise -------------------------------------------------------

TEST(Mser, StationaryNoiseIsSteadyWithSmallTruncation) {
  // iid noise has no warm-up: MSER(d) ~ sigma^2 / (n-d) grows with d, so d* is
  // at or near 0, except for the end artefact above.
  const std::size_t n = 1000;
  for (std::size_t m : {1u, 5u}) {
    std::size_t steady = 0;
    for (std::uint64_t seed = 1; seed <= 100; ++seed) {
      Noise noise{seed};
      std::vector<double> y;
      for (std::size_t i = 0; i < n; ++i) y.push_back(5.0 + noise());
      const MserResult r = mser(y, m);
      EXPECT_EQ(r.truncation, brute_force_mser(y, m).truncation) << "seed " << seed << " batch " << m;
      if (r.steady) {
        ++steady;
        EXPECT_LE(r.truncation, n / 10) << "seed " << seed << " batch " << m;
      } else {
        EXPECT_GE(r.truncation, n - 10 * m) << "seed " << seed << " batch " << m;
      }
    }
    EXPECT_GE(steady, m == 1 ? 90u : 85u) << "batch " << m;  // measured 95 and 92 of 100
  }
}

// ---- still trending ---------------------------------------------------------

TEST(Mser, TrendToTheEndIsNotSteady) {
  // Exact line y_i = i: c equispaced values with unit spacing have
  // SS = c (c^2 - 1) / 12, so MSER(d) = (c^2 - 1) / (12 c), c = n - d, which
  // decreases as c shrinks: d* = k - 2 (the last allowed candidate), not steady.
  std::vector<double> y;
  for (int i = 0; i < 100; ++i) y.push_back(i);
  const MserResult r1 = mser(y, 1);
  EXPECT_EQ(r1.truncation, 98u);
  EXPECT_FALSE(r1.steady);
  EXPECT_NEAR(r1.statistic, 3.0 / 24.0, 1e-15);  // c = 2: (4 - 1) / 24
  // Batch 5: the means 2, 7, 12, ... are again a line: d* = 18 of k = 20 -> 90.
  const MserResult r5 = mser(y, 5);
  EXPECT_EQ(r5.truncation, 90u);
  EXPECT_FALSE(r5.steady);
  // A noisy drift (slope 0.05 per sample, noise +-1) is not steady either.
  Noise noise{3};
  std::vector<double> z;
  for (int i = 0; i < 1000; ++i) z.push_back(0.05 * i + noise());
  EXPECT_FALSE(mser(z, 5).steady);
  EXPECT_FALSE(mser(z, 1).steady);
}

// ---- SteadyStateMonitor -----------------------------------------------------

TEST(SteadyStateMonitor, SamplesSeeTheValueCurrentAtEachSampleTime) {
  // dt = 0.5 (exact in binary). Changes at 1.0 (exactly a sample time: the
  // sample sees the new value) and at 1.7 (between samples 1.5 and 2.0).
  SteadyStateMonitor m(0.5, 1000, 1, 1);
  m.set(0.0, 10);
  m.set(1.0, 20);
  m.set(1.7, 30);
  EXPECT_FALSE(m.advance(2.0));
  EXPECT_EQ(m.samples(), (std::vector<double>{10, 10, 20, 20, 30}));  // t = 0, .5, 1, 1.5, 2
  m.set(2.25, 40);
  m.set(2.5, 50);                      // same time as sample 5: it sees 50, 40 never sampled
  EXPECT_EQ(m.samples().size(), 5u);   // sample 2.5 not yet due (set() records only t_k < t)
  m.advance(2.5);
  EXPECT_EQ(m.samples(), (std::vector<double>{10, 10, 20, 20, 30, 50}));
  m.advance(3.4);  // t_6 = 3.0 <= 3.4 < t_7
  EXPECT_EQ(m.samples().size(), 7u);
  EXPECT_EQ(m.samples().back(), 50);
}

TEST(SteadyStateMonitor, SampleTimesAreExactMultiples) {
  // dt = 0.1: summing 0.1 a hundred times gives 9.99999999999998, but
  // 100 * 0.1 rounds to exactly 10.0, so advance(10.0) takes the sample k = 100.
  double sum = 0.0;
  for (int i = 0; i < 100; ++i) sum += 0.1;
  ASSERT_NE(sum, 10.0);
  ASSERT_EQ(100 * 0.1, 10.0);
  SteadyStateMonitor m(0.1, 1000, 1, 1);
  m.set(0.0, 1.0);
  m.advance(10.0);
  EXPECT_EQ(m.samples().size(), 101u);
}

TEST(SteadyStateMonitor, InitialValueAndAdvanceBeforeSet) {
  SteadyStateMonitor m(1.0, 1000, 1, 1);
  EXPECT_FALSE(m.advance(2.0));  // no value yet: nothing recorded
  EXPECT_TRUE(m.samples().empty());
  m.set(2.5, 7);                 // first value also covers t_0 .. t_2
  m.set(4.0, 8);
  m.advance(4.0);
  EXPECT_EQ(m.samples(), (std::vector<double>{7, 7, 7, 7, 8}));
}

TEST(SteadyStateMonitor, CheckCadenceAndMinSamples) {
  // Ramp y_k = k (never steady). min_samples 10, every 5: checks at sample
  // counts 10, 15, 20, 25, 30.
  SteadyStateMonitor m(1.0, 10, 5, 1);
  for (int t = 0; t < 30; ++t) {
    m.set(t, t);
    EXPECT_FALSE(m.advance(t));
    const std::size_t c = static_cast<std::size_t>(t) + 1;  // samples so far
    const std::size_t expected = c < 10 ? 0 : (c - 10) / 5 + 1;
    EXPECT_EQ(m.checks(), expected) << "after " << c << " samples";
    if (c < 10) {
      EXPECT_TRUE(std::isnan(m.steady_time()));
    } else {
      EXPECT_EQ(m.steady_time(), static_cast<double>(10 + 5 * (expected - 1) - 1));  // last sample of the last check
    }
  }
  // Last check at 30 samples of a line: d* = k - 2 = 28.
  EXPECT_EQ(m.result().truncation, 28u);
  EXPECT_EQ(m.result().batches, 30u);
  EXPECT_FALSE(m.result().steady);

  // The same observable announced all at once, one advance: identical checks.
  SteadyStateMonitor once(1.0, 10, 5, 1);
  for (int t = 0; t < 30; ++t) once.set(t, t);
  once.advance(29.0);
  EXPECT_EQ(once.samples(), m.samples());
  EXPECT_EQ(once.checks(), 5u);
  EXPECT_EQ(once.result().truncation, 28u);
}

TEST(SteadyStateMonitor, ConstantSeriesIsSteadyAtTheFirstCheckAndLatches) {
  SteadyStateMonitor m(1.0, 25, 3, 5);
  m.set(0.0, 7.0);
  EXPECT_FALSE(m.advance(23.0));  // 24 samples: below min_samples, no check
  EXPECT_EQ(m.checks(), 0u);
  EXPECT_TRUE(m.advance(24.0));   // 25 samples = 5 identical batch means: d* = 0
  EXPECT_EQ(m.checks(), 1u);
  EXPECT_EQ(m.steady_time(), 24.0);
  EXPECT_EQ(m.result().truncation, 0u);
  EXPECT_EQ(m.result().batches, 5u);
  EXPECT_TRUE(m.advance(100.0));  // latched: nothing more recorded
  EXPECT_EQ(m.samples().size(), 25u);
  EXPECT_EQ(m.checks(), 1u);
}

TEST(SteadyStateMonitor, DecayDeclaredSteadyWhenTheCutReachesTheFirstHalf) {
  // N drops by 2 at t = k - 1/2 (k = 1..50) from 100 to 0, so sample k is
  // max(0, 100 - 2k). dt = 1, MSER-5, min_samples 30, checks every 10.
  // Batches j = 0..9 are on the line (means 96 - 10 j), batches 10.. are 0.
  //   c = 30, 40, 50: a pure line, k = 6, 8, 10: d* = k - 2 and 2 (k-2) > k;
  //   c = 60, 70, 80, 90: k = 12, 14, 16, 18 and d* = 10 (the first all-zero
  //   batch; every d < 10 keeps a nonzero batch, SS > 0): 2 d* = 20 > k;
  //   c = 100: k = 20, d* = 10, 20 <= 20: steady; truncation 50, t = 99.
  SteadyStateMonitor m(1.0, 30, 10, 5);
  m.set(0.0, 100.0);
  double steady_at = -1.0;
  for (int i = 1; i <= 200 && steady_at < 0; ++i) {
    const double t = i - 0.5;
    m.set(t, std::max(0.0, 100.0 - 2.0 * i));
    if (m.advance(t)) steady_at = t;
  }
  EXPECT_TRUE(m.steady());
  EXPECT_EQ(m.steady_time(), 99.0);
  EXPECT_EQ(steady_at, 99.5);  // first advance() that took sample 99
  EXPECT_EQ(m.result().truncation, 50u);
  EXPECT_EQ(m.result().batches, 20u);
  EXPECT_EQ(m.checks(), 8u);  // c = 30, 40, ..., 100
  EXPECT_EQ(m.samples().size(), 100u);
}

TEST(SteadyStateMonitor, RejectsBadSettings) {
  EXPECT_THROW(SteadyStateMonitor(0.0, 10, 1, 1), std::invalid_argument);
  EXPECT_THROW(SteadyStateMonitor(std::nan(""), 10, 1, 1), std::invalid_argument);
  EXPECT_THROW(SteadyStateMonitor(1.0, 10, 0, 1), std::invalid_argument);
  EXPECT_THROW(SteadyStateMonitor(1.0, 10, 1, 0), std::invalid_argument);
  // Fewer than 5 batches: 2 d* <= k holds for every candidate d <= k - 2, the check could not fail.
  EXPECT_THROW(SteadyStateMonitor(1.0, 24, 1, 5), std::invalid_argument);
  EXPECT_NO_THROW(SteadyStateMonitor(1.0, 25, 1, 5));
  EXPECT_THROW(SteadyStateMonitor(1.0, 4, 1, 1), std::invalid_argument);
}

// ---- command line -----------------------------------------------------------

struct CliRun {
  int status;
  std::string out;
  std::string err;
};

class MserCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("ringsim_test_mser_" + std::to_string(getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path) << text;
    return path;
  }
  // Runs `ringsim ARGS` (ARGS may hold a shell redirection); stdout and stderr apart.
  CliRun run(const std::string& args) {
    const std::string err_path = (dir_ / "stderr.txt").string();
    const std::string cmd = std::string(RINGSIM_BINARY) + " " + args + " 2>" + err_path;
    CliRun r{0, "", ""};
    FILE* f = popen(cmd.c_str(), "r");
    std::array<char, 4096> buf;
    while (fgets(buf.data(), buf.size(), f)) r.out += buf.data();
    const int st = pclose(f);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    std::ifstream e(err_path);
    std::stringstream ss;
    ss << e.rdbuf();
    r.err = ss.str();
    return r;
  }
  static std::string series_text(const std::vector<double>& y) {
    std::ostringstream s;
    s.precision(17);
    for (double v : y) s << v << '\n';
    return s.str();
  }
  std::filesystem::path dir_;
};

TEST_F(MserCli, FileGivesTheStepTruncation) {
  // The step of StepIsCutAtTheStep, with comments and blank lines that are skipped.
  const std::string path = write("step.txt", "# N_t series\n\n" + series_text(step_series(0.0)) + "  \n# end\n");
  const CliRun r = run("mser " + path);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_EQ(r.out.back(), '\n');
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["truncation"], 20);
  EXPECT_EQ(j["steady"], true);
  EXPECT_EQ(j["batches"], 20);  // default batch 5
  EXPECT_EQ(j["n"], 100);
  EXPECT_EQ(j["statistic"], 0.0);
  EXPECT_EQ(r.out.rfind("{\"truncation\":", 0), 0u) << r.out;  // the contract fields come first
}

TEST_F(MserCli, StandardInput) {
  const std::string path = write("line.txt", series_text({1, 2, 3, 4, 4}));
  for (const char* args : {"mser --batch 1 < ", "mser --batch 1 - < "}) {
    const CliRun r = run(args + path);
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["truncation"], 3);  // TinyExampleStillRisingIsNotSteady
    EXPECT_EQ(j["steady"], false);
    EXPECT_EQ(j["batches"], 5);
  }
}

TEST_F(MserCli, BadBatch) {
  const std::string path = write("step.txt", series_text(step_series(0.0)));
  for (const char* value : {"0", "-3", "abc", "2.5"}) {
    const CliRun r = run("mser --batch=" + std::string(value) + " " + path);
    EXPECT_EQ(r.status, 1) << value;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(r.err.rfind("ringsim mser: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find("--batch"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(value), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(">= 1"), std::string::npos) << r.err;
  }
}

TEST_F(MserCli, UnparsableLineIsNamed) {
  const std::string path = write("bad.txt", "1\n# comment\n2\n12abc\n3\n");
  const CliRun r = run("mser --batch 1 " + path);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err.rfind("ringsim mser: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(":4:"), std::string::npos) << r.err;  // line 4 of the file
  EXPECT_NE(r.err.find("12abc"), std::string::npos) << r.err;
  const CliRun n = run("mser --batch 1 < " + write("nan.txt", "1\n2\nnan\n"));
  EXPECT_EQ(n.status, 1);
  EXPECT_NE(n.err.find("<stdin>:3:"), std::string::npos) << n.err;
  // Out of double's range: an overflow is no finite number, an underflow is
  // one (it rounds to 0; it was once rejected as "not finite").
  const CliRun big = run("mser --batch 1 < " + write("big.txt", "1\n2\n1e400\n"));
  EXPECT_EQ(big.status, 1);
  EXPECT_NE(big.err.find("<stdin>:3:"), std::string::npos) << big.err;
  const CliRun tiny = run("mser --batch 1 < " + write("tiny.txt", "1\n2\n1e-400\n3\n"));
  EXPECT_EQ(tiny.status, 0) << tiny.err;
  EXPECT_EQ(nlohmann::json::parse(tiny.out)["n"], 4);
}

TEST_F(MserCli, OneSignOnly) {
  // A leading '+' is allowed ("+5" is 5), but "+-5" is not a number (it was
  // once read as -5: the '+' was stripped before parsing the rest).
  const CliRun plus = run("mser --batch 1 " + write("plus.txt", "+5\n+.5\n1\n"));
  EXPECT_EQ(plus.status, 0) << plus.err;
  EXPECT_EQ(nlohmann::json::parse(plus.out)["n"], 3);
  for (const char* bad : {"+-5", "-+5", "++5", "+ 5"}) {
    const CliRun r = run("mser --batch 1 " + write("signs.txt", "1\n" + std::string(bad) + "\n2\n3\n"));
    EXPECT_EQ(r.status, 1) << bad << ": " << r.out;
    EXPECT_NE(r.err.find(":2:"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(bad), std::string::npos) << r.err;
  }
}

TEST_F(MserCli, TooShortAndMissingFile) {
  const CliRun r = run("mser " + write("short.txt", series_text({1, 2, 3, 4, 5, 6, 7, 8, 9})));
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err.rfind("ringsim mser: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("too short"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("at least 2 batches"), std::string::npos) << r.err;
  const CliRun ok = run("mser " + write("ten.txt", series_text({1, 2, 3, 4, 5, 6, 7, 8, 9, 10})));
  EXPECT_EQ(ok.status, 0) << ok.err;
  const CliRun missing = run("mser " + (dir_ / "does_not_exist.txt").string());
  EXPECT_EQ(missing.status, 1);
  EXPECT_NE(missing.err.find("cannot open"), std::string::npos) << missing.err;
}

TEST_F(MserCli, HelpHasAnExample) {
  const CliRun r = run("mser --help");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("--batch"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Examples:"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace ringsim
