// Checks of the peer's held dihedral (held_dihedral.hpp), run by ctest as
// peer_held_dihedral:
//  1. its three angular Jacobians against central differences of C, for
//     three linkers in random orientations turned along random angular
//     velocities, and their sum (zero: C is invariant under a common turn);
//  2. the row in Bullet's solver (HeldDihedralSolver), on a chain
//     L-S-L-S-L (neighbour, sphere, central linker, sphere, neighbour) on
//     ball joints, nothing else held, every body given a random velocity
//     and spin, collisions off, 20 time units at dt = 0.001:
//     - |C| stays below 1e-4, and phi within 0.01 degrees of phi0 wherever
//       both neighbours are at least sine 0.2 off M's axis (phi is measured
//       to |C| / (|u x n0| |u x n1|); this chain swings a neighbour through
//       M's axis, where phi is undefined and the row's zero set passes from
//       phi0 to phi0 + pi, as ringsim's does). Without the row phi wanders
//       by tens of degrees: checked, so the bound can fail;
//     - a free degree of freedom moves: the bond angle at a sphere changes
//       by more than 10 degrees;
//     - momentum within 1e-5 of its scale (the sum of the bodies' |m v|):
//       single-precision rounding over 20 000 steps (1e-15 in double);
//     - angular momentum (about the origin, spins included) within 1e-4 of
//       its scale (the sum of |x x m v| + |I omega|), on linkers with
//       isotropic inertia. Why isotropic: with a rod's inertia Bullet's
//       implicit gyroscopic step itself changes a tumbling body's angular
//       momentum, by 1e-4 of the scale here with or without the row (first
//       order in dt; printed). With isotropic inertia that term vanishes,
//       and what is left is rounding: positions in single precision
//       (x + v dt rounded at 6e-8 |x| per step, a random walk of ~1e-5 over
//       20 000 steps) and the ball joints' equal and opposite impulses acting
//       at pivots up to their drift apart (in Bullet's double build, where
//       rounding is gone, the whole drift is 2e-7). Without the row the
//       same chain drifts as much (printed). With the reaction on the
//       central linker left out (a two-body split) angular momentum is off
//       by 0.18 of its scale: checked, so the bound can fail;
//  3. a chain at rest turned 5 degrees off phi0 is pulled back (the sign of
//     the error term).
// Exit status 0 when every check passes; each failure is printed.
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <random>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "core/bond_rules.hpp"
#include "core/vec.hpp"
#include "held_dihedral.hpp"
#include "test_support.hpp"

namespace {

using ringsim::Vec3;
using ringsim::peer::HeldDihedralConstraint;
using ringsim::peer::HeldDihedralSolver;
using namespace ringsim::peer::test;

Vec3 to_vec(const btVector3& v) { return Vec3(double(v.x()), double(v.y()), double(v.z())); }
Vec3 axis_of(const btRigidBody& b) { return to_vec(b.getCenterOfMassTransform().getBasis().getColumn(2)).normalized(); }
Vec3 outward(const btRigidBody& b, int end) { return end == 0 ? Vec3(-axis_of(b)) : axis_of(b); }

void jacobian_check() {
  std::mt19937_64 rng(11);
  btCylinderShapeZ shape(btVector3(btScalar(0.25), btScalar(0.25), btScalar(1)));
  const bool single = sizeof(btScalar) == sizeof(float);
  const double h = single ? 1e-3 : 1e-6;
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  double worst = 0.0, worst_sum = 0.0;
  int used = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const btQuaternion qm = random_rotation(rng), qa = random_rotation(rng), qb = random_rotation(rng);
    auto m = linker(&shape, btVector3(0, 0, 0), qm);
    auto a = linker(&shape, btVector3(2, 0, 0), qa);
    auto b = linker(&shape, btVector3(-2, 0, 0), qb);
    HeldDihedralConstraint row(*m, *a, trial % 2, *b, (trial / 2) % 2, angle(rng));
    // Near a neighbour along M's axis the rules refuse the hold.
    if (axis_of(*m).cross(axis_of(*a)).norm() < 0.1 || axis_of(*m).cross(axis_of(*b)).norm() < 0.1) continue;
    ++used;
    const btVector3 wm = random_vector(rng), wa = random_vector(rng), wb = random_vector(rng);
    btVector3 jm, ja, jb;
    row.jacobian(jm, ja, jb);
    const double scale = std::max({double(jm.length()), double(ja.length()), double(jb.length())});
    worst_sum = std::max(worst_sum, double((jm + ja + jb).length()) / scale);
    const double analytic = double(jm.dot(wm) + ja.dot(wa) + jb.dot(wb));
    turn(*m, qm, btScalar(h) * wm);
    turn(*a, qa, btScalar(h) * wa);
    turn(*b, qb, btScalar(h) * wb);
    const double cp = row.residual();
    turn(*m, qm, btScalar(-h) * wm);
    turn(*a, qa, btScalar(-h) * wa);
    turn(*b, qb, btScalar(-h) * wb);
    const double cm = row.residual();
    const double fd = (cp - cm) / (2 * h);
    worst = std::max(worst, std::abs(fd - analytic) / std::max(1.0, std::abs(analytic)));
  }
  check(used >= 40, "Jacobian: random poses used", used);
  check(worst < (single ? 2e-3 : 1e-7), "Jacobian against central differences (largest relative error)", worst);
  check(worst_sum < (single ? 1e-6 : 1e-14), "|J_M + J_0 + J_1| / largest |J_k| (zero: C is rotation invariant)",
        worst_sum);
}

