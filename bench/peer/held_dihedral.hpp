#pragma once
// The held dihedral of the articulated reading in Bullet (docs/PEER.md,
// "The held dihedral"; ringsim's row: core/joints.hpp, HeldDihedral).
//
// The dihedral phi about a central linker M (axis u) between the outward
// axes n0, n1 of its neighbours (core/bond_rules.hpp: end 0 -> -u, end 1 ->
// +u, u the body-frame z axis of a linker) is held at phi0 through
//   C = cos(phi0) u.(n0 x n1) - sin(phi0) (u x n0).(u x n1)
// (= |u x n0| |u x n1| sin(phi - phi0)). Its velocity is
// C' = J_M . omega_M + J_0 . omega_0 + J_1 . omega_1, no linear part; the
// value and the three angular Jacobians are ringsim's own
// (held_dihedral_residual, held_dihedral_gradient in core/joints.cpp), on the
// engine's axes.
//
// Why a solver pass and not a btTypedConstraint row: Bullet's constraint row
// (btSolverConstraint) joins two solver bodies, and C depends on three. Two
// two-body rows cannot express it: a row between M and a neighbour that
// ignores the third body's reaction applies a torque that does not sum to
// zero, which puts angular momentum in. So the row is solved by a
// subclass of Bullet's own solver (HeldDihedralSolver below) as a
// three-body row, by the recipe of Bullet's joint rows
// (btSequentialImpulseConstraintSolver::convertJoint and
// resolveSingleConstraintRowGeneric):
//  - effective mass K = sum_k J_k . I_k^-1 J_k over the three linkers (world
//    inverse inertias), impulse per unit of row velocity 1/K;
//  - target velocity erp * fps * (-C), the Baumgarte bias Bullet feeds its
//    joints (m_erp, not the contacts' m_erp2; no split impulse for joints),
//    and the row's velocity at the start of the solve taken with the
//    external and gyroscopic impulses, as Bullet takes its joints';
//  - each sweep updates the accumulated impulse lambda by
//    (rhs - J . delta omega / K) and applies the torques J_k dlambda (as the
//    angular impulses I_k^-1 J_k dlambda) to the three solver bodies.
// The three torques are J_k dlambda with J_M + J_0 + J_1 = 0 (C is invariant
// under a common rotation), and there is no force: momentum and angular
// momentum are untouched by the row, up to rounding of the Jacobians. The
// row runs inside every Gauss-Seidel sweep of Bullet's solver, before
// Bullet's own rows of that sweep (joints before contacts, the order Bullet
// gives its own), for the sweeps Bullet gives its joint rows
// (btContactSolverInfo::m_numIterations); it is not a post-solve split.
//
// Which bodies: a HeldDihedralConstraint is a btTypedConstraint between the
// two neighbours with no row of its own (getInfo1: 0 rows). The ball joints
// put the three linkers and their two spheres in one simulation island;
// the constraint reaches the solver in that island's constraint list, where
// HeldDihedralSolver picks it up by its tag.
#include <algorithm>
#include <cmath>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "core/joints.hpp"
#include "core/vec.hpp"
#include "held_row.hpp"

namespace ringsim::peer {

class HeldDihedralConstraint : public HeldRowConstraint {
 public:
  // btTypedConstraint::getUserConstraintType of every held dihedral.
  static constexpr int kTag = 0x64696864;  // "dihd"

  // Holds the dihedral about m between the outward axes of (nb0, end0),
  // the neighbour at m's end-0 side, and (nb1, end1), at its end-1 side, at
  // phi0 (radians; ringsim's make_held_dihedral measures it).
  HeldDihedralConstraint(btRigidBody& m, btRigidBody& nb0, int end0, btRigidBody& nb1, int end1, double phi0)
      : HeldRowConstraint(nb0, nb1), m_(m), end0_(end0), end1_(end1), phi0_(phi0) {
    setUserConstraintType(kTag);
  }

  // The held dihedral behind a constraint of the world, or null.
  static HeldDihedralConstraint* of(btTypedConstraint* c) {
    return c->getUserConstraintType() == kTag ? static_cast<HeldDihedralConstraint*>(c) : nullptr;
  }

  btRigidBody& central() const { return m_; }
  btRigidBody& neighbour0() const { return m_rbA; }
  btRigidBody& neighbour1() const { return m_rbB; }
  double phi0() const { return phi0_; }

