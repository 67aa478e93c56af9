// Bond-rule geometry (core/bond_rules.hpp) on hand-built poses: square rings,
// zigzag chains, chains twisted by known angles; cis/trans in both modes;
// tolerance boundaries to 1e-9 degrees; filters on and off; degenerate
// dihedrals.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/bond_rules.hpp"

namespace ringsim {
namespace {

constexpr double kPi = 3.14159265358979323846;

double rad(double deg) { return deg * kPi / 180.0; }

// A linker lying between two consecutive spheres of a chain: `forward` says
// whether its axis u points from sphere i to sphere i + 1 (then end 0, at
// x + h u, faces sphere i + 1).
struct ChainLinker {
  Vec3 x, u;
  int end_towards_next;  // the end facing sphere i + 1
  int end_towards_prev;  // the end facing sphere i
};

// Linkers of a chain through the sphere centres `s` (closed: also s.back() ->
// s.front()), with axis orientations given by `forward` (one per linker).
std::vector<ChainLinker> build_chain(const std::vector<Vec3>& s, const std::vector<bool>& forward, bool closed) {
  std::vector<ChainLinker> out;
  const std::size_t n = closed ? s.size() : s.size() - 1;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3& p = s[i];
    const Vec3& q = s[(i + 1) % s.size()];
    const Vec3 d = (q - p).normalized();
    ChainLinker l;
    l.x = 0.5 * (p + q);
    l.u = forward[i] ? d : Vec3(-d);
    l.end_towards_next = forward[i] ? 0 : 1;
    l.end_towards_prev = 1 - l.end_towards_next;
    out.push_back(l);
  }
  return out;
}

// Bond angle at sphere i + 1, between linker i and linker i + 1.
double angle_at_joint(const std::vector<ChainLinker>& l, std::size_t i) {
  const ChainLinker& a = l[i];
  const ChainLinker& b = l[(i + 1) % l.size()];
  return bond_angle_deg(outward_axis(a.u, a.end_towards_next), outward_axis(b.u, b.end_towards_prev));
}

// Dihedral about linker i, with its neighbours i - 1 and i + 1, following the
// header's convention (n0: the neighbour on the end-0 side).
std::optional<double> dihedral_about(const std::vector<ChainLinker>& l, std::size_t i) {
  const ChainLinker& m = l[i];
  const ChainLinker& prev = l[(i + l.size() - 1) % l.size()];
  const ChainLinker& next = l[(i + 1) % l.size()];
  const Vec3 n_prev = outward_axis(prev.u, prev.end_towards_next);  // at the sphere before m
  const Vec3 n_next = outward_axis(next.u, next.end_towards_prev);  // at the sphere after m
  // m's end facing the next sphere is end_towards_next.
  return m.end_towards_next == 0 ? dihedral_deg(m.u, n_next, n_prev) : dihedral_deg(m.u, n_prev, n_next);
}

BondingParams defaults() { return BondingParams{}; }

// ---- conventions ------------------------------------------------------------------

TEST(BondRules, EndsAndOutwardAxes) {
  const Vec3 x(1.0, 2.0, 3.0);
  const Vec3 u = Vec3(1.0, -2.0, 2.0).normalized();
  const double h = 2.0;
  const Vec3 a = linker_end(x, u, h, 0);
  const Vec3 b = linker_end(x, u, h, 1);
  EXPECT_LT((a - (x + h * u)).norm(), 1e-15);  // MODEL.md: p = x_L + (l_L/2) u
  EXPECT_LT((b - (x - h * u)).norm(), 1e-15);
  // Outward axis: from the bonded end towards the other end.
  EXPECT_LT((outward_axis(u, 0) - (b - a).normalized()).norm(), 1e-15);
  EXPECT_LT((outward_axis(u, 1) - (a - b).normalized()).norm(), 1e-15);
  EXPECT_EQ(outward_axis(u, 0), Vec3(-u));
  EXPECT_EQ(outward_axis(u, 1), u);
}

// ---- bond angle -------------------------------------------------------------------

TEST(BondRules, BondAngleOfKnownPoses) {
  const Vec3 ex(1, 0, 0), ey(0, 1, 0);
  EXPECT_DOUBLE_EQ(bond_angle_deg(ex, ey), 90.0);
  EXPECT_DOUBLE_EQ(bond_angle_deg(ex, ex), 0.0);
  EXPECT_DOUBLE_EQ(bond_angle_deg(ex, Vec3(-ex)), 180.0);
  for (double t = 0.0; t <= 180.0; t += 7.5) {
    const Vec3 n(std::cos(rad(t)), std::sin(rad(t)), 0.0);
    EXPECT_NEAR(bond_angle_deg(ex, n), t, 1e-12) << t;
    EXPECT_NEAR(bond_angle_deg(3.0 * n, 0.25 * ex), t, 1e-12) << t;  // scale and order free
  }
  // Near 0 and 180, where acos(dot) would return exactly 0 or 180.
  const double eps = 1e-8;  // radians
  EXPECT_NEAR(bond_angle_deg(ex, Vec3(std::cos(eps), std::sin(eps), 0)), eps * 180.0 / kPi, 1e-20);
  EXPECT_NEAR(bond_angle_deg(ex, Vec3(-std::cos(eps), std::sin(eps), 0)), 180.0 - eps * 180.0 / kPi, 1e-12);
  EXPECT_LT(bond_angle_deg(ex, Vec3(-std::cos(eps), std::sin(eps), 0)), 180.0);
}

TEST(BondRules, SquareRingHasRightAnglesAndCisDihedrals) {
  const double s = 6.0;  // l_L + 2 r_S
  const std::vector<Vec3> corners = {Vec3(0, 0, 0), Vec3(s, 0, 0), Vec3(s, s, 0), Vec3(0, s, 0)};
  // Every orientation of the four linker axes: the measures must not care.
  for (int mask = 0; mask < 16; ++mask) {
    const std::vector<bool> fwd = {bool(mask & 1), bool(mask & 2), bool(mask & 4), bool(mask & 8)};
    const auto ring = build_chain(corners, fwd, true);
    for (std::size_t i = 0; i < 4; ++i) {
      EXPECT_NEAR(angle_at_joint(ring, i), 90.0, 1e-12) << mask << " " << i;
      const auto phi = dihedral_about(ring, i);
      ASSERT_TRUE(phi.has_value());
      EXPECT_NEAR(*phi, 0.0, 1e-12) << mask << " " << i;
      EXPECT_TRUE(angle_ok(angle_at_joint(ring, i), defaults()));
      EXPECT_TRUE(planarity_ok(phi, defaults()));
    }
  }
}

TEST(BondRules, RotatedSquareKeepsItsAngles) {
  const Quat q = Quat(Eigen::AngleAxisd(0.7, Vec3(1.0, 2.0, -0.5).normalized()));
  const double s = 6.0;
  std::vector<Vec3> corners = {Vec3(0, 0, 0), Vec3(s, 0, 0), Vec3(s, s, 0), Vec3(0, s, 0)};
  for (Vec3& c : corners) c = q * c + Vec3(10, 20, 30);
  const auto ring = build_chain(corners, {true, false, true, true}, true);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_NEAR(angle_at_joint(ring, i), 90.0, 1e-12);
    EXPECT_NEAR(*dihedral_about(ring, i), 0.0, 1e-12);
  }
}

