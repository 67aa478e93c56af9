#pragma once
// MSER / MSER-m steady-state detection (marginal standard error rule).
//
// References: K. P. White Jr., "An effective truncation heuristic for bias
// reduction in simulation output", Simulation 69(6), 323-334 (1997);
// MSER-m (batched): White, Cobb & Spratt, Proc. Winter Simulation Conference
// (2000).
//
// Definition used here. Raw observations y_0 .. y_{n-1} (0-based), batch size
// m >= 1. The first k = floor(n / m) batch means
//     x_j = (1/m) * (y_{jm} + ... + y_{jm+m-1}),   j = 0 .. k-1,
// are formed from the start of the series; a trailing remainder of n mod m raw
// observations is DROPPED (it never enters the statistic). For a truncation of
// d batches the retained means are x_d .. x_{k-1} and
//     MSER(d) = (1 / (k-d)^2) * sum_{j=d}^{k-1} (x_j - xbar_d)^2,
// xbar_d their mean (White 1997 with Y = x; m = 1 is plain MSER, m = 5 MSER-5).
//
// The rule, exactly:
//   * candidates d = 0 .. k-2 (at least 2 batches are always retained);
//   * d* = argmin MSER(d); ties (equal floating-point values) go to the
//     smallest d;
//   * truncation (in raw observations) = m * d*: observations
//     y_0 .. y_{m d* - 1} are warm-up, y_{m d*} onwards is steady;
//   * steady  <=>  2 * d* <= k  (the truncation point lies in the first half
//     of the batched series; for odd k this is d* <= (k-1)/2).
// A series still drifting at its end puts d* in the second half (the rule
// then keeps discarding), so it is reported as not steady.
// Caveats (documented in docs/STEADY_STATE.md):
//   * k <= 4: every candidate satisfies 2 d <= k, so "steady" is always true;
//     the rule can only say "not steady" from k = 5 batches on
//     (SteadyStateMonitor requires min_samples >= 5 * batch).
//   * Noisy stationary data: MSER(d) for d near k-2 rests on 2-3 values and
//     undercuts sigma^2/(k-d) when those happen to be close, so one evaluation
//     of an iid series of 1000 lands in the last few batches ("not steady") in
//     about 5 % (m = 1) to 10 % (m = 5) of cases; repeated checks absorb this.
//     An observable constant after its last change (N_t at the end of the
//     bonding) has MSER(d) = 0 exactly for every d past that change, so d* is
//     the first batch after the last change (when at least 2 batches follow
//     it): steady <=> the last change lies in the first half of the series.
//
// Cost O(n), no allocation: the retained-suffix mean and sum of squared
// deviations are updated with Welford's recurrence run backwards from the end
// (numerically stable: no difference of large sums, exact zero for a constant
// suffix).

#include <cstddef>
#include <limits>
#include <vector>

namespace ringsim {

struct MserResult {
  std::size_t truncation = 0;  // m * d*, in raw observations
  bool steady = false;         // 2 * d* <= batches
  std::size_t batches = 0;     // k = floor(n / m)
  double statistic = std::numeric_limits<double>::quiet_NaN();  // MSER(d*), in units of x^2
};

// MSER-`batch` of `y`. Throws std::invalid_argument when batch == 0, when
// y.size() < 2 * batch (fewer than 2 batches) or when an observation is not
// finite (the message names the index). batch = 5 gives MSER-5.
MserResult mser(const std::vector<double>& y, std::size_t batch = 1);

// Steady-state monitor for one replicate.
//
// The observable is piecewise constant (it changes only at events, e.g. N_t
// at bonds) and is sampled at t_k = k * dt, k = 0, 1, 2, ... (t_k computed as
// k * dt, never as a running sum of dt, so sample times are exact multiples).
// Conventions:
//   * set(t, v): the observable equals v on [t, next change). A sample at
//     t_k == t therefore sees the NEW value v; samples at t_k < t see the old one.
//   * The value given by the first set() is also the value before it (the
//     initial value): call set(0, N_0) before the run. advance() before any
//     set() records nothing.
//   * Checks: MSER-`batch` is applied to the whole series y_0 .. y_{c-1} each
//     time the sample count c reaches min_samples, min_samples + check_every,
//     min_samples + 2 check_every, ... . Checks are run at exactly these counts
//     however the calls to set()/advance() are spaced, so the outcome does
//     not depend on how often the caller advances.
//   * At one time t, call set(t, v) before advance(t): advance(t) takes the
//     sample at k * dt == t, and a later set() cannot change a recorded
//     sample (asserted: set() needs t > the time of the last recorded sample).
//   * The first steady check latches: no samples are recorded afterwards,
//     samples() ends with the last sample used, steady_time() = (c-1) * dt.
// Invariants: samples()[k] is the value current at k * dt; t passed to
// set()/advance() is non-decreasing (asserted). No exceptions after
// construction (safe in the event loop).
// Smallest number of batches a monitor check may use: with k <= 4 batches
// every candidate d <= k - 2 satisfies 2 d <= k, so MSER could never answer
// "not steady". A monitor needs min_samples >= kMinMonitorBatches * batch.
inline constexpr std::size_t kMinMonitorBatches = 5;

class SteadyStateMonitor {
 public:
  // Throws std::invalid_argument (naming the parameter, value and valid range)
  // unless sample_interval is finite and > 0, batch >= 1, check_every >= 1 and
  // min_samples >= 5 * batch (with fewer than 5 batches the steady rule cannot
  // fail, see above).
  SteadyStateMonitor(double sample_interval, std::size_t min_samples, std::size_t check_every, std::size_t batch);

  // The observable takes `value` from time t on. Records the samples at
  // k * dt < t with the previous value first (and runs the checks they make due).
  void set(double t, double value);
  // Records the samples at k * dt <= t with the current value, running the
  // checks that become due; returns true once the series is steady.
  bool advance(double t);

  bool steady() const { return steady_; }
  const std::vector<double>& samples() const { return samples_; }
  double sample_interval() const { return dt_; }
  std::size_t checks() const { return checks_; }
  // Time of the last sample used by the most recent check (NaN before the
  // first check); when steady(), the time at which steady state was declared.
  double steady_time() const { return last_check_time_; }
  // Result of the most recent check (default values before the first check).
  const MserResult& result() const { return result_; }

 private:
  // Appends samples k * dt for k = samples_.size(), ... while k * dt < t
  // (inclusive == false) or <= t (inclusive == true), checking when due.
  void record(double t, bool inclusive);
  void check();

  double dt_;
  std::size_t min_samples_;
  std::size_t check_every_;
  std::size_t batch_;
  std::vector<double> samples_;
  double current_ = 0.0;
  bool has_value_ = false;
  bool steady_ = false;
  double last_t_ = -std::numeric_limits<double>::infinity();
  std::size_t checks_ = 0;
  double last_check_time_ = std::numeric_limits<double>::quiet_NaN();
  MserResult result_;
};

}  // namespace ringsim
