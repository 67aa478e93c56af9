#pragma once
// `ringsim aggregate FILES... [--format table|markdown|csv|json]`: merges
// result files (shards of job arrays, reruns, several scenarios), groups them
// by configuration, drops duplicate replicates and prints the study's
// Table 5, one row per configuration.

#include <iosfwd>
#include <string>
#include <vector>

#include "analysis/table5.hpp"

namespace CLI {
class App;
}

namespace ringsim {

struct AggregateOptions {
  std::vector<std::string> files;
  std::string format = "table";
};

// One configuration's merged rows.
struct AggregateGroup {
  std::string config_hash;
  std::string label;  // scenario name
  std::string sweep;  // its --set overrides, comma-separated
  std::vector<std::string> files;
  std::vector<ReplicateRecord> records;  // unique (seed, id); pending ones only where no file has a result
  int duplicates = 0;                    // identical rows seen more than once (dropped)
  int conflicts = 0;                     // same (seed, id) with different results (first kept)
};

// Reads and merges the files; throws ResultsFileError naming a bad file.
std::vector<AggregateGroup> aggregate_files(const std::vector<std::string>& files);

void add_aggregate_command(CLI::App& app, AggregateOptions& opt);
int aggregate_main(const AggregateOptions& opt, std::ostream& out, std::ostream& err);

}  // namespace ringsim
