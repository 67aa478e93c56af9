// Whole-replicate behaviour: queue equivalence, validation-mode runs,
// inelastic collapse, scene set-up and the command line.

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/event_queue.hpp"
#include "core/motion.hpp"
#include "core/rng.hpp"
#include "core/scene.hpp"
#include "core/simulation.hpp"
#include "core/snapshot.hpp"
#include "core/validation.hpp"
#include "ensemble/config.hpp"
#include "body_builder.hpp"

namespace ringsim {
namespace {

// Random updates with coarse times, so that ties happen often; `spread`
// scales the times (a calendar queue re-bins as they move on).
void expect_matches_reference(EventQueue& fast, int n, double spread, bool increasing) {
  ReferenceQueue ref;
  fast.reset(n);
  ref.reset(n);
  Rng rng(3, 0, Stream::Placement);
  double now = 0.0;
  for (int k = 0; k < 20000; ++k) {
    // Either any body at any time, or (increasing) the earliest one moved
    // past the present, as in a simulation; now and then one to infinity.
    const int i = increasing ? ref.top() : static_cast<int>(rng.below(n));
    if (increasing && std::isfinite(ref.time(i))) now = std::max(now, ref.time(i));
    double t = now + std::floor(rng.uniform() * 50.0) * spread;
    if (rng.uniform() < 0.02) t = std::numeric_limits<double>::infinity();
    fast.update(i, t);
    ref.update(i, t);
    ASSERT_EQ(fast.top(), ref.top()) << "after update " << k;
    ASSERT_EQ(fast.time(i), t);
  }
}

TEST(EventQueue, CalendarMatchesReferenceUnderRandomUpdates) {
  for (const int n : {1, 5, 37, 300})
    for (const double spread : {1e-9, 1.0, 1e6})
      for (const bool increasing : {false, true}) {
        SCOPED_TRACE(testing::Message() << "n " << n << " spread " << spread << " increasing " << increasing);
        CalendarQueue q;
        expect_matches_reference(q, n, spread, increasing);
      }
}

TEST(EventQueue, CalendarWithEveryTimeInfiniteReturnsTheLowestId) {
  CalendarQueue q;
  q.reset(5);
  EXPECT_EQ(q.top(), 0);
  q.update(3, 2.0);
  EXPECT_EQ(q.top(), 3);
  q.update(3, std::numeric_limits<double>::infinity());
  EXPECT_EQ(q.top(), 0);
  q.update(0, std::numeric_limits<double>::infinity());
  q.update(4, 1e300);
  EXPECT_EQ(q.top(), 4);
}

std::vector<Simulation::LoggedEvent> event_log(SimParams p, std::uint64_t seed) {
  Simulation sim(p, build_scene(p, seed, 0, nullptr));
  sim.enable_log(true);
  sim.run();
  return sim.log();
}

// One replicate in validation mode: how it ended, the validator's report and
// the run's counters.
struct ValidatedRun {
  Termination end;
  ValidationReport report;
  bool energy_conserving;
  RunStats stats;
};

ValidatedRun validated_run(const SimParams& p, std::uint64_t seed) {
  Simulation sim(p, build_scene(p, seed, 0, nullptr));
  Validator v(sim);
  sim.set_validator(&v);
  const Termination end = sim.run();
  return {end, v.report(), v.energy_conserving(), sim.stats()};
}

TEST(EventQueue, FastAndReferenceQueuesGiveIdenticalEventSequence) {
  SimParams p;  // default scene, 300 + 300 bodies
  p.bonding.enabled = false;  // hard-body dynamics
  p.run.t_max = 4.0;
  p.run.queue = QueueKind::Fast;
  const auto a = event_log(p, 11);
  p.run.queue = QueueKind::Reference;
  const auto b = event_log(p, 11);
  ASSERT_GT(a.size(), 1000u);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a[k].time, b[k].time) << k;  // bit-identical
    ASSERT_EQ(a[k].type, b[k].type) << k;
    ASSERT_EQ(a[k].a, b[k].a) << k;
    ASSERT_EQ(a[k].b, b[k].b) << k;
  }
}

// The same run with pair and capture searches stopped at the partner's
// pending event (run.partner_horizon, the default) and at the body's own
// horizon: the same contacts, wall hits and captures, in the same order,
// between the same bodies. A contact may now be found from the other body's
// side, by another search that meets the contact band (run.contact_tolerance)
// at another step, so times agree within the band's resolution only; the runs
// are short enough that the dynamics has not amplified that into another
// sequence (measured: the largest time difference grows from ~3e-10 at
// t = 2 to 1e-8 - 4e-8 at t = 6 and 1e-6 at t = 9, so t <= 6.5 leaves a wide
// margin below 1e-6). (Cell events are bookkeeping: a cluster member's
// relocation fires anywhere in a band of the cell slack, so it is left out.)
std::vector<Simulation::LoggedEvent> physical_events(const std::vector<Simulation::LoggedEvent>& log) {
  std::vector<Simulation::LoggedEvent> out;
  for (const auto& e : log)
    if (e.type == EventType::Collision || e.type == EventType::Wall || e.type == EventType::Capture) out.push_back(e);
  return out;
}

void expect_same_events_both_horizons(SimParams p, std::uint64_t seed, std::size_t min_events) {
  p.run.partner_horizon = false;
  const auto own = physical_events(event_log(p, seed));
  p.run.partner_horizon = true;
  const auto partner = physical_events(event_log(p, seed));
  ASSERT_GT(own.size(), min_events);
  ASSERT_EQ(partner.size(), own.size());
  for (std::size_t e = 0; e < own.size(); ++e) {
    ASSERT_EQ(partner[e].type, own[e].type) << "event " << e;
    const bool pair = own[e].type == EventType::Collision || own[e].type == EventType::Capture;
    const bool swapped = pair && partner[e].a == own[e].b && partner[e].b == own[e].a;
    ASSERT_TRUE(swapped || (partner[e].a == own[e].a && partner[e].b == own[e].b))
        << "event " << e << ": " << partner[e].a << "-" << partner[e].b << " against " << own[e].a << "-" << own[e].b;
    ASSERT_NEAR(partner[e].time, own[e].time, 1e-6) << "event " << e;
  }
}

TEST(PartnerHorizon, SameEventsAsOwnHorizonSearchesWithBonds) {
  SimParams p;  // the default scene: Scenario 4, captures, rigid clusters
  p.run.t_max = 6.5;
  // (599 contacts, wall hits and captures by t = 6.5 with the end-face
  // capture reading; the floor only makes sure the run did something.)
  expect_same_events_both_horizons(p, 3, 500);
}

