#include "analysis/mser.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <stdexcept>
#include <string>

namespace ringsim {
namespace {


// MSER-m of y[0 .. n-1] without input checks; requires m >= 1 and n >= 2 m.
// One backward pass over the k batch means: after adding x_j the running
// (count, mean, m2) describe the retained suffix x_j .. x_{k-1}, i.e. d = j,
// with m2 = sum (x_i - xbar_d)^2 (Welford's update; each increment
// delta * (x - mean_new) is >= 0 because mean_new lies between mean and x).
//
// The pass works on y * 2^-e, e the binary exponent of the largest |y_i| used,
// so every value lies in (-1, 1): batch sums, deviations and their squares can
// neither overflow (data near 1e308) nor underflow to 0 (data near 1e-300,
// which would make every candidate a tie at 0). Scaling by a power of two is
// exact, so for data whose squares stay in the normal range every MSER(d), and
// hence d*, is bit for bit what the unscaled pass gives; the statistic is
// scaled back by 2^(2e) (inf or 0 only when MSER(d*) itself is out of range).
MserResult mser_unchecked(const double* y, std::size_t n, std::size_t m) {
  const std::size_t k = n / m;
  assert(m >= 1 && k >= 2);
  double largest = 0.0;
  for (std::size_t i = 0; i < k * m; ++i) largest = std::max(largest, std::fabs(y[i]));
  int e = 0;
  if (largest > 0.0) std::frexp(largest, &e);  // largest = f * 2^e, f in [0.5, 1)
  double count = 0.0, mean = 0.0, m2 = 0.0;
  double best = std::numeric_limits<double>::infinity();
  std::size_t best_d = 0;
  for (std::size_t j = k; j-- > 0;) {
    double x;
    if (m == 1) {
      x = std::scalbn(y[j], -e);
    } else {
      double s = 0.0;
      for (std::size_t i = j * m; i < (j + 1) * m; ++i) s += std::scalbn(y[i], -e);
      x = s / static_cast<double>(m);
    }
    count += 1.0;
    const double delta = x - mean;
    mean += delta / count;
    m2 += delta * (x - mean);
    if (j + 2 <= k) {  // candidate d = j in [0, k-2]
      const double stat = m2 / (count * count);
      // Descending j with <=: equal values go to the smallest d.
      if (stat <= best) {
        best = stat;
        best_d = j;
      }
    }
  }
  MserResult r;
  r.batches = k;
  r.truncation = m * best_d;
  r.steady = 2 * best_d <= k;
  r.statistic = std::ldexp(best, 2 * e);  // back to squared units of y
  return r;
}

}  // namespace

MserResult mser(const std::vector<double>& y, std::size_t batch) {
  if (batch == 0) throw std::invalid_argument("MSER batch size = 0; valid range: integer >= 1");
  const std::size_t k = y.size() / batch;
  if (k < 2)
    throw std::invalid_argument("series too short for MSER-" + std::to_string(batch) + ": " +
                                std::to_string(y.size()) + " observations give " + std::to_string(k) +
                                " batch(es) of " + std::to_string(batch) + "; at least 2 batches (" +
                                std::to_string(2 * batch) + " observations) are needed");
  for (std::size_t i = 0; i < y.size(); ++i)
    if (!std::isfinite(y[i]))
      throw std::invalid_argument("MSER observation " + std::to_string(i) + " is not finite");
  return mser_unchecked(y.data(), y.size(), batch);
}

SteadyStateMonitor::SteadyStateMonitor(double sample_interval, std::size_t min_samples, std::size_t check_every,
                                       std::size_t batch)
    : dt_(sample_interval), min_samples_(min_samples), check_every_(check_every), batch_(batch) {
  if (!(std::isfinite(sample_interval) && sample_interval > 0.0))
    throw std::invalid_argument("steady-state sample interval = " + std::to_string(sample_interval) +
                                "; valid range: finite, > 0");
  if (batch < 1) throw std::invalid_argument("steady-state MSER batch = 0; valid range: integer >= 1");
  if (check_every < 1) throw std::invalid_argument("steady-state check cadence = 0 samples; valid range: integer >= 1");
  // With k <= 4 batches every candidate d <= k-2 has 2 d <= k: the check could never say "not steady".
  if (min_samples < kMinMonitorBatches * batch)
    throw std::invalid_argument("steady-state minimum samples = " + std::to_string(min_samples) +
                                "; valid range: integer >= 5 x batch = " +
                                std::to_string(kMinMonitorBatches * batch));
}

void SteadyStateMonitor::set(double t, double value) {
  assert(t >= last_t_ && "SteadyStateMonitor: time must be non-decreasing");
  assert(std::isfinite(value));
  assert((samples_.empty() || static_cast<double>(samples_.size() - 1) * dt_ < t || steady_) &&
         "SteadyStateMonitor: set() at or before an already recorded sample; call set() before advance()");
  last_t_ = t;
  if (has_value_) {
    record(t, false);
  } else {
    // The first value is the initial value: advance() recorded nothing before it.
    has_value_ = true;
  }
  current_ = value;
}

bool SteadyStateMonitor::advance(double t) {
  assert(t >= last_t_ && "SteadyStateMonitor: time must be non-decreasing");
  last_t_ = t;
  if (has_value_) record(t, true);
  return steady_;
}

void SteadyStateMonitor::record(double t, bool inclusive) {
  while (!steady_) {
    // Exact sample time k * dt (no accumulated sum of dt).
    const double tk = static_cast<double>(samples_.size()) * dt_;
    if (inclusive ? !(tk <= t) : !(tk < t)) break;
    samples_.push_back(current_);
    const std::size_t c = samples_.size();
    if (c >= min_samples_ && (c - min_samples_) % check_every_ == 0) check();
  }
}

void SteadyStateMonitor::check() {
  result_ = mser_unchecked(samples_.data(), samples_.size(), batch_);
  ++checks_;
  last_check_time_ = static_cast<double>(samples_.size() - 1) * dt_;
  steady_ = result_.steady;
}

}  // namespace ringsim
