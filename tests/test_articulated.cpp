// Articulated clusters (core/joints.hpp, core/constrained_dynamics.hpp,
// core/joint_projection.hpp, core/joint_impulses.hpp, and ClusterIntegrator
// with joints): the bond-formation impulse (momentum, angular momentum,
// kinetic energy), position projection, contact impulses against a dense KKT
// solve, free flight of an L-S-L chain for 1e3 time units (energy, momentum,
// angular momentum, constraint residual), a spinning straight L-S-L against
// the analytic steady rotation, held angle and dihedral kept while the free
// degrees of freedom move, and the integration methods compared.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

#include <Eigen/Dense>

#include "articulated_chain.hpp"
#include "core/bond_rules.hpp"
#include "core/compliant_integrator.hpp"
#include "core/constrained_dynamics.hpp"
#include "core/joint_impulses.hpp"
#include "core/joint_projection.hpp"
#include "core/joints.hpp"

namespace ringsim {
namespace {

constexpr double kPi = 3.14159265358979323846;

double max_abs(const Eigen::VectorXd& x) { return x.size() == 0 ? 0.0 : x.cwiseAbs().maxCoeff(); }

double velocity_residual(const std::vector<CompliantBody>& bodies, const JointSet& joints) {
  const VelocityLayout layout(bodies);
  JointRows rows;
  joint_rows(bodies, layout, joints, rows);
  return max_abs(rows.g * velocity_vector(bodies, layout));
}

// ---- bond-formation impulse and projections ----------------------------------------

// Two linkers and a sphere moving at random meet: the new ball joints and the
// held angle make their velocities consistent by the M-orthogonal projection.
TEST(JointProjection, BondImpulseKeepsMomentaAndNeverHeats) {
  for (int seed = 1; seed <= 5; ++seed) {
    test::Articulated a = test::lsl(0.5 * kPi + 0.05, 0.2, true);
    test::jitter_velocities(a.cluster, 2.0, 1.5, seed);
    for (CompliantBody& b : a.bodies()) b.x += Vec3(3.0, -2.0, 5.0);  // away from the origin: a real lever
    const Vec3 p0 = total_momentum(a.cluster), l0 = total_angular_momentum(a.cluster);
    const double e0 = kinetic_energy(a.cluster);
    ASSERT_GT(velocity_residual(a.bodies(), a.joints), 0.1);

    const VelocityProjection r = project_velocities(a.bodies(), a.joints);
    const Vec3 p1 = total_momentum(a.cluster), l1 = total_angular_momentum(a.cluster);
    const double e1 = kinetic_energy(a.cluster);
    EXPECT_LT((p1 - p0).norm(), 1e-12 * p0.norm()) << "seed " << seed;
    EXPECT_LT((l1 - l0).norm(), 1e-12 * l0.norm()) << "seed " << seed;
    EXPECT_LE(e1, e0) << "seed " << seed;
    EXPECT_GT(e0 - e1, 1e-3);  // inelastic in the held directions
    EXPECT_NEAR(r.energy_change, e1 - e0, 1e-12 * e0);
    EXPECT_LT(r.residual_after, 1e-13);
    EXPECT_LT(velocity_residual(a.bodies(), a.joints), 1e-13);
    // A second projection changes nothing.
    const VelocityProjection again = project_velocities(a.bodies(), a.joints);
    EXPECT_NEAR(again.energy_change, 0.0, 1e-14 * e0);
  }
}

// The same on a closed square with both filters: redundant rows (rank 29 of 32).
TEST(JointProjection, BondImpulseOnAnOverconstrainedRing) {
  test::Articulated a = test::square(0.15, true, true);
  test::jitter_velocities(a.cluster, 1.0, 1.0, 4);
  const Vec3 p0 = total_momentum(a.cluster), l0 = total_angular_momentum(a.cluster);
  const double e0 = kinetic_energy(a.cluster);
  project_velocities(a.bodies(), a.joints);
  EXPECT_LT((total_momentum(a.cluster) - p0).norm(), 1e-12 * p0.norm());
  EXPECT_LT((total_angular_momentum(a.cluster) - l0).norm(), 1e-12 * l0.norm());
  EXPECT_LE(kinetic_energy(a.cluster), e0);
  EXPECT_LT(velocity_residual(a.bodies(), a.joints), 1e-12);
}

// Gauss-Newton in the M metric brings a displaced pose back in a few steps
// and keeps the centre of mass.
TEST(JointProjection, PositionsConvergeAndKeepTheCentreOfMass) {
  test::Articulated a = test::open_chain(4, 0.3, true, true);
  test::jitter_velocities(a.cluster, 0.5, 0.5, 8);
  test::Jitter rng(21);
  for (CompliantBody& b : a.bodies()) {
    b.x += 1e-3 * rng.vec();
    if (b.shape == Shape::Linker) b.q = (Eigen::AngleAxisd(1e-3, rng.vec().normalized()) * b.q).normalized();
  }
  auto com = [&] {
    Vec3 s = Vec3::Zero();
    double m = 0.0;
    for (const CompliantBody& b : a.bodies()) s += b.mass * b.x, m += b.mass;
    return Vec3(s / m);
  };
  const Vec3 c0 = com(), p0 = total_momentum(a.cluster);
  const PositionProjection r = project_positions(a.bodies(), a.joints, 1e-12);
  std::printf("position projection: residual %.3g -> %.3g in %d steps, displacement %.3g\n", r.residual_before,
              r.residual_after, r.iterations, r.displacement);
  EXPECT_TRUE(r.converged);
  EXPECT_LE(r.iterations, 4);
  EXPECT_GT(r.residual_before, 1e-4);
  EXPECT_LT(max_abs(joint_residual(a.bodies(), a.joints)), 1e-12);
  EXPECT_LT((com() - c0).norm(), 1e-14);
  EXPECT_LT((total_momentum(a.cluster) - p0).norm(), 1e-13);
  EXPECT_LT(velocity_residual(a.bodies(), a.joints), 1e-13);
}

// One Gauss-Newton step (max_iterations = 1), solved with the spheres
// riding on their hosts, against the step of the full problem solved
// densely: the M-smallest dnu with G dnu = -C, from the KKT system
//   [M G^T; G 0] [dnu; mu] = [0; -C]
// (least squares with the minimum norm, COD), applied as the same
// displacement. The chain is pulled 1e-3 off every joint, host joints
// included.
TEST(JointProjection, PositionStepIsTheFullProblemsStep) {
  test::Articulated a = test::open_chain(4, 0.3, true, true);
  test::Jitter rng(5);
  for (CompliantBody& b : a.bodies()) {
    b.x += 1e-3 * rng.vec();
    if (b.shape == Shape::Linker) b.q = (Eigen::AngleAxisd(1e-3, rng.vec().normalized()) * b.q).normalized();
  }
  std::vector<CompliantBody> dense = a.bodies();
  const MassMatrix m(dense);
  JointRows rows;
  joint_rows(dense, m.layout, a.joints, rows);
  const int n = m.layout.size, k = int(rows.g.rows());
  const Eigen::MatrixXd kkt = test::kkt_matrix(m, rows.g);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n + k);
  rhs.tail(k) = -rows.c;
  const Eigen::VectorXd dnu = kkt.completeOrthogonalDecomposition().solve(rhs).head(n);
  EXPECT_LT(max_abs(rows.g * dnu + rows.c), 1e-14);
  displace(dense, m.layout, dnu);

