#include "ensemble/config.hpp"

#include "analysis/mser.hpp"
#include "core/interaction_range.hpp"

// Loading works in three steps, all driven by one table of key descriptors:
//   1. parse the TOML text (syntax errors: source:line:column);
//   2. for each key of the file, then each --set override: look the key up
//      (unknown: did-you-mean), convert the value to the key's type, check the
//      key's own range, store it through the descriptor;
//   3. check the rules that involve several keys (friction order, at least one
//      body, box large enough, capture distance below the linker length,
//      compliant bonds not yet runnable, MSER minimum length).
// Problems are collected and reported together, in source order, one per line.

#include <toml++/toml.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <variant>

namespace ringsim {
namespace {

// ---- values ----------------------------------------------------------------

// A key's value in transit: Real -> double, Integer -> int64, Bool -> bool,
// Enum -> its name.
using Value = std::variant<double, std::int64_t, bool, std::string>;

enum class KeyType { Real, Integer, Bool, Enum };

const char* type_name(KeyType t) {
  switch (t) {
    case KeyType::Real: return "float";
    case KeyType::Integer: return "integer";
    case KeyType::Bool: return "bool";
    case KeyType::Enum: return "enum";
  }
  return "?";
}

// Shortest text that reads back to the same double (std::to_chars: exact,
// locale-independent, identical on every platform).
std::string format_real(double x) {
  if (std::isnan(x)) return "nan";
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, res.ptr);
}

// As format_real, but always a TOML float ("50" -> "50.0").
std::string toml_real(double x) {
  std::string s = format_real(x);
  if (std::isfinite(x) && s.find_first_of(".eE") == std::string::npos) s += ".0";
  return s;
}

// A TOML basic string with the escapes the spec requires.
std::string toml_quote(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      case '\r': out += "\\r"; break;
      case '\b': out += "\\b"; break;
      case '\f': out += "\\f"; break;
      default:
        if (u < 0x20 || u == 0x7f) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", u);
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

// ---- enums -----------------------------------------------------------------

template <typename E>
struct EnumValues;
template <>
struct EnumValues<Boundary> {
  static constexpr std::array all{Boundary::Reflective, Boundary::Periodic};
};
template <>
struct EnumValues<CombineRule> {
  static constexpr std::array all{CombineRule::Min, CombineRule::Max, CombineRule::Product,
                                  CombineRule::Mean};
};
template <>
struct EnumValues<VelocityInit> {
  static constexpr std::array all{VelocityInit::Uniform, VelocityInit::Thermal};
};
template <>
struct EnumValues<QueueKind> {
  static constexpr std::array all{QueueKind::Fast, QueueKind::Reference};
};
template <>
struct EnumValues<CoplanarityMode> {
  static constexpr std::array all{CoplanarityMode::CisOrTrans, CoplanarityMode::Cis};
};
template <>
struct EnumValues<CaptureSite> {
  static constexpr std::array all{CaptureSite::EndFace, CaptureSite::EndPoint};
};
template <>
struct EnumValues<BondJoint> {
  static constexpr std::array all{BondJoint::Articulated, BondJoint::Welded};
};
template <>
struct EnumValues<Exclusions> {
  static constexpr std::array all{Exclusions::OneThree, Exclusions::OneTwo};
};
template <>
struct EnumValues<CompliantMethod> {
  static constexpr std::array all{CompliantMethod::Auto, CompliantMethod::Bdf, CompliantMethod::Adams,
                                  CompliantMethod::Erk};
};

template <typename E>
std::optional<E> parse_enum(std::string_view s) {
  for (const E e : EnumValues<E>::all) {
    if (s == to_string(e)) return e;
  }
  return std::nullopt;
}

template <typename E>
std::vector<std::string> enum_names() {
  std::vector<std::string> names;
  for (const E e : EnumValues<E>::all) names.emplace_back(to_string(e));
  return names;
}

std::string join(const std::vector<std::string>& items, const char* sep) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (i) out += sep;
    out += items[i];
  }
  return out;
}

// ---- ranges ----------------------------------------------------------------

struct Range {
  enum class Kind { Any, Greater, AtLeast, Closed };
  Kind kind = Kind::Any;
  double lo = 0.0;
  double hi = 0.0;
};

constexpr Range greater(double lo) { return {Range::Kind::Greater, lo, 0.0}; }
constexpr Range at_least(double lo) { return {Range::Kind::AtLeast, lo, 0.0}; }
constexpr Range closed(double lo, double hi) { return {Range::Kind::Closed, lo, hi}; }
constexpr Range any() { return {}; }

bool in_range(const Range& r, double x) {
  switch (r.kind) {
    case Range::Kind::Any: return true;
    case Range::Kind::Greater: return x > r.lo;
    case Range::Kind::AtLeast: return x >= r.lo;
    case Range::Kind::Closed: return x >= r.lo && x <= r.hi;
  }
  return false;
}

// "> 0", ">= 0", "in [0, 1]"; empty for Any.
std::string range_text(const Range& r) {
  switch (r.kind) {
    case Range::Kind::Any: return "";
    case Range::Kind::Greater: return "> " + format_real(r.lo);
    case Range::Kind::AtLeast: return ">= " + format_real(r.lo);
    case Range::Kind::Closed: return "in [" + format_real(r.lo) + ", " + format_real(r.hi) + "]";
  }
  return "";
}

// Upper bounds that turn sizes the program cannot hold into configuration
// errors instead of std::bad_alloc or a wrapped int later on. Both are far
// above the study (600 bodies, 5000 samples of N_t).
// 1e6 bodies of one species: a few GB of body, contact and event state.
constexpr double kMaxBodiesPerSpecies = 1e6;
// 1e7 samples of N_t: 80 MB per replicate in memory, 40 MB per row of
// /series/N_t (--series); a run of R replicates pre-allocates R times that.
constexpr double kMaxSamples = 1e7;

// ---- key descriptors --------------------------------------------------------

