#pragma once
// Ensemble summary: the per-observable statistics of one scenario's
// replicates (MODEL.md "Observables", "Protocol"; DESIGN.md "Analysis").
//
// Only records with status Ok enter the statistics; Failed and Pending ones
// are counted. Every observable is a mean with a Student-t 95 % half-width
// (summarize()); undefined values (S4 of a replicate without rings) are NaN,
// skipped and counted in n_undefined, never averaged as 0. tau_tar of a
// censored replicate is its t_end (the study's reading), so its mean is a
// lower bound when n_censored > 0; the Kaplan-Meier median treats those
// values as right-censored instead.

#include <string>
#include <vector>

#include "analysis/replicate_record.hpp"

namespace ringsim {

struct ObservableSummary {
  std::string name;     // the ReplicateRecord field name
  double mean = 0.0;    // NaN when no replicate defines it
  double ci95 = 0.0;    // Student-t half-width; NaN when n < 2
  double std = 0.0;     // sample standard deviation (n - 1); NaN when n < 2
  int n = 0;            // Ok replicates with a finite value
  int n_undefined = 0;  // Ok replicates with a NaN value (S4 without rings)
  int n_censored = 0;   // tau_tar only: Ok replicates censored at t_end
};

struct EnsembleSummary {
  // One row per observable, in this order: N_t, N_tar, N_viab, N_nv1, N_nv2,
  // N_nv3, N_cyc, Phi_obj, Phi_viab, S4, M_mono, M_mono_S, M_mono_L, tau_tar,
  // t_end, events, wall_seconds. Fractions stay fractions (not percent).
  std::vector<ObservableSummary> rows;
  double S4_pooled = 0.0;       // sum N_4 / sum N_cyc over Ok replicates; NaN if sum N_cyc == 0
  double S4_pooled_ci95 = 0.0;  // delta-method half-width (see .cpp); NaN when n_ok < 2 or undefined
  double tau_tar_km_median = 0.0;  // Kaplan-Meier median of tau_tar; NaN when S(t) never reaches 0.5
  int n_total = 0, n_ok = 0, n_failed = 0, n_pending = 0;
};

// Throws std::invalid_argument on a record whose status is not a RecordStatus.
EnsembleSummary summarize_ensemble(const std::vector<ReplicateRecord>& records);

// The row named `name`, or nullptr.
const ObservableSummary* find(const EnsembleSummary& summary, const std::string& name);

// Kaplan-Meier median of right-censored times (censored[i] != 0: times[i] is
// a censoring time). NaN when the survival curve never drops to <= 0.5.
double kaplan_meier_median(const std::vector<double>& times, const std::vector<int>& censored);

// Ratio-of-sums estimate R = sum y / sum x and its 95 % delta-method
// half-width (Cochran 1977, eq. 6.13). Both NaN when sum x == 0; the
// half-width is NaN when fewer than 2 pairs.
struct RatioEstimate {
  double ratio = 0.0;
  double ci95 = 0.0;
};
RatioEstimate ratio_of_sums(const std::vector<double>& y, const std::vector<double>& x);

}  // namespace ringsim
