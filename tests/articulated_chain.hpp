#pragma once
// Hand-built articulated clusters for tests (tests/test_joints.cpp,
// tests/test_articulated.cpp): spheres and linkers at the study's default
// sizes, posed by hand, with joints that hold the pose they are built in
// (core/joints.hpp). Anchors are off the linkers' axes unless asked otherwise
// (a capture anywhere on the end face, MODEL.md).

#include <cmath>
#include <vector>

#include "compliant_chain.hpp"
#include "core/compliant.hpp"
#include "core/constrained_dynamics.hpp"
#include "core/joints.hpp"
#include "core/scene.hpp"

namespace ringsim {
namespace test {

struct Articulated {
  CompliantCluster cluster;  // params all zero: no force field
  JointSet joints;
  std::vector<CompliantBody>& bodies() { return cluster.bodies; }
};

inline Species sphere_species() { return make_species(Shape::Sphere, SimParams{}); }
inline Species linker_species() { return make_species(Shape::Linker, SimParams{}); }

// A linker centred at x with unit axis u, turned by `roll` radians about it.
inline CompliantBody linker_at(const Vec3& x, const Vec3& u, double roll = 0.0) {
  CompliantBody b = make_compliant_body(linker_species(), x, Vec3::Zero(), u, Vec3::Zero());
  b.q = (Eigen::AngleAxisd(roll, u.normalized()) * b.q).normalized();
  return b;
}
inline CompliantBody sphere_at(const Vec3& x) {
  return make_compliant_body(sphere_species(), x, Vec3::Zero(), Vec3::UnitZ(), Vec3::Zero());
}

// Distance from a linker's centre to the centre of a sphere touching its end face.
inline double reach() {
  const Species s = sphere_species(), l = linker_species();
  return l.half_length + s.radius;
}

// A unit vector perpendicular to u.
inline Vec3 perpendicular(const Vec3& u) {
  const Vec3 t = std::abs(u.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  return u.cross(t).normalized();
}

// Random velocities (each component up to v, omega) on every body.
inline void jitter_velocities(CompliantCluster& c, double v, double omega, std::uint64_t seed) {
  Jitter rng(seed);
  for (CompliantBody& b : c.bodies) {
    b.v = v * rng.vec();
    if (b.shape == Shape::Linker) b.omega = omega * rng.vec();
  }
}

// L0 - S - L1 around the sphere at the origin (bodies: L0, S, L1). L0's end 0
// faces the sphere along -na, L1's end 1 along -nb (na, nb the outward axes,
// their angle theta), the sphere off each axis by `off`.
inline Articulated lsl(double theta, double off, bool hold_angle) {
  Articulated a;
  const Vec3 na = Vec3(-1, 0, 0);
  const Vec3 nb = Vec3(-std::cos(theta), std::sin(theta), 0.0);
  const Vec3 ua = -na, ub = nb;  // end 0's outward axis is -u, end 1's +u
  a.cluster.bodies = {linker_at(-reach() * ua + off * Vec3(0, 0.6, 0.8), ua, 0.3), sphere_at(Vec3::Zero()),
                      linker_at(reach() * ub + off * Vec3(0.48, 0.64, 0.6).normalized(), ub, -0.7)};
  a.joints.balls = {make_ball_joint(a.bodies(), 1, 0), make_ball_joint(a.bodies(), 1, 2)};
  if (hold_angle) a.joints.angles = {make_held_angle(a.bodies(), 1, 0, 0, 2, 1)};
  return a;
}

// Closed square ring S0 L0 S1 L1 S2 L2 S3 L3 (bodies in that order): sphere i
// at corner P_i, linker i from P_i to P_{i+1} (end 1 at sphere i, end 0 at
// sphere i + 1). `off` moves every linker off its side and tilts it, so that
// no anchor is on an axis; off = 0 puts every anchor on its linker's axis.
inline Articulated square(double off, bool angles, bool dihedrals) {
  Articulated a;
  const double s = 2.0 * reach();
  const Vec3 p[4] = {Vec3(0, 0, 0), Vec3(s, 0, 0), Vec3(s, s, 0), Vec3(0, s, 0)};
  Jitter rng(11);
  for (int i = 0; i < 4; ++i) {
    a.cluster.bodies.push_back(sphere_at(p[i]));
    const Vec3 d = (p[(i + 1) % 4] - p[i]).normalized();
    const Vec3 u = (d + off * 0.3 * rng.vec()).normalized();
    a.cluster.bodies.push_back(linker_at(0.5 * (p[i] + p[(i + 1) % 4]) + off * rng.vec(), u, rng.next()));
  }
  for (int i = 0; i < 4; ++i) {
    const int S = 2 * i, L = 2 * i + 1, prev = (2 * i + 7) % 8, next = (2 * i + 3) % 8;
    a.joints.balls.push_back(make_ball_joint(a.bodies(), S, L));
    a.joints.balls.push_back(make_ball_joint(a.bodies(), (S + 2) % 8, L));
    if (angles) a.joints.angles.push_back(make_held_angle(a.bodies(), S, prev, 0, L, 1));
    // About linker L: its end-0 neighbour is the next linker (at its end 1),
    // its end-1 neighbour the previous one (at its end 0).
    if (dihedrals) a.joints.dihedrals.push_back(make_held_dihedral(a.bodies(), L, next, 1, prev, 0));
  }
  return a;
}

// Open chain S0 L0 S1 L1 ... L_{m-1} of m corners along a square's sides
// (bodies in that order; the last linker's end 0 free), off-axis anchors,
// angles at the inner spheres and dihedrals about the linkers with cornered
// spheres at both ends when asked.
inline Articulated open_chain(int m, double off, bool angles, bool dihedrals) {
  Articulated a;
  const double s = 2.0 * reach();
  const Vec3 dir[4] = {Vec3::UnitX(), Vec3::UnitY(), -Vec3::UnitX(), -Vec3::UnitY()};
  Jitter rng(5);
  Vec3 p = Vec3::Zero();
  for (int i = 0; i < m; ++i) {
    const Vec3 d = dir[i % 4];
    a.cluster.bodies.push_back(sphere_at(p));
    const Vec3 u = (d + off * 0.3 * rng.vec()).normalized();
    a.cluster.bodies.push_back(linker_at(p + 0.5 * s * d + off * rng.vec(), u, rng.next()));
    p += s * d;
  }
  for (int i = 0; i < m; ++i) {
    const int S = 2 * i, L = 2 * i + 1;
    a.joints.balls.push_back(make_ball_joint(a.bodies(), S, L));
    if (i > 0) {
      a.joints.balls.push_back(make_ball_joint(a.bodies(), S, L - 2));
      if (angles) a.joints.angles.push_back(make_held_angle(a.bodies(), S, L - 2, 0, L, 1));
    }
  }
  if (dihedrals) {
    for (int i = 1; i + 1 < m; ++i) {
      const int L = 2 * i + 1;
      a.joints.dihedrals.push_back(make_held_dihedral(a.bodies(), L, L + 2, 1, L - 2, 0));
    }
  }
  return a;
}

// The hosted multiplier problem of a cluster (core/constrained_dynamics.hpp,
// HostedProblem) at its present state: G, the bias and the rows' body
// blocks, as the right-hand side builds them.
struct HostedRows {
  MassMatrix m;
  HostedProblem p;
  Eigen::MatrixXd g;
  Eigen::VectorXd bias;
  RowBlocks blocks;

  explicit HostedRows(const Articulated& a) : m(a.cluster.bodies), p(a.cluster.bodies, a.joints, m) {
    hosted_joint_rows(a.cluster.bodies, p.columns, a.joints, g, bias, &blocks);
  }
};

// The saddle-point matrix [M G^T; G 0] of a constrained problem in maximal
// coordinates, for the dense reference solves of the tests.
inline Eigen::MatrixXd kkt_matrix(const MassMatrix& m, const Eigen::MatrixXd& g) {
  const Eigen::Index n = m.layout.size, k = g.rows();
  Eigen::MatrixXd kkt = Eigen::MatrixXd::Zero(n + k, n + k);
  kkt.topLeftCorner(n, n) = m.dense();
  kkt.topRightCorner(n, k) = g.transpose();
  kkt.bottomLeftCorner(k, n) = g;
  return kkt;
}

}  // namespace test
}  // namespace ringsim
