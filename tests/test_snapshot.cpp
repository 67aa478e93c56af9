// Snapshots (core/snapshot.hpp, docs/OUTPUT.md "Snapshots"): bit-exact
// extended XYZ round trips, the OVITO orientation quaternion, line-numbered
// errors on malformed files, the VTK layout, and the PNG renderer
// scripts/render_snapshot.py (skipped without /usr/bin/python3 + matplotlib).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/snapshot.hpp"
#include "ensemble/replicate_command.hpp"

namespace ringsim {
namespace {

// Deterministic uniform noise in [-1, 1) (splitmix64).
struct Noise {
  std::uint64_t state;
  double operator()() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return 2.0 * (static_cast<double>(z >> 11) * 0x1.0p-53) - 1.0;
  }
};

Vec3 random_unit(Noise& u) {
  while (true) {
    const Vec3 v(u(), u(), u());
    const double n = v.norm();
    if (n > 0.1 && n <= 1.0) return v / n;
  }
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

SnapshotBody sphere_at(const Vec3& x, int object) {
  return SnapshotBody{true, x, Vec3::UnitZ(), 1.0, 0.0, object};
}
SnapshotBody linker_at(const Vec3& x, const Vec3& axis, int object) {
  return SnapshotBody{false, x, axis, 1.0, 2.0, object};
}

// A square target ring (4 S + 4 L, every bond in the target pose: sphere
// centre on the linker axis, touching the end face) centred at c in the
// z = c.z plane, plus one free sphere and one free linker. Bodies: spheres
// 0..4, linkers 5..9.
Snapshot ring_snapshot(const Vec3& c) {
  Snapshot s;
  s.time = 12.5;
  s.box_length = 30.0;
  s.periodic = false;
  s.comment = "scenario=test seed=7";
  const double a = 3.0;  // half the side: linker half-length 2 + sphere radius 1
  const Vec3 corner[4] = {c + Vec3(-a, -a, 0), c + Vec3(a, -a, 0), c + Vec3(a, a, 0), c + Vec3(-a, a, 0)};
  for (int i = 0; i < 4; ++i) s.bodies.push_back(sphere_at(corner[i], 0));
  s.bodies.push_back(sphere_at(c + Vec3(0, 0, 8), 1));
  for (int i = 0; i < 4; ++i) {
    const Vec3 mid = 0.5 * (corner[i] + corner[(i + 1) % 4]);
    const Vec3 axis = (corner[(i + 1) % 4] - corner[i]).normalized();
    s.bodies.push_back(linker_at(mid, axis, 0));
    s.bonds.emplace_back(i, 5 + i);
    s.bonds.emplace_back((i + 1) % 4, 5 + i);
  }
  s.bodies.push_back(linker_at(c + Vec3(0, 0, -8), Vec3(0, 0.6, 0.8), 2));
  return s;
}

std::string to_xyz(const Snapshot& s) {
  std::ostringstream out;
  write_extended_xyz(out, s);
  return out.str();
}

Snapshot from_xyz(const std::string& text) {
  std::istringstream in(text);
  return read_extended_xyz(in);
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

std::string join(const std::vector<std::string>& lines) {
  std::string t;
  for (const auto& l : lines) t += l + "\n";
  return t;
}

// ---- round trip -------------------------------------------------------------

TEST(Snapshot, RoundTripIsBitExact) {
  Noise u{42};
  Snapshot s;
  s.time = 1.0 / 3.0;
  s.box_length = 50.0;
  s.periodic = true;
  s.comment = "scenario=dense seed=123 note: a=b, spaces\tand tab";
  const double awkward[] = {0.1, 1.0 / 3.0, 5e-324, 2.2250738585072014e-308, 1e300,
                            -0.0, 49.999999999999993, 0x1.fffffffffffffp-1};
  for (int i = 0; i < 40; ++i) {
    const bool sphere = i < 20;
    SnapshotBody b;
    b.sphere = sphere;
    b.x = Vec3(25.0 + 25.0 * u(), 25.0 + 25.0 * u(), 25.0 + 25.0 * u());
    if (i < 8) b.x.x() = awkward[i];
    b.axis = sphere ? Vec3(u(), u(), u()) : random_unit(u);  // spheres: any axis survives too
    b.radius = 1.0 + 0.1 * u();
    b.half_length = sphere ? 0.0 : 2.0 + 0.3 * u();
    b.object = i % 7 - 1;
    s.bodies.push_back(b);
  }
  s.bonds = {{0, 20}, {1, 20}, {1, 21}, {2, 22}, {2, 22}, {19, 39}};  // a repeated pair too

  const std::string text = to_xyz(s);
  const Snapshot r = from_xyz(text);
  EXPECT_TRUE(same_bits(r.time, s.time));
  EXPECT_TRUE(same_bits(r.box_length, s.box_length));
  EXPECT_EQ(r.periodic, s.periodic);
  EXPECT_EQ(r.comment, s.comment);
  EXPECT_EQ(r.bonds, s.bonds);
  ASSERT_EQ(r.bodies.size(), s.bodies.size());
  for (std::size_t i = 0; i < s.bodies.size(); ++i) {
    const SnapshotBody& a = s.bodies[i];
    const SnapshotBody& b = r.bodies[i];
    SCOPED_TRACE("body " + std::to_string(i));
    EXPECT_EQ(a.sphere, b.sphere);
    for (int c = 0; c < 3; ++c) {
      EXPECT_TRUE(same_bits(a.x[c], b.x[c])) << a.x[c] << " vs " << b.x[c];
      EXPECT_TRUE(same_bits(a.axis[c], b.axis[c])) << a.axis[c] << " vs " << b.axis[c];
    }
    EXPECT_TRUE(same_bits(a.radius, b.radius));
    EXPECT_TRUE(same_bits(a.half_length, b.half_length));
    EXPECT_EQ(a.object, b.object);
  }
  // The text itself is a fixed point.
  EXPECT_EQ(to_xyz(r), text);
}

TEST(Snapshot, HeaderAndColumnsFollowTheOvitoMapping) {
  Snapshot s = ring_snapshot(Vec3(15, 15, 15));
  const auto lines = lines_of(to_xyz(s));
  ASSERT_EQ(lines.size(), 2 + s.bodies.size());
  EXPECT_EQ(lines[0], "10");
  EXPECT_EQ(lines[1],
            "Lattice=\"30 0 0 0 30 0 0 0 30\" Properties=species:S:1:pos:R:3:radius:R:1"
            ":orientation:R:4:aspherical_shape:R:3:axis:R:3:half_length:R:1:object:I:1"
            " Time=12.5 pbc=\"F F F\" bonds=\"0-5 1-5 1-6 2-6 2-7 3-7 3-8 0-8\""
            " comment=\"scenario=test seed=7\"");
  // Sphere: identity orientation (x y z w), aspherical shape 0 0 0 (OVITO then
  // falls back to Radius), axis z.
  EXPECT_EQ(lines[2], "S 12 12 15 1 0 0 0 1 0 0 0 0 0 1 0 0");
  // Linker 5 lies along +x: the rotation taking z onto x is a quarter turn
  // about y, q = (0, sin 45, 0, cos 45); shape (r, r, 2 h) = (1, 1, 4).
  EXPECT_EQ(lines[7], "L 15 12 15 1 0 0.7071067811865475 0 0.7071067811865475 1 1 4 1 0 0 2 0");
}

// ---- orientation ------------------------------------------------------------

void expect_maps_z_onto(const Vec3& a) {
  const Quat q = orientation_from_axis(a);
  EXPECT_NEAR(q.norm(), 1.0, 4e-16) << a.transpose();
  EXPECT_LT((q * Vec3::UnitZ() - a).norm(), 8e-16) << a.transpose();
  // Same as the rotation matrix (OVITO applies q to (0, 0, h) as q v q*).
  EXPECT_LT((q.toRotationMatrix().col(2) - a).norm(), 8e-16) << a.transpose();
}

TEST(Snapshot, OrientationMapsZOntoTheAxis) {
  for (const Vec3& a : {Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(1, 0, 0), Vec3(-1, 0, 0), Vec3(0, 1, 0),
                        Vec3(0, -1, 0), Vec3(1e-9, -2e-9, -1).normalized(),
                        Vec3(1e-300, 0, -1).normalized(), Vec3(3e-8, 1e-8, 1).normalized(),
                        Vec3(1, 1, 1e-17).normalized(), Vec3(1, 1, -1e-17).normalized()})
    expect_maps_z_onto(a);
  Noise u{2024};
  for (int i = 0; i < 10000; ++i) expect_maps_z_onto(random_unit(u));
  // Exact values at the poles: identity and a half turn about x.
  const Quat up = orientation_from_axis(Vec3::UnitZ());
  const Quat down = orientation_from_axis(-Vec3::UnitZ());
  EXPECT_EQ(up.coeffs(), Quat::Identity().coeffs());
  EXPECT_EQ(down.coeffs(), Eigen::Vector4d(1, 0, 0, 0));  // (x y z w)
}

// ---- malformed input ---------------------------------------------------------

void expect_error_at(const std::string& text, int line, const std::string& fragment) {
  try {
    from_xyz(text);
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const std::runtime_error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("extended XYZ line " + std::to_string(line) + ":"), std::string::npos) << msg;
    EXPECT_NE(msg.find(fragment), std::string::npos) << msg;
  }
}

TEST(Snapshot, MalformedInputNamesTheLine) {
  const std::vector<std::string> good = lines_of(to_xyz(ring_snapshot(Vec3(15, 15, 15))));
  ASSERT_NO_THROW(from_xyz(join(good)));
  auto with = [&](int index, const std::string& replacement) {
    std::vector<std::string> l = good;
    l[index] = replacement;
    return join(l);
  };
  auto header_with = [&](const std::string& from, const std::string& to) {
    std::string h = good[1];
    const auto at = h.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    h.replace(at, from.size(), to);
    return with(1, h);
  };

  expect_error_at("", 1, "empty input");
  expect_error_at(with(0, "ten"), 1, "number of bodies");
  expect_error_at(with(0, "10 11"), 1, "number of bodies");
  expect_error_at("10\n", 2, "comment line");
  expect_error_at(header_with("Lattice=", "Lattic="), 2, "Lattice");
  expect_error_at(header_with("\"30 0 0 0 30 0 0 0 30\"", "\"30 0 0 0 31 0 0 0 30\""), 2, "cube");
  expect_error_at(header_with("\"30 0 0 0 30 0 0 0 30\"", "\"30 0 0 0 30 0 0 0\""), 2, "9 numbers");
  expect_error_at(header_with("Time=12.5", "Time=soon"), 2, "Time");
  expect_error_at(header_with("Time=12.5 ", ""), 2, "Time");
  expect_error_at(header_with("pbc=\"F F F\"", "pbc=\"T F T\""), 2, "pbc");
  expect_error_at(header_with(":axis:R:3", ":axes:R:3"), 2, "axis");
  expect_error_at(header_with("object:I:1", "object:R:1"), 2, "object");
  expect_error_at(header_with("half_length:R:1", "half_length:R"), 2, "triplets");
  expect_error_at(header_with("comment=\"scenario=test seed=7\"", "comment=\"open"), 2, "unterminated");
  expect_error_at(header_with("0-5 ", "0-1 "), 2, "bond '0-1'");
  expect_error_at(header_with("0-5 ", "0-99 "), 2, "bond '0-99'");
  expect_error_at(header_with("0-5 ", "0+5 "), 2, "bond '0+5'");
  expect_error_at(with(4, "S 12 12 15 1 0 0 0 1 0 0 0 0 0 1 0"), 5, "fields");
  expect_error_at(with(4, "X 12 12 15 1 0 0 0 1 0 0 0 0 0 1 0 0"), 5, "neither S nor L");
  expect_error_at(with(4, "S 12 1.2.3 15 1 0 0 0 1 0 0 0 0 0 1 0 0"), 5, "pos");
  expect_error_at(with(4, "S 12 nan 15 1 0 0 0 1 0 0 0 0 0 1 0 0"), 5, "not finite");
  expect_error_at(with(4, "S 12 12 15 0 0 0 0 1 0 0 0 0 0 1 0 0"), 5, "radius");
  expect_error_at(with(4, "S 12 12 15 1 0 0 0 1 0 0 0 0 0 1 0.5 0"), 5, "half_length");
  expect_error_at(with(4, "S 12 12 15 1 0 0 0 1 0 0 0 0 0 1 0 zero"), 5, "object");
  // A linker whose axis is not a unit vector, whose orientation does not
  // match its axis, or whose shape is not (r, r, 2 h).
  expect_error_at(with(7, "L 15 12 15 1 0 0.7071067811865475 0 0.7071067811865475 1 1 4 1 0.1 0 2 0"),
                  8, "unit");
  expect_error_at(with(7, "L 15 12 15 1 0.7071067811865475 0 0 0.7071067811865475 1 1 4 1 0 0 2 0"),
                  8, "orientation");
  expect_error_at(with(7, "L 15 12 15 1 0 0.7071067811865475 0 0.7071067811865475 1 1 2 1 0 0 2 0"),
                  8, "aspherical_shape");
  // Truncated: the first missing body line is named.
  std::vector<std::string> cut(good.begin(), good.begin() + 6);
  expect_error_at(join(cut), 7, "body 4 of 10");
}

TEST(Snapshot, ReaderAcceptsReorderedColumnsAndCrlf) {
  // Columns are found by name: a minimal file with the required ones only,
  // in another order, Windows line ends, no bonds or comment keys.
  const std::string text =
      "2\r\nTime=0 pbc=\"F F F\" Properties=pos:R:3:species:S:1:object:I:1:radius:R:1:axis:R:3"
      ":half_length:R:1 Lattice=\"10 0 0 0 10 0 0 0 10\"\r\n"
      "1 2 3 S 4 1 0 0 1 0\r\n"
      "5 5 5 L 4 1 0 1 0 2\r\n";
  const Snapshot s = from_xyz(text);
  ASSERT_EQ(s.bodies.size(), 2u);
  EXPECT_FALSE(s.periodic);
  EXPECT_TRUE(s.bodies[0].sphere);
  EXPECT_EQ(s.bodies[0].x, Vec3(1, 2, 3));
  EXPECT_FALSE(s.bodies[1].sphere);
  EXPECT_EQ(s.bodies[1].axis, Vec3(0, 1, 0));
  EXPECT_EQ(s.bodies[1].half_length, 2.0);
  EXPECT_TRUE(s.bonds.empty());
  EXPECT_TRUE(s.comment.empty());
}

TEST(Snapshot, WriterRejectsInvalidSnapshots) {
  const Snapshot good = ring_snapshot(Vec3(15, 15, 15));
  auto rejects = [](const Snapshot& s, const std::string& fragment) {
    std::ostringstream out;
    try {
      write_extended_xyz(out, s);
      ADD_FAILURE() << "accepted; expected an error with '" << fragment << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
    EXPECT_THROW(write_vtk(out, s), std::invalid_argument);
  };
  Snapshot s = good;
  s.comment = "say \"hi\"";
  rejects(s, "comment");
  s = good;
  s.comment = "two\nlines";
  rejects(s, "comment");
  s = good;
  s.bonds.emplace_back(5, 6);  // linker-linker
  rejects(s, "bond 8");
  s = good;
  s.bodies[3].x.y() = std::numeric_limits<double>::quiet_NaN();
  rejects(s, "body 3");
  s = good;
  s.bodies[6].axis = Vec3(1, 1, 0);
  rejects(s, "body 6");
  s = good;
  s.bodies[2].half_length = 1.0;
  rejects(s, "body 2");
}

// ---- VTK ----------------------------------------------------------------------

// The numbers following the line that starts with `keyword` (count values).
std::vector<double> vtk_block(const std::string& text, const std::string& keyword, std::size_t count) {
  const auto at = text.find("\n" + keyword);
  EXPECT_NE(at, std::string::npos) << keyword;
  std::istringstream in(text.substr(text.find('\n', at + 1 + keyword.size()) + 1));
  std::vector<double> v(count);
  for (double& x : v) in >> x;
  EXPECT_TRUE(static_cast<bool>(in)) << keyword;
  return v;
}

TEST(Snapshot, VtkHasBodiesBondsAndGlyphArrays) {
  // Periodic box 20, linker 1 at x = 18.5 along x (ends at 16.5 and 20.5).
  // Sphere 0 at x = 1.5 is bonded to the end at 20.5, seen through the
  // boundary: its bond point is x = 0.5. Sphere 2 at x = 14.5 is bonded to
  // the end at 16.5.
  Snapshot s;
  s.time = 3.0;
  s.box_length = 20.0;
  s.periodic = true;
  s.bodies.push_back(sphere_at(Vec3(1.5, 10, 10), 4));
  s.bodies.push_back(linker_at(Vec3(18.5, 10, 10), Vec3(1, 0, 0), 4));
  s.bodies.push_back(sphere_at(Vec3(14.5, 10, 10), 4));
  s.bonds.emplace_back(0, 1);
  s.bonds.emplace_back(2, 1);
  std::ostringstream out;
  write_vtk(out, s);
  const std::string t = out.str();
  const auto lines = lines_of(t);
  ASSERT_GE(lines.size(), 6u);
  EXPECT_EQ(lines[0], "# vtk DataFile Version 3.0");
  EXPECT_EQ(lines[1], "ringsim snapshot time=3 periodic box=20");
  EXPECT_EQ(lines[2], "ASCII");
  EXPECT_EQ(lines[3], "DATASET POLYDATA");
  EXPECT_EQ(lines[4], "POINTS 5 double");
  const auto pts = vtk_block(t, "POINTS", 15);
  EXPECT_EQ(std::vector<double>(pts.begin() + 9, pts.end()),
            (std::vector<double>{0.5, 10, 10, 16.5, 10, 10}));
  EXPECT_EQ(vtk_block(t, "VERTICES 3 6", 6), (std::vector<double>{1, 0, 1, 1, 1, 2}));
  EXPECT_EQ(vtk_block(t, "LINES 2 6", 6), (std::vector<double>{2, 0, 3, 2, 2, 4}));
  EXPECT_NE(t.find("\nPOINT_DATA 5\n"), std::string::npos);
  EXPECT_EQ(vtk_block(t, "SCALARS species int 1\nLOOKUP_TABLE", 5),
            (std::vector<double>{0, 1, 0, -1, -1}));
  EXPECT_EQ(vtk_block(t, "SCALARS body int 1\nLOOKUP_TABLE", 5),
            (std::vector<double>{0, 1, 2, -1, -1}));
  EXPECT_EQ(vtk_block(t, "SCALARS object int 1\nLOOKUP_TABLE", 5),
            (std::vector<double>{4, 4, 4, 4, 4}));
  EXPECT_EQ(vtk_block(t, "SCALARS radius double 1\nLOOKUP_TABLE", 5),
            (std::vector<double>{1, 1, 1, 0, 0}));
  EXPECT_EQ(vtk_block(t, "VECTORS axis double", 15),
            (std::vector<double>{0, 0, 1, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(vtk_block(t, "VECTORS glyph_scale double", 15),
            (std::vector<double>{2, 2, 2, 4, 2, 2, 2, 2, 2, 0, 0, 0, 0, 0, 0}));
  EXPECT_NE(t.find("\nCELL_DATA 5\n"), std::string::npos);
  EXPECT_EQ(vtk_block(t, "SCALARS kind int 1\nLOOKUP_TABLE", 5), (std::vector<double>{0, 0, 0, 1, 1}));
}

TEST(Snapshot, BondEndsRoundTripAndPlaceTheVtkBondPoints) {
  // Linker 1 along x at x = 10 (end a at 12, end b at 8); sphere 0 at x = 11
  // is bonded to end b although end a is nearer (a capture shell wider than
  // the linker), sphere 2 at x = 13 to end a.
  Snapshot s;
  s.time = 1.0;
  s.box_length = 20.0;
  s.bodies.push_back(sphere_at(Vec3(11, 10, 10), 0));
  s.bodies.push_back(linker_at(Vec3(10, 10, 10), Vec3(1, 0, 0), 0));
  s.bodies.push_back(sphere_at(Vec3(13, 10, 10), 0));
  s.bonds = {{0, 1}, {2, 1}};
  s.bond_ends = {1, 0};
  std::ostringstream xyz;
  write_extended_xyz(xyz, s);
  EXPECT_NE(xyz.str().find(" bond_ends=\"1 0\""), std::string::npos);
  std::istringstream back(xyz.str());
  EXPECT_EQ(read_extended_xyz(back).bond_ends, s.bond_ends);
  std::ostringstream vtk;
  write_vtk(vtk, s);
  const auto pts = vtk_block(vtk.str(), "POINTS 5 double", 15);
  EXPECT_EQ(std::vector<double>(pts.begin() + 9, pts.end()), (std::vector<double>{8, 10, 10, 12, 10, 10}));
  // Without ends (older files) the nearest end stands in.
  s.bond_ends.clear();
  std::ostringstream nearest;
  write_vtk(nearest, s);
  const auto pn = vtk_block(nearest.str(), "POINTS 5 double", 15);
  EXPECT_EQ(std::vector<double>(pn.begin() + 9, pn.end()), (std::vector<double>{12, 10, 10, 12, 10, 10}));
  // Invalid ends are refused by the writer and the reader.
  s.bond_ends = {0};
  EXPECT_THROW(write_vtk(nearest, s), std::invalid_argument);
  s.bond_ends = {2, 0};
  EXPECT_THROW(write_vtk(nearest, s), std::invalid_argument);
  s.bond_ends = {0, 0};  // end a of linker 1 bonded twice
  EXPECT_THROW(write_extended_xyz(nearest, s), std::invalid_argument);
  std::string text = xyz.str();
  text.replace(text.find("bond_ends=\"1 0\""), 15, "bond_ends=\"1\"");
  std::istringstream short_ends(text);
  EXPECT_THROW(read_extended_xyz(short_ends), std::runtime_error);
}

// ---- renderer --------------------------------------------------------------------

struct TempDir {
  std::filesystem::path path;
  TempDir() {
    path = std::filesystem::temp_directory_path() /
           ("ringsim_test_snapshot_" + std::to_string(::getpid()));
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

int run(const std::string& command) {
  const int status = std::system(command.c_str());
  return (status != -1 && WIFEXITED(status)) ? WEXITSTATUS(status) : -1;
}

bool python_with_matplotlib() {
  if (::access("/usr/bin/python3", X_OK) != 0) return false;
  return run("/usr/bin/python3 -c 'import numpy, matplotlib' >/dev/null 2>&1") == 0;
}

// A replicate that ends in an error still writes its snapshot, at the time it
// stopped, for debugging (it used to write none). The resting pair of
// InelasticCollapse.FrozenTimeEndsTheRunWithAnError stops time at 0.2194;
// the snapshot's bodies are where the run left them: no overlaps, in the box.
TEST(Snapshot, AReplicateThatFailsWritesItsLastConfiguration) {
  TempDir dir;
  SimParams p;
  p.bonding.enabled = false;
  p.contact.restitution_sphere = 0.0;
  p.run.min_separation_speed = 0.0;
  p.run.t_max = 1.0;
  ReplicateIo io;
  io.snapshot_path = (dir.path / "failed.xyz").string();
  const nlohmann::json result = run_replicate(p, 3, 0, io);
  ASSERT_EQ(result.at("termination").get<std::string>(), "error");
  std::ifstream in(io.snapshot_path);
  ASSERT_TRUE(in.good());
  const Snapshot snap = read_extended_xyz(in);
  EXPECT_NEAR(snap.time, result.at("t_end").get<double>(), 1e-9);
  ASSERT_EQ(static_cast<int>(snap.bodies.size()), p.init.spheres + p.init.linkers);
  for (std::size_t i = 0; i < snap.bodies.size(); ++i) {
    const SnapshotBody& a = snap.bodies[i];
    for (int d = 0; d < 3; ++d) {
      EXPECT_GE(a.x[d], a.radius - 1e-6) << i;  // reflective box
      EXPECT_LE(a.x[d], p.geometry.box_length - a.radius + 1e-6) << i;
    }
    for (std::size_t j = i + 1; j < snap.bodies.size(); ++j) {
      const SnapshotBody& c = snap.bodies[j];
      if (a.sphere && c.sphere) EXPECT_GE((a.x - c.x).norm(), a.radius + c.radius - 1e-6) << i << " " << j;
    }
  }
}

// A replicate's VTK bond points are the ends that actually bonded, not the
// ends nearest the sphere. With a capture distance this large (r_c = 3, filters
// off) a sphere can bond both ends of one linker, both ends lying inside its
// capture shell: the old writer, which took the nearest end, drew both bonds
// of such a pair to the same end.
TEST(Snapshot, ReplicateVtkBondPointsAreTheBondedEnds) {
  TempDir dir;
  SimParams p;
  p.init.spheres = 60;
  p.init.linkers = 60;
  p.geometry.box_length = 20.0;
  p.bonding.angle_filter = false;
  p.bonding.coplanarity_filter = false;
  p.bonding.capture_distance = 3.0;
  p.run.t_max = 1e-3;  // the bonds formed at t = 0 (pairs already inside the shell)
  ReplicateIo io;
  io.snapshot_path = (dir.path / "final.vtk").string();
  const nlohmann::json result = run_replicate(p, 1, 0, io);
  ASSERT_EQ(result.at("termination").get<std::string>(), "t_max");
  std::ifstream in(io.snapshot_path);
  const std::string t((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const int n = p.init.spheres + p.init.linkers;
  const int nb = result.at("bonds").get<int>();
  const auto pts = vtk_block(t, "POINTS " + std::to_string(n + nb) + " double", 3 * (n + nb));
  const auto lines = vtk_block(t, "LINES " + std::to_string(nb) + " " + std::to_string(3 * nb), 3 * nb);
  // Which linker each bond point belongs to: the snapshot's bonds (XYZ order = VTK order).
  io.snapshot_path = (dir.path / "final.xyz").string();
  run_replicate(p, 1, 0, io);
  std::ifstream xin(io.snapshot_path);
  const Snapshot xyz = read_extended_xyz(xin);
  ASSERT_EQ(static_cast<int>(xyz.bonds.size()), nb);
  int repeated = 0;
  for (int k = 0; k < nb; ++k) {
    for (int j = k + 1; j < nb; ++j) {
      if (xyz.bonds[k] != xyz.bonds[j]) continue;
      ++repeated;  // one sphere on both ends of one linker: the points must be the two ends
      ASSERT_EQ(lines[3 * k + 1], xyz.bonds[k].first);
      const Vec3 pk(pts[3 * (n + k)], pts[3 * (n + k) + 1], pts[3 * (n + k) + 2]);
      const Vec3 pj(pts[3 * (n + j)], pts[3 * (n + j) + 1], pts[3 * (n + j) + 2]);
      const SnapshotBody& lk = xyz.bodies[xyz.bonds[k].second];
      EXPECT_NEAR((pk - pj).norm(), 2.0 * lk.half_length, 1e-9) << "bonds " << k << " and " << j;
    }
  }
  EXPECT_GT(repeated, 0) << "the scene must hold a sphere bonded to both ends of a linker";
}

TEST(Snapshot, RenderScriptWritesAPng) {
  if (!python_with_matplotlib()) GTEST_SKIP() << "/usr/bin/python3 with numpy and matplotlib not found";
  TempDir dir;
  const auto xyz = dir.path / "ring.xyz";
  const auto png = dir.path / "ring.png";
  {
    std::ofstream f(xyz);
    write_extended_xyz(f, ring_snapshot(Vec3(15, 15, 15)));
  }
  const std::string script = std::string(RINGSIM_SOURCE_DIR) + "/scripts/render_snapshot.py";
  const std::string log = (dir.path / "log.txt").string();
  const int rc = run("/usr/bin/python3 '" + script + "' '" + xyz.string() + "' -o '" + png.string() +
                     "' --dpi 60 >'" + log + "' 2>&1");
  ASSERT_EQ(rc, 0) << "render_snapshot.py failed; see " << log;
  ASSERT_TRUE(std::filesystem::exists(png));
  EXPECT_GT(std::filesystem::file_size(png), 1000u);
  std::ifstream f(png, std::ios::binary);
  char sig[8] = {};
  f.read(sig, 8);
  EXPECT_EQ(std::string(sig, 8), std::string("\x89PNG\r\n\x1a\n", 8));

  // The script's own analysis: one target ring (8 members) in ring.xyz; none
  // once an extra bond joins the ring's sphere 0 to the free linker 9; bond
  // ends by minimum image in a periodic box (as in the VTK test above).
  {
    Snapshot extra = ring_snapshot(Vec3(15, 15, 15));
    extra.bonds.emplace_back(0, 9);
    std::ofstream fx(dir.path / "extra.xyz");
    write_extended_xyz(fx, extra);
    Snapshot periodic;
    periodic.time = 0.0;
    periodic.box_length = 20.0;
    periodic.periodic = true;
    periodic.bodies = {sphere_at(Vec3(1.5, 10, 10), 0), linker_at(Vec3(18.5, 10, 10), Vec3(1, 0, 0), 0),
                       sphere_at(Vec3(14.5, 10, 10), 0)};
    periodic.bonds = {{0, 1}, {2, 1}};
    std::ofstream g(dir.path / "periodic.xyz");
    write_extended_xyz(g, periodic);
  }
  const std::string probe =
      "import sys; sys.path.insert(0, '" + std::string(RINGSIM_SOURCE_DIR) + "/scripts'); "
      "import render_snapshot as r; d = '" + dir.path.string() + "/'; "
      "print(int(r.target_members(r.read_snapshot(d + 'ring.xyz')).sum()), "
      "int(r.target_members(r.read_snapshot(d + 'extra.xyz')).sum()), "
      "r.bond_segments(r.read_snapshot(d + 'periodic.xyz'))[:, 1].ravel().tolist())";
  const std::string probe_out = (dir.path / "probe.txt").string();
  ASSERT_EQ(run("/usr/bin/python3 -B -c \"" + probe + "\" >'" + probe_out + "' 2>&1"), 0);
  {
    std::ifstream pf(probe_out);
    const std::string text((std::istreambuf_iterator<char>(pf)), std::istreambuf_iterator<char>());
    EXPECT_EQ(text, "8 0 [0.5, 10.0, 10.0, 16.5, 10.0, 10.0]\n");
  }

  // A malformed file: exit status 1 and a message naming the line.
  const auto bad = dir.path / "bad.xyz";
  {
    std::ofstream b(bad);
    b << "2\nLattice=\"10 0 0 0 10 0 0 0 10\" Time=0 Properties=species:S:1:pos:R:3:radius:R:1"
         ":axis:R:3:half_length:R:1\nS 1 2 3 1 0 0 1 0\n";
  }
  EXPECT_EQ(run("/usr/bin/python3 '" + script + "' '" + bad.string() + "' -o '" +
                (dir.path / "bad.png").string() + "' >'" + log + "' 2>&1"),
            1);
  std::ifstream l(log);
  const std::string msg((std::istreambuf_iterator<char>(l)), std::istreambuf_iterator<char>());
  EXPECT_NE(msg.find("line 4"), std::string::npos) << msg;
  EXPECT_FALSE(std::filesystem::exists(dir.path / "bad.png"));

  // Other bad input gives a one-line message, not a traceback (a sweep found
  // tracebacks): an output directory that does not exist, a file that is not
  // text, a picture too large to draw (argparse's usage error, status 2).
  auto one_line_error = [&](const std::string& args, int status) {
    EXPECT_EQ(run("/usr/bin/python3 '" + script + "' " + args + " >'" + log + "' 2>&1"), status) << args;
    std::ifstream lf(log);
    const std::string out((std::istreambuf_iterator<char>(lf)), std::istreambuf_iterator<char>());
    EXPECT_EQ(out.find("Traceback"), std::string::npos) << out;
    EXPECT_NE(out.find("render_snapshot"), std::string::npos) << out;
  };
  one_line_error("'" + xyz.string() + "' -o '" + (dir.path / "no" / "x.png").string() + "'", 1);
  one_line_error("'" + script + ".does-not-exist' -o x.png", 1);
  one_line_error("'" + std::string("/bin/sh") + "' -o '" + png.string() + "'", 1);
  one_line_error("'" + xyz.string() + "' -o '" + png.string() + "' --dpi 100000", 2);
}

}  // namespace
}  // namespace ringsim