struct KeyDesc {
  const char* name;  // "section.key"
  KeyType type;
  Range range;
  const char* doc;
  Value (*get)(const SimParams&);
  void (*set)(SimParams&, const Value&);  // the value has passed check_value
  std::vector<std::string> (*choices)();  // Enum keys only
  std::int64_t int_min;                   // Integer keys: what the field can hold
  std::int64_t int_max;
};

template <typename C, typename M>
M member_type(M C::*);

// key<&SimParams::geometry, &GeometryParams::box_length>(...) describes
// p.geometry.box_length; the key's type follows from the field's C++ type.
template <auto Section, auto Field>
KeyDesc key(const char* name, Range range, const char* doc) {
  using T = decltype(member_type(Field));
  KeyDesc d{};
  d.name = name;
  d.range = range;
  d.doc = doc;
  d.get = [](const SimParams& p) -> Value {
    const T& v = (p.*Section).*Field;
    if constexpr (std::is_same_v<T, bool>) {
      return v;
    } else if constexpr (std::is_enum_v<T>) {
      return std::string(to_string(v));
    } else if constexpr (std::is_integral_v<T>) {
      return static_cast<std::int64_t>(v);
    } else {
      return static_cast<double>(v);
    }
  };
  d.set = [](SimParams& p, const Value& v) {
    T& f = (p.*Section).*Field;
    if constexpr (std::is_same_v<T, bool>) {
      f = std::get<bool>(v);
    } else if constexpr (std::is_enum_v<T>) {
      f = *parse_enum<T>(std::get<std::string>(v));
    } else if constexpr (std::is_integral_v<T>) {
      f = static_cast<T>(std::get<std::int64_t>(v));
    } else {
      f = std::get<double>(v);
    }
  };
  if constexpr (std::is_same_v<T, bool>) {
    d.type = KeyType::Bool;
  } else if constexpr (std::is_enum_v<T>) {
    d.type = KeyType::Enum;
    d.choices = &enum_names<T>;
  } else if constexpr (std::is_integral_v<T>) {
    static_assert(sizeof(T) <= sizeof(std::int64_t) && std::is_signed_v<T>);
    d.type = KeyType::Integer;
    d.int_min = std::numeric_limits<T>::min();
    d.int_max = std::numeric_limits<T>::max();
  } else {
    static_assert(std::is_same_v<T, double>);
    d.type = KeyType::Real;
  }
  return d;
}

using S = SimParams;
using G = GeometryParams;
using C = ContactParams;
using I = InitParams;
using B = BondingParams;
using P = CompliantParams;
using R = RunParams;

