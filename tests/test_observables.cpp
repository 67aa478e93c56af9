// The bond graph and the study's observables (MODEL.md, "Observables"):
// hand-built objects with hand-computed values, then a randomized cross-check
// of the incremental totals against the from-scratch reference.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/bond_graph.hpp"

namespace ringsim {
namespace {

// Builds objects bond by bond; times are 1, 2, 3, ... in bond order.
class Builder {
 public:
  Builder(int n_spheres, int n_linkers) : g(n_spheres, n_linkers), ns_(n_spheres) {}
  int L(int j) const { return ns_ + j; }  // body id of linker j

  // Sphere s to the first free end of linker j.
  void bond(int s, int j) {
    const int end = g.end_bonded(L(j), 0) ? 1 : 0;
    g.add_bond(s, L(j), end, ++t);
  }
  // Closed ring of m spheres s0..s0+m-1 and m linkers j0..j0+m-1:
  // s_i - l_i - s_{i+1}; the last bond, s_0 - l_{m-1}, closes it.
  void ring(int s0, int j0, int m) {
    for (int i = 0; i < m; ++i) {
      bond(s0 + i, j0 + i);
      bond(s0 + (i + 1) % m, j0 + i);
    }
  }
  // Open alternating chain; starts with a sphere when spheres >= linkers
  // (|spheres - linkers| <= 1): S L S L ... or L S L S ... .
  void chain(int s0, int spheres, int j0, int linkers) {
    // Walk along the chain; each step bonds the current sphere and linker and
    // moves past the vertex just left behind.
    bool at_sphere = spheres >= linkers;
    int s = s0, j = j0;
    for (int k = 0; k + 1 < spheres + linkers; ++k) {
      bond(s, j);
      if (at_sphere) {
        ++s;
      } else {
        ++j;
      }
      at_sphere = !at_sphere;
    }
  }

  BondGraph g;
  double t = 0.0;