TEST(PartnerHorizon, SameEventsAsOwnHorizonSearchesPeriodicLinkers) {
  SimParams p;
  p.bonding.enabled = false;  // hard-body dynamics
  p.init.spheres = 0;
  p.init.linkers = 600;
  p.geometry.boundary = Boundary::Periodic;
  p.run.t_max = 6.5;
  expect_same_events_both_horizons(p, 4, 600);
}

// The profile (ringsim replicate --profile) accounts for every event and
// search, and profiling changes nothing: the same events, bit for bit.
TEST(Profile, CountsEveryEventAndSearchAndChangesNoEvent) {
  SimParams p;  // the default scene: Scenario 4, captures, rigid clusters
  p.run.t_max = 20.0;
  const auto plain = event_log(p, 5);
  Simulation sim(p, build_scene(p, 5, 0, nullptr));
  sim.enable_log(true);
  sim.enable_profile(true);
  const Predictor::SearchCounts before = sim.predictor_counts();  // the constructor's first predictions
  sim.run();
  const auto& profiled = sim.log();
  ASSERT_GT(plain.size(), 1000u);
  ASSERT_EQ(profiled.size(), plain.size());
  for (std::size_t e = 0; e < plain.size(); ++e) {
    ASSERT_EQ(profiled[e].time, plain[e].time) << "event " << e;
    ASSERT_EQ(profiled[e].type, plain[e].type) << "event " << e;
    ASSERT_EQ(profiled[e].a, plain[e].a) << "event " << e;
    ASSERT_EQ(profiled[e].b, plain[e].b) << "event " << e;
  }
  const EventProfile& prof = sim.profile();
  const RunStats& st = sim.stats();
  std::int64_t events = 0, searches = 0;
  for (int k = 0; k < EventProfile::kKinds; ++k) {
    if (k != EventProfile::kStale) events += prof.kind[k].events;
    searches += prof.kind[k].pair_searches;
    EXPECT_GE(prof.kind[k].seconds, 0.0);
  }
  EXPECT_EQ(events, st.events);
  EXPECT_EQ(prof.kind[EventProfile::kStale].events, st.stale);
  EXPECT_EQ(prof.kind[EventProfile::kRelocation].events, st.cell_crossings);
  EXPECT_EQ(prof.kind[EventProfile::kRelocation].predictions, st.cell_crossings);  // one body each
  EXPECT_GT(prof.kind[EventProfile::kCollision].events, 0);
  EXPECT_GT(prof.kind[EventProfile::kCollision].capture_searches, 0);
  // Each bin holds the searches of its range of work, and they add up.
  std::int64_t binned = 0, capsule = 0, found = 0;
  for (int b = 0; b < EventProfile::kBins; ++b) {
    const EventProfile::Work& x = prof.bin[b].all;
    const EventProfile::Work& f = prof.bin[b].found;
    binned += x.searches;
    found += f.searches;
    EXPECT_LE(f.searches, x.searches);
    EXPECT_LE(f.seconds, x.seconds);
    EXPECT_LE(f.exact_distances, x.exact_distances);
    if (b > 0 && x.searches > 0) EXPECT_GT(x.work, EventProfile::kWorkBins[b - 1] * x.searches) << "bin " << b;
    if (b < EventProfile::kBins - 1) EXPECT_LE(x.work, EventProfile::kWorkBins[b] * x.searches) << "bin " << b;
    // A contact fires only at an exact distance, never from a capsule bound.
    EXPECT_GE(f.exact_distances, f.searches) << "bin " << b;
    capsule += x.work - x.plane_evaluations - x.exact_distances;
  }
  EXPECT_EQ(binned, searches);
  EXPECT_GT(searches, 1000);
  EXPECT_GT(found, 0);
  // Capsule steps are taken only by pair searches: the bins hold all those of the run.
  const Predictor::SearchCounts& sc = sim.predictor_counts();
  const auto run_capsule = sc.pair_capsule + sc.cluster_pair_capsule - before.pair_capsule - before.cluster_pair_capsule;
  EXPECT_GT(run_capsule, 0u);
  EXPECT_EQ(capsule, static_cast<std::int64_t>(run_capsule));
}

// A thermal hard-sphere gas (no linkers, bonding off): the case where each
// sphere keeps its earliest collision candidates (run.sphere_candidates).
SimParams sphere_gas(int n, double packing, Boundary boundary, int candidates) {
  SimParams p;
  p.bonding.enabled = false;
  p.init.spheres = n;
  p.init.linkers = 0;
  p.init.velocity = VelocityInit::Thermal;
  p.geometry.boundary = boundary;
  p.geometry.box_length = std::cbrt(n * 4.0 / 3.0 * M_PI / packing);
  p.run.t_max = 1e9;
  p.run.sphere_candidates = candidates;
  return p;
}

TEST(SphereCandidates, SameEventsAsFullNeighbourhoodScans) {
  // Kept candidates (partial scans after cell crossings, the next candidate
  // after a stale one) against a full scan at every prediction. The times
  // agree to rounding only: a kept candidate was solved from the positions
  // at an earlier scan. 4 000 events of 500 spheres are few enough that the
  // gas's chaos has not yet amplified that rounding into another sequence.
  for (const Boundary boundary : {Boundary::Periodic, Boundary::Reflective}) {
    for (const int k : {1, 4}) {
      SimParams p = sphere_gas(500, 0.2, boundary, 0);
      p.run.max_events = 4000;
      const auto full = event_log(p, 7);
      p.run.sphere_candidates = k;
      const auto kept = event_log(p, 7);
      ASSERT_EQ(full.size(), 4000u);
      ASSERT_EQ(kept.size(), full.size());
      int crossings = 0;
      for (std::size_t e = 0; e < full.size(); ++e) {
        ASSERT_EQ(kept[e].type, full[e].type) << "event " << e << ", K = " << k;
        // A collision may be found (and logged) from either body.
        const bool pair = full[e].type == EventType::Collision;
        const bool swapped = pair && kept[e].a == full[e].b && kept[e].b == full[e].a;
        ASSERT_TRUE(swapped || (kept[e].a == full[e].a && kept[e].b == full[e].b))
            << "event " << e << ", K = " << k << ": " << kept[e].a << "-" << kept[e].b << " against "
            << full[e].a << "-" << full[e].b;
        ASSERT_NEAR(kept[e].time, full[e].time, 1e-10 * std::max(1.0, full[e].time)) << "event " << e;
        crossings += full[e].type == EventType::CellCross;
      }
      EXPECT_GT(crossings, 1000);  // the partial scans were exercised
    }
  }
}