  const PositionProjection r = project_positions(a.bodies(), a.joints, 1e-300, 1);
  EXPECT_EQ(r.iterations, 1);
  double gap = 0.0;
  for (std::size_t i = 0; i < dense.size(); ++i) {
    gap = std::max(gap, (a.bodies()[i].x - dense[i].x).norm());
    gap = std::max(gap, a.bodies()[i].q.angularDistance(dense[i].q));
  }
  std::printf("position step: hosted against dense KKT, largest difference %.3g (step %.3g)\n", gap,
              dnu.cwiseAbs().maxCoeff());
  EXPECT_LT(gap, 1e-13);
}

// ---- contact impulses ----------------------------------------------------------------

// A contact impulse J at a point of one linker of a four-corner chain (every
// kind of joint): the velocities against the KKT system
//   [M G^T; G 0] [nu'; mu] = [M nu + C^T J; 0]
// solved densely, the collision matrix K = C W C^T against the change of the
// point's velocity, and the momenta: P changes by J, L by x_p x J.
TEST(JointImpulses, ContactImpulseMatchesDenseKkt) {
  test::Articulated a = test::open_chain(4, 0.3, true, true);
  test::jitter_velocities(a.cluster, 0.5, 0.5, 12);
  project_velocities(a.bodies(), a.joints);  // consistent before the contact
  const int body = 3;                        // linker 1
  const Vec3 arm = a.bodies()[body].q * Vec3(0.3, -0.5, 1.2);
  const Vec3 point = a.bodies()[body].x + arm;
  const Vec3 J(0.8, -1.7, 0.4);

  const MassMatrix m(a.bodies());
  JointRows rows;
  joint_rows(a.bodies(), m.layout, a.joints, rows);
  const int n = m.layout.size, k = int(rows.g.rows());
  const Eigen::MatrixXd c = point_velocity_rows(a.bodies(), m.layout, body, arm);
  const Eigen::MatrixXd kkt = test::kkt_matrix(m, rows.g);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n + k);
  const Eigen::VectorXd nu0 = velocity_vector(a.bodies(), m.layout);
  rhs.head(n) = m.times(nu0) + c.transpose() * J;
  const Eigen::VectorXd sol = kkt.fullPivLu().solve(rhs);
  const Eigen::VectorXd nu_kkt = sol.head(n);

