#pragma once
// Scenario configuration: TOML text + command-line overrides -> validated
// SimParams (docs/CONFIG.md).
//
// Rules
// - The built-in defaults are the member initializers of SimParams (the
//   study's tables, MODEL.md). A scenario file lists only deviations.
// - Keys are "section.key" (sections geometry, contact, init, bonding, run),
//   plus the optional top-level strings `name` and `description`.
// - Overrides ("section.key=value", from `--set`) apply after the file; the
//   value is read according to the key's type (TOML syntax; enum names and
//   strings may be bare or quoted).
// - Everything is checked at load time. A failure is one ConfigError whose
//   message names the source, the key, the offending value and the valid range
//   (several problems: one per line).
//
// All keys live in one descriptor table in config.cpp; config_keys() exposes
// it for --help and documentation.

#include <stdexcept>
#include <string>
#include <vector>

#include "core/params.hpp"

namespace ringsim {

// A user-facing configuration problem; what() is ready to print.
class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(const std::string& message) : std::runtime_error(message) {}
};

// A scenario: metadata plus the settings of one replicate.
struct Scenario {
  std::string name;         // top-level `name` (optional, empty by default)
  std::string description;  // top-level `description` (optional)
  SimParams params;
};

// One configuration key, for generated help and docs.
struct KeyInfo {
  std::string name;           // "geometry.box_length"
  std::string type;           // "float", "integer", "bool" or "enum"
  std::string default_value;  // as written in TOML, e.g. "50.0", "\"reflective\""
  std::string range;          // e.g. "> 0", "[0, 1]", "reflective, periodic"
  std::string description;    // one line, with units
};

// Every SimParams key, in canonical order (the order of config_to_toml).
const std::vector<KeyInfo>& config_keys();

// Parse a scenario from TOML text. `source_name` (a path, or e.g. "<string>")
// prefixes error messages. Throws ConfigError.
Scenario load_scenario(const std::string& toml_text, const std::vector<std::string>& overrides,
                       const std::string& source_name);

// The text of a scenario file; ConfigError naming the path when it is
// missing, a directory or unreadable.
std::string read_scenario_text(const std::string& path);

// Read and parse a scenario file; an empty path means built-in defaults (plus
// overrides). A missing or unreadable file is a ConfigError naming the path.
Scenario load_scenario_file(const std::string& path, const std::vector<std::string>& overrides);

// As load_scenario / load_scenario_file, returning only the settings.
SimParams load_config(const std::string& toml_text, const std::vector<std::string>& overrides,
                      const std::string& source_name);
SimParams load_config_file(const std::string& path, const std::vector<std::string>& overrides);

// Check ranges and cross-key rules of settings built in code. Throws
// ConfigError (same messages as loading, without a source prefix).
void validate(const SimParams& params);

// The full effective configuration as canonical TOML: every key, fixed order,
// shortest round-trip number formatting, no comments. Deterministic (suitable
// for hashing); load_config(config_to_toml(p), {}, ...) == p exactly.
std::string config_to_toml(const SimParams& params);

// As config_to_toml, preceded by `name` and `description` when non-empty.
std::string scenario_to_toml(const Scenario& scenario);

}  // namespace ringsim