  // The three unit axes (u, n0, n1) at the bodies' present poses, in double.
  void axes(Vec3& u, Vec3& n0, Vec3& n1) const {
    u = axis(m_);
    n0 = end0_ == 0 ? Vec3(-axis(m_rbA)) : axis(m_rbA);
    n1 = end1_ == 0 ? Vec3(-axis(m_rbB)) : axis(m_rbB);
  }
  // C at the present poses.
  double residual() const {
    Vec3 u, n0, n1;
    axes(u, n0, n1);
    return held_dihedral_residual(u, n0, n1, phi0_);
  }
  // The angular Jacobians for M, nb0, nb1.
  void jacobian(btVector3& jm, btVector3& j0, btVector3& j1) const {
    Vec3 u, n0, n1, gm, g0, g1;
    axes(u, n0, n1);
    held_dihedral_gradient(u, n0, n1, phi0_, gm, g0, g1);
    jm = to_bt(gm);
    j0 = to_bt(g0);
    j1 = to_bt(g1);
  }
  // Neighbours at least this sine off M's axis: phi is measured there to
  // |C| / (|u x n0| |u x n1|) <= 25 |C|.
  static constexpr double kMeasurableSine = 0.2;
  // How far phi is from the row's zero set, phi0 or phi0 + pi (radians, in
  // [0, pi/2]; the cis/trans flip a neighbour swinging through M's axis
  // makes stays on it, core/joints.hpp), where both neighbours are
  // kMeasurableSine off M's axis; elsewhere phi is ill measured or
  // undefined, and this is 0 (|C| still says how well the row holds).
  double dihedral_error() const {
    Vec3 u, n0, n1;
    axes(u, n0, n1);
    const Vec3 a = u.cross(n0), b = u.cross(n1);
    if (std::min(a.norm(), b.norm()) < kMeasurableSine) return 0.0;
    const double phi = std::atan2(u.dot(a.cross(b)), a.dot(b));
    return std::abs(std::remainder(phi - phi0_, M_PI));
  }

  // Tests only: leave body k (0 = M, 1 = nb0, 2 = nb1) out of the torques the
  // solver applies, the split that ignores one body's reaction (it breaks
  // angular momentum; the test shows its check sees that).
  void drop_reaction_of(int k) { dropped_ = k; }
  int dropped_reaction() const { return dropped_; }

  // The row is HeldDihedralSolver's; Bullet's row list gets none.
  void getInfo1(btConstraintInfo1* info) override {
    info->m_numConstraintRows = 0;
    info->nub = 0;
  }
  void getInfo2(btConstraintInfo2* info) override { (void)info; }

 private:
  static Vec3 axis(const btRigidBody& b) {
    const btVector3 z = b.getCenterOfMassTransform().getBasis().getColumn(2);
    return Vec3(double(z.x()), double(z.y()), double(z.z())).normalized();
  }
  static btVector3 to_bt(const Vec3& v) { return btVector3(btScalar(v.x()), btScalar(v.y()), btScalar(v.z())); }

  btRigidBody& m_;
  int end0_, end1_;
  double phi0_;
  int dropped_ = -1;
};

// Bullet's sequential-impulse solver with the held dihedrals' three-body rows
// (see the top of this file). Without held dihedrals in a group it is
// Bullet's solver unchanged.
class HeldDihedralSolver : public btSequentialImpulseConstraintSolver {
 public:
  // Rows set up so far whose three linkers were not all in the solved group
  // (never expected: they share an island); such a row is skipped.
  long skipped_rows() const { return skipped_; }

 protected:
  btScalar solveGroupCacheFriendlySetup(btCollisionObject** bodies, int numBodies, btPersistentManifold** manifolds,
                                        int numManifolds, btTypedConstraint** constraints, int numConstraints,
                                        const btContactSolverInfo& info, btIDebugDraw* debugDrawer) override {
    const btScalar r = btSequentialImpulseConstraintSolver::solveGroupCacheFriendlySetup(
        bodies, numBodies, manifolds, numManifolds, constraints, numConstraints, info, debugDrawer);
    rows_.clear();
    for (int i = 0; i < numConstraints; ++i) {
      HeldDihedralConstraint* d = HeldDihedralConstraint::of(constraints[i]);
      if (d && d->isEnabled()) set_up(*d, info);
    }
    return r;
  }