// The one list of configuration keys; its order is the canonical order.
// Units are reduced (length = sphere radius, unit mass density, time from
// length and speed).
const std::vector<KeyDesc>& key_table() {
  static const std::vector<KeyDesc> table = {
      key<&S::geometry, &G::sphere_radius>("geometry.sphere_radius", greater(0),
          "sphere radius r_S (1 = the unit of length)"),
      key<&S::geometry, &G::linker_radius>("geometry.linker_radius", greater(0),
          "linker (cylinder) radius r_L"),
      key<&S::geometry, &G::linker_length>("geometry.linker_length", greater(0),
          "linker axial length l_L, end face to end face"),
      key<&S::geometry, &G::box_length>("geometry.box_length", greater(0),
          "edge l_B of the cubic box [0, l_B]^3; must exceed twice the largest body bounding radius "
          "(periodic: twice the interaction range)"),
      key<&S::geometry, &G::boundary>("geometry.boundary", any(),
          "walls: reflective (impulse with restitution_wall) or periodic (minimum image)"),
      key<&S::geometry, &G::density>("geometry.density", greater(0),
          "mass density of both species; masses and inertia follow from the solid shapes"),

      key<&S::contact, &C::restitution_sphere>("contact.restitution_sphere", closed(0, 1),
          "coefficient of restitution e_S of spheres"),
      key<&S::contact, &C::restitution_linker>("contact.restitution_linker", closed(0, 1),
          "coefficient of restitution e_L of linkers"),
      key<&S::contact, &C::restitution_wall>("contact.restitution_wall", closed(0, 1),
          "coefficient of restitution e_B of the walls (reflective boundary)"),
      key<&S::contact, &C::static_friction_sphere>("contact.static_friction_sphere", at_least(0),
          "static (sticking) friction coefficient mu_S of spheres; 0 = smooth"),
      key<&S::contact, &C::static_friction_linker>("contact.static_friction_linker", at_least(0),
          "static (sticking) friction coefficient mu_L of linkers; 0 = smooth"),
      key<&S::contact, &C::static_friction_wall>("contact.static_friction_wall", at_least(0),
          "static (sticking) friction coefficient mu_B of the walls; 0 = smooth"),
      key<&S::contact, &C::dynamic_friction_sphere>("contact.dynamic_friction_sphere", at_least(0),
          "dynamic (sliding) friction coefficient nu_S of spheres; <= static_friction_sphere"),
      key<&S::contact, &C::dynamic_friction_linker>("contact.dynamic_friction_linker", at_least(0),
          "dynamic (sliding) friction coefficient nu_L of linkers; <= static_friction_linker"),
      key<&S::contact, &C::dynamic_friction_wall>("contact.dynamic_friction_wall", at_least(0),
          "dynamic (sliding) friction coefficient nu_B of the walls; <= static_friction_wall"),
      key<&S::contact, &C::restitution_rule>("contact.restitution_rule", any(),
          "how the two objects' restitutions combine into the pair's"),
      key<&S::contact, &C::friction_rule>("contact.friction_rule", any(),
          "how the two objects' friction coefficients (static and dynamic) combine"),

      key<&S::init, &I::spheres>("init.spheres", closed(0, kMaxBodiesPerSpecies),
          "number of spheres N_S (spheres + linkers >= 1)"),
      key<&S::init, &I::linkers>("init.linkers", closed(0, kMaxBodiesPerSpecies),
          "number of linkers N_L (spheres + linkers >= 1)"),
      key<&S::init, &I::alpha>("init.alpha", closed(0, 1),
          "mixing degree: 0 segregated (spheres in x < l_B/2, linkers in x >= l_B/2), 1 fully mixed"),
      key<&S::init, &I::velocity>("init.velocity", any(),
          "initial velocities: uniform (bounded by v_max, omega_max) or thermal (Maxwell-Boltzmann at temperature)"),
      key<&S::init, &I::v_max>("init.v_max", at_least(0),
          "uniform: each velocity component drawn in [-v_max, v_max]"),
      key<&S::init, &I::omega_max>("init.omega_max", at_least(0),
          "uniform: each angular velocity component drawn in [-omega_max, omega_max]"),
      key<&S::init, &I::temperature>("init.temperature", greater(0),
          "thermal: temperature T (k_B = 1)"),

      key<&S::bonding, &B::enabled>("bonding.enabled", any(),
          "capture and bond formation; false = hard bodies only, no captures"),
      key<&S::bonding, &B::capture_distance>("bonding.capture_distance", greater(0),
          "capture distance r_c (length): a linker end and a sphere meet when the capture gap g "
          "(bonding.capture_site) falls through r_c; < geometry.linker_length"),
      key<&S::bonding, &B::capture_site>("bonding.capture_site", any(),
          "where the capture gap is measured: end_face (g = distance from the sphere's centre to the end face's "
          "disk of radius r_L, minus r_S: the sphere's surface to the face; the study's closest approach) or "
          "end_point (g = |p - x_S| - r_S to the face's centre point p only; a window of radius ~0.46 on the face, "
          "bonding ~10x slower)"),
      key<&S::bonding, &B::sphere_valency>("bonding.sphere_valency", at_least(0),
          "valency v_S: number of bonds a sphere can carry"),
      key<&S::bonding, &B::end_valency>("bonding.end_valency", closed(0, 1),
          "valency v_aL = v_bL of each linker end (an end face bonds at most one sphere); 0 = inert ends"),
      key<&S::bonding, &B::angle_filter>("bonding.angle_filter", any(),
          "bond-angle rule: at a sphere with two bonds, |theta - theta0_deg| <= dtheta_deg"),
      key<&S::bonding, &B::theta0_deg>("bonding.theta0_deg", closed(0, 180),
          "target bond angle theta_0 (degrees) between the two linker axes at a sphere, each pointing away from it"),
      key<&S::bonding, &B::dtheta_deg>("bonding.dtheta_deg", closed(0, 180),
          "half-width Delta_theta (degrees) of the bond-angle window, boundary included"),
      key<&S::bonding, &B::coplanarity_filter>("bonding.coplanarity_filter", any(),
          "coplanarity rule: the dihedral about a linker with cornered spheres at both ends deviates from "
          "planarity by <= dphi_deg"),
      key<&S::bonding, &B::dphi_deg>("bonding.dphi_deg", closed(0, 90),
          "half-width Delta_phi (degrees) of the coplanarity window, boundary included"),
      key<&S::bonding, &B::coplanarity_mode>("bonding.coplanarity_mode", any(),
          "planar dihedrals: cis-or-trans (deviation min(|phi|, 180 - |phi|)) or cis (deviation |phi|)"),
      key<&S::bonding, &B::joint>("bonding.joint", any(),
          "what a rigid bond holds: articulated (a ball joint at the capture position, plus the bond angle and "
          "dihedrals the filters name, held at their values; every other freedom stays free, so chains flex "
          "and rings close; docs/ARTICULATED.md) or welded (the two clusters become one rigid body in the "
          "capture pose; rings practically never close). Compliant bonds (compliant.k > 0) ignore it"),
      key<&S::bonding, &B::joint_tolerance>("bonding.joint_tolerance", greater(0),
          "articulated clusters: largest joint residual (length; radians for held angles) the position "
          "projection leaves at each slice end"),
      key<&S::bonding, &B::exclusions>("bonding.exclusions", any(),
          "bonded pairs that never collide: 1-3 (bonded pairs and pairs bonded to a common partner, the usual "
          "force-field exclusions; MODEL.md) or 1-2 (bonded pairs only: two linkers on one sphere collide as "
          "hard bodies; articulated bonds only, docs/ARTICULATED.md)"),
      key<&S::bonding, &B::joint_slice>("bonding.joint_slice", closed(1e-4, 10),
          "articulated clusters: longest slice (time) integrated ahead of the event loop; its members move on "
          "the quintic Hermite interpolant of the slice's end states (compliant.slice serves compliant clusters)"),

      key<&S::compliant, &P::k>("compliant.k", at_least(0),
          "bond spring k (force/length) on the vector from a bonded sphere's centre to its target point on the "
          "linker axis; 0 with k_omega = 0 = rigid bonds"),
      key<&S::compliant, &P::c>("compliant.c", at_least(0),
          "bond damper c (mass/time) on the relative velocity at the sphere centre"),
      key<&S::compliant, &P::k_omega>("compliant.k_omega", at_least(0),
          "angle and dihedral spring k_omega (energy/rad^2) on the deviation from theta0 and from cis/trans"),
      key<&S::compliant, &P::c_omega>("compliant.c_omega", at_least(0),
          "angle and dihedral damper c_omega (energy*time/rad^2) on the rate of the bond angle and dihedral"),
      key<&S::compliant, &P::target_gap>("compliant.target_gap", at_least(0),
          "target gap (length) between a bonded sphere's surface and the linker's end face"),
      key<&S::compliant, &P::method>("compliant.method", any(),
          "integrator of compliant clusters: auto (erk while k, k_omega <= 1e4, else bdf), bdf (CVODE BDF, "
          "Newton), adams (CVODE Adams-Moulton), erk (ARKODE Dormand-Prince)"),
      key<&S::compliant, &P::rtol>("compliant.rtol", closed(1e-14, 1e-1),
          "relative tolerance of the compliant integrator"),
      key<&S::compliant, &P::atol>("compliant.atol", closed(1e-16, 1e-1),
          "absolute tolerance of the compliant integrator (every state component)"),
      key<&S::compliant, &P::slice>("compliant.slice", closed(1e-4, 10),
          "longest slice (time) a compliant cluster is integrated ahead of the event loop; its members move "
          "on the quintic Hermite interpolant of the slice's end states (articulated clusters: bonding.joint_slice)"),
      key<&S::compliant, &P::track_tolerance>("compliant.track_tolerance", at_least(0),
          "largest estimated distance (length) between the cubic through a slice's end states and the "
          "integrated motion at the slice's midpoint (an upper estimate for the quintic tracks); a slice that "
          "strays further is halved (stiff bonds); 0 = no check"),
      key<&S::compliant, &P::relax_energy>("compliant.relax_energy", at_least(0),
          "relaxed-cluster switch: internal kinetic energy at or below which a cluster counts as quiet; "
          "0 = always integrate"),
      key<&S::compliant, &P::relax_time>("compliant.relax_time", at_least(0),
          "relaxed-cluster switch: a cluster quiet for this long (time) moves as a rigid body until disturbed"),
      key<&S::compliant, &P::burst_contacts>("compliant.burst_contacts", at_least(0),
          "contact bursts: a cluster taking this many impulses each less than burst_time after the previous "
          "moves as a rigid body from the last one until disturbed (stops a resting contact's endless "
          "bounces); 0 = never"),
      key<&S::compliant, &P::burst_time>("compliant.burst_time", greater(0),
          "contact bursts: largest time (time) between impulses that continue a burst"),

      key<&S::run, &R::t_max>("run.t_max", greater(0),
          "simulated time limit of a replicate (the study's 5e5 steps of 0.01)"),
      key<&S::run, &R::steady_state>("run.steady_state", any(),
          "stop at steady state (MSER on the N_t series) before t_max; false = always run to t_max"),
      key<&S::run, &R::sample_interval>("run.sample_interval", greater(0),
          "time between samples of the number of objects N_t for steady-state detection"),
      key<&S::run, &R::mser_batch>("run.mser_batch", at_least(1),
          "MSER batch size, in samples (5 = MSER-5)"),
      key<&S::run, &R::mser_min_samples>("run.mser_min_samples", at_least(2),
          "samples before the first steady-state test; >= 5 x run.mser_batch"),
      key<&S::run, &R::mser_check_every>("run.mser_check_every", at_least(1),
          "samples between steady-state tests after the first"),
      key<&S::run, &R::max_events>("run.max_events", at_least(0),
          "event budget of a replicate; 0 = unlimited"),
      // Floor 1e-10: the band [tol/2, tol] must be wider than what the
      // distances of cluster members resolve (~1e-12); at 1e-11 every
      // Scenario 4 replicate failed a conservative-advancement search
      // (docs/PERFORMANCE.md, "Speed against accuracy").
      key<&S::run, &R::contact_tolerance>("run.contact_tolerance", closed(1e-10, 1e-3),
          "gap at which a contact found without a closed form fires (below 1e-10 the band is finer than cluster members' distances resolve)"),
      key<&S::run, &R::tc_time>("run.tc_time", at_least(0),
          "TC-model collision-time window (Luding & McNamara 1998) against inelastic collapse; 0 = off (a collapsing cluster then stops time, and the run ends with `error` \"time stopped\")"),
      key<&S::run, &R::min_separation_speed>("run.min_separation_speed", at_least(0),
          "floor of the normal separation speed a contact leaves (stops resting contacts bouncing for ever inside "
          "the contact band; a higher floor makes resting contacts cheaper and adds at most m_eff floor^2 / 2 of "
          "energy per floored contact, docs/ARCHITECTURE.md); 0 = off (a pair resting at restitution 0 then fires "
          "at one instant for ever, and the run ends with `error` \"time stopped\")"),
      key<&S::run, &R::cell_size>("run.cell_size", at_least(0),
          "edge of the neighbour-search cells; 0 = automatic"),
      key<&S::run, &R::sphere_candidates>("run.sphere_candidates", closed(0, 64),
          "hard-sphere gas (no linkers, bonding off): earliest collisions each sphere keeps, so a cell "
          "crossing scans only the 9 newly adjacent cells; 0 = off (every prediction scans all 27)"),
      key<&S::run, &R::partner_horizon>("run.partner_horizon", any(),
          "pair and capture searches stop at the partner's pending event, where the partner re-predicts "
          "the pair (same events, less work); false = search to the body's own horizon (for testing)"),
      key<&S::run, &R::validate>("run.validate", any(),
          "check whole-state invariants after every event (slow; for debugging)"),
      key<&S::run, &R::queue>("run.queue", any(),
          "event queue: fast, or reference (slow, exact; for testing the fast one)"),
  };
  return table;
}

