#include "analysis/table5.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <utility>

namespace ringsim {
namespace {

// The Table 5 observables, in column order. percent: a fraction printed x 100
// in the text formats; decimals: digits after the point in those formats.
struct Metric {
  const char* name;    // ObservableSummary::name
  const char* header;  // text-format column header
  bool percent;
  int decimals;
};
constexpr Metric kMetrics[] = {
    {"N_t", "N_t", false, 1},
    {"tau_tar", "tau_tar", false, 1},
    {"Phi_obj", "Phi_obj (%)", true, 2},
    {"S4", "S4 (%)", true, 2},
    {"Phi_viab", "Phi_viab (%)", true, 2},
    {"M_mono", "M_mono (%)", true, 2},
};
constexpr int kTimeDecimals = 1;  // KM median, like tau_tar

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
const ObservableSummary kMissing{"", kNaN, kNaN, kNaN, 0, 0, 0};  // a row absent from the summary

const ObservableSummary& row_of(const EnsembleSummary& s, const char* name) {
  const ObservableSummary* row = find(s, name);
  return row ? *row : kMissing;
}

// Locale-independent fixed-point text.
std::string fixed(double v, int decimals) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed, decimals);
  return std::string(buf, r.ptr);
}

// Shortest text that reads back to the same double; NaN -> empty (CSV).
std::string shortest(double v) {
  if (std::isnan(v)) return {};
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string mean_pm_ci(double mean, double ci, double scale, int decimals) {
  if (!std::isfinite(mean)) return "undefined";
  return fixed(mean * scale, decimals) + " ± " + (std::isfinite(ci) ? fixed(ci * scale, decimals) : "n/a");
}

bool any_sweep(const std::vector<ScenarioResult>& scenarios) {
  return std::any_of(scenarios.begin(), scenarios.end(), [](const ScenarioResult& s) { return !s.sweep.empty(); });
}

// Header and body cells shared by Table and Markdown. Columns before
// `n_left` are left-aligned text, the others right-aligned numbers.
struct TextTable {
  std::vector<std::vector<std::string>> rows;  // rows[0]: header
  std::size_t n_left = 1;
};

TextTable text_cells(const std::vector<ScenarioResult>& scenarios) {
  TextTable t;
  const bool sweep = any_sweep(scenarios);
  t.n_left = sweep ? 2 : 1;
  std::vector<std::string> header{"scenario"};
  if (sweep) header.push_back("sweep");
  for (const Metric& m : kMetrics) header.push_back(m.header);
  for (const char* h : {"n", "failed", "S4 undefined", "tau_tar censored", "tau_tar KM median", "S4 pooled (%)"})
    header.push_back(h);
  t.rows.push_back(std::move(header));

  for (const ScenarioResult& sc : scenarios) {
    const EnsembleSummary& s = sc.summary;
    std::vector<std::string> cells{sc.label};
    if (sweep) cells.push_back(sc.sweep);
    for (const Metric& m : kMetrics) {
      const ObservableSummary& o = row_of(s, m.name);
      std::string cell = mean_pm_ci(o.mean, o.ci95, m.percent ? 100.0 : 1.0, m.decimals);
      // tau_tar of a replicate without a target counts as its t_end: with
      // any such replicate the mean is a lower bound, and with only such
      // replicates (n_censored = n) it is t_end itself, not a time measured.
      if (o.n_censored > 0 && std::isfinite(o.mean))
        cell = o.n_censored == o.n ? "≥ " + fixed(o.mean, m.decimals) + " (all censored)" : "≥ " + cell;
      cells.push_back(std::move(cell));
    }
    cells.push_back(std::to_string(s.n_ok));
    cells.push_back(std::to_string(s.n_failed));
    cells.push_back(std::to_string(row_of(s, "S4").n_undefined));
    cells.push_back(std::to_string(row_of(s, "tau_tar").n_censored));
    cells.push_back(std::isfinite(s.tau_tar_km_median) ? fixed(s.tau_tar_km_median, kTimeDecimals)
                    : s.n_ok > 0                      ? "not reached"
                                                      : "undefined");
    cells.push_back(mean_pm_ci(s.S4_pooled, s.S4_pooled_ci95, 100.0, 2));
    t.rows.push_back(std::move(cells));
  }
  return t;
}

// Terminal columns of UTF-8 text: code points (UTF-8 continuation bytes
// 10xxxxxx do not start one); the cells hold no wide characters.
std::size_t display_width(const std::string& s) {
  return std::size_t(std::count_if(s.begin(), s.end(), [](char c) { return (c & 0xC0) != 0x80; }));
}

void print_text(std::ostream& out, const TextTable& t) {
  std::vector<std::size_t> width(t.rows[0].size(), 0);
  for (const auto& row : t.rows)
    for (std::size_t c = 0; c < row.size(); ++c) width[c] = std::max(width[c], display_width(row[c]));
  auto print_row = [&](const std::vector<std::string>& row) {
    std::string line;
    for (std::size_t c = 0; c < row.size(); ++c) {
      const std::string pad(width[c] - display_width(row[c]), ' ');
      if (c > 0) line += "  ";
      line += c < t.n_left ? row[c] + pad : pad + row[c];
    }
    line.erase(line.find_last_not_of(' ') + 1);
    out << line << '\n';
  };
  print_row(t.rows[0]);
  std::string rule;
  for (std::size_t c = 0; c < width.size(); ++c) rule += (c > 0 ? "  " : "") + std::string(width[c], '-');
  out << rule << '\n';
  for (std::size_t r = 1; r < t.rows.size(); ++r) print_row(t.rows[r]);
}

std::string markdown_escape(const std::string& s) {
  std::string e;
  for (char c : s) {
    if (c == '|') e += '\\';
    e += c;
  }
  return e;
}

void print_markdown(std::ostream& out, const TextTable& t) {
  auto print_row = [&](const std::vector<std::string>& row) {
    out << '|';
    for (const std::string& cell : row) out << ' ' << markdown_escape(cell) << " |";
    out << '\n';
  };
  print_row(t.rows[0]);
  out << '|';
  for (std::size_t c = 0; c < t.rows[0].size(); ++c) out << (c < t.n_left ? ":---|" : "---:|");
  out << '\n';
  for (std::size_t r = 1; r < t.rows.size(); ++r) print_row(t.rows[r]);
}

// RFC 4180: a field holding a comma, quote or line break is quoted, quotes doubled.
std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + '"';
}

