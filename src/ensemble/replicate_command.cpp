#include "ensemble/replicate_command.hpp"

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <ostream>

#include "core/motion.hpp"
#include "core/scene.hpp"
#include "core/simulation.hpp"
#include "core/validation.hpp"
#include "ensemble/config.hpp"
#include "ringsim/version.hpp"

namespace ringsim {

nlohmann::json run_replicate(const SimParams& params, std::uint64_t seed, std::uint64_t replicate) {
  const auto start = std::chrono::steady_clock::now();
  SceneReport scene;
  BodyStore bodies = build_scene(params, seed, replicate, &scene);
  Simulation sim(params, std::move(bodies));
  std::unique_ptr<Validator> validator;
  if (params.run.validate) {
    validator = std::make_unique<Validator>(sim);
    sim.set_validator(validator.get());
  }
  const Termination term = sim.run();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  double e_trans = 0.0, e_rot = 0.0;
  Vec3 momentum = Vec3::Zero();
  const BodyStore& b = sim.bodies();
  for (int i = 0; i < b.size(); ++i) {
    e_trans += translational_energy(b.kin[i], b.sp(i));
    e_rot += rotational_energy(b.kin[i], b.sp(i));
    momentum += b.sp(i).mass * b.kin[i].v;
  }
  const RunStats& s = sim.stats();
  nlohmann::json j;
  j["version"] = kVersion;
  j["seed"] = seed;
  j["replicate"] = replicate;
  j["spheres"] = params.init.spheres;
  j["linkers"] = params.init.linkers;
  j["packing_fraction"] = scene.packing_fraction;
  j["mixing"] = scene.mixing;
  j["fallback_placements"] = scene.fallback_placements;
  j["events"] = s.events;
  j["collisions"] = s.collisions;
  j["wall_collisions"] = s.wall_collisions;
  j["cell_crossings"] = s.cell_crossings;
  j["stale_events"] = s.stale;
  j["tc_collisions"] = s.tc_collisions;
  j["stick_contacts"] = s.stick;
  j["slide_contacts"] = s.slide;
  j["ca_steps"] = s.ca_steps;
  j["plane_evaluations"] = s.plane_evaluations;
  j["t_end"] = sim.time();
  j["termination"] = to_string(term);
  if (term == Termination::Error) j["error"] = sim.error();
  j["wall_seconds"] = wall;
  j["events_per_second"] = wall > 0 ? static_cast<double>(s.events) / wall : 0.0;
  j["energy"] = {{"translational", e_trans}, {"rotational", e_rot}};
  j["momentum"] = {momentum.x(), momentum.y(), momentum.z()};
  if (validator) {
    const ValidationReport& r = validator->report();
    j["validation"] = {{"checks", r.checks},
                       {"overlaps", r.overlaps},
                       {"max_momentum_error", r.max_momentum_error},
                       {"max_angular_momentum_error", r.max_angular_momentum_error},
                       {"max_energy_error", r.max_energy_error},
                       {"energy_conserving", validator->energy_conserving()}};
  }
  return j;
}

void add_replicate_command(CLI::App& app, ReplicateOptions& opt) {
  CLI::App* cmd = app.add_subcommand("replicate", "Run one replicate and print its event statistics.");
  cmd->footer(
      "Examples:\n"
      "  ringsim replicate --seed 7                       built-in default scene (300 spheres + 300 linkers)\n"
      "  ringsim replicate jobs/scenarios/1-baseline.toml --seed 7 --json\n"
      "  ringsim replicate --seed 1 --set run.t_max=50 --set geometry.boundary=periodic\n"
      "  ringsim replicate --seed 1 --validate --set run.t_max=10   check invariants after every event\n"
      "Configuration keys and ranges: docs/CONFIG.md (or `ringsim keys`).");
  cmd->add_option("scenario", opt.scenario, "Scenario TOML file listing deviations from the defaults (optional)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--seed,-s", opt.seed, "Base seed of the random streams")->required();
  cmd->add_option("--replicate", opt.replicate, "Replicate index (with --seed, keys every random stream)");
  cmd->add_option("--set", opt.overrides, "Override one key: SECTION.KEY=VALUE (repeatable)")->take_all();
  cmd->add_flag("--json", opt.json, "Print one JSON object instead of a table");
  cmd->add_flag("--validate", opt.validate, "Validation mode: check overlaps and conservation laws after every event");
}

int replicate_main(const ReplicateOptions& opt, std::ostream& out) {
  std::vector<std::string> overrides = opt.overrides;
  if (opt.validate) overrides.push_back("run.validate=true");
  const SimParams params = load_config_file(opt.scenario, overrides);
  const nlohmann::json j = run_replicate(params, opt.seed, opt.replicate);
  if (opt.json) {
    out << j.dump() << '\n';
  } else {
    char line[160];
    auto row = [&](const char* k, const std::string& v) {
      std::snprintf(line, sizeof line, "  %-22s %s\n", k, v.c_str());
      out << line;
    };
    out << "ringsim replicate (" << kVersion << ")\n";
    for (const char* k : {"seed", "spheres", "linkers", "packing_fraction", "mixing", "events", "collisions",
                          "wall_collisions", "cell_crossings", "stale_events", "tc_collisions", "ca_steps", "plane_evaluations", "t_end",
                          "termination", "wall_seconds", "events_per_second"})
      row(k, j[k].dump());
    row("energy.translational", j["energy"]["translational"].dump());
    row("energy.rotational", j["energy"]["rotational"].dump());
    row("momentum", j["momentum"].dump());
    if (j.contains("validation")) row("validation", j["validation"].dump());
    if (j.contains("error")) row("error", j["error"].get<std::string>());
  }
  return j["termination"] == "error" ? 3 : 0;
}

}  // namespace ringsim