 private:
  int ns_;
};

// Every hand-built graph must also agree with the reference.
void ExpectConsistent(const BondGraph& g) { EXPECT_EQ(g.validate(), ""); }

TEST(BondGraph, RejectsEmptyOrNegativeSizes) {
  EXPECT_THROW(BondGraph(0, 0), std::invalid_argument);
  EXPECT_THROW(BondGraph(-1, 3), std::invalid_argument);
  EXPECT_NO_THROW(BondGraph(1, 0));
}

TEST(Observables, MonomersOnly) {
  BondGraph g(3, 2);
  const Observables o = g.observables(10.0);
  EXPECT_EQ(o.N_t, 5);  // every body is its own object
  EXPECT_EQ(o.N_tar, 0);
  EXPECT_EQ(o.N_viab, 5);
  EXPECT_EQ(o.N_cyc, 0);
  EXPECT_EQ(o.n_nv1 + o.n_nv2 + o.n_nv3, 0);
  EXPECT_TRUE(o.rings.empty());
  EXPECT_DOUBLE_EQ(o.Phi_obj, 0.0);
  EXPECT_DOUBLE_EQ(o.Phi_viab, 1.0);
  EXPECT_FALSE(o.S4.has_value());
  EXPECT_DOUBLE_EQ(o.M_mono, 1.0);
  EXPECT_DOUBLE_EQ(o.M_mono_S, 3.0 / 5.0);
  EXPECT_DOUBLE_EQ(o.M_mono_L, 2.0 / 5.0);
  EXPECT_EQ(o.n_mono_S, 3);
  EXPECT_EQ(o.n_mono_L, 2);
  EXPECT_DOUBLE_EQ(o.tau_tar, 10.0);
  EXPECT_TRUE(o.tau_tar_censored);
  EXPECT_EQ(o.bonds, 0);
  EXPECT_EQ(g.free_sphere_slots(2), 6);
  EXPECT_EQ(g.free_ends(), 4);
}

TEST(Observables, OneBondLeavesThreeMonomers) {
  BondGraph g(3, 2);
  g.add_bond(0, 3, 0, 0.5);  // sphere 0 to end a of linker 0 (body 3)
  const Observables o = g.observables(1.0);
  EXPECT_EQ(o.N_t, 4);
  EXPECT_EQ(o.N_viab, 4);
  // Monomers: spheres 1, 2 and linker 1, over N_S + N_L = 5.
  EXPECT_DOUBLE_EQ(o.M_mono, 3.0 / 5.0);
  EXPECT_DOUBLE_EQ(o.M_mono_S, 2.0 / 5.0);
  EXPECT_DOUBLE_EQ(o.M_mono_L, 1.0 / 5.0);
  EXPECT_DOUBLE_EQ(o.M_mono_S + o.M_mono_L, o.M_mono);
  EXPECT_EQ(g.degree(0), 1);
  EXPECT_EQ(g.degree(3), 1);
  EXPECT_EQ(g.sphere_of(3, 0), 0);
  EXPECT_EQ(g.sphere_of(3, 1), -1);
  EXPECT_TRUE(g.end_bonded(3, 0));
  EXPECT_FALSE(g.end_bonded(3, 1));
  ASSERT_EQ(g.linkers_of(0).size(), 1u);
  EXPECT_EQ(g.linkers_of(0)[0].linker, 3);
  EXPECT_EQ(g.linkers_of(0)[0].end, 0);
  EXPECT_TRUE(g.same_component(0, 3));
  EXPECT_FALSE(g.same_component(0, 1));
  EXPECT_EQ(g.component_size(3), 2);
  EXPECT_EQ(g.free_sphere_slots(2), 5);
  EXPECT_EQ(g.free_ends(), 3);
  ExpectConsistent(g);
}

TEST(Observables, SquareIsTheTarget) {
  Builder b(4, 4);
  b.ring(0, 0, 4);  // 8 bonds at t = 1..8, the last closes the ring
  const Observables o = b.g.observables(100.0);
  EXPECT_EQ(o.N_t, 1);
  EXPECT_EQ(o.N_tar, 1);
  EXPECT_EQ(o.N_viab, 1);
  EXPECT_EQ(o.n_nv1 + o.n_nv2 + o.n_nv3, 0);
  EXPECT_EQ(o.rings, (std::map<int, int>{{4, 1}}));
  EXPECT_EQ(o.histogram.count(4), 1);
  EXPECT_EQ(o.N_cyc, 1);
  ASSERT_TRUE(o.S4.has_value());
  EXPECT_DOUBLE_EQ(*o.S4, 1.0);
  EXPECT_DOUBLE_EQ(o.Phi_obj, 1.0);
  EXPECT_DOUBLE_EQ(o.Phi_viab, 1.0);
  EXPECT_DOUBLE_EQ(o.M_mono, 0.0);
  EXPECT_DOUBLE_EQ(o.tau_tar, 8.0);
  EXPECT_FALSE(o.tau_tar_censored);
  EXPECT_EQ(o.bonds, 8);
  EXPECT_EQ(b.g.free_sphere_slots(2), 0);
  EXPECT_EQ(b.g.free_ends(), 0);
  ExpectConsistent(b.g);
}

TEST(Observables, TriangleIsANonViableRingOfThree) {
  Builder b(3, 3);
  b.ring(0, 0, 3);
  const Observables o = b.g.observables(50.0);
  EXPECT_EQ(o.N_t, 1);
  EXPECT_EQ(o.N_tar, 0);
  EXPECT_EQ(o.N_viab, 0);
  EXPECT_EQ(o.n_nv1, 0);
  EXPECT_EQ(o.n_nv2, 1);  // alternating length 6 != 8
  EXPECT_EQ(o.n_nv3, 0);
  EXPECT_EQ(o.rings, (std::map<int, int>{{3, 1}}));
  EXPECT_EQ(o.N_cyc, 1);
  ASSERT_TRUE(o.S4.has_value());  // defined (N_cyc = 1) and zero
  EXPECT_DOUBLE_EQ(*o.S4, 0.0);
  EXPECT_DOUBLE_EQ(o.Phi_viab, 0.0);
  EXPECT_DOUBLE_EQ(o.tau_tar, 50.0);
  EXPECT_TRUE(o.tau_tar_censored);
  ExpectConsistent(b.g);
}

TEST(Observables, HexagonIsNV2AndNV3) {
  Builder b(6, 6);
  b.ring(0, 0, 6);
  const Observables o = b.g.observables(1.0);
  EXPECT_EQ(o.N_t, 1);
  EXPECT_EQ(o.N_viab, 0);
  EXPECT_EQ(o.n_nv1, 0);
  EXPECT_EQ(o.n_nv2, 1);
  EXPECT_EQ(o.n_nv3, 1);  // 6 spheres and 6 linkers > 4
  EXPECT_EQ(o.rings, (std::map<int, int>{{6, 1}}));
  EXPECT_EQ(o.histogram.count(6), 1);
  EXPECT_EQ(o.N_cyc, 1);
  EXPECT_DOUBLE_EQ(*o.S4, 0.0);
  ExpectConsistent(b.g);
}

struct ChainCase {
  int spheres, linkers;
  bool viable;
};

TEST(Observables, OpenChainsAreViableUpToFourOfEach) {
  const ChainCase cases[] = {
      {1, 1, true},   // S-L
      {2, 1, true},   // S-L-S
      {1, 2, true},   // L-S-L
      {3, 3, true},   // S-L-S-L-S-L
      {4, 4, true},   // open square: viable, not a target
      {4, 3, true},   // S-L-S-L-S-L-S
      {3, 4, true},   // L-S-L-S-L-S-L
      {5, 4, false},  // 5 spheres: NV3
      {4, 5, false},  // 5 linkers: NV3
      {6, 6, false},  // NV3
  };
  for (const ChainCase& c : cases) {
    SCOPED_TRACE(::testing::Message() << c.spheres << " S, " << c.linkers << " L");
    Builder b(c.spheres, c.linkers);
    b.chain(0, c.spheres, 0, c.linkers);
    const Observables o = b.g.observables(1.0);
    EXPECT_EQ(o.bonds, c.spheres + c.linkers - 1);
    EXPECT_EQ(o.N_t, 1);
    EXPECT_EQ(o.N_tar, 0);
    EXPECT_EQ(o.N_viab, c.viable ? 1 : 0);
    EXPECT_EQ(o.n_nv1, 0);
    EXPECT_EQ(o.n_nv2, 0);
    EXPECT_EQ(o.n_nv3, c.viable ? 0 : 1);
    EXPECT_TRUE(o.rings.empty());
    EXPECT_FALSE(o.S4.has_value());
    for (int v = 0; v < b.g.n_bodies(); ++v) EXPECT_LE(b.g.degree(v), 2);
    ExpectConsistent(b.g);
  }
}

TEST(Observables, BranchedObjectsAreNV1) {
  {
    // Sphere 0 carries linkers 0, 1, 2 (sphere valency 3): degree 3.
    Builder b(1, 3);
    b.bond(0, 0);
    b.bond(0, 1);
    b.bond(0, 2);
    const Observables o = b.g.observables(1.0);
    EXPECT_EQ(b.g.degree(0), 3);
    EXPECT_EQ(o.N_t, 1);
    EXPECT_EQ(o.N_viab, 0);
    EXPECT_EQ(o.n_nv1, 1);
    EXPECT_EQ(o.n_nv2, 0);
    EXPECT_EQ(o.n_nv3, 0);
    EXPECT_EQ(b.g.free_sphere_slots(3), 0);
    EXPECT_EQ(b.g.free_sphere_slots(2), 0);  // a sphere above the valency counts 0
    EXPECT_EQ(b.g.free_sphere_slots(4), 1);
    EXPECT_EQ(b.g.free_ends(), 3);
    ExpectConsistent(b.g);
  }
  {
    // Star: sphere 0 with five linkers, sphere 1 on the far end of linker 0:
    // degree 5 (NV1) and 5 linkers (NV3).
    Builder b(2, 5);
    for (int j = 0; j < 5; ++j) b.bond(0, j);
    b.bond(1, 0);
    const Observables o = b.g.observables(1.0);
    EXPECT_EQ(o.N_t, 1);
    EXPECT_EQ(o.N_viab, 0);
    EXPECT_EQ(o.n_nv1, 1);
    EXPECT_EQ(o.n_nv2, 0);
    EXPECT_EQ(o.n_nv3, 1);
    ExpectConsistent(b.g);
  }
}

TEST(Observables, RingsOfTwoAndOneSphereAreNV2ButNotInNcyc) {
  {
    // s0 - l0 - s1 - l1 - s0: alternating length 4, m = 2.
    Builder b(2, 2);
    b.ring(0, 0, 2);
    const Observables o = b.g.observables(1.0);
    EXPECT_EQ(o.rings, (std::map<int, int>{{2, 1}}));
    EXPECT_EQ(o.histogram.small, 1);
    EXPECT_EQ(o.N_cyc, 0);
    EXPECT_FALSE(o.S4.has_value());  // undefined, not 0
    EXPECT_EQ(o.n_nv2, 1);
    EXPECT_EQ(o.N_viab, 0);
    ExpectConsistent(b.g);
  }
  {
    // One linker with both ends on one sphere: length 2, m = 1.
    Builder b(1, 1);
    b.ring(0, 0, 1);
    const Observables o = b.g.observables(1.0);
    EXPECT_EQ(o.rings, (std::map<int, int>{{1, 1}}));
    EXPECT_EQ(o.histogram.small, 1);
    EXPECT_EQ(o.N_cyc, 0);
    EXPECT_EQ(o.n_nv2, 1);
    EXPECT_EQ(b.g.degree(0), 2);
    ExpectConsistent(b.g);
  }
}

TEST(Observables, MixtureOfEveryKindOfObject) {
  // Spheres / linkers:
  //   triangle      S 4-6,   L 4-6     (built first: bonds t = 1..6)
  //   square        S 0-3,   L 0-3     (t = 7..14, closes at 14)
  //   hexagon       S 7-12,  L 7-12
  //   chain S-L-S   S 13,14, L 13
  //   branched      S 15 with L 14,15,16 (valency 3)
  //   chain 5S 4L   S 16-20, L 17-20
  //   ring m = 2    S 21,22, L 21,22
  //   monomers      S 23,24; L 23,24,25
  Builder b(25, 26);
  b.ring(4, 4, 3);
  b.ring(0, 0, 4);
  b.ring(7, 7, 6);
  b.chain(13, 2, 13, 1);
  b.bond(15, 14);
  b.bond(15, 15);
  b.bond(15, 16);
  b.chain(16, 5, 17, 4);
  b.ring(21, 21, 2);
  const Observables o = b.g.observables(1000.0);

  // 7 objects + 5 monomers.
  EXPECT_EQ(o.N_t, 12);
  EXPECT_EQ(o.N_tar, 1);
  // Viable: square, S-L-S chain, 5 monomers.
  EXPECT_EQ(o.N_viab, 7);
  EXPECT_EQ(o.n_nv1, 1);  // branched
  EXPECT_EQ(o.n_nv2, 3);  // triangle, hexagon, m = 2
  EXPECT_EQ(o.n_nv3, 2);  // hexagon, 5S 4L chain
  EXPECT_EQ(o.rings, (std::map<int, int>{{2, 1}, {3, 1}, {4, 1}, {6, 1}}));
  EXPECT_EQ(o.N_cyc, 3);
  ASSERT_TRUE(o.S4.has_value());
  EXPECT_DOUBLE_EQ(*o.S4, 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(o.Phi_obj, 1.0 / 12.0);
  EXPECT_DOUBLE_EQ(o.Phi_viab, 7.0 / 12.0);
  EXPECT_EQ(o.n_mono_S, 2);
  EXPECT_EQ(o.n_mono_L, 3);
  EXPECT_DOUBLE_EQ(o.M_mono, 5.0 / 51.0);
  EXPECT_DOUBLE_EQ(o.M_mono_S, 2.0 / 51.0);
  EXPECT_DOUBLE_EQ(o.M_mono_L, 3.0 / 51.0);
  EXPECT_DOUBLE_EQ(o.tau_tar, 14.0);
  EXPECT_FALSE(o.tau_tar_censored);
  // 6 + 8 + 12 + 2 + 3 + 8 + 4 bonds.
  EXPECT_EQ(o.bonds, 43);
  // Free ends: one on each branch linker (3) and both on L 23-25 (6).
  EXPECT_EQ(b.g.free_ends(), 9);
  // Sphere degrees: 18 of degree 2, S 13, 14, 16, 20 of degree 1, S 15 of
  // degree 3, S 23, 24 of degree 0. Valency 3: 18 + 4 * 2 + 2 * 3 = 32;
  // valency 2: 4 + 2 * 2 = 8.
  EXPECT_EQ(b.g.free_sphere_slots(3), 32);
  EXPECT_EQ(b.g.free_sphere_slots(2), 8);
  ExpectConsistent(b.g);
}

TEST(Observables, S4OnAMixOfRings) {
  // 3 squares, a triangle, a pentagon, a ring of 13 (overflow bin) and a
  // ring of 2 (not in N_cyc): S4 = 3 / (3 + 1 + 1 + 1) = 1/2.
  Builder b(35, 35);
  b.ring(0, 0, 4);
  b.ring(4, 4, 4);
  b.ring(8, 8, 4);
  b.ring(12, 12, 3);
  b.ring(15, 15, 5);
  b.ring(20, 20, 13);
  b.ring(33, 33, 2);
  const Observables o = b.g.observables(1.0);
  EXPECT_EQ(o.rings, (std::map<int, int>{{2, 1}, {3, 1}, {4, 3}, {5, 1}, {13, 1}}));
  EXPECT_EQ(o.histogram.count(4), 3);
  EXPECT_EQ(o.histogram.count(13), 0);  // beyond the binned range
  EXPECT_EQ(o.histogram.overflow, 1);
  EXPECT_EQ(o.histogram.small, 1);
  EXPECT_EQ(o.N_cyc, 6);
  ASSERT_TRUE(o.S4.has_value());
  EXPECT_DOUBLE_EQ(*o.S4, 0.5);
  EXPECT_EQ(o.N_t, 7);
  EXPECT_EQ(o.N_tar, 3);
  EXPECT_DOUBLE_EQ(o.Phi_obj, 3.0 / 7.0);
  EXPECT_EQ(o.N_viab, 3);
  EXPECT_EQ(o.n_nv2, 4);  // triangle, pentagon, 13, m = 2
  EXPECT_EQ(o.n_nv3, 2);  // pentagon, 13
  ExpectConsistent(b.g);
}

TEST(Observables, TauTarIsTheBondClosingTheFirstSquare) {
  // Square A: S 0-3, L 0-3; square B: S 4-7, L 4-7. Both left open, then B
  // closed at t = 20.5 and A at t = 30.
  BondGraph g(8, 8);
  const int L = 8;
  auto open_square = [&](int s0, int j0, double t0) {
    for (int i = 0; i < 4; ++i) {
      g.add_bond(s0 + i, L + j0 + i, 0, t0 + i);
      if (i < 3) g.add_bond(s0 + i + 1, L + j0 + i, 1, t0 + i + 0.5);
    }
  };
  open_square(0, 0, 1.0);
  open_square(4, 4, 10.0);
  EXPECT_EQ(g.N_tar(), 0);
  EXPECT_FALSE(g.first_target_time().has_value());
  EXPECT_TRUE(g.observables(19.0).tau_tar_censored);
  EXPECT_DOUBLE_EQ(g.observables(19.0).tau_tar, 19.0);

  g.add_bond(4, L + 7, 1, 20.5);  // closes B
  EXPECT_EQ(g.N_tar(), 1);
  EXPECT_DOUBLE_EQ(*g.first_target_time(), 20.5);
  g.add_bond(0, L + 3, 1, 30.0);  // closes A
  EXPECT_EQ(g.N_tar(), 2);
  const Observables o = g.observables(100.0);
  EXPECT_DOUBLE_EQ(o.tau_tar, 20.5);
  EXPECT_FALSE(o.tau_tar_censored);
  EXPECT_EQ(o.rings, (std::map<int, int>{{4, 2}}));
  ExpectConsistent(g);
}

TEST(Observables, TauTarCensoredWithoutTarget) {
  Builder b(7, 7);
  b.ring(0, 0, 3);
  b.chain(3, 4, 3, 4);  // open square
  const Observables o = b.g.observables(250.0);
  EXPECT_EQ(o.N_tar, 0);
  EXPECT_TRUE(o.tau_tar_censored);
  EXPECT_DOUBLE_EQ(o.tau_tar, 250.0);
  ExpectConsistent(b.g);
}

TEST(Observables, RunningTotalsOfNtAndNtar) {
  // Building a square: each of the first 7 bonds joins two objects
  // (8 -> 1), the 8th closes the ring inside one object.
  Builder b(4, 4);
  const int expected_nt[8] = {7, 6, 5, 4, 3, 2, 1, 1};
  const int expected_ntar[8] = {0, 0, 0, 0, 0, 0, 0, 1};
  EXPECT_EQ(b.g.N_t(), 8);
  int k = 0;
  for (int i = 0; i < 4; ++i) {
    for (int s : {i, (i + 1) % 4}) {
      b.bond(s, i);
      EXPECT_EQ(b.g.N_t(), expected_nt[k]) << "after bond " << k + 1;
      EXPECT_EQ(b.g.N_tar(), expected_ntar[k]) << "after bond " << k + 1;
      ++k;
    }
  }
  for (int v = 1; v < 8; ++v) EXPECT_EQ(b.g.component(v), b.g.component(0));
  EXPECT_EQ(b.g.component_size(5), 8);
}

TEST(Observables, ChordDestroysTheTargetAndClosesATriangle) {
  // Sphere valency 3. Square S 0-3, L 0-3 (target at t = 8), then linker 4
  // from S 0 to S 2: S 0 and S 2 reach degree 3, 5 linkers, and the chord
  // closes a ring whose shortest path S2-L1-S1-L0-S0-L4 has 5 edges: m = 3.
  Builder b(4, 5);
  b.ring(0, 0, 4);
  EXPECT_EQ(b.g.N_tar(), 1);
  b.bond(0, 4);
  EXPECT_EQ(b.g.N_tar(), 0);
  b.bond(2, 4);
  const Observables o = b.g.observables(100.0);
  EXPECT_EQ(o.N_t, 1);
  EXPECT_EQ(o.N_tar, 0);
  EXPECT_EQ(o.N_viab, 0);
  EXPECT_EQ(o.n_nv1, 1);
  EXPECT_EQ(o.n_nv2, 1);
  EXPECT_EQ(o.n_nv3, 1);
  EXPECT_EQ(o.rings, (std::map<int, int>{{3, 1}, {4, 1}}));
  EXPECT_DOUBLE_EQ(*o.S4, 0.5);
  EXPECT_DOUBLE_EQ(o.tau_tar, 8.0);  // the first target time survives its loss
  EXPECT_FALSE(o.tau_tar_censored);
  ExpectConsistent(b.g);
}

TEST(Observables, HighValencyRingsAreAShortestPathCycleBasis) {
  // Square A: S0 L0 S1 L1 S2 L2 S3 L3 (S0). Square B shares S0-L0-S1:
  // S1 L4 S4 L5 S5 L6 S0, closing with shortest path S0-L0-S1-L4-S4-L5-S5-L6
  // (7 edges, m = 4). The outer 12-cycle (m = 6) is not recorded (see the
  // header): NV1 (S0, S1 of degree 3) and NV3 (6 S, 7 L), but not NV2.
  Builder b(6, 7);
  b.ring(0, 0, 4);
  b.bond(1, 4);
  b.bond(4, 4);
  b.bond(4, 5);
  b.bond(5, 5);
  b.bond(5, 6);
  b.bond(0, 6);
  const Observables o = b.g.observables(100.0);
  EXPECT_EQ(o.rings, (std::map<int, int>{{4, 2}}));
  EXPECT_DOUBLE_EQ(*o.S4, 1.0);
  EXPECT_EQ(o.N_tar, 0);
  EXPECT_EQ(o.n_nv1, 1);
  EXPECT_EQ(o.n_nv2, 0);
  EXPECT_EQ(o.n_nv3, 1);
  EXPECT_EQ(o.N_viab, 0);
  // Recorded rings = cyclomatic number: 14 bonds - 13 vertices + 1 object.
  EXPECT_EQ(o.rings.at(4), o.bonds - b.g.n_bodies() + o.N_t);
  ExpectConsistent(b.g);
}

// Graph distances from vertex `from` through the public adjacency; -1 if unreachable.
std::vector<int> Distances(const BondGraph& g, int from) {
  std::vector<int> dist(g.n_bodies(), -1);
  std::vector<int> queue{from};
  dist[from] = 0;
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const int v = queue[head];
    std::vector<int> next;
    if (g.is_sphere(v)) {
      for (const BondedEnd& e : g.linkers_of(v)) next.push_back(e.linker);
    } else {
      for (int e = 0; e < 2; ++e) {
        if (g.end_bonded(v, e)) next.push_back(g.sphere_of(v, e));
      }
    }
    for (int w : next) {
      if (dist[w] < 0) {
        dist[w] = dist[v] + 1;
        queue.push_back(w);
      }
    }
  }
  return dist;
}

// How many sequences reached each kind of object (so the test cannot pass
// by never exercising them).
struct Coverage {
  int target = 0, ring = 0, branched = 0;
};

// Uniform in [0, 1) from the raw 64-bit output (the standard distributions
// differ between standard libraries).
double Uniform(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

// Random valid bond sequence up to saturation (no sphere below the valency or
// no free end). Each bond is, with probability about p_close / 2, one that
// closes a square if any exists, else, about p_close / 2, one that closes a
// ring of m >= 2 if any, else a uniform sphere below the valency with a
// uniform free end. Checks the incremental observables against the reference
// (after every bond if asked, else at the end) and the graph's invariants.
void RandomSequence(std::mt19937_64& rng, int ns, int nl, int valency, double p_close, bool check_every_bond,
                    Coverage* coverage) {
  BondGraph g(ns, nl);
  std::vector<Bond> log;
  double t = 0.0;
  for (;;) {
    std::vector<int> spheres;
    for (int s = 0; s < ns; ++s) {
      if (g.degree(s) < valency) spheres.push_back(s);
    }
    std::vector<std::pair<int, int>> ends;
    for (int l = ns; l < ns + nl; ++l) {
      for (int e = 0; e < 2; ++e) {
        if (!g.end_bonded(l, e)) ends.emplace_back(l, e);
      }
    }
    ASSERT_EQ(g.free_sphere_slots(valency) > 0, !spheres.empty());
    ASSERT_EQ(g.free_ends(), static_cast<int>(ends.size()));
    if (spheres.empty() || ends.empty()) break;
    // Pairs (sphere, free end) that would close a ring of m >= 2 spheres
    // (path of >= 3 bonds; m = 1 still comes from the uniform pick), and those
    // that would close a square (path of 7 bonds).
    struct Pair { int s, l, e; };
    std::vector<Pair> near, square;
    for (int s : spheres) {
      const std::vector<int> dist = Distances(g, s);
      for (const auto& [l, e] : ends) {
        if (dist[l] >= 3) near.push_back({s, l, e});
        if (dist[l] == 7) square.push_back({s, l, e});
      }
    }
    Pair pick;
    if (!square.empty() && Uniform(rng) < 0.5 * p_close) {
      pick = square[rng() % square.size()];
    } else if (!near.empty() && Uniform(rng) < 0.5 * p_close) {
      pick = near[rng() % near.size()];
    } else {
      const auto& end = ends[rng() % ends.size()];
      pick = {spheres[rng() % spheres.size()], end.first, end.second};
    }
    t += 0.25;
    g.add_bond(pick.s, pick.l, pick.e, t);
    log.push_back({pick.s, pick.l, pick.e, t});
    if (check_every_bond) {
      const std::string d = diff_observables(g.observables(t + 1.0), observables_from_scratch(ns, nl, log, t + 1.0));
      ASSERT_EQ(d, "") << "after bond " << log.size();
    }
  }
  const Observables o = g.observables(t + 1.0);
  ASSERT_EQ(diff_observables(o, observables_from_scratch(ns, nl, log, t + 1.0)), "");
  ASSERT_EQ(g.validate(), "");
  // Each bond either joins two objects or closes one ring.
  int recorded = 0;
  for (const auto& [m, c] : o.rings) recorded += c;
  ASSERT_EQ(recorded, o.bonds - (ns + nl) + o.N_t);
  ASSERT_EQ(g.bonds().size(), log.size());
  for (std::size_t k = 0; k < log.size(); ++k) {
    ASSERT_EQ(g.bonds()[k], std::make_pair(log[k].sphere, log[k].linker));
  }
  if (valency <= 2) {
    for (int v = 0; v < ns + nl; ++v) ASSERT_LE(g.degree(v), 2);
  }
  coverage->target += !o.tau_tar_censored;
  coverage->ring += o.N_cyc > 0;
  coverage->branched += o.n_nv1 > 0;
}

TEST(Observables, IncrementalMatchesReferenceOnRandomSequences) {
  // Small systems, every prefix of every sequence checked against the
  // reference; sequences run until no bond is possible.
  std::mt19937_64 rng(20240611);
  const int valencies[] = {1, 2, 2, 2, 3, 4, 8};
  Coverage coverage;
  for (int run = 0; run < 1000; ++run) {
    const int ns = 1 + static_cast<int>(rng() % 12);
    const int nl = std::max(1, ns - 2 + static_cast<int>(rng() % 5));  // near N_S, so targets can form
    const int valency = valencies[rng() % 7];
    const double p_close = 0.3 + 0.3 * (run % 3);  // 0.3, 0.6, 0.9
    SCOPED_TRACE(::testing::Message() << "run " << run << ": N_S " << ns << ", N_L " << nl << ", valency "
                                      << valency);
    RandomSequence(rng, ns, nl, valency, p_close, true, &coverage);
    if (HasFatalFailure()) return;
  }
  // With this seed: 63 sequences reach a target, 358 a ring with m >= 3,
  // 375 an NV1 object.
  EXPECT_GT(coverage.target, 30);
  EXPECT_GT(coverage.ring, 200);
  EXPECT_GT(coverage.branched, 100);
}

TEST(Observables, IncrementalMatchesReferenceOnLargeHighValencySystems) {
  // 80 + 80 bodies up to saturation, checked at the end (and by validate()).
  std::mt19937_64 rng(7);
  Coverage coverage;
  for (int run = 0; run < 20; ++run) {
    const int valency = 2 + run % 5;  // 2..6
    SCOPED_TRACE(::testing::Message() << "run " << run << ", valency " << valency);
    RandomSequence(rng, 80, 80, valency, 0.5, false, &coverage);
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(coverage.ring, 10);
  EXPECT_GT(coverage.target, 2);
  EXPECT_GT(coverage.branched, 10);
}

}  // namespace
}  // namespace ringsim
