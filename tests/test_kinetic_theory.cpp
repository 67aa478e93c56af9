// Kinetic theory checks of the event-driven dynamics (physics label).
//
//  - HardSphereGas.CollisionFrequencyMatchesEnskog: the per-particle collision
//    frequency of an elastic hard-sphere gas against Enskog's
//        Gamma_E = 4 n sigma^2 g(sigma) sqrt(pi k T / m)
//    (Enskog 1922; Chapman & Cowling, "The Mathematical Theory of Non-Uniform
//    Gases", ch. 16), with the Carnahan-Starling contact value
//    g(sigma) = (1 - eta/2) / (1 - eta)^3 (Carnahan & Starling, J. Chem.
//    Phys. 51, 635 (1969)). In equilibrium the relation is exact given the
//    true contact value (pre-collision velocities are Maxwellian and
//    uncorrelated with positions); Carnahan-Starling is within ~0.1-0.5 % of
//    the simulated contact value for eta <= 0.2, and finite N adds O(1/N).
//  - HardSphereGas.EnergyAndMomentumExactlyConserved: elastic smooth spheres
//    in a periodic box conserve kinetic energy and momentum to rounding.
//  - LinkerGas.EquipartitionTranslationTumbling: a gas of smooth hard
//    cylinders started far from equipartition relaxes to equal energy per
//    degree of freedom in translation (3) and tumbling (2).
//  - LinkerGas.SpinAboutAxisConservedBySmoothContacts: the spin omega . u of
//    every linker is a constant of the motion for smooth contacts (every
//    contact normal of a cylinder of revolution lies in a plane containing its
//    axis, so no impulse has a moment about the axis); checked to 1e-9.
//
// Runs: fixed seeds, deterministic. Measured (Release, one core): Enskog
// ~3 s, conservation 0.1 s, equipartition ~25-50 s, spin ~1-2 s.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "core/body.hpp"
#include "core/motion.hpp"
#include "core/params.hpp"
#include "core/scene.hpp"
#include "core/simulation.hpp"
#include "ensemble/config.hpp"

