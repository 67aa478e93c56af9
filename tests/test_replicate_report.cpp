// The human-readable replicate report (ensemble/replicate_report): precision,
// the wording of undefined and censored observables, the section order and
// the column alignment; and `ringsim replicate` with and without --json.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "ensemble/config.hpp"
#include "ensemble/replicate_command.hpp"
#include "ensemble/replicate_report.hpp"

namespace {

using namespace ringsim;

// A real result object (a short run of the defaults), edited per test.
const nlohmann::json& short_run() {
  static const nlohmann::json j = run_replicate(load_config_file("", {"run.t_max=1"}), 1, 0);
  return j;
}

std::string report(const nlohmann::json& j) {
  std::ostringstream out;
  print_replicate_report(j, out);
  return out.str();
}

// The value column of the row labelled `label` (after the aligned padding).
std::string value_of(const std::string& text, const std::string& label) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line))
    if (line.compare(0, 2 + label.size() + 1, "  " + label + " ") == 0) {
      const auto start = line.find_first_not_of(' ', 2 + label.size());
      return start == std::string::npos ? "" : line.substr(start);
    }
  return "<no row " + label + ">";
}

TEST(ReplicateReport, FractionsArePercentWithFourDigitsAndTimesOneDecimal) {
  nlohmann::json j = short_run();
  j["Phi_obj"] = 0.123456;
  j["Phi_viab"] = 1.0;
  j["M_mono"] = 0.0;
  j["S4"] = 0.5;
  j["tau_tar"] = 12.345;
  j["tau_tar_censored"] = false;
  j["t_end"] = 40.04;
  const std::string r = report(j);
  EXPECT_EQ(value_of(r, "Phi_obj"), "12.35 %") << r;
  EXPECT_EQ(value_of(r, "Phi_viab"), "100.0 %") << r;
  EXPECT_EQ(value_of(r, "M_mono"), "0.000 %") << r;
  EXPECT_EQ(value_of(r, "S4"), "50.00 %") << r;
  EXPECT_EQ(value_of(r, "tau_tar"), "12.3") << r;
  EXPECT_NE(r.find("Observables at t_end = 40.0\n"), std::string::npos) << r;
}

TEST(ReplicateReport, UndefinedS4AndCensoredTauAreSpelledOut) {
  nlohmann::json j = short_run();
  j["S4"] = nullptr;
  j["tau_tar"] = 7.25;
  j["tau_tar_censored"] = true;
  j["t_end"] = 7.25;
  j["rings"] = nlohmann::json::object();
  const std::string r = report(j);
  EXPECT_EQ(value_of(r, "S4"), "undefined (no ring)") << r;
  EXPECT_EQ(value_of(r, "tau_tar"), "censored at t_end = 7.2") << r;  // %.1f of 7.25 rounds to even
  EXPECT_EQ(value_of(r, "rings"), "none") << r;
  EXPECT_EQ(r.find("null"), std::string::npos) << r;
  j["rings"] = {{"4", 3}, {"6", 1}};
  EXPECT_EQ(value_of(report(j), "rings"), "4-ring x 3, 6-ring x 1");
}

TEST(ReplicateReport, ObservablesComeFirstAndDiagnosticsBelowInAlignedColumns) {
  const std::string r = report(short_run());
  const auto obs = r.find("\nObservables"), run = r.find("\nRun\n"), diag = r.find("\nDiagnostics\n");
  ASSERT_NE(obs, std::string::npos) << r;
  ASSERT_NE(run, std::string::npos) << r;
  ASSERT_NE(diag, std::string::npos) << r;
  EXPECT_LT(obs, run);
  EXPECT_LT(run, diag);
  for (const char* k : {"N_t", "S4", "tau_tar"}) EXPECT_LT(r.find("  " + std::string(k) + " "), run) << k;
  for (const char* k : {"events", "collisions", "energy", "momentum", "energy_budget"})
    EXPECT_GT(r.find("\n  " + std::string(k) + " "), diag) << k;
  EXPECT_GT(r.find("\n  wall time "), run) << r;
  // Every row's value starts in the same column: the one of N_t's value.
  const std::size_t column = r.find(value_of(r, "N_t"), r.find("\n  N_t ")) - r.find("\n  N_t ") - 1;
  std::istringstream in(r);
  std::string line;
  int rows = 0;
  while (std::getline(in, line))
    if (line.compare(0, 2, "  ") == 0) {
      ++rows;
      ASSERT_GT(line.size(), column) << line;
      EXPECT_EQ(line[column - 1], ' ') << line;
      EXPECT_NE(line[column], ' ') << line;
    }
  EXPECT_GT(rows, 20);
}

struct Cmd {
  int status;
  std::string out;
};

Cmd run_cli(const std::string& args) {
  Cmd r{0, ""};
  FILE* f = popen((std::string(RINGSIM_BINARY) + " " + args + " 2>/dev/null").c_str(), "r");
  std::array<char, 4096> buf;
  while (fgets(buf.data(), buf.size(), f)) r.out += buf.data();
  const int st = pclose(f);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

TEST(ReplicateReport, TheCommandPrintsTheReportAndJsonStaysOneObject) {
  const std::string args = "replicate --seed 5 --set run.t_max=3";
  const Cmd human = run_cli(args);
  ASSERT_EQ(human.status, 0) << human.out;
  const Cmd json = run_cli(args + " --json");
  ASSERT_EQ(json.status, 0) << json.out;
  // --json: one line, nlohmann's compact dump, nothing else.
  ASSERT_EQ(json.out.find('\n'), json.out.size() - 1) << json.out;
  const nlohmann::json j = nlohmann::json::parse(json.out);
  EXPECT_EQ(json.out, j.dump() + "\n");
  // The human report of the same replicate (same seed: same observables).
  nlohmann::json same = j;
  std::ostringstream expected;
  print_replicate_report(same, expected);
  const std::string& h = human.out;
  for (const char* k : {"N_t", "N_tar", "Phi_obj", "S4", "M_mono", "tau_tar", "events", "collisions"})
    EXPECT_EQ(value_of(h, k), value_of(expected.str(), k)) << k << "\n" << h;
}

}  // namespace
