// Ensemble summary and Table 5 output against hand-computed values.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis/ensemble_summary.hpp"
#include "analysis/table5.hpp"

namespace ringsim {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kT3 = 3.1824463;  // t_{0.975, 3} (tables)

ReplicateRecord record(RecordStatus status, int N_t) {
  ReplicateRecord r;
  r.status = static_cast<std::int8_t>(status);
  r.N_t = N_t;
  r.t_end = 100.0;
  r.tau_tar = 100.0;
  r.tau_tar_censored = 1;
  r.S4 = kNaN;  // N_cyc = 0
  return r;
}

// A ring census: n4 squares among ncyc rings (the rest hexagons).
ReplicateRecord with_rings(ReplicateRecord r, int n4, int ncyc) {
  r.ring[1] = n4;
  r.ring[3] = ncyc - n4;
  r.N_cyc = ncyc;
  r.S4 = ncyc > 0 ? double(n4) / ncyc : kNaN;
  return r;
}

ReplicateRecord with_tau(ReplicateRecord r, double tau, bool censored) {
  r.tau_tar = tau;
  r.tau_tar_censored = censored ? 1 : 0;
  return r;
}

// Four Ok replicates N_t = 10, 12, 14, 16 with rings (N_4, N_cyc) = (2, 4),
// (1, 1), (0, 0), (3, 5); plus one Failed and one Pending that must not count.
std::vector<ReplicateRecord> four_ok_records() {
  std::vector<ReplicateRecord> v{
      with_rings(with_tau(record(RecordStatus::Ok, 10), 20.0, false), 2, 4),
      with_rings(with_tau(record(RecordStatus::Ok, 12), 40.0, false), 1, 1),
      with_rings(record(RecordStatus::Ok, 14), 0, 0),
      with_rings(record(RecordStatus::Ok, 16), 3, 5),
      with_rings(record(RecordStatus::Failed, 1000), 50, 50),
      record(RecordStatus::Pending, 0),
  };
  for (auto& r : v) r.Phi_obj = 0.01 * r.N_t;  // 0.10 .. 0.16 on the Ok ones
  return v;
}

TEST(EnsembleSummary, RowsInFixedOrder) {
  const EnsembleSummary s = summarize_ensemble(four_ok_records());
  const std::vector<std::string> names{"N_t",    "N_tar",    "N_viab",   "N_nv1",   "N_nv2", "N_nv3",
                                       "N_cyc",  "Phi_obj",  "Phi_viab", "S4",      "M_mono", "M_mono_S",
                                       "M_mono_L", "tau_tar", "t_end",   "events",  "wall_seconds"};
  ASSERT_EQ(s.rows.size(), names.size());
  for (std::size_t i = 0; i < names.size(); ++i) EXPECT_EQ(s.rows[i].name, names[i]);
  EXPECT_EQ(find(s, "S4"), &s.rows[9]);
  EXPECT_EQ(find(s, "N_4"), nullptr);
}

TEST(EnsembleSummary, MeanAndCiOverOkOnlyFailedAndPendingCounted) {
  const EnsembleSummary s = summarize_ensemble(four_ok_records());
  EXPECT_EQ(s.n_total, 6);
  EXPECT_EQ(s.n_ok, 4);
  EXPECT_EQ(s.n_failed, 1);
  EXPECT_EQ(s.n_pending, 1);
  // N_t = 10, 12, 14, 16: mean 13, sample variance (9 + 1 + 1 + 9) / 3 = 20/3,
  // half-width t_{0.975,3} * sqrt(20/3) / sqrt(4) = 4.1085...
  const ObservableSummary* nt = find(s, "N_t");
  ASSERT_NE(nt, nullptr);
  EXPECT_EQ(nt->n, 4);
  EXPECT_EQ(nt->n_undefined, 0);
  EXPECT_EQ(nt->n_censored, 0);
  EXPECT_DOUBLE_EQ(nt->mean, 13.0);
  EXPECT_NEAR(nt->std, std::sqrt(20.0 / 3.0), 1e-14);
  EXPECT_NEAR(nt->ci95, kT3 * std::sqrt(20.0 / 3.0) / 2.0, 1e-6);
  // Phi_obj = N_t / 100: the same statistics scaled.
  EXPECT_NEAR(find(s, "Phi_obj")->mean, 0.13, 1e-15);
  EXPECT_NEAR(find(s, "Phi_obj")->ci95, 0.01 * kT3 * std::sqrt(20.0 / 3.0) / 2.0, 1e-8);
}

TEST(EnsembleSummary, TauTarMeanIncludesCensoredAtTEnd) {
  // tau_tar = 20, 40 (events), 100, 100 (censored at t_end): mean 65.
  const EnsembleSummary s = summarize_ensemble(four_ok_records());
  const ObservableSummary* tau = find(s, "tau_tar");
  EXPECT_EQ(tau->n, 4);
  EXPECT_EQ(tau->n_censored, 2);
  EXPECT_DOUBLE_EQ(tau->mean, 65.0);
  for (const ObservableSummary& row : s.rows)
    if (row.name != "tau_tar") EXPECT_EQ(row.n_censored, 0) << row.name;
  // KM: S(20) = 3/4, S(40) = 3/4 * 2/3 = 1/2 -> median 40.
  EXPECT_DOUBLE_EQ(s.tau_tar_km_median, 40.0);
}

TEST(EnsembleSummary, S4AllUndefined) {
  const std::vector<ReplicateRecord> v(3, record(RecordStatus::Ok, 5));
  const EnsembleSummary s = summarize_ensemble(v);
  const ObservableSummary* s4 = find(s, "S4");
  EXPECT_TRUE(std::isnan(s4->mean));
  EXPECT_TRUE(std::isnan(s4->ci95));
  EXPECT_EQ(s4->n, 0);
  EXPECT_EQ(s4->n_undefined, 3);
  EXPECT_TRUE(std::isnan(s.S4_pooled));
  EXPECT_TRUE(std::isnan(s.S4_pooled_ci95));
}

TEST(EnsembleSummary, PooledS4AndDeltaMethodCi) {
  const EnsembleSummary s = summarize_ensemble(four_ok_records());
  // Mean of the defined ratios: (2/4 + 1/1 + 3/5) / 3 = 0.7, one undefined.
  const ObservableSummary* s4 = find(s, "S4");
  EXPECT_EQ(s4->n, 3);
  EXPECT_EQ(s4->n_undefined, 1);
  EXPECT_NEAR(s4->mean, 0.7, 1e-15);
  // Ratio of sums over the 4 Ok replicates (the Failed one's 50/50 excluded):
  // R = (2 + 1 + 0 + 3) / (4 + 1 + 0 + 5) = 0.6.
  EXPECT_NEAR(s.S4_pooled, 0.6, 1e-15);
  // Residuals y - R x: 2 - 2.4, 1 - 0.6, 0 - 0, 3 - 3 = -0.4, 0.4, 0, 0.
  // v(R) = [(0.16 + 0.16) / (4 - 1)] / (4 * 2.5^2) = 0.0042666...
  const double v = (0.16 + 0.16) / 3.0 / (4.0 * 2.5 * 2.5);
  EXPECT_NEAR(s.S4_pooled_ci95, kT3 * std::sqrt(v), 1e-6);
  EXPECT_NEAR(s.S4_pooled_ci95, 0.2078760, 1e-6);
}

TEST(EnsembleSummary, KaplanMeierTextbookWithCensoringAndTies) {
  // Times 1, 1, 1.5+, 1.5+, 2, 2+, 3, 4+ (+ = censored).
  //   t = 1: n = 8, d = 2  ->  S = 6/8 = 0.75
  //   t = 2: n = 4 (2, 2+, 3, 4+: the censoring at 2 is still at risk), d = 1
  //          ->  S = 0.75 * 3/4 = 0.5625
  //   t = 3: n = 2, d = 1  ->  S = 0.28125 <= 0.5: median 3.
  // Censorings before events at t = 2 would give n = 3, S = 0.5, median 2;
  // ignoring censoring, the median of the event times would be 1.5.
  const std::vector<double> t{3, 1, 2, 1.5, 4, 1, 2, 1.5};
  const std::vector<int> c{0, 0, 1, 1, 1, 0, 0, 1};
  EXPECT_DOUBLE_EQ(kaplan_meier_median(t, c), 3.0);

  std::vector<ReplicateRecord> v;
  for (std::size_t i = 0; i < t.size(); ++i) v.push_back(with_tau(record(RecordStatus::Ok, 1), t[i], c[i] != 0));
  v.push_back(with_tau(record(RecordStatus::Failed, 1), 0.5, false));  // not an Ok replicate: ignored
  EXPECT_DOUBLE_EQ(summarize_ensemble(v).tau_tar_km_median, 3.0);
}

TEST(EnsembleSummary, KaplanMeierMedianNotReached) {
  // 1, 2+, 3+, 4+: S = 3/4 after t = 1, then only censorings.
  EXPECT_TRUE(std::isnan(kaplan_meier_median({1, 2, 3, 4}, {0, 1, 1, 1})));
  EXPECT_TRUE(std::isnan(kaplan_meier_median({5, 5}, {1, 1})));
  EXPECT_TRUE(std::isnan(kaplan_meier_median({}, {})));
  EXPECT_TRUE(std::isnan(summarize_ensemble({}).tau_tar_km_median));
  // Exactly one half is reached: 1, 2, 3+, 4+ gives S(2) = 3/4 * 2/3 = 0.5.
  EXPECT_DOUBLE_EQ(kaplan_meier_median({1, 2, 3, 4}, {0, 0, 1, 1}), 2.0);
}

TEST(EnsembleSummary, UnknownStatusIsAnError) {
  ReplicateRecord r = record(RecordStatus::Ok, 1);
  r.id = 7;
  r.status = 5;
  try {
    summarize_ensemble({r});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("replicate 7: status = 5"), std::string::npos) << e.what();
  }
}