TEST(BondRules, PlanarZigzagIsTrans) {
  // S-L-S-L-S-L-S-L-S with right-angle corners turning alternately.
  const double s = 6.0;
  const std::vector<Vec3> spheres = {Vec3(0, 0, 0), Vec3(s, 0, 0), Vec3(s, s, 0), Vec3(2 * s, s, 0),
                                     Vec3(2 * s, 2 * s, 0)};
  for (int mask = 0; mask < 16; ++mask) {
    const std::vector<bool> fwd = {bool(mask & 1), bool(mask & 2), bool(mask & 4), bool(mask & 8)};
    const auto chain = build_chain(spheres, fwd, false);
    for (std::size_t i = 0; i + 1 < chain.size(); ++i) EXPECT_NEAR(angle_at_joint(chain, i), 90.0, 1e-12);
    for (std::size_t i = 1; i + 1 < chain.size(); ++i) {
      const auto phi = dihedral_about(chain, i);
      ASSERT_TRUE(phi.has_value());
      EXPECT_EQ(*phi, 180.0) << mask << " " << i;  // exactly: (-180, 180]
      EXPECT_TRUE(planarity_ok(phi, defaults()));
    }
  }
}

TEST(BondRules, TwistedChainsGiveTheirTwist) {
  // Linker along +x; neighbour at end 0 along +y; neighbour at end 1 turned by
  // psi about +x (counter-clockwise positive). Axial components of the
  // neighbours (bond angles other than 90) must not matter.
  const Vec3 u(1, 0, 0);
  for (double psi = -175.0; psi <= 180.0; psi += 5.0) {
    const Vec3 n0(0.3, 1.0, 0.0);
    const Vec3 n1(-0.7, std::cos(rad(psi)), std::sin(rad(psi)));
    const auto phi = dihedral_deg(u, n0, n1);
    ASSERT_TRUE(phi.has_value());
    EXPECT_NEAR(*phi, psi, 1e-12) << psi;
    // Relabelling the linker (u -> -u, ends swapped) gives the same dihedral.
    EXPECT_NEAR(*dihedral_deg(Vec3(-u), n1, n0), psi, 1e-12) << psi;
    // Non-unit axis and neighbours.
    EXPECT_NEAR(*dihedral_deg(2.5 * u, 4.0 * n0, 0.1 * n1), psi, 1e-12) << psi;
    // A mirror image has the opposite twist.
    const Vec3 m(1, 1, -1);  // reflection z -> -z
    const double mirrored = *dihedral_deg(u, n0.cwiseProduct(m), n1.cwiseProduct(m));
    if (std::abs(psi) < 180.0) {
      EXPECT_NEAR(mirrored, -psi, 1e-12) << psi;
    }
  }
  // The same twists built from whole chains of spheres: sphere 0 above the
  // middle linker, sphere 3 turned by psi.
  for (double psi : {0.0, 30.0, -60.0, 90.0, 135.0, 180.0}) {
    const double s = 6.0;
    const std::vector<Vec3> spheres = {Vec3(0, s, 0), Vec3(0, 0, 0), Vec3(s, 0, 0),
                                       Vec3(s, s * std::cos(rad(psi)), s * std::sin(rad(psi)))};
    for (int mask = 0; mask < 8; ++mask) {
      const auto chain = build_chain(spheres, {bool(mask & 1), bool(mask & 2), bool(mask & 4)}, false);
      EXPECT_NEAR(angle_at_joint(chain, 0), 90.0, 1e-12);
      EXPECT_NEAR(angle_at_joint(chain, 1), 90.0, 1e-12);
      // Along +x (sphere 1 -> 2) the far neighbour is turned by psi from the
      // near one. With u = +x end 0 faces sphere 2, so n0 is the far
      // neighbour and phi (from n0 to n1) is -psi; with u = -x, n0 is the
      // near one and the turn about -x is again -psi: the orientation of the
      // middle linker's axis does not matter.
      const double expected = -psi;
      const double got = *dihedral_about(chain, 1);
      if (std::abs(psi) == 180.0) {
        EXPECT_NEAR(std::abs(got), 180.0, 1e-12);
      } else {
        EXPECT_NEAR(got, expected, 1e-12) << psi << " " << mask;
      }
    }
  }
}

