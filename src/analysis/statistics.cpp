#include "analysis/statistics.hpp"

#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <limits>

namespace ringsim {

double student_t_quantile(double level, int dof) {
  boost::math::students_t dist(dof);
  return boost::math::quantile(dist, 0.5 + 0.5 * level);
}

Summary summarize(const std::vector<double>& values) {
  Summary s;
  double sum = 0.0;
  for (double v : values) {
    if (std::isfinite(v)) {
      sum += v;
      ++s.n;
    } else {
      ++s.n_undefined;
    }
  }
  if (s.n == 0) {
    s.mean = s.std = s.ci95 = std::numeric_limits<double>::quiet_NaN();
    return s;
  }
  s.mean = sum / s.n;
  double ss = 0.0;
  for (double v : values)
    if (std::isfinite(v)) ss += (v - s.mean) * (v - s.mean);
  if (s.n < 2) {
    s.std = s.ci95 = std::numeric_limits<double>::quiet_NaN();
    return s;
  }
  s.std = std::sqrt(ss / (s.n - 1));
  s.ci95 = student_t_quantile(0.95, s.n - 1) * s.std / std::sqrt(static_cast<double>(s.n));
  return s;
}

}  // namespace ringsim
