#pragma once
// Summary statistics over replicates: mean with a Student-t 95 % confidence
// half-width. Non-finite values (undefined metrics) are skipped and counted.

#include <vector>

namespace ringsim {

struct Summary {
  double mean = 0.0;
  double std = 0.0;    // sample standard deviation (n - 1)
  double ci95 = 0.0;   // half-width t_{0.975, n-1} * std / sqrt(n); NaN when n < 2
  int n = 0;           // finite values used
  int n_undefined = 0; // NaN values skipped
};

Summary summarize(const std::vector<double>& values);

// Two-sided Student-t quantile t_{1 - (1-level)/2, dof}.
double student_t_quantile(double level, int dof);

}  // namespace ringsim
