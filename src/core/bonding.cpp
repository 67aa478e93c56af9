// Capture and bond formation inside the event loop (MODEL.md, "Capture and
// bond formation"): the bond rules, rigid merges with ring closure, the
// checks at t = 0, and the "no bond possible" end. Part of class Simulation
// (core/simulation.hpp); the geometry of the rules is core/bond_rules.hpp.
#include <algorithm>
#include <string>
#include <tuple>
#include <vector>

#include "core/bond_rules.hpp"
#include "core/cluster.hpp"
#include "core/joints.hpp"
#include "core/motion.hpp"
#include "core/pose.hpp"
#include "core/simulation.hpp"

namespace ringsim {

namespace {
constexpr double kRadPerDeg = 3.14159265358979323846 / 180.0;
}  // namespace

bool Simulation::rules_allow(int s, int l, int end, double t) {
  if (rules_pass(s, l, end, t)) return true;
  predictor_.capture_refused(l, end, s);
  return false;
}

bool Simulation::rules_pass(int s, int l, int end, double t) {
  const BondingParams& bp = params_.bonding;
  // 1. valency: a free end, a sphere below its valency.
  if (bp.end_valency < 1 || graph_.sphere_of(l, end) >= 0 || graph_.degree(s) >= bp.sphere_valency) {
    ++stats_.rejected_valency;
    return false;
  }
  const Vec3 u = body_axis(bodies_, l, t);
  const Vec3 out = outward_axis(u, end);
  // 2. bond angle at the sphere, against every linker already bonded to it.
  if (bp.angle_filter) {
    for (const auto& [l2, e2] : graph_.linkers_of(s)) {
      const double theta = bond_angle_deg(out, outward_axis(body_axis(bodies_, l2, t), e2));
      // Articulated: a held angle needs a measurable gradient (never within
      // the study's window; core/joints.hpp, held_angle_defined).
      if (!angle_ok(theta, bp) || (articulated_ && !held_angle_defined(theta * kRadPerDeg))) {
        ++stats_.rejected_angle;
        return false;
      }
    }
  }
  if (!bp.coplanarity_filter) return true;
  // 3. coplanarity, for every linker whose two ends would both be bonded to
  // spheres that carry a second linker: the dihedral about its axis between
  // the neighbouring linkers' outward axes (MODEL.md).
  // The dihedral about linker c (axis uc) with neighbour axis n_at[e] at its end e.
  auto planar = [&](const Vec3& uc, const Vec3& n_end0, const Vec3& n_end1) {
    if (articulated_ && !held_dihedral_defined(uc, n_end0, n_end1)) return false;  // could not be held
    return planarity_ok(dihedral_deg(uc, n_end0, n_end1), bp);
  };
  // (a) the new linker l: neighbours at s (this end) and at the sphere on its other end.
  const int s_other = graph_.sphere_of(l, 1 - end);
  if (s_other >= 0) {
    for (const auto& [la, ea] : graph_.linkers_of(s)) {
      const Vec3 na = outward_axis(body_axis(bodies_, la, t), ea);
      for (const auto& [lb, eb] : graph_.linkers_of(s_other)) {
        if (lb == l) continue;
        const Vec3 nb = outward_axis(body_axis(bodies_, lb, t), eb);
        if (!(end == 0 ? planar(u, na, nb) : planar(u, nb, na))) {
          ++stats_.rejected_coplanarity;
          return false;
        }
      }
    }
  }
  // (b) each linker c already at s: the new linker becomes its neighbour at s.
  for (const auto& [c, ec] : graph_.linkers_of(s)) {
    const int s3 = graph_.sphere_of(c, 1 - ec);
    if (s3 < 0) continue;
    const Vec3 uc = body_axis(bodies_, c, t);
    for (const auto& [l3, e3] : graph_.linkers_of(s3)) {
      if (l3 == c) continue;
      const Vec3 n3 = outward_axis(body_axis(bodies_, l3, t), e3);
      if (!(ec == 0 ? planar(uc, out, n3) : planar(uc, n3, out))) {
        ++stats_.rejected_coplanarity;
        return false;
      }
    }
  }
  return true;
}

void Simulation::form_bond(int s, int l, int end, double t) {
  if (compliant_) {
    form_compliant_bond(s, l, end, t);
    return;
  }
  graph_.add_bond(s, l, end, t);
  ++stats_.bonds;
  const int gs = bodies_.group[s], gl = bodies_.group[l];
  if (gs >= 0 && gs == gl) {  // a ring closing inside one cluster
    monitor_.set(t, graph_.N_t());
    return;
  }
  // Rigid bond: the two groups become one rigid body. Pairs the merge puts
  // inside one cluster are checked now (this is how a rigid ring closes).
  auto members = [&](int b) {
    const int g = bodies_.group[b];
    return g < 0 ? std::vector<int>{b} : bodies_.clusters[g].members;
  };
  const std::vector<int> side_s = members(s), side_l = members(l);
  const double before = group_kinetic_energy(bodies_, s) + group_kinetic_energy(bodies_, l);
  const int g = merge_groups(bodies_, box_, s, l, t);
  stats_.lost_rigid_merges += before - group_kinetic_energy(bodies_, s);
  std::vector<std::tuple<int, int, int>> closures;  // (sphere, linker, end)
  const double rc = params_.bonding.capture_distance;
  const double band = params_.run.contact_tolerance;
  auto scan = [&](const std::vector<int>& from, const std::vector<int>& to) {
    for (int a : from) {
      if (bodies_.shape[a] != Shape::Sphere) continue;
      for (int b : to) {
        if (bodies_.shape[b] != Shape::Linker) continue;
        for (int e = 0; e < 2; ++e)
          if (graph_.sphere_of(b, e) < 0 && predictor_.capture_gap(b, e, a, t, rc) <= band) closures.emplace_back(a, b, e);
      }
    }
  };
  scan(side_s, side_l);
  scan(side_l, side_s);
  std::sort(closures.begin(), closures.end());
  for (const auto& [cs, cl, ce] : closures) {
    if (rules_allow(cs, cl, ce, t)) {
      ++stats_.closure_bonds;
      graph_.add_bond(cs, cl, ce, t);
      ++stats_.bonds;
    }
  }
  monitor_.set(t, graph_.N_t());
  if (box_.periodic) {
    double extent = 0.0;
    for (int m : bodies_.clusters[g].members) extent = std::max(extent, reference_radius(bodies_, m));
    check_cluster_extent("rigid", extent, t);
  }
}

void Simulation::check_cluster_extent(const char* kind, double extent, double t) {
  if (4.0 * extent <= box_.length) return;
  termination_ = Termination::Error;
  error_ = std::string("a ") + kind + " cluster reached a radius of " + std::to_string(extent) + " at t = " +
           std::to_string(t) + ", more than a quarter of the periodic box (geometry.box_length = " +
           std::to_string(box_.length) + "); minimum images would be ambiguous: use a larger box or reflective walls";
}

void Simulation::process_capture(int i, const Event& ev, double t) {
  const int j = ev.partner;
  const int l = bodies_.shape[i] == Shape::Linker ? i : j, s = l == i ? j : i;
  ++stats_.captures;
  if (rules_allow(s, l, ev.dim, t)) {
    touch(s, t, false);
    touch(l, t, false);
    form_bond(s, l, ev.dim, t);
    bump(l, t);  // l and s now share a cluster: every member
    if (termination_ == Termination::Error) return;
    predict_group(l, t);
    if (!bond_possible()) termination_ = Termination::NoBondPossible;
  } else {
    // Nothing changes; the pair may capture again only after leaving the shell.
    predict(i, t);
  }
}

bool Simulation::repeats_a_refusal(int i, const Event& ev) const {
  // A pending capture of a pair whose capture the rules refused since it was
  // predicted: every search of the pair that starts after a refusal, inside
  // the shell, walks out first (Predictor::capture), so this one was found
  // before the refusal, from the other body's side. It would be refused
  // again; it is stale.
  if (ev.type != EventType::Capture) return false;
  const bool linker = bodies_.shape[i] == Shape::Linker;
  return predictor_.capture_is_refused(linker ? i : ev.partner, ev.dim, linker ? ev.partner : i);
}

void Simulation::check_initial_captures() {
  // MODEL.md: rules are checked at t = 0 for pairs already inside the shell.
  const double rc = params_.bonding.capture_distance;
  std::vector<std::tuple<int, int, int>> inside;
  for (int s = 0; s < n_spheres_; ++s) {
    grid_.for_each_near(grid_.cell_of_body(s), [&](int l) {
      if (bodies_.shape[l] != Shape::Linker) return;
      for (int e = 0; e < 2; ++e)
        if (predictor_.capture_gap(l, e, s, 0.0, rc) <= 0.0) inside.emplace_back(s, l, e);
    });
  }
  std::sort(inside.begin(), inside.end());
  for (const auto& [s, l, e] : inside) {
    if (graph_.sphere_of(l, e) >= 0) continue;
    ++stats_.captures;
    if (!rules_allow(s, l, e, 0.0)) continue;
    if (articulated_) {
      // A rigid articulated cluster formed by an earlier bond of this pass
      // is carried rigidly: wake it (and cut an integrated one), as
      // process_capture does. (Compliant clusters formed at t = 0 need
      // neither: their integrators stand at t = 0.)
      touch(s, 0.0, false);
      touch(l, 0.0, false);
    }
    form_bond(s, l, e, 0.0);
  }
}

bool Simulation::bond_possible() const {
  // A bond needs a free end and a sphere below its valency in *different*
  // groups (a rigid cluster never closes a ring later).
  const BondingParams& bp = params_.bonding;
  if (bp.end_valency < 1) return false;
  // Groups are keyed by cluster id, free bodies by -1 - id.
  int first_group = 0;
  bool seen = false, spread = false, any_sphere = false, any_end = false;
  // Compliant bonds: a cluster can close a ring inside itself (its bodies
  // move relative to each other; a relaxed one wakes when disturbed), so
  // every body counts as its own group.
  // An articulated cluster with no internal freedom is carried rigidly until
  // another bond: a rigid body again.
  auto rigid_group = [&](int g) {
    return !compliant_ || (g < static_cast<int>(dormant_.size()) && dormant_[g] >= 0 && cgroups_[dormant_[g]].rigid);
  };
  auto note = [&](int b) {
    const int g = bodies_.group[b];
    const int key = g >= 0 && rigid_group(g) ? g : -1 - b;
    if (!seen) first_group = key, seen = true;
    else if (key != first_group) spread = true;
  };
  for (int s = 0; s < n_spheres_; ++s)
    if (graph_.degree(s) < bp.sphere_valency) {
      any_sphere = true;
      note(s);
    }
  for (int l = n_spheres_; l < bodies_.size(); ++l)
    if (graph_.sphere_of(l, 0) < 0 || graph_.sphere_of(l, 1) < 0) {
      any_end = true;
      note(l);
    }
  return any_sphere && any_end && spread;
}

}  // namespace ringsim
