#include "ensemble/replicate_command.hpp"

#include <CLI/CLI.hpp>
#include <chrono>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <ostream>

#include "core/cluster.hpp"
#include "core/motion.hpp"
#include "core/scene.hpp"
#include "core/simulation.hpp"
#include "core/snapshot.hpp"
#include "core/validation.hpp"
#include "ensemble/cli_checks.hpp"
#include "ensemble/config.hpp"
#include "ensemble/replicate_report.hpp"
#include "ringsim/version.hpp"

namespace ringsim {

namespace {

void write_snapshot(const Simulation& sim, const SimParams& params, std::uint64_t seed, std::uint64_t replicate,
                    const std::string& path) {
  const BodyStore& b = sim.bodies();  // synchronized, also after an error: every kin holds the last pose
  Snapshot snap;
  snap.time = sim.time();
  snap.box_length = params.geometry.box_length;
  snap.periodic = params.geometry.boundary == Boundary::Periodic;
  snap.comment = "ringsim " + std::string(kVersion) + " seed " + std::to_string(seed) + " replicate " +
                 std::to_string(replicate);
  for (int i = 0; i < b.size(); ++i) {
    const Species& s = b.sp(i);
    snap.bodies.push_back(SnapshotBody{s.shape == Shape::Sphere, b.kin[i].x,
                                       s.shape == Shape::Sphere ? Vec3(Vec3::UnitZ()) : Vec3(b.kin[i].axis.normalized()),
                                       s.radius, s.half_length, sim.graph().component(i)});
  }
  snap.bonds = sim.graph().bonds();
  for (const Bond& bond : sim.graph().bond_log()) snap.bond_ends.push_back(bond.end);
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot open snapshot file " + path + " for writing");
  const bool vtk = path.size() >= 4 && path.compare(path.size() - 4, 4, ".vtk") == 0;
  if (vtk) write_vtk(out, snap);
  else write_extended_xyz(out, snap);
  out.close();
  if (!out) throw std::runtime_error("could not write snapshot file " + path + " (disk full?)");
}

void write_series(const Simulation& sim, const std::string& path) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot open series file " + path + " for writing");
  out << "# N_t sampled every " << sim.params().run.sample_interval << " time units from t = 0 (ringsim "
      << kVersion << ")\n";
  for (double v : sim.monitor().samples()) out << v << '\n';
  out.close();
  if (!out) throw std::runtime_error("could not write series file " + path + " (disk full?)");
}

nlohmann::json profile_json(const EventProfile& p) {
  nlohmann::json by_event = nlohmann::json::object();
  for (int k = 0; k < EventProfile::kKinds; ++k) {
    const EventProfile::PerKind& e = p.kind[k];
    by_event[EventProfile::kNames[k]] = {{"events", e.events},
                                         {"predictions", e.predictions},
                                         {"pair_searches", e.pair_searches},
                                         {"capture_searches", e.capture_searches},
                                         {"seconds", e.seconds}};
  }
  nlohmann::json bins = nlohmann::json::array();
  for (int b = 0; b < EventProfile::kBins; ++b) {
    const EventProfile::Bin& x = p.bin[b];
    auto work = [](const EventProfile::Work& w) {
      return nlohmann::json{{"searches", w.searches},
                            {"work", w.work},
                            {"exact_distances", w.exact_distances},
                            {"plane_evaluations", w.plane_evaluations},
                            {"seconds", w.seconds}};
    };
    nlohmann::json row = work(x.all);
    row["max_work"] = b < EventProfile::kBins - 1 ? nlohmann::json(EventProfile::kWorkBins[b]) : nlohmann::json(nullptr);
    row["contacts"] = x.found.searches;
    row["found"] = work(x.found);
    bins.push_back(row);
  }
  return {{"by_event", by_event}, {"pair_searches_by_work", bins}};
}

}  // namespace

void add_observables_json(nlohmann::json& j, const Observables& o) {
  j["N_t"] = o.N_t;
  j["N_tar"] = o.N_tar;
  j["N_viab"] = o.N_viab;
  j["N_nv1"] = o.n_nv1;
  j["N_nv2"] = o.n_nv2;
  j["N_nv3"] = o.n_nv3;
  j["N_cyc"] = o.N_cyc;
  nlohmann::json rings = nlohmann::json::object();
  for (const auto& [m, count] : o.rings) rings[std::to_string(m)] = count;
  j["rings"] = rings;
  j["Phi_obj"] = o.Phi_obj;
  j["Phi_viab"] = o.Phi_viab;
  j["S4"] = o.S4 ? nlohmann::json(*o.S4) : nlohmann::json(nullptr);
  j["M_mono"] = o.M_mono;
  j["M_mono_S"] = o.M_mono_S;
  j["M_mono_L"] = o.M_mono_L;
  j["tau_tar"] = o.tau_tar;
  j["tau_tar_censored"] = o.tau_tar_censored;
}

