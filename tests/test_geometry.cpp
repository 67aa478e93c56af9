// Narrow-phase geometry against hand-derived cases and the independent
// reference set tests/data/cylinder_distance.json.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/geometry.hpp"
#include "core/shapes.hpp"

#ifndef RINGSIM_TESTDATA_DIR
#define RINGSIM_TESTDATA_DIR "tests/data"
#endif

namespace {

using ringsim::Vec3;
using namespace ringsim::geom;

constexpr double kPi = 3.14159265358979323846;

Cylinder unit_z_cylinder() { return {Vec3::Zero(), Vec3::UnitZ(), 1.0, 2.0}; }

// A uniformly random direction (rejection from the unit ball, away from 0).
Vec3 random_unit(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vec3 v;
  do v = Vec3(u(rng), u(rng), u(rng));
  while (v.norm() > 1.0 || v.norm() < 0.1);
  return v.normalized();
}

// The second axis of a random pose: every sixth pose from it % 6 == 1 on
// parallel, antiparallel and perpendicular to the first (the special cases of
// every distance routine), the random direction `ub` otherwise.
Vec3 special_axis(int it, const Vec3& ua, const Vec3& ub) {
  if (it % 6 == 1) return ua;
  if (it % 6 == 2) return -ua;
  if (it % 6 == 3) return ua.cross(ub).normalized();
  return ub;
}

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

// ---- point vs end-face disk (the capture gap, bonding.capture_site = end_face)

TEST(PointDisk, HandCases) {
  // Disk of radius 1 at c with normal n = z.
  const Vec3 c(1, 2, 3), n = Vec3::UnitZ();
  Vec3 q;
  // Face-on: straight above a point of the face, the axial distance.
  EXPECT_DOUBLE_EQ(point_disk_distance(c + Vec3(0.3, -0.4, 2.5), c, n, 1.0, &q), 2.5);
  EXPECT_TRUE(q.isApprox(c + Vec3(0.3, -0.4, 0.0), 1e-15));
  // On the axis: the centre.
  EXPECT_DOUBLE_EQ(point_disk_distance(c + Vec3(0, 0, 0.7), c, n, 1.0, &q), 0.7);
  EXPECT_EQ(q, c);
  // In the disk's plane beyond the rim: the radial excess.
  EXPECT_DOUBLE_EQ(point_disk_distance(c + Vec3(0, 1.75, 0), c, n, 1.0, &q), 0.75);
  EXPECT_TRUE(q.isApprox(c + Vec3(0, 1, 0), 1e-15));
  // Diagonal over the rim (3-4-5 triangle from the rim point).
  EXPECT_NEAR(point_disk_distance(c + Vec3(4.0, 0, 4.0), c, n, 1.0, &q), 5.0, 1e-14);
  EXPECT_TRUE(q.isApprox(c + Vec3(1, 0, 0), 1e-15));
  // Behind the face, beside the side of its cylinder: the disk is two-sided,
  // so the distance is to the rim again.
  EXPECT_NEAR(point_disk_distance(c + Vec3(0, -2.2, -0.5), c, n, 1.0), std::hypot(1.2, 0.5), 1e-15);
  // A sphere grazing the side near the rim (lateral gap 0.05, 0.3 behind the
  // face plane) is within reach of the face: the surface reading captures it.
  EXPECT_NEAR(point_disk_distance(c + Vec3(2.05, 0, -0.3), c, n, 1.0) - 1.0, std::hypot(1.05, 0.3) - 1.0, 1e-15);
  // Behind the face on the axis: the centre, at the axial distance.
  EXPECT_DOUBLE_EQ(point_disk_distance(c + Vec3(0, 0, -2.0), c, n, 1.0), 2.0);
}

TEST(PointDisk, ClosedFormMatchesSearchOnRandomPoses) {
  // 10^4 random disks and points (radius 0.5-2, point within 4 of the
  // centre, at least 0.01 from the disk): the closed form against the
  // independent search over the azimuth (point_disk_distance_search).
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0), rad(0.5, 2.0);
  double worst = 0.0;
  int rim = 0;
  for (int it = 0; it < 10000; ++it) {
    const Vec3 c(5.0 * u(rng), 5.0 * u(rng), 5.0 * u(rng)), n = random_unit(rng);
    const double r = rad(rng);
    const Vec3 x = c + 4.0 * Vec3(u(rng), u(rng), u(rng));
    Vec3 q;
    const double d = point_disk_distance(x, c, n, r, &q);
    if (d < 0.01) continue;
    rim += std::abs((q - c).norm() - r) < 1e-12;
    EXPECT_NEAR((x - q).norm(), d, 1e-13);             // the closest point is at that distance
    EXPECT_LT(std::abs(n.dot(q - c)), 1e-13);           // and in the disk's plane
    EXPECT_LE((q - c).norm(), r + 1e-13);               // and on the disk
    worst = std::max(worst, std::abs(d - point_disk_distance_search(x, c, n, r)));
  }
  EXPECT_LT(worst, 1e-12);
  EXPECT_GT(rim, 1000);  // both regimes (rim and face) are exercised
  std::printf("closed form vs search: largest difference %.2e, %d rim cases\n", worst, rim);
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

// The pose of the one failed replicate of the R = 60 study (Scenario 5, seed
// 1, replicate 20, t = 4593.2; docs/ARCHITECTURE.md, "A search that gave
// up"): a rim of b 3e-9 from the side of a, b's face tilted 11 degrees from
// a's tangent plane. With a's axis as the simulation had it (|u| = 1 +
// 2.6e-9) no plane certified it; with unit axes the feature solver must,
// and the exact side normal gives the distance to rounding.
TEST(CylinderCylinder, Scenario5FailurePoseCertifies) {
  const Vec3 ua = Vec3(0x1.e03834f1ad0afp-12, 0x1.432dff4ad36cfp-19, -0x1.fffffc9159963p-1).normalized();
  const Cylinder a{Vec3(0x1.87fcee898e95p+5, 0x1.00005165cbfe8p+0, 0x1.654766c092be2p+5), ua, 1.0, 2.0};
  const Cylinder b{Vec3(0x1.7ef61573583b7p+5, 0x1.fef9030533f7bp+1, 0x1.72594dc3f54fp+5),
                   Vec3(0x1.bb122e94b7b77p-6, -0x1.fd9d2bc678468p-1, 0x1.7b20e0620728bp-4), 1.0, 2.0};
  for (bool swap : {false, true}) {
    double gap = 1.0;
    const Separation f = swap ? cylinder_cylinder_features(b, a, &gap) : cylinder_cylinder_features(a, b, &gap);
    EXPECT_LE(gap, 1e-12) << swap;
    EXPECT_NEAR(f.distance, 2.9682203e-9, 1e-15) << swap;
    bool certified = false;
    const Separation s = swap ? cylinder_cylinder(b, a, 1e-10, &certified) : cylinder_cylinder(a, b, 1e-10, &certified);
    EXPECT_TRUE(certified) << swap;
    EXPECT_EQ(s.distance, f.distance) << swap;
  }
  // The side normal of a at its closest point (exactly perpendicular to a's
  // axis) is the separating plane: its value is the distance.
  const Separation f = cylinder_cylinder_features(a, b);
  Vec3 radial = f.point_a - a.center;
  radial -= radial.dot(a.axis) * a.axis;
  const Vec3 n = radial.normalized();
  const double plane = n.dot(b.center - a.center) - cylinder_support(a, n) - cylinder_support(b, -n);
  EXPECT_NEAR(plane, f.distance, 1e-14);
}

// A rim of a crossing over the edge of b's end face at distance eps, in the
// rim region of b (direction alpha between b's radial and its face normal):
// along the rim the distance to b has a kink at the scale of eps (one side
// faces b's end face, the other b's side), the case RimSearch::face_edge
// samples where the rim crosses the face's plane. Construction: b along z,
// edge point E = (1, 0, 2); P = E + eps n, n = (cos alpha, 0, sin alpha);
// tau = (-sin alpha, 0, cos alpha) (perpendicular to n and to the edge).
// a's rim (radius 1) passes through P along tau, centred at P + m with
// m = cos(gamma) n + sin(gamma) y: it curves away from E, so P is its point
// nearest to b, and the tilt gamma puts P between the search's samples
// (which start from the point of b nearest to the rim's centre). a's axis
// is tau x m, its body on the side where its generator through P moves away
// from b. The distance is eps, the normal -n.
TEST(CylinderCylinder, RimOverAFaceEdge) {
  const Cylinder b{Vec3::Zero(), Vec3::UnitZ(), 1.0, 2.0};
  int cases = 0;
  for (double eps : {1e-2, 1e-5, 1e-8, 5e-10}) {
    for (double alpha : {0.2, 0.7, 1.2}) {
      for (double gamma : {0.3, -0.5, 0.9}) {
        const Vec3 n(std::cos(alpha), 0.0, std::sin(alpha)), tau(-std::sin(alpha), 0.0, std::cos(alpha));
        const Vec3 m = std::cos(gamma) * n + std::sin(gamma) * Vec3::UnitY();
        const Vec3 rim_center = Vec3(1.0, 0.0, 2.0) + eps * n + m;
        const Vec3 u = tau.cross(m);
        const Vec3 axis = gamma > 0.0 ? Vec3(-u) : u;
        const Cylinder a{rim_center + 2.0 * axis, axis, 1.0, 2.0};
        for (bool swap : {false, true}) {
          bool certified = false;
          const Separation s = swap ? cylinder_cylinder(b, a, 1e-10, &certified) : cylinder_cylinder(a, b, 1e-10, &certified);
          EXPECT_TRUE(certified) << eps << " " << alpha << " " << gamma << " " << swap;
          EXPECT_NEAR(s.distance, eps, 1e-14 + 1e-12 * eps) << eps << " " << alpha << " " << gamma << " " << swap;
          const Vec3 normal = swap ? Vec3(-s.normal) : s.normal;  // from a towards b
          EXPECT_NEAR(normal.dot(-n), 1.0, 1e-6) << eps << " " << alpha << " " << gamma << " " << swap;
          ++cases;
        }
      }
    }
  }
  EXPECT_EQ(cases, 72);
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
  std::uniform_real_distribution<double> pos(0.0, 1.0);
  auto unit = [&] { return random_unit(rng); };
  int separated = 0, overlapping = 0;
  for (int it = 0; it < 3000; ++it) {
    const Cylinder a{Vec3::Zero(), unit(), 0.2 + 1.5 * pos(rng), 0.05 + 3.0 * pos(rng)};
    const Vec3 ub = special_axis(it, a.axis, unit());
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

// ---- segment-segment and capsule distance -----------------------------------------

// Exact distance from point p to the segment c + s u, |s| <= h (closed form).
double point_segment(const Vec3& p, const Vec3& c, const Vec3& u, double h) {
  const double s = std::min(std::max((p - c).dot(u), -h), h);
  return (p - c - s * u).norm();
}

// Brute force: sample A's parameter densely with the exact point-to-segment
// distance to B, then refine around the best sample by golden section
// (D(s) = dist(c_a + s u_a, segment B) is convex in s, so the bracket around
// the best sample holds the minimum).
double brute_segment_distance(const Vec3& ca, const Vec3& ua, double ha, const Vec3& cb, const Vec3& ub, double hb) {
  constexpr int kSamples = 2000;
  auto D = [&](double s) { return point_segment(ca + s * ua, cb, ub, hb); };
  int best = 0;
  double best_d = D(-ha);
  for (int k = 1; k <= kSamples; ++k) {
    const double d = D(-ha + 2.0 * ha * k / kSamples);
    if (d < best_d) best_d = d, best = k;
  }
  double lo = -ha + 2.0 * ha * std::max(best - 1, 0) / kSamples;
  double hi = -ha + 2.0 * ha * std::min(best + 1, kSamples) / kSamples;
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int it = 0; it < 200 && hi - lo > 1e-15; ++it) {
    const double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
    if (D(x1) < D(x2)) hi = x2;
    else lo = x1;
  }
  return std::min({best_d, D(lo), D(hi), D(0.5 * (lo + hi))});
}

TEST(SegmentSegment, HandCases) {
  // Perpendicular, crossing at a distance 3 (interior points).
  SegmentPair p = segment_segment(Vec3::Zero(), Vec3::UnitX(), 2.0, Vec3(0.5, 0.25, 3.0), Vec3::UnitY(), 1.0);
  EXPECT_NEAR(p.distance, 3.0, 1e-15);
  EXPECT_NEAR(p.s_a, 0.5, 1e-15);
  EXPECT_NEAR(p.s_b, -0.25, 1e-15);
  // Collinear, end to end with a gap 0.5.
  p = segment_segment(Vec3::Zero(), Vec3::UnitX(), 2.0, Vec3(4.5, 0, 0), Vec3(-1, 0, 0), 2.0);
  EXPECT_NEAR(p.distance, 0.5, 1e-15);
  EXPECT_TRUE(p.point_a.isApprox(Vec3(2, 0, 0), 1e-15));
  EXPECT_TRUE(p.point_b.isApprox(Vec3(2.5, 0, 0), 1e-15));
  // Parallel, overlapping in projection: the line distance.
  p = segment_segment(Vec3::Zero(), Vec3::UnitX(), 2.0, Vec3(1, 0.7, 0), Vec3::UnitX(), 2.0);
  EXPECT_NEAR(p.distance, 0.7, 1e-15);
  // Skew, both closest points clamped to ends: (2,0,0) and (3,1,0).
  p = segment_segment(Vec3::Zero(), Vec3::UnitX(), 2.0, Vec3(3, 2, 0), Vec3::UnitY(), 1.0);
  EXPECT_NEAR(p.distance, std::sqrt(2.0), 1e-15);
  EXPECT_TRUE(p.point_b.isApprox(Vec3(3, 1, 0), 1e-15));
  // Zero-length segments are points.
  p = segment_segment(Vec3::Zero(), Vec3::UnitX(), 0.0, Vec3(0, 0, 2), Vec3::UnitY(), 0.0);
  EXPECT_NEAR(p.distance, 2.0, 1e-15);
}

// Random segments, a third of them with parallel, antiparallel or
// perpendicular directions, and collinear ones: the distance agrees with
// brute force, the points lie on the segments and realise it.
TEST(SegmentSegment, MatchesBruteForce) {
  std::mt19937_64 rng(2024);
  std::uniform_real_distribution<double> u(-1.0, 1.0), pos(0.0, 1.0);
  auto unit = [&] { return random_unit(rng); };
  double worst = 0.0;
  for (int it = 0; it < 3000; ++it) {
    const Vec3 ua = unit();
    Vec3 ub = special_axis(it, ua, unit());
    if (it % 6 == 4) ub = (ua + 1e-9 * unit()).normalized();  // nearly parallel
    const double ha = 3.0 * pos(rng), hb = 3.0 * pos(rng);
    const Vec3 ca = Vec3(u(rng), u(rng), u(rng)), cb = it % 6 == 5 ? Vec3(ca + 6.0 * u(rng) * ua) : Vec3(5.0 * Vec3(u(rng), u(rng), u(rng)));
    if (it % 6 == 5) ub = it % 2 ? ua : Vec3(-ua);  // collinear
    const SegmentPair p = segment_segment(ca, ua, ha, cb, ub, hb);
    const double ref = brute_segment_distance(ca, ua, ha, cb, ub, hb);
    worst = std::max(worst, std::abs(p.distance - ref));
    EXPECT_NEAR(p.distance, ref, 1e-12) << it;
    EXPECT_LE(std::abs(p.s_a), ha) << it;
    EXPECT_LE(std::abs(p.s_b), hb) << it;
    EXPECT_TRUE(p.point_a.isApprox(ca + p.s_a * ua, 1e-14)) << it;
    EXPECT_TRUE(p.point_b.isApprox(cb + p.s_b * ub, 1e-14)) << it;
    EXPECT_NEAR((p.point_b - p.point_a).norm(), p.distance, 1e-14) << it;
    // Symmetric under swapping the segments.
    EXPECT_NEAR(segment_segment(cb, ub, hb, ca, ua, ha).distance, p.distance, 1e-12) << it;
  }
  std::printf("[ segment_segment ] max |d - brute force| over 3000 poses: %.3g\n", worst);
}

// The capsule (axis segment swept by a ball of the radius) contains the
// cylinder, so its distance is a lower bound of the cylinder distance; equal
// when both closest points of the cylinders are on their lateral surfaces.
// Along the capsule normal the cylinders' separating-plane value is at least
// the capsule distance (the bound advance_generic steps from).
// `reference`: an independent distance, accurate to `ref_tol`.
// Returns {checked, lateral-lateral} counts.
std::pair<int, int> check_capsule_bound(const Cylinder& a, const Cylinder& b, double reference, double ref_tol,
                                        const char* what, int it) {
  const Separation cap = capsule_capsule(a, b);
  const Separation cyl = cylinder_cylinder(a, b);
  EXPECT_NEAR(cap.normal.norm(), 1.0, 1e-14) << what << " " << it;
  EXPECT_LE(cap.distance, reference + ref_tol) << what << " " << it;
  EXPECT_LE(cap.distance, cyl.distance + 1e-12) << what << " " << it;
  const double plane = cap.normal.dot(b.center - a.center) - cylinder_support(a, cap.normal) - cylinder_support(b, -cap.normal);
  EXPECT_GE(plane, cap.distance - 1e-12) << what << " " << it;
  auto on_side = [](const Cylinder& c, const Vec3& p) {
    return std::abs((p - c.center).dot(c.axis)) < c.half_length - 1e-6;
  };
  const bool lateral = on_side(a, cyl.point_a) && on_side(b, cyl.point_b);
  if (lateral) EXPECT_NEAR(cap.distance, cyl.distance, 1e-12) << what << " " << it;
  return {1, lateral ? 1 : 0};
}

TEST(CapsuleCapsule, LowerBoundOnReference) {
  int lateral = 0, it = 0;
  double worst_gap = 0.0;
  for (const RefCase& c : reference()) {
    // (the reference set is accurate to 3e-9, see check_reference)
    lateral += check_capsule_bound(c.a, c.b, c.distance, 3e-9, "reference case", it++).second;
    worst_gap = std::max(worst_gap, c.distance - capsule_capsule(c.a, c.b).distance);
  }
  EXPECT_GT(lateral, 20);
  std::printf("[ capsule ] %d of %d reference cases lateral-lateral (equal); largest cylinder - capsule: %.3g\n",
              lateral, it, worst_gap);
}

TEST(CapsuleCapsule, LowerBoundOnRandomPoses) {
  std::mt19937_64 rng(777);
  std::uniform_real_distribution<double> pos(0.0, 1.0);
  auto unit = [&] { return random_unit(rng); };
  int separated = 0, lateral = 0;
  for (int it = 0; it < 3000; ++it) {
    // Linkers (radius 1, half length 2) half the time, random sizes otherwise.
    const bool linker = it % 2 == 0;
    const Cylinder a{Vec3::Zero(), unit(), linker ? 1.0 : 0.2 + 1.5 * pos(rng), linker ? 2.0 : 0.05 + 3.0 * pos(rng)};
    const Vec3 ub = special_axis(it, a.axis, unit());
    const double rb = linker ? 1.0 : 0.2 + 1.5 * pos(rng), hb = linker ? 2.0 : 0.05 + 3.0 * pos(rng);
    const double reach = std::hypot(a.radius, a.half_length) + std::hypot(rb, hb);
    const Cylinder b{(0.5 + 1.5 * pos(rng)) * reach * unit(), ub, rb, hb};
    const Separation cyl = cylinder_cylinder(a, b);
    if (cyl.distance <= 0.0) continue;
    const auto [n, l] = check_capsule_bound(a, b, cyl.distance, 1e-12, "random pose", it);
    separated += n, lateral += l;
  }
  EXPECT_GT(separated, 2000);
  EXPECT_GT(lateral, 200);
  std::printf("[ capsule ] %d random separated poses, %d lateral-lateral\n", separated, lateral);
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

// FCL's cylinder frame is built from the axis (fcl_pose). Eigen's
// FromTwoVectors lost accuracy for axes near -z (a rotation matrix up to 3e-4
// off orthogonal), so FCL measured a deformed cylinder there. The certified
// feature solver is the reference; the same solid with the axis flipped
// (a cylinder is symmetric under u -> -u) must give the same answer.
TEST(FclOracle, AxisNearMinusZ) {
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  int checked = 0;
  for (double eps : {1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7}) {
    for (int k = 0; k < 40; ++k) {
      const Vec3 u = Vec3(eps * U(rng), eps * U(rng), -1.0).normalized();
      const Cylinder a{Vec3::Zero(), u, 1.0, 2.0};
      // b beside a's side or beyond its face, 0.05-0.5 away.
      const Vec3 dir = k % 2 ? Vec3(U(rng), U(rng), 0.2 * U(rng)).normalized() : Vec3(0.2 * U(rng), 0.2 * U(rng), -1.0).normalized();
      const Cylinder b{(3.3 + 0.5 * std::abs(U(rng))) * dir, random_unit(rng), 1.0, 2.0};
      double gap = 1.0;
      const Separation f = cylinder_cylinder_features(a, b, &gap);
      if (f.distance < 0.05) continue;
      ASSERT_LE(gap, 1e-11) << eps << " " << k;
      ++checked;
      const Cylinder flipped{a.center, -u, 1.0, 2.0};
      EXPECT_NEAR(cylinder_cylinder_fcl(a, b, 1e-12).distance, f.distance, 3e-8) << eps << " " << k;
      EXPECT_NEAR(cylinder_cylinder_fcl(flipped, b, 1e-12).distance, f.distance, 3e-8) << eps << " " << k;
      // Touching within 1e-6: the oracle sees an overlap once b is moved
      // 2e-6 closer along the normal, and none at its place.
      EXPECT_FALSE(fcl_cylinders_overlap(a, b, 0.0)) << eps << " " << k;
      const Cylinder closer{b.center - (f.distance + 2e-6) * f.normal, b.axis, 1.0, 2.0};
      EXPECT_TRUE(fcl_cylinders_overlap(a, closer, 0.0)) << eps << " " << k;
    }
  }
  EXPECT_GT(checked, 150);
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
