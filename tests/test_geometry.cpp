// Narrow-phase geometry against hand-derived cases and the independent
// reference set ../shared/testdata/cylinder_distance.json.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/geometry.hpp"
#include "core/shapes.hpp"

#ifndef RINGSIM_TESTDATA_DIR
#define RINGSIM_TESTDATA_DIR "../shared/testdata"
#endif

namespace {

using ringsim::Vec3;
using namespace ringsim::geom;

constexpr double kPi = 3.14159265358979323846;

Cylinder unit_z_cylinder() { return {Vec3::Zero(), Vec3::UnitZ(), 1.0, 2.0}; }

// ---- point / sphere vs cylinder ------------------------------------------------

TEST(PointCylinder, InsideIsZeroAndSelf) {
  Vec3 q;
  const Vec3 p(0.3, -0.2, 1.5);
  EXPECT_EQ(point_cylinder_distance(p, unit_z_cylinder(), &q), 0.0);
  EXPECT_EQ(q, p);
}

TEST(PointCylinder, SideFaceRim) {
  const Cylinder c = unit_z_cylinder();
  Vec3 q;
  EXPECT_NEAR(point_cylinder_distance(Vec3(3, 0, 1), c, &q), 2.0, 1e-15);
  EXPECT_TRUE(q.isApprox(Vec3(1, 0, 1), 1e-15));
  EXPECT_NEAR(point_cylinder_distance(Vec3(0.5, 0.5, -5), c, &q), 3.0, 1e-15);
  EXPECT_TRUE(q.isApprox(Vec3(0.5, 0.5, -2), 1e-15));
  EXPECT_NEAR(point_cylinder_distance(Vec3(0, 4, 6), c, &q), 5.0, 1e-15);  // 3-4-5 to the rim
  EXPECT_TRUE(q.isApprox(Vec3(0, 1, 2), 1e-15));
}

TEST(SphereCylinder, Side) {
  // Tilted cylinder: axis along (1,1,0)/sqrt2; sphere beside its middle.
  const Vec3 u = Vec3(1, 1, 0).normalized();
  const Cylinder c{Vec3(1, 2, 3), u, 0.5, 2.0};
  const Vec3 side = Vec3(1, -1, 0).normalized();
  const Vec3 center = c.center + 0.3 * u + 2.0 * side;
  const Separation s = sphere_cylinder(center, 0.25, c);
  EXPECT_NEAR(s.distance, 2.0 - 0.5 - 0.25, 1e-14);
  EXPECT_TRUE(s.normal.isApprox(-side, 1e-14));
  EXPECT_TRUE(s.point_a.isApprox(center - 0.25 * side, 1e-14));
  EXPECT_TRUE(s.point_b.isApprox(c.center + 0.3 * u + 0.5 * side, 1e-14));
}

TEST(SphereCylinder, EndFace) {
  const Separation s = sphere_cylinder(Vec3(0.4, 0.1, 3.5), 1.0, unit_z_cylinder());
  EXPECT_NEAR(s.distance, 0.5, 1e-15);
  EXPECT_TRUE(s.normal.isApprox(Vec3(0, 0, -1), 1e-15));
  EXPECT_TRUE(s.point_a.isApprox(Vec3(0.4, 0.1, 2.5), 1e-15));
  EXPECT_TRUE(s.point_b.isApprox(Vec3(0.4, 0.1, 2.0), 1e-15));
}

TEST(SphereCylinder, RimDiagonal) {
  // Centre at 45 degrees off the rim (1, 0, 2): offset (1, 0, 1) * 2/sqrt2.
  const Vec3 dir = Vec3(1, 0, 1).normalized();
  const Vec3 center = Vec3(1, 0, 2) + 2.0 * dir;
  const Separation s = sphere_cylinder(center, 1.5, unit_z_cylinder());
  EXPECT_NEAR(s.distance, 0.5, 1e-14);
  EXPECT_TRUE(s.normal.isApprox(-dir, 1e-14));
  EXPECT_TRUE(s.point_b.isApprox(Vec3(1, 0, 2), 1e-14));
  EXPECT_TRUE(s.point_a.isApprox(center - 1.5 * dir, 1e-14));
}

TEST(SphereCylinder, CentreInsideIsNegativeAndFinite) {
  const Cylinder c = unit_z_cylinder();
  const Separation s = sphere_cylinder(Vec3(0.1, 0, 1.8), 0.5, c);  // nearest: top face
  EXPECT_NEAR(s.distance, -0.2 - 0.5, 1e-15);
  EXPECT_TRUE(s.normal.isApprox(Vec3(0, 0, -1), 1e-15));
  EXPECT_TRUE(s.point_b.isApprox(Vec3(0.1, 0, 2), 1e-15));
  // Exactly on the axis at the centre: still finite, unit normal.
  const Separation z = sphere_cylinder(Vec3::Zero(), 0.5, c);
  EXPECT_LT(z.distance, 0.0);
  EXPECT_TRUE(z.normal.allFinite() && z.point_a.allFinite() && z.point_b.allFinite());
  EXPECT_NEAR(z.normal.norm(), 1.0, 1e-15);
}

TEST(CylinderSupport, Formula) {
  const Cylinder c{Vec3(5, 5, 5), Vec3::UnitZ(), 1.0, 2.0};
  EXPECT_NEAR(cylinder_support(c, Vec3::UnitZ()), 2.0, 1e-15);
  EXPECT_NEAR(cylinder_support(c, Vec3::UnitX()), 1.0, 1e-15);
  EXPECT_NEAR(cylinder_support(c, Vec3(1, 0, 1).normalized()), 3.0 / std::sqrt(2.0), 1e-15);
}

// ---- cylinder vs cylinder against the reference set ------------------------------

struct RefCase {
  std::string kind;
  Cylinder a, b;
  double distance;
};

std::vector<RefCase> load_reference() {
  const std::string path = std::string(RINGSIM_TESTDATA_DIR) + "/cylinder_distance.json";
  std::ifstream in(path);
  if (!in) ADD_FAILURE() << "cannot open " << path;
  if (!in) return {};
  const nlohmann::json j = nlohmann::json::parse(in);
  const double r = j.at("radius"), h = 0.5 * j.at("length").get<double>();
  auto v = [](const nlohmann::json& x) { return Vec3(x[0], x[1], x[2]); };
  std::vector<RefCase> out;
  for (const auto& c : j.at("cases"))
    out.push_back({c.at("kind"), {v(c.at("center_a")), v(c.at("axis_a")).normalized(), r, h},
                   {v(c.at("center_b")), v(c.at("axis_b")).normalized(), r, h}, c.at("distance")});
  return out;
}

const std::vector<RefCase>& reference() {
  static const std::vector<RefCase> cases = load_reference();
  return cases;
}

// Checks one solver on every reference case; returns the max |d - d_ref|.
template <class Solver>
double check_reference(Solver solve, const char* name) {
  const auto& cases = reference();
  EXPECT_EQ(cases.size(), 290u);
  double max_err = 0.0;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const RefCase& c = cases[i];
    const Separation s = solve(c.a, c.b);
    const double err = std::abs(s.distance - c.distance);
    max_err = std::max(max_err, err);
    EXPECT_LE(err, 3e-9) << name << " case " << i << " (" << c.kind << ")";
    EXPECT_LE(point_cylinder_distance(s.point_a, c.a, nullptr), 1e-8) << name << " case " << i;
    EXPECT_LE(point_cylinder_distance(s.point_b, c.b, nullptr), 1e-8) << name << " case " << i;
    EXPECT_NEAR((s.point_b - s.point_a).norm(), s.distance, 1e-8) << name << " case " << i;
    EXPECT_NEAR(s.normal.norm(), 1.0, 1e-12) << name << " case " << i;
    EXPECT_GT(s.normal.dot(s.point_b - s.point_a), 0.0) << name << " case " << i;
  }
  std::printf("[ %s ] max |d - d_ref| over %zu cases: %.3g\n", name, cases.size(), max_err);
  return max_err;
}