// Scenario "A": the four Ok records; "B": three replicates without rings (S4
// undefined); "C": one replicate (no CI).
std::vector<ScenarioResult> three_scenarios() {
  return {{"A", "bonding.dtheta_deg=2", summarize_ensemble(four_ok_records())},
          {"B", "", summarize_ensemble(std::vector<ReplicateRecord>(3, record(RecordStatus::Ok, 5)))},
          {"C", "", summarize_ensemble({with_tau(record(RecordStatus::Ok, 9), 30.0, false)})}};
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> split(const std::string& line, char sep) {
  std::vector<std::string> f;
  std::string cur;
  for (char ch : line) {
    if (ch == sep) {
      f.push_back(cur);
      cur.clear();
    } else {
      cur += ch;
    }
  }
  f.push_back(cur);
  return f;
}

TEST(Table5, MarkdownHeaderAndOneRowPerScenario) {
  std::ostringstream out;
  print_table5(out, three_scenarios(), TableFormat::Markdown);
  const auto lines = lines_of(out.str());
  ASSERT_EQ(lines.size(), 2u + 3u);
  for (const char* h : {"| scenario | sweep | N_t | tau_tar | Phi_obj (%) | S4 (%) | Phi_viab (%) | M_mono (%) |",
                        "| n | failed | S4 undefined | tau_tar censored | tau_tar KM median | S4 pooled (%) |"})
    EXPECT_NE(lines[0].find(h), std::string::npos) << lines[0];
  EXPECT_EQ(lines[1].rfind("|:---|:---|---:|", 0), 0u) << lines[1];
  const std::size_t n_cols = split(lines[0], '|').size();
  for (std::size_t i = 2; i < lines.size(); ++i) EXPECT_EQ(split(lines[i], '|').size(), n_cols) << lines[i];
  // A: N_t 13.0 ± 4.1, Phi_obj in percent 13.00 ± 4.11, pooled S4 60.00 ± 20.79.
  // tau_tar with 2 of 4 censored (counted at t_end): a lower bound.
  EXPECT_EQ(lines[2].rfind("| A | bonding.dtheta_deg=2 | 13.0 ± 4.1 | ≥ 65.0 ± ", 0), 0u) << lines[2];
  EXPECT_NE(lines[2].find("| 13.00 ± 4.11 | 70.00 ± "), std::string::npos) << lines[2];
  EXPECT_NE(lines[2].find("| 4 | 1 | 1 | 2 | 40.0 | 60.00 ± 20.79 |"), std::string::npos) << lines[2];
}

TEST(Table5, TextShowsUndefinedAndNa) {
  std::ostringstream out;
  print_table5(out, three_scenarios(), TableFormat::Table);
  const auto lines = lines_of(out.str());
  ASSERT_EQ(lines.size(), 2u + 3u);
  EXPECT_EQ(lines[0].rfind("scenario  sweep", 0), 0u) << lines[0];
  EXPECT_NE(lines[0].find("Phi_obj (%)"), std::string::npos);
  // B: no rings -> S4 and pooled S4 undefined (never 0); all censored -> KM not reached.
  EXPECT_NE(lines[3].find("undefined"), std::string::npos) << lines[3];
  EXPECT_NE(lines[3].find("not reached"), std::string::npos) << lines[3];
  // ... and its tau_tar mean is the mean t_end, shown as the bound it is.
  EXPECT_NE(lines[3].find("(all censored)"), std::string::npos) << lines[3];
  // C: one replicate -> no CI.
  EXPECT_NE(lines[4].find("9.0 ± n/a"), std::string::npos) << lines[4];
  // Right-aligned columns end together (widths in code points: "±" is 2 bytes).
  auto width = [](const std::string& s) {
    std::size_t w = 0;
    for (char ch : s) w += (ch & 0xC0) != 0x80;
    return w;
  };
  for (std::size_t i = 1; i < lines.size(); ++i) EXPECT_EQ(width(lines[i]), width(lines[1])) << lines[i];
}

TEST(Table5, CsvParsesBackToSameNumbers) {
  const auto scenarios = three_scenarios();
  std::ostringstream out;
  print_table5(out, scenarios, TableFormat::Csv);
  const auto lines = lines_of(out.str());
  ASSERT_EQ(lines.size(), 1u + 3u);
  const auto header = split(lines[0], ',');
  for (std::size_t k = 0; k < scenarios.size(); ++k) {
    const auto fields = split(lines[k + 1], ',');
    ASSERT_EQ(fields.size(), header.size());
    std::map<std::string, std::string> f;
    for (std::size_t i = 0; i < header.size(); ++i) f[header[i]] = fields[i];
    const EnsembleSummary& s = scenarios[k].summary;
    // Exact round trip; NaN is an empty field.
    auto check = [&](const std::string& column, double expected) {
      ASSERT_EQ(f.count(column), 1u) << column;
      if (std::isnan(expected)) {
        EXPECT_EQ(f[column], "") << column;
      } else {
        EXPECT_EQ(std::strtod(f[column].c_str(), nullptr), expected) << column << " = " << f[column];
      }
    };
    EXPECT_EQ(f["scenario"], scenarios[k].label);
    EXPECT_EQ(f["sweep"], scenarios[k].sweep);
    for (const char* name : {"N_t", "tau_tar", "Phi_obj", "S4", "Phi_viab", "M_mono"}) {
      check(std::string(name) + "_mean", find(s, name)->mean);
      check(std::string(name) + "_ci95", find(s, name)->ci95);
    }
    check("S4_pooled", s.S4_pooled);
    check("S4_pooled_ci95", s.S4_pooled_ci95);
    check("tau_tar_km_median", s.tau_tar_km_median);
    EXPECT_EQ(f["n_ok"], std::to_string(s.n_ok));
    EXPECT_EQ(f["n_failed"], std::to_string(s.n_failed));
    EXPECT_EQ(f["n_pending"], std::to_string(s.n_pending));
    EXPECT_EQ(f["S4_n_undefined"], std::to_string(find(s, "S4")->n_undefined));
    EXPECT_EQ(f["tau_tar_n_censored"], std::to_string(find(s, "tau_tar")->n_censored));
  }
  // Fractions, not percent.
  EXPECT_NEAR(std::strtod(split(lines[1], ',')[6].c_str(), nullptr), 0.13, 1e-15);

  // A label with a comma and a quote is quoted (RFC 4180).
  std::ostringstream quoted;
  print_table5(quoted, {{"6-1, \"low\"", "", EnsembleSummary{}}}, TableFormat::Csv);
  EXPECT_EQ(lines_of(quoted.str())[1].rfind("\"6-1, \"\"low\"\"\",,", 0), 0u) << quoted.str();
}

TEST(Table5, JsonHasEveryRowAndNullForUndefined) {
  const auto scenarios = three_scenarios();
  std::ostringstream out;
  print_table5(out, scenarios, TableFormat::Json);
  const nlohmann::json j = nlohmann::json::parse(out.str());
  ASSERT_TRUE(j.is_array());
  ASSERT_EQ(j.size(), 3u);
  const nlohmann::json& a = j[0];
  EXPECT_EQ(a["scenario"], "A");
  EXPECT_EQ(a["sweep"], "bonding.dtheta_deg=2");
  EXPECT_EQ(a["n_total"], 6);
  EXPECT_EQ(a["n_ok"], 4);
  EXPECT_EQ(a["n_failed"], 1);
  EXPECT_EQ(a["n_pending"], 1);
  EXPECT_EQ(a["observables"].size(), scenarios[0].summary.rows.size());
  EXPECT_EQ(a["observables"]["N_t"]["mean"].get<double>(), 13.0);
  EXPECT_EQ(a["observables"]["N_t"]["n"], 4);
  EXPECT_EQ(a["observables"]["tau_tar"]["n_censored"], 2);
  EXPECT_EQ(a["observables"]["S4"]["n_undefined"], 1);
  EXPECT_EQ(a["S4_pooled"].get<double>(), scenarios[0].summary.S4_pooled);
  EXPECT_EQ(a["tau_tar_km_median"].get<double>(), 40.0);
  const nlohmann::json& b = j[1];
  EXPECT_TRUE(b["observables"]["S4"]["mean"].is_null());
  EXPECT_TRUE(b["observables"]["S4"]["ci95"].is_null());
  EXPECT_EQ(b["observables"]["S4"]["n_undefined"], 3);
  EXPECT_TRUE(b["S4_pooled"].is_null());
  EXPECT_TRUE(b["S4_pooled_ci95"].is_null());
  EXPECT_TRUE(b["tau_tar_km_median"].is_null());
  EXPECT_TRUE(j[2]["observables"]["N_t"]["ci95"].is_null());
  EXPECT_EQ(j[2]["observables"]["N_t"]["mean"].get<double>(), 9.0);
}

TEST(Table5, ParseTableFormat) {
  EXPECT_EQ(parse_table_format("table"), TableFormat::Table);
  EXPECT_EQ(parse_table_format("markdown"), TableFormat::Markdown);
  EXPECT_EQ(parse_table_format("csv"), TableFormat::Csv);
  EXPECT_EQ(parse_table_format("json"), TableFormat::Json);
  try {
    parse_table_format("xlsx");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("\"xlsx\""), std::string::npos) << what;
    EXPECT_NE(what.find("table, markdown, csv, json"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace ringsim