TEST(BondRules, DihedralRangeExcludesMinus180) {
  // Exact trans poses, with every sign of the zero sine, give +180.
  for (const Vec3& u : {Vec3(1, 0, 0), Vec3(-1, 0, 0), Vec3(0, 0, 1), Vec3(0, -1, 0)}) {
    for (const Vec3& n : {Vec3(0, 1, 0), Vec3(0, 0, -1), Vec3(1, 0, 0), Vec3(-1, 0, 0)}) {
      const auto phi = dihedral_deg(u, n, Vec3(-n));
      if (!phi) continue;  // n parallel to u
      EXPECT_EQ(*phi, 180.0);
    }
  }
}

// ---- degenerate projections -----------------------------------------------------

TEST(BondRules, DegenerateDihedralIsUndefinedAndFailsTheRule) {
  const Vec3 u(0, 0, 1);
  const Vec3 n(1, 0, 0);
  EXPECT_FALSE(dihedral_deg(u, u, n).has_value());             // neighbour parallel to the axis
  EXPECT_FALSE(dihedral_deg(u, n, Vec3(-u)).has_value());      // antiparallel
  EXPECT_FALSE(dihedral_deg(u, 5.0 * u, 5.0 * u).has_value());  // both
  EXPECT_FALSE(dihedral_deg(u, Vec3(1e-13, 0, 1), n).has_value());  // |projection| < 1e-12
  EXPECT_FALSE(dihedral_deg(u, n, Vec3(0, -1e-13, -1)).has_value());
  EXPECT_FALSE(dihedral_deg(u, Vec3(0, 0, 0), n).has_value());  // no neighbour direction at all
  // Just above the threshold the dihedral is defined (here: 90).
  const auto phi = dihedral_deg(u, Vec3(1e-10, 0, 1), Vec3(0, 1, 0));
  ASSERT_TRUE(phi.has_value());
  EXPECT_NEAR(*phi, 90.0, 1e-9);

  // The rule fails in both modes, whatever the tolerance, when the filter is on.
  BondingParams b;
  for (CoplanarityMode mode : {CoplanarityMode::CisOrTrans, CoplanarityMode::Cis}) {
    b.coplanarity_mode = mode;
    for (double dphi : {0.0, 5.0, 90.0}) {
      b.dphi_deg = dphi;
      b.coplanarity_filter = true;
      EXPECT_FALSE(planarity_ok(std::nullopt, b));
      EXPECT_FALSE(planarity_ok(dihedral_deg(u, u, n), b));
      b.coplanarity_filter = false;
      EXPECT_TRUE(planarity_ok(std::nullopt, b));
    }
  }
}

