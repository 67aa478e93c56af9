// Articulated bonds inside the event loop (bonding.joint = articulated;
// docs/ARTICULATED.md, "In the event loop"): a four-corner Scenario 1 chain
// closing into the square by a capture inside its own cluster at the time an
// independent integration of the same constrained system finds; a rigid
// cluster (no internal freedom) moving as the welded code's rigid body;
// conservation, no overlap and no energy gain in validation mode while
// spheres strike a floppy chain; and the welded reading unchanged.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "body_builder.hpp"
#include "core/cluster.hpp"
#include "core/compliant_integrator.hpp"
#include "core/geometry.hpp"
#include "core/joint_projection.hpp"
#include "core/joints.hpp"
#include "core/pose.hpp"
#include "core/simulation.hpp"
#include "core/validation.hpp"

namespace ringsim {
namespace {

using test::Init;
using test::make_bodies;

SimParams articulated_params(bool filters) {
  SimParams p;
  p.geometry.box_length = 40.0;
  p.init.spheres = 0;
  p.init.linkers = 0;
  p.bonding.enabled = true;
  p.bonding.angle_filter = filters;
  p.bonding.coplanarity_filter = filters;
  p.bonding.joint = BondJoint::Articulated;
  p.compliant.rtol = 1e-10;
  p.compliant.atol = 1e-12;
  p.run.t_max = 30.0;
  p.run.steady_state = false;
  return p;
}

// The open square S0 L0 S1 L1 S2 L2 S3 L3 (bond gaps 0.05 < r_c, so seven
// bonds form at t = 0) with L3 turned in the plane by turn_deg about S3,
// away from S0, and turning back towards it at rate w about S3.
std::vector<Init> open_square(double turn_deg, double w) {
  const double g = 0.05, side = 4.0 + 2.0 * (1.0 + g);
  const Vec3 o(15, 15, 20);
  const Vec3 S[4] = {o, o + Vec3(side, 0, 0), o + Vec3(side, side, 0), o + Vec3(0, side, 0)};
  std::vector<Init> init;
  for (int k = 0; k < 4; ++k) init.push_back({Shape::Sphere, S[k], Vec3::Zero(), Vec3::UnitZ(), Vec3::Zero()});
  for (int k = 0; k < 4; ++k) {
    const Vec3 a = S[k], b = S[(k + 1) % 4];
    Vec3 axis = (a - b).normalized();  // end 0 (x + h u) faces S_k
    Vec3 centre = 0.5 * (a + b);
    Vec3 v = Vec3::Zero(), omega = Vec3::Zero();
    if (k == 3) {
      const Eigen::AngleAxisd R(-turn_deg * M_PI / 180.0, Vec3::UnitZ());
      centre = a + R * (centre - a);
      axis = R * axis;
      omega = Vec3(0, 0, w);
      v = omega.cross(centre - a);
    }
    init.push_back({Shape::Linker, centre, v, axis, omega});
  }
  return init;
}

// The capture gap of sphere s to linker l's end e (end face, core/geometry.hpp).
double face_gap(const std::vector<CompliantBody>& b, int s, int l, int e) {
  const Vec3 u = b[l].axis();
  const Vec3 n = e == 0 ? u : Vec3(-u);
  return geom::point_disk_distance(b[s].x, b[l].x + b[l].half_length * n, n, b[l].radius) - b[s].radius;
}

TEST(ArticulatedChain, ClosesIntoTheSquareAtTheIndependentlyIntegratedTime) {
  const SimParams p = articulated_params(false);  // Scenario 1: valency only
  const std::vector<Init> init = open_square(25.0, 0.4);
  Simulation sim(p, make_bodies(p, init));
  ASSERT_EQ(sim.stats().bonds, 7);
  ASSERT_EQ(sim.graph().N_t(), 1);
  Validator v(sim);
  sim.set_validator(&v);
  while (sim.stats().bonds < 8 && sim.step()) {
  }
  ASSERT_NE(sim.termination(), Termination::Error) << sim.error();
  ASSERT_EQ(sim.stats().bonds, 8) << "t = " << sim.time();
  const double t_loop = sim.time();
  const Observables obs = sim.graph().observables(t_loop);
  EXPECT_EQ(obs.N_tar, 1);
  EXPECT_EQ(v.report().overlaps, 0);
  EXPECT_EQ(v.report().missed_captures, 0);
  EXPECT_LT(v.report().max_momentum_error, 1e-12);

  // Reference: the same bodies and joints built by hand (the seven bonds in
  // the order of the chain; ball joints only, so the order does not matter),
  // the bond impulse, then one integration without the event loop, sampled
  // finely and bisected where S0's gap to L3's free end (end 1) falls
  // through r_c.
  CompliantCluster c;
  c.params = p.compliant;
  const BodyStore b0 = make_bodies(p, init);
  for (int i = 0; i < 8; ++i) c.bodies.push_back(compliant_body_from(b0.kin[i], b0.sp(i)));
  JointSet joints;
  CompliantCluster topo = c;
  for (int k = 0; k < 4; ++k) {
    add_articulated_bond(topo, joints, k, 4 + k, 0, p.bonding);
    if (k < 3) add_articulated_bond(topo, joints, k + 1, 4 + k, 1, p.bonding);
  }
  project_velocities(c.bodies, joints);
  IntegratorOptions o;
  o.method = Method::ExplicitRk;
  o.rtol = 1e-12;
  o.atol = 1e-14;
  o.max_steps = 1000000;
  ClusterIntegrator integ(c, 0.0, o, joints);
  const double rc = p.bonding.capture_distance;
  auto gap_at = [&](double t) {
    ClusterIntegrator fresh(integ.state(), integ.time(), o, joints);
    EXPECT_TRUE(fresh.advance_to(t).ok());
    return face_gap(fresh.state().bodies, 0, 7, 1);
  };
  ASSERT_GT(face_gap(integ.state().bodies, 0, 7, 1), rc);
  double lo = 0.0, hi = -1.0;
  for (double t = 0.01; t < 30.0; t += 0.01) {
    const double before = integ.time();
    ASSERT_TRUE(integ.advance_to(t).ok());
    if (face_gap(integ.state().bodies, 0, 7, 1) <= rc) {
      lo = before;
      hi = t;
      break;
    }
  }
  ASSERT_GT(hi, 0.0) << "the reference never closes";
  // Bisection from the state at the last sample before the crossing.
  ClusterIntegrator back(c, 0.0, o, joints);
  ASSERT_TRUE(back.advance_to(lo).ok());
  integ = std::move(back);
  for (int it = 0; it < 40; ++it) {
    const double mid = 0.5 * (lo + hi);
    (gap_at(mid) <= rc ? hi : lo) = mid;
  }
  std::printf("closure: event loop t = %.10f, reference t = %.10f (difference %.1e)\n", t_loop, hi,
              std::abs(t_loop - hi));
  EXPECT_NEAR(t_loop, hi, 1e-6);
}

TEST(ArticulatedChain, RigidClusterMovesAsTheWeldedRigidBody) {
  // Scenario 4's rules. A sphere and a linker bonded at t = 0: the ball
  // joint leaves no internal freedom, so the pair is one rigid body from its
  // formation (no integrator), with the motion merge_groups gives the same
  // two bodies (spheres as point masses: their smooth spins are held aside).
  SimParams p = articulated_params(true);
  p.run.t_max = 20.0;
  const double g = 0.05;
  const std::vector<Init> init = {
      {Shape::Sphere, Vec3(18, 20, 20), Vec3(0.3, 0.1, -0.2), Vec3::UnitZ(), Vec3(0.4, -0.2, 0.3)},
      // A free sphere and a free linker at rest far away: a bond stays
      // possible, so the run goes on to t_max.
      {Shape::Sphere, Vec3(4, 4, 4), Vec3::Zero(), Vec3::UnitZ(), Vec3::Zero()},
      {Shape::Linker, Vec3(18 + 1 + g + 2, 20.3, 20), Vec3(-0.2, 0.2, 0.1), -Vec3::UnitX(), Vec3(0.3, 0.5, -0.7)},
      {Shape::Linker, Vec3(35, 35, 35), Vec3::Zero(), Vec3::UnitZ(), Vec3::Zero()}};
  Simulation sim(p, make_bodies(p, init));
  ASSERT_EQ(sim.stats().bonds, 1);
  EXPECT_EQ(sim.stats().joint_rigid, 1);
  EXPECT_EQ(sim.stats().joint_articulated, 0);
  ASSERT_EQ(sim.run(), Termination::TimeLimit) << sim.error();
  EXPECT_EQ(sim.stats().slices, 0);  // never integrated
  EXPECT_EQ(sim.stats().wall_collisions, 0);
  const Simulation::ClusterShare share = sim.cluster_share();
  EXPECT_EQ(share.rigid, 1);
  EXPECT_EQ(share.rigid_bodies, 2);
  EXPECT_EQ(share.articulated, 0);

  BodyStore ref = make_bodies(p, init);
  ref.free_all();
  set_angular_velocity(ref.kin[0], ref.sp(0), Vec3::Zero());  // the sphere's own spin: held aside
  const Box box{p.geometry.box_length, false};
  merge_groups(ref, box, 0, 2, 0.0, false);  // sphere 0, linker 2 (ids: spheres first)
  for (int i : {0, 2}) {
    const double t = sim.time();
    EXPECT_LT((body_center(sim.bodies(), i, t) - body_center(ref, i, t)).norm(), 1e-12) << "body " << i;
    if (i == 2) EXPECT_LT((body_axis(sim.bodies(), i, t) - body_axis(ref, i, t)).norm(), 1e-12);
  }
}

TEST(ArticulatedChain, StruckChainKeepsMomentaAndNeverOverlaps) {
  // An L-S-L chain (Scenario 1: three internal degrees of freedom) bonded at
  // t = 0, with spheres thrown at it and the walls around: contacts on the
  // chain are solved with its joint impulses. Validation mode checks every
  // event: no overlap, no missed capture, momentum kept by every impulse
  // (walls take theirs, counted), energy never above its start.
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    SimParams p = articulated_params(false);
    p.geometry.box_length = 16.0;
    p.bonding.sphere_valency = 2;
    p.run.t_max = 40.0;
    std::mt19937_64 gen(seed);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    const double g = 0.05;
    const Vec3 s(8, 8, 8);
    std::vector<Init> init = {{Shape::Sphere, s, Vec3::Zero(), Vec3::UnitZ(), Vec3::Zero()}};
    // Spare spheres at valency 0 would still bond; thrown spheres are
    // ordinary ones, so captures may happen too.
    for (int k = 0; k < 4; ++k)
      init.push_back({Shape::Sphere, Vec3(2.5 + 11 * (k % 2), 2.5 + 11 * (k / 2), 2.5 + 11 * (k % 2)),
                      Vec3(U(gen), U(gen), U(gen)), Vec3::UnitZ(), Vec3::Zero()});
    init.push_back({Shape::Linker, s + Vec3(1 + g + 2, 0, 0), Vec3(0.2 * U(gen), 0.2 * U(gen), 0.2 * U(gen)),
                    -Vec3::UnitX(), Vec3(0.5 * U(gen), 0.5 * U(gen), 0.5 * U(gen))});
    init.push_back({Shape::Linker, s + Vec3(0, 1 + g + 2, 0), Vec3(0.2 * U(gen), 0.2 * U(gen), 0.2 * U(gen)),
                    -Vec3::UnitY(), Vec3(0.5 * U(gen), 0.5 * U(gen), 0.5 * U(gen))});
    Simulation sim(p, make_bodies(p, init));
    ASSERT_EQ(sim.stats().bonds, 2);
    EXPECT_EQ(sim.stats().joint_articulated, 1);
    EXPECT_EQ(sim.cluster_share().articulated, 1);
    EXPECT_EQ(sim.cluster_share().articulated_bodies, 3);
    EXPECT_EQ(sim.cluster_share().rigid, 0);
    Validator v(sim);
    sim.set_validator(&v);
    const Termination term = sim.run();
    ASSERT_NE(term, Termination::Error) << sim.error();
    const ValidationReport r = v.report();
    EXPECT_EQ(r.overlaps, 0) << "seed " << seed << ": first overlap at t = " << r.first_overlap_time;
    EXPECT_EQ(r.missed_captures, 0) << "seed " << seed;
    EXPECT_LT(r.max_momentum_error, 1e-12) << "seed " << seed;
    EXPECT_GT(sim.stats().collisions + sim.stats().wall_collisions, 10) << "seed " << seed;
    const EnergyBudget e = sim.energy_budget();
    EXPECT_LE(e.kinetic, e.initial * (1.0 + 1e-8)) << "seed " << seed;
    EXPECT_GE(e.joint_impulses, 0.0);
    std::printf("seed %lu: collisions %ld, walls %ld, bonds %ld, slices %ld, cuts %ld, dL %.1e, "
                "ledger rest %.1e of %.3f, joint residual %.1e\n",
                (unsigned long)seed, (long)sim.stats().collisions, (long)sim.stats().wall_collisions,
                (long)sim.stats().bonds, (long)sim.stats().slices, (long)sim.stats().slice_cuts,
                r.max_angular_momentum_error, e.dampers, e.initial, sim.stats().joint_residual);
  }
}

// Two linkers on one sphere (an L-S-L chain of Scenario 1, bond angle free)
// folding towards each other about the sphere. With the default 1-3
// exclusions (MODEL.md, "Contacts") they never collide: the fold carries one
// through the other. With bonding.exclusions = 1-2 they collide as hard
// bodies, their contact solved with the joint impulses: the validator, which
// then checks the pair, finds no overlap, and the impulses add no energy.
TEST(ArticulatedChain, LinkersOnOneSphereCollideOnlyWithOneTwoExclusions) {
  auto fold = [](Exclusions ex) {
    SimParams p = articulated_params(false);
    p.geometry.box_length = 16.0;
    p.bonding.exclusions = ex;
    p.run.t_max = 6.0;
    const double g = 0.05, w = 0.5, arm = 1 + g + 2;
    const Vec3 s(8, 8, 8);
    const std::vector<Init> init = {
        {Shape::Sphere, s, Vec3::Zero(), Vec3::UnitZ(), Vec3::Zero()},
        // A spare sphere at rest in a corner: a bond stays possible, so the
        // run goes on to t_max.
        {Shape::Sphere, Vec3(2, 2, 14), Vec3::Zero(), Vec3::UnitZ(), Vec3::Zero()},
        {Shape::Linker, s + Vec3(arm, 0, 0), Vec3(0, arm * w, 0), -Vec3::UnitX(), Vec3(0, 0, w)},
        {Shape::Linker, s + Vec3(0, arm, 0), Vec3(arm * w, 0, 0), -Vec3::UnitY(), Vec3(0, 0, -w)}};
    Simulation sim(p, make_bodies(p, init));
    EXPECT_EQ(sim.stats().bonds, 2);
    Validator v(sim);
    sim.set_validator(&v);
    EXPECT_NE(sim.run(), Termination::Error) << sim.error();
    const ValidationReport r = v.report();
    EXPECT_EQ(r.overlaps, 0) << to_string(ex);
    EXPECT_LT(r.max_momentum_error, 1e-12) << to_string(ex);
    // The impulses never add energy (elastic contacts: zero to rounding);
    // the ledger's rest is the tracks' error at the cuts (measured 1.8e-8
    // and 1.5e-7 of the initial energy).
    const EnergyBudget e = sim.energy_budget();
    EXPECT_GE(e.contacts, -1e-12 * e.initial) << to_string(ex);
    EXPECT_GE(e.joint_impulses, -1e-12 * e.initial) << to_string(ex);
    EXPECT_LT(std::abs(e.dampers), 1e-6 * e.initial) << to_string(ex);
    std::printf("exclusions %s: collisions %ld, walls %ld, kinetic %.9f of %.9f, contacts %.2e, joint impulses %.2e, projections %.2e, rest %.2e\n", to_string(ex),
                (long)sim.stats().collisions, (long)sim.stats().wall_collisions, e.kinetic, e.initial, e.contacts, e.joint_impulses, e.projections, e.dampers);
    return sim.stats().collisions;
  };
  EXPECT_EQ(fold(Exclusions::OneThree), 0);
  EXPECT_GE(fold(Exclusions::OneTwo), 1);
}

// A closed triangle under Scenario 3's rules (coplanarity only): three
// spheres, three linkers, six bonds at t = 0, each linker's dihedral held.
// In a planar triangle the three dihedrals are nearly one function of the
// linkers' rolls (exactly, with the anchors on the axes; here the axes are
// tilted by up to 1 degree): the ring is not rigid (one roll mechanism
// leaves them all unchanged to first order), and the rows nearly implied by
// the others (kHoldSine2) are released, held, they would take multipliers
// ~ 1 / sine^2 (seen before: the integrator's steps collapsing, or a joint
// left 1.5e-2 apart). Checked: the run ends without error, every projection
// converges, a released dihedral never leaves the filter's window about its
// held value (C = |a||b| sin(phi - phi0) with |a||b| = sin^2 60 for a
// triangle), no overlap, momentum kept.
TEST(ArticulatedChain, ClosedTriangleWithHeldDihedralsRunsThrough) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    SimParams p = articulated_params(false);
    p.bonding.coplanarity_filter = true;
    p.geometry.box_length = 24.0;
    p.run.t_max = 60.0;
    std::mt19937_64 gen(seed);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    const double g = 0.05, arm = 1 + g + 2;
    const Vec3 o(12, 12, 12);
    Vec3 S[3];
    for (int k = 0; k < 3; ++k) {
      const double a = 2.0 * M_PI * k / 3.0;
      S[k] = o + (2.0 * arm / std::sqrt(3.0)) * Vec3(std::cos(a), std::sin(a), 0.0);
    }
    std::vector<Init> init;
    for (int k = 0; k < 3; ++k) init.push_back({Shape::Sphere, S[k], Vec3::Zero(), Vec3::UnitZ(), Vec3::Zero()});
    for (int k = 0; k < 3; ++k) {
      const Vec3 a = S[k], b = S[(k + 1) % 3];
      // Each axis tilted out of the plane by up to 1 degree about the side's
      // in-plane normal (so the anchors are off the axes and the line
      // through them is not parallel to it: the rolls move the axes), with
      // random velocities and spins: the ring tumbles and its linkers roll.
      const Vec3 side = (a - b).normalized();
      const Eigen::AngleAxisd tilt(0.0175 * U(gen), side.cross(Vec3::UnitZ()));
      const Vec3 axis = tilt * side;  // end 0 faces S_k
      init.push_back({Shape::Linker, 0.5 * (a + b), Vec3(0.2 * U(gen), 0.2 * U(gen), 0.2 * U(gen)), axis,
                      Vec3(0.6 * U(gen), 0.6 * U(gen), 0.6 * U(gen))});
    }
    // A spare sphere and a spare linker at rest in two corners: a bond stays
    // possible, so the run goes on to t_max.
    init.insert(init.begin() + 3, {Shape::Sphere, Vec3(2, 2, 2), Vec3::Zero(), Vec3::UnitZ(), Vec3::Zero()});
    init.push_back({Shape::Linker, Vec3(20, 20, 20), Vec3::Zero(), Vec3::UnitZ(), Vec3::Zero()});
    Simulation sim(p, make_bodies(p, init));
    ASSERT_EQ(sim.stats().bonds, 6) << "seed " << seed;
    ASSERT_EQ(sim.graph().observables(0.0).N_cyc, 1) << "seed " << seed;
    Validator v(sim);
    sim.set_validator(&v);
    const Termination term = sim.run();
    ASSERT_NE(term, Termination::Error) << "seed " << seed << ": " << sim.error();
    const RunStats& s = sim.stats();
    const ValidationReport r = v.report();
    std::printf("seed %lu: dropped %ld (released later %ld, readmitted %ld), released rows strayed %.1e, "
                "residual before projection %.1e, after %.1e, slices %ld\n",
                (unsigned long)seed, (long)s.dropped_rows, (long)s.released_rows, (long)s.readmitted_rows,
                s.released_residual, s.joint_residual, s.joint_residual_after, (long)s.slices);
    EXPECT_GE(s.dropped_rows, 1) << "seed " << seed;
    EXPECT_GT(s.slices, 100) << "seed " << seed;
    EXPECT_LT(s.joint_residual_after, 1e-8) << "seed " << seed;
    const double window = 0.75 * std::sin(p.bonding.dphi_deg * M_PI / 180.0);
    EXPECT_LT(s.released_residual, window) << "seed " << seed;
    EXPECT_EQ(r.overlaps, 0) << "seed " << seed;
    EXPECT_LT(r.max_momentum_error, 1e-12) << "seed " << seed;
  }
}

}  // namespace
}  // namespace ringsim