TEST(CylinderCylinder, FeatureSolverMatchesReference) {
  double worst_gap = 0.0;
  check_reference(
      [&](const Cylinder& a, const Cylinder& b) {
        double gap = 0.0;
        Separation s = cylinder_cylinder_features(a, b, &gap);
        worst_gap = std::max(worst_gap, gap);
        return s;
      },
      "features");
  // The a-posteriori duality gap stays far below the fallback threshold.
  EXPECT_LT(worst_gap, 1e-8);
  std::printf("[ features ] worst duality gap: %.3g\n", worst_gap);
}

TEST(CylinderCylinder, DefaultSolverMatchesReferenceWithoutFallback) {
  const long before = cylinder_cylinder_fallbacks();
  check_reference([](const Cylinder& a, const Cylinder& b) { return cylinder_cylinder(a, b); },
                  "cylinder_cylinder");
  EXPECT_EQ(cylinder_cylinder_fallbacks(), before);
}

TEST(CylinderCylinder, FclMatchesReference) {
  check_reference(
      [](const Cylinder& a, const Cylinder& b) { return cylinder_cylinder_fcl(a, b, 1e-10); },
      "fcl");
}

TEST(CylinderCylinder, SymmetricUnderSwap) {
  for (const RefCase& c : reference()) {
    const Separation ab = cylinder_cylinder(c.a, c.b), ba = cylinder_cylinder(c.b, c.a);
    EXPECT_NEAR(ab.distance, ba.distance, 1e-12);
    EXPECT_TRUE(ab.normal.isApprox(-ba.normal, 1e-6));
  }
}

