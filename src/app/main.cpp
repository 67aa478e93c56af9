// ringsim: thin executable. One options struct per subcommand, one top-level catch.
#include <CLI/CLI.hpp>
#include <iostream>

#include "analysis/mser_command.hpp"
#include "core/scene.hpp"
#include "ensemble/config.hpp"
#include "ensemble/aggregate_command.hpp"
#include "ensemble/replicate_command.hpp"
#include "ensemble/results_file.hpp"
#include "ensemble/run_command.hpp"
#include "ringsim/version.hpp"

int main(int argc, char** argv) {
  CLI::App app{"ringsim: event-driven rigid-body simulation of geometry-driven macrocyclization "
               "(spheres and cylindrical linkers). See README.md and docs/."};
  app.require_subcommand(1);
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
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    if (app.got_subcommand("replicate")) return ringsim::replicate_main(rep, std::cout);
    if (app.got_subcommand("run")) return ringsim::run_main(run_opts, std::cout, std::cerr);
    if (app.got_subcommand("aggregate")) return ringsim::aggregate_main(agg_opts, std::cout, std::cerr);
    if (app.got_subcommand("mser")) return ringsim::mser_main(mser_opts, std::cin, std::cout, std::cerr);
    if (keys->parsed()) {
      for (const auto& k : ringsim::config_keys())
        std::cout << k.name << " (" << k.type << ", default " << k.default_value << ", " << k.range << "): "
                  << k.description << '\n';
      return 0;
    }
  } catch (const ringsim::ConfigError& e) {
    std::cerr << "ringsim: configuration error: " << e.what() << '\n';
    return 1;
  } catch (const ringsim::SceneError& e) {
    std::cerr << "ringsim: scene error: " << e.what() << '\n';
    return 2;
  } catch (const ringsim::ResultsFileError& e) {
    std::cerr << "ringsim: result file error: " << e.what() << '\n';
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "ringsim: error: " << e.what() << '\n';
    return 3;
  }
  return 0;
}