TEST(SphereCandidates, InelasticGasSameEventsAndLossesAsGeneralSolver) {
  // The gas's own collision path (collide_smooth_spheres, with candidates)
  // against the general contact solver (run.sphere_candidates = 0), with
  // restitution < 1, the TC rule (a window long enough to fire often) and the
  // separation floor: the same events, and the same energy lost, to rounding.
  SimParams p = sphere_gas(300, 0.25, Boundary::Periodic, 0);
  p.contact.restitution_sphere = 0.6;
  p.run.tc_time = 0.02;
  p.run.min_separation_speed = 0.5;
  p.run.max_events = 3000;
  auto run = [&](int k) {
    p.run.sphere_candidates = k;
    Simulation sim(p, build_scene(p, 13, 0, nullptr));
    sim.enable_log(true);
    sim.run();
    return std::make_pair(sim.log(), sim.stats());
  };
  const auto [general_log, general] = run(0);
  const auto [gas_log, gas] = run(4);
  ASSERT_EQ(gas_log.size(), general_log.size());
  for (std::size_t e = 0; e < general_log.size(); ++e) {
    ASSERT_EQ(gas_log[e].type, general_log[e].type) << "event " << e;
    ASSERT_NEAR(gas_log[e].time, general_log[e].time, 1e-9 * std::max(1.0, general_log[e].time)) << "event " << e;
  }
  EXPECT_GT(general.tc_collisions, 10);  // the TC rule fired
  EXPECT_GT(general.floored, 10);        // and so did the floor
  EXPECT_EQ(gas.tc_collisions, general.tc_collisions);
  EXPECT_EQ(gas.floored, general.floored);
  EXPECT_GT(general.lost_contacts, 0.0);
  EXPECT_NEAR(gas.lost_contacts, general.lost_contacts, 1e-9 * general.lost_contacts);
}

TEST(SphereCandidates, ValidationRunNoOverlapEnergyConserved) {
  // One candidate per sphere: the list runs empty often, so the fall-back
  // to a full scan (past `floor`) is exercised as much as the partial scans.
  SimParams p = sphere_gas(500, 0.3, Boundary::Periodic, 1);
  p.run.max_events = 20000;
  const ValidatedRun run = validated_run(p, 3);
  EXPECT_EQ(run.end, Termination::EventBudget);
  const ValidationReport& r = run.report;
  EXPECT_EQ(r.overlaps, 0) << "first overlap at t = " << r.first_overlap_time;
  EXPECT_LT(r.max_energy_error, 1e-9);
  EXPECT_LT(r.max_momentum_error, 1e-12);
  EXPECT_GT(run.stats.stale, 500);
  EXPECT_GT(run.stats.cell_crossings, 4000);
}

TEST(Validation, DefaultBoxHundredThousandEventsNoOverlapElastic) {
  SimParams p;  // 300 spheres + 300 linkers, 50 box, reflective, e = 1, smooth
  p.bonding.enabled = false;  // hard-body dynamics
  p.run.t_max = 1e9;
  p.run.max_events = 100000;
  const ValidatedRun run = validated_run(p, 5);
  EXPECT_EQ(run.end, Termination::EventBudget);
  const ValidationReport& r = run.report;
  EXPECT_EQ(r.checks, 100000);
  EXPECT_EQ(r.overlaps, 0) << "first overlap at t = " << r.first_overlap_time;
  EXPECT_TRUE(run.energy_conserving);
  EXPECT_LT(r.max_energy_error, 1e-9);
  EXPECT_LT(r.max_momentum_error, 1e-12);
  EXPECT_LT(r.max_angular_momentum_error, 1e-12);
  EXPECT_GT(run.stats.collisions, 10000);
}

// Hard bodies (no bonding) in a periodic box, run for a number of events.
SimParams periodic_hard_bodies(int spheres, int linkers, double box, std::int64_t events) {
  SimParams p;
  p.bonding.enabled = false;
  p.geometry.boundary = Boundary::Periodic;
  p.init.spheres = spheres;
  p.init.linkers = linkers;
  p.geometry.box_length = box;
  p.run.t_max = 1e9;
  p.run.max_events = events;
  return p;
}

TEST(Validation, PeriodicFrictionalInelasticRunKeepsMomentumAndNoOverlap) {
  SimParams p = periodic_hard_bodies(150, 150, 35.0, 20000);
  p.contact.restitution_sphere = 0.8;
  p.contact.restitution_linker = 0.9;
  p.contact.static_friction_sphere = p.contact.static_friction_linker = 0.4;
  p.contact.dynamic_friction_sphere = p.contact.dynamic_friction_linker = 0.3;
  const ValidatedRun run = validated_run(p, 9);
  EXPECT_EQ(run.report.overlaps, 0);
  EXPECT_LT(run.report.max_momentum_error, 1e-12);
  EXPECT_FALSE(run.energy_conserving);
  EXPECT_LT(run.report.max_energy_error, 1e-12);  // energy never increases
  EXPECT_GT(run.stats.stick + run.stats.slide, 100);
}

TEST(Validation, SmallPeriodicBoxTwoCellsASideNoOverlap) {
  // 12 spheres and 12 linkers in a periodic box of edge 12: two cells a side,
  // so a pair that parts on one image meets again on the next within a few
  // time units, inside one search and between two predictions of the pair.
  // Before the image-return fixes of 2026-11-25 every seed overlapped within
  // ~150 events (the pair memo, the window entry, the pair search and the
  // spheres' closed form all trusted the minimum image of their start).
  SimParams p = periodic_hard_bodies(12, 12, 12.0, 8000);
  for (std::uint64_t seed : {1, 2}) {
    const ValidatedRun run = validated_run(p, seed);
    EXPECT_EQ(run.report.overlaps, 0) << "seed " << seed;
    EXPECT_LT(run.report.max_energy_error, 1e-12) << "seed " << seed;
    EXPECT_GT(run.stats.collisions, 3000) << "seed " << seed;
  }
  // A gas of 12 spheres: box 7 has 3 cells a side (the general path; the gas
  // path overlapped there), box 8.5 has 4 (the gas path, exact from 4 on).
  p.init.linkers = 0;
  for (double box : {7.0, 8.5}) {
    p.geometry.box_length = box;
    const ValidatedRun run = validated_run(p, 3);
    EXPECT_EQ(run.report.overlaps, 0) << "box " << box;
    EXPECT_LT(run.report.max_energy_error, 1e-12) << "box " << box;
    EXPECT_GT(run.stats.collisions, 1000) << "box " << box;
  }
}