nlohmann::json run_replicate(const SimParams& params, std::uint64_t seed, std::uint64_t replicate,
                             const ReplicateIo& io) {
  const auto start = std::chrono::steady_clock::now();
  SceneReport scene;
  BodyStore bodies = build_scene(params, seed, replicate, &scene);
  Simulation sim(params, std::move(bodies));
  std::unique_ptr<Validator> validator;
  if (params.run.validate) {
    validator = std::make_unique<Validator>(sim);
    sim.set_validator(validator.get());
  }
  sim.set_stop_flag(io.stop);
  sim.enable_profile(io.profile);
  const Termination term = sim.run();
  if (!io.snapshot_path.empty()) write_snapshot(sim, params, seed, replicate, io.snapshot_path);
  if (!io.series_path.empty()) write_series(sim, io.series_path);
  if (io.series) *io.series = sim.monitor().samples();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const MechanicalTotals totals = mechanical_totals(sim.bodies(), sim.time());
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
  j["memo_resumed"] = s.memo_resumed;
  j["tc_collisions"] = s.tc_collisions;
  j["floored_contacts"] = s.floored;
  j["stick_contacts"] = s.stick;
  j["slide_contacts"] = s.slide;
  j["ca_steps"] = s.ca_steps;
  j["plane_evaluations"] = s.plane_evaluations;
  {
    const Predictor::SearchCounts& sc = sim.predictor_counts();
    j["ca_by_kind"] = {{"capture", sc.capture}, {"cluster_pair", sc.cluster_pair}, {"cluster_wall", sc.cluster_wall},
                       {"cell", sc.cell}, {"cluster_pair_capsule", sc.cluster_pair_capsule},
                       {"pair_capsule", sc.pair_capsule}};
  }
  if (params.compliant.enabled() && params.bonding.enabled) {
    j["compliant"] = {{"slices", s.slices},           {"slice_cuts", s.slice_cuts},
                      {"relaxed", s.relaxed},         {"woken", s.woken}, {"bursts", s.bursts},
                      {"sundials_steps", s.sundials_steps}, {"sundials_rhs", s.sundials_rhs},
                      {"sundials_seconds", s.sundials_seconds}};
  }
  const bool articulated = articulated_bonds(params);
  if (articulated) {
    j["articulated"] = {{"rigid_formations", s.joint_rigid},
                        {"articulated_formations", s.joint_articulated},
                        {"slices", s.slices},
                        {"slice_cuts", s.slice_cuts},
                        {"projections", s.projections},
                        {"dropped_held_rows", s.dropped_rows},
                        {"released_held_rows", s.released_rows},
                        {"readmitted_held_rows", s.readmitted_rows},
                        {"failed_slices", s.failed_slices},
                        {"max_released_residual", s.released_residual},
                        {"max_joint_residual", s.joint_residual},
                        {"max_residual_after_projection", s.joint_residual_after},
                        {"max_cut_residual", s.cut_residual},
                        {"max_projection", s.projection_size},
                        {"sundials_steps", s.sundials_steps},
                        {"sundials_rhs", s.sundials_rhs},
                        {"sundials_seconds", s.sundials_seconds}};
    const Simulation::ClusterShare share = sim.cluster_share();
    j["articulated"]["clusters_at_end"] = {{"rigid", share.rigid},
                                           {"rigid_bodies", share.rigid_bodies},
                                           {"articulated", share.articulated},
                                           {"articulated_bodies", share.articulated_bodies}};
  }
  j["t_end"] = sim.time();
  j["termination"] = to_string(term);
  if (term == Termination::Error) j["error"] = sim.error();
  j["wall_seconds"] = wall;
  j["events_per_second"] = wall > 0 ? static_cast<double>(s.events) / wall : 0.0;
  j["energy"] = {{"translational", totals.translational}, {"rotational", totals.rotational}};
  j["momentum"] = {totals.momentum.x(), totals.momentum.y(), totals.momentum.z()};
  {
    const EnergyBudget e = sim.energy_budget();
    j["energy_budget"] = {{"initial", e.initial},       {"bonds_in", e.bonds_in},   {"kinetic", e.kinetic},
                          {"potential", e.potential},   {"lost_contacts", e.contacts},
                          {"lost_rigid_merges", e.rigid_merges}, {"lost_relaxed", e.relaxed},
                          {"lost_bursts", e.bursts},    {"lost_dampers", e.dampers}};
    if (articulated) {
      j["energy_budget"]["lost_joint_impulses"] = e.joint_impulses;
      j["energy_budget"]["lost_projections"] = e.projections;
    }
  }
  // The study's observables (MODEL.md, "Observables"), at the final time.
  const Observables o = sim.graph().observables(sim.time());
  j["captures"] = s.captures;
  j["bonds"] = s.bonds;
  j["closure_bonds"] = s.closure_bonds;
  j["rejected"] = {{"valency", s.rejected_valency}, {"angle", s.rejected_angle}, {"coplanarity", s.rejected_coplanarity}};
  add_observables_json(j, o);
  if (term == Termination::SteadyState) {
    const MserResult& m = sim.monitor().result();
    j["mser"] = {{"truncation", m.truncation}, {"batches", m.batches}, {"samples", sim.monitor().samples().size()}};
  }
  if (io.profile) j["profile"] = profile_json(sim.profile());
  if (validator) {
    const ValidationReport& r = validator->report();
    j["validation"] = {{"checks", r.checks},
                       {"overlaps", r.overlaps},
                       {"missed_captures", r.missed_captures},
                       {"max_momentum_error", r.max_momentum_error},
                       {"max_angular_momentum_error", r.max_angular_momentum_error},
                       {"max_energy_error", r.max_energy_error},
                       {"max_axis_error", r.max_axis_error},
                       {"energy_conserving", validator->energy_conserving()}};
  }
  return j;
}

