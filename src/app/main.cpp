// ringsim: thin executable. One options struct per subcommand, one top-level catch.
#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>

#include "analysis/mser_command.hpp"
#include "core/allocator.hpp"
#include "core/scene.hpp"
#include "ensemble/config.hpp"
#include "ensemble/aggregate_command.hpp"
#include "ensemble/replicate_command.hpp"
#include "ensemble/results_file.hpp"
#include "ensemble/run_command.hpp"
#include "ringsim/version.hpp"

int main(int argc, char** argv) {
  ringsim::keep_freed_memory();
  CLI::App app{"ringsim: event-driven rigid-body simulation of geometry-driven macrocyclization "
               "(spheres and cylindrical linkers). See README.md and docs/."};
  app.require_subcommand(1);
  app.footer(
      "Start with `ringsim replicate --seed 1` (one replicate of the built-in default scenario) or\n"
      "`mpirun -np 2 ringsim run --replicates 4 --seed 1 -o out.h5` (an ensemble and its table).\n"
      "Each command's --help gives examples and its exit codes; 0 is always success.");
  app.set_version_flag("--version", ringsim::kVersion);
  ringsim::ReplicateOptions rep;
  ringsim::add_replicate_command(app, rep);
  ringsim::RunOptions run_opts;
  ringsim::add_run_command(app, run_opts);
  ringsim::AggregateOptions agg_opts;
  ringsim::add_aggregate_command(app, agg_opts);
  ringsim::MserOptions mser_opts;
  ringsim::add_mser_command(app, mser_opts);
  CLI::App* keys = app.add_subcommand("keys", "List every configuration key with its default, range and meaning.");
  keys->footer(
      "One key per line: name (type, default, range): meaning. The same table: docs/CONFIG.md.\n"
      "Example:\n"
      "  ringsim keys | grep '^bonding\\.'      the bond rules' keys\n"
      "Exit codes: 0 done; 3 stdout not writable.");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every command-line error (a missing or
    // out-of-range option, e.g. --seed -1) is a configuration error: exit 1,
    // not CLI11's own codes (105, 106, ...), which no document lists.
    return app.exit(e) == 0 ? 0 : 1;
  }
  int code = 0;
  try {
    if (app.got_subcommand("replicate")) code = ringsim::replicate_main(rep, std::cout);
    else if (app.got_subcommand("run")) code = ringsim::run_main(run_opts, std::cout, std::cerr);
    else if (app.got_subcommand("aggregate")) code = ringsim::aggregate_main(agg_opts, std::cout, std::cerr);
    else if (app.got_subcommand("mser")) code = ringsim::mser_main(mser_opts, std::cin, std::cout, std::cerr);
    else if (keys->parsed()) {
      for (const auto& k : ringsim::config_keys())
        std::cout << k.name << " (" << k.type << ", default " << k.default_value << ", " << k.range << "): "
                  << k.description << '\n';
    }
  } catch (const ringsim::ConfigError& e) {
    std::cerr << "ringsim: configuration error: " << e.what() << '\n';
    code = 1;
  } catch (const ringsim::SceneError& e) {
    std::cerr << "ringsim: scene error: " << e.what() << '\n';
    code = 2;
  } catch (const ringsim::ResultsFileError& e) {
    std::cerr << "ringsim: result file error: " << e.what() << '\n';
    code = 3;
  } catch (const std::exception& e) {
    std::cerr << "ringsim: error: " << e.what() << '\n';
    code = 3;
  }
  // Output that never reached stdout (a full disk, /dev/full, a closed pipe)
  // is a failed command, not a success: exit 3 unless an error came first.
  std::cout.flush();
  if (!std::cout || std::fflush(stdout) != 0 || std::ferror(stdout)) {
    std::cerr << "ringsim: error: cannot write to standard output: " << std::strerror(errno) << '\n';
    if (code == 0) code = 3;
  }
  return code;
}
