#pragma once
// What the peer's held rows (held_angle.hpp, held_dihedral.hpp) share as
// Bullet constraints: no per-constraint ERP or CFM (the solver's global
// values apply, as for the held rows' Baumgarte term).
#include <btBulletDynamicsCommon.h>

namespace ringsim::peer {

class HeldRowConstraint : public btTypedConstraint {
 public:
  HeldRowConstraint(btRigidBody& a, btRigidBody& b) : btTypedConstraint(MAX_CONSTRAINT_TYPE, a, b) {}

  void setParam(int num, btScalar value, int axis = -1) override {
    (void)num;
    (void)value;
    (void)axis;
  }
  btScalar getParam(int num, int axis = -1) const override {
    (void)num;
    (void)axis;
    return 0;
  }
};

}  // namespace ringsim::peer