  const Vec3 p0 = total_momentum(a.cluster), l0 = total_angular_momentum(a.cluster);
  const Mat3 K = collision_matrix(a.bodies(), a.joints, body, arm);
  const Vec3 u0 = c * nu0;
  apply_point_impulse(a.bodies(), a.joints, body, arm, J);
  const Eigen::VectorXd nu1 = velocity_vector(a.bodies(), m.layout);
  EXPECT_LT((nu1 - nu_kkt).cwiseAbs().maxCoeff(), 1e-12 * nu_kkt.cwiseAbs().maxCoeff());
  EXPECT_LT(velocity_residual(a.bodies(), a.joints), 1e-13);
  EXPECT_LT((Vec3(c * nu1) - u0 - K * J).norm(), 1e-12);
  EXPECT_LT((K - K.transpose()).norm(), 1e-14);
  EXPECT_GT(K.selfadjointView<Eigen::Upper>().eigenvalues().minCoeff(), 0.0);
  // The free body's K is larger: the joints make the point heavier.
  const Mat3 K_free = collision_matrix(a.bodies(), JointSet{}, body, arm);
  EXPECT_GT((K_free - K).selfadjointView<Eigen::Upper>().eigenvalues().minCoeff(), -1e-14);
  EXPECT_LT((total_momentum(a.cluster) - p0 - J).norm(), 1e-12);
  EXPECT_LT((total_angular_momentum(a.cluster) - l0 - point.cross(J)).norm(), 1e-12);
}