// Linker 0 at rest; linker 1, offset by (3.2, 3, 0) and moving at (1, vy, 0),
// passes it within the bounding-sphere window without touching (lateral
// offset > 2 r_L), goes once round the periodic box and comes back with the
// offset reduced by |vy| t: it must touch then. Body 0 predicts the pair once,
// at t = 0 (it never moves, so its own horizon is infinite), and that search
// sees the bounding spheres part for good on the minimum image of t = 0; its
// proof must not be taken for "never" when the pair meets again through the
// boundary (by the pair memo, or within one search in a small box).
void expect_contact_after_one_turn(double box, double vy, bool partner_horizon) {
  SCOPED_TRACE("box " + std::to_string(box) + ", vy " + std::to_string(vy) +
               ", partner_horizon " + std::to_string(partner_horizon));
  SimParams p;
  p.bonding.enabled = false;
  p.geometry.boundary = Boundary::Periodic;
  p.geometry.box_length = box;
  p.init.spheres = 0;
  p.init.linkers = 2;
  p.run.t_max = 3.0 * box;
  p.run.partner_horizon = partner_horizon;
  const Vec3 c(0.5 * box, 0.5 * box, 0.5 * box), zero = Vec3::Zero();
  BodyStore b = test::make_bodies(p, {{Shape::Linker, c, zero, Vec3::UnitZ(), zero},
                                      {Shape::Linker, c + Vec3(3.2, 3.0, 0), Vec3(1, vy, 0), Vec3::UnitZ(), zero}});
  Simulation sim(p, std::move(b));
  while (sim.stats().collisions == 0 && sim.step()) {
  }
  ASSERT_EQ(sim.stats().collisions, 1);
  // Parallel cylinders touch side to side at axis distance 2 r_L = 2; after
  // one turn their offset is (3.2 + t - L, 3 + vy t): the first root of
  // |offset|^2 = 4, fired within the contact band (gap in [delta/2, delta]).
  const double qa = 1.0 + vy * vy, qb = 2.0 * (3.2 - box) + 6.0 * vy, qc = (3.2 - box) * (3.2 - box) + 5.0;
  const double t_touch = (-qb - std::sqrt(qb * qb - 4.0 * qa * qc)) / (2.0 * qa);
  const double delta = p.run.contact_tolerance;
  const double rate = std::abs(2.0 * qa * t_touch + qb) / 4.0;  // d|offset|/dt there
  EXPECT_NEAR(sim.time(), t_touch, delta / rate);
  EXPECT_NEAR(std::hypot(3.2 + sim.time() - box, 3.0 + vy * sim.time()), 2.0 + 0.75 * delta, 0.25 * delta + 1e-12);
  sim.run();
  EXPECT_EQ(Validator::count_overlaps(sim, sim.time(), 1e-9), 0);
}

TEST(Regression, PairMeetingAgainThroughThePeriodicBoundaryIsNotSkipped) {
  for (bool partner_horizon : {true, false}) {
    expect_contact_after_one_turn(50.0, -0.05, partner_horizon);  // the default box, 10 cells a side
    expect_contact_after_one_turn(10.0, -0.3, partner_horizon);   // two cells a side
  }
}

// A linker turning on the spot (axis along z, turning about x) next to a
// sphere at rest on the x axis, 3 apart: the bounding spheres overlap for
// ever (3 < 1 + sqrt(5)), the side of the linker always faces the sphere, so
// the gap stays 3 - r_L - r_S = 1 and no contact ever comes. Neither body
// leaves its cell. Such a pair once had no limit at all: the sphere's first
// prediction (its partner not yet predicted) searched 10^7 steps and the
// replicate ended in an error after a minute (init.v_max = 0, found by a
// validation sweep). Now every search stops by a re-check.
// A sphere at rest at c and, at c + offset, a linker at rest with its axis
// along z, turning about x at 5 rad/s; hard bodies in a closed box of 20.
Simulation sphere_beside_turning_linker(const Vec3& c, const Vec3& offset, double t_max, bool partner_horizon) {
  SimParams p;
  p.bonding.enabled = false;
  p.init.spheres = 0;
  p.init.linkers = 0;
  p.geometry.box_length = 20.0;
  p.run.t_max = t_max;
  p.run.partner_horizon = partner_horizon;
  const Vec3 zero = Vec3::Zero();
  return Simulation(p, test::make_bodies(p, {{Shape::Sphere, c, zero, Vec3::UnitZ(), zero},
                                             {Shape::Linker, c + offset, zero, Vec3::UnitZ(), Vec3(5.0, 0, 0)}}));
}

TEST(Regression, LinkerTurningOnTheSpotNextToASphereAtRestIsNotSearchedForEver) {
  for (bool partner_horizon : {true, false}) {
    Simulation sim = sphere_beside_turning_linker(Vec3(8, 10, 10), Vec3(3, 0, 0), 200.0, partner_horizon);
    Validator v(sim);
    sim.set_validator(&v);
    ASSERT_EQ(sim.run(), Termination::TimeLimit) << sim.error();
    EXPECT_EQ(sim.stats().collisions, 0);
    // About 140 turns at 5 rad/s: a few steps each, not millions.
    EXPECT_LT(sim.stats().ca_steps, 100000) << "partner horizon " << partner_horizon;
    EXPECT_GT(sim.stats().events, 0);  // the re-checks
    EXPECT_EQ(v.report().overlaps, 0);
  }
}

// The same pair with the sphere on the y axis, in the plane the linker turns
// in: its end face comes round and hits the sphere within a quarter turn.
TEST(Regression, LinkerTurningOnTheSpotHitsASphereAtRest) {
  Simulation sim = sphere_beside_turning_linker(Vec3(10, 7, 10), Vec3(0, 3, 0), 50.0, true);
  while (sim.stats().collisions == 0 && sim.step()) {
  }
  ASSERT_EQ(sim.stats().collisions, 1);
  // Axis at angle 5 t from z towards -y: the rim point nearest the sphere
  // reaches it between the side's gap of 1 (t = 0) and the face's (t = pi / 10).
  EXPECT_GT(sim.time(), 0.0);
  EXPECT_LT(sim.time(), M_PI / 10.0);
  sim.run();
  EXPECT_EQ(Validator::count_overlaps(sim, sim.time(), 1e-9), 0);
}

// Bodies that start at rest and spin have no momentum to measure errors
// against (a sum of |p| of 0 once gave "errors" of 1e287); collisions turn
// their spin into translation, and the momentum stays exactly conserved.
TEST(Validation, BodiesStartingAtRestAndSpinningKeepMomentum) {
  SimParams p;
  p.bonding.enabled = false;
  p.geometry.box_length = 12.0;
  p.init.spheres = 2;
  p.init.linkers = 2;
  p.init.v_max = 0.0;
  p.init.omega_max = 20.0;
  p.run.t_max = 10.0;
  const ValidatedRun run = validated_run(p, 1);
  EXPECT_EQ(run.end, Termination::TimeLimit);
  EXPECT_GT(run.stats.collisions, 5);
  EXPECT_EQ(run.report.overlaps, 0);
  EXPECT_LT(run.report.max_momentum_error, 1e-12);
  EXPECT_LT(run.report.max_angular_momentum_error, 1e-12);
  EXPECT_LT(run.report.max_energy_error, 1e-12);
}