// FCL 0.7: are nearest_points world-frame? Place both cylinders far from the
// origin and rotated, so local-frame points would be off the surfaces.
TEST(CylinderCylinder, FclNearestPointsAreWorldFrame) {
  const Vec3 off(10, -20, 30);
  const Cylinder a{off, Vec3(0, 1, 0), 1.0, 2.0};
  const Cylinder b{off + Vec3(2.5, 0.5, 0), Vec3(0, 0, 1), 1.0, 2.0};
  const Separation s = cylinder_cylinder_fcl(a, b, 1e-10);
  EXPECT_NEAR(s.distance, 0.5, 1e-8);
  EXPECT_TRUE(s.point_a.isApprox(off + Vec3(1, 0.5, 0), 1e-7)) << s.point_a.transpose();
  EXPECT_TRUE(s.point_b.isApprox(off + Vec3(1.5, 0.5, 0), 1e-7)) << s.point_b.transpose();
}

TEST(CylinderCylinder, HandCases) {
  const Cylinder a = unit_z_cylinder();
  // Coaxial, end to end with a 0.3 gap.
  Separation s = cylinder_cylinder(a, {Vec3(0, 0, 4.3), Vec3(0, 0, -1), 1.0, 2.0});
  EXPECT_NEAR(s.distance, 0.3, 1e-14);
  EXPECT_TRUE(s.normal.isApprox(Vec3::UnitZ(), 1e-14));
  // Parallel side by side.
  s = cylinder_cylinder(a, {Vec3(2.5, 0, 1), Vec3::UnitZ(), 1.0, 2.0});
  EXPECT_NEAR(s.distance, 0.5, 1e-14);
  EXPECT_TRUE(s.normal.isApprox(Vec3::UnitX(), 1e-14));
  // Crossed sides (perpendicular, axes offset by 2.7 along y).
  s = cylinder_cylinder(a, {Vec3(0, 2.7, 0.5), Vec3::UnitX(), 1.0, 2.0});
  EXPECT_NEAR(s.distance, 0.7, 1e-14);
  EXPECT_TRUE(s.point_a.isApprox(Vec3(0, 1, 0.5), 1e-14));
  // Cap of b resting over the end face of a, b perpendicular: b's side line.
  s = cylinder_cylinder(a, {Vec3(0, 0, 3.2), Vec3::UnitX(), 1.0, 2.0});
  EXPECT_NEAR(s.distance, 0.2, 1e-14);
  // Coin's edge against the face of a perpendicular coin.
  const Cylinder c1{Vec3::Zero(), Vec3::UnitZ(), 1.0, 0.1};
  const Cylinder c2{Vec3(2.6, 0, 0), Vec3::UnitX(), 1.0, 0.1};  // face towards c1's edge
  s = cylinder_cylinder(c1, c2);
  EXPECT_NEAR(s.distance, 2.6 - 0.1 - 1.0, 1e-14);
}