// A contact between two bodies of the same cluster (equal and opposite
// impulses): momenta unchanged, K with the cross terms against the change of
// the relative velocity.
TEST(JointImpulses, InternalContactKeepsMomenta) {
  test::Articulated a = test::open_chain(4, 0.3, false, false);
  test::jitter_velocities(a.cluster, 0.5, 0.5, 13);
  project_velocities(a.bodies(), a.joints);
  const int ba = 1, bb = 7;  // linkers 0 and 3
  const Vec3 arm_a = a.bodies()[ba].q * Vec3(0.5, 0.2, -1.0), arm_b = a.bodies()[bb].q * Vec3(-0.4, 0.6, 1.1);
  const Vec3 J(0.3, 0.9, -0.5);  // on B; -J on A
  const VelocityLayout layout(a.bodies());
  const Eigen::MatrixXd c = point_velocity_rows(a.bodies(), layout, bb, arm_b) -
                            point_velocity_rows(a.bodies(), layout, ba, arm_a);
  const Mat3 K = collision_matrix(a.bodies(), a.joints, ba, arm_a, bb, arm_b);
  const Vec3 u0 = c * velocity_vector(a.bodies(), layout);
  const Vec3 p0 = total_momentum(a.cluster), l0 = total_angular_momentum(a.cluster);
  apply_impulse(a.bodies(), a.joints, c, J);
  EXPECT_LT((Vec3(c * velocity_vector(a.bodies(), layout)) - u0 - K * J).norm(), 1e-12);
  EXPECT_LT((total_momentum(a.cluster) - p0).norm(), 1e-12);
  // The two points differ: the pair of impulses is a couple, (x_B - x_A) x J.
  const Vec3 xa = a.bodies()[ba].x + arm_a, xb = a.bodies()[bb].x + arm_b;
  EXPECT_LT((total_angular_momentum(a.cluster) - l0 - (xb - xa).cross(J)).norm(), 1e-12);
}

// ---- integration ---------------------------------------------------------------------

struct FlightFigures {
  double energy_error = 0.0;    // max |E - E0| / E0
  double momentum_error = 0.0;  // max |P - P0| / |P0|
  double angular_error = 0.0;   // max |L - L0| / |L0|
  double residual = 0.0;        // max |C| before each projection
  double velocity_residual = 0.0;
  double correction = 0.0;      // largest position correction (M-norm)
  long steps = 0, rhs = 0;
  double wall = 0.0;
};

// Integrates for `duration`, projecting every `every` time units.
FlightFigures fly(test::Articulated a, Method method, double duration, double every, double rtol, double atol,
                  double tolerance) {
  IntegratorOptions o;
  o.method = method;
  o.rtol = rtol;
  o.atol = atol;
  o.max_steps = 1000000;
  ClusterIntegrator integ(a.cluster, 0.0, o, a.joints);
  const double e0 = kinetic_energy(a.cluster);
  const Vec3 p0 = total_momentum(a.cluster), l0 = total_angular_momentum(a.cluster);
  FlightFigures f;
  const auto start = std::chrono::steady_clock::now();
  const int n = int(std::lround(duration / every));
  for (int i = 1; i <= n; ++i) {
    const AdvanceResult r = integ.advance_to(i * every);
    if (!r.ok()) {
      ADD_FAILURE() << r.reason;
      break;
    }
    const CompliantCluster& c = integ.state();
    f.residual = std::max(f.residual, max_abs(joint_residual(c.bodies, a.joints)));
    f.velocity_residual = std::max(f.velocity_residual, velocity_residual(c.bodies, a.joints));
    const PositionProjection pr = integ.project_onto_joints(tolerance);
    EXPECT_TRUE(pr.converged);
    f.correction = std::max(f.correction, pr.displacement);
    const CompliantCluster& d = integ.state();
    f.energy_error = std::max(f.energy_error, std::abs(kinetic_energy(d) - e0) / e0);
    f.momentum_error = std::max(f.momentum_error, (total_momentum(d) - p0).norm() / p0.norm());
    f.angular_error = std::max(f.angular_error, (total_angular_momentum(d) - l0).norm() / l0.norm());
  }
  f.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  f.steps = integ.stats().steps;
  f.rhs = integ.stats().rhs_evals;
  return f;
}

test::Articulated moving_lsl(bool hold_angle) {
  test::Articulated a = test::lsl(0.5 * kPi + 0.1, 0.2, hold_angle);
  test::jitter_velocities(a.cluster, 1.0, 1.0, 6);
  project_velocities(a.bodies(), a.joints);
  return a;
}