struct ChainRun {
  double worst_c = 0;          // largest |C|
  double worst_deg = 0;        // largest |phi - phi0| (to the row's zero set), degrees, where both sines >= 0.2
  double closest = 1;          // smallest max(|u x n0|, |u x n1|) (0: both neighbours along M's axis)
  double nearest_axis = 1;     // smallest min(|u x n0|, |u x n1|)
  double final_deg = 0;        // at the end
  double angle_moved_deg = 0;  // largest change of the bond angle at the end-0 sphere
  double dp = 0, dl = 0;       // largest |P - P(0)|, |L - L(0)| over the run
  double p_scale = 0, l_scale = 0;
};

// The chain nb0 - s0 - M - s1 - nb1: M along x (its end 0, at +x, on s0),
// nb0 on s0 by its end 1, nb1 on s1 by its end 0, bond angles of about 101
// and 95 degrees and a dihedral of about 42 degrees. held: the dihedral row
// is in the world; drop: a body whose reaction the row leaves out (-1 none);
// offset_deg: nb1 turned about M's axis after phi0 was taken; moving: random
// velocities and spins (seed 5), else at rest; isotropic: the linkers' three
// moments equal (0.35), else a rod's (0.35, 0.35, 0.1).
ChainRun chain(bool held, int drop, double offset_deg, bool moving, bool isotropic, double dt, double t_end) {
  HeldDihedralSolver solver;
  TestWorld w(solver);
  btDiscreteDynamicsWorld& world = w.world;
  btCylinderShapeZ* rod = &w.rod;
  const btVector3 z(0, 0, 1);
  const btVector3 xs0(btScalar(1.5), 0, 0), xs1(btScalar(-1.5), 0, 0);
  const btVector3 n0 = btVector3(btScalar(0.2), 1, 0).normalized();
  const btVector3 n1 = btVector3(btScalar(-0.1), btScalar(0.75), btScalar(0.67)).normalized();
  auto m = linker(rod, btVector3(0, 0, 0), shortestArcQuat(z, btVector3(1, 0, 0)));
  auto a = linker(rod, xs0 + btScalar(1.5) * n0, shortestArcQuat(z, n0));   // end 1 on s0: n0 = +u
  auto b = linker(rod, xs1 + btScalar(1.5) * n1, shortestArcQuat(z, -n1));  // end 0 on s1: n1 = -u
  auto s0 = sphere(&w.ball, xs0), s1 = sphere(&w.ball, xs1);
  const std::optional<double> phi_deg = ringsim::dihedral_deg(axis_of(*m), outward(*a, 1), outward(*b, 0));
  HeldDihedralConstraint row(*m, *a, 1, *b, 0, *phi_deg * M_PI / 180.0);
  row.drop_reaction_of(drop);
  if (offset_deg != 0) {
    // nb1 turned rigidly about the line through s1 along M's axis.
    const btQuaternion r(btVector3(1, 0, 0), btScalar(offset_deg * M_PI / 180.0));
    const btTransform about(r, btVector3(0, 0, 0));
    btTransform t = b->getWorldTransform();
    t.setOrigin(xs1 + about * (t.getOrigin() - xs1));
    t.setRotation(r * t.getRotation());
    b->setWorldTransform(t);
    b->setCenterOfMassTransform(t);
  }
  std::vector<btRigidBody*> bodies{s0.get(), s1.get(), m.get(), a.get(), b.get()};
  if (isotropic)
    for (btRigidBody* l : {m.get(), a.get(), b.get()}) {
      l->setMassProps(1, btVector3(btScalar(0.35), btScalar(0.35), btScalar(0.35)));
      l->updateInertiaTensor();
    }
  if (moving) {
    std::mt19937_64 rng(5);
    for (btRigidBody* body : bodies) {
      body->setLinearVelocity(btScalar(0.5) * random_vector(rng));
      body->setAngularVelocity(random_vector(rng));
    }
  }
  for (btRigidBody* body : bodies) world.addRigidBody(body, 1, 0);  // collides with nothing
  btPoint2PointConstraint j0m(*s0, *m, btVector3(0, 0, 0), btVector3(0, 0, btScalar(1.5)));
  btPoint2PointConstraint j1m(*s1, *m, btVector3(0, 0, 0), btVector3(0, 0, btScalar(-1.5)));
  btPoint2PointConstraint j0a(*s0, *a, btVector3(0, 0, 0), btVector3(0, 0, btScalar(-1.5)));
  btPoint2PointConstraint j1b(*s1, *b, btVector3(0, 0, 0), btVector3(0, 0, btScalar(1.5)));
  for (btTypedConstraint* c : {static_cast<btTypedConstraint*>(&j0m), static_cast<btTypedConstraint*>(&j1m),
                               static_cast<btTypedConstraint*>(&j0a), static_cast<btTypedConstraint*>(&j1b)})
    world.addConstraint(c, true);
  if (held) world.addConstraint(&row, false);

  // Momentum and angular momentum about the origin (spins included), and
  // their scales: the sums of the bodies' |m v| and |x x m v| + |I omega|.
  auto totals = [&](Vec3& p, Vec3& l, double& ps, double& ls) {
    p = l = Vec3::Zero();
    ps = ls = 0;
    for (const btRigidBody* body : bodies) {
      const double mass = 1.0 / double(body->getInvMass());
      const Vec3 x = to_vec(body->getCenterOfMassPosition()), v = to_vec(body->getLinearVelocity());
      const btMatrix3x3& basis = body->getWorldTransform().getBasis();
      const btVector3 inertia = body->getLocalInertia();
      const btVector3 w_body = basis.transpose() * body->getAngularVelocity();
      const Vec3 spin = to_vec(basis * btVector3(inertia.x() * w_body.x(), inertia.y() * w_body.y(),
                                                 inertia.z() * w_body.z()));
      p += mass * v;
      l += x.cross(mass * v) + spin;
      ps += mass * v.norm();
      ls += x.cross(mass * v).norm() + spin.norm();
    }
  };
  Vec3 p0, l0;
  ChainRun run;
  totals(p0, l0, run.p_scale, run.l_scale);
  run.p_scale = std::max(run.p_scale, 1.0);
  run.l_scale = std::max(run.l_scale, 1.0);
  auto bond_angle = [&] { return std::acos(std::clamp(outward(*m, 0).dot(outward(*a, 1)), -1.0, 1.0)) * 180 / M_PI; };
  const double theta_start = bond_angle();
  const int steps = static_cast<int>(std::lround(t_end / dt));
  for (int k = 0; k < steps; ++k) {
    world.stepSimulation(btScalar(dt), 0, btScalar(dt));
    Vec3 u, na, nb;
    row.axes(u, na, nb);
    const double sa = u.cross(na).norm(), sb = u.cross(nb).norm();
    run.closest = std::min(run.closest, std::max(sa, sb));
    run.nearest_axis = std::min(run.nearest_axis, std::min(sa, sb));
    run.worst_c = std::max(run.worst_c, std::abs(row.residual()));
    // phi is measured to |C| / (|u x n0| |u x n1|): near a neighbour along
    // M's axis it is undefined, and there it may flip to phi0 + pi
    // (dihedral_error is 0 there).
    run.worst_deg = std::max(run.worst_deg, row.dihedral_error() * 180 / M_PI);
    run.angle_moved_deg = std::max(run.angle_moved_deg, std::abs(bond_angle() - theta_start));
    Vec3 p, l;
    double ps, ls;
    totals(p, l, ps, ls);
    run.dp = std::max(run.dp, (p - p0).norm());
    run.dl = std::max(run.dl, (l - l0).norm());
  }
  run.final_deg = row.dihedral_error() * 180 / M_PI;
  if (solver.skipped_rows() != 0) check(false, "rows skipped by the solver", double(solver.skipped_rows()));
  if (held) world.removeConstraint(&row);
  for (btTypedConstraint* c : {static_cast<btTypedConstraint*>(&j1b), static_cast<btTypedConstraint*>(&j0a),
                               static_cast<btTypedConstraint*>(&j1m), static_cast<btTypedConstraint*>(&j0m)})
    world.removeConstraint(c);
  for (btRigidBody* body : bodies) world.removeRigidBody(body);
  return run;
}

}  // namespace