constexpr const char* kMetaKeys[] = {"name", "description"};

const KeyDesc* find_key(std::string_view name) {
  for (const KeyDesc& d : key_table()) {
    if (name == d.name) return &d;
  }
  return nullptr;
}

std::string section_of(std::string_view name) {
  const auto dot = name.find('.');
  return std::string(name.substr(0, dot));
}

std::string leaf_of(std::string_view name) {
  const auto dot = name.rfind('.');
  return std::string(dot == std::string_view::npos ? name : name.substr(dot + 1));
}

std::vector<std::string> section_names() {
  std::vector<std::string> out;
  for (const KeyDesc& d : key_table()) {
    std::string s = section_of(d.name);
    if (std::find(out.begin(), out.end(), s) == out.end()) out.push_back(std::move(s));
  }
  return out;
}

bool is_section(std::string_view s) {
  const auto names = section_names();
  return std::find(names.begin(), names.end(), s) != names.end();
}

// ---- did you mean ------------------------------------------------------------

// Optimal string alignment distance: Levenshtein plus adjacent transpositions
// ("lenght" -> "length" costs 1).
std::size_t edit_distance(std::string_view a, std::string_view b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1));
  for (std::size_t i = 0; i <= n; ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= m; ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[n][m];
}

// The closest candidate, or empty when none is close. A key filed under the
// wrong section ("geometry.restitution_sphere") is matched by its last part.
std::string suggest(std::string_view name, const std::vector<std::string>& candidates) {
  const std::size_t limit = std::max<std::size_t>(2, name.size() / 4);
  std::size_t best_score = limit + 1;
  std::string best;
  for (const std::string& c : candidates) {
    std::size_t score = edit_distance(name, c);
    if (c.find('.') != std::string::npos) {
      score = std::min(score, edit_distance(leaf_of(name), leaf_of(c)) + 1);
    }
    if (score < best_score) {
      best_score = score;
      best = c;
    }
  }
  return best;
}