void print(const char* what, const FlightFigures& f) {
  std::printf("%-28s steps %8ld  rhs %8ld  wall %7.3f s  dE/E %.2e  dP/P %.2e  dL/L %.2e  |C| %.2e  |Gv| %.2e  "
              "corr %.2e\n",
              what, f.steps, f.rhs, f.wall, f.energy_error, f.momentum_error, f.angular_error, f.residual,
              f.velocity_residual, f.correction);
}

// (a) L-S-L with ball joints in free flight for 1e3 time units (three free
// internal degrees of freedom: it tumbles and flexes), projected every time
// unit: the constraint forces do no work, so the kinetic energy is conserved
// to the integrator's tolerance; the momentum (a linear invariant of the
// state, which Runge-Kutta stages keep exactly) to round-off; the angular
// momentum (quadratic in the state, sum m x x v) to the tolerance, like the
// energy: the constraint loads are internal up to C x lambda, and the
// projections keep it exactly.
TEST(ArticulatedIntegrator, FreeLslConservesEnergyAndMomenta) {
  const test::Articulated a = moving_lsl(false);
  EXPECT_EQ(internal_dof(a.cluster.bodies, a.joints), 3);
  const FlightFigures f = fly(a, Method::ExplicitRk, 1000.0, 1.0, 1e-9, 1e-11, 1e-10);
  print("L-S-L, erk, 1e3 time units", f);
  EXPECT_LT(f.energy_error, 1e-6);
  EXPECT_LT(f.momentum_error, 1e-12);
  EXPECT_LT(f.angular_error, 1e-7);
  EXPECT_LT(f.residual, 1e-8);  // drift in one time unit, before the projection
}

// (b) A straight L-S-L (anchors on the axes, sphere at the centre of mass)
// spinning rigidly at omega about an axis normal to the line: by symmetry a
// steady rotation, held by a tension m_L omega^2 d in each joint (d: the
// linker centre's distance from the axis). The integrated pose after t is the
// initial one turned by omega t about z, and the multipliers give the tension.
TEST(ArticulatedIntegrator, SpinningStraightChainIsASteadyRotation) {
  const double d = test::reach();
  test::Articulated a;
  a.cluster.bodies = {test::linker_at(Vec3(-d, 0, 0), Vec3::UnitX(), 0.4), test::sphere_at(Vec3::Zero()),
                      test::linker_at(Vec3(d, 0, 0), Vec3::UnitX(), -1.1)};
  a.joints.balls = {make_ball_joint(a.bodies(), 1, 0), make_ball_joint(a.bodies(), 1, 2)};
  const double w = 1.3;
  const Vec3 omega(0, 0, w);
  for (CompliantBody& b : a.bodies()) {
    b.v = omega.cross(b.x);
    if (b.shape == Shape::Linker) b.omega = omega;
  }
  // The tension from the multipliers (no applied loads).
  std::vector<Vec3> f(3, Vec3::Zero()), tau(3, Vec3::Zero());
  add_constraint_loads(a.bodies(), a.joints, f, tau);
  const double m_l = a.bodies()[0].mass;
  EXPECT_LT((f[0] - Vec3(m_l * w * w * d, 0, 0)).norm(), 1e-12);  // pulled toward the axis
  EXPECT_LT((f[2] + Vec3(m_l * w * w * d, 0, 0)).norm(), 1e-12);
  EXPECT_LT(f[1].norm(), 1e-12);
  EXPECT_LT(tau[0].norm() + tau[2].norm(), 1e-12);

  IntegratorOptions o;
  o.method = Method::ExplicitRk;
  o.rtol = 1e-10;
  o.atol = 1e-12;
  ClusterIntegrator integ(a.cluster, 0.0, o, a.joints);
  const double t = 20.0;  // ~4 turns
  ASSERT_TRUE(integ.advance_to(t).ok());
  const Eigen::AngleAxisd turn(w * t, Vec3::UnitZ());
  double worst = 0.0;
  for (std::size_t i = 0; i < 3; ++i) {
    const CompliantBody &b0 = a.bodies()[i], &b = integ.state().bodies[i];
    worst = std::max(worst, (b.x - turn * b0.x).norm());
    worst = std::max(worst, (b.v - turn * b0.v).norm());
    if (b.shape == Shape::Linker) {
      worst = std::max(worst, (b.q * Vec3(0.3, 0.7, -0.2) - turn * (b0.q * Vec3(0.3, 0.7, -0.2))).norm());
      worst = std::max(worst, (b.omega - omega).norm());
    }
  }
  std::printf("spinning L-S-L: largest deviation from the steady rotation after t = %g: %.3g\n", t, worst);
  EXPECT_LT(worst, 1e-7);
}

