#pragma once
// The study's Table 5 layout: one row per scenario, the headline observables
// as mean ± 95 % CI half-width over the Ok replicates (MODEL.md "Protocol"),
// with the counts the study's reading needs (DESIGN.md "Analysis"):
//
//   scenario [sweep] | N_t | tau_tar | Phi_obj (%) | S4 (%) | Phi_viab (%) |
//   M_mono (%) | n | failed | S4 undefined | tau_tar censored |
//   tau_tar KM median | S4 pooled (%)
//
// The sweep column appears in Table and Markdown only when some scenario has
// one; Csv and Json always carry it.
// Formats:
//   Table     aligned plain text for a terminal (UTF-8 "±"); fractions in percent.
//   Markdown  a GitHub table, same cells as Table.
//   Csv       one header line, then one line per scenario; fractions stay
//             fractions, mean and ci95 in separate columns, shortest
//             round-trip numbers, NaN as an empty field (RFC 4180 quoting).
//   Json      an array of objects: every ObservableSummary row under
//             "observables" plus the counts, S4 pooled and the KM median;
//             fractions; NaN as null.
// Text cells: "mean ± ci95", "mean ± n/a" when ci95 is NaN (n < 2),
// "undefined" when the mean is (never 0); a KM median that the survival curve
// never reaches is "not reached".

#include <ostream>
#include <string>
#include <vector>

#include "analysis/ensemble_summary.hpp"

namespace ringsim {

enum class TableFormat { Table, Markdown, Csv, Json };

// "table", "markdown", "csv" or "json"; throws std::invalid_argument naming
// the value and the valid choices otherwise.
TableFormat parse_table_format(const std::string& text);

struct ScenarioResult {
  std::string label;  // scenario name, e.g. "4 passive selection"
  std::string sweep;  // swept setting, e.g. "bonding.dtheta_deg=2"; empty when none
  EnsembleSummary summary;
};

void print_table5(std::ostream& out, const std::vector<ScenarioResult>& scenarios, TableFormat format);

}  // namespace ringsim
