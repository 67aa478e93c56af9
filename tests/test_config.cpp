// Scenario configuration: defaults, file + overrides, every class of bad
// input (message names key, value and range), did-you-mean, canonical TOML
// round trip.

#include <gtest/gtest.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/interaction_range.hpp"
#include "core/scene.hpp"
#include "core/simulation.hpp"
#include "ensemble/config.hpp"

namespace ringsim {
namespace {

// Exact field-by-field equality (doubles compared bitwise-equal by value).
void expect_same(const SimParams& a, const SimParams& b) {
  EXPECT_EQ(a.geometry.sphere_radius, b.geometry.sphere_radius);
  EXPECT_EQ(a.geometry.linker_radius, b.geometry.linker_radius);
  EXPECT_EQ(a.geometry.linker_length, b.geometry.linker_length);
  EXPECT_EQ(a.geometry.box_length, b.geometry.box_length);
  EXPECT_EQ(a.geometry.boundary, b.geometry.boundary);
  EXPECT_EQ(a.geometry.density, b.geometry.density);
  EXPECT_EQ(a.contact.restitution_sphere, b.contact.restitution_sphere);
  EXPECT_EQ(a.contact.restitution_linker, b.contact.restitution_linker);
  EXPECT_EQ(a.contact.restitution_wall, b.contact.restitution_wall);
  EXPECT_EQ(a.contact.static_friction_sphere, b.contact.static_friction_sphere);
  EXPECT_EQ(a.contact.static_friction_linker, b.contact.static_friction_linker);
  EXPECT_EQ(a.contact.static_friction_wall, b.contact.static_friction_wall);
  EXPECT_EQ(a.contact.dynamic_friction_sphere, b.contact.dynamic_friction_sphere);
  EXPECT_EQ(a.contact.dynamic_friction_linker, b.contact.dynamic_friction_linker);
  EXPECT_EQ(a.contact.dynamic_friction_wall, b.contact.dynamic_friction_wall);
  EXPECT_EQ(a.contact.restitution_rule, b.contact.restitution_rule);
  EXPECT_EQ(a.contact.friction_rule, b.contact.friction_rule);
  EXPECT_EQ(a.init.spheres, b.init.spheres);
  EXPECT_EQ(a.init.linkers, b.init.linkers);
  EXPECT_EQ(a.init.alpha, b.init.alpha);
  EXPECT_EQ(a.init.velocity, b.init.velocity);
  EXPECT_EQ(a.init.v_max, b.init.v_max);
  EXPECT_EQ(a.init.omega_max, b.init.omega_max);
  EXPECT_EQ(a.init.temperature, b.init.temperature);
  EXPECT_EQ(a.bonding.enabled, b.bonding.enabled);
  EXPECT_EQ(a.bonding.capture_distance, b.bonding.capture_distance);
  EXPECT_EQ(a.bonding.capture_site, b.bonding.capture_site);
  EXPECT_EQ(a.bonding.sphere_valency, b.bonding.sphere_valency);
  EXPECT_EQ(a.bonding.end_valency, b.bonding.end_valency);
  EXPECT_EQ(a.bonding.angle_filter, b.bonding.angle_filter);
  EXPECT_EQ(a.bonding.theta0_deg, b.bonding.theta0_deg);
  EXPECT_EQ(a.bonding.dtheta_deg, b.bonding.dtheta_deg);
  EXPECT_EQ(a.bonding.coplanarity_filter, b.bonding.coplanarity_filter);
  EXPECT_EQ(a.bonding.dphi_deg, b.bonding.dphi_deg);
  EXPECT_EQ(a.bonding.coplanarity_mode, b.bonding.coplanarity_mode);
  EXPECT_EQ(a.bonding.exclusions, b.bonding.exclusions);
  EXPECT_EQ(a.compliant.k, b.compliant.k);
  EXPECT_EQ(a.compliant.c, b.compliant.c);
  EXPECT_EQ(a.compliant.k_omega, b.compliant.k_omega);
  EXPECT_EQ(a.compliant.c_omega, b.compliant.c_omega);
  EXPECT_EQ(a.compliant.target_gap, b.compliant.target_gap);
  EXPECT_EQ(a.run.t_max, b.run.t_max);
  EXPECT_EQ(a.run.steady_state, b.run.steady_state);
  EXPECT_EQ(a.run.sample_interval, b.run.sample_interval);
  EXPECT_EQ(a.run.mser_batch, b.run.mser_batch);
  EXPECT_EQ(a.run.mser_min_samples, b.run.mser_min_samples);
  EXPECT_EQ(a.run.mser_check_every, b.run.mser_check_every);
  EXPECT_EQ(a.run.max_events, b.run.max_events);
  EXPECT_EQ(a.run.contact_tolerance, b.run.contact_tolerance);
  EXPECT_EQ(a.run.tc_time, b.run.tc_time);
  EXPECT_EQ(a.run.min_separation_speed, b.run.min_separation_speed);
  EXPECT_EQ(a.run.sphere_candidates, b.run.sphere_candidates);
  EXPECT_EQ(a.run.cell_size, b.run.cell_size);
  EXPECT_EQ(a.run.partner_horizon, b.run.partner_horizon);
  EXPECT_EQ(a.run.validate, b.run.validate);
  EXPECT_EQ(a.run.queue, b.run.queue);
}

// The ConfigError message of loading `text` with `overrides`, or "" if none.
std::string error_of(const std::string& text, const std::vector<std::string>& overrides = {}) {
  try {
    load_config(text, overrides, "test.toml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

#define EXPECT_CONTAINS(haystack, needle) \
  EXPECT_NE(std::string(haystack).find(needle), std::string::npos) << "message: " << (haystack)

TEST(Config, ToStringNames) {
  EXPECT_STREQ(to_string(Boundary::Reflective), "reflective");
  EXPECT_STREQ(to_string(Boundary::Periodic), "periodic");
  EXPECT_STREQ(to_string(CombineRule::Min), "min");
  EXPECT_STREQ(to_string(CombineRule::Max), "max");
  EXPECT_STREQ(to_string(CombineRule::Product), "product");
  EXPECT_STREQ(to_string(CombineRule::Mean), "mean");
  EXPECT_STREQ(to_string(VelocityInit::Uniform), "uniform");
  EXPECT_STREQ(to_string(VelocityInit::Thermal), "thermal");
  EXPECT_STREQ(to_string(QueueKind::Fast), "fast");
  EXPECT_STREQ(to_string(QueueKind::Reference), "reference");
  EXPECT_STREQ(to_string(CoplanarityMode::CisOrTrans), "cis-or-trans");
  EXPECT_STREQ(to_string(CoplanarityMode::Cis), "cis");
}

TEST(Config, EmptyTextGivesStudyDefaults) {
  const SimParams p = load_config("", {}, "empty.toml");
  expect_same(p, SimParams{});
  // The study's tables (MODEL.md G, I, D).
  EXPECT_EQ(p.geometry.sphere_radius, 1.0);
  EXPECT_EQ(p.geometry.linker_length, 4.0);
  EXPECT_EQ(p.geometry.box_length, 50.0);
  EXPECT_EQ(p.geometry.boundary, Boundary::Reflective);
  EXPECT_EQ(p.contact.restitution_rule, CombineRule::Min);
  EXPECT_EQ(p.contact.friction_rule, CombineRule::Product);
  EXPECT_EQ(p.init.spheres, 300);
  EXPECT_EQ(p.init.linkers, 300);
  EXPECT_EQ(p.run.t_max, 5000.0);
  // Bonding: the study's Scenario 4 (= 6-2), MODEL.md "Capture and bond formation".
  EXPECT_TRUE(p.bonding.enabled);
  EXPECT_EQ(p.bonding.capture_distance, 0.1);
  EXPECT_EQ(p.bonding.capture_site, CaptureSite::EndFace);
  EXPECT_EQ(p.bonding.sphere_valency, 2);
  EXPECT_EQ(p.bonding.end_valency, 1);
  EXPECT_TRUE(p.bonding.angle_filter);
  EXPECT_EQ(p.bonding.theta0_deg, 90.0);
  EXPECT_EQ(p.bonding.dtheta_deg, 5.0);
  EXPECT_TRUE(p.bonding.coplanarity_filter);
  EXPECT_EQ(p.bonding.dphi_deg, 5.0);
  EXPECT_EQ(p.bonding.coplanarity_mode, CoplanarityMode::CisOrTrans);
  // Steady state: MSER-5 (MODEL.md "Protocol").
  EXPECT_TRUE(p.run.steady_state);
  EXPECT_EQ(p.run.sample_interval, 1.0);
  EXPECT_EQ(p.run.mser_batch, 5);
  EXPECT_EQ(p.run.mser_min_samples, 200);
  EXPECT_EQ(p.run.mser_check_every, 50);
  EXPECT_NO_THROW(validate(p));
}

TEST(Config, EmptyPathGivesDefaultsPlusOverrides) {
  expect_same(load_config_file("", {}), SimParams{});
  const SimParams p = load_config_file("", {"init.spheres=10"});
  EXPECT_EQ(p.init.spheres, 10);
}

TEST(Config, ScenarioMetadata) {
  const Scenario s = load_scenario("name = \"baseline\"\ndescription = \"valency only\"\n", {}, "s.toml");
  EXPECT_EQ(s.name, "baseline");
  EXPECT_EQ(s.description, "valency only");
  expect_same(s.params, SimParams{});
  EXPECT_EQ(load_scenario("name = \"a\"", {"name=b c"}, "s.toml").name, "b c");
  EXPECT_EQ(load_scenario("", {"name=2024"}, "s.toml").name, "2024");
  EXPECT_EQ(load_scenario("", {"description=\"quoted\""}, "s.toml").description, "quoted");
  const std::string e = error_of("name = 3");
  EXPECT_CONTAINS(e, "name = 3: expected a string");
}

TEST(Config, FileDeviationsAndOverrides) {
  const std::string text = R"(
[geometry]
box_length = 30
boundary = "periodic"

[contact]
restitution_sphere = 0.9
static_friction_linker = 0.5
dynamic_friction_linker = 0.25
restitution_rule = "mean"

[init]
spheres = 150
linkers = 150.0   # an integral float is accepted
velocity = "thermal"
temperature = 2.5

[run]
max_events = 1_000_000
validate = true
queue = "reference"
)";
  const SimParams p = load_config(text,
                                  {"geometry.box_length=40", "init.linkers = 120", "run.queue=fast",
                                   "contact.friction_rule=\"max\"", "run.validate=false",
                                   "init.alpha=0.5", "run.tc_time=0"},
                                  "scenario.toml");
  EXPECT_EQ(p.geometry.box_length, 40.0);  // override wins over file
  EXPECT_EQ(p.geometry.boundary, Boundary::Periodic);
  EXPECT_EQ(p.contact.restitution_sphere, 0.9);
  EXPECT_EQ(p.contact.static_friction_linker, 0.5);
  EXPECT_EQ(p.contact.dynamic_friction_linker, 0.25);
  EXPECT_EQ(p.contact.restitution_rule, CombineRule::Mean);
  EXPECT_EQ(p.contact.friction_rule, CombineRule::Max);
  EXPECT_EQ(p.init.spheres, 150);
  EXPECT_EQ(p.init.linkers, 120);
  EXPECT_EQ(p.init.velocity, VelocityInit::Thermal);
  EXPECT_EQ(p.init.temperature, 2.5);
  EXPECT_EQ(p.init.alpha, 0.5);
  EXPECT_EQ(p.run.max_events, 1000000);
  EXPECT_FALSE(p.run.validate);
  EXPECT_EQ(p.run.queue, QueueKind::Fast);
  EXPECT_EQ(p.run.tc_time, 0.0);
  // Untouched keys keep their defaults.
  EXPECT_EQ(p.geometry.sphere_radius, 1.0);
  EXPECT_EQ(p.run.t_max, 5000.0);
}

TEST(Config, DottedKeysAndInlineTables) {
  const SimParams p = load_config("geometry.box_length = 20\ninit = { spheres = 7 }\n", {}, "d.toml");
  EXPECT_EQ(p.geometry.box_length, 20.0);
  EXPECT_EQ(p.init.spheres, 7);
}

TEST(Config, LaterOverrideWins) {
  const SimParams p = load_config("", {"init.spheres=1", "init.spheres=2"}, "x");
  EXPECT_EQ(p.init.spheres, 2);
}

TEST(Config, FileOnDisk) {
  const std::string path = ::testing::TempDir() + "ringsim_test_config.toml";
  {
    std::ofstream out(path);
    out << "[run]\nt_max = 12.5\n";
  }
  const SimParams p = load_config_file(path, {"run.cell_size=3"});
  EXPECT_EQ(p.run.t_max, 12.5);
  EXPECT_EQ(p.run.cell_size, 3.0);
  {
    std::ofstream out(path);
    out << "[run]\nt_max = -1\n";
  }
  try {
    load_config_file(path, {});
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_CONTAINS(e.what(), path + ":2:9: run.t_max = -1: must be > 0");
  }
  std::remove(path.c_str());
}

TEST(Config, MissingFileNamesPath) {
  const std::string path = "/nonexistent/dir/scenario_42.toml";
  try {
    load_config_file(path, {});
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_CONTAINS(e.what(), path);
    EXPECT_CONTAINS(e.what(), "not found");
  }
}

// ---- ranges ---------------------------------------------------------------------

TEST(Config, RangeErrorsNameKeyValueAndRange) {
  struct Case {
    std::string text;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {"[geometry]\nbox_length = -3", "geometry.box_length = -3: must be > 0"},
      {"[geometry]\nsphere_radius = 0", "geometry.sphere_radius = 0: must be > 0"},
      {"[geometry]\nlinker_radius = -0.5", "geometry.linker_radius = -0.5: must be > 0"},
      {"[geometry]\nlinker_length = 0.0", "geometry.linker_length = 0: must be > 0"},
      {"[geometry]\ndensity = -1", "geometry.density = -1: must be > 0"},
      {"[geometry]\ndensity = nan", "geometry.density = nan: must be a finite number > 0"},
      {"[geometry]\nbox_length = inf", "geometry.box_length = inf: must be a finite number > 0"},
      {"[contact]\nrestitution_sphere = 1.5", "contact.restitution_sphere = 1.5: must be in [0, 1]"},
      {"[contact]\nrestitution_linker = -0.1", "contact.restitution_linker = -0.1: must be in [0, 1]"},
      {"[contact]\nrestitution_wall = 2", "contact.restitution_wall = 2: must be in [0, 1]"},
      {"[contact]\nstatic_friction_sphere = -1", "contact.static_friction_sphere = -1: must be >= 0"},
      {"[contact]\nstatic_friction_wall = -0.5", "contact.static_friction_wall = -0.5: must be >= 0"},
      {"[contact]\ndynamic_friction_linker = -2", "contact.dynamic_friction_linker = -2: must be >= 0"},
      {"[init]\nspheres = -1", "init.spheres = -1: must be an integer in [0, 1e+06]"},
      {"[init]\nlinkers = -5", "init.linkers = -5: must be an integer in [0, 1e+06]"},
      {"[init]\nspheres = 3000000000", "init.spheres = 3000000000: must be an integer in [0, 1e+06]"},
      {"[init]\nalpha = 1.01", "init.alpha = 1.01: must be in [0, 1]"},
      {"[init]\nv_max = -1", "init.v_max = -1: must be >= 0"},
      {"[init]\nomega_max = -0.1", "init.omega_max = -0.1: must be >= 0"},
      {"[init]\ntemperature = 0", "init.temperature = 0: must be > 0"},
      {"[run]\nt_max = 0", "run.t_max = 0: must be > 0"},
      {"[run]\nmax_events = -1", "run.max_events = -1: must be an integer >= 0"},
      {"[run]\ncontact_tolerance = 0", "run.contact_tolerance = 0: must be in [1e-10, 0.001]"},
      {"[run]\ncontact_tolerance = 1e-11", "run.contact_tolerance = 1e-11: must be in [1e-10, 0.001]"},
      {"[run]\ncontact_tolerance = 0.01", "run.contact_tolerance = 0.01: must be in [1e-10, 0.001]"},
      {"[run]\ntc_time = -1e-7", "run.tc_time = -1e-07: must be >= 0"},
      {"[run]\ncell_size = -2", "run.cell_size = -2: must be >= 0"},
      {"[geometry]\nboundary = \"wall\"", "geometry.boundary = \"wall\": must be one of reflective, periodic"},
      {"[contact]\nrestitution_rule = \"median\"",
       "contact.restitution_rule = \"median\": must be one of min, max, product, mean"},
      {"[contact]\nfriction_rule = \"Min\"", "contact.friction_rule = \"Min\": must be one of min, max, product, mean"},
      {"[init]\nvelocity = \"gaussian\"", "init.velocity = \"gaussian\": must be one of uniform, thermal"},
      {"[run]\nqueue = \"slow\"", "run.queue = \"slow\": must be one of fast, reference"},
      {"[bonding]\ncapture_distance = 0", "bonding.capture_distance = 0: must be > 0"},
      {"[bonding]\ncapture_distance = -0.1", "bonding.capture_distance = -0.1: must be > 0"},
      {"[bonding]\nsphere_valency = -1", "bonding.sphere_valency = -1: must be an integer >= 0"},
      {"[bonding]\nend_valency = 2", "bonding.end_valency = 2: must be an integer in [0, 1]"},
      {"[bonding]\nend_valency = -1", "bonding.end_valency = -1: must be an integer in [0, 1]"},
      {"[bonding]\ntheta0_deg = 180.5", "bonding.theta0_deg = 180.5: must be in [0, 180]"},
      {"[bonding]\ntheta0_deg = -1", "bonding.theta0_deg = -1: must be in [0, 180]"},
      {"[bonding]\ndtheta_deg = 181", "bonding.dtheta_deg = 181: must be in [0, 180]"},
      {"[bonding]\ndtheta_deg = -0.5", "bonding.dtheta_deg = -0.5: must be in [0, 180]"},
      {"[bonding]\ndphi_deg = 90.01", "bonding.dphi_deg = 90.01: must be in [0, 90]"},
      {"[bonding]\ndphi_deg = -5", "bonding.dphi_deg = -5: must be in [0, 90]"},
      {"[bonding]\ncoplanarity_mode = \"trans\"",
       "bonding.coplanarity_mode = \"trans\": must be one of cis-or-trans, cis"},
      {"[run]\nsample_interval = 0", "run.sample_interval = 0: must be > 0"},
      {"[run]\nsample_interval = nan", "run.sample_interval = nan: must be a finite number > 0"},
      {"[run]\nmser_batch = 0", "run.mser_batch = 0: must be an integer >= 1"},
      {"[run]\nmser_min_samples = 1", "run.mser_min_samples = 1: must be an integer >= 2"},
      {"[run]\nmser_check_every = 0", "run.mser_check_every = 0: must be an integer >= 1"},
  };
  for (const Case& c : cases) {
    const std::string e = error_of(c.text);
    EXPECT_CONTAINS(e, c.expected);
    EXPECT_CONTAINS(e, "test.toml:2:");  // source and line of the value
  }
  // Boundary values are valid.
  EXPECT_NO_THROW(load_config("[contact]\nrestitution_sphere = 0\nrestitution_wall = 1\n"
                              "[init]\nalpha = 0\nv_max = 0\nomega_max = 0\n"
                              "[run]\ncontact_tolerance = 1e-3\ncell_size = 0\ntc_time = 0\nmax_events = 0",
                              {}, "ok.toml"));
  EXPECT_NO_THROW(load_config("[bonding]\nsphere_valency = 0\nend_valency = 0\ntheta0_deg = 0\ndtheta_deg = 0\n"
                              "dphi_deg = 0\n[run]\nmser_batch = 1\nmser_min_samples = 5\nmser_check_every = 1",
                              {}, "ok.toml"));
  EXPECT_NO_THROW(load_config("[bonding]\nend_valency = 1\ntheta0_deg = 180\ndtheta_deg = 180\ndphi_deg = 90",
                              {}, "ok.toml"));
}

TEST(Config, RangeErrorsFromOverrides) {
  const std::string e = error_of("", {"geometry.box_length=-3"});
  EXPECT_CONTAINS(e, "--set: geometry.box_length = -3: must be > 0");
  EXPECT_CONTAINS(error_of("", {"geometry.boundary=wall"}),
                  "geometry.boundary = \"wall\": must be one of reflective, periodic");
  EXPECT_CONTAINS(error_of("", {"init.spheres=-1"}), "init.spheres = -1: must be an integer in [0, 1e+06]");
}

TEST(Config, BondingKeys) {
  EXPECT_FALSE(load_config("[bonding]\nenabled = false", {}, "b.toml").bonding.enabled);
  EXPECT_TRUE(load_config("[bonding]\nenabled = true", {}, "b.toml").bonding.enabled);
  EXPECT_TRUE(load_config("", {"bonding.enabled=true"}, "b.toml").bonding.enabled);
  const std::string text = R"(
[bonding]
capture_distance = 0.25
capture_site = "end_point"
sphere_valency = 3
end_valency = 0
angle_filter = false
theta0_deg = 109.5
dtheta_deg = 2
coplanarity_filter = false
dphi_deg = 10
coplanarity_mode = "cis"
)";
  const SimParams p = load_config(text, {}, "b.toml");
  EXPECT_EQ(p.bonding.capture_distance, 0.25);
  EXPECT_EQ(p.bonding.capture_site, CaptureSite::EndPoint);
  EXPECT_EQ(p.bonding.sphere_valency, 3);
  EXPECT_EQ(p.bonding.end_valency, 0);
  EXPECT_FALSE(p.bonding.angle_filter);
  EXPECT_EQ(p.bonding.theta0_deg, 109.5);
  EXPECT_EQ(p.bonding.dtheta_deg, 2.0);
  EXPECT_FALSE(p.bonding.coplanarity_filter);
  EXPECT_EQ(p.bonding.dphi_deg, 10.0);
  EXPECT_EQ(p.bonding.coplanarity_mode, CoplanarityMode::Cis);
  // Overrides, bare and quoted enum names.
  EXPECT_EQ(load_config(text, {"bonding.coplanarity_mode=cis-or-trans"}, "b.toml").bonding.coplanarity_mode,
            CoplanarityMode::CisOrTrans);
  EXPECT_EQ(load_config("", {"bonding.coplanarity_mode=\"cis\""}, "b.toml").bonding.coplanarity_mode,
            CoplanarityMode::Cis);
  EXPECT_TRUE(load_config(text, {"bonding.angle_filter=true"}, "b.toml").bonding.angle_filter);
  EXPECT_EQ(load_config(text, {"bonding.capture_site=end_face"}, "b.toml").bonding.capture_site, CaptureSite::EndFace);
  EXPECT_CONTAINS(error_of("", {"bonding.capture_site=face"}),
                  "bonding.capture_site = \"face\": must be one of end_face, end_point");
  EXPECT_CONTAINS(error_of("", {"bonding.end_valency=2"}), "--set: bonding.end_valency = 2: must be an integer in [0, 1]");
  EXPECT_CONTAINS(error_of("", {"bonding.dphi_deg=91"}), "--set: bonding.dphi_deg = 91: must be in [0, 90]");
}

TEST(Config, SteadyStateKeys) {
  const SimParams p = load_config(
      "[run]\nsteady_state = false\nsample_interval = 0.5\nmser_batch = 10\nmser_min_samples = 50\n"
      "mser_check_every = 7\n",
      {}, "r.toml");
  EXPECT_FALSE(p.run.steady_state);
  EXPECT_EQ(p.run.sample_interval, 0.5);
  EXPECT_EQ(p.run.mser_batch, 10);
  EXPECT_EQ(p.run.mser_min_samples, 50);  // exactly 5 batches: allowed
  EXPECT_EQ(p.run.mser_check_every, 7);
  // A test needs 5 batch means: mser_min_samples >= 5 mser_batch.
  const std::string e = error_of("[run]\nmser_batch = 10\nmser_min_samples = 49");
  EXPECT_CONTAINS(e, "test.toml:3:20: run.mser_min_samples = 49: must be >= 5 x run.mser_batch = 50");
  EXPECT_CONTAINS(error_of("", {"run.mser_batch=101"}),
                  "--set: run.mser_min_samples = 200: must be >= 5 x run.mser_batch = 505");
}

TEST(Config, EnumDidYouMean) {
  EXPECT_CONTAINS(error_of("[bonding]\ncoplanarity_mode = \"cis-or-tran\""),
                  "bonding.coplanarity_mode = \"cis-or-tran\": must be one of cis-or-trans, cis; "
                  "did you mean \"cis-or-trans\"?");
  EXPECT_CONTAINS(error_of("", {"bonding.coplanarity_mode=cis_or_trans"}), "did you mean \"cis-or-trans\"?");
  EXPECT_CONTAINS(error_of("", {"bonding.coplanarity_mode=Cis"}), "did you mean \"cis\"?");
  EXPECT_CONTAINS(error_of("[contact]\nfriction_rule = \"Min\""), "did you mean \"min\"?");
  EXPECT_CONTAINS(error_of("[geometry]\nboundary = \"periodc\""), "did you mean \"periodic\"?");
  // Nothing close: the list of values only.
  const std::string e = error_of("[bonding]\ncoplanarity_mode = \"anything\"");
  EXPECT_CONTAINS(e, "must be one of cis-or-trans, cis");
  EXPECT_EQ(e.find("did you mean"), std::string::npos) << e;
}

// Compliant keys load and range-check; any spring > 0 is refused until the
// compliant force field is coupled to the event loop (core/compliant*.hpp).
TEST(Config, CompliantKeys) {
  const SimParams d;
  EXPECT_EQ(d.compliant.k, 0.0);
  EXPECT_EQ(d.compliant.k_omega, 0.0);
  EXPECT_FALSE(d.compliant.enabled());
  const SimParams p = load_config("[compliant]\nc = 100\nc_omega = 50\ntarget_gap = 0.05", {}, "c.toml");
  EXPECT_EQ(p.compliant.c, 100.0);
  EXPECT_EQ(p.compliant.c_omega, 50.0);
  EXPECT_EQ(p.compliant.target_gap, 0.05);
  EXPECT_CONTAINS(error_of("", {"compliant.c=-1"}), "--set: compliant.c = -1: must be >= 0");
  EXPECT_CONTAINS(error_of("", {"compliant.target_gap=-0.1"}), "compliant.target_gap = -0.1: must be >= 0");
  // Compliant bonds run; the integrator keys are checked.
  const SimParams c = load_config("[compliant]\nk = 1000\nc = 100\nmethod = \"bdf\"\nslice = 0.02", {}, "c.toml");
  EXPECT_TRUE(c.compliant.enabled());
  EXPECT_EQ(c.compliant.method, CompliantMethod::Bdf);
  EXPECT_EQ(c.compliant.slice, 0.02);
  EXPECT_CONTAINS(error_of("", {"compliant.method=rk4"}), "compliant.method");
  EXPECT_CONTAINS(error_of("", {"compliant.slice=0"}), "compliant.slice = 0: must be in [1e-04, 10]");
  EXPECT_EQ(load_config("[compliant]\nk = 1000\ntrack_tolerance = 0.001", {}, "t.toml").compliant.track_tolerance, 0.001);
  EXPECT_CONTAINS(error_of("", {"compliant.track_tolerance=-0.1"}), "compliant.track_tolerance = -0.1: must be >= 0");
  EXPECT_CONTAINS(error_of("", {"compliant.rtol=1"}), "compliant.rtol = 1");
  EXPECT_CONTAINS(error_of("", {"compliant.relax_energy=-1"}), "compliant.relax_energy = -1: must be >= 0");
  // Smooth spheres only: a compliant cluster keeps a sphere's spin constant.
  EXPECT_CONTAINS(error_of("[compliant]\nk = 1000\n[contact]\nstatic_friction_sphere = 0.5\ndynamic_friction_sphere = 0.3"),
                  "contact.static_friction_sphere = 0.5: must be 0 with compliant bonds");
  SimParams q;
  q.compliant.k = 1.0;
  q.contact.static_friction_sphere = 0.2;
  q.contact.dynamic_friction_sphere = 0.1;
  EXPECT_THROW(validate(q), ConfigError);
}

TEST(Config, OneTwoExclusionsOnlyWithArticulatedBonds) {
  EXPECT_EQ(load_config("[bonding]\nexclusions = \"1-2\"", {}, "x.toml").bonding.exclusions, Exclusions::OneTwo);
  EXPECT_EQ(load_config("", {}, "x.toml").bonding.exclusions, Exclusions::OneThree);
  EXPECT_CONTAINS(error_of("", {"bonding.exclusions=1-4"}), "bonding.exclusions");
  EXPECT_CONTAINS(error_of("", {"bonding.exclusions=1-2", "bonding.joint=welded"}),
                  "bonding.exclusions = 1-2: only with articulated rigid bonds");
  EXPECT_CONTAINS(error_of("", {"bonding.exclusions=1-2", "compliant.k=1000"}),
                  "bonding.exclusions = 1-2: only with articulated rigid bonds");
}

TEST(Config, CaptureDistanceBelowLinkerLength) {
  const std::string e = error_of("[bonding]\ncapture_distance = 4");
  EXPECT_CONTAINS(e, "test.toml:2:20: bonding.capture_distance = 4: must be < geometry.linker_length = 4");
  EXPECT_CONTAINS(error_of("[geometry]\nlinker_length = 0.05"),
                  "test.toml:2:17: bonding.capture_distance = 0.1: must be < geometry.linker_length = 0.05");
  EXPECT_NO_THROW(load_config("[bonding]\ncapture_distance = 3.999", {}, "x"));
  // With bonding off the rule still holds (a disabled capture band is still a setting).
  EXPECT_CONTAINS(error_of("", {"bonding.enabled=false", "bonding.capture_distance=5"}),
                  "--set: bonding.capture_distance = 5: must be < geometry.linker_length = 4");
}

TEST(Config, DynamicFrictionAboveStaticNamesBothKeys) {
  const std::string e = error_of("[contact]\nstatic_friction_sphere = 0.3\ndynamic_friction_sphere = 0.5");
  EXPECT_CONTAINS(e, "contact.dynamic_friction_sphere = 0.5");
  EXPECT_CONTAINS(e, "must be <= contact.static_friction_sphere = 0.3");
  EXPECT_CONTAINS(e, "test.toml:3:");
  EXPECT_CONTAINS(error_of("", {"contact.dynamic_friction_wall=0.1"}),
                  "contact.dynamic_friction_wall = 0.1: must be <= contact.static_friction_wall = 0");
  EXPECT_CONTAINS(error_of("[contact]\ndynamic_friction_linker = 0.2"), "contact.static_friction_linker");
  // Equal is fine.
  EXPECT_NO_THROW(load_config("[contact]\nstatic_friction_wall = 0.4\ndynamic_friction_wall = 0.4", {}, "f"));
}

TEST(Config, AtLeastOneBody) {
  const std::string e = error_of("[init]\nspheres = 0\nlinkers = 0");
  EXPECT_CONTAINS(e, "init.spheres + init.linkers = 0: must be >= 1");
  EXPECT_NO_THROW(load_config("[init]\nspheres = 0\nlinkers = 1", {}, "x"));
  EXPECT_NO_THROW(load_config("[init]\nspheres = 1\nlinkers = 0", {}, "x"));
}

TEST(Config, TheNumberOfSamplesIsBounded) {
  // t_max / sample_interval samples of N_t: 1e-300 overflowed the series
  // length, 1e-12 asked for terabytes.
  for (const char* v : {"1e-300", "1e-12", "0.0001"}) {
    const std::string e = error_of("", {std::string("run.sample_interval=") + v});
    EXPECT_CONTAINS(e, "--set: run.t_max / run.sample_interval = 5000 / ");
    EXPECT_CONTAINS(e, "must be <= 1e+07");
  }
  EXPECT_NO_THROW(load_config("", {"run.sample_interval=0.0005"}, "x"));  // exactly 1e7
  EXPECT_CONTAINS(error_of("", {"run.t_max=1e300"}), "run.t_max / run.sample_interval");
  // Without bonding no series is sampled: hard-body runs end on an event budget.
  EXPECT_EQ(error_of("", {"bonding.enabled=false", "run.t_max=1e12", "run.max_events=1000"}), "");
}

TEST(Config, BodyCountsAreBounded) {
  // 2147483647 spheres ended in "cannot create std::vector larger than max_size()".
  const std::string e = error_of("", {"init.spheres=2147483647"});
  EXPECT_CONTAINS(e, "init.spheres");
  EXPECT_CONTAINS(e, "2147483647");
  EXPECT_CONTAINS(e, "[0, 1e+06]");
  EXPECT_CONTAINS(error_of("", {"init.linkers=1000001"}), "init.linkers");
  EXPECT_EQ(error_of("", {"init.spheres=1000000", "geometry.box_length=1000"}), "");
}

TEST(Config, BoxMustHoldLargestBody) {
  // Default linker: bounding radius sqrt(1 + 2^2) = 2.236..., so l_B > 4.472...
  const std::string e = error_of("[geometry]\nbox_length = 4");
  EXPECT_CONTAINS(e, "geometry.box_length = 4: must be > 2 x the largest body bounding radius");
  EXPECT_CONTAINS(e, "4.47213595499958");
  EXPECT_CONTAINS(e, "linker");
  EXPECT_NO_THROW(load_config("[geometry]\nbox_length = 4.5", {}, "x"));
  // A big sphere is the largest body.
  const std::string e2 = error_of("[geometry]\nsphere_radius = 3\nbox_length = 6");
  EXPECT_CONTAINS(e2, "geometry.box_length = 6: must be > 2 x the largest body bounding radius = 6");
  EXPECT_CONTAINS(e2, "sphere");
  // Only species that are present count.
  EXPECT_NO_THROW(load_config("[geometry]\nbox_length = 3\n[init]\nlinkers = 0", {}, "x"));
}

// ---- periodic minimum box (core/interaction_range.hpp) ---------------------------

// Shortest round-trip text of x (the form messages and --set use).
std::string shortest(double x) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, res.ptr);
}

// One sphere and one linker of the default shapes (bonding on) in a periodic
// box of edge `box`, as --set overrides.
std::vector<std::string> periodic_pair(double box) {
  return {"geometry.boundary=periodic", "init.spheres=1", "init.linkers=1", "geometry.box_length=" + shortest(box)};
}

TEST(PeriodicMinimum, DefaultShapesCountContactCaptureToleranceAndSlack) {
  SimParams p;
  p.geometry.boundary = Boundary::Periodic;
  const InteractionRange r = interaction_range(p);
  // 2 x (2 sqrt(1 + 2^2) + 2 delta + 2 x 0.01): the linker's bounding sphere
  // (4.472) beats the capture range: the face's rim sqrt(h^2 + r_L^2) + r_S +
  // r_c = 3.336 (end_face), the end point h + r_S + r_c = 3.1 (end_point).
  EXPECT_DOUBLE_EQ(r.contact, 2.0 * std::sqrt(5.0));
  EXPECT_DOUBLE_EQ(r.capture, std::sqrt(5.0) + 1.1);
  p.bonding.capture_site = CaptureSite::EndPoint;
  EXPECT_DOUBLE_EQ(interaction_range(p).capture, 3.1);
  p.bonding.capture_site = CaptureSite::EndFace;
  EXPECT_DOUBLE_EQ(r.periodic_min_box(), 2.0 * (2.0 * std::sqrt(5.0) + 2e-9 + 0.02));
  EXPECT_NEAR(r.periodic_min_box(), 8.984271914, 1e-9);
  // Without bonding no capture and no cluster slack: 2 x (4.472 + 2 delta).
  p.bonding.enabled = false;
  EXPECT_NEAR(interaction_range(p).periodic_min_box(), 8.944271914, 1e-9);
}

TEST(PeriodicMinimum, BoxJustAboveLoadsAndTheSimulationConstructs) {
  const double min = interaction_range(load_config("", periodic_pair(50.0), "x")).periodic_min_box();
  const double above = std::nextafter(min, 2.0 * min);
  SimParams p;
  ASSERT_NO_THROW(p = load_config("", periodic_pair(above), "x"));
  EXPECT_EQ(p.geometry.box_length, above);
  EXPECT_NO_THROW(validate(p));
  EXPECT_NO_THROW(Simulation(p, build_scene(p, 1, 0, nullptr)));
  // The fuzz sweep's box, 8.95, lies between the old documented minimum
  // (8.944) and the run's: now a configuration error, not a run-time one.
  EXPECT_CONTAINS(error_of("", periodic_pair(8.95)), "geometry.box_length = 8.95: must be > " + shortest(min));
}

TEST(PeriodicMinimum, BoxJustBelowIsAConfigErrorNamingKeyValueAndBound) {
  const double min = interaction_range(load_config("", periodic_pair(50.0), "x")).periodic_min_box();
  const double below = std::nextafter(min, 0.0);
  const std::string e = error_of("", periodic_pair(below));
  EXPECT_CONTAINS(e, "--set: geometry.box_length = " + shortest(below) + ": must be > " + shortest(min) +
                         " with geometry.boundary = periodic (twice the interaction range");
  EXPECT_CONTAINS(e, "linker bounding radius");
  EXPECT_CONTAINS(e, "cell slack");
  // Settings built in code: validate() refuses them, and the Simulation's own
  // check (the safety net) draws the line at the same place.
  SimParams p = load_config("", periodic_pair(50.0), "x");
  const BodyStore bodies = build_scene(p, 1, 0, nullptr);
  p.geometry.box_length = below;
  EXPECT_THROW(validate(p), ConfigError);
  EXPECT_THROW(Simulation(p, bodies), std::invalid_argument);
  // A capture range longer than the linker's bounding sphere sets the bound.
  const std::string e2 = error_of("", {"geometry.boundary=periodic", "geometry.linker_radius=0.1",
                                       "bonding.capture_distance=3.9", "geometry.box_length=13.8"});
  EXPECT_CONTAINS(e2, "geometry.box_length = 13.8: must be > 13.84");
  EXPECT_CONTAINS(e2, "capture range");
}

TEST(PeriodicMinimum, SpheresOnlyBoxIsNotConstrainedByAbsentLinkers) {
  // Long linkers (bounding radius 10.05, capture range 11.1), none present:
  // only the spheres count, 2 x (2 r_S + 2 delta) = 4.000000004.
  const std::vector<std::string> set = {"geometry.boundary=periodic", "init.spheres=2", "init.linkers=0",
                                        "geometry.linker_length=20", "geometry.box_length=10"};
  SimParams p;
  ASSERT_NO_THROW(p = load_config("", set, "x"));
  EXPECT_TRUE(p.bonding.enabled);
  const InteractionRange r = interaction_range(p);
  EXPECT_DOUBLE_EQ(r.periodic_min_box(), 2.0 * (2.0 + 2e-9));
  EXPECT_EQ(r.capture, 0.0);
  EXPECT_EQ(r.slack, 0.0);
  EXPECT_NO_THROW(Simulation(p, build_scene(p, 1, 0, nullptr)));
  EXPECT_CONTAINS(error_of("", {"geometry.boundary=periodic", "init.spheres=2", "init.linkers=0",
                                "geometry.linker_length=20", "geometry.box_length=4"}),
                  "geometry.box_length = 4: must be > 4.000000004");
  // Linkers only: no capture range either (3.9 + 2 + 1 = 6.9 > 2 x 2.0025).
  const std::vector<std::string> linkers = {"geometry.boundary=periodic", "init.spheres=0", "init.linkers=2",
                                            "geometry.linker_radius=0.1", "bonding.capture_distance=3.9",
                                            "geometry.box_length=9"};
  ASSERT_NO_THROW(p = load_config("", linkers, "x"));
  EXPECT_NO_THROW(Simulation(p, build_scene(p, 1, 0, nullptr)));
}

// ---- types ----------------------------------------------------------------------

TEST(Config, WrongTypesNameKeyValueAndType) {
  struct Case {
    std::string text;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {"[geometry]\nbox_length = \"big\"", "geometry.box_length = \"big\": expected a number"},
      {"[geometry]\nbox_length = true", "geometry.box_length = true: expected a number"},
      {"[geometry]\nbox_length = [1, 2]", "geometry.box_length = [ 1, 2 ]: expected a number"},
      {"[init]\nspheres = 2.5", "init.spheres = 2.5: expected an integer"},
      {"[init]\nspheres = \"10\"", "init.spheres = \"10\": expected an integer"},
      {"[run]\nvalidate = 1", "run.validate = 1: expected a boolean (true or false)"},
      {"[run]\nvalidate = \"yes\"", "run.validate = \"yes\": expected a boolean"},
      {"[geometry]\nboundary = 3", "geometry.boundary = 3: expected a string, one of reflective, periodic"},
      {"[bonding]\nenabled = 0", "bonding.enabled = 0: expected a boolean"},
      {"[bonding]\nangle_filter = \"on\"", "bonding.angle_filter = \"on\": expected a boolean"},
      {"[bonding]\nsphere_valency = 1.5", "bonding.sphere_valency = 1.5: expected an integer"},
      {"[bonding]\ncoplanarity_mode = 0", "bonding.coplanarity_mode = 0: expected a string, one of cis-or-trans, cis"},
      {"[run]\nmser_batch = \"5\"", "run.mser_batch = \"5\": expected an integer"},
      {"[run]\nsteady_state = 1", "run.steady_state = 1: expected a boolean"},
      {"geometry = 5", "geometry = 5: expected a table"},
  };
  for (const Case& c : cases) EXPECT_CONTAINS(error_of(c.text), c.expected);
}

TEST(Config, WrongTypesFromOverrides) {
  EXPECT_CONTAINS(error_of("", {"geometry.box_length=big"}), "geometry.box_length = big: expected a number");
  EXPECT_CONTAINS(error_of("", {"init.spheres=2.5"}), "init.spheres = 2.5: expected an integer");
  EXPECT_CONTAINS(error_of("", {"run.validate=yes"}), "run.validate = yes: expected a boolean");
  EXPECT_CONTAINS(error_of("", {"run.validate=1"}), "run.validate = 1: expected a boolean");
  EXPECT_CONTAINS(error_of("", {"init.spheres="}), "init.spheres = (empty): expected an integer");
  EXPECT_CONTAINS(error_of("", {"init.spheres"}), "\"init.spheres\": expected section.key=value");
  // Integral floats and integers for floats are fine.
  EXPECT_EQ(load_config("", {"init.spheres=1e2"}, "x").init.spheres, 100);
  EXPECT_EQ(load_config("", {"geometry.box_length=20"}, "x").geometry.box_length, 20.0);
}

TEST(Config, SyntaxErrorHasSourceLineAndColumn) {
  const std::string e = error_of("[geometry]\nbox_length = = 3\n");
  EXPECT_CONTAINS(e, "test.toml:2:");
  EXPECT_CONTAINS(e, "TOML syntax error");
  try {
    load_config("[run]\nt_max = 1\nt_max = 2\n", {}, "dup.toml");
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& ex) {
    EXPECT_CONTAINS(ex.what(), "dup.toml:3:");
  }
}

// ---- unknown keys ---------------------------------------------------------------

TEST(Config, UnknownKeyDidYouMean) {
  EXPECT_CONTAINS(error_of("[geometry]\nbox_lenght = 3"),
                  "unknown key \"geometry.box_lenght\"; did you mean \"geometry.box_length\"?");
  EXPECT_CONTAINS(error_of("[geometry]\nbox_lenght = 3"), "test.toml:2:1:");
  EXPECT_CONTAINS(error_of("", {"geometry.box_lenght=3"}),
                  "--set: unknown key \"geometry.box_lenght\"; did you mean \"geometry.box_length\"?");
  EXPECT_CONTAINS(error_of("[init]\nsphere = 3"), "did you mean \"init.spheres\"?");
  EXPECT_CONTAINS(error_of("[run]\ntmax = 3"), "did you mean \"run.t_max\"?");
  // A key filed under the wrong section.
  EXPECT_CONTAINS(error_of("[geometry]\nrestitution_sphere = 1"), "did you mean \"contact.restitution_sphere\"?");
  // A top-level key that belongs to a section.
  EXPECT_CONTAINS(error_of("box_length = 3"), "unknown key \"box_length\"; did you mean \"geometry.box_length\"?");
  EXPECT_CONTAINS(error_of("nmae = \"x\""), "did you mean \"name\"?");
  EXPECT_CONTAINS(error_of("[bonding]\ncapture_distnace = 0.1"), "did you mean \"bonding.capture_distance\"?");
  EXPECT_CONTAINS(error_of("[bonding]\ntheta_0_deg = 3"), "did you mean \"bonding.theta0_deg\"?");
  // Nothing close: list the section's keys.
  const std::string e = error_of("[bonding]\nbreakable = true");
  EXPECT_CONTAINS(e, "unknown key \"bonding.breakable\"");
  EXPECT_CONTAINS(e, "valid keys in [bonding]: enabled, capture_distance, capture_site, sphere_valency, end_valency, "
                     "angle_filter, theta0_deg, dtheta_deg, coplanarity_filter, dphi_deg, coplanarity_mode");
}

TEST(Config, UnknownSectionDidYouMean) {
  EXPECT_CONTAINS(error_of("[geomtry]\nbox_length = 3"), "unknown section \"geomtry\"; did you mean \"geometry\"?");
  const std::string e = error_of("[output]\nfile = \"x\"");
  EXPECT_CONTAINS(e, "unknown section \"output\"");
  EXPECT_CONTAINS(e, "valid sections: geometry, contact, init, bonding, compliant, run");
  EXPECT_CONTAINS(error_of("", {"geomtry.box_length=3"}), "did you mean \"geometry.box_length\"?");
}

TEST(Config, AllProblemsReportedInSourceOrder) {
  const std::string e = error_of("[run]\nt_max = -1\n[geometry]\nbox_lenght = 3\ndensity = 0\n");
  const auto a = e.find("test.toml:2:");
  const auto b = e.find("test.toml:4:");
  const auto c = e.find("test.toml:5:");
  ASSERT_NE(a, std::string::npos) << e;
  ASSERT_NE(b, std::string::npos) << e;
  ASSERT_NE(c, std::string::npos) << e;
  EXPECT_LT(a, b);
  EXPECT_LT(b, c);
}

// ---- validate() on settings built in code ------------------------------------------

TEST(Config, ValidateCodeBuiltSettings) {
  SimParams p;
  EXPECT_NO_THROW(validate(p));
  p.contact.restitution_wall = 1.5;
  try {
    validate(p);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_CONTAINS(e.what(), "contact.restitution_wall = 1.5: must be in [0, 1]");
  }
  p = SimParams{};
  p.geometry.box_length = 1.0;
  EXPECT_THROW(validate(p), ConfigError);
}

// ---- canonical TOML ----------------------------------------------------------------

TEST(Config, CanonicalTomlListsEveryKeyInTableOrder) {
  const std::string text = config_to_toml(SimParams{});
  std::size_t last = 0;
  for (const KeyInfo& k : config_keys()) {
    const std::string leaf = k.name.substr(k.name.find('.') + 1);
    const auto pos = text.find("\n" + leaf + " = " + k.default_value + "\n");
    ASSERT_NE(pos, std::string::npos) << k.name << " missing in\n" << text;
    EXPECT_GT(pos, last) << k.name;
    last = pos;
  }
  EXPECT_EQ(text.rfind("[geometry]\n", 0), 0u);
  EXPECT_NE(text.find("box_length = 50.0\n"), std::string::npos);
  EXPECT_NE(text.find("boundary = \"reflective\"\n"), std::string::npos);
  EXPECT_NE(text.find("spheres = 300\n"), std::string::npos);
  EXPECT_NE(text.find("contact_tolerance = 1e-09\n"), std::string::npos);
  EXPECT_NE(text.find("validate = false\n"), std::string::npos);
  EXPECT_EQ(config_to_toml(SimParams{}), text);  // deterministic
}

TEST(Config, RoundTripIsExact) {
  SimParams p;
  p.geometry.sphere_radius = 0.1;                 // not exactly representable
  p.geometry.linker_radius = 1.0 / 3.0;
  p.geometry.linker_length = 4.000000000000001;   // needs 16+ significant digits
  p.geometry.box_length = 123456789.123456789;
  p.geometry.boundary = Boundary::Periodic;
  p.geometry.density = 2.2250738585072014e-300;  // tiny
  p.contact.restitution_sphere = 0.95;
  p.contact.restitution_linker = std::nextafter(1.0, 0.0);
  p.contact.restitution_wall = 0.0;
  p.contact.static_friction_sphere = 0.7;
  p.contact.static_friction_linker = 1e300;
  p.contact.static_friction_wall = 0.3;
  p.contact.dynamic_friction_sphere = 0.7;
  p.contact.dynamic_friction_linker = 0.1 + 0.2;
  p.contact.dynamic_friction_wall = 0.25;
  p.contact.restitution_rule = CombineRule::Mean;
  p.contact.friction_rule = CombineRule::Max;
  p.init.spheres = 1000000;  // the largest allowed
  p.init.linkers = 0;
  p.init.alpha = 0.123456789012345678;
  p.init.velocity = VelocityInit::Thermal;
  p.init.v_max = 0.0;
  p.init.omega_max = 3.5e-5;
  p.init.temperature = 1e-12;
  p.bonding.enabled = false;
  p.bonding.capture_distance = 0.1 + 1e-17 * 7;  // shortest text needs many digits
  p.bonding.sphere_valency = 4;
  p.bonding.end_valency = 0;
  p.bonding.angle_filter = false;
  p.bonding.theta0_deg = 109.47122063449069;  // tetrahedral, acos(-1/3)
  p.bonding.dtheta_deg = 0.0;
  p.bonding.coplanarity_filter = false;
  p.bonding.dphi_deg = 90.0;
  p.bonding.coplanarity_mode = CoplanarityMode::Cis;
  p.bonding.capture_site = CaptureSite::EndPoint;
  p.compliant.c = 1.0 / 7.0;  // springs stay 0: compliant bonds cannot run yet
  p.compliant.c_omega = 1e-300;
  p.compliant.target_gap = 0.3;
  p.run.t_max = 5e3;
  p.run.steady_state = false;
  p.run.sample_interval = 0.1;
  p.run.mser_batch = 1;
  p.run.mser_min_samples = 2147483647;
  p.run.mser_check_every = 3;
  p.run.max_events = 9007199254740993LL;  // > 2^53: must stay an integer
  p.run.contact_tolerance = 1e-3;
  p.run.tc_time = 0.0;
  p.run.cell_size = 7.25;
  p.run.validate = true;
  p.run.queue = QueueKind::Reference;
  ASSERT_NO_THROW(validate(p));

  const std::string text = config_to_toml(p);
  const SimParams q = load_config(text, {}, "roundtrip.toml");
  expect_same(q, p);
  EXPECT_EQ(config_to_toml(q), text);

  expect_same(load_config(config_to_toml(SimParams{}), {}, "defaults.toml"), SimParams{});
}

TEST(Config, ScenarioRoundTripWithEscapedStrings) {
  Scenario s;
  s.name = "scenario 5 \"compliant\"";
  s.description = "line one\nline two\t\\ tab";
  s.params.init.spheres = 42;
  const Scenario r = load_scenario(scenario_to_toml(s), {}, "s.toml");
  EXPECT_EQ(r.name, s.name);
  EXPECT_EQ(r.description, s.description);
  expect_same(r.params, s.params);
}

TEST(Config, KeyInfoTable) {
  const auto& keys = config_keys();
  ASSERT_EQ(keys.size(), 68u);
  for (const KeyInfo& k : keys) {
    EXPECT_FALSE(k.type.empty()) << k.name;
    EXPECT_FALSE(k.default_value.empty()) << k.name;
    EXPECT_FALSE(k.description.empty()) << k.name;
  }
  EXPECT_EQ(keys.front().name, "geometry.sphere_radius");
  EXPECT_EQ(keys.front().type, "float");
  EXPECT_EQ(keys.front().range, "> 0");
  EXPECT_EQ(keys.back().name, "run.queue");
  EXPECT_EQ(keys.back().range, "fast, reference");
}

// ---- scenario files (jobs/scenarios) ---------------------------------------------------

// Every file of jobs/scenarios loads, carries its name and a description, and
// gives the settings of its MODEL.md "Scenarios" row; the file lists only
// deviations from the built-in defaults (= Scenario 4).
TEST(Config, ScenarioFilesMatchModelTable) {
  struct Row {
    const char* stem;
    bool angle_filter;
    bool coplanarity_filter;
    int bodies;  // N_S = N_L
    int deviations;  // keys the file must set
    bool compliant = false;  // Scenario 5: k = k_omega = 1000, c = c_omega = 100
  };
  const std::vector<Row> rows = {
      {"1-baseline", false, false, 300, 2},      {"2-bond-angle", true, false, 300, 1},
      {"3-coplanarity", false, true, 300, 1},    {"4-passive-selection", true, true, 300, 0},
      {"5-compliant", true, true, 300, 4, true},
      {"6-1-low-density", true, true, 150, 2},   {"6-3-high-density", true, true, 600, 2},
  };
  const std::filesystem::path dir = std::filesystem::path(RINGSIM_SOURCE_DIR) / "jobs" / "scenarios";
  ASSERT_TRUE(std::filesystem::is_directory(dir)) << dir;

  std::vector<std::string> found;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() == ".toml") found.push_back(entry.path().stem().string());
  }
  std::sort(found.begin(), found.end());
  std::vector<std::string> expected;
  for (const Row& r : rows) expected.emplace_back(r.stem);
  EXPECT_EQ(found, expected) << "every scenario file needs a row here";

  for (const Row& r : rows) {
    const std::string path = (dir / (std::string(r.stem) + ".toml")).string();
    SCOPED_TRACE(path);
    Scenario s;
    ASSERT_NO_THROW(s = load_scenario_file(path, {}));
    EXPECT_EQ(s.name, r.stem);
    EXPECT_FALSE(s.description.empty());

    SimParams want;  // the defaults: Scenario 4, both filters, rigid, 300 + 300
    want.bonding.angle_filter = r.angle_filter;
    want.bonding.coplanarity_filter = r.coplanarity_filter;
    want.init.spheres = r.bodies;
    want.init.linkers = r.bodies;
    if (r.compliant) {
      want.compliant.k = want.compliant.k_omega = 1000.0;
      want.compliant.c = want.compliant.c_omega = 100.0;
    }
    expect_same(s.params, want);
    EXPECT_TRUE(s.params.bonding.enabled);
    EXPECT_EQ(s.params.bonding.theta0_deg, 90.0);
    EXPECT_EQ(s.params.bonding.dtheta_deg, 5.0);
    EXPECT_EQ(s.params.bonding.dphi_deg, 5.0);

    // Only deviations: count the key = value lines other than name/description.
    std::ifstream in(path);
    std::string line;
    int keys = 0;
    while (std::getline(in, line)) {
      const auto b = line.find_first_not_of(" \t");
      if (b == std::string::npos || line[b] == '#' || line[b] == '[') continue;
      if (line.compare(b, 4, "name") == 0 || line.compare(b, 11, "description") == 0) continue;
      if (line.find('=') != std::string::npos) ++keys;
    }
    EXPECT_EQ(keys, r.deviations);
  }
}

}  // namespace
}  // namespace ringsim
