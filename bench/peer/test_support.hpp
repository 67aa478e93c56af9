#pragma once
// What the peer's row tests (held_angle_test.cpp, held_dihedral_test.cpp)
// share: the printed check, random rotations and vectors, a world without
// gravity with the bodies' shapes, a linker body (length 2, radius 0.25,
// mass 1), a sphere body (radius 0.5, mass 0.5) and turning a body by a
// world rotation.
#include <cstdio>
#include <memory>
#include <random>

#include <btBulletDynamicsCommon.h>

namespace ringsim::peer::test {

// Failed checks so far; each check prints one line.
inline int failures = 0;
inline void check(bool ok, const char* what, double value) {
  std::printf("%s %s: %.3g\n", ok ? "ok  " : "FAIL", what, value);
  if (!ok) ++failures;
}

inline btQuaternion random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  btQuaternion q(btScalar(g(rng)), btScalar(g(rng)), btScalar(g(rng)), btScalar(g(rng)));
  return q.normalized();
}

inline btVector3 random_vector(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  return btVector3(btScalar(g(rng)), btScalar(g(rng)), btScalar(g(rng)));
}

// A world without gravity on `solver`, and the shapes of the bodies below.
struct TestWorld {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btDiscreteDynamicsWorld world;
  btSphereShape ball{btScalar(0.5)};
  btCylinderShapeZ rod{btVector3(btScalar(0.25), btScalar(0.25), btScalar(1))};
  explicit TestWorld(btConstraintSolver& solver) : world(&dispatcher, &broadphase, &solver, &config) {
    world.setGravity(btVector3(0, 0, 0));
  }
};

inline std::unique_ptr<btRigidBody> sphere(btCollisionShape* shape, const btVector3& x) {
  btRigidBody::btRigidBodyConstructionInfo ci(btScalar(0.5), nullptr, shape,
                                              btVector3(btScalar(0.05), btScalar(0.05), btScalar(0.05)));
  ci.m_startWorldTransform = btTransform(btQuaternion(0, 0, 0, 1), x);
  auto s = std::make_unique<btRigidBody>(ci);
  s->setActivationState(DISABLE_DEACTIVATION);
  return s;
}

inline std::unique_ptr<btRigidBody> linker(btCollisionShape* shape, const btVector3& x, const btQuaternion& q) {
  btRigidBody::btRigidBodyConstructionInfo ci(1, nullptr, shape, btVector3(btScalar(0.35), btScalar(0.35), btScalar(0.1)));
  ci.m_startWorldTransform = btTransform(q, x);
  auto b = std::make_unique<btRigidBody>(ci);
  b->setActivationState(DISABLE_DEACTIVATION);
  return b;
}

// The world rotation exp(w) applied to a body's orientation q0.
inline void turn(btRigidBody& b, const btQuaternion& q0, const btVector3& w) {
  btTransform t = b.getWorldTransform();
  const btScalar a = w.length();
  t.setRotation(a > 0 ? btQuaternion(w / a, a) * q0 : q0);
  b.setWorldTransform(t);
  b.setCenterOfMassTransform(t);
}

}  // namespace ringsim::peer::test