TEST(Validation, PeriodicBoxIgnoresTheWallsContactSettings) {
  // A periodic box has no walls: wall restitution and wall friction do not
  // act, so elastic, smooth bodies conserve energy and the validator checks
  // |dE| both ways. It took wall friction into account, and then only
  // checked for energy gains (a frictional wall made any run "dissipative").
  SimParams p = periodic_hard_bodies(12, 12, 12.0, 3000);
  p.contact.restitution_wall = 0.3;
  p.contact.static_friction_wall = 0.8;
  p.contact.dynamic_friction_wall = 0.5;
  const ValidatedRun run = validated_run(p, 2);
  EXPECT_TRUE(run.energy_conserving);
  EXPECT_EQ(run.report.overlaps, 0);
  EXPECT_LT(run.report.max_energy_error, 1e-12);
  // The same settings with walls: not conserving.
  p.geometry.boundary = Boundary::Reflective;
  Simulation walls(p, build_scene(p, 2, 0, nullptr));
  EXPECT_FALSE(Validator(walls).energy_conserving());
}

TEST(Regression, GrazingWallContactOfALinkerDoesNotStall) {
  // Seed 1001 of the default scene once froze at t = 442.7643: a linker in
  // the contact band (gap 3e-15) whose single support point looked separating
  // while the exact gap was closing, with certified steps below one ulp of t.
  SimParams p;
  p.bonding.enabled = false;  // hard-body dynamics
  p.run.t_max = 1e12;
  p.run.max_events = 160000;
  Simulation sim(p, build_scene(p, 1001, 0, nullptr));
  EXPECT_EQ(sim.run(), Termination::EventBudget);
  EXPECT_GT(sim.time(), 442.8);
  EXPECT_EQ(Validator::count_overlaps(sim, sim.time(), 1e-9), 0);
}

// Packing 0.31, e = 0.3: without a remedy the cooling gas clusters and
// collapses (infinitely many collisions in finite time; measured without the
// TC model at t = 966, 189, 105 for seeds 2, 3, 4).
SimParams collapsing_gas(double tc_time, std::int64_t event_budget) {
  SimParams p;
  p.bonding.enabled = false;  // hard-body dynamics
  p.geometry.boundary = Boundary::Periodic;
  p.init.linkers = 0;
  p.init.spheres = 2000;
  p.geometry.box_length = 30.0;
  p.contact.restitution_sphere = 0.3;
  p.run.tc_time = tc_time;
  p.run.t_max = 20000.0;
  p.run.max_events = event_budget;
  return p;
}

TEST(InelasticCollapse, DenseGasWithRestitutionPointThreeFinishes) {
  // The TC model keeps the collision count finite; the budget is a generous guard.
  const SimParams p = collapsing_gas(1e-7, 20'000'000);
  Simulation sim(p, build_scene(p, 3, 0, nullptr));
  EXPECT_EQ(sim.run(), Termination::TimeLimit);
  EXPECT_GT(sim.stats().tc_collisions, 0);
  EXPECT_EQ(Validator::count_overlaps(sim, sim.time(), 1e-9), 0);
}

TEST(InelasticCollapse, WithoutTcModelTheEventRateExplodes) {
  // The same gas without the TC model collapses: the collisions pile up
  // until time stops at one instant (t = 189.37 for this seed), and the run
  // ends with an error naming the remedy instead of spending its whole
  // event budget (which it did before the frozen-time guard) or, without a
  // budget, never ending.
  const SimParams p = collapsing_gas(0.0, 2'000'000);
  Simulation sim(p, build_scene(p, 3, 0, nullptr));
  EXPECT_EQ(sim.run(), Termination::Error);
  EXPECT_LT(sim.time(), 1000.0);
  EXPECT_LT(sim.stats().events, 1'000'000);
  EXPECT_NE(sim.error().find("run.tc_time"), std::string::npos) << sim.error();
}

// The default box without bonding, e = 0.7 (optionally with friction 0.2):
// two linkers turning against each other keep meeting at normal speeds
// that each inelastic bounce shrinks, a resting contact the event loop can
// only take as a chatter of collisions ~1e-7 apart, each a grazing search
// (measured, seed 3, old default run.tc_time = 1e-7: 80 000 collisions in
// 0.009 time units at t = 6.05, then ~950 distance evaluations per
// collision from t = 8.14; seeds 2, 3, 4 did not reach t = 10 in 60 s).
SimParams chattering_linkers(bool friction, std::int64_t event_budget) {
  SimParams p;
  p.bonding.enabled = false;
  p.contact.restitution_sphere = p.contact.restitution_linker = 0.7;
  if (friction) {
    p.contact.static_friction_sphere = p.contact.dynamic_friction_sphere = 0.2;
    p.contact.static_friction_linker = p.contact.dynamic_friction_linker = 0.2;
  }
  p.run.t_max = 10.0;
  p.run.max_events = event_budget;
  return p;
}

