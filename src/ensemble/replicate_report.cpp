#include "ensemble/replicate_report.hpp"

#include <cstdio>
#include <ostream>
#include <string>

#include "core/simulation.hpp"
#include "ringsim/version.hpp"

namespace ringsim {

namespace {

std::string format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

// A fraction as a percentage, 4 significant digits ("72.80 %").
std::string percent(const nlohmann::json& v) {
  if (!v.is_number()) return "undefined";
  return format("%#.4g", 100.0 * v.get<double>()) + " %";
}

// A simulation time, 1 decimal.
std::string time_text(const nlohmann::json& v) { return format("%.1f", v.get<double>()); }

// A number: integers as they are, others with 6 significant digits.
std::string number(const nlohmann::json& v) {
  if (v.is_number_integer() || v.is_boolean()) return v.dump();
  if (v.is_number()) return format("%.6g", v.get<double>());
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

// An object's fields inline: "a 1, b 2.5" (nested objects in braces).
std::string fields(const nlohmann::json& obj) {
  std::string s;
  for (const auto& [k, v] : obj.items()) {
    s += (s.empty() ? "" : ", ") + k + " ";
    s += v.is_object() ? "{" + fields(v) + "}" : number(v);
  }
  return s;
}

std::string rings_text(const nlohmann::json& rings) {
  if (rings.empty()) return "none";
  std::string s;
  for (const auto& [m, count] : rings.items()) s += (s.empty() ? "" : ", ") + m + "-ring x " + count.dump();
  return s;
}

// Bin k of the profile's pair-search work: "0", "1-3", ..., "> 1000".
std::string work_bin_label(int k) {
  const std::int64_t* edge = EventProfile::kWorkBins;
  if (k == 0) return "0";
  if (k == EventProfile::kBins - 1) return "> " + std::to_string(edge[k - 1]);
  return std::to_string(edge[k - 1] + 1) + "-" + std::to_string(edge[k]);
}

// One half of a row of the profile's work table: searches, seconds, and
// exact distances and plane evaluations per search (widths as the header's).
constexpr const char* kWorkHeader = " searches seconds  exact  planes";
std::string work_cells(const nlohmann::json& w) {
  const long long n = w["searches"].get<long long>();
  const double per = n > 0 ? 1.0 / static_cast<double>(n) : 0.0;
  char cells[96];
  std::snprintf(cells, sizeof cells, "%9lld %7.3f %6.2f %7.2f", n, w["seconds"].get<double>(),
                per * w["exact_distances"].get<double>(), per * w["plane_evaluations"].get<double>());
  return cells;
}

void print_profile(const nlohmann::json& profile, std::ostream& out) {
  char line[160];
  out << "\nProfile (per kind of event: events, predictions, pair searches, capture searches, seconds)\n";
  for (const char* kind : EventProfile::kNames) {
    const nlohmann::json& v = profile["by_event"][kind];
    std::snprintf(line, sizeof line, "  %-22s %10lld %10lld %11lld %11lld %9.3f\n", kind, v["events"].get<long long>(),
                  v["predictions"].get<long long>(), v["pair_searches"].get<long long>(),
                  v["capture_searches"].get<long long>(), v["seconds"].get<double>());
    out << line;
  }
  out << "pair searches by work (distance + plane evaluations); left: all, right: those that found a contact\n";
  std::snprintf(line, sizeof line, "  %-22s %s | %s\n", "work", kWorkHeader, kWorkHeader);
  out << line;
  for (int k = 0; k < EventProfile::kBins; ++k) {
    const nlohmann::json& b = profile["pair_searches_by_work"][k];
    const std::string cells = work_cells(b) + " | " + work_cells(b["found"]);
    std::snprintf(line, sizeof line, "  %-22s %s\n", work_bin_label(k).c_str(), cells.c_str());
    out << line;
  }
}

}  // namespace

void print_replicate_report(const nlohmann::json& j, std::ostream& out) {
  auto row = [&](const char* label, const std::string& value) {
    char head[64];
    std::snprintf(head, sizeof head, "  %-18s ", label);
    out << head << value << '\n';  // (value may be long: the energy budget is)
  };
  out << "ringsim replicate (" << kVersion << "): seed " << j["seed"].dump() << ", replicate "
      << j["replicate"].dump() << '\n';

  out << "\nObservables at t_end = " << time_text(j["t_end"]) << "\n";
  for (const char* k : {"N_t", "N_tar", "N_viab", "N_nv1", "N_nv2", "N_nv3", "N_cyc"}) row(k, j[k].dump());
  row("rings", rings_text(j["rings"]));
  for (const char* k : {"Phi_obj", "Phi_viab"}) row(k, percent(j[k]));
  row("S4", j["S4"].is_null() ? "undefined (no ring)" : percent(j["S4"]));
  for (const char* k : {"M_mono", "M_mono_S", "M_mono_L"}) row(k, percent(j[k]));
  row("tau_tar", j["tau_tar_censored"].get<bool>() ? "censored at t_end = " + time_text(j["t_end"])
                                                    : time_text(j["tau_tar"]));

  out << "\nRun\n";
  row("termination", j["termination"].get<std::string>() + " at t = " + time_text(j["t_end"]));
  if (j.contains("error")) row("error", j["error"].get<std::string>());
  row("bodies", j["spheres"].dump() + " spheres + " + j["linkers"].dump() + " linkers");
  row("packing fraction", percent(j["packing_fraction"]));
  row("mixing", percent(j["mixing"]));
  if (j.contains("mser")) row("steady state", "MSER " + fields(j["mser"]));
  row("wall time", format("%.2f s", j["wall_seconds"].get<double>()) + " (" +
                       format("%.3g", j["events_per_second"].get<double>()) + " events/s)");

  out << "\nDiagnostics\n";
  for (const char* k : {"events", "collisions", "wall_collisions", "captures", "bonds", "closure_bonds",
                        "cell_crossings", "stale_events", "tc_collisions", "floored_contacts", "ca_steps"})
    row(k, j[k].dump());
  row("rejected", fields(j["rejected"]));
  row("energy", fields(j["energy"]));
  const nlohmann::json& p = j["momentum"];
  row("momentum", "(" + number(p[0]) + ", " + number(p[1]) + ", " + number(p[2]) + ")");
  row("energy_budget", fields(j["energy_budget"]));
  if (j.contains("compliant")) row("compliant", fields(j["compliant"]));
  if (j.contains("validation")) row("validation", fields(j["validation"]));
  if (j.contains("profile")) print_profile(j["profile"], out);
}

}  // namespace ringsim