// ---- rule 2: bond angle -------------------------------------------------------------

TEST(BondRules, AngleToleranceBoundaries) {
  BondingParams b;  // 90 +- 5, filter on
  EXPECT_TRUE(angle_ok(90.0, b));
  EXPECT_TRUE(angle_ok(95.0, b));
  EXPECT_TRUE(angle_ok(85.0, b));
  EXPECT_TRUE(angle_ok(95.0 - 1e-9, b));
  EXPECT_TRUE(angle_ok(85.0 + 1e-9, b));
  EXPECT_FALSE(angle_ok(95.0 + 1e-9, b));
  EXPECT_FALSE(angle_ok(85.0 - 1e-9, b));
  EXPECT_FALSE(angle_ok(180.0, b));
  EXPECT_FALSE(angle_ok(0.0, b));

  // Poses built at the boundary (their computed angle carries rounding).
  const Vec3 ex(1, 0, 0);
  auto at = [&](double t) { return bond_angle_deg(ex, Vec3(std::cos(rad(t)), std::sin(rad(t)), 0)); };
  EXPECT_TRUE(angle_ok(at(95.0), b));
  EXPECT_TRUE(angle_ok(at(85.0), b));
  EXPECT_TRUE(angle_ok(at(95.0 - 1e-9), b));
  EXPECT_FALSE(angle_ok(at(95.0 + 1e-9), b));
  EXPECT_FALSE(angle_ok(at(85.0 - 1e-9), b));

  // Other targets, including a zero half-width and the ends of the range.
  b.theta0_deg = 120.0;
  b.dtheta_deg = 0.0;
  EXPECT_TRUE(angle_ok(at(120.0), b));
  EXPECT_FALSE(angle_ok(at(120.0 + 1e-9), b));
  EXPECT_FALSE(angle_ok(at(120.0 - 1e-9), b));
  b.theta0_deg = 180.0;
  b.dtheta_deg = 1.0;
  EXPECT_TRUE(angle_ok(bond_angle_deg(ex, Vec3(-ex)), b));
  EXPECT_TRUE(angle_ok(at(179.0), b));
  EXPECT_FALSE(angle_ok(at(179.0 - 1e-9), b));
  b.theta0_deg = 90.0;
  b.dtheta_deg = 180.0;  // accepts every angle
  for (double t = 0.0; t <= 180.0; t += 15.0) EXPECT_TRUE(angle_ok(at(t), b));
}