// A slice end's loads come from the integrator's own right-hand side
// (ClusterIntegrator::present_loads): they are the cluster's loads, and the
// solver's first right-hand side after the restart at that state is served
// from them, which changes nothing: an integrator that was asked goes on bit
// for bit as one that was not. A state changed after the question is not
// served from it.
TEST(ArticulatedIntegrator, PresentLoadsServeTheRestartExactly) {
  test::Articulated chain = test::open_chain(3, 0.3, true, true);
  test::jitter_velocities(chain.cluster, 1.0, 1.0, 23);
  project_velocities(chain.bodies(), chain.joints);
  IntegratorOptions o;
  o.method = Method::ExplicitRk;
  ClusterIntegrator asked(chain.cluster, 0.0, o, chain.joints), plain(chain.cluster, 0.0, o, chain.joints);
  auto same_state = [](const ClusterIntegrator& a, const ClusterIntegrator& b) {
    for (std::size_t i = 0; i < a.state().bodies.size(); ++i) {
      const CompliantBody &p = a.state().bodies[i], &q = b.state().bodies[i];
      if (p.x != q.x || p.v != q.v || p.q.coeffs() != q.q.coeffs() || p.omega != q.omega) return false;
    }
    return true;
  };
  for (int k = 1; k <= 4; ++k) {
    ASSERT_TRUE(asked.advance_to(0.2 * k).ok());
    ASSERT_TRUE(plain.advance_to(0.2 * k).ok());
    asked.project_onto_joints(1e-10);
    plain.project_onto_joints(1e-10);
    std::vector<Vec3> f, tau, f_ref, tau_ref;
    asked.present_loads(f, tau);
    cluster_loads(asked.state(), chain.joints, f_ref, tau_ref);
    double scale = 0.0, worst = 0.0;
    for (std::size_t i = 0; i < f.size(); ++i) {
      scale = std::max({scale, f_ref[i].norm(), tau_ref[i].norm()});
      worst = std::max({worst, (f[i] - f_ref[i]).norm(), (tau[i] - tau_ref[i]).norm()});
    }
    ASSERT_GT(scale, 1e-3);  // the chain moves: the joints pull
    EXPECT_LT(worst, 1e-12 * scale) << "slice " << k;
  }
  ASSERT_TRUE(asked.advance_to(1.0).ok());
  ASSERT_TRUE(plain.advance_to(1.0).ok());
  EXPECT_EQ(asked.stats().rhs_reused, 4);
  EXPECT_EQ(plain.stats().rhs_reused, 0);
  EXPECT_EQ(asked.stats().rhs_evals, plain.stats().rhs_evals);
  EXPECT_TRUE(same_state(asked, plain));

  // Asked, then the state changed (an impulse): computed anew.
  std::vector<Vec3> f, tau;
  asked.present_loads(f, tau);
  for (ClusterIntegrator* integ : {&asked, &plain}) {
    integ->mutable_state().bodies[0].v += Vec3(0.0, 0.0, 0.1);
    integ->reinit();
    ASSERT_TRUE(integ->advance_to(1.2).ok());
  }
  EXPECT_EQ(asked.stats().rhs_reused, 4);
  EXPECT_TRUE(same_state(asked, plain));
}

