#include "analysis/ensemble_summary.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <utility>

#include "analysis/statistics.hpp"

namespace ringsim {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The summarized observables, in row order, with how to read each from a record.
struct Field {
  const char* name;
  double (*get)(const ReplicateRecord&);
};
constexpr Field kFields[] = {
    {"N_t", [](const ReplicateRecord& r) { return double(r.N_t); }},
    {"N_tar", [](const ReplicateRecord& r) { return double(r.N_tar); }},
    {"N_viab", [](const ReplicateRecord& r) { return double(r.N_viab); }},
    {"N_nv1", [](const ReplicateRecord& r) { return double(r.N_nv1); }},
    {"N_nv2", [](const ReplicateRecord& r) { return double(r.N_nv2); }},
    {"N_nv3", [](const ReplicateRecord& r) { return double(r.N_nv3); }},
    {"N_cyc", [](const ReplicateRecord& r) { return double(r.N_cyc); }},
    {"Phi_obj", [](const ReplicateRecord& r) { return r.Phi_obj; }},
    {"Phi_viab", [](const ReplicateRecord& r) { return r.Phi_viab; }},
    {"S4", [](const ReplicateRecord& r) { return r.S4; }},
    {"M_mono", [](const ReplicateRecord& r) { return r.M_mono; }},
    {"M_mono_S", [](const ReplicateRecord& r) { return r.M_mono_S; }},
    {"M_mono_L", [](const ReplicateRecord& r) { return r.M_mono_L; }},
    {"tau_tar", [](const ReplicateRecord& r) { return r.tau_tar; }},
    {"t_end", [](const ReplicateRecord& r) { return r.t_end; }},
    {"events", [](const ReplicateRecord& r) { return double(r.events); }},
    {"wall_seconds", [](const ReplicateRecord& r) { return r.wall_seconds; }},
};

}  // namespace

// Kaplan-Meier product-limit estimator (Kaplan & Meier, J. Am. Stat. Assoc.
// 53, 457-481, 1958):
//     S(t) = prod_{t_i <= t} (1 - d_i / n_i),
// t_i the distinct event (uncensored) times, d_i the events at t_i, n_i the
// subjects still at risk just before t_i (time >= t_i). Ties: an event and a
// censoring at the same time count the censored subject as still at risk at
// t_i (events before censorings, Kaplan & Meier's convention). The median is
// the smallest t_i with S(t_i) <= 0.5; NaN if S never gets there (more than
// half censored before enough events, or no subjects). The comparison allows
// 1e-12 of rounding so that an exact 0.5 (e.g. 3/4 * 2/3) counts as reached.
double kaplan_meier_median(const std::vector<double>& times, const std::vector<int>& censored) {
  if (times.size() != censored.size())
    throw std::invalid_argument("kaplan_meier_median: " + std::to_string(times.size()) + " times but " +
                                std::to_string(censored.size()) + " censoring flags");
  std::vector<std::pair<double, bool>> obs;  // (time, is_event)
  obs.reserve(times.size());
  for (std::size_t i = 0; i < times.size(); ++i)
    if (!std::isnan(times[i])) obs.emplace_back(times[i], censored[i] == 0);
  std::sort(obs.begin(), obs.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  double S = 1.0;
  std::size_t i = 0;
  while (i < obs.size()) {  // one group of equal times per pass
    const double t = obs[i].first;
    const double at_risk = double(obs.size() - i);  // time >= t: censorings at t included
    std::size_t j = i;
    int d = 0;
    for (; j < obs.size() && obs[j].first == t; ++j) d += obs[j].second ? 1 : 0;
    if (d > 0) {
      S *= (at_risk - d) / at_risk;
      if (S <= 0.5 + 1e-12) return t;
    }
    i = j;
  }
  return kNaN;
}

// Ratio estimator R = sum y_i / sum x_i and its first-order (delta-method,
// Taylor-linearized) variance estimate, Cochran, "Sampling Techniques", 3rd
// ed. (Wiley 1977), ch. 6, with no finite-population correction (replicates
// are draws from an infinite population):
//     v(R) = 1 / (n xbar^2) * sum_i (y_i - R x_i)^2 / (n - 1),
// xbar = sum x_i / n. Half-width t_{0.975, n-1} * sqrt(v(R)), as for means.
RatioEstimate ratio_of_sums(const std::vector<double>& y, const std::vector<double>& x) {
  if (y.size() != x.size())
    throw std::invalid_argument("ratio_of_sums: " + std::to_string(y.size()) + " numerators but " +
                                std::to_string(x.size()) + " denominators");
  const std::size_t n = x.size();
  const double sx = std::accumulate(x.begin(), x.end(), 0.0);
  const double sy = std::accumulate(y.begin(), y.end(), 0.0);
  if (sx == 0.0) return {kNaN, kNaN};
  RatioEstimate est{sy / sx, kNaN};
  if (n < 2) return est;
  double ss = 0.0;
  for (std::size_t i = 0; i < n; ++i) ss += (y[i] - est.ratio * x[i]) * (y[i] - est.ratio * x[i]);
  const double xbar = sx / double(n);
  const double var = ss / double(n - 1) / (double(n) * xbar * xbar);
  est.ci95 = student_t_quantile(0.95, int(n) - 1) * std::sqrt(var);
  return est;
}

EnsembleSummary summarize_ensemble(const std::vector<ReplicateRecord>& records) {
  EnsembleSummary out;
  out.n_total = int(records.size());
  std::vector<const ReplicateRecord*> ok;
  for (const ReplicateRecord& r : records) {
    switch (static_cast<RecordStatus>(r.status)) {
      case RecordStatus::Ok: ++out.n_ok; ok.push_back(&r); break;
      case RecordStatus::Failed: ++out.n_failed; break;
      case RecordStatus::Pending: ++out.n_pending; break;
      default:
        throw std::invalid_argument("replicate " + std::to_string(r.id) + ": status = " +
                                    std::to_string(int(r.status)) +
                                    "; valid values: 0 (pending), 1 (ok), 2 (failed)");
    }
  }

  std::vector<double> values(ok.size());
  for (const Field& f : kFields) {
    std::transform(ok.begin(), ok.end(), values.begin(), [&](const ReplicateRecord* r) { return f.get(*r); });
    const Summary s = summarize(values);
    out.rows.push_back({f.name, s.mean, s.ci95, s.std, s.n, s.n_undefined, 0});
  }

  std::vector<double> n4(ok.size()), ncyc(ok.size()), tau(ok.size());
  std::vector<int> cens(ok.size());
  for (std::size_t i = 0; i < ok.size(); ++i) {
    n4[i] = ok[i]->ring[1];  // ring[m - 3]: N_4
    ncyc[i] = ok[i]->N_cyc;
    tau[i] = ok[i]->tau_tar;
    cens[i] = ok[i]->tau_tar_censored != 0;
  }
  const RatioEstimate s4 = ratio_of_sums(n4, ncyc);
  out.S4_pooled = s4.ratio;
  out.S4_pooled_ci95 = s4.ci95;
  out.tau_tar_km_median = kaplan_meier_median(tau, cens);
  for (ObservableSummary& row : out.rows)
    if (row.name == "tau_tar") row.n_censored = int(std::count(cens.begin(), cens.end(), 1));
  return out;
}

const ObservableSummary* find(const EnsembleSummary& summary, const std::string& name) {
  for (const ObservableSummary& row : summary.rows)
    if (row.name == name) return &row;
  return nullptr;
}

}  // namespace ringsim
