#include "ensemble/aggregate_command.hpp"

#include <CLI/CLI.hpp>
#include <cstring>
#include <map>
#include <ostream>
#include <utility>

#include "analysis/ensemble_summary.hpp"
#include "ensemble/results_file.hpp"

namespace ringsim {

namespace {

bool is_pending(const ReplicateRecord& r) { return r.status == static_cast<std::int8_t>(RecordStatus::Pending); }

// Equal results: every field but the measured wall time.
bool same_result(ReplicateRecord a, ReplicateRecord b) {
  a.wall_seconds = b.wall_seconds = 0.0;
  return std::memcmp(&a, &b, sizeof a) == 0;  // both rows were zero-initialized before filling (padding too)
}

std::string comma_list(const std::string& lines) {
  std::string s = lines;
  for (std::size_t p = 0; (p = s.find('\n', p)) != std::string::npos;) s.replace(p, 1, ", ");
  return s;
}

}  // namespace

std::vector<AggregateGroup> aggregate_files(const std::vector<std::string>& files) {
  std::vector<AggregateGroup> groups;
  std::map<std::string, std::size_t> by_hash;
  std::vector<std::map<std::pair<std::uint64_t, std::uint64_t>, std::size_t>> index;
  for (const std::string& f : files) {
    ResultsContent c = read_results(f, false);
    const Provenance& p = c.provenance;
    auto [it, added] = by_hash.emplace(p.config_hash, groups.size());
    if (added) {
      groups.push_back(AggregateGroup{p.config_hash, p.scenario, comma_list(p.overrides), {}, {}, 0, 0});
      index.emplace_back();
    }
    AggregateGroup& g = groups[it->second];
    auto& idx = index[it->second];
    g.files.push_back(f);
    for (const ReplicateRecord& r : c.records) {
      const auto key = std::make_pair(r.seed, r.id);
      auto found = idx.find(key);
      if (found == idx.end()) {
        idx.emplace(key, g.records.size());
        g.records.push_back(r);
        continue;
      }
      ReplicateRecord& kept = g.records[found->second];
      if (is_pending(r)) continue;
      if (is_pending(kept)) kept = r;
      else if (same_result(kept, r)) ++g.duplicates;
      else ++g.conflicts;
    }
  }
  return groups;
}

void add_aggregate_command(CLI::App& app, AggregateOptions& opt) {
  CLI::App* cmd = app.add_subcommand(
      "aggregate", "Merge result files (shards, reruns, scenarios) and print the study's Table 5.");
  cmd->footer(
      "Files with the same configuration (hash of the full effective settings) are merged into one row;\n"
      "replicates present in several files (same seed and id) count once. Each distinct configuration,\n"
      "e.g. a scenario or a sweep point made by --set, is its own row.\n"
      "Examples:\n"
      "  ringsim aggregate results/*.h5\n"
      "  ringsim aggregate shard-*.h5 --format markdown > table5.md\n"
      "  ringsim aggregate results/*.h5 --format csv > table5.csv\n"
      "Exit codes: 0 done; 1 command-line error (e.g. a missing file); 3 a file that is not a readable\n"
      "ringsim result, or stdout not writable.");
  cmd->add_option("files", opt.files, "HDF5 result files written by `ringsim run`")->required()->check(
      CLI::ExistingFile);
  cmd->add_option("--format", opt.format, "table (terminal), markdown, csv or json")
      ->check(CLI::IsMember({"table", "markdown", "csv", "json"}));
}

int aggregate_main(const AggregateOptions& opt, std::ostream& out, std::ostream& err) {
  const std::vector<AggregateGroup> groups = aggregate_files(opt.files);
  std::vector<ScenarioResult> rows;
  for (const AggregateGroup& g : groups) {
    rows.push_back(ScenarioResult{g.label, g.sweep, summarize_ensemble(g.records)});
    const EnsembleSummary& s = rows.back().summary;
    err << "ringsim aggregate: " << g.label << (g.sweep.empty() ? "" : " [" + g.sweep + "]") << " (config "
        << g.config_hash << "): " << g.files.size() << (g.files.size() == 1 ? " file, " : " files, ") << s.n_ok
        << " ok, " << s.n_failed << " failed, " << s.n_pending << " pending";
    if (g.duplicates) err << ", " << g.duplicates << " duplicate rows dropped";
    if (g.conflicts) err << ", WARNING: " << g.conflicts << " conflicting duplicate rows (first kept)";
    err << '\n';
  }
  print_table5(out, rows, parse_table_format(opt.format));
  return 0;
}

}  // namespace ringsim