// (c) Held angle and held dihedral stay at their bonding values while the
// free degrees of freedom move: an open chain S L S L S L with angles at the
// two inner spheres and the dihedral about the middle linker (27 velocity
// coordinates, 18 independent rows: 3 internal freedoms), and the L-S-L with
// its angle held (2), integrated for 200 time units with a projection every
// time unit.
TEST(ArticulatedIntegrator, HeldAngleAndDihedralStayWhileTheRestMoves) {
  test::Articulated chain = test::open_chain(3, 0.3, true, true);
  ASSERT_EQ(chain.joints.dihedrals.size(), 1u);
  EXPECT_EQ(internal_dof(chain.cluster.bodies, chain.joints), 3);
  test::jitter_velocities(chain.cluster, 1.0, 1.0, 17);
  project_velocities(chain.bodies(), chain.joints);
  const test::Articulated lsl = moving_lsl(true);
  EXPECT_EQ(internal_dof(lsl.cluster.bodies, lsl.joints), 2);

  for (const test::Articulated* a : {static_cast<const test::Articulated*>(&chain), &lsl}) {
    IntegratorOptions o;
    o.method = Method::ExplicitRk;
    o.rtol = 1e-9;
    o.atol = 1e-11;
    ClusterIntegrator integ(a->cluster, 0.0, o, a->joints);
    // A free motion to watch: the relative orientation of the first and last
    // linkers (it must change: the cluster is not moving rigidly).
    const int first = 0 + (a->cluster.bodies[0].shape == Shape::Sphere), last = int(a->cluster.bodies.size()) - 1;
    const Quat rel0 = a->cluster.bodies[first].q.conjugate() * a->cluster.bodies[last].q;
    double held_error = 0.0, largest_turn = 0.0;
    for (int i = 1; i <= 200; ++i) {
      ASSERT_TRUE(integ.advance_to(double(i)).ok());
      const CompliantCluster& c = integ.state();
      const Eigen::VectorXd res = joint_residual(c.bodies, a->joints);
      held_error = std::max(held_error, max_abs(res.tail(a->joints.angles.size() + a->joints.dihedrals.size())));
      const Quat rel = c.bodies[first].q.conjugate() * c.bodies[last].q;
      largest_turn = std::max(largest_turn, rel0.angularDistance(rel));
      integ.project_onto_joints(1e-10);
    }
    std::printf("%s: held rows within %.3g rad of their values; free relative turn up to %.3g rad\n",
                a == &chain ? "S-L-S-L-S-L" : "L-S-L (angle held)", held_error, largest_turn);
    EXPECT_LT(held_error, 1e-6);
    EXPECT_GT(largest_turn, 0.5);
    // Held to the projection tolerance at the end.
    EXPECT_LT(max_abs(joint_residual(integ.state().bodies, a->joints)), 1e-10);
  }
}

// The methods on the L-S-L chain (100 time units, projection every time
// unit, atol = rtol / 100) over three tolerances: the figures behind the
// choice in docs/ARTICULATED.md (work per accuracy). Every method must
// conserve energy to its tolerance.
TEST(ArticulatedIntegrator, MethodComparison) {
  const test::Articulated a = moving_lsl(false);
  for (const double rtol : {1e-7, 1e-9, 1e-11}) {
    for (const Method m : {Method::ExplicitRk, Method::Adams, Method::Bdf}) {
      const FlightFigures f = fly(a, m, 100.0, 1.0, rtol, 1e-2 * rtol, 1e-10);
      char what[64];
      std::snprintf(what, sizeof what, "L-S-L, %s, rtol %.0e", to_string(m), rtol);
      print(what, f);
      EXPECT_LT(f.energy_error, 1e4 * rtol) << what;
      EXPECT_LT(f.momentum_error, 1e-8) << what;
    }
  }
  // In the event loop the state is projected (and the method restarted) at
  // every slice end (bonding.joint_slice, 0.2 by default; 0.05 here): a multistep method
  // restarts at order 1 each time, a one-step method loses nothing.
  for (const Method m : {Method::ExplicitRk, Method::Adams, Method::Bdf}) {
    const FlightFigures f = fly(a, m, 100.0, 0.05, 1e-9, 1e-11, 1e-10);
    char what[64];
    std::snprintf(what, sizeof what, "L-S-L, %s, slices 0.05", to_string(m));
    print(what, f);
    EXPECT_LT(f.energy_error, 1e-5) << what;
  }
}