int main() {
  jacobian_check();
  const bool single = sizeof(btScalar) == sizeof(float);
  const double dt = 0.001, t_end = 20.0;
  // Linkers with a rod's inertia: the row holds the dihedral, a bond angle moves.
  const ChainRun held = chain(true, -1, 0.0, true, false, dt, t_end);
  const ChainRun free = chain(false, -1, 0.0, true, false, dt, t_end);
  check(held.worst_c < 1e-4, "held dihedral: largest |C| over 20 time units", held.worst_c);
  check(held.worst_deg < 0.01, "held dihedral: largest |phi - phi0| (deg) where both sines >= 0.2", held.worst_deg);
  std::printf("     (closest approach to a singular pose, max(|u x n0|, |u x n1|): %.3g; a neighbour came within "
              "sine %.3g of M's axis)\n",
              held.closest, held.nearest_axis);
  check(free.worst_deg > 10.0, "same start without the row: largest |phi - phi0| (deg)", free.worst_deg);
  check(held.angle_moved_deg > 10.0, "held dihedral: the free bond angle moved by (deg)", held.angle_moved_deg);
  const double p_bound = single ? 1e-5 : 1e-12;
  check(held.dp < p_bound * held.p_scale, "held dihedral: largest |P - P(0)| / scale", held.dp / held.p_scale);
  std::printf("     |L - L(0)| / scale with a rod's inertia: %.3g with the row, %.3g without (the engine's "
              "gyroscopic step, first order in dt)\n",
              held.dl / held.l_scale, free.dl / free.l_scale);
  // Isotropic linkers: the engine then turns a free body without changing
  // its angular momentum, and what is left is rounding and the ball joints.
  const double l_bound = single ? 1e-4 : 1e-6;
  const ChainRun iso = chain(true, -1, 0.0, true, true, dt, t_end);
  const ChainRun iso_free = chain(false, -1, 0.0, true, true, dt, t_end);
  const ChainRun split = chain(true, 0, 0.0, true, true, dt, t_end);
  check(iso.worst_c < 1e-4, "isotropic linkers, held dihedral: largest |C|", iso.worst_c);
  check(iso.dp < p_bound * iso.p_scale, "isotropic linkers, held dihedral: largest |P - P(0)| / scale",
        iso.dp / iso.p_scale);
  check(iso.dl < l_bound * iso.l_scale, "isotropic linkers, held dihedral: largest |L - L(0)| / scale",
        iso.dl / iso.l_scale);
  std::printf("     without the row: |P - P(0)| / scale %.3g, |L - L(0)| / scale %.3g\n", iso_free.dp / iso_free.p_scale,
              iso_free.dl / iso_free.l_scale);
  check(split.dl > 100 * l_bound * split.l_scale,
        "the row without the central linker's reaction: largest |L - L(0)| / scale (must be far off)",
        split.dl / split.l_scale);
  const ChainRun kicked = chain(true, -1, 5.0, false, false, dt, t_end);
  check(kicked.final_deg < 0.05, "turned 5 degrees off phi0 at rest: |phi - phi0| (deg) after 20 time units",
        kicked.final_deg);
  std::printf("%s\n", failures == 0 ? "held dihedral checks passed" : "held dihedral checks FAILED");
  return failures == 0 ? 0 : 1;
}
