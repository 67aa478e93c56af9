#pragma once
// `ringsim replicate [SCENARIO.toml] --seed S [--set SECTION.KEY=VALUE]... [--json]`
// Runs one replicate and prints its statistics (a table, or one JSON object).

#include <atomic>
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/replicate_record.hpp"
#include "core/bond_graph.hpp"
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
  bool profile = false;               // add where the time went (core EventProfile) to the output
};

// Optional inputs and outputs of one replicate beyond its JSON result.
struct ReplicateIo {
  std::string snapshot_path;  // final configuration: .xyz (extended XYZ) or .vtk; empty: none
  std::string series_path;    // N_t samples, one per line (for `ringsim mser`); empty: none
  std::vector<double>* series = nullptr;    // receives the same N_t samples
  const std::atomic<bool>* stop = nullptr;  // ends the run as "interrupted" when it turns true
  bool profile = false;  // add "profile" (core EventProfile, docs/OUTPUT.md) to the result
};

// Runs one replicate with the given settings and returns the result object
// (the `--json` output). With a snapshot path, also writes the final
// configuration (core/snapshot.hpp): extended XYZ, or legacy VTK when the
// path ends in ".vtk"; a run that ends in an error writes the configuration
// at the time it stopped, for debugging. Throws ConfigError / SceneError on bad input,
// std::runtime_error when the snapshot cannot be written.
// The N_t series holds the steady-state monitor's samples,
// `run.sample_interval` apart from t = 0.
nlohmann::json run_replicate(const SimParams& params, std::uint64_t seed, std::uint64_t replicate,
                             const ReplicateIo& io = {});

// The study's observables (MODEL.md, "Observables") as run_replicate's
// result fields: N_t ... tau_tar_censored, rings by size. Also the
// time-stepped peer's output (bench/peer), so both carry the same fields.
void add_observables_json(nlohmann::json& j, const Observables& o);

// The result object of run_replicate as one row of the ensemble's table.
// Status Ok for the study's normal ends (steady_state, t_max,
// no_bond_possible); Failed, with the reason in `error`, otherwise.
ReplicateRecord to_record(const nlohmann::json& result);

void add_replicate_command(CLI::App& app, ReplicateOptions& opt);
int replicate_main(const ReplicateOptions& opt, std::ostream& out);

}  // namespace ringsim
