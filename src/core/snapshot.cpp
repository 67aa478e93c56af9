// Snapshot writers and the extended XYZ reader; the formats are described in
// docs/OUTPUT.md, "Snapshots".
//
// Extended XYZ column names and their OVITO 3 properties (OVITO's XYZ
// importer, XYZImporter::mapVariableToProperty, maps them by name):
//   species -> Particle Type, pos -> Position, radius -> Radius,
//   orientation -> Orientation (X, Y, Z, W: the columns in this order),
//   aspherical_shape -> Aspherical Shape; axis, half_length and object become
//   user properties of the same names.
// OVITO's cylinder shape (manual, "Non-spherical particle shapes",
// https://docs.ovito.org/advanced_topics/aspherical_particles.html#cylinders,
// and "Particles" visual element): radius = Aspherical Shape.X, height =
// Aspherical Shape.Z (Y ignored), rest axis +z, rotated by Orientation; the
// renderer (ParticlesVis::renderCylindricalParticles) centres it on the
// particle position, from x - h/2 q(z) to x + h/2 q(z). Hence a linker is
// written as aspherical_shape = (r, r, 2 * half_length) and orientation =
// the rotation taking z onto its axis. Spheres get aspherical_shape = (0, 0, 0),
// for which OVITO documents the fall-back to the Radius property (a sphere,
// not an ellipsoid), and the identity orientation.
#include "core/snapshot.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <istream>
#include <limits>
#include <map>
#include <ostream>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>