TEST(BondRules, AngleFilterOff) {
  BondingParams b;
  b.angle_filter = false;
  for (double t : {0.0, 45.0, 84.0, 90.0, 96.0, 180.0}) EXPECT_TRUE(angle_ok(t, b)) << t;
  b.angle_filter = true;
  EXPECT_FALSE(angle_ok(45.0, b));
}

// ---- rule 3: coplanarity ------------------------------------------------------------

TEST(BondRules, PlanarityDeviationByMode) {
  EXPECT_EQ(planarity_deviation_deg(0.0, CoplanarityMode::CisOrTrans), 0.0);
  EXPECT_EQ(planarity_deviation_deg(180.0, CoplanarityMode::CisOrTrans), 0.0);
  EXPECT_EQ(planarity_deviation_deg(90.0, CoplanarityMode::CisOrTrans), 90.0);
  EXPECT_EQ(planarity_deviation_deg(-90.0, CoplanarityMode::CisOrTrans), 90.0);
  EXPECT_EQ(planarity_deviation_deg(170.0, CoplanarityMode::CisOrTrans), 10.0);
  EXPECT_EQ(planarity_deviation_deg(-170.0, CoplanarityMode::CisOrTrans), 10.0);
  EXPECT_EQ(planarity_deviation_deg(-3.0, CoplanarityMode::CisOrTrans), 3.0);
  EXPECT_EQ(planarity_deviation_deg(0.0, CoplanarityMode::Cis), 0.0);
  EXPECT_EQ(planarity_deviation_deg(180.0, CoplanarityMode::Cis), 180.0);
  EXPECT_EQ(planarity_deviation_deg(-170.0, CoplanarityMode::Cis), 170.0);
  EXPECT_EQ(planarity_deviation_deg(-3.0, CoplanarityMode::Cis), 3.0);
}

