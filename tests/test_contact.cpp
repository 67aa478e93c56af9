// Two-body collisions for each shape pair, through the whole event loop
// (prediction + contact law), against hand-derived post-collision velocities,
// plus momentum, angular momentum and (e = 1, smooth) energy conservation.
//
// Hand derivations use the collision matrix of core/contact.hpp: for an
// impulse j n through contact arms r_A, r_B the normal relative velocity
// changes by j K_n with
//   K_n = 1/m_A + 1/m_B + |r_A x n|^2 / I_A + |r_B x n|^2 / I_B
// (I the moment about the axis r x n; principal for the poses used here),
// so j = -(1 + e) u_n / K_n.

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <tuple>

#include "body_builder.hpp"
#include "core/contact.hpp"
#include "core/motion.hpp"
#include "core/scene.hpp"
#include "core/simulation.hpp"
#include "core/validation.hpp"

namespace ringsim {
namespace {

using test::Init;
using test::make_bodies;

SimParams two_body_params(double e, double mu_s = 0.0, double nu = 0.0) {
  SimParams p;
  p.bonding.enabled = false;  // hard-body contacts only
  p.geometry.box_length = 40.0;
  p.init.spheres = 0;
  p.init.linkers = 0;
  p.contact.restitution_sphere = p.contact.restitution_linker = e;
  p.contact.static_friction_sphere = p.contact.static_friction_linker = mu_s;
  p.contact.dynamic_friction_sphere = p.contact.dynamic_friction_linker = nu;
  p.contact.friction_rule = CombineRule::Min;  // keeps the pair's coefficient equal to the bodies'
  p.run.t_max = 50.0;
  return p;
}

// Runs until the first body-body collision has been processed.
struct Outcome {
  std::vector<Vec3> v, omega;
  Validator::Totals before, after;
  double time;
};

Outcome collide_once(const SimParams& p, const std::vector<Init>& init) {
  Simulation sim(p, make_bodies(p, init));
  Outcome o;
  o.before = Validator::totals(sim, 0.0);
  while (sim.stats().collisions == 0) {
    EXPECT_EQ(sim.stats().wall_collisions, 0);
    if (!sim.step()) break;
  }
  EXPECT_EQ(sim.stats().collisions, 1);
  o.time = sim.time();
  o.after = Validator::totals(sim, sim.time());
  for (const auto& k : sim.bodies().kin) {
    o.v.push_back(k.v);
    o.omega.push_back(k.precession + k.spin * axis_at(k, sim.time()));
  }
  return o;
}

void expect_conserved(const Outcome& o, bool energy) {
  const double p_scale = o.before.p_scale, l_scale = o.before.l_scale;
  EXPECT_LT((o.after.momentum - o.before.momentum).norm(), 1e-12 * p_scale);
  EXPECT_LT((o.after.angular_momentum - o.before.angular_momentum).norm(), 1e-12 * l_scale);
  if (energy) EXPECT_NEAR(o.after.energy, o.before.energy, 1e-12 * o.before.energy);
  else EXPECT_LE(o.after.energy, o.before.energy * (1.0 + 1e-12));
}

void expect_vec_near(const Vec3& a, const Vec3& b, double tol) {
  EXPECT_NEAR(a.x(), b.x(), tol);
  EXPECT_NEAR(a.y(), b.y(), tol);
  EXPECT_NEAR(a.z(), b.z(), tol);
}

constexpr double kSphereMass = 4.0 / 3.0 * M_PI;
constexpr double kLinkerMass = 4.0 * M_PI;          // pi r^2 l, r = 1, l = 4
constexpr double kLinkerIperp = 19.0 * M_PI / 3.0;  // m (3 r^2 + l^2) / 12
// Contact-position tolerance: CA contacts fire at a gap <= 1e-9, which moves
// the contact arms by that much.
constexpr double kTol = 1e-8;

// Parameters: restitution, and run.sphere_candidates: 4 (the default) takes
// the sphere gas's own collision path (Simulation::collide_smooth_spheres),
// 0 the general solver of every other pair.
class SphereSphere : public ::testing::TestWithParam<std::tuple<double, int>> {
 protected:
  double e() const { return std::get<0>(GetParam()); }
  SimParams params() const {
    SimParams p = two_body_params(e());
    p.run.sphere_candidates = std::get<1>(GetParam());
    return p;
  }
};

TEST_P(SphereSphere, HeadOnExchangesNormalMomentum) {
  const double e = this->e();
  const SimParams p = params();
  const Outcome o = collide_once(p, {{Shape::Sphere, {15, 20, 20}, {1, 0, 0}, {0, 0, 1}, {0, 0, 0}},
                                     {Shape::Sphere, {25, 20, 20}, {-0.5, 0, 0}, {0, 0, 1}, {0, 0, 0}}});
  // Equal masses: v1' = ((1-e) v1 + (1+e) v2) / 2, v2' = ((1+e) v1 + (1-e) v2) / 2.
  expect_vec_near(o.v[0], {((1 - e) * 1.0 + (1 + e) * -0.5) / 2, 0, 0}, 1e-13);
  expect_vec_near(o.v[1], {((1 + e) * 1.0 + (1 - e) * -0.5) / 2, 0, 0}, 1e-13);
  EXPECT_NEAR(o.time, 8.0 / 1.5, 1e-12);  // gap 10 - 2 closed at relative speed 1.5
  expect_conserved(o, e == 1.0);
}

TEST_P(SphereSphere, ObliqueKeepsTangentialVelocity) {
  const double e = this->e();
  const SimParams p = params();
  // Offset 1 in y: contact normal (sqrt(3), 1, 0)/2 at touching distance 2.
  const Outcome o = collide_once(p, {{Shape::Sphere, {10, 20, 20}, {1, 0, 0}, {0, 0, 1}, {0, 0, 0}},
                                     {Shape::Sphere, {20, 21, 20}, {0, 0, 0}, {0, 0, 1}, {0, 0, 0}}});
  const Vec3 n = Vec3(std::sqrt(3.0), 1.0, 0.0) / 2.0;
  const double un = -n.x();  // relative normal velocity (v2 - v1).n
  const double j = -(1 + e) * un / (2.0 / kSphereMass);
  expect_vec_near(o.v[0], Vec3(1, 0, 0) - j / kSphereMass * n, 1e-12);
  expect_vec_near(o.v[1], j / kSphereMass * n, 1e-12);
  expect_conserved(o, e == 1.0);
}

INSTANTIATE_TEST_SUITE_P(Restitution, SphereSphere,
                         ::testing::Combine(::testing::Values(1.0, 0.5, 0.0), ::testing::Values(4, 0)));

TEST(SphereSphereFriction, StickingZeroesTangentialSlip) {
  // Identical spheres, mu large enough to stick: tangential impulse m u_t / 7
  // (K_t = 2/m + 2 r^2 / I = 7/m with I = 2/5 m r^2), normal (1+e) m |u_n| / 2.
  const double e = 1.0;
  const SimParams p = two_body_params(e, 10.0, 10.0);
  const Outcome o = collide_once(p, {{Shape::Sphere, {10, 20, 20}, {1, 0, 0}, {0, 0, 1}, {0, 0, 0}},
                                     {Shape::Sphere, {20, 21, 20}, {0, 0, 0}, {0, 0, 1}, {0, 0, 0}}});
  const Vec3 n = Vec3(std::sqrt(3.0), 1.0, 0.0) / 2.0;
  const Vec3 u = Vec3(-1, 0, 0);  // relative velocity of B w.r.t. A at contact (no spin)
  const double un = u.dot(n);
  const Vec3 ut = u - un * n;
  const Vec3 J = -(1 + e) * un * kSphereMass / 2.0 * n - kSphereMass / 7.0 * ut;
  expect_vec_near(o.v[1], J / kSphereMass, 1e-12);
  expect_vec_near(o.v[0], Vec3(1, 0, 0) - J / kSphereMass, 1e-12);
  // Spin: omega = r x J / I for B (arm -n), and A (arm +n, impulse -J).
  const double I = 0.4 * kSphereMass;
  expect_vec_near(o.omega[1], (-n).cross(J) / I, 1e-12);
  expect_vec_near(o.omega[0], n.cross(-J) / I, 1e-12);
  // Sticking: no relative tangential velocity at the contact afterwards.
  const Vec3 ua = o.v[0] + o.omega[0].cross(n), ub = o.v[1] + o.omega[1].cross(-n);
  const Vec3 du = ub - ua;
  EXPECT_LT((du - du.dot(n) * n).norm(), 1e-12);
  EXPECT_NEAR(du.dot(n), -e * un, 1e-12);
  // Sticking with e = 1 still loses the tangential slip energy.
  EXPECT_LT(o.after.energy, o.before.energy);
  EXPECT_LT((o.after.momentum - o.before.momentum).norm(), 1e-12 * o.before.p_scale);
  EXPECT_LT((o.after.angular_momentum - o.before.angular_momentum).norm(), 1e-12 * o.before.l_scale);
}

TEST(SphereSphereFriction, SlidingUsesDynamicCoefficient) {
  // Sticking would need |J_t| / J_n = (2/7) (|u_t| / |u_n|) / (1 + e) = 0.0916
  // here, above mu_s = 0.05: the contact slides.
  const double e = 0.8, nu = 0.04;
  const SimParams p = two_body_params(e, 0.05, nu);
  const Outcome o = collide_once(p, {{Shape::Sphere, {10, 20, 20}, {1, 0, 0}, {0, 0, 1}, {0, 0, 0}},
                                     {Shape::Sphere, {20, 21, 20}, {0, 0, 0}, {0, 0, 1}, {0, 0, 0}}});
  const Vec3 n = Vec3(std::sqrt(3.0), 1.0, 0.0) / 2.0;
  const Vec3 u = Vec3(-1, 0, 0);
  const double un = u.dot(n);
  const Vec3 t = (u - un * n).normalized();
  // Tangential arm terms: n.K(n - nu t) = K_n since K t is along t for spheres.
  const double jn = -(1 + e) * un / (2.0 / kSphereMass);
  const Vec3 J = jn * (n - nu * t);
  expect_vec_near(o.v[1], J / kSphereMass, 1e-12);
  expect_conserved(o, false);
}

class SphereLinker : public ::testing::TestWithParam<double> {};

TEST_P(SphereLinker, HeadOnThroughCentre) {
  const double e = GetParam();
  const SimParams p = two_body_params(e);
  // Linker along z at the origin of the collision; sphere hits its side
  // midway: impulse through both centres, no torque.
  const Outcome o = collide_once(p, {{Shape::Sphere, {10, 20, 20}, {1, 0, 0}, {0, 0, 1}, {0, 0, 0}},
                                     {Shape::Linker, {20, 20, 20}, {0, 0, 0}, {0, 0, 1}, {0, 0, 0}}});
  const double ms = kSphereMass, ml = kLinkerMass;
  const double j = (1 + e) * 1.0 / (1 / ms + 1 / ml);
  expect_vec_near(o.v[0], {1 - j / ms, 0, 0}, 1e-10);
  expect_vec_near(o.v[1], {j / ml, 0, 0}, 1e-10);
  expect_vec_near(o.omega[1], Vec3::Zero(), 1e-10);
  EXPECT_NEAR(o.time, 8.0, 1e-8);  // gap 10 - 1 - 1, closes at speed 1 (CA fires within 1e-9)
  expect_conserved(o, e == 1.0);
}

TEST_P(SphereLinker, OffCentreSideHitSpinsTheLinker) {
  const double e = GetParam();
  const SimParams p = two_body_params(e);
  // Sphere at axial offset a = 1.5 from the linker centre.
  const double a = 1.5;
  const Outcome o = collide_once(p, {{Shape::Sphere, {10, 20, 20 + a}, {1, 0, 0}, {0, 0, 1}, {0, 0, 0}},
                                     {Shape::Linker, {20, 20, 20}, {0, 0, 0}, {0, 0, 1}, {0, 0, 0}}});
  const double ms = kSphereMass, ml = kLinkerMass;
  const double K = 1 / ms + 1 / ml + a * a / kLinkerIperp;
  const double j = (1 + e) * 1.0 / K;
  expect_vec_near(o.v[0], {1 - j / ms, 0, 0}, kTol);
  expect_vec_near(o.v[1], {j / ml, 0, 0}, kTol);
  // Torque about the linker centre: r x J with r = (-1, 0, a), J = (j, 0, 0): (0, a j, 0).
  expect_vec_near(o.omega[1], {0, a * j / kLinkerIperp, 0}, kTol);
  expect_conserved(o, e == 1.0);
}

TEST_P(SphereLinker, EndFaceHit) {
  const double e = GetParam();
  const SimParams p = two_body_params(e);
  // Sphere moving along -z onto the end face at radial offset 0.5 in x.
  const Outcome o = collide_once(p, {{Shape::Sphere, {20.5, 20, 30}, {0, 0, -1}, {0, 0, 1}, {0, 0, 0}},
                                     {Shape::Linker, {20, 20, 20}, {0, 0, 0}, {0, 0, 1}, {0, 0, 0}}});
  const double ms = kSphereMass, ml = kLinkerMass;
  const double K = 1 / ms + 1 / ml + 0.25 / kLinkerIperp;
  const double j = (1 + e) * 1.0 / K;
  expect_vec_near(o.v[0], {0, 0, -1 + j / ms}, kTol);
  expect_vec_near(o.v[1], {0, 0, -j / ml}, kTol);
  // r = (0.5, 0, 2), J on linker = (0, 0, -j): r x J = (0, 0.5 j, 0).
  expect_vec_near(o.omega[1], {0, 0.5 * j / kLinkerIperp, 0}, kTol);
  expect_conserved(o, e == 1.0);
}

INSTANTIATE_TEST_SUITE_P(Restitution, SphereLinker, ::testing::Values(1.0, 0.5));

class LinkerLinker : public ::testing::TestWithParam<double> {};

TEST_P(LinkerLinker, CrossedSidesThroughCentres) {
  const double e = GetParam();
  const SimParams p = two_body_params(e);
  // A along x, B along y, B above A: side-side contact on the line of centres.
  const Outcome o = collide_once(p, {{Shape::Linker, {20, 20, 15}, {0, 0, 1}, {1, 0, 0}, {0, 0, 0}},
                                     {Shape::Linker, {20, 20, 25}, {0, 0, -1}, {0, 1, 0}, {0, 0, 0}}});
  // Equal masses, head-on: v_A' = -e ... exchange scaled by restitution.
  expect_vec_near(o.v[0], {0, 0, ((1 - e) * 1.0 + (1 + e) * -1.0) / 2}, kTol);
  expect_vec_near(o.v[1], {0, 0, ((1 + e) * 1.0 + (1 - e) * -1.0) / 2}, kTol);
  expect_vec_near(o.omega[0], Vec3::Zero(), kTol);
  expect_conserved(o, e == 1.0);
}

TEST_P(LinkerLinker, CrossedSidesOffCentre) {
  const double e = GetParam();
  const SimParams p = two_body_params(e);
  // B displaced by a along A's axis: A is hit at axial offset a, B at its centre.
  const double a = 1.2;
  const Outcome o = collide_once(p, {{Shape::Linker, {20, 20, 15}, {0, 0, 1}, {1, 0, 0}, {0, 0, 0}},
                                     {Shape::Linker, {20 + a, 20, 25}, {0, 0, -1}, {0, 1, 0}, {0, 0, 0}}});
  const double m = kLinkerMass;
  const double K = 2 / m + a * a / kLinkerIperp;
  const double j = (1 + e) * 2.0 / K;  // approach speed 2
  expect_vec_near(o.v[0], {0, 0, 1 - j / m}, kTol);
  expect_vec_near(o.v[1], {0, 0, -1 + j / m}, kTol);
  // Torque on A: r = (a, 0, 1), J_A = (0, 0, -j): r x J = (0, a j, 0).
  expect_vec_near(o.omega[0], {0, a * j / kLinkerIperp, 0}, kTol);
  expect_vec_near(o.omega[1], Vec3::Zero(), kTol);
  expect_conserved(o, e == 1.0);
}

TEST_P(LinkerLinker, RotatingLinkerStrikesResting) {
  // No hand value here (the contact time depends on the rotation), but the
  // conservation laws must hold exactly through prediction and response.
  const double e = GetParam();
  const SimParams p = two_body_params(e);
  const Outcome o = collide_once(p, {{Shape::Linker, {20, 20, 20}, {0.3, 0, 0}, {1, 0, 0}, {0, 0, 1.5}},
                                     {Shape::Linker, {24, 23.5, 20}, {0, -0.2, 0.05}, {0, 0, 1}, {0.2, 0, 0}}});
  expect_conserved(o, e == 1.0);
}

INSTANTIATE_TEST_SUITE_P(Restitution, LinkerLinker, ::testing::Values(1.0, 0.5));

TEST(LinkerLinkerFriction, FrictionConservesMomentaAndDissipates) {
  for (const auto& mu : {std::pair{0.05, 0.03}, std::pair{5.0, 5.0}}) {
    const SimParams p = two_body_params(0.7, mu.first, mu.second);
    const Outcome o = collide_once(p, {{Shape::Linker, {20, 20, 15}, {0.4, 0.1, 1}, {1, 0, 0}, {0, 0.3, 0}},
                                       {Shape::Linker, {21, 20.5, 25}, {0, 0, -1}, {0, 1, 0.2}, {0.5, 0, 0}}});
    expect_conserved(o, false);
  }
}

// Newton's restitution with Coulomb friction can create energy where the
// collision matrix couples the normal and tangential directions (a spinning
// body on a rough wall: found by a validation sweep with mu_B = 3). Over
// random contacts of a spinning linker with a wall or another linker, every
// impulse keeps Newton's normal law, stays in the friction cone, and takes
// kinetic energy out (within rounding), never puts it in.
TEST(ContactLaw, FrictionNeverCreatesEnergy) {
  SimParams p;
  const Species sp = make_species(Shape::Linker, p);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u01(0.0, 1.0), u11(-1.0, 1.0);
  auto vec = [&](double scale) { return Vec3(scale * u11(rng), scale * u11(rng), scale * u11(rng)); };
  auto side = [&](bool wall) {
    if (wall) return ContactSide{0.0, Mat3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
    const Vec3 axis = vec(1.0).normalized();
    return ContactSide{1.0 / sp.mass, inverse_inertia(sp, axis), vec(2.0), vec(0.1), vec(200.0 * u01(rng))};
  };
  for (int trial = 0; trial < 20000; ++trial) {
    const ContactSide a = side(false), b = side(trial % 2 == 0);
    const ContactLaw law{trial % 3 == 0 ? 0.5 : 1.0, 3.0 * u01(rng), 3.0 * u01(rng)};
    Vec3 n = vec(1.0).normalized();
    const Vec3 u = relative_point_velocity(a, b);
    if (n.dot(u) > 0.0) n = -n;  // approaching
    const ContactResult r = solve_contact(a, b, n, law);
    // Kinetic energy of both bodies, the scale of the rounding.
    auto kinetic = [&](const ContactSide& s) {
      if (s.inv_mass == 0.0) return 0.0;
      return 0.5 * s.v.squaredNorm() / s.inv_mass + 0.5 * s.omega.dot(s.inv_inertia.inverse() * s.omega);
    };
    const double energy = kinetic(a) + kinetic(b);
    ASSERT_GE(r.energy_loss, -1e-12 * energy) << "trial " << trial;
    const double jn = r.impulse.dot(n), jt = (r.impulse - jn * n).norm();
    EXPECT_LE(jt, std::max(law.static_friction, law.dynamic_friction) * jn * (1.0 + 1e-12) + 1e-12 * jn);
    ContactSide a2 = a, b2 = b;
    a2.v -= a.inv_mass * r.impulse;
    a2.omega -= a.inv_inertia * a.arm.cross(r.impulse);
    b2.v += b.inv_mass * r.impulse;
    b2.omega += b.inv_inertia * b.arm.cross(r.impulse);
    EXPECT_NEAR(n.dot(relative_point_velocity(a2, b2)), -law.restitution * n.dot(u), 1e-9 * u.norm()) << "trial " << trial;
  }
}

TEST(ContactLaw, CombineRules) {
  EXPECT_DOUBLE_EQ(combine(CombineRule::Min, 0.3, 0.7), 0.3);
  EXPECT_DOUBLE_EQ(combine(CombineRule::Max, 0.3, 0.7), 0.7);
  EXPECT_DOUBLE_EQ(combine(CombineRule::Product, 0.3, 0.7), 0.21);
  EXPECT_DOUBLE_EQ(combine(CombineRule::Mean, 0.3, 0.7), 0.5);
}

TEST(WallContact, SphereReflectsWithWallRestitution) {
  SimParams p = two_body_params(1.0);
  p.contact.restitution_wall = 0.5;
  Simulation sim(p, make_bodies(p, {{Shape::Sphere, {20, 20, 20}, {1, 0, 0}, {0, 0, 1}, {0, 0, 0}}}));
  while (sim.stats().wall_collisions == 0 && sim.step()) {
  }
  EXPECT_NEAR(sim.time(), 19.0, 1e-12);  // reaches x = L - r = 39
  expect_vec_near(sim.bodies().kin[0].v, {-0.5, 0, 0}, 1e-15);
}

// run.min_separation_speed (ContactLaw::min_separation): a contact met at a
// normal speed far below the floor leaves at the floor, by a normal top-up
// whose energy is exactly (u'^2 - u^2) / (2 K_nn); ordinary contacts are
// untouched; the floor off gives Newton's law.
TEST(ContactFloor, TopsUpATinySeparationSpeedAndLeavesOrdinaryContactsAlone) {
  const Vec3 n = Vec3::UnitZ();
  Mat3 ia = Mat3::Identity() * 2.5, ib = Mat3::Identity() * 0.8;
  ib(0, 1) = ib(1, 0) = 0.1;
  const ContactSide a0{1.0, ia, Vec3(0.3, -0.2, 0.5), Vec3(0.1, 0.0, 0.0), Vec3(0.0, 0.2, 0.0)};
  auto kinetic = [&](const ContactSide& a, const ContactSide& b, const Vec3& J) {
    // kinetic energy of the two bodies (the sides' inverse mass and inertia)
    // after the impulse J on B and -J on A
    const Vec3 va = a.v - a.inv_mass * J, vb = b.v + b.inv_mass * J;
    const Vec3 wa = a.omega - a.inv_inertia * a.arm.cross(J), wb = b.omega + b.inv_inertia * b.arm.cross(J);
    auto e = [](double im, const Mat3& ii, const Vec3& v, const Vec3& w) {
      return 0.5 * v.squaredNorm() / im + 0.5 * w.dot(ii.inverse() * w);
    };
    return e(a.inv_mass, a.inv_inertia, va, wa) + e(b.inv_mass, b.inv_inertia, vb, wb);
  };
  auto normal_speed = [&](const ContactSide& a, const ContactSide& b, const Vec3& J) {
    const Vec3 ua = a.v - a.inv_mass * J + (a.omega - a.inv_inertia * a.arm.cross(J)).cross(a.arm);
    const Vec3 ub = b.v + b.inv_mass * J + (b.omega + b.inv_inertia * b.arm.cross(J)).cross(b.arm);
    return n.dot(ub - ua);
  };
  for (const double un : {-1e-12, -3e-7, -1.0}) {
    // B's centre velocity chosen so that the contact's normal speed is un
    ContactSide b{0.5, ib, Vec3(-0.1, 0.4, -0.5), Vec3::Zero(), Vec3(0.1, 0.0, 0.3)};
    b.v.z() += un - normal_speed(a0, b, Vec3::Zero());
    ASSERT_NEAR(normal_speed(a0, b, Vec3::Zero()), un, 1e-15);
    const ContactResult newton = solve_contact(a0, b, n, ContactLaw{1.0, 0.0, 0.0, 0.0});
    EXPECT_FALSE(newton.floored);
    EXPECT_NEAR(normal_speed(a0, b, newton.impulse), -un, 1e-15);
    const ContactResult r = solve_contact(a0, b, n, ContactLaw{1.0, 0.0, 0.0, 1e-6});
    const double after = normal_speed(a0, b, r.impulse);
    if (-un < 1e-6) {
      EXPECT_TRUE(r.floored) << un;
      EXPECT_NEAR(after, 1e-6, 1e-15) << un;
      const double e0 = kinetic(a0, b, Vec3::Zero()), e1 = kinetic(a0, b, r.impulse);
      const double knn = r.impulse.norm() / (after - un);  // j = (u' - u) / K_nn
      // (a difference of two O(1) energies: rounding ~1e-16 each)
      EXPECT_NEAR(e1 - e0, (after * after - un * un) / (2.0 / knn), 1e-15) << un;
      EXPECT_LT(e1 - e0, 1e-11);
    } else {
      EXPECT_FALSE(r.floored);
      EXPECT_NEAR(after, -un, 1e-12);
      EXPECT_EQ(r.impulse, newton.impulse);
    }
  }
}

}  // namespace
}  // namespace ringsim