std::vector<std::string> all_key_names() {
  std::vector<std::string> out;
  for (const KeyDesc& d : key_table()) out.emplace_back(d.name);
  for (const char* m : kMetaKeys) out.emplace_back(m);
  return out;
}

std::string unknown_key_message(const std::string& name) {
  std::string msg = "unknown key \"" + name + "\"";
  const std::string hint = suggest(name, all_key_names());
  if (!hint.empty()) return msg + "; did you mean \"" + hint + "\"?";
  const std::string section = section_of(name);
  if (name.find('.') != std::string::npos && is_section(section)) {
    std::vector<std::string> keys;
    for (const KeyDesc& d : key_table()) {
      if (section_of(d.name) == section) keys.push_back(leaf_of(d.name));
    }
    return msg + "; valid keys in [" + section + "]: " + join(keys, ", ");
  }
  return msg + "; see docs/CONFIG.md for the valid keys";
}

std::string unknown_section_message(const std::string& name) {
  std::string msg = "unknown section \"" + name + "\"";
  const std::string hint = suggest(name, section_names());
  if (!hint.empty()) return msg + "; did you mean \"" + hint + "\"?";
  return msg + "; valid sections: " + join(section_names(), ", ");
}

// ---- conversion and checks ---------------------------------------------------

std::string expected_type(const KeyDesc& d) {
  switch (d.type) {
    case KeyType::Real: return "expected a number (float)";
    case KeyType::Integer: return "expected an integer";
    case KeyType::Bool: return "expected a boolean (true or false)";
    case KeyType::Enum: return "expected a string, one of " + join(d.choices(), ", ");
  }
  return "";
}

std::string value_text(const Value& v) {
  return std::visit(
      [](const auto& x) -> std::string {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, double>) {
          return format_real(x);
        } else if constexpr (std::is_same_v<T, std::int64_t>) {
          return std::to_string(x);
        } else if constexpr (std::is_same_v<T, bool>) {
          return x ? "true" : "false";
        } else {
          return toml_quote(x);
        }
      },
      v);
}

// The value as the user wrote it (TOML notation), for messages.
std::string node_text(const toml::node& n) {
  if (const auto* f = n.as_floating_point()) return format_real(f->get());
  if (const auto* i = n.as_integer()) return std::to_string(i->get());
  if (const auto* b = n.as_boolean()) return b->get() ? "true" : "false";
  if (const auto* s = n.as_string()) return toml_quote(s->get());
  if (n.is_table()) return "(a table)";
  std::ostringstream os;
  n.visit([&os](const auto& x) { os << x; });
  return os.str();
}

// TOML node -> the key's type, or nullopt with *why set.
std::optional<Value> convert(const KeyDesc& d, const toml::node& n, std::string* why) {
  switch (d.type) {
    case KeyType::Real:
      if (const auto* f = n.as_floating_point()) return Value(f->get());
      if (const auto* i = n.as_integer()) return Value(static_cast<double>(i->get()));
      break;
    case KeyType::Integer:
      if (const auto* i = n.as_integer()) return Value(i->get());
      if (const auto* f = n.as_floating_point()) {
        // A float is accepted when it is an integer (300.0, 1e3).
        const double x = f->get();
        if (std::isfinite(x) && x == std::floor(x) && std::fabs(x) < 9.0e18) {
          return Value(static_cast<std::int64_t>(x));
        }
      }
      break;
    case KeyType::Bool:
      if (const auto* b = n.as_boolean()) return Value(b->get());
      break;
    case KeyType::Enum:
      if (const auto* s = n.as_string()) return Value(s->get());
      break;
  }
  *why = expected_type(d);
  return std::nullopt;
}

// The key's own rule; empty when the value is valid.
std::string check_value(const KeyDesc& d, const Value& v) {
  const std::string rt = range_text(d.range);
  switch (d.type) {
    case KeyType::Real: {
      const double x = std::get<double>(v);
      if (!std::isfinite(x)) return rt.empty() ? "must be finite" : "must be a finite number " + rt;
      if (!in_range(d.range, x)) return "must be " + rt;
      return "";
    }
    case KeyType::Integer: {
      const std::int64_t n = std::get<std::int64_t>(v);
      if (!in_range(d.range, static_cast<double>(n))) return "must be an integer " + rt;
      if (n > d.int_max) return "must be an integer <= " + std::to_string(d.int_max);
      if (n < d.int_min) return "must be an integer >= " + std::to_string(d.int_min);
      return "";
    }
    case KeyType::Bool:
      return "";
    case KeyType::Enum: {
      const auto names = d.choices();
      const std::string& name = std::get<std::string>(v);
      if (std::find(names.begin(), names.end(), name) == names.end()) {
        const std::string hint = suggest(name, names);
        return "must be one of " + join(names, ", ") + (hint.empty() ? "" : "; did you mean \"" + hint + "\"?");
      }
      return "";
    }
  }
  return "";
}

// ---- error collection ---------------------------------------------------------

struct Problems {
  struct Entry {
    int phase;  // 0 file, 1 overrides, 2 cross-key rules
    std::uint32_t line, column;
    std::size_t seq;
    std::string text;
  };
  std::vector<Entry> entries;