  btScalar solveSingleIteration(int iteration, btCollisionObject** bodies, int numBodies,
                                btPersistentManifold** manifolds, int numManifolds, btTypedConstraint** constraints,
                                int numConstraints, const btContactSolverInfo& info,
                                btIDebugDraw* debugDrawer) override {
    btScalar residual2 = 0;
    if (iteration < info.m_numIterations)
      for (Row& row : rows_) residual2 = std::max(residual2, solve(row));
    return std::max(residual2, btSequentialImpulseConstraintSolver::solveSingleIteration(
                                   iteration, bodies, numBodies, manifolds, numManifolds, constraints,
                                   numConstraints, info, debugDrawer));
  }

 private:
  struct Row {
    int body[3];             // solver bodies of M, nb0, nb1
    btVector3 j[3];          // angular Jacobians
    btVector3 turn[3];       // I^-1 J (times the angular factor): angular velocity per unit impulse
    btScalar inv_k = 0;      // 1 / (J M^-1 J^T)
    btScalar rhs = 0;        // impulse that brings the row's velocity to the bias, from the start velocities
    btScalar cfm = 0;
    btScalar applied = 0;    // accumulated impulse of this step
  };

  void set_up(const HeldDihedralConstraint& d, const btContactSolverInfo& info) {
    btRigidBody* rb[3] = {&d.central(), &d.neighbour0(), &d.neighbour1()};
    Row row;
    for (int k = 0; k < 3; ++k) {
      // The group's bodies all have solver bodies (convertBodies), indexed
      // by their companion id; a body outside the group has none.
      row.body[k] = rb[k]->getCompanionId();
      if (row.body[k] < 0 || row.body[k] >= m_tmpSolverBodyPool.size() ||
          m_tmpSolverBodyPool[row.body[k]].m_originalBody != rb[k]) {
        ++skipped_;
        return;
      }
    }
    d.jacobian(row.j[0], row.j[1], row.j[2]);
    // One linker as both neighbours (a ring of two spheres, where ringsim
    // makes such a row too): its two columns act on one body. Then n1 = -n0
    // and the row is identically zero (its columns cancel); held at nothing.
    if (rb[2] == rb[1]) {
      row.j[1] += row.j[2];
      row.j[2].setZero();
    }
    btScalar k_eff = 0, velocity = 0;
    for (int k = 0; k < 3; ++k) {
      const btSolverBody& sb = m_tmpSolverBodyPool[row.body[k]];
      const btVector3 turn = rb[k]->getInvInertiaTensorWorld() * row.j[k];
      k_eff += turn.dot(row.j[k]);
      velocity += row.j[k].dot(sb.m_angularVelocity + sb.m_externalTorqueImpulse);
      row.turn[k] = d.dropped_reaction() == k ? btVector3(0, 0, 0) : turn * rb[k]->getAngularFactor();
    }
    // Singular only with both neighbours along M's axis (core/joints.hpp);
    // there, as Bullet does with a degenerate joint row, no impulse.
    row.inv_k = k_eff > SIMD_EPSILON ? 1 / k_eff : 0;
    const btScalar fps = 1 / info.m_timeStep;
    row.rhs = (fps * info.m_erp * btScalar(-d.residual()) - velocity * info.m_damping) * row.inv_k;
    row.cfm = info.m_globalCfm;
    rows_.push_back(row);
  }

  // One Gauss-Seidel update of a row; returns the squared velocity residual
  // (Bullet's measure of a sweep).
  btScalar solve(Row& row) {
    btScalar dv = 0;
    for (int k = 0; k < 3; ++k) dv += row.j[k].dot(m_tmpSolverBodyPool[row.body[k]].internalGetDeltaAngularVelocity());
    const btScalar delta = row.rhs - row.applied * row.cfm - dv * row.inv_k;
    row.applied += delta;
    const btVector3 none(0, 0, 0);
    for (int k = 0; k < 3; ++k) m_tmpSolverBodyPool[row.body[k]].internalApplyImpulse(none, row.turn[k], delta);
    const btScalar v = row.inv_k > 0 ? delta / row.inv_k : 0;
    return v * v;
  }

  std::vector<Row> rows_;
  long skipped_ = 0;
};

}  // namespace ringsim::peer