ReplicateRecord to_record(const nlohmann::json& j) {
  const std::string term = j.at("termination").get<std::string>();
  const bool ok = term == "steady_state" || term == "t_max" || term == "no_bond_possible";
  const std::string error = j.contains("error")       ? j["error"].get<std::string>()
                            : term == "event_budget" ? "event budget run.max_events exhausted"
                                                     : "";
  ReplicateRecord r = blank_record(j.at("replicate").get<std::uint64_t>(), j.at("seed").get<std::uint64_t>(),
                                   ok ? RecordStatus::Ok : RecordStatus::Failed, term.c_str(), error);
  r.t_end = j.at("t_end").get<double>();
  r.events = j.at("events").get<std::uint64_t>();
  r.wall_seconds = j.at("wall_seconds").get<double>();
  r.N_t = j.at("N_t").get<std::int32_t>();
  r.N_tar = j.at("N_tar").get<std::int32_t>();
  r.N_viab = j.at("N_viab").get<std::int32_t>();
  r.N_nv1 = j.at("N_nv1").get<std::int32_t>();
  r.N_nv2 = j.at("N_nv2").get<std::int32_t>();
  r.N_nv3 = j.at("N_nv3").get<std::int32_t>();
  r.N_cyc = j.at("N_cyc").get<std::int32_t>();
  r.Phi_obj = j.at("Phi_obj").get<double>();
  r.Phi_viab = j.at("Phi_viab").get<double>();
  r.S4 = j.at("S4").is_null() ? std::numeric_limits<double>::quiet_NaN() : j["S4"].get<double>();
  r.M_mono = j.at("M_mono").get<double>();
  r.M_mono_S = j.at("M_mono_S").get<double>();
  r.M_mono_L = j.at("M_mono_L").get<double>();
  r.tau_tar = j.at("tau_tar").get<double>();
  r.tau_tar_censored = j.at("tau_tar_censored").get<bool>() ? 1 : 0;
  for (const auto& [key, count] : j.at("rings").items()) {
    const int m = std::stoi(key);
    const int n = count.get<int>();
    if (m < RingHistogram::kMinBinned) r.ring_2 += n;
    else if (m > RingHistogram::kMaxBinned) r.ring_over += n;
    else r.ring[m - RingHistogram::kMinBinned] += n;
  }
  r.collisions = j.at("collisions").get<std::uint64_t>();
  r.captures = j.at("captures").get<std::uint64_t>();
  r.bonds = j.at("bonds").get<std::int32_t>();
  r.closure_bonds = j.at("closure_bonds").get<std::int32_t>();
  r.mser_truncation = j.contains("mser") ? j["mser"].at("truncation").get<std::int64_t>() : -1;
  r.packing_fraction = j.at("packing_fraction").get<double>();
  r.mixing = j.at("mixing").get<double>();
  if (j.contains("articulated")) {
    const nlohmann::json& a = j["articulated"];
    r.failed_slices = a.at("failed_slices").get<std::int64_t>();
    r.released_held_rows = a.at("released_held_rows").get<std::int64_t>();
    r.readmitted_held_rows = a.at("readmitted_held_rows").get<std::int64_t>();
    r.max_residual_after_projection = a.at("max_residual_after_projection").get<double>();
    r.max_cut_residual = a.at("max_cut_residual").get<double>();
    r.max_released_residual = a.at("max_released_residual").get<double>();
    r.max_projection = a.at("max_projection").get<double>();
    r.end_rigid_bodies = a.at("clusters_at_end").at("rigid_bodies").get<std::int32_t>();
    r.end_articulated_bodies = a.at("clusters_at_end").at("articulated_bodies").get<std::int32_t>();
  }
  return r;
}