TEST(CylinderCylinder, OverlapIsNonPositiveAndFinite) {
  const Cylinder a = unit_z_cylinder();
  const std::vector<Cylinder> others = {
      {Vec3(1.5, 0, 0), Vec3::UnitZ(), 1.0, 2.0},          // parallel, sides overlap
      {Vec3(0, 1.5, 0.3), Vec3::UnitX(), 1.0, 2.0},        // crossed, rims outside
      {Vec3(0, 0, 3.5), Vec3::UnitZ(), 1.0, 2.0},          // coaxial overlap
      {Vec3(0.2, 0.1, 0.0), Vec3(1, 2, 3).normalized(), 1.0, 2.0},  // nearly concentric
      {Vec3::Zero(), Vec3::UnitZ(), 1.0, 2.0},             // identical
      {Vec3(0, 0, 0.5), Vec3::UnitX(), 0.2, 5.0},          // needle through the middle
  };
  for (const Cylinder& b : others) {
    for (const Separation& s : {cylinder_cylinder(a, b), cylinder_cylinder(b, a)}) {
      EXPECT_LE(s.distance, 0.0);
      EXPECT_TRUE(s.point_a.allFinite() && s.point_b.allFinite() && s.normal.allFinite());
      EXPECT_NEAR(s.normal.norm(), 1.0, 1e-12);
    }
  }
}

// Random sizes and poses around contact, a third of them with parallel,
// antiparallel or perpendicular axes: separated pairs must agree with FCL
// (its GJK error ~1e-8) and be certified by the duality gap; pairs FCL finds
// colliding must come out <= 0 from cylinder_cylinder (possibly via fallback).
// (A pair at distance 1.9e-7 that FCL's collide() calls colliding was seen.)
TEST(CylinderCylinder, RandomPosesAgreeWithFcl) {
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u(-1.0, 1.0), pos(0.0, 1.0);
  auto unit = [&] {
    Vec3 v;
    do v = Vec3(u(rng), u(rng), u(rng));
    while (v.norm() > 1.0 || v.norm() < 0.1);
    return Vec3(v.normalized());
  };
  int separated = 0, overlapping = 0;
  for (int it = 0; it < 3000; ++it) {
    const Cylinder a{Vec3::Zero(), unit(), 0.2 + 1.5 * pos(rng), 0.05 + 3.0 * pos(rng)};
    Vec3 ub = unit();
    if (it % 6 == 1) ub = a.axis;
    if (it % 6 == 2) ub = -a.axis;
    if (it % 6 == 3) ub = a.axis.cross(ub).normalized();
    const double rb = 0.2 + 1.5 * pos(rng), hb = 0.05 + 3.0 * pos(rng);
    const double reach = std::hypot(a.radius, a.half_length) + std::hypot(rb, hb);
    const Vec3 dir = it % 6 == 4 ? a.axis : unit();
    const Cylinder b{pos(rng) * reach * dir, ub, rb, hb};
    // FCL's collide() has a GJK tolerance of ~1e-6: call a pair overlapping
    // only when the solids shrunk by 1e-6 still collide.
    const bool collide = fcl_cylinders_overlap(a, b, 1e-6);
    const Separation s = cylinder_cylinder(a, b);
    ASSERT_TRUE(s.point_a.allFinite() && s.point_b.allFinite() && s.normal.allFinite()) << it;
    EXPECT_NEAR(s.normal.norm(), 1.0, 1e-12) << it;
    if (collide) {
      ++overlapping;
      EXPECT_LE(s.distance, 0.0) << it;
      continue;
    }
    if (fcl_cylinders_overlap(a, b, 0.0)) continue;  // within FCL's tolerance of touching
    double gap = 1.0;
    const Separation f = cylinder_cylinder_features(a, b, &gap);
    const Separation g = cylinder_cylinder_fcl(a, b, 1e-12);
    if (f.distance <= 1e-9 || g.distance <= 1e-9) continue;  // touching within FCL's accuracy
    ++separated;
    EXPECT_LE(gap, 1e-11) << it;
    EXPECT_NEAR(f.distance, g.distance, 3e-8) << it;
    EXPECT_LE(point_cylinder_distance(f.point_a, a, nullptr), 1e-12) << it;
    EXPECT_LE(point_cylinder_distance(f.point_b, b, nullptr), 1e-12) << it;
    EXPECT_NEAR((f.point_b - f.point_a).norm(), f.distance, 1e-12) << it;
  }
  EXPECT_GT(separated, 500);
  EXPECT_GT(overlapping, 500);
}

