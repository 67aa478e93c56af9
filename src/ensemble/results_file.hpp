#pragma once
// The ensemble's HDF5 result file (layout: docs/OUTPUT.md).
//
//   /                 provenance attributes (Provenance below)
//   /replicates       compound, one ReplicateRecord per replicate, pre-sized
//                     to R rows at creation (status "pending" = 0 until run)
//   /series/N_t       optional float32 [R x L]: the sampled N_t(t), NaN-padded
//   /summary          compound, one row per observable (written when the run
//                     ends, also after a graceful stop)
//
// Crash safety. The file is created complete (every dataset allocated and
// filled) and flushed before any replicate runs; afterwards a running
// ensemble only overwrites raw row data in place and flushes, so no metadata
// changes until the end and a `kill -9` at any moment leaves a readable file
// whose finished rows are intact. The closing write (summary, end time) goes
// to a new file `OUT.tmp` that is then renamed over OUT, so it is atomic too.
//
// Writing goes through HDF5's MPI-IO driver on MPI_COMM_SELF of rank 0 (the
// only writer: see docs/ARCHITECTURE.md "Ensemble"); reading uses the default
// POSIX driver and needs no MPI.

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis/ensemble_summary.hpp"
#include "analysis/replicate_record.hpp"

namespace ringsim {

struct Provenance {
  std::string program = "ringsim";
  std::string version;        // from git (ringsim --version)
  std::string scenario;       // scenario name (file `name`, else the file's stem, else "default")
  std::string scenario_file;  // path as given; empty for the built-in defaults
  std::string overrides;      // the --set arguments, one per line (a sweep point)
  std::string config_toml;    // the full effective configuration (config_to_toml)
  std::string config_hash;    // FNV-1a 64 of config_toml, 16 hex digits
  std::uint64_t base_seed = 0;
  std::uint64_t replicates = 0;  // R: rows of /replicates
  std::int64_t ranks = 0;        // MPI ranks of the (last) run that wrote the file
  std::string host;
  std::string start_time;        // ISO 8601 UTC of the first run
  std::string end_time;          // ISO 8601 UTC when closed; empty while running
  std::int64_t complete = 0;     // 1 when every row is done (ok or failed)
  std::int64_t series_length = 0;  // L, columns of /series/N_t; 0 without series
  std::int64_t runs = 1;         // number of runs (1 + resumes) that wrote the file
};

// FNV-1a 64-bit hash (Fowler, Noll, Vo) of text, as 16 lowercase hex digits.
std::string fnv1a_hex(const std::string& text);

// An HDF5 error; what() names the file and the failing operation.
class ResultsFileError : public std::runtime_error {
 public:
  explicit ResultsFileError(const std::string& message) : std::runtime_error(message) {}
};

class ResultsWriter {
 public:
  // Creates `path` with every dataset allocated (R pending rows), flushes it.
  // Refuses nothing: the caller decides about existing files. Throws
  // ResultsFileError (unwritable directory, disk full, ...).
  static std::unique_ptr<ResultsWriter> create(const std::string& path, const Provenance& prov);
  // Opens an existing file for resuming (rows are overwritten in place).
  static std::unique_ptr<ResultsWriter> open(const std::string& path);
  ~ResultsWriter();
  ResultsWriter(const ResultsWriter&) = delete;
  ResultsWriter& operator=(const ResultsWriter&) = delete;

  // Overwrites the rows of these records (by id) and their series (row-major
  // [n x L], may be empty when the file has no series), then flushes to disk.
  void write_rows(const std::vector<ReplicateRecord>& records, const std::vector<float>& series);
  void close();

  struct Impl;

 private:
  explicit ResultsWriter(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Everything in a result file, read with the POSIX driver.
struct ResultsContent {
  Provenance provenance;
  std::vector<ReplicateRecord> records;
  std::vector<float> series;  // [R x L] row-major; empty without series
};

// Throws ResultsFileError when the file is missing, unreadable or not a
// ringsim result file.
ResultsContent read_results(const std::string& path, bool with_series = true);

// Writes a complete file (provenance, rows, series, summary) to `path` + ".tmp"
// and renames it over `path`: atomic on POSIX file systems.
void write_results_atomically(const std::string& path, const ResultsContent& content,
                              const EnsembleSummary& summary);

}  // namespace ringsim