void add_replicate_command(CLI::App& app, ReplicateOptions& opt) {
  CLI::App* cmd = app.add_subcommand("replicate",
                                     "Run one replicate to steady state (or t_max) and print the study's observables "
                                     "and its event statistics.");
  cmd->footer(
      "Examples:\n"
      "  ringsim replicate --seed 7                       built-in defaults = Scenario 4 (300 + 300, both filters, rigid)\n"
      "  ringsim replicate jobs/scenarios/1-baseline.toml --seed 7 --json\n"
      "  ringsim replicate --seed 1 --set run.t_max=50 --set geometry.boundary=periodic\n"
      "  ringsim replicate --seed 1 --validate --set run.t_max=10   check invariants after every event\n"
      "  ringsim replicate jobs/scenarios/4-passive-selection.toml --seed 3 --snapshot final.xyz\n"
      "      then: /usr/bin/python3 scripts/render_snapshot.py final.xyz -o final.png\n"
      "  ringsim replicate --seed 2 --series nt.txt && ringsim mser nt.txt   steady-state analysis of N_t(t)\n"
      "  ringsim replicate jobs/scenarios/4-passive-selection.toml --seed 1 --json --profile   where the time goes\n"
      "Configuration keys and ranges: docs/CONFIG.md (or `ringsim keys`).\n"
      "Exit codes: 0 done; 1 configuration or command-line error (also an unusable --snapshot or --series\n"
      "path, checked before the run); 2 the scene cannot be built (e.g. too many bodies for the box);\n"
      "3 simulation error (the output is still printed, termination \"error\") or stdout not writable.");
  cmd->add_option("scenario", opt.scenario, "Scenario TOML file listing deviations from the defaults (optional)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--seed,-s", opt.seed, "Base seed of the random streams, an integer in [0, 2^64 - 1]")
      ->required()
      ->check(unsigned64());
  cmd->add_option("--replicate", opt.replicate,
                  "Replicate index (with --seed, keys every random stream), an integer in [0, 2^64 - 1]")
      ->check(unsigned64());
  cmd->add_option("--set", opt.overrides, "Override one key: SECTION.KEY=VALUE (repeatable)")
      ->expected(1)
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_flag("--json", opt.json, "Print one JSON object instead of a table");
  cmd->add_flag("--validate", opt.validate, "Validation mode: check overlaps and conservation laws after every event");
  cmd->add_option("--snapshot", opt.snapshot,
                  "Write the final configuration to FILE: extended XYZ (OVITO), or legacy VTK (ParaView) when FILE "
                  "ends in .vtk; render with scripts/render_snapshot.py");
  cmd->add_option("--series", opt.series,
                  "Write the sampled N_t(t) series (one value per line, every run.sample_interval from t = 0) to "
                  "FILE; inspect it with `ringsim mser FILE`");
  cmd->add_flag("--profile", opt.profile,
                "Also report where the time went: per kind of event (collision, stale, wall, relocation, slice) its "
                "events, predictions, pair and capture searches and wall seconds, and the pair searches binned by "
                "their work, with their exact distances and plane evaluations, all of them and those that found a "
                "contact (docs/OUTPUT.md, \"profile\"); the events are the same, the run 2-5 % slower");
}

int replicate_main(const ReplicateOptions& opt, std::ostream& out) {
  std::vector<std::string> overrides = opt.overrides;
  if (opt.validate) overrides.push_back("run.validate=true");
  const SimParams params = load_config_file(opt.scenario, overrides);
  // Checked before the run, so a bad path does not cost the replicate; the
  // writes after the run still report their own failures.
  if (!opt.snapshot.empty()) check_output_path(opt.snapshot, "--snapshot");
  if (!opt.series.empty()) check_output_path(opt.series, "--series");
  ReplicateIo io{opt.snapshot, opt.series};
  io.profile = opt.profile;
  const nlohmann::json j = run_replicate(params, opt.seed, opt.replicate, io);
  if (opt.json) {
    out << j.dump() << '\n';
  } else {
    print_replicate_report(j, out);
  }
  return j["termination"] == "error" ? 3 : 0;
}

}  // namespace ringsim