  void add(int phase, std::uint32_t line, std::uint32_t column, std::string text) {
    entries.push_back({phase, line, column, entries.size(), std::move(text)});
  }
  void throw_if_any() {
    if (entries.empty()) return;
    std::stable_sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
      return std::tie(a.phase, a.line, a.column, a.seq) < std::tie(b.phase, b.line, b.column, b.seq);
    });
    std::string msg;
    for (const Entry& e : entries) {
      if (!msg.empty()) msg += '\n';
      msg += e.text;
    }
    throw ConfigError(msg);
  }
};

std::string position(const std::string& source, const toml::source_region& r) {
  if (r.begin.line == 0) return source + ": ";
  return source + ":" + std::to_string(r.begin.line) + ":" + std::to_string(r.begin.column) + ": ";
}

// Where each key was last set ("file.toml:3:14: ", "--set: "), for messages of
// the cross-key rules; keys left at their default are absent.
using Origins = std::map<std::string, std::string>;

std::string origin(const Origins& origins, const std::string& key) {
  const auto it = origins.find(key);
  return it == origins.end() ? std::string() : it->second;
}

// Rules that involve several keys. Assumes every key passed check_value.
void check_cross(const SimParams& p, const Origins& origins, Problems& problems) {
  const char* species[] = {"sphere", "linker", "wall"};
  const double statics[] = {p.contact.static_friction_sphere, p.contact.static_friction_linker,
                            p.contact.static_friction_wall};
  const double dynamics[] = {p.contact.dynamic_friction_sphere, p.contact.dynamic_friction_linker,
                             p.contact.dynamic_friction_wall};
  for (int k = 0; k < 3; ++k) {
    if (dynamics[k] > statics[k]) {
      const std::string dyn = std::string("contact.dynamic_friction_") + species[k];
      const std::string sta = std::string("contact.static_friction_") + species[k];
      std::string where = origin(origins, dyn);
      if (where.empty()) where = origin(origins, sta);
      problems.add(2, 0, 0,
                   where + dyn + " = " + format_real(dynamics[k]) + ": must be <= " + sta + " = " +
                       format_real(statics[k]) + " (dynamic friction cannot exceed static friction)");
    }
  }

  if (static_cast<std::int64_t>(p.init.spheres) + p.init.linkers < 1) {
    std::string where = origin(origins, "init.spheres");
    if (where.empty()) where = origin(origins, "init.linkers");
    problems.add(2, 0, 0,
                 where + "init.spheres + init.linkers = " +
                     std::to_string(static_cast<std::int64_t>(p.init.spheres) + p.init.linkers) +
                     ": must be >= 1 (at least one body)");
  }

  // The N_t series, sampled when bonding is on, holds t_max / sample_interval
  // + 1 samples: bound it. (Hard-body runs sample nothing and may set t_max
  // huge to stop on run.max_events; `run --series` bounds its own file.)
  if (p.bonding.enabled && p.run.t_max / p.run.sample_interval > kMaxSamples) {
    std::string where = origin(origins, "run.sample_interval");
    if (where.empty()) where = origin(origins, "run.t_max");
    problems.add(2, 0, 0,
                 where + "run.t_max / run.sample_interval = " + format_real(p.run.t_max) + " / " +
                     format_real(p.run.sample_interval) + " = " +
                     format_real(p.run.t_max / p.run.sample_interval) + " samples of N_t: must be <= " +
                     format_real(kMaxSamples) + " (80 MB per replicate in memory, 40 MB per row with run --series); "
                     "raise run.sample_interval to >= " + format_real(p.run.t_max / kMaxSamples) + " or lower run.t_max");
  }

  // A body must fit in the box with room to move: l_B > 2 * bounding radius
  // of the largest species present (linker: half-diagonal of the cylinder).
  const double r_sphere = p.geometry.sphere_radius;
  const double r_linker = std::hypot(p.geometry.linker_radius, 0.5 * p.geometry.linker_length);
  double r_max = 0.0;
  std::string which;
  if (p.init.spheres > 0 && r_sphere > r_max) {
    r_max = r_sphere;
    which = "sphere bounding radius geometry.sphere_radius = " + format_real(r_sphere);
  }
  if (p.init.linkers > 0 && r_linker > r_max) {
    r_max = r_linker;
    which = "linker bounding radius sqrt(geometry.linker_radius^2 + (geometry.linker_length/2)^2) = " +
            format_real(r_linker);
  }
  // A periodic box must exceed twice the interaction range of the species
  // present for the minimum-image convention to hold: the run's own bound
  // (core/interaction_range.hpp), so a box accepted here also runs.
  const InteractionRange reach = interaction_range(p);
  const double periodic_min = reach.periodic_min_box();
  if (!(p.geometry.box_length > 2.0 * r_max)) {
    problems.add(2, 0, 0,
                 origin(origins, "geometry.box_length") + "geometry.box_length = " +
                     format_real(p.geometry.box_length) + ": must be > 2 x the largest body bounding radius = " +
                     format_real(2.0 * r_max) + " (" + which + ")");
  } else if (p.geometry.boundary == Boundary::Periodic && !(p.geometry.box_length > periodic_min)) {
    std::string terms = reach.capture > reach.contact
                            ? std::string("capture range ") +
                                  (p.bonding.capture_site == CaptureSite::EndFace
                                       ? "sqrt((geometry.linker_length/2)^2 + geometry.linker_radius^2)"
                                       : "geometry.linker_length/2") +
                                  " + geometry.sphere_radius + bonding.capture_distance = " + format_real(reach.capture)
                            : "2 x " + which;
    terms += " + 2 x run.contact_tolerance";
    if (reach.slack > 0.0)
      terms += " + 2 x cell slack " + format_real(0.5 * reach.slack) + " of bonded clusters (bonding.enabled)";
    std::string where = origin(origins, "geometry.box_length");
    if (where.empty()) where = origin(origins, "geometry.boundary");
    problems.add(2, 0, 0,
                 where + "geometry.box_length = " + format_real(p.geometry.box_length) + ": must be > " +
                     format_real(periodic_min) + " with geometry.boundary = periodic (twice the interaction range " +
                     "2 x (" + terms + "), for the minimum-image convention)");
  }

  // The capture band is a thin shell at an end face: with r_c >= l_L one end
  // could capture a sphere resting on the axis against the other end face,
  // so both ends of one linker could bond the same sphere.
  if (!(p.bonding.capture_distance < p.geometry.linker_length)) {
    std::string where = origin(origins, "bonding.capture_distance");
    if (where.empty()) where = origin(origins, "geometry.linker_length");
    problems.add(2, 0, 0,
                 where + "bonding.capture_distance = " + format_real(p.bonding.capture_distance) +
                     ": must be < geometry.linker_length = " + format_real(p.geometry.linker_length));
  }

  // Compliant clusters carry a sphere's spin as a constant (no compliant load
  // turns a smooth sphere, core/compliant.hpp): frictional sphere contacts,
  // which would change it, are refused rather than run with a wrong torque.
  // Articulated clusters likewise: a sphere is a point mass on its joints.
  const bool integrated = (p.bonding.enabled && p.compliant.enabled()) || articulated_bonds(p);
  if (integrated && (p.contact.static_friction_sphere > 0.0 || p.contact.dynamic_friction_sphere > 0.0)) {
    const char* key = p.contact.static_friction_sphere > 0.0 ? "contact.static_friction_sphere"
                                                              : "contact.dynamic_friction_sphere";
    const double value = std::max(p.contact.static_friction_sphere, p.contact.dynamic_friction_sphere);
    problems.add(2, 0, 0,
                 origin(origins, key) + key + " = " + format_real(value) +
                     ": must be 0 with compliant bonds (compliant.k or compliant.k_omega > 0) and with "
                     "bonding.joint = articulated: their clusters model smooth spheres (use bonding.joint = welded)");
  }

  // Exclusions of bonded pairs only: meaningful where bonded bodies move
  // relative to each other under hard contacts alone (articulated joints);
  // springs (compliant) would press a 1-3 pair into contact, welded pairs
  // never move.
  if (p.bonding.exclusions == Exclusions::OneTwo && p.bonding.enabled && !articulated_bonds(p)) {
    problems.add(2, 0, 0,
                 origin(origins, "bonding.exclusions") +
                     "bonding.exclusions = 1-2: only with articulated rigid bonds (bonding.joint = articulated, "
                     "compliant.k = compliant.k_omega = 0); use 1-3");
  }

  // A steady-state test needs enough batch means to say "not steady"
  // (analysis/mser.hpp, kMinMonitorBatches).
  const std::int64_t min_batches = static_cast<std::int64_t>(kMinMonitorBatches);
  if (static_cast<std::int64_t>(p.run.mser_min_samples) < min_batches * static_cast<std::int64_t>(p.run.mser_batch)) {
    std::string where = origin(origins, "run.mser_min_samples");
    if (where.empty()) where = origin(origins, "run.mser_batch");
    problems.add(2, 0, 0,
                 where + "run.mser_min_samples = " + std::to_string(p.run.mser_min_samples) + ": must be >= " +
                     std::to_string(min_batches) + " x run.mser_batch = " +
                     std::to_string(min_batches * static_cast<std::int64_t>(p.run.mser_batch)) +
                     " (MSER needs at least " + std::to_string(min_batches) + " batch means to tell a trend)");
  }
}