namespace ringsim {
namespace {

// Tolerance on |axis| - 1 and on the derived columns (orientation) when read.
constexpr double kUnitTolerance = 1e-6;

// ---- number formatting: shortest text that reads back to the same double ----

void put(std::string& out, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

void put(std::string& out, long long v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

void put(std::string& out, int v) { put(out, static_cast<long long>(v)); }

// ---- validation shared by the writers ----------------------------------------

std::string body_name(int i) { return "snapshot body " + std::to_string(i); }

void validate(const Snapshot& s) {
  if (!std::isfinite(s.time)) throw std::invalid_argument("snapshot time is not finite");
  if (!(std::isfinite(s.box_length) && s.box_length > 0.0))
    throw std::invalid_argument("snapshot box_length = " + std::to_string(s.box_length) +
                                " must be finite and > 0");
  for (const char c : s.comment) {
    if (c == '"' || c == '\\' || c == '\n' || c == '\r')
      throw std::invalid_argument(
          "snapshot comment must not contain '\"', '\\\\', a newline or a carriage return");
  }
  const int n = static_cast<int>(s.bodies.size());
  for (int i = 0; i < n; ++i) {
    const SnapshotBody& b = s.bodies[i];
    if (!b.x.allFinite()) throw std::invalid_argument(body_name(i) + ": position is not finite");
    if (!b.axis.allFinite()) throw std::invalid_argument(body_name(i) + ": axis is not finite");
    if (!(std::isfinite(b.radius) && b.radius > 0.0))
      throw std::invalid_argument(body_name(i) + ": radius = " + std::to_string(b.radius) +
                                  " must be finite and > 0");
    if (b.sphere) {
      if (b.half_length != 0.0)
        throw std::invalid_argument(body_name(i) + ": a sphere has half_length 0, got " +
                                    std::to_string(b.half_length));
    } else {
      if (!(std::isfinite(b.half_length) && b.half_length > 0.0))
        throw std::invalid_argument(body_name(i) + ": linker half_length = " +
                                    std::to_string(b.half_length) + " must be finite and > 0");
      if (std::abs(b.axis.norm() - 1.0) > kUnitTolerance)
        throw std::invalid_argument(body_name(i) + ": linker axis is not a unit vector");
    }
  }
  for (std::size_t k = 0; k < s.bonds.size(); ++k) {
    const auto [sp, lk] = s.bonds[k];
    const bool ok = sp >= 0 && sp < n && lk >= 0 && lk < n && s.bodies[sp].sphere &&
                    !s.bodies[lk].sphere;
    if (!ok)
      throw std::invalid_argument("snapshot bond " + std::to_string(k) + " (" +
                                  std::to_string(sp) + ", " + std::to_string(lk) +
                                  ") is not a (sphere id, linker id) pair of the " +
                                  std::to_string(n) + " bodies");
  }
  if (s.bond_ends.empty()) return;
  if (s.bond_ends.size() != s.bonds.size())
    throw std::invalid_argument("snapshot has " + std::to_string(s.bond_ends.size()) + " bond ends for " +
                                std::to_string(s.bonds.size()) + " bonds");
  std::set<std::pair<int, int>> seen;
  for (std::size_t k = 0; k < s.bonds.size(); ++k) {
    const int e = s.bond_ends[k];
    if (e != 0 && e != 1)
      throw std::invalid_argument("snapshot bond " + std::to_string(k) + " has end " + std::to_string(e) +
                                  " (valid: 0 = a, 1 = b)");
    if (!seen.emplace(s.bonds[k].second, e).second)
      throw std::invalid_argument("snapshot bond " + std::to_string(k) + ": end " + std::to_string(e) +
                                  " of linker " + std::to_string(s.bonds[k].second) + " is bonded twice");
  }
}

// Unit axis written for a body: spheres have none, so they get z (identity).
Vec3 written_axis(const SnapshotBody& b) { return b.sphere ? Vec3::UnitZ() : b.axis; }

// ---- extended XYZ reader helpers ---------------------------------------------

[[noreturn]] void fail(long line, const std::string& what) {
  throw std::runtime_error("extended XYZ line " + std::to_string(line) + ": " + what);
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::vector<std::string_view> split_ws(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    const std::size_t j = i;
    while (i < s.size() && !std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    if (i > j) out.push_back(s.substr(j, i - j));
  }
  return out;
}

bool parse_double(std::string_view t, double& v) {
  if (!t.empty() && t.front() == '+') t.remove_prefix(1);  // from_chars takes no '+'
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

bool parse_int(std::string_view t, long long& v) {
  if (!t.empty() && t.front() == '+') t.remove_prefix(1);
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

double need_double(std::string_view t, long line, const std::string& what) {
  double v = 0.0;
  if (!parse_double(t, v)) fail(line, what + ": '" + std::string(t) + "' is not a number");
  if (!std::isfinite(v)) fail(line, what + ": '" + std::string(t) + "' is not finite");
  return v;
}

// Key=value pairs of the comment line (extxyz: bare values end at whitespace,
// quoted values may hold spaces and backslash escapes; a key without '=' is a
// true flag). Keys are lower-cased.
std::map<std::string, std::string> parse_key_values(const std::string& s, long line) {
  std::map<std::string, std::string> kv;
  std::size_t i = 0;
  const std::size_t n = s.size();
  auto space = [&](std::size_t k) { return std::isspace(static_cast<unsigned char>(s[k])) != 0; };
  while (true) {
    while (i < n && space(i)) ++i;
    if (i >= n) break;
    const std::size_t k0 = i;
    while (i < n && s[i] != '=' && !space(i)) ++i;
    std::string key = lower(s.substr(k0, i - k0));
    if (key.empty()) fail(line, "empty key before '=' at column " + std::to_string(k0 + 1));
    std::string value = "T";
    if (i < n && s[i] == '=') {
      ++i;
      value.clear();
      if (i < n && s[i] == '"') {
        ++i;
        bool closed = false;
        while (i < n) {
          if (s[i] == '\\' && i + 1 < n) {
            value.push_back(s[i + 1]);
            i += 2;
          } else if (s[i] == '"') {
            closed = true;
            ++i;
            break;
          } else {
            value.push_back(s[i++]);
          }
        }
        if (!closed) fail(line, "unterminated quoted value of key '" + key + "'");
      } else {
        while (i < n && !space(i)) value.push_back(s[i++]);
      }
    }
    if (!kv.emplace(key, value).second) fail(line, "key '" + key + "' appears twice");
  }
  return kv;
}

struct Column {
  int first;  // index of the first whitespace-separated field
  char type;  // S, R, I or L
  int count;
};

std::map<std::string, Column> parse_properties(const std::string& spec, long line) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (true) {
    const std::size_t colon = spec.find(':', start);
    parts.push_back(spec.substr(start, colon - start));
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  if (parts.size() % 3 != 0)
    fail(line, "Properties='" + spec + "' is not a list of name:type:count triplets");
  std::map<std::string, Column> cols;
  int next = 0;
  for (std::size_t k = 0; k < parts.size(); k += 3) {
    const std::string& name = parts[k];
    const std::string& type = parts[k + 1];
    long long count = 0;
    if (name.empty() || type.size() != 1 || std::string("SRIL").find(type[0]) == std::string::npos)
      fail(line, "Properties entry '" + name + ":" + type + "' needs a name and a type S, R, I or L");
    if (!parse_int(parts[k + 2], count) || count < 1 || count > 9)
      fail(line, "Properties entry '" + name + "' has column count '" + parts[k + 2] +
                     "' (valid: 1 to 9)");
    if (!cols.emplace(lower(name), Column{next, type[0], static_cast<int>(count)}).second)
      fail(line, "Properties names '" + name + "' twice");
    next += static_cast<int>(count);
  }
  return cols;
}

const Column* require_column(const std::map<std::string, Column>& cols, const std::string& name,
                             char type, int count, bool required, long line) {
  const auto it = cols.find(name);
  if (it == cols.end()) {
    if (required) fail(line, "Properties lacks the column '" + name + "'");
    return nullptr;
  }
  if (it->second.type != type || it->second.count != count)
    fail(line, "Properties column '" + name + "' must be " + name + ":" + std::string(1, type) +
                   ":" + std::to_string(count));
  return &it->second;
}

bool getline_cr(std::istream& in, std::string& s) {
  if (!std::getline(in, s)) return false;
  if (!s.empty() && s.back() == '\r') s.pop_back();
  return true;
}

// The point of bond k on the linker, as seen from the sphere (minimum image
// when periodic): the bonded end (centre of an end face) when bond_ends says
// which, else the end nearest the sphere centre.
Vec3 bond_end(const Snapshot& s, std::size_t k) {
  const SnapshotBody& sph = s.bodies[s.bonds[k].first];
  const SnapshotBody& lk = s.bodies[s.bonds[k].second];
  auto seen_from_sphere = [&](double sign) {
    Vec3 d = lk.x + sign * lk.half_length * lk.axis - sph.x;
    if (s.periodic) {
      for (int c = 0; c < 3; ++c) d[c] -= s.box_length * std::round(d[c] / s.box_length);
    }
    return d;
  };
  if (!s.bond_ends.empty()) return sph.x + seen_from_sphere(s.bond_ends[k] == 0 ? 1.0 : -1.0);
  const Vec3 a = seen_from_sphere(1.0), b = seen_from_sphere(-1.0);
  return sph.x + (b.squaredNorm() < a.squaredNorm() ? b : a);
}

}  // namespace

void write_extended_xyz(std::ostream& out, const Snapshot& s) {
  validate(s);
  std::string t;
  t.reserve(200 + 160 * s.bodies.size() + 12 * s.bonds.size());
  put(t, static_cast<long long>(s.bodies.size()));
  t += "\nLattice=\"";
  const double L = s.box_length;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      if (r + c > 0) t += ' ';
      put(t, r == c ? L : 0.0);
    }
  }
  t += "\" Properties=species:S:1:pos:R:3:radius:R:1:orientation:R:4:aspherical_shape:R:3"
       ":axis:R:3:half_length:R:1:object:I:1 Time=";
  put(t, s.time);
  t += s.periodic ? " pbc=\"T T T\"" : " pbc=\"F F F\"";
  t += " bonds=\"";
  for (std::size_t k = 0; k < s.bonds.size(); ++k) {
    if (k > 0) t += ' ';
    put(t, s.bonds[k].first);
    t += '-';
    put(t, s.bonds[k].second);
  }
  t += '"';
  if (!s.bond_ends.empty()) {
    t += " bond_ends=\"";
    for (std::size_t k = 0; k < s.bond_ends.size(); ++k) {
      if (k > 0) t += ' ';
      put(t, s.bond_ends[k]);
    }
    t += '"';
  }
  t += " comment=\"";
  t += s.comment;
  t += "\"\n";
  for (const SnapshotBody& b : s.bodies) {
    const Vec3 a = written_axis(b);
    const Quat q = b.sphere ? Quat::Identity() : orientation_from_axis(a);
    t += b.sphere ? 'S' : 'L';
    for (int c = 0; c < 3; ++c) { t += ' '; put(t, b.x[c]); }
    t += ' ';
    put(t, b.radius);
    for (const double v : {q.x(), q.y(), q.z(), q.w()}) { t += ' '; put(t, v); }
    const std::array<double, 3> shape = b.sphere ? std::array<double, 3>{0.0, 0.0, 0.0}
                                                 : std::array<double, 3>{b.radius, b.radius,
                                                                         2.0 * b.half_length};
    for (const double v : shape) { t += ' '; put(t, v); }
    for (int c = 0; c < 3; ++c) { t += ' '; put(t, b.axis[c]); }
    t += ' ';
    put(t, b.half_length);
    t += ' ';
    put(t, b.object);
    t += '\n';
  }
  out << t;
  if (!out) throw std::runtime_error("write_extended_xyz: the output stream failed");
}

Snapshot read_extended_xyz(std::istream& in) {
  std::string line;
  if (!getline_cr(in, line)) fail(1, "empty input (expected the number of bodies)");
  const auto count_tokens = split_ws(line);
  long long n = -1;
  if (count_tokens.size() != 1 || !parse_int(count_tokens[0], n) || n < 0)
    fail(1, "expected the number of bodies, got '" + line + "'");

  if (!getline_cr(in, line)) fail(2, "missing the comment line (key=value pairs)");
  const auto kv = parse_key_values(line, 2);
  auto get = [&](const char* key) -> const std::string* {
    const auto it = kv.find(key);
    return it == kv.end() ? nullptr : &it->second;
  };

  Snapshot s;
  const std::string* lattice = get("lattice");
  if (!lattice) fail(2, "missing Lattice=\"L 0 0 0 L 0 0 0 L\"");
  {
    const auto f = split_ws(*lattice);
    if (f.size() != 9) fail(2, "Lattice needs 9 numbers, got " + std::to_string(f.size()));
    std::array<double, 9> m{};
    for (int k = 0; k < 9; ++k) m[k] = need_double(f[k], 2, "Lattice");
    const bool cube = m[0] > 0.0 && m[4] == m[0] && m[8] == m[0] && m[1] == 0.0 && m[2] == 0.0 &&
                      m[3] == 0.0 && m[5] == 0.0 && m[6] == 0.0 && m[7] == 0.0;
    if (!cube) fail(2, "Lattice=\"" + *lattice + "\" is not a cube \"L 0 0 0 L 0 0 0 L\", L > 0");
    s.box_length = m[0];
  }
  if (const std::string* pbc = get("pbc")) {
    const auto f = split_ws(*pbc);
    auto flag = [](std::string_view v, bool& out) {
      const std::string l = lower(std::string(v));
      if (l == "t" || l == "true" || l == "1") { out = true; return true; }
      if (l == "f" || l == "false" || l == "0") { out = false; return true; }
      return false;
    };
    std::array<bool, 3> p{};
    const bool ok = f.size() == 3 && flag(f[0], p[0]) && flag(f[1], p[1]) && flag(f[2], p[2]) &&
                    p[0] == p[1] && p[1] == p[2];
    if (!ok) fail(2, "pbc=\"" + *pbc + "\" must be \"T T T\" or \"F F F\"");
    s.periodic = p[0];
  } else {
    s.periodic = true;  // extxyz: a Lattice without pbc means periodic
  }
  const std::string* time = get("time");
  if (!time) fail(2, "missing Time=");
  s.time = need_double(*time, 2, "Time");
  if (const std::string* comment = get("comment")) s.comment = *comment;

  const std::string* props = get("properties");
  if (!props) fail(2, "missing Properties=");
  const auto cols = parse_properties(*props, 2);
  const Column* c_species = require_column(cols, "species", 'S', 1, true, 2);
  const Column* c_pos = require_column(cols, "pos", 'R', 3, true, 2);
  const Column* c_radius = require_column(cols, "radius", 'R', 1, true, 2);
  const Column* c_axis = require_column(cols, "axis", 'R', 3, true, 2);
  const Column* c_half = require_column(cols, "half_length", 'R', 1, true, 2);
  const Column* c_object = require_column(cols, "object", 'I', 1, true, 2);
  const Column* c_orient = require_column(cols, "orientation", 'R', 4, false, 2);
  const Column* c_shape = require_column(cols, "aspherical_shape", 'R', 3, false, 2);
  int n_fields = 0;
  for (const auto& [name, c] : cols) n_fields = std::max(n_fields, c.first + c.count);

  s.bodies.resize(static_cast<std::size_t>(n));
  for (long long i = 0; i < n; ++i) {
    const long ln = static_cast<long>(3 + i);
    if (!getline_cr(in, line))
      fail(ln, "end of input; expected body " + std::to_string(i) + " of " + std::to_string(n));
    const auto f = split_ws(line);
    if (static_cast<int>(f.size()) != n_fields)
      fail(ln, "expected " + std::to_string(n_fields) + " fields, got " + std::to_string(f.size()));
    SnapshotBody& b = s.bodies[static_cast<std::size_t>(i)];
    const std::string_view sp = f[c_species->first];
    if (sp != "S" && sp != "L") fail(ln, "species '" + std::string(sp) + "' is neither S nor L");
    b.sphere = sp == "S";
    for (int c = 0; c < 3; ++c) {
      b.x[c] = need_double(f[c_pos->first + c], ln, "pos");
      b.axis[c] = need_double(f[c_axis->first + c], ln, "axis");
    }
    b.radius = need_double(f[c_radius->first], ln, "radius");
    b.half_length = need_double(f[c_half->first], ln, "half_length");
    long long object = 0;
    if (!parse_int(f[c_object->first], object) || object < std::numeric_limits<int>::min() ||
        object > std::numeric_limits<int>::max())
      fail(ln, "object '" + std::string(f[c_object->first]) + "' is not an integer");
    b.object = static_cast<int>(object);
    if (!(b.radius > 0.0)) fail(ln, "radius must be > 0");
    if (b.sphere && b.half_length != 0.0) fail(ln, "a sphere (S) must have half_length 0");
    if (!b.sphere) {
      if (!(b.half_length > 0.0)) fail(ln, "a linker (L) must have half_length > 0");
      if (std::abs(b.axis.norm() - 1.0) > kUnitTolerance) fail(ln, "linker axis is not a unit vector");
    }
    // Derived columns must agree with the primary ones (catches a file whose
    // columns were reordered without updating Properties).
    if (c_orient) {
      Quat q;
      q.x() = need_double(f[c_orient->first + 0], ln, "orientation");
      q.y() = need_double(f[c_orient->first + 1], ln, "orientation");
      q.z() = need_double(f[c_orient->first + 2], ln, "orientation");
      q.w() = need_double(f[c_orient->first + 3], ln, "orientation");
      if (std::abs(q.norm() - 1.0) > kUnitTolerance) fail(ln, "orientation is not a unit quaternion");
      if (!b.sphere && (q * Vec3::UnitZ() - b.axis).norm() > kUnitTolerance)
        fail(ln, "orientation (x y z w) does not rotate z onto the axis");
    }
    if (c_shape) {
      Vec3 shape;
      for (int c = 0; c < 3; ++c) shape[c] = need_double(f[c_shape->first + c], ln, "aspherical_shape");
      const Vec3 expect = b.sphere ? Vec3::Zero() : Vec3(b.radius, b.radius, 2.0 * b.half_length);
      if ((shape - expect).norm() > kUnitTolerance * std::max(1.0, expect.norm()))
        fail(ln, b.sphere ? "aspherical_shape of a sphere must be 0 0 0"
                          : "aspherical_shape of a linker must be radius radius 2*half_length");
    }
  }

  if (const std::string* bonds = get("bonds")) {
    for (const std::string_view tok : split_ws(*bonds)) {
      const std::size_t dash = tok.find('-', 1);
      long long a = -1, l = -1;
      if (dash == std::string_view::npos || !parse_int(tok.substr(0, dash), a) ||
          !parse_int(tok.substr(dash + 1), l))
        fail(2, "bond '" + std::string(tok) + "' is not 'sphere-linker'");
      const bool ok = a >= 0 && a < n && l >= 0 && l < n && s.bodies[a].sphere && !s.bodies[l].sphere;
      if (!ok) fail(2, "bond '" + std::string(tok) + "' is not a (sphere id, linker id) pair");
      s.bonds.emplace_back(static_cast<int>(a), static_cast<int>(l));
    }
  }
  if (const std::string* ends = get("bond_ends")) {
    for (const std::string_view tok : split_ws(*ends)) {
      long long e = -1;
      if (!parse_int(tok, e) || (e != 0 && e != 1))
        fail(2, "bond end '" + std::string(tok) + "' is not 0 (a) or 1 (b)");
      s.bond_ends.push_back(static_cast<int>(e));
    }
    if (s.bond_ends.size() != s.bonds.size())
      fail(2, "bond_ends has " + std::to_string(s.bond_ends.size()) + " ends for " + std::to_string(s.bonds.size()) +
                  " bonds");
  }
  return s;
}

void write_vtk(std::ostream& out, const Snapshot& s) {
  validate(s);
  const int n = static_cast<int>(s.bodies.size());
  const int nb = static_cast<int>(s.bonds.size());
  const int np = n + nb;  // body centres, then one bond point per bond
  std::vector<Vec3> bond_points;
  bond_points.reserve(nb);
  for (std::size_t k = 0; k < s.bonds.size(); ++k) bond_points.push_back(bond_end(s, k));

  std::string t;
  t.reserve(400 + 200 * static_cast<std::size_t>(np));
  t += "# vtk DataFile Version 3.0\n";
  std::string title = "ringsim snapshot time=";
  put(title, s.time);
  title += s.periodic ? " periodic box=" : " reflective box=";
  put(title, s.box_length);
  if (!s.comment.empty()) title += " " + s.comment;
  if (title.size() > 255) title.resize(255);  // the legacy header line holds 256 characters
  t += title;
  t += "\nASCII\nDATASET POLYDATA\nPOINTS ";
  put(t, np);
  t += " double\n";
  auto vec = [&](const Vec3& v) {
    put(t, v.x());
    t += ' ';
    put(t, v.y());
    t += ' ';
    put(t, v.z());
    t += '\n';
  };
  for (const SnapshotBody& b : s.bodies) vec(b.x);
  for (const Vec3& p : bond_points) vec(p);
  if (n > 0) {
    t += "VERTICES ";
    put(t, n);
    t += ' ';
    put(t, 2 * n);
    t += '\n';
    for (int i = 0; i < n; ++i) {
      t += "1 ";
      put(t, i);
      t += '\n';
    }
  }
  if (nb > 0) {
    t += "LINES ";
    put(t, nb);
    t += ' ';
    put(t, 3 * nb);
    t += '\n';
    for (int k = 0; k < nb; ++k) {
      t += "2 ";
      put(t, s.bonds[k].first);
      t += ' ';
      put(t, n + k);
      t += '\n';
    }
  }
  auto int_array = [&](const char* name, auto value_of, int count) {
    t += "SCALARS ";
    t += name;
    t += " int 1\nLOOKUP_TABLE default\n";
    for (int i = 0; i < count; ++i) {
      put(t, value_of(i));
      t += '\n';
    }
  };
  t += "POINT_DATA ";
  put(t, np);
  t += '\n';
  // species: 0 sphere, 1 linker, -1 bond point.
  int_array("species", [&](int i) { return i < n ? (s.bodies[i].sphere ? 0 : 1) : -1; }, np);
  int_array("body", [&](int i) { return i < n ? i : -1; }, np);
  int_array("object", [&](int i) { return s.bodies[i < n ? i : s.bonds[i - n].first].object; }, np);
  t += "SCALARS radius double 1\nLOOKUP_TABLE default\n";
  for (int i = 0; i < np; ++i) {
    put(t, i < n ? s.bodies[i].radius : 0.0);
    t += '\n';
  }
  t += "SCALARS half_length double 1\nLOOKUP_TABLE default\n";
  for (int i = 0; i < np; ++i) {
    put(t, i < n ? s.bodies[i].half_length : 0.0);
    t += '\n';
  }
  // Orientation for the Glyph filter: the unit axis (spheres z, bond points 0).
  t += "VECTORS axis double\n";
  for (int i = 0; i < np; ++i) vec(i < n ? written_axis(s.bodies[i]) : Vec3::Zero());
  // Per-component glyph scale in the glyph's own frame, whose x axis the
  // Glyph filter turns onto `axis`: a unit-diameter, unit-height cylinder
  // lying along x becomes (2 half_length, 2 r, 2 r); a unit-diameter sphere
  // becomes (2 r, 2 r, 2 r); bond points vanish (0, 0, 0).
  t += "VECTORS glyph_scale double\n";
  for (int i = 0; i < np; ++i) {
    if (i >= n) {
      vec(Vec3::Zero());
      continue;
    }
    const SnapshotBody& b = s.bodies[i];
    const double d = 2.0 * b.radius;
    vec(b.sphere ? Vec3(d, d, d) : Vec3(2.0 * b.half_length, d, d));
  }
  t += "CELL_DATA ";
  put(t, n + nb);
  t += '\n';
  // kind: 0 body (vertex), 1 bond (line); cells are ordered vertices, lines.
  int_array("kind", [&](int c) { return c < n ? 0 : 1; }, n + nb);
  int_array("object", [&](int c) { return s.bodies[c < n ? c : s.bonds[c - n].first].object; },
            n + nb);
  out << t;
  if (!out) throw std::runtime_error("write_vtk: the output stream failed");
}

}  // namespace ringsim