void print_csv(std::ostream& out, const std::vector<ScenarioResult>& scenarios) {
  out << "scenario,sweep";
  for (const Metric& m : kMetrics) out << ',' << m.name << "_mean," << m.name << "_ci95";
  out << ",n_ok,n_failed,n_pending,S4_n_undefined,tau_tar_n_censored,tau_tar_km_median,S4_pooled,S4_pooled_ci95\n";
  for (const ScenarioResult& sc : scenarios) {
    const EnsembleSummary& s = sc.summary;
    out << csv_field(sc.label) << ',' << csv_field(sc.sweep);
    for (const Metric& m : kMetrics) {
      const ObservableSummary& o = row_of(s, m.name);
      out << ',' << shortest(o.mean) << ',' << shortest(o.ci95);
    }
    out << ',' << s.n_ok << ',' << s.n_failed << ',' << s.n_pending << ',' << row_of(s, "S4").n_undefined << ','
        << row_of(s, "tau_tar").n_censored << ',' << shortest(s.tau_tar_km_median) << ','
        << shortest(s.S4_pooled) << ',' << shortest(s.S4_pooled_ci95) << '\n';
  }
}

nlohmann::ordered_json number(double v) {
  return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json(nullptr);
}

void print_json(std::ostream& out, const std::vector<ScenarioResult>& scenarios) {
  nlohmann::ordered_json all = nlohmann::ordered_json::array();
  for (const ScenarioResult& sc : scenarios) {
    const EnsembleSummary& s = sc.summary;
    nlohmann::ordered_json j;
    j["scenario"] = sc.label;
    j["sweep"] = sc.sweep;
    j["n_total"] = s.n_total;
    j["n_ok"] = s.n_ok;
    j["n_failed"] = s.n_failed;
    j["n_pending"] = s.n_pending;
    j["S4_pooled"] = number(s.S4_pooled);
    j["S4_pooled_ci95"] = number(s.S4_pooled_ci95);
    j["tau_tar_km_median"] = number(s.tau_tar_km_median);
    nlohmann::ordered_json obs = nlohmann::ordered_json::object();
    for (const ObservableSummary& o : s.rows)
      obs[o.name] = {{"mean", number(o.mean)}, {"ci95", number(o.ci95)}, {"std", number(o.std)},
                     {"n", o.n},           {"n_undefined", o.n_undefined}, {"n_censored", o.n_censored}};
    j["observables"] = std::move(obs);
    all.push_back(std::move(j));
  }
  out << all.dump(2) << '\n';
}

}  // namespace

TableFormat parse_table_format(const std::string& text) {
  static constexpr std::pair<const char*, TableFormat> kNames[] = {
      {"table", TableFormat::Table}, {"markdown", TableFormat::Markdown},
      {"csv", TableFormat::Csv},     {"json", TableFormat::Json}};
  for (const auto& [name, format] : kNames)
    if (text == name) return format;
  throw std::invalid_argument("table format = \"" + text + "\"; valid choices: table, markdown, csv, json");
}

void print_table5(std::ostream& out, const std::vector<ScenarioResult>& scenarios, TableFormat format) {
  switch (format) {
    case TableFormat::Table: print_text(out, text_cells(scenarios)); return;
    case TableFormat::Markdown: print_markdown(out, text_cells(scenarios)); return;
    case TableFormat::Csv: print_csv(out, scenarios); return;
    case TableFormat::Json: print_json(out, scenarios); return;
  }
}

}  // namespace ringsim
