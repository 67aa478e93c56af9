#pragma once
// `ringsim replicate [SCENARIO.toml] --seed S [--set SECTION.KEY=VALUE]... [--json]`
// Runs one replicate and prints its statistics (a table, or one JSON object).

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/params.hpp"

namespace CLI {
class App;
}

namespace ringsim {

struct ReplicateOptions {
  std::string scenario;               // empty: built-in defaults
  std::uint64_t seed = 1;
  std::uint64_t replicate = 0;        // replicate index within an ensemble
  std::vector<std::string> overrides;
  bool json = false;
  bool validate = false;              // same as --set run.validate=true
  std::string snapshot;               // final configuration: .xyz (extended XYZ) or .vtk; empty: none
  std::string series;                 // sampled N_t(t), one value per line (for `ringsim mser`); empty: none
};

// Runs one replicate with the given settings and returns the result object
// (the `--json` output). With a snapshot path, also writes the final
// configuration (core/snapshot.hpp): extended XYZ, or legacy VTK when the
// path ends in ".vtk". Throws ConfigError / SceneError on bad input,
// std::runtime_error when the snapshot cannot be written.
// With a series path, writes the N_t samples of the steady-state monitor
// (one per line, `run.sample_interval` apart, from t = 0).
nlohmann::json run_replicate(const SimParams& params, std::uint64_t seed, std::uint64_t replicate,
                             const std::string& snapshot_path = "", const std::string& series_path = "");

void add_replicate_command(CLI::App& app, ReplicateOptions& opt);
int replicate_main(const ReplicateOptions& opt, std::ostream& out);

}  // namespace ringsim