TEST(BondRules, CisAndTransInBothModes) {
  BondingParams b;  // +- 5 degrees, filter on
  const Vec3 u(1, 0, 0), n0(0, 1, 0);
  auto twisted = [&](double psi) { return dihedral_deg(u, n0, Vec3(0, std::cos(rad(psi)), std::sin(rad(psi)))); };

  b.coplanarity_mode = CoplanarityMode::CisOrTrans;
  for (double psi : {0.0, 5.0, -5.0, 175.0, -175.0, 180.0, 5.0 - 1e-9, -175.0 - 1e-9, 175.0 + 1e-9}) {
    EXPECT_TRUE(planarity_ok(twisted(psi), b)) << psi;
  }
  for (double psi : {5.0 + 1e-9, -5.0 - 1e-9, 175.0 - 1e-9, -175.0 + 1e-9, 90.0, -90.0, 45.0, 135.0}) {
    EXPECT_FALSE(planarity_ok(twisted(psi), b)) << psi;
  }

  b.coplanarity_mode = CoplanarityMode::Cis;
  for (double psi : {0.0, 5.0, -5.0, 5.0 - 1e-9, -5.0 + 1e-9}) EXPECT_TRUE(planarity_ok(twisted(psi), b)) << psi;
  for (double psi : {180.0, 175.0, -175.0, 5.0 + 1e-9, -5.0 - 1e-9, 90.0}) {
    EXPECT_FALSE(planarity_ok(twisted(psi), b)) << psi;
  }

  // Whole poses: the square (cis) passes both modes, the zigzag (trans) only
  // cis-or-trans.
  const double s = 6.0;
  const auto ring = build_chain({Vec3(0, 0, 0), Vec3(s, 0, 0), Vec3(s, s, 0), Vec3(0, s, 0)},
                                {true, true, false, true}, true);
  const auto zig = build_chain({Vec3(0, 0, 0), Vec3(s, 0, 0), Vec3(s, s, 0), Vec3(2 * s, s, 0)},
                               {true, false, true}, false);
  b.coplanarity_mode = CoplanarityMode::CisOrTrans;
  EXPECT_TRUE(planarity_ok(dihedral_about(ring, 2), b));
  EXPECT_TRUE(planarity_ok(dihedral_about(zig, 1), b));
  b.coplanarity_mode = CoplanarityMode::Cis;
  EXPECT_TRUE(planarity_ok(dihedral_about(ring, 2), b));
  EXPECT_FALSE(planarity_ok(dihedral_about(zig, 1), b));
}

TEST(BondRules, PlanarityToleranceBoundariesAndWidths) {
  BondingParams b;
  b.dphi_deg = 0.0;  // exact planarity only
  EXPECT_TRUE(planarity_ok(0.0, b));
  EXPECT_TRUE(planarity_ok(180.0, b));
  EXPECT_FALSE(planarity_ok(1e-9, b));
  EXPECT_FALSE(planarity_ok(180.0 - 1e-9, b));
  b.dphi_deg = 90.0;  // cis-or-trans at its widest accepts every defined dihedral
  for (double phi = -179.0; phi <= 180.0; phi += 1.0) EXPECT_TRUE(planarity_ok(phi, b)) << phi;
  b.coplanarity_mode = CoplanarityMode::Cis;  // cis at 90 accepts only the cis half
  EXPECT_TRUE(planarity_ok(90.0, b));
  EXPECT_TRUE(planarity_ok(-90.0, b));
  EXPECT_FALSE(planarity_ok(90.0 + 1e-9, b));
  EXPECT_FALSE(planarity_ok(180.0, b));
}

TEST(BondRules, CoplanarityFilterOff) {
  BondingParams b;
  b.coplanarity_filter = false;
  for (CoplanarityMode mode : {CoplanarityMode::CisOrTrans, CoplanarityMode::Cis}) {
    b.coplanarity_mode = mode;
    for (double phi : {0.0, 45.0, -90.0, 135.0, 180.0}) EXPECT_TRUE(planarity_ok(phi, b)) << phi;
  }
  b.coplanarity_filter = true;
  EXPECT_FALSE(planarity_ok(45.0, b));
}

TEST(BondRules, DefaultsAreScenarioFour) {
  const BondingParams b;
  EXPECT_TRUE(b.enabled);
  EXPECT_TRUE(b.angle_filter);
  EXPECT_TRUE(b.coplanarity_filter);
  EXPECT_EQ(b.theta0_deg, 90.0);
  EXPECT_EQ(b.dtheta_deg, 5.0);
  EXPECT_EQ(b.dphi_deg, 5.0);
  EXPECT_EQ(b.coplanarity_mode, CoplanarityMode::CisOrTrans);
}

}  // namespace
}  // namespace ringsim