TEST(InelasticCollapse, ChatteringLinkersFinishWithTheDefaultContactTime) {
  // With the default TC window (1e-4) a chatter turns elastic and ends:
  // ~3 000 (smooth) and ~6 700 (frictional) collisions to t = 10.
  for (const bool friction : {false, true}) {
    const SimParams p = chattering_linkers(friction, 50'000);
    Simulation sim(p, build_scene(p, 3, 0, nullptr));
    EXPECT_EQ(sim.run(), Termination::TimeLimit) << "friction " << friction << ", t = " << sim.time();
    EXPECT_GT(sim.stats().tc_collisions, 0);
    EXPECT_EQ(Validator::count_overlaps(sim, sim.time(), 1e-9), 0);
  }
}

TEST(InelasticCollapse, ChatteringLinkersExhaustABudgetWithAShortContactTime) {
  // The same box with the old window of 1e-7 spends the whole budget in the
  // first chatter (t ~ 6.05) with the separation floor of that time (1e-6):
  // the failure the default is chosen against. The floor of today (1e-4)
  // lifts the pairs out of the band sooner, but the window is still needed:
  // the budget still runs out before t_max (measured: at t = 8.27).
  for (const double floor : {1e-6, 1e-4}) {
    SimParams p = chattering_linkers(false, 50'000);
    p.run.tc_time = 1e-7;
    p.run.min_separation_speed = floor;
    Simulation sim(p, build_scene(p, 3, 0, nullptr));
    EXPECT_EQ(sim.run(), Termination::EventBudget) << "floor " << floor;
    if (floor < 1e-5) EXPECT_LT(sim.time(), 7.0);
  }
}

// Restitution 0 leaves a pair touching at zero normal speed; rounding then
// showed one pair as approaching to the prediction and as separating to the
// contact frame, so it fired again and again at one instant with no impulse
// (a sweep found t frozen at 0.2147 for this scene; both the general path,
// with linkers, and the sphere gas's). Now such a contact gets the separation
// floor and time goes on.
SimParams resting_spheres(int linkers, std::int64_t event_budget) {
  SimParams p;
  p.bonding.enabled = false;
  p.geometry.boundary = Boundary::Periodic;
  p.geometry.box_length = 20.0;
  p.init.spheres = linkers > 0 ? 60 : 400;
  p.init.linkers = linkers;
  p.contact.restitution_sphere = 0.0;
  p.run.t_max = 1.0;
  p.run.max_events = event_budget;
  return p;
}

TEST(InelasticCollapse, RestitutionZeroDoesNotFreezeTime) {
  for (int linkers : {20, 0}) {
    const SimParams p = resting_spheres(linkers, 200'000);
    const ValidatedRun run = validated_run(p, 485);
    EXPECT_EQ(run.end, Termination::TimeLimit) << linkers << " linkers";
    EXPECT_GT(run.stats.floored, 0);
    EXPECT_EQ(run.report.overlaps, 0);
    EXPECT_LT(run.report.max_momentum_error, 1e-12);
  }
}

// The same scene with the separation floor switched off (0, a valid value):
// the resting pair fires at one instant for ever. The run must stop with an
// error that says so and names the key, not spend its budget (or, without
// one, never end).
TEST(InelasticCollapse, FrozenTimeEndsTheRunWithAnError) {
  for (int linkers : {20, 0}) {
    SimParams p = resting_spheres(linkers, 2'000'000);
    p.run.min_separation_speed = 0.0;
    Simulation sim(p, build_scene(p, 485, 0, nullptr));
    EXPECT_EQ(sim.run(), Termination::Error) << linkers << " linkers, t = " << sim.time();
    EXPECT_LT(sim.stats().events, 200'000);
    EXPECT_NE(sim.error().find("time stopped"), std::string::npos) << sim.error();
    EXPECT_NE(sim.error().find("run.min_separation_speed"), std::string::npos) << sim.error();
  }
}

// A linker on the rim of a tilted end face at a wall, turning about its axis,
// restitution 0 (the mechanism of a sweep's "time stopped at t = 11.689",
// replicate seed 105 with restitution 0 in a box of 25; docs/OUTPUT.md). The
// wall contact's candidates include 16 samples of the face's rim; tilting
// the axis by 2e-5 out of its plane puts sample 0 6.5e-5 rad along the rim
// from the touching point, 6.2e-10 higher: inside the contact band (1e-9),
// so it is a candidate, and there the spin about the axis has a normal
// component (~2.6e-5). The turn about the rim point's radial direction
// makes that sample approach fastest by the shape velocity (which leaves
// the spin out), 5e-5 faster than the touching point; by the material
// velocity it is only 2.4e-5 faster. Restitution 0 stopped the material
// point, but by the shape velocity the sample still approached at 2.6e-5
// (above the separation floor, 1e-6): once the TC model's elastic repeat
// had left the material point separating at the floor, the wall fired
// again and again at t = 0, each time found not approaching by the
// response, which then did nothing. Predictor::wall_contact now fires only
// a contact the response acts on.
TEST(InelasticCollapse, LinkerRimAtAWallDoesNotFreezeTime) {
  SimParams p;
  p.bonding.enabled = false;
  p.geometry.box_length = 10.0;
  p.contact.restitution_linker = 0.0;
  p.contact.restitution_wall = 0.0;
  // Afterwards the turning linker keeps swinging its rim into the wall, a
  // resting contact taken as bounces at the separation floor (~100 to t = 0.01).
  p.run.t_max = 0.01;
  p.run.max_events = 1'000'000;  // a guard: the frozen-time check ended the loop at 100 001
  const Vec3 n(0, -1, 0);        // from the body to the wall y = 0
  const Vec3 u = Vec3(2e-5, -std::cos(0.3), std::sin(0.3)).normalized();
  const Vec3 radial = (n - n.dot(u) * u).normalized();  // of the rim point touching the wall
  const double R = p.geometry.linker_radius, h = 0.5 * p.geometry.linker_length;
  // The touching rim point (the support point along n) 0.75e-9 above the
  // wall, inside the contact band, approaching at 0.01: the wall fires at t = 0.
  Vec3 c(5, 0, 5);
  c.y() = -(h * u + R * radial).y() + 0.75e-9;
  BodyStore b = test::make_bodies(p, {{Shape::Linker, c, Vec3(0, -0.01, 0), u, 2.0 * u + radial}});
  Simulation sim(p, std::move(b));
  Validator v(sim);
  sim.set_validator(&v);
  EXPECT_EQ(sim.run(), Termination::TimeLimit) << sim.error();
  EXPECT_GT(sim.stats().wall_collisions, 0);
  EXPECT_LT(sim.stats().events, 1000);
  EXPECT_EQ(v.report().overlaps, 0);
}

// Spheres of radius 1e-15 in the default box: rounding put a sphere's wall
// contact at the instant its centre reached the box's face, which counted as
// a cell exit out of the box, again and again at t = 4.7309 (a sweep found
// it; CellGrid.AnOuterFaceOfAClosedBoxIsNoExitOnceTheCentreIsOnIt).
TEST(Regression, TinySpheresReachTheWallsWithoutStalling) {
  SimParams p;
  p.geometry.sphere_radius = 1e-15;
  p.run.t_max = 5.0;
  p.run.max_events = 100'000;
  const ValidatedRun run = validated_run(p, 1);
  EXPECT_EQ(run.end, Termination::TimeLimit);
  EXPECT_GT(run.stats.wall_collisions, 50);
  EXPECT_EQ(run.report.overlaps, 0);
}

TEST(Scene, SegregatedAndMixedRouting) {
  SimParams p;
  p.init.alpha = 0.0;
  SceneReport rep;
  BodyStore b = build_scene(p, 4, 0, &rep);
  const double half = 0.5 * p.geometry.box_length;
  for (int i = 0; i < b.size(); ++i) {
    if (b.shape[i] == Shape::Sphere) EXPECT_LT(b.kin[i].x.x(), half);
    else EXPECT_GE(b.kin[i].x.x(), half);
  }
  EXPECT_LT(rep.mixing, 0.1);
  p.init.alpha = 1.0;
  build_scene(p, 4, 0, &rep);
  EXPECT_GT(rep.mixing, 0.35);  // random mixture of equal numbers: about 1/2
  EXPECT_LT(rep.mixing, 0.65);
  const double expected = (300 * 4.0 / 3.0 * M_PI + 300 * 4.0 * M_PI) / std::pow(50.0, 3);
  EXPECT_NEAR(rep.packing_fraction, expected, 1e-12);
}

TEST(Scene, NoInitialOverlapsAndDenseRequestUsesFallback) {
  SimParams p;
  p.init.spheres = 2500;
  p.init.linkers = 1500;
  p.geometry.box_length = 50.0;  // packing ~0.24
  SceneReport rep;
  BodyStore b = build_scene(p, 8, 0, &rep);
  Simulation sim(p, std::move(b));
  EXPECT_EQ(Validator::count_overlaps(sim, 0.0, 0.0), 0);
  EXPECT_NEAR(rep.packing_fraction, (2500 * 4.0 / 3.0 * M_PI + 1500 * 4.0 * M_PI) / 125000.0, 1e-12);
}

TEST(Scene, ImpossibleRequestFailsFastNamingPackingFraction) {
  SimParams p;
  p.init.linkers = 20000;
  try {
    build_scene(p, 1, 0, nullptr);
    FAIL() << "expected SceneError";
  } catch (const SceneError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("packing fraction"), std::string::npos) << msg;
    EXPECT_NE(msg.find("20000 linkers"), std::string::npos) << msg;
  }
}

TEST(Scene, ThermalVelocitiesHaveTheTemperature) {
  SimParams p;
  p.init.velocity = VelocityInit::Thermal;
  p.init.temperature = 2.0;
  p.init.spheres = 3000;
  p.init.linkers = 3000;
  p.geometry.box_length = 80.0;
  BodyStore b = build_scene(p, 12, 0, nullptr);
  double et = 0.0, er = 0.0;
  for (int i = 0; i < b.size(); ++i) {
    et += translational_energy(b.kin[i], b.sp(i));
    er += rotational_energy(b.kin[i], b.sp(i));
  }
  // Equipartition: 3/2 T per body for translation and for rotation.
  const double n = b.size();
  EXPECT_NEAR(et / (1.5 * n), 2.0, 2.0 * 0.04);  // 4 %: ~5 sigma for 6000 bodies
  EXPECT_NEAR(er / (1.5 * n), 2.0, 2.0 * 0.04);
}

TEST(Scene, SameSeedSameScene) {
  SimParams p;
  BodyStore a = build_scene(p, 21, 3, nullptr), b = build_scene(p, 21, 3, nullptr), c = build_scene(p, 21, 4, nullptr);
  EXPECT_EQ(a.kin[17].x, b.kin[17].x);
  EXPECT_EQ(a.kin[400].precession, b.kin[400].precession);
  EXPECT_NE(a.kin[17].x, c.kin[17].x);
}

// ---- command line ----------------------------------------------------------
struct Cmd {
  int status;
  std::string out;
};
// Runs a shell command line; its output (as redirected there) and exit status.
Cmd run_shell(const std::string& cmd) {
  Cmd r{0, ""};
  FILE* f = popen(cmd.c_str(), "r");
  std::array<char, 4096> buf;
  while (fgets(buf.data(), buf.size(), f)) r.out += buf.data();
  const int st = pclose(f);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}
Cmd run_cli(const std::string& args) { return run_shell(std::string(RINGSIM_BINARY) + " " + args + " 2>&1"); }

TEST(Cli, ReplicateJsonHasTheContractFields) {
  const Cmd c = run_cli("replicate --seed 3 --set run.t_max=2 --json");
  ASSERT_EQ(c.status, 0) << c.out;
  for (const char* key : {"\"seed\":3", "\"events\":", "\"collisions\":", "\"wall_collisions\":", "\"t_end\":2.0",
                          "\"termination\":\"t_max\"", "\"wall_seconds\":", "\"translational\":", "\"rotational\":",
                          "\"momentum\":["})
    EXPECT_NE(c.out.find(key), std::string::npos) << key << " missing in " << c.out;
}

TEST(Cli, ReplicateJsonHasTheObservables) {
  // Scenario 1 (valency only) for 40 time units: bonds form, fractions are
  // fractions, S4 is a number or null, never a percentage.
  const Cmd c = run_cli("replicate --seed 2 --set run.t_max=40 --set bonding.angle_filter=false "
                        "--set bonding.coplanarity_filter=false --json");
  ASSERT_EQ(c.status, 0) << c.out;
  const nlohmann::json j = nlohmann::json::parse(c.out);
  for (const char* key : {"captures", "bonds", "N_t", "N_tar", "N_viab", "N_cyc", "rings", "Phi_obj", "Phi_viab", "S4",
                          "M_mono", "M_mono_S", "M_mono_L", "tau_tar", "tau_tar_censored", "termination", "t_end"})
    EXPECT_TRUE(j.contains(key)) << key << " missing in " << c.out;
  EXPECT_GT(j["bonds"].get<int>(), 0);
  EXPECT_EQ(j["N_t"].get<int>(), 600 - j["bonds"].get<int>() + j["N_cyc"].get<int>() + j["rings"].value("2", 0));
  for (const char* key : {"Phi_obj", "Phi_viab", "M_mono", "M_mono_S", "M_mono_L"}) {
    EXPECT_GE(j[key].get<double>(), 0.0) << key;
    EXPECT_LE(j[key].get<double>(), 1.0) << key;
  }
  EXPECT_TRUE(j["S4"].is_null() || (j["S4"].get<double>() >= 0.0 && j["S4"].get<double>() <= 1.0));
}

TEST(Cli, ReplicateSnapshotWritesTheFinalConfiguration) {
  const std::string path = ::testing::TempDir() + "ringsim_snapshot_test.xyz";
  std::remove(path.c_str());
  const Cmd c = run_cli("replicate --seed 4 --set run.t_max=30 --snapshot " + path + " --json");
  ASSERT_EQ(c.status, 0) << c.out;
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  const Snapshot snap = read_extended_xyz(in);
  EXPECT_EQ(snap.bodies.size(), 600u);
  EXPECT_DOUBLE_EQ(snap.time, 30.0);
  const nlohmann::json j = nlohmann::json::parse(c.out);
  EXPECT_EQ(static_cast<int>(snap.bonds.size()), j["bonds"].get<int>());
  for (const SnapshotBody& b : snap.bodies)
    for (int d = 0; d < 3; ++d) {
      EXPECT_GE(b.x[d], 0.0);
      EXPECT_LE(b.x[d], 50.0);
    }
  std::remove(path.c_str());
}

TEST(Cli, ReplicateSeriesFeedsTheMserCommand) {
  // N_t sampled every 0.5 over 40 time units: 81 samples from at most 600
  // (pairs placed inside a capture shell bond at t = 0) down, each no larger
  // than the previous (bonds only merge objects); `ringsim mser` reads the
  // file as written.
  const std::string path = ::testing::TempDir() + "ringsim_series_test.txt";
  std::remove(path.c_str());
  Cmd c = run_cli("replicate --seed 6 --set run.t_max=40 --set run.sample_interval=0.5 --series " + path + " --json");
  ASSERT_EQ(c.status, 0) << c.out;
  std::ifstream in(path);
  std::string line;
  std::vector<double> v;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#') v.push_back(std::stod(line));
  ASSERT_EQ(v.size(), 81u);
  EXPECT_LE(v.front(), 600.0);
  EXPECT_GT(v.front(), 590.0);
  for (std::size_t k = 1; k < v.size(); ++k) EXPECT_LE(v[k], v[k - 1]) << k;
  const nlohmann::json j = nlohmann::json::parse(c.out);
  c = run_cli("mser " + path);
  ASSERT_EQ(c.status, 0) << c.out;
  const nlohmann::json m = nlohmann::json::parse(c.out);
  EXPECT_EQ(m["batches"].get<int>(), 16);  // floor(81 / 5)
  EXPECT_EQ(v.back(), static_cast<double>(j["N_t"].get<int>()));  // the sample at t_max is the final state
  std::remove(path.c_str());
}

TEST(Cli, BadInputIsRejectedNamingKeyValueAndRange) {
  Cmd c = run_cli("replicate --seed 1 --set contact.restitution_sphere=1.5");
  EXPECT_EQ(c.status, 1);
  EXPECT_NE(c.out.find("contact.restitution_sphere"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("1.5"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("[0, 1]"), std::string::npos) << c.out;
  c = run_cli("replicate --seed 1 --set bonding.dtheta_deg=200");
  EXPECT_EQ(c.status, 1);
  EXPECT_NE(c.out.find("bonding.dtheta_deg"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("200"), std::string::npos) << c.out;
  c = run_cli("replicate --seed 1 --set geometry.box_lenght=30");
  EXPECT_EQ(c.status, 1);
  EXPECT_NE(c.out.find("did you mean"), std::string::npos) << c.out;
  c = run_cli("replicate --seed 1 --set init.linkers=20000");
  EXPECT_EQ(c.status, 2);
  EXPECT_NE(c.out.find("packing fraction"), std::string::npos) << c.out;
  c = run_cli("replicate --seed 1 --set geometry.boundary=periodic --set geometry.box_length=8.5");
  EXPECT_EQ(c.status, 1);  // > 2 R (4.47) but not > 2 x the interaction range (8.98)
  EXPECT_NE(c.out.find("geometry.box_length = 8.5"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("periodic"), std::string::npos) << c.out;
  c = run_cli("replicate");  // --seed is required
  EXPECT_NE(c.status, 0);
  EXPECT_NE(c.out.find("--seed"), std::string::npos) << c.out;
}

// `args` with stdout sent to `target` (e.g. /dev/full); stderr is captured.
Cmd run_cli_stdout_to(const std::string& args, const std::string& target, const std::string& stdin_from = "") {
  return run_shell((stdin_from.empty() ? "" : stdin_from + " | ") + std::string(RINGSIM_BINARY) + " " + args +
                   " 2>&1 >" + target);
}

TEST(Cli, EveryCommandsHelpTeachesItsExitCodes) {
  // A sweep found exit codes only in `run --help`.
  for (const char* command : {"replicate", "run", "aggregate", "mser", "keys"}) {
    const Cmd c = run_cli(std::string(command) + " --help");
    EXPECT_EQ(c.status, 0) << command;
    EXPECT_NE(c.out.find("Exit codes: 0 done"), std::string::npos) << command << ":\n" << c.out;
    EXPECT_NE(c.out.find("xample"), std::string::npos) << command << ":\n" << c.out;
  }
  EXPECT_NE(run_cli("--help").out.find("exit codes"), std::string::npos);
}

TEST(Cli, FailedWritesToStdoutAreErrors) {
  // Before: every one of these exited 0 with nothing written.
  const char* commands[] = {"keys", "replicate --seed 1 --set run.t_max=0.5 --json"};
  for (const char* args : commands) {
    const Cmd c = run_cli_stdout_to(args, "/dev/full");
    EXPECT_EQ(c.status, 3) << args << ": " << c.out;
    EXPECT_NE(c.out.find("cannot write to standard output"), std::string::npos) << args << ": " << c.out;
  }
  const Cmd m = run_cli_stdout_to("mser", "/dev/full", "seq 100");
  EXPECT_EQ(m.status, 3) << m.out;
  EXPECT_NE(m.out.find("cannot write to standard output"), std::string::npos) << m.out;
  EXPECT_EQ(run_cli_stdout_to("keys", "/dev/null").status, 0);
}

TEST(Cli, SeedsAndReplicateIndicesDoNotWrap) {
  // CLI11 read these as 2^64 - 1 (or 2^64 - 3) without a word.
  for (const char* args : {"--seed -1", "--seed 18446744073709551616", "--seed 99999999999999999999999",
                           "--seed 1 --replicate -3", "--seed 1.5"}) {
    const Cmd c = run_cli(std::string("replicate --set run.t_max=0.5 ") + args);
    EXPECT_EQ(c.status, 1) << args << ": " << c.out;
    const std::string option = std::string(args).find("--replicate") != std::string::npos ? "--replicate" : "--seed";
    EXPECT_NE(c.out.find(option), std::string::npos) << args << ": " << c.out;
    EXPECT_NE(c.out.find("[0, 18446744073709551615]"), std::string::npos) << args << ": " << c.out;
  }
  const Cmd ok = run_cli("replicate --seed 18446744073709551615 --replicate 0 --set run.t_max=0.5 --json");
  ASSERT_EQ(ok.status, 0) << ok.out;
  EXPECT_EQ(nlohmann::json::parse(ok.out)["seed"].get<std::uint64_t>(), 18446744073709551615ull);
}

TEST(Cli, ReplicateChecksItsOutputPathsBeforeRunning) {
  // A missing directory, a directory, a FIFO and a device are refused with
  // exit 1 before the simulation (before: after it, losing the result, or
  // blocked forever on the FIFO).
  const std::string dir = ::testing::TempDir() + "ringsim_cli_paths_" + std::to_string(getpid());
  ASSERT_EQ(mkdir(dir.c_str(), 0700), 0);
  const std::string fifo = dir + "/series.fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const struct {
    std::string args, says;
  } cases[] = {{"--snapshot " + dir + "/missing/final.xyz", "does not exist"},
               {"--series " + dir, "is a directory"},
               {"--series " + fifo, "FIFO"},
               {"--snapshot /dev/null", "character device"}};
  for (const auto& k : cases) {
    const Cmd c = run_cli("replicate --seed 1 --set run.t_max=5 --json " + k.args);
    EXPECT_EQ(c.status, 1) << k.args << ": " << c.out;
    EXPECT_NE(c.out.find(k.says), std::string::npos) << k.args << ": " << c.out;
    EXPECT_EQ(c.out.find("termination"), std::string::npos) << k.args << ": " << c.out;
  }
  std::remove(fifo.c_str());
  rmdir(dir.c_str());
}

}  // namespace
}  // namespace ringsim
