#pragma once
// Hand-built compliant chains for tests and benchmarks (tests/test_compliant.cpp,
// bench/bench_compliant.cpp): spheres and linkers alternating along a polyline,
// optionally perturbed from the target pose, with random velocities.

#include <cmath>
#include <cstdint>
#include <vector>

#include "core/compliant.hpp"
#include "core/params.hpp"
#include "core/scene.hpp"

namespace ringsim {
namespace test {

// Scenario 5's bond constants (MODEL.md, "Scenarios"; jobs/scenarios/5-compliant.toml).
inline CompliantParams scenario5_compliant() {
  CompliantParams p;
  p.k = p.k_omega = 1000.0;
  p.c = p.c_omega = 100.0;
  return p;
}

// The whole Scenario 5 (the defaults are Scenario 4: both filters, 300 + 300)
// run to t_max without the steady-state stop.
inline SimParams scenario5_scene(double t_max) {
  SimParams p;
  p.compliant = scenario5_compliant();
  p.run.t_max = t_max;
  p.run.steady_state = false;
  return p;
}

// Small deterministic generator (splitmix64): uniform in [-1, 1).
class Jitter {
 public:
  explicit Jitter(std::uint64_t seed) : s_(seed) {}
  double next() {
    std::uint64_t z = (s_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    return 2.0 * static_cast<double>(z >> 11) * 0x1.0p-53 - 1.0;
  }
  Vec3 vec() {
    const double a = next(), b = next(), c = next();
    return Vec3(a, b, c);
  }

 private:
  std::uint64_t s_;
};

struct ChainSetup {
  double dx = 0.0;         // each position component moved by up to dx
  double drot_deg = 0.0;   // each linker turned by up to drot_deg about a random axis
  double v = 0.0;          // each velocity component up to v
  double omega = 0.0;      // each linker angular velocity component up to omega
  std::uint64_t seed = 1;
};

// Open chain S0 L0 S1 L1 ... S_{m-1} L_{m-1} through the points P_0 .. P_m
// (spheres at P_0 .. P_{m-1}; linker i between P_i and P_{i+1}, its axis
// pointing from P_i to P_{i+1}, so end 1 faces sphere i and end 0 faces the
// next sphere, or P_m, the free end, for the last linker). The points must be
// spaced by the target sphere-to-sphere distance 2 (h + r_S + target_gap).
// Bodies are listed along the backbone (banded Jacobian). Bonds are added in
// chain order, so each dihedral's target is taken from the (perturbed) pose.
inline CompliantCluster make_chain(const std::vector<Vec3>& points, const CompliantParams& cp,
                                   const BondingParams& bp, const ChainSetup& setup) {
  SimParams p;
  const Species sphere = make_species(Shape::Sphere, p);
  const Species linker = make_species(Shape::Linker, p);
  Jitter rng(setup.seed);
  CompliantCluster c;
  c.params = cp;
  const int m = static_cast<int>(points.size()) - 1;
  for (int i = 0; i < m; ++i) {
    c.bodies.push_back(make_compliant_body(sphere, points[i] + setup.dx * rng.vec(), setup.v * rng.vec(),
                                           Vec3::UnitZ(), Vec3::Zero()));
    const Vec3 d = (points[i + 1] - points[i]).normalized();
    CompliantBody l = make_compliant_body(linker, 0.5 * (points[i] + points[i + 1]) + setup.dx * rng.vec(),
                                          setup.v * rng.vec(), d, setup.omega * rng.vec());
    const Vec3 axis = rng.vec();
    const double angle = setup.drot_deg * 3.14159265358979323846 / 180.0 * rng.next();
    if (axis.norm() > 1e-3) l.q = (Eigen::AngleAxisd(angle, axis.normalized()) * l.q).normalized();
    c.bodies.push_back(l);
  }
  for (int i = 0; i < m; ++i) {
    const int s = 2 * i, l = 2 * i + 1;
    if (i > 0) add_compliant_bond(c, s, l - 2, 0, bp);
    add_compliant_bond(c, s, l, 1, bp);
  }
  return c;
}

// The four-corner open chain S-L-S-L-S-L-S-L of a square ring with one bond
// missing: the last linker's free end (end 0) faces the first sphere.
inline CompliantCluster four_corner_chain(const CompliantParams& cp, const BondingParams& bp, const ChainSetup& setup) {
  SimParams p;
  const double side = 2.0 * (0.5 * p.geometry.linker_length + p.geometry.sphere_radius + cp.target_gap);
  const std::vector<Vec3> pts = {Vec3(0, 0, 0), Vec3(side, 0, 0), Vec3(side, side, 0), Vec3(0, side, 0),
                                 Vec3(0, 0, 0)};
  return make_chain(pts, cp, bp, setup);
}

// A planar staircase of `corners` right-angle corners alternating left and
// right turns (trans dihedrals), for long banded chains.
inline CompliantCluster staircase_chain(int corners, const CompliantParams& cp, const BondingParams& bp,
                                        const ChainSetup& setup) {
  SimParams p;
  const double side = 2.0 * (0.5 * p.geometry.linker_length + p.geometry.sphere_radius + cp.target_gap);
  std::vector<Vec3> pts = {Vec3::Zero()};
  for (int i = 0; i < corners + 1; ++i) pts.push_back(pts.back() + side * (i % 2 == 0 ? Vec3::UnitX() : Vec3::UnitY()));
  return make_chain(pts, cp, bp, setup);
}

}  // namespace test
}  // namespace ringsim
