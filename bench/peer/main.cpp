// ringsim_peer [SCENARIO.toml] --seed S [--replicate R] [--set SECTION.KEY=VALUE]...
//              [--dt DT] [--bullet-defaults] [--iterations N] [--json]
// One replicate of the model on Bullet, from the same scene as
// `ringsim replicate` with the same arguments; prints one JSON object with
// the fields of `ringsim replicate --json` plus "peer" (docs/PEER.md).
//
// `--set bonding.joint=welded|articulated` chooses how a bond is held
// (peer.hpp; welded when not set). The peer reads this key itself and also
// passes it on to the configuration, whose checks of other keys depend on
// it (e.g. bonding.exclusions = 1-2 needs articulated bonds).
//
// Exit status as ringsim's: 0 done, 1 configuration or command-line error,
// 2 scene cannot be built, 3 the engine's run ended in an error.
#include <cstdint>
#include <iostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/scene.hpp"
#include "ensemble/config.hpp"
#include "peer.hpp"

int main(int argc, char** argv) {
  CLI::App app{"A time-stepped peer of ringsim on the Bullet engine (docs/PEER.md)"};
  std::string scenario;
  std::uint64_t seed = 1, replicate = 0;
  std::vector<std::string> sets;
  ringsim::peer::PeerOptions opt;
  bool json = true;
  app.add_option("scenario", scenario, "scenario file (TOML); none: built-in defaults");
  app.add_option("--seed", seed, "random seed (as ringsim replicate)");
  app.add_option("--replicate", replicate, "replicate index (as ringsim replicate)");
  app.add_option("--set", sets, "SECTION.KEY=VALUE override (repeatable)")
      ->expected(1)  // one value per --set, so a scenario file after it stays positional
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app.add_option("--dt", opt.dt, "time step")->check(CLI::PositiveNumber);
  app.add_flag("--bullet-defaults", opt.bullet_defaults, "Bullet's stock contact settings (docs/PEER.md)");
  app.add_option("--iterations", opt.solver_iterations, "solver iterations per step")->check(CLI::PositiveNumber);
  app.add_flag("--json", json, "print the JSON object (always on; for symmetry with ringsim)");
  CLI11_PARSE(app, argc, argv);

  std::vector<std::string> overrides;
  try {
    for (const std::string& s : sets) {
      const std::string key = "bonding.joint=";
      if (s.rfind(key, 0) == 0) {
        std::string v = s.substr(key.size());
        if (v.size() >= 2 && v.front() == '"' && v.back() == '"') v = v.substr(1, v.size() - 2);
        opt.joint = ringsim::peer::joint_reading_from_string(v);
      }
      overrides.push_back(s);
    }
    const ringsim::SimParams params = ringsim::load_config_file(scenario, overrides);
    const nlohmann::json j = ringsim::peer::run_peer(params, seed, replicate, opt);
    std::cout << j.dump() << '\n';
    return j["termination"] == "error" ? 3 : 0;
  } catch (const ringsim::SceneError& e) {
    std::cerr << "ringsim_peer: " << e.what() << '\n';
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "ringsim_peer: " << e.what() << '\n';
    return 1;
  }
}