// ---- FCL overlap oracle ------------------------------------------------------------

TEST(FclOracle, Cylinders) {
  const Cylinder a = unit_z_cylinder();
  EXPECT_TRUE(fcl_cylinders_overlap(a, {Vec3(1.5, 0, 0), Vec3::UnitZ(), 1.0, 2.0}, 0.0));
  EXPECT_TRUE(fcl_cylinders_overlap(a, {Vec3(0, 1.5, 0.3), Vec3::UnitX(), 1.0, 2.0}, 0.1));
  EXPECT_FALSE(fcl_cylinders_overlap(a, {Vec3(2.1, 0, 0), Vec3::UnitZ(), 1.0, 2.0}, 0.0));
  EXPECT_FALSE(fcl_cylinders_overlap(a, {Vec3(0, 0, 4.3), Vec3::UnitZ(), 1.0, 2.0}, 0.0));
  // Overlapping by 0.02 on the sides: an overlap, but not with slack 0.05.
  const Cylinder b{Vec3(1.98, 0, 0.5), Vec3::UnitZ(), 1.0, 2.0};
  EXPECT_TRUE(fcl_cylinders_overlap(a, b, 0.0));
  EXPECT_FALSE(fcl_cylinders_overlap(a, b, 0.05));
}

TEST(FclOracle, SphereCylinder) {
  const Cylinder c = unit_z_cylinder();
  EXPECT_TRUE(fcl_sphere_cylinder_overlap(Vec3(1.8, 0, 0), 1.0, c, 0.0));
  EXPECT_FALSE(fcl_sphere_cylinder_overlap(Vec3(2.1, 0, 0), 1.0, c, 0.0));
  EXPECT_TRUE(fcl_sphere_cylinder_overlap(Vec3(0, 0, 2.9), 1.0, c, 0.0));
  EXPECT_FALSE(fcl_sphere_cylinder_overlap(Vec3(0, 0, 2.9), 1.0, c, 0.1));
  // Rim diagonal: centre 1.2 from the rim (distance -> 0.2 apart).
  EXPECT_FALSE(fcl_sphere_cylinder_overlap(Vec3(1, 0, 2) + 1.2 * Vec3(1, 0, 1).normalized(), 1.0, c, 0.0));
  EXPECT_TRUE(fcl_sphere_cylinder_overlap(Vec3(1, 0, 2) + 0.9 * Vec3(1, 0, 1).normalized(), 1.0, c, 0.0));
}

TEST(FclOracle, AgreesWithCylinderDistanceSign) {
  // Reference pairs are separated by > 0; pushed together by 1.5 d they overlap.
  for (const RefCase& c : reference()) {
    EXPECT_FALSE(fcl_cylinders_overlap(c.a, c.b, 0.0));
    const Separation s = cylinder_cylinder(c.a, c.b);
    Cylinder b = c.b;
    b.center -= 1.5 * s.distance * s.normal;
    EXPECT_TRUE(fcl_cylinders_overlap(c.a, b, 0.0));
    EXPECT_LE(cylinder_cylinder(c.a, b).distance, 0.0);
  }
}

// ---- mass properties ---------------------------------------------------------------

TEST(Shapes, CylinderMassProps) {
  const ringsim::MassProps m = ringsim::cylinder_mass_props(1.0, 4.0, 1.0);
  EXPECT_NEAR(m.mass, 4.0 * kPi, 1e-14);
  EXPECT_NEAR(m.i_axial, 2.0 * kPi, 1e-14);
  EXPECT_NEAR(m.i_perp, 19.0 * kPi / 3.0, 1e-14);
  EXPECT_NEAR(ringsim::cylinder_bounding_radius(1.0, 4.0), std::sqrt(5.0), 1e-15);
}

TEST(Shapes, SphereMassProps) {
  const ringsim::MassProps m = ringsim::sphere_mass_props(2.0, 0.5);
  EXPECT_NEAR(m.mass, 4.0 / 3.0 * kPi * 8.0 * 0.5, 1e-14);
  EXPECT_NEAR(m.i_axial, 0.4 * m.mass * 4.0, 1e-14);
  EXPECT_EQ(m.i_axial, m.i_perp);
}

}  // namespace