// Per-key checks of settings built in code (loading checks each value as it
// is read).
void check_keys(const SimParams& p, Problems& problems) {
  for (const KeyDesc& d : key_table()) {
    const Value v = d.get(p);
    const std::string why = check_value(d, v);
    if (!why.empty()) problems.add(0, 0, 0, std::string(d.name) + " = " + value_text(v) + ": " + why);
  }
}

// ---- loading -------------------------------------------------------------------

class Loader {
 public:
  Scenario scenario;

  void load_text(const std::string& text, const std::string& source) {
    toml::table root;
    try {
      root = toml::parse(std::string_view(text), std::string_view(source));
    } catch (const toml::parse_error& e) {
      throw ConfigError(position(source, e.source()) + "TOML syntax error: " + std::string(e.description()));
    }
    for (const auto& [k, node] : root) {
      const std::string top(k.str());
      if (top == "name" || top == "description") {
        apply_meta(top, node, 0, position(source, node.source()), node.source());
      } else if (is_section(top)) {
        const toml::table* tbl = node.as_table();
        if (!tbl) {
          add(0, node.source(),
              position(source, node.source()) + top + " = " + node_text(node) + ": expected a table ([" +
                  top + "])");
          continue;
        }
        for (const auto& [k2, n2] : *tbl) {
          const std::string full = top + "." + std::string(k2.str());
          const KeyDesc* d = find_key(full);
          if (!d) {
            add(0, k2.source(), position(source, k2.source()) + unknown_key_message(full));
            continue;
          }
          apply(*d, n2, 0, position(source, n2.source()), n2.source(), node_text(n2));
        }
      } else if (node.is_table()) {
        add(0, k.source(), position(source, k.source()) + unknown_section_message(top));
      } else {
        add(0, k.source(), position(source, k.source()) + unknown_key_message(top));
      }
    }
  }

