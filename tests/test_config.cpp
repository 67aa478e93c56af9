// Scenario configuration: defaults, file + overrides, every class of bad
// input (message names key, value and range), did-you-mean, canonical TOML
// round trip.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

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
  EXPECT_EQ(a.run.t_max, b.run.t_max);
  EXPECT_EQ(a.run.max_events, b.run.max_events);
  EXPECT_EQ(a.run.contact_tolerance, b.run.contact_tolerance);
  EXPECT_EQ(a.run.tc_time, b.run.tc_time);
  EXPECT_EQ(a.run.cell_size, b.run.cell_size);
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
      {"[init]\nspheres = -1", "init.spheres = -1: must be an integer >= 0"},
      {"[init]\nlinkers = -5", "init.linkers = -5: must be an integer >= 0"},
      {"[init]\nspheres = 3000000000", "init.spheres = 3000000000: must be an integer <= 2147483647"},
      {"[init]\nalpha = 1.01", "init.alpha = 1.01: must be in [0, 1]"},
      {"[init]\nv_max = -1", "init.v_max = -1: must be >= 0"},
      {"[init]\nomega_max = -0.1", "init.omega_max = -0.1: must be >= 0"},
      {"[init]\ntemperature = 0", "init.temperature = 0: must be > 0"},
      {"[run]\nt_max = 0", "run.t_max = 0: must be > 0"},
      {"[run]\nmax_events = -1", "run.max_events = -1: must be an integer >= 0"},
      {"[run]\ncontact_tolerance = 0", "run.contact_tolerance = 0: must be in (0, 0.001]"},
      {"[run]\ncontact_tolerance = 0.01", "run.contact_tolerance = 0.01: must be in (0, 0.001]"},
      {"[run]\ntc_time = -1e-7", "run.tc_time = -1e-07: must be >= 0"},
      {"[run]\ncell_size = -2", "run.cell_size = -2: must be >= 0"},
      {"[geometry]\nboundary = \"wall\"", "geometry.boundary = \"wall\": must be one of reflective, periodic"},
      {"[contact]\nrestitution_rule = \"median\"",
       "contact.restitution_rule = \"median\": must be one of min, max, product, mean"},
      {"[contact]\nfriction_rule = \"Min\"", "contact.friction_rule = \"Min\": must be one of min, max, product, mean"},
      {"[init]\nvelocity = \"gaussian\"", "init.velocity = \"gaussian\": must be one of uniform, thermal"},
      {"[run]\nqueue = \"slow\"", "run.queue = \"slow\": must be one of fast, reference"},
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
}

TEST(Config, RangeErrorsFromOverrides) {
  const std::string e = error_of("", {"geometry.box_length=-3"});
  EXPECT_CONTAINS(e, "--set: geometry.box_length = -3: must be > 0");
  EXPECT_CONTAINS(error_of("", {"geometry.boundary=wall"}),
                  "geometry.boundary = \"wall\": must be one of reflective, periodic");
  EXPECT_CONTAINS(error_of("", {"init.spheres=-1"}), "init.spheres = -1: must be an integer >= 0");
}

TEST(Config, BondingOnlyFalse) {
  EXPECT_FALSE(load_config("[bonding]\nenabled = false", {}, "b.toml").bonding.enabled);
  const std::string e = error_of("[bonding]\nenabled = true");
  EXPECT_CONTAINS(e, "bonding.enabled = true");
  EXPECT_CONTAINS(e, "bonding is not implemented yet in this version");
  EXPECT_CONTAINS(error_of("", {"bonding.enabled=true"}), "bonding is not implemented yet");
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
  // Nothing close: list the section's keys.
  const std::string e = error_of("[bonding]\ncapture_distance = 0.1");
  EXPECT_CONTAINS(e, "unknown key \"bonding.capture_distance\"");
  EXPECT_CONTAINS(e, "valid keys in [bonding]: enabled");
}

TEST(Config, UnknownSectionDidYouMean) {
  EXPECT_CONTAINS(error_of("[geomtry]\nbox_length = 3"), "unknown section \"geomtry\"; did you mean \"geometry\"?");
  const std::string e = error_of("[output]\nfile = \"x\"");
  EXPECT_CONTAINS(e, "unknown section \"output\"");
  EXPECT_CONTAINS(e, "valid sections: geometry, contact, init, bonding, run");
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
  p.init.spheres = 2147483647;
  p.init.linkers = 0;
  p.init.alpha = 0.123456789012345678;
  p.init.velocity = VelocityInit::Thermal;
  p.init.v_max = 0.0;
  p.init.omega_max = 3.5e-5;
  p.init.temperature = 1e-12;
  p.run.t_max = 5e3;
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
  ASSERT_EQ(keys.size(), 32u);
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

}  // namespace
}  // namespace ringsim
