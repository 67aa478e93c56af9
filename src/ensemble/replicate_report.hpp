#pragma once
// The human-readable form of one replicate's result (`ringsim replicate`
// without --json): the study's observables first, then the run and its
// diagnostics, in aligned columns. The JSON object of run_replicate is the
// single source; this only formats it.

#include <iosfwd>

#include <nlohmann/json.hpp>

namespace ringsim {

// Fractions are shown as percentages with 4 significant digits, simulation
// times with 1 decimal; S4 without rings reads "undefined (no ring)", a
// censored tau_tar "censored at t_end = ...".
void print_replicate_report(const nlohmann::json& result, std::ostream& out);

}  // namespace ringsim
