#pragma once
// The held bond angle of the articulated reading as one Bullet constraint
// row between two linkers on one sphere (docs/ARTICULATED.md, "Constraint
// equations"; core/joints.hpp, HeldAngle):
//   C = (cos theta0 - n_A . n_B) / sin theta0,
// n_A, n_B the linkers' outward axes at the sphere (core/bond_rules.hpp:
// end 0 -> -u, end 1 -> +u, u the body-frame z axis of a linker), theta0
// the angle when the row was made. Its velocity is C' = J_A . omega_A +
// J_B . omega_B with J_A = -c / sin theta0, J_B = +c / sin theta0,
// c = n_A x n_B, and no linear part. Bullet's solver drives the row's
// velocity J v to the constraint error it is given; like Bullet's own
// joints (btPoint2PointConstraint: error = erp * fps * (pivot_B - pivot_A)
// for C = pivot_A - pivot_B), that error is erp * fps * (-C).
#include <algorithm>
#include <cmath>

#include <btBulletDynamicsCommon.h>

#include "held_row.hpp"

namespace ringsim::peer {

class HeldAngleConstraint : public HeldRowConstraint {
 public:
  // Holds the present angle between the outward axes of (a, end_a) and
  // (b, end_b). The caller keeps theta0 away from 0 and 180 degrees (the
  // row's gradient |n_A x n_B| / sin theta0 vanishes there).
  HeldAngleConstraint(btRigidBody& a, int end_a, btRigidBody& b, int end_b)
      : HeldRowConstraint(a, b), end_a_(end_a), end_b_(end_b) {
    const btScalar cos0 = std::clamp(outward(m_rbA, end_a_).dot(outward(m_rbB, end_b_)), btScalar(-1), btScalar(1));
    theta0_ = std::acos(cos0);
    cos0_ = cos0;
    sin0_ = std::sin(theta0_);
  }

  static btVector3 outward(const btRigidBody& body, int end) {
    const btVector3 u = body.getCenterOfMassTransform().getBasis().getColumn(2);
    return end == 0 ? -u : u;
  }

  btScalar theta0() const { return theta0_; }
  // C at the present poses (radians near the held pose).
  btScalar residual() const {
    return (cos0_ - outward(m_rbA, end_a_).dot(outward(m_rbB, end_b_))) / sin0_;
  }
  // |theta - theta0| in radians.
  btScalar angle_error() const {
    const btScalar c = std::clamp(outward(m_rbA, end_a_).dot(outward(m_rbB, end_b_)), btScalar(-1), btScalar(1));
    return std::abs(std::acos(c) - theta0_);
  }
  // The angular Jacobians of the row (for bodies A and B).
  void jacobian(btVector3& ja, btVector3& jb) const {
    const btVector3 c = outward(m_rbA, end_a_).cross(outward(m_rbB, end_b_));
    ja = -c / sin0_;
    jb = c / sin0_;
  }

  void getInfo1(btConstraintInfo1* info) override {
    info->m_numConstraintRows = 1;
    info->nub = 1;  // unbounded
  }

  void getInfo2(btConstraintInfo2* info) override {
    btVector3 ja, jb;
    jacobian(ja, jb);
    for (int k = 0; k < 3; ++k) {
      info->m_J1linearAxis[k] = 0;
      info->m_J2linearAxis[k] = 0;
      info->m_J1angularAxis[k] = ja[k];
      info->m_J2angularAxis[k] = jb[k];
    }
    info->m_constraintError[0] = info->fps * info->erp * -residual();
    info->m_lowerLimit[0] = -SIMD_INFINITY;
    info->m_upperLimit[0] = SIMD_INFINITY;
  }

 private:
  int end_a_, end_b_;
  btScalar theta0_ = 0, cos0_ = 0, sin0_ = 1;
};

}  // namespace ringsim::peer
