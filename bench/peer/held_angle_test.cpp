// Checks of the peer's held bond angle row (held_angle.hpp), run by ctest
// as peer_held_angle:
//  1. its angular Jacobians against central differences of C, for two
//     linkers in random orientations turned along random angular velocities;
//  2. the row in Bullet's solver: two tumbling linkers on a ball joint at a
//     common sphere keep their angle near theta0 (without the row it wanders
//     by tens of degrees), and a pose turned 5 degrees off theta0 is pulled
//     back (the sign of the error term).
// Exit status 0 when every check passes; each failure is printed.
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>

#include <btBulletDynamicsCommon.h>

#include "held_angle.hpp"
#include "test_support.hpp"

namespace {

using ringsim::peer::HeldAngleConstraint;
using namespace ringsim::peer::test;

void jacobian_check() {
  std::mt19937_64 rng(7);
  btCylinderShapeZ shape(btVector3(btScalar(0.25), btScalar(0.25), btScalar(1)));
  const double h = sizeof(btScalar) == sizeof(double) ? 1e-6 : 1e-3;
  double worst = 0.0;
  for (int trial = 0; trial < 50; ++trial) {
    const btQuaternion qa = random_rotation(rng), qb = random_rotation(rng);
    auto a = linker(&shape, btVector3(0, 0, 0), qa);
    auto b = linker(&shape, btVector3(0, 0, 2), qb);
    HeldAngleConstraint row(*a, trial % 2, *b, (trial / 2) % 2);
    if (std::sin(row.theta0()) < 0.1) continue;  // near 0 or 180 degrees: the caller refuses those
    // Move off the held pose, so that C and c are generic.
    turn(*a, qa, btScalar(0.2) * random_vector(rng));
    const btQuaternion qa1 = a->getWorldTransform().getRotation();
    const btVector3 wa = random_vector(rng), wb = random_vector(rng);
    btVector3 ja, jb;
    row.jacobian(ja, jb);
    const double analytic = double(ja.dot(wa) + jb.dot(wb));
    turn(*a, qa1, btScalar(h) * wa);
    turn(*b, qb, btScalar(h) * wb);
    const double cp = double(row.residual());
    turn(*a, qa1, btScalar(-h) * wa);
    turn(*b, qb, btScalar(-h) * wb);
    const double cm = double(row.residual());
    const double fd = (cp - cm) / (2 * h);
    worst = std::max(worst, std::abs(fd - analytic) / std::max(1.0, std::abs(analytic)));
  }
  const double tol = sizeof(btScalar) == sizeof(double) ? 1e-7 : 2e-3;
  check(worst < tol, "Jacobian against central differences (largest relative error)", worst);
}

// Two linkers (length 2) joined by ball joints to one sphere at end 1 of A
// and end 0 of B, the row holding the angle of 80 degrees; B then turned by
// `offset_deg` more, the linkers tumbling (`spin`) or at rest, for 20 time
// units at dt = 0.01. Returns the largest |theta - theta0| in degrees (and
// the final one).
double tumble(bool held, double offset_deg, bool spin, double* final_deg) {
  btSequentialImpulseConstraintSolver solver;
  TestWorld w(solver);
  btDiscreteDynamicsWorld& world = w.world;
  // A along z below the sphere, B tilted 80 degrees from A's axis.
  const btVector3 xs(0, 0, 0);
  const btQuaternion qa(0, 0, 0, 1);
  const btQuaternion qb(btVector3(1, 0, 0), btScalar(80.0 * M_PI / 180.0));
  auto a = linker(&w.rod, xs - btVector3(0, 0, btScalar(1.5)), qa);
  const btVector3 ub = btTransform(qb).getBasis().getColumn(2);
  auto b = linker(&w.rod, xs + btScalar(1.5) * ub, qb);
  auto sp = sphere(&w.ball, xs);
  btRigidBody& s = *sp;
  if (spin) {
    a->setAngularVelocity(btVector3(btScalar(0.3), btScalar(1.1), btScalar(-0.4)));
    b->setAngularVelocity(btVector3(btScalar(-0.9), btScalar(0.2), btScalar(0.7)));
  }
  world.addRigidBody(&s);
  world.addRigidBody(a.get());
  world.addRigidBody(b.get());
  btPoint2PointConstraint ja(s, *a, btVector3(0, 0, 0), btVector3(0, 0, btScalar(1.5)));
  btPoint2PointConstraint jb(s, *b, btVector3(0, 0, 0), btVector3(0, 0, btScalar(-1.5)));
  HeldAngleConstraint row(*a, 1, *b, 0);
  if (offset_deg != 0) {
    const btQuaternion q1(btVector3(1, 0, 0), btScalar((80.0 + offset_deg) * M_PI / 180.0));
    const btTransform t(q1, xs + btScalar(1.5) * btTransform(q1).getBasis().getColumn(2));
    b->setWorldTransform(t);
    b->setCenterOfMassTransform(t);
  }
  world.addConstraint(&ja, true);
  world.addConstraint(&jb, true);
  if (held) world.addConstraint(&row, true);
  double worst = double(row.angle_error()) * 180.0 / M_PI;
  for (int k = 0; k < 2000; ++k) {
    world.stepSimulation(btScalar(0.01), 0, btScalar(0.01));
    worst = std::max(worst, double(row.angle_error()) * 180.0 / M_PI);
  }
  *final_deg = double(row.angle_error()) * 180.0 / M_PI;
  if (held) world.removeConstraint(&row);
  world.removeConstraint(&jb);
  world.removeConstraint(&ja);
  world.removeRigidBody(b.get());
  world.removeRigidBody(a.get());
  world.removeRigidBody(&s);
  return worst;
}

}  // namespace

int main() {
  jacobian_check();
  double end_held = 0.0, end_free = 0.0, end_kicked = 0.0;
  const double held = tumble(true, 0.0, true, &end_held);
  const double unheld = tumble(false, 0.0, true, &end_free);
  tumble(true, 5.0, false, &end_kicked);
  check(held < 1.0, "held angle: largest |theta - theta0| (deg) over 20 time units", held);
  check(unheld > 10.0, "same start without the row: largest |theta - theta0| (deg)", unheld);
  check(end_kicked < 0.05, "turned 5 degrees off theta0 at rest: |theta - theta0| (deg) after 20 time units",
        end_kicked);
  std::printf("%s\n", failures == 0 ? "held angle checks passed" : "held angle checks FAILED");
  return failures == 0 ? 0 : 1;
}