// Scenario 3's filters (coplanarity on, angle off): S L S L S L with ball
// joints and the dihedral about the middle linker held, the bond angles free
// (27 - 15 - 1 - 6 = 5 internal freedoms). The planar swing of a neighbour
// carries it through M's axis, where the dihedral jumps between phi0 and
// phi0 + pi; the polynomial row (core/joints.hpp) stays regular there.
// Integrated in slices of 0.05 with a projection at each end, as in the event
// loop: no failure, the pose reaches a near-collinear neighbour, and the
// dihedral away from such poses stays at phi0 or phi0 + pi.
TEST(ArticulatedIntegrator, HeldDihedralPassesACollinearNeighbour) {
  double closest = 1.0;
  for (int seed = 1; seed <= 3; ++seed) {
    test::Articulated chain = test::open_chain(3, 0.3, false, true);
    EXPECT_EQ(internal_dof(chain.cluster.bodies, chain.joints), 5);
    test::jitter_velocities(chain.cluster, 1.0, 1.0, seed);
    project_velocities(chain.bodies(), chain.joints);
    const double e0 = kinetic_energy(chain.cluster);
    IntegratorOptions o;
    o.method = Method::ExplicitRk;
    o.rtol = 1e-9;
    o.atol = 1e-11;
    ClusterIntegrator integ(chain.cluster, 0.0, o, chain.joints);
    const HeldDihedral& d = chain.joints.dihedrals[0];
    double worst_dev = 0.0, worst_res = 0.0, worst_e = 0.0;
    int flips = 0;
    bool trans_side = false;
    for (int i = 1; i <= 1000; ++i) {
      const AdvanceResult r = integ.advance_to(0.05 * i);
      ASSERT_TRUE(r.ok()) << "seed " << seed << ": " << r.reason;
      const auto& b = integ.state().bodies;
      worst_res = std::max(worst_res, max_abs(joint_residual(b, chain.joints)));
      const Vec3 u = b[d.linker].axis();
      const Vec3 n0 = outward_axis(b[d.nb0].axis(), d.nb0_end), n1 = outward_axis(b[d.nb1].axis(), d.nb1_end);
      const double sa = u.cross(n0).norm(), sb = u.cross(n1).norm();
      closest = std::min(closest, std::min(sa, sb));
      if (sa > 0.1 && sb > 0.1) {
        const double phi = *dihedral_deg(u, n0, n1) * kPi / 180.0;
        const double dev = std::remainder(phi - d.phi0, kPi);  // 0 on either branch
        worst_dev = std::max(worst_dev, std::abs(dev));
        const bool t = std::abs(std::remainder(phi - d.phi0, 2.0 * kPi)) > 0.5 * kPi;
        if (i > 1 && t != trans_side) ++flips;
        trans_side = t;
      }
      integ.project_onto_joints(1e-10);
      worst_e = std::max(worst_e, std::abs(kinetic_energy(integ.state()) - e0) / e0);
    }
    std::printf("seed %d: |C| before projections <= %.2e, dihedral off its branch <= %.2e rad, %d cis/trans "
                "flips, dE/E %.2e, %ld steps\n",
                seed, worst_res, worst_dev, flips, worst_e, integ.stats().steps);
    EXPECT_LT(worst_res, 1e-8);
    EXPECT_LT(worst_dev, 1e-7);
    EXPECT_LT(worst_e, 1e-6);
  }
  std::printf("closest neighbour to the axis: sine %.3g\n", closest);
  EXPECT_LT(closest, 0.05);  // the singular pose of phi - phi0 was reached
}

}  // namespace
}  // namespace ringsim