namespace ringsim {
namespace {

constexpr double kPi = 3.14159265358979323846;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Periodic elastic smooth gas settings: no walls, no friction, no dissipation.
SimParams gas_params(int spheres, int linkers, double box_length) {
  SimParams p;
  p.bonding.enabled = false;  // hard-body gas
  p.geometry.boundary = Boundary::Periodic;
  p.geometry.box_length = box_length;
  p.contact = ContactParams{};  // restitution 1, friction 0 everywhere
  p.init.spheres = spheres;
  p.init.linkers = linkers;
  p.init.alpha = 1.0;
  p.run.t_max = 1e12;  // the tests stop the runs themselves
  p.run.max_events = 0;
  validate(p);
  return p;
}

// Box edge giving packing fraction eta for n bodies of volume v each.
double box_for(int n, double body_volume, double eta) { return std::cbrt(n * body_volume / eta); }

Vec3 total_momentum(const BodyStore& b) {
  Vec3 P = Vec3::Zero();
  for (int i = 0; i < b.size(); ++i) P += b.sp(i).mass * b.kin[i].v;
  return P;
}

double total_mass(const BodyStore& b) {
  double M = 0.0;
  for (int i = 0; i < b.size(); ++i) M += b.sp(i).mass;
  return M;
}

// Translational kinetic energy in the centre-of-mass frame.
double peculiar_translational_energy(const BodyStore& b) {
  const Vec3 V = total_momentum(b) / total_mass(b);
  double e = 0.0;
  for (int i = 0; i < b.size(); ++i) e += 0.5 * b.sp(i).mass * (b.kin[i].v - V).squaredNorm();
  return e;
}

// ---------------------------------------------------------------------------
// Hard spheres

struct EnskogResult {
  double gamma, gamma_e, kT, collisions, seconds;
};

EnskogResult measure_collision_frequency(double eta, int n, std::uint64_t seed, std::int64_t window_collisions) {
  const auto wall0 = std::chrono::steady_clock::now();
  const double r = 1.0, sigma = 2.0 * r;
  const double L = box_for(n, 4.0 / 3.0 * kPi * r * r * r, eta);
  SimParams p = gas_params(n, 0, L);
  p.init.velocity = VelocityInit::Thermal;
  p.init.temperature = 1.0;
  SceneReport rep;
  Simulation sim(p, build_scene(p, seed, 0, &rep));
  EXPECT_NEAR(rep.packing_fraction, eta, 1e-9 * eta);
  const double m = sim.bodies().species[0].mass;

  // Temperature from the peculiar kinetic energy: 3 (N - 1) degrees of
  // freedom once the total momentum is fixed. Elastic collisions keep it.
  const double kT = 2.0 * peculiar_translational_energy(sim.bodies()) / (3.0 * (n - 1));

  // Equilibrate for 10 collisions per particle (5 N collisions, each involving
  // two particles): the velocities are Maxwellian from the start, and the
  // random sequential placement relaxes to the equilibrium structure within a
  // few collisions per particle at these densities.
  const std::int64_t equil = 5 * n;
  while (sim.stats().collisions < equil) {
    if (!sim.step()) {
      ADD_FAILURE() << "stopped: " << to_string(sim.termination()) << " " << sim.error();
      return {};
    }
  }
  const double t0 = sim.time();
  const std::int64_t c0 = sim.stats().collisions;
  while (sim.stats().collisions - c0 < window_collisions) {
    if (!sim.step()) {
      ADD_FAILURE() << "stopped: " << to_string(sim.termination()) << " " << sim.error();
      break;
    }
  }
  const double t1 = sim.time();
  const double c = static_cast<double>(sim.stats().collisions - c0);
  const double kT_end = 2.0 * peculiar_translational_energy(sim.bodies()) / (3.0 * (n - 1));
  EXPECT_NEAR(kT_end / kT, 1.0, 1e-12);

  const double nd = n / (L * L * L);
  const double g = (1.0 - 0.5 * eta) / std::pow(1.0 - eta, 3);
  EnskogResult res;
  res.gamma = 2.0 * c / (n * (t1 - t0));
  res.gamma_e = 4.0 * nd * sigma * sigma * g * std::sqrt(kPi * kT / m);
  res.kT = kT;
  res.collisions = c;
  res.seconds = seconds_since(wall0);
  return res;
}

TEST(HardSphereGas, CollisionFrequencyMatchesEnskog) {
  struct Case {
    double eta;
    int n;
    std::uint64_t seed;
  };
  for (const Case& cs : {Case{0.05, 1000, 11}, Case{0.2, 1000, 12}}) {
    const EnskogResult r = measure_collision_frequency(cs.eta, cs.n, cs.seed, 500000);
    const double ratio = r.gamma / r.gamma_e;
    std::printf("[ Enskog ] eta=%.2f N=%d kT=%.4f collisions=%.0f Gamma=%.6f Gamma_E=%.6f ratio=%.5f (%.1f s)\n",
                cs.eta, cs.n, r.kT, r.collisions, r.gamma, r.gamma_e, ratio, r.seconds);
    // 5e5 collisions: Poisson error 0.14 %, well below the 3 % tolerance.
    EXPECT_GE(r.collisions, 1e5);
    EXPECT_NEAR(ratio, 1.0, 0.03) << "eta = " << cs.eta;
  }
}

TEST(HardSphereGas, EnergyAndMomentumExactlyConserved) {
  const int n = 500;
  const double eta = 0.15;
  SimParams p = gas_params(n, 0, box_for(n, 4.0 / 3.0 * kPi, eta));
  p.init.velocity = VelocityInit::Thermal;
  Simulation sim(p, build_scene(p, 7, 0, nullptr));
  auto kinetic = [&] {
    double e = 0.0;
    for (int i = 0; i < n; ++i)
      e += translational_energy(sim.bodies().kin[i], sim.bodies().sp(i)) +
           rotational_energy(sim.bodies().kin[i], sim.bodies().sp(i));
    return e;
  };
  double momentum_scale = 0.0;  // sum of m |v|: the size of the rounding of P
  for (int i = 0; i < n; ++i) momentum_scale += sim.bodies().sp(i).mass * sim.bodies().kin[i].v.norm();
  const double e0 = kinetic();
  const Vec3 p0 = total_momentum(sim.bodies());
  while (sim.stats().events < 100000) ASSERT_TRUE(sim.step()) << sim.error();
  const double e1 = kinetic();
  const Vec3 p1 = total_momentum(sim.bodies());
  std::printf("[ conserve ] events=%lld collisions=%lld dE/E=%.3e |dP|/sum(m|v|)=%.3e\n",
              static_cast<long long>(sim.stats().events), static_cast<long long>(sim.stats().collisions),
              (e1 - e0) / e0, (p1 - p0).norm() / momentum_scale);
  EXPECT_GT(sim.stats().collisions, 20000);
  EXPECT_LT(std::abs(e1 - e0) / e0, 1e-12);
  EXPECT_LT((p1 - p0).norm() / momentum_scale, 1e-12);
}

// ---------------------------------------------------------------------------
// Linkers

struct LinkerEnergies {
  double trans = 0.0;   // peculiar translational kinetic energy
  double tumble = 0.0;  // rotational energy about axes normal to the symmetry axis
  double spin = 0.0;    // rotational energy about the symmetry axis
  double total = 0.0;   // translational + rotational (lab frame)
};

// omega . u of a linker: constant in free flight (Omega . u is, u turning
// about Omega) and, for smooth contacts, across impulses.
double axial_rate(const Kinematics& k) { return k.precession.dot(k.axis) + k.spin; }

LinkerEnergies linker_energies(const BodyStore& b) {
  LinkerEnergies e;
  e.trans = peculiar_translational_energy(b);
  for (int i = 0; i < b.size(); ++i) {
    const Kinematics& k = b.kin[i];
    const Species& s = b.sp(i);
    // omega = Omega + lambda u: its part normal to u is that of Omega, whose
    // size is constant in free flight, so the reference time does not matter.
    const Vec3 w_perp = k.precession - k.precession.dot(k.axis) * k.axis;
    const double w_ax = axial_rate(k);
    e.tumble += 0.5 * s.i_perp * w_perp.squaredNorm();
    e.spin += 0.5 * s.i_axial * w_ax * w_ax;
    e.total += translational_energy(k, s) + rotational_energy(k, s);
  }
  return e;
}

// A periodic gas of smooth elastic linkers (no spheres) at packing eta.
SimParams linker_gas(int n, double eta) {
  const SimParams d;
  const double v = kPi * d.geometry.linker_radius * d.geometry.linker_radius * d.geometry.linker_length;
  return gas_params(0, n, box_for(n, v, eta));
}

// Runs until `collisions` body-body contacts in total have been processed.
::testing::AssertionResult run_collisions(Simulation& sim, std::int64_t collisions) {
  while (sim.stats().collisions < collisions)
    if (!sim.step())
      return ::testing::AssertionFailure()
             << "stopped at t = " << sim.time() << ": " << to_string(sim.termination()) << " " << sim.error();
  return ::testing::AssertionSuccess();
}

// Equipartition between translation and tumbling. Conserved: the total
// energy, the total momentum (3 translational degrees of freedom are fixed)
// and each linker's spin (its 1 axial degree of freedom is fixed); the
// periodic box does not conserve angular momentum. In the microcanonical
// ensemble each remaining quadratic degree of freedom carries the same mean
// energy exactly, so
//     <KE_trans - KE_cm> / (3 (N - 1)) = <KE_tumble> / (2 N).
// The gas starts with ~10x more energy per degree of freedom in translation
// than in tumbling; the ratio relaxes to 1 within ~8 collisions per linker.
//
// Statistics (measured, N = 400, eta = 0.08): the instantaneous ratio
// fluctuates by ~6 % (sqrt(2/800) from the 800 tumbling degrees of freedom,
// plus translation), with a correlation time of a few collisions per linker.
// Time averages over blocks of 40 collisions per linker (8000 collisions)
// scatter by 2.1 % (40 blocks from 6 seeds; their run averages 1.0016,
// 0.9985, 0.9968, 0.9904, 1.0007, 0.9858, mean 0.996). The window of 300
// collisions per linker below therefore has sigma ~0.75 %, and the 3 %
// tolerance is a 4 sigma bound.
TEST(LinkerGas, EquipartitionTranslationTumbling) {
  const auto wall0 = std::chrono::steady_clock::now();
  const int n = 400;
  SimParams p = linker_gas(n, 0.08);
  // Uniform start: <|v|^2> = v_max^2, <|w_perp|^2> = 2 omega_max^2 / 3; with
  // m = 4 pi and I_perp = 19 m / 12 the energy per degree of freedom starts
  // ~10x higher in translation than in tumbling.
  p.init.velocity = VelocityInit::Uniform;
  p.init.v_max = 1.0;
  p.init.omega_max = 0.25;
  SceneReport rep;
  Simulation sim(p, build_scene(p, 2024, 0, &rep));
  const BodyStore& b = sim.bodies();
  const double dof_trans = 3.0 * (n - 1), dof_tumble = 2.0 * n;
  const LinkerEnergies e0 = linker_energies(b);
  const Vec3 p0 = total_momentum(b);
  const double start_ratio = (e0.trans / dof_trans) / (e0.tumble / dof_tumble);
  std::printf("[ linkers ] N=%d eta=%.3f L=%.3f start: trans/dof=%.4f tumble/dof=%.4f ratio=%.3f\n", n,
              rep.packing_fraction, p.geometry.box_length, e0.trans / dof_trans, e0.tumble / dof_tumble, start_ratio);
  ASSERT_GT(start_ratio, 5.0) << "the test must start far from equipartition";

  // Relaxation: 15 collisions per linker (each collision involves 2).
  for (int per_body : {2, 5, 10, 15}) {
    ASSERT_TRUE(run_collisions(sim, per_body * n / 2));
    const LinkerEnergies e = linker_energies(b);
    std::printf("[ linkers ] t=%.2f collisions/linker=%d instantaneous ratio=%.4f (%.1f s)\n", sim.time(), per_body,
                (e.trans / dof_trans) / (e.tumble / dof_tumble), seconds_since(wall0));
  }

  // Time average over 300 collisions per linker. The energies change only at
  // collisions, so the average weighted by the intervals between them is exact.
  const double t_start = sim.time();
  const std::int64_t window = 300 * n / 2;
  const std::int64_t c_end = sim.stats().collisions + window;
  LinkerEnergies e = linker_energies(b);
  double t_prev = t_start, int_trans = 0.0, int_tumble = 0.0;
  std::int64_t seen = sim.stats().collisions;
  while (sim.stats().collisions < c_end) {
    ASSERT_TRUE(sim.step()) << "stopped at t = " << sim.time() << ": " << to_string(sim.termination()) << " "
                            << sim.error();
    if (sim.stats().collisions == seen) continue;  // cell crossings, stale events: no change of velocities
    const double t = sim.time();
    int_trans += e.trans * (t - t_prev);
    int_tumble += e.tumble * (t - t_prev);
    t_prev = t;
    e = linker_energies(b);
    seen = sim.stats().collisions;
  }
  const double span = t_prev - t_start;
  const double trans_dof = int_trans / span / dof_trans, tumble_dof = int_tumble / span / dof_tumble;
  const double ratio = trans_dof / tumble_dof;
  const LinkerEnergies e1 = linker_energies(b);
  const double dE = (e1.total - e0.total) / e0.total;
  const double dP = (total_momentum(b) - p0).norm() / (total_mass(b) * std::sqrt(2.0 * e0.trans / total_mass(b)));
  std::printf(
      "[ linkers ] window t=[%.2f, %.2f], %lld collisions: <trans>/dof=%.5f <tumble>/dof=%.5f ratio=%.5f; "
      "spin energy %.6g -> %.6g; dE/E=%.2e dP/(M v_rms)=%.2e (%.1f s)\n",
      t_start, t_prev, static_cast<long long>(window), trans_dof, tumble_dof, ratio, e0.spin, e1.spin, dE, dP,
      seconds_since(wall0));
  EXPECT_NEAR(ratio, 1.0, 0.03);
  // The comparison assumes the spin energy stays out of the exchange; the
  // exact per-linker check is LinkerGas.SpinAboutAxisConservedBySmoothContacts.
  EXPECT_NEAR(e1.spin / e0.spin, 1.0, 1e-3);
  EXPECT_LT(std::abs(dE), 1e-10);
  EXPECT_LT(dP, 1e-10);
}

// Smooth contacts cannot change a linker's spin omega . u: the impulse acts
// along the contact normal, and every normal of a cylinder of revolution
// (lateral surface: radial; end face: axial; rim: in the cone spanned by the
// two, i.e. in the meridian plane) lies in a plane containing the axis, so its
// moment about the axis is zero. Free flight keeps omega . u as well (torque-
// free symmetric top). Hence each linker's omega . u must be unchanged up to
// rounding after many collisions.
TEST(LinkerGas, SpinAboutAxisConservedBySmoothContacts) {
  const int n = 400;
  SimParams p = linker_gas(n, 0.08);
  p.init.velocity = VelocityInit::Thermal;
  Simulation sim(p, build_scene(p, 99, 0, nullptr));
  const BodyStore& b = sim.bodies();
  std::vector<double> spin0(n);
  double rms = 0.0;
  for (int i = 0; i < n; ++i) {
    spin0[i] = axial_rate(b.kin[i]);
    rms += spin0[i] * spin0[i];
  }
  rms = std::sqrt(rms / n);
  ASSERT_TRUE(run_collisions(sim, 10 * n / 2));  // 10 collisions per linker
  double worst = 0.0;
  int worst_id = -1, changed = 0;
  for (int i = 0; i < n; ++i) {
    // Relative to the linker's own spin, or the typical spin when its own is
    // nearly zero.
    const double rel = std::abs(axial_rate(b.kin[i]) - spin0[i]) / std::max(std::abs(spin0[i]), rms);
    if (rel > 1e-9) ++changed;
    if (rel > worst) worst = rel, worst_id = i;
  }
  std::printf(
      "[ spin ] %lld collisions: worst relative change of omega.u %.3e (linker %d), %d of %d linkers beyond 1e-9\n",
      static_cast<long long>(sim.stats().collisions), worst, worst_id, changed, n);
  // Contact frames come from exact features (the line of action meets both
  // axes: side-side, rim-rim via the rim tangents, rim-side polished, rim-face
  // closed form), certified by the feature solver. Measured: worst 1.0e-12
  // (before the feature frames: 280 of 400 linkers beyond 1e-9, worst 7.8e-5).
  EXPECT_LT(worst, 1e-9) << changed << " of " << n
                         << " linkers changed their spin omega.u by more than 1e-9 (relative)";
}

}  // namespace
}  // namespace ringsim
