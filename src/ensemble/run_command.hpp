#pragma once
// `ringsim run [SCENARIO.toml] --replicates R --seed S -o OUT.h5` under
// `mpirun -np P` (or alone): the ensemble (docs/ARCHITECTURE.md "Ensemble",
// docs/OUTPUT.md for the file).

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace ringsim {

// Exit code after SIGTERM / SIGUSR1 / SIGINT: finished replicates are saved,
// `--resume` completes the rest (EX_TEMPFAIL of sysexits.h: "try again").
constexpr int kExitInterrupted = 75;
// Exit code of a `run` that finished but in which at least one replicate
// failed (termination `error` or `event_budget`): the file and the table are
// still written; the failed rows carry their `error` message.
constexpr int kExitReplicatesFailed = 4;

struct RunOptions {
  std::string scenario;  // empty: built-in defaults (Scenario 4)
  std::uint64_t replicates = 0;
  std::uint64_t seed = 1;
  std::string output;
  std::vector<std::string> overrides;
  bool resume = false;
  bool force = false;
  bool series = false;           // store N_t(t) per replicate in /series/N_t
  double progress_interval = 30;  // seconds between log lines
  std::string progress = "auto";   // bar (live, \r), log (lines), none; auto: ensemble/progress_mode.hpp
  std::string format = "table";  // the closing Table 5: table, markdown, csv, json
};

void add_run_command(CLI::App& app, RunOptions& opt);

// Initializes and finalizes MPI itself. Returns the process exit code.
int run_main(const RunOptions& opt, std::ostream& out, std::ostream& err);

}  // namespace ringsim