  void load_override(const std::string& ov) {
    const std::string where = "--set: ";
    const auto eq = ov.find('=');
    if (eq == std::string::npos) {
      add(1, {}, where + "\"" + ov + "\": expected section.key=value");
      return;
    }
    const std::string name = trim(ov.substr(0, eq));
    const std::string raw = trim(ov.substr(eq + 1));
    const bool meta = name == "name" || name == "description";
    const KeyDesc* d = meta ? nullptr : find_key(name);
    if (!meta && !d) {
      add(1, {}, where + unknown_key_message(name));
      return;
    }
    // The value in TOML notation; a bare word is taken as a string for enum
    // and string keys ("--set geometry.boundary=periodic").
    std::optional<toml::table> parsed;
    try {
      const std::string doc = "v = " + raw;
      toml::table t = toml::parse(std::string_view(doc), std::string_view("--set"));
      if (t.size() == 1 && t.contains("v")) parsed = std::move(t);
    } catch (const toml::parse_error&) {
    }
    // Metadata is free text: anything that is not a TOML string is taken as written.
    if (meta && parsed && !parsed->get("v")->is_string()) parsed.reset();
    const bool stringy = meta || d->type == KeyType::Enum;
    if (parsed) {
      const toml::node& n = *parsed->get("v");
      if (meta) {
        apply_meta(name, n, 1, where, {});
      } else {
        apply(*d, n, 1, where, {}, node_text(n));
      }
    } else if (stringy) {
      const toml::value<std::string> n(raw);
      if (meta) {
        apply_meta(name, n, 1, where, {});
      } else {
        apply(*d, n, 1, where, {}, toml_quote(raw));
      }
    } else {
      add(1, {}, where + name + " = " + (raw.empty() ? "(empty)" : raw) + ": " + expected_type(*d));
    }
  }

  void finish() {
    problems_.throw_if_any();
    check_cross(scenario.params, origins_, problems_);
    problems_.throw_if_any();
  }

 private:
  Problems problems_;
  Origins origins_;

  static std::string trim(const std::string& s) {
    const auto b = s.find_first_not_of(" \t");
    if (b == std::string::npos) return "";
    const auto e = s.find_last_not_of(" \t");
    return s.substr(b, e - b + 1);
  }

  void add(int phase, const toml::source_region& r, std::string text) {
    problems_.add(phase, r.begin.line, r.begin.column, std::move(text));
  }

  void apply(const KeyDesc& d, const toml::node& n, int phase, const std::string& where,
             const toml::source_region& r, const std::string& shown) {
    std::string why;
    const std::optional<Value> v = convert(d, n, &why);
    if (v) why = check_value(d, *v);
    if (!why.empty()) {
      add(phase, r, where + d.name + " = " + shown + ": " + why);
      return;
    }
    d.set(scenario.params, *v);
    origins_[d.name] = where;
  }

  void apply_meta(const std::string& name, const toml::node& n, int phase, const std::string& where,
                  const toml::source_region& r) {
    const auto* s = n.as_string();
    if (!s) {
      add(phase, r, where + name + " = " + node_text(n) + ": expected a string");
      return;
    }
    (name == "name" ? scenario.name : scenario.description) = s->get();
  }
};

}  // namespace

std::string read_scenario_text(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw ConfigError("configuration file \"" + path + "\" not found");
  }
  if (std::filesystem::is_directory(path, ec)) {
    throw ConfigError("configuration file \"" + path + "\" is a directory");
  }
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw ConfigError("cannot open configuration file \"" + path + "\"" +
                      (errno ? std::string(": ") + std::strerror(errno) : std::string()));
  }
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw ConfigError("cannot read configuration file \"" + path + "\"");
  return ss.str();
}

namespace {

std::string toml_value(const KeyDesc& d, const SimParams& p) {
  const Value v = d.get(p);
  switch (d.type) {
    case KeyType::Real: return toml_real(std::get<double>(v));
    case KeyType::Integer: return std::to_string(std::get<std::int64_t>(v));
    case KeyType::Bool: return std::get<bool>(v) ? "true" : "false";
    case KeyType::Enum: return toml_quote(std::get<std::string>(v));
  }
  return "";
}

std::string range_info(const KeyDesc& d) {
  switch (d.type) {
    case KeyType::Real: return range_text(d.range);
    case KeyType::Integer: return range_text(d.range);
    case KeyType::Bool: return "true, false";
    case KeyType::Enum: return join(d.choices(), ", ");
  }
  return "";
}

}  // namespace

// ---- public API ------------------------------------------------------------------

const std::vector<KeyInfo>& config_keys() {
  static const std::vector<KeyInfo> keys = [] {
    std::vector<KeyInfo> out;
    const SimParams defaults;
    for (const KeyDesc& d : key_table()) {
      std::string range = range_info(d);
      if (range.rfind("in ", 0) == 0) range = range.substr(3);
      out.push_back({d.name, type_name(d.type), toml_value(d, defaults), range, d.doc});
    }
    return out;
  }();
  return keys;
}

Scenario load_scenario(const std::string& toml_text, const std::vector<std::string>& overrides,
                       const std::string& source_name) {
  Loader loader;
  loader.load_text(toml_text, source_name);
  for (const std::string& ov : overrides) loader.load_override(ov);
  loader.finish();
  return loader.scenario;
}

Scenario load_scenario_file(const std::string& path, const std::vector<std::string>& overrides) {
  if (path.empty()) return load_scenario("", overrides, "<defaults>");
  return load_scenario(read_scenario_text(path), overrides, path);
}

SimParams load_config(const std::string& toml_text, const std::vector<std::string>& overrides,
                      const std::string& source_name) {
  return load_scenario(toml_text, overrides, source_name).params;
}

SimParams load_config_file(const std::string& path, const std::vector<std::string>& overrides) {
  return load_scenario_file(path, overrides).params;
}

void validate(const SimParams& params) {
  Problems problems;
  check_keys(params, problems);
  problems.throw_if_any();
  check_cross(params, {}, problems);
  problems.throw_if_any();
}

std::string config_to_toml(const SimParams& params) {
  std::string out;
  std::string section;
  for (const KeyDesc& d : key_table()) {
    const std::string s = section_of(d.name);
    if (s != section) {
      if (!section.empty()) out += '\n';
      out += "[" + s + "]\n";
      section = s;
    }
    out += leaf_of(d.name) + " = " + toml_value(d, params) + "\n";
  }
  return out;
}

std::string scenario_to_toml(const Scenario& scenario) {
  std::string out;
  if (!scenario.name.empty()) out += "name = " + toml_quote(scenario.name) + "\n";
  if (!scenario.description.empty()) out += "description = " + toml_quote(scenario.description) + "\n";
  if (!out.empty()) out += '\n';
  return out + config_to_toml(scenario.params);
}

}  // namespace ringsim
