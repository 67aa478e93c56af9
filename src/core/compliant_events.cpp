// Compliant clusters inside the event loop (docs/COMPLIANT.md, "Coupling";
// core/compliant_group.hpp): slices, cuts at impulses and bonds, compliant
// bond formation with ring closure, and the relaxed-cluster switch. Part of
// class Simulation (core/simulation.hpp).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <tuple>

#include "core/cluster.hpp"
#include "core/constrained_dynamics.hpp"
#include "core/joint_projection.hpp"
#include "core/motion.hpp"
#include "core/pose.hpp"
#include "core/simulation.hpp"

namespace ringsim {

namespace {
// A joint residual the projection cannot bring below this (length units of
// the sphere radius; radians for held rows) is a failure, not drift.
constexpr double kJointOpen = 1e-4;
// A released held row (Simulation::readmit_rows) is tested for independence
// once it strays this far from its held value (radians times sines).
constexpr double kReadmitAbove = 1e-6;

// What the integrator of group G sees for the state `model`: an articulated
// group's model keeps its bond topology (which bonds, angles and dihedrals
// exist) for the next bond's rules, but its joints act, not springs.
CompliantCluster integrated_model(const CompliantGroup& G, const CompliantCluster& model) {
  if (!G.articulated) return model;
  CompliantCluster c;
  c.bodies = model.bodies;
  c.params = model.params;
  return c;
}

// Group G's slice end at its integrator's present state. An articulated
// group's loads are its integrator's own right-hand side
// (ClusterIntegrator::present_loads), whose rates then serve the solver's
// restart at that state: one evaluation where there were two. A compliant
// group's are computed apart, as they always were (its trajectories stay
// bit for bit).
SliceEnd group_slice_end(CompliantGroup& G) {
  if (!G.articulated) return slice_end(G.integ->state(), G.joints);
  std::vector<Vec3> force, torque;
  G.integ->present_loads(force, torque);
  return slice_end(G.integ->state(), force, torque);
}
}  // namespace

IntegratorOptions Simulation::integrator_options() const {
  const CompliantParams& p = params_.compliant;
  IntegratorOptions o;
  o.rtol = p.rtol;
  o.atol = p.atol;
  switch (p.method) {
    // docs/COMPLIANT.md, stability study: explicit Runge-Kutta is the cheapest
    // up to k ~ 1e4 (4x cheaper than BDF at the study's k = 1e3); BDF's cost
    // is flat in stiffness and wins from ~1e4 to 1e5 on.
    case CompliantMethod::Auto: o.method = std::max(p.k, p.k_omega) <= 1e4 ? Method::ExplicitRk : Method::Bdf; break;
    case CompliantMethod::Bdf: o.method = Method::Bdf; break;
    case CompliantMethod::Adams: o.method = Method::Adams; break;
    case CompliantMethod::Erk: o.method = Method::ExplicitRk; break;
  }
  return o;
}

bool Simulation::contact_excluded(int i, int j) const {
  return params_.bonding.enabled && graph_.excluded(i, j, params_.bonding.exclusions == Exclusions::OneThree);
}

void Simulation::retire_integrator(CompliantGroup& g) {
  if (!g.integ) return;
  const IntegratorStats& st = g.integ->stats();
  stats_.sundials_steps += st.steps;
  stats_.sundials_rhs += st.rhs_evals;
  stats_.sundials_seconds += st.wall_seconds;
  g.integ.reset();
}

void Simulation::collect_integrator_stats() {
  // Retired integrators are already in stats_; add the live ones once, at the
  // end of the run (they are retired here so a second call adds nothing).
  for (CompliantGroup& g : cgroups_) retire_integrator(g);
}

void Simulation::cut_group(int g, double t) {
  CompliantGroup& G = cgroups_[g];
  if (G.pending && G.ta == t) return;  // already cut at t (both bodies of one contact)
  CompliantCluster& st = G.integ->mutable_state();
  for (std::size_t k = 0; k < G.members.size(); ++k)
    st.bodies[k] = member_state(bodies_, G.members[k], t, st.bodies[k], G.shift, G.articulated);
  // A slice's end that released a row or held one again (at the value it
  // had there) applies from that end on: before it the slice moved on the
  // joints of its start, and so does the state from the tracks here. Held
  // from this state a row readmitted at the end would be off by all it
  // moved in between (seen: a Scenario 3 dihedral 1.6e-3 from its
  // readmitted value after a cut, 1e-3 clear of another's span, which no
  // projection could close: the run ended in an error at t = 2156).
  if (t < G.tb ? G.restore_slice_joints() : (G.commit_slice_joints(), false)) G.integ->set_joints(G.joints);
  if (G.articulated) {
    // The tracks interpolate a linker's roll: fit the rolls to the joints
    // (invisible to the event loop). They keep the joints' velocities only to
    // their interpolation error: project them (G nu = 0) so that an impulse
    // or a bond at t acts on a consistent state. Positions are left as the
    // tracks have them (continuous motion); the next slice end projects them.
    const RollFit roll = fit_rolls(st.bodies, G.joints);
    stats_.cut_residual = std::max(stats_.cut_residual, roll.residual_after);
    stats_.lost_projections -=
        project_velocities(st.bodies, G.joints, false, &G.integ->projection_workspace()).energy_change;
  }
  G.ta = t;
  G.pending = true;
  ++stats_.slice_cuts;
}

bool Simulation::begin_slice(int g, double t) {
  CompliantGroup& G = cgroups_[g];
  // A slice that follows the last one (at its end tb) starts from its end
  // state, whose accelerations that slice's check computed; after a cut, a
  // bond or a new integrator (pending) the state is new.
  const bool follows = !G.pending && G.end_cached && G.tb == t;
  G.end_cached = false;
  if (G.pending) G.integ->reinit_at(t);
  G.pending = false;
  if (box_.periodic) {
    // Keep the centre of mass in the box through the shift (the integrator's
    // own coordinates run on unwrapped).
    Vec3 com = Vec3::Zero();
    double mass = 0.0;
    for (const CompliantBody& b : G.integ->state().bodies) {
      com += b.mass * b.x;
      mass += b.mass;
    }
    com = com / mass + G.shift;
    for (int d = 0; d < 3; ++d) G.shift[d] -= box_.length * std::floor(com[d] / box_.length);
  }
  const CompliantParams& cp = params_.compliant;
  const SliceEnd start = follows ? std::move(G.end) : group_slice_end(G);
  const double longest = G.articulated ? params_.bonding.joint_slice : cp.slice;
  double D = std::min(longest, G.track_slice);
  bool track_halved = false;
  double error = 0.0;
  G.commit_slice_joints();  // the last slice's end is this one's start
  // An attempt that is not kept goes back to the slice start, and so do the
  // joints (CompliantGroup::restore_slice_joints): a row readmitted at the
  // attempt's end (readmit_rows) holds the value it had there, and held from
  // the start state it would begin the retry that far from it (seen: a
  // Scenario 2 ring of four held angles, 8e-3 rad apart at t = 3510, which
  // no projection could close: the run ended in an error).
  // Back to the slice start (a fresh integrator: a failed one cannot go
  // on), release what is weak there (a change of the start state, so
  // committed), and try half the slice: its end's test (release_weak_rows)
  // then catches a weak row in time, and a shorter slice leaves the
  // integrator's error control less room to drift.
  auto retry_halved = [&] {
    G.restore_slice_joints();
    CompliantCluster st = G.integ->state();
    st.bodies = start.bodies;
    retire_integrator(G);
    G.integ = std::make_unique<ClusterIntegrator>(st, t, integrator_options(), G.joints);
    if (release_weak_rows(G, true, -1.0)) G.commit_slice_joints();
    G.end_cached = false;
    D *= 0.5;
    ++stats_.failed_slices;
  };
  for (int attempt = 0;; ++attempt) {
    const AdvanceResult r = G.integ->advance_to(t + D);
    if (!r.ok() && G.articulated && attempt < 8) {  // the steps collapsed: a held row came near the others' span
      retry_halved();
      continue;
    }
    if (!r.ok()) {
      termination_ = Termination::Error;
      error_ = std::string(G.articulated ? "articulated" : "compliant") + " cluster of " +
               std::to_string(G.members.size()) + " bodies: " + r.reason;
      return false;
    }
    PositionProjection pr;
    if (G.articulated) {
      // Drift back onto the joints at the slice end, in the integrator's own
      // state, before the tracks are laid (they end at the projected state,
      // so the motion stays continuous). Unconverged only at a singular pose
      // (a redundant ring's left null space, core/joint_projection.cpp):
      // recorded; an open joint ends the run.
      const double tol = params_.bonding.joint_tolerance;
      pr = G.integ->project_onto_joints(tol, true);
      const bool stalled = !(pr.residual_after <= tol) && stalled_on_held_row(G);
      if (release_weak_rows(G, stalled, pr.velocities.weakest_held_sine2) || readmit_rows(G)) {
        const double before = pr.residual_before;
        pr = G.integ->project_onto_joints(tol);
        pr.residual_before = std::max(before, pr.residual_before);
      }
      if (!(pr.residual_after <= kJointOpen) && attempt < 8) {
        // The slice drifted further than the projection can take back
        // (seen: a Scenario 2 cluster of 8 bodies, 5e-3 at t = 3510):
        // the same slice again, shorter.
        retry_halved();
        continue;
      }
      if (!(pr.residual_after <= kJointOpen)) {
        termination_ = Termination::Error;
        char msg[256];
        std::snprintf(msg, sizeof msg,
                      "articulated cluster of %zu bodies: a joint came %.3g apart at t = %.9g, and the position "
                      "projection left %.3g (bonding.joint_tolerance = %.3g): lower compliant.rtol",
                      G.members.size(), pr.residual_before, t + D, pr.residual_after, params_.bonding.joint_tolerance);
        error_ = msg;
        return false;
      }
    }
    // A slice in which an axis turns by about a radian or more is halved:
    // the interpolated axis must stay well away from zero length
    // (core/compliant_group.cpp). So is one whose tracks stray from the
    // integrated motion by more than compliant.track_tolerance (stiff bonds:
    // a slice longer than a bond period).
    // The end's accelerations make the tracks quintic (core/track.hpp).
    G.end = group_slice_end(G);
    G.end_cached = true;
    const double len = set_tracks(bodies_, G, start, t, G.end, t + D);
    bool good = len >= 0.5;
    if (good && cp.track_tolerance > 0.0) {
      error = track_error_estimate(start, G.end, D);
      good = error <= cp.track_tolerance;
      track_halved = track_halved || !good;
    }
    if (good || attempt == 30) {
      if (G.articulated) {  // the accepted slice's projection (a halved one's is undone)
        ++stats_.projections;
        stats_.joint_residual = std::max(stats_.joint_residual, pr.residual_before);
        stats_.projection_size = std::max(stats_.projection_size, pr.displacement);
        stats_.lost_projections -= pr.velocities.energy_change;
        stats_.joint_residual_after = std::max(stats_.joint_residual_after, pr.residual_after);
      }
      break;
    }
    G.integ->mutable_state().bodies = start.bodies;
    G.integ->reinit_at(t);
    if (G.restore_slice_joints()) G.integ->set_joints(G.joints);
    G.end_cached = false;
    D *= 0.5;
  }
  // The next slice starts from the length the tolerance allowed, and doubles
  // back towards the longest slice while the estimate (~ D^4) leaves room.
  if (track_halved) G.track_slice = D;
  else if (D == G.track_slice && error <= cp.track_tolerance / 32.0)
    G.track_slice = 2.0 * D < longest ? 2.0 * D : std::numeric_limits<double>::infinity();
  G.ta = t;
  G.tb = t + D;
  ++stats_.slices;
  return true;
}

void Simulation::process_slice(int i, const Event& ev, double t) {
  const int g = bodies_.cgroup[i];
  if (g < 0 || cgroups_[g].pending || cgroups_[g].tb != t) {  // superseded (a cut or a new group)
    ++stats_.stale;
    predict(i, t);
    return;
  }
  (void)ev;
  CompliantGroup& G = cgroups_[g];
  // Relaxed-cluster switch (issue "model no more than the scene needs"):
  // the internal kinetic energy at each slice boundary; quiet for relax_time
  // in a row: carry the cluster as a rigid body.
  const CompliantParams& cp = params_.compliant;
  if (cp.relax_energy > 0.0 && !G.articulated) {
    if (internal_kinetic_energy(G.integ->state()) <= cp.relax_energy) {
      if (std::isnan(G.quiet_since)) G.quiet_since = t;
      if (t - G.quiet_since >= cp.relax_time) {
        relax_group(g, G.integ->state(), t, Freeze::Relaxed);
        for (int m : G.members) ++bodies_.counter[m];
        for (int m : G.members) predict(m, t);
        return;
      }
    } else {
      G.quiet_since = std::numeric_limits<double>::quiet_NaN();
    }
  }
  if (!begin_slice(g, t)) return;
  for (int m : G.members) ++bodies_.counter[m];
  for (int m : G.members) predict(m, t);
}

void Simulation::relax_group(int g, const CompliantCluster& st, double t, Freeze why) {
  CompliantGroup& G = cgroups_[g];
  G.frozen_potential = potential_energy(st);
  const double before = kinetic_energy(st);
  for (std::size_t k = 0; k < G.members.size(); ++k) {
    const int m = G.members[k];
    CompliantBody b = st.bodies[k];
    b.x += G.shift;
    if (b.shape == Shape::Sphere) {
      bodies_.held_spin[m] = b.omega;  // carried aside (BodyStore::held_spin)
      b.omega = Vec3::Zero();
    }
    bodies_.kin[m] = kinematics_from(b, t);
    bodies_.cgroup[m] = -1;
  }
  // One rigid body with the present relative pose: a perfectly inelastic
  // merge (momentum and angular momentum kept; the small internal kinetic
  // energy and the linkers' spins' energy go). The spheres enter it as point
  // masses: their spins are held aside and do not turn with it, so that
  // wake_cluster gives them back exactly.
  int cluster = -1;
  for (std::size_t k = 1; k < G.members.size(); ++k)
    cluster = merge_groups(bodies_, box_, G.members[0], G.members[k], t, false);
  double after = group_kinetic_energy(bodies_, G.members[0]);
  for (int m : G.members) after += 0.5 * bodies_.sp(m).i_perp * bodies_.held_spin[m].squaredNorm();
  switch (why) {
    // (RunStats::relaxed counts the switches of both kinds.)
    case Freeze::Relaxed: stats_.lost_relaxed += before - after; ++stats_.relaxed; break;
    case Freeze::Burst: stats_.lost_bursts += before - after; ++stats_.relaxed; break;
    // Its velocities were already a rigid motion (projected onto joints that
    // leave no internal freedom): round-off.
    case Freeze::Rigid: stats_.lost_joint_impulses += before - after; break;
  }
  if (G.articulated) {
    // Each member's full orientation in the rigid body's frame: waking gives
    // the off-axis joint anchors back where they were.
    const Mat3& R = bodies_.clusters[cluster].orientation_at(t);
    const Quat to_body(Mat3(R.transpose()));
    G.frozen_rot.resize(G.members.size());
    for (std::size_t k = 0; k < G.members.size(); ++k) G.frozen_rot[k] = to_body * st.bodies[k].q;
  }
  retire_integrator(G);
  dormant_.resize(bodies_.clusters.size(), -1);
  dormant_[cluster] = g;
  G.pending = false;
  G.quiet_since = std::numeric_limits<double>::quiet_NaN();
  G.hold_until = -std::numeric_limits<double>::infinity();  // a quiet cluster wakes at any contact
}

void Simulation::wake_cluster(int cluster, double t) {
  const int g = dormant_[cluster];
  dormant_[cluster] = -1;
  CompliantGroup& G = cgroups_[g];
  Cluster& c = bodies_.clusters[cluster];
  rebase_cluster(c, box_, t);
  CompliantCluster st = G.model;
  for (std::size_t k = 0; k < G.members.size(); ++k) {
    const int m = G.members[k];
    const Vec3 x = body_center(bodies_, m, t);
    const Species& sp = bodies_.sp(m);
    const Vec3 omega = sp.shape == Shape::Sphere ? bodies_.held_spin[m] : body_omega(bodies_, m, t);
    bodies_.held_spin[m] = Vec3::Zero();
    st.bodies[k] = make_compliant_body(sp, x, shape_point_velocity(bodies_, m, t, x, x), body_axis(bodies_, m, t), omega);
    if (G.articulated && sp.shape == Shape::Linker)
      st.bodies[k].q = (Quat(c.orientation_at(t)) * G.frozen_rot[k]).normalized();
  }
  for (std::size_t k = 0; k < G.members.size(); ++k) {
    const int m = G.members[k];
    bodies_.group[m] = -1;
    bodies_.cgroup[m] = g;
    cindex_[m] = static_cast<int>(k);
  }
  c.alive = false;
  c.members.clear();
  G.shift = Vec3::Zero();
  G.integ = std::make_unique<ClusterIntegrator>(integrated_model(G, st), t, integrator_options(), G.joints);
  // Zero-length tracks: exact poses and velocities at t until the slice begins.
  const SliceEnd now{st.bodies, {}, {}};
  set_tracks(bodies_, G, now, t, now, t);
  G.ta = t;
  G.pending = true;
  G.rigid = false;  // until its next bond says again
  ++stats_.woken;
}

Simulation::ClusterShare Simulation::cluster_share() const {
  ClusterShare s;
  for (const CompliantGroup& G : cgroups_) {
    if (!G.alive || !G.articulated) continue;
    const int n = int(G.members.size());
    if (G.rigid) ++s.rigid, s.rigid_bodies += n;
    else ++s.articulated, s.articulated_bodies += n;
  }
  return s;
}

bool Simulation::release_weak_rows(CompliantGroup& G, bool stalled, double weakest) {
  // A held row whose gradient has come within kHoldSine2 of the span of the
  // others (a closed Scenario 3 triangle: its dihedrals are nearly one
  // function of the three rolls, docs/ARTICULATED.md, "Released rows") is
  // released, as at formation: held, its multiplier would grow as 1/sine^2
  // and the integrator's steps collapse; within kRankThreshold the dynamics
  // stop holding it and the projection stalls on it. Tested at every slice
  // end from the slice-end velocity projection's factors when S has full
  // rank (`weakest`: the held rows' columns of S~'s inverse), by
  // the greedy test when a projection stalls on a held row (S rank
  // deficient: a two-linker ring) or when a slice failed (`stalled`).
  if (G.joints.angles.empty() && G.joints.dihedrals.empty()) return false;
  const std::vector<CompliantBody>& bodies = G.integ->state().bodies;
  if (!stalled && !(weakest >= 0.0 && weakest < kHoldSine2)) return false;
  JointSet kept = G.joints, dropped;
  const int n = drop_redundant_held_rows(bodies, kept, &dropped, kHoldSine2);
  if (n == 0) return false;
  G.save_slice_joints();
  append_joints(G.released, dropped, 0);
  stats_.dropped_rows += n;
  stats_.released_rows += n;
  G.joints = kept;
  G.readmit_above = kReadmitAbove;
  G.integ->set_joints(std::move(kept));
  return true;
}

bool Simulation::stalled_on_held_row(const CompliantGroup& G) const {
  const int held = G.joints.rows() - 3 * int(G.joints.balls.size());
  if (held == 0) return false;
  // joint_residual's rows: the balls, then the held rows.
  const Eigen::VectorXd c = joint_residual(G.integ->state().bodies, G.joints);
  return c.tail(held).cwiseAbs().maxCoeff() > params_.bonding.joint_tolerance;
}

bool Simulation::readmit_rows(CompliantGroup& G) {
  // Released rows stray from their held values only while they stay nearly
  // implied by the others (then to second order). Once the motion has taken
  // one kReadmitSine2 clear of the others' span it is held again, at the
  // value it has then (no jump: the projection has nothing to take up); how
  // far it strayed is reported (RunStats::released_residual). The test runs
  // when a released row has strayed above kReadmitAbove, and after one that
  // readmits nothing, not again before that row has strayed twice as far.
  if (G.released.empty()) return false;
  const std::vector<CompliantBody>& bodies = G.integ->state().bodies;
  const double strayed = joint_residual(bodies, G.released).cwiseAbs().maxCoeff();
  stats_.released_residual = std::max(stats_.released_residual, strayed);
  if (!(strayed > G.readmit_above)) return false;
  JointSet left = G.released;
  const JointSet back = take_independent_rows(bodies, G.joints, left, kReadmitSine2);
  const int n = int(back.angles.size() + back.dihedrals.size());
  if (n == 0) {
    G.readmit_above = 2.0 * strayed;
    return false;
  }
  G.save_slice_joints();
  G.released = std::move(left);
  append_held_at_present(G.joints, back, bodies);
  stats_.readmitted_rows += n;
  G.readmit_above = kReadmitAbove;
  G.integ->set_joints(G.joints);
  return true;
}

void Simulation::add_group_bond(CompliantCluster& model, JointSet& joints, int s, int l, int end) {
  if (articulated_) add_articulated_bond(model, joints, s, l, end, params_.bonding);
  else add_compliant_bond(model, s, l, end, params_.bonding);
}

void Simulation::start_group(int g, CompliantCluster model, double t) {
  CompliantGroup& G = cgroups_[g];
  retire_integrator(G);
  G.commit_slice_joints();  // new joints: no slice has run on them
  if (G.articulated) {
    // Model no more than the scene needs: joints that leave no internal
    // freedom make one rigid body (exact free rotation), until the next
    // bond. The test counts every held row, released ones too (at the rank
    // threshold): a cluster that all its rows together leave rigid holds
    // them all exactly, even where some are nearly implied by the others;
    // only an integrated cluster releases rows.
    JointSet every = G.joints;
    append_joints(every, G.released, 0);
    G.rigid = internal_dof(model.bodies, every) <= 0;
    if (G.rigid) {
      // Held from now as they are (rows that had strayed, at their present values).
      append_held_at_present(G.joints, G.released, model.bodies);
      G.released = JointSet{};
    } else {
      // Surplus held rows (a ring closed under the filters) and rows nearly
      // implied by the others are released (kHoldSine2).
      stats_.dropped_rows += drop_redundant_held_rows(model.bodies, G.joints, &G.released, kHoldSine2);
      G.readmit_above = kReadmitAbove;
    }
    // The new joints' impulse: perfectly inelastic in the held directions
    // only (core/joint_projection.hpp), momentum and angular momentum kept.
    stats_.lost_joint_impulses -= project_velocities(model.bodies, G.joints).energy_change;
  }
  G.model = model;
  if (cluster_observer_) cluster_observer_(model, t);
  if (G.articulated) {
    ++(G.rigid ? stats_.joint_rigid : stats_.joint_articulated);
    if (G.rigid) {
      relax_group(g, G.model, t, Freeze::Rigid);
      return;
    }
  }
  G.integ = std::make_unique<ClusterIntegrator>(integrated_model(G, model), t, integrator_options(), G.joints);
  G.ta = t;
  G.pending = true;
}

void Simulation::form_compliant_bond(int s, int l, int end, double t) {
  // Both bodies were touched at t: free ones advanced, integrated clusters
  // cut (their integrator states are the states at t), relaxed or rigid
  // articulated ones woken.
  const BondingParams& bp = params_.bonding;
  graph_.add_bond(s, l, end, t);
  ++stats_.bonds;
  const int gs = bodies_.cgroup[s], gl = bodies_.cgroup[l];
  if (gs >= 0 && gs == gl) {
    // A ring closing inside one cluster: new terms, a new integrator.
    CompliantGroup& G = cgroups_[gs];
    CompliantCluster st = G.model;
    st.bodies = G.integ->state().bodies;
    const double before = potential_energy(st);
    add_group_bond(st, G.joints, cindex_[s], cindex_[l], end);
    bond_energy_ += potential_energy(st) - before;
    start_group(gs, std::move(st), t);
    monitor_.set(t, graph_.N_t());
    return;
  }
  // Merge the two sides (free bodies or clusters) into one integrated
  // cluster, side s first; states in world coordinates, side l moved to the
  // periodic image nearest to s.
  CompliantCluster nc;
  nc.params = params_.compliant;
  JointSet joints, released;
  std::vector<int> members;
  double before = 0.0;
  auto add_side = [&](int b) {
    const int base = static_cast<int>(members.size());
    const int g = bodies_.cgroup[b];
    if (g < 0) {
      Kinematics k = bodies_.kin[b];
      advance(k, t);
      nc.bodies.push_back(compliant_body_from(k, bodies_.sp(b)));
      members.push_back(b);
      return base;
    }
    CompliantGroup& G = cgroups_[g];
    const CompliantCluster& st = G.integ->state();
    before += potential_energy(st);
    for (std::size_t k = 0; k < G.members.size(); ++k) {
      CompliantBody body = st.bodies[k];
      body.x += G.shift;
      nc.bodies.push_back(body);
      members.push_back(G.members[k]);
    }
    // The terms (compliant springs; articulated: the topology) and joints,
    // renumbered.
    for (CompliantBond x : G.model.bonds) nc.bonds.push_back({x.sphere + base, x.linker + base, x.end});
    for (CompliantAngle x : G.model.angles)
      nc.angles.push_back({x.sphere + base, x.linker_a + base, x.end_a, x.linker_b + base, x.end_b, x.theta0});
    for (CompliantDihedral x : G.model.dihedrals)
      nc.dihedrals.push_back({x.linker + base, x.nb0 + base, x.nb0_end, x.nb1 + base, x.nb1_end, x.phi0});
    append_joints(joints, G.joints, base);
    append_joints(released, G.released, base);
    retire_integrator(G);
    G.alive = false;
    return base;
  };
  const int base_s = add_side(s);
  const int base_l = add_side(l);
  auto index_of = [&](int b) {
    return static_cast<int>(std::find(members.begin(), members.end(), b) - members.begin());
  };
  {
    const Vec3 xs = nc.bodies[index_of(s)].x, xl = nc.bodies[index_of(l)].x;
    const Vec3 move = box_.min_image(xl - xs) - (xl - xs);
    for (std::size_t k = base_l; k < nc.bodies.size(); ++k) nc.bodies[k].x += move;
  }
  add_group_bond(nc, joints, index_of(s), index_of(l), end);
  const int id = static_cast<int>(cgroups_.size());
  cgroups_.emplace_back();
  CompliantGroup& G = cgroups_.back();
  G.alive = true;
  G.articulated = articulated_;
  G.members = members;
  for (std::size_t k = 0; k < members.size(); ++k) {
    bodies_.cgroup[members[k]] = id;
    cindex_[members[k]] = static_cast<int>(k);
  }
  // Exact at t until the slice begins. Before the closure scan: from here on
  // body_center/body_axis read the members' tracks (cgroup >= 0), and a body
  // that was free has none yet (a default track, at the origin).
  const SliceEnd now{nc.bodies, {}, {}};
  set_tracks(bodies_, G, now, t, now, t);
  // Pairs the merge put inside one cluster that are already in the capture
  // shell are checked now (MODEL.md, "Capture and bond formation"); the
  // others can still close later, when their gap falls through r_c.
  std::vector<std::tuple<int, int, int>> closures;
  const double rc = bp.capture_distance, band = params_.run.contact_tolerance;
  auto scan = [&](int from_lo, int from_hi, int to_lo, int to_hi) {
    for (int a = from_lo; a < from_hi; ++a) {
      if (nc.bodies[a].shape != Shape::Sphere) continue;
      for (int b = to_lo; b < to_hi; ++b) {
        if (nc.bodies[b].shape != Shape::Linker) continue;
        for (int e = 0; e < 2; ++e)
          if (graph_.sphere_of(members[b], e) < 0 &&
              predictor_.capture_gap(members[b], e, members[a], t, rc) <= band)
            closures.emplace_back(members[a], members[b], e);
      }
    }
  };
  const int n = static_cast<int>(members.size());
  scan(base_s, base_l, base_l, n);
  scan(base_l, n, base_s, base_l);
  std::sort(closures.begin(), closures.end());
  for (const auto& [cs, cl, ce] : closures) {
    if (rules_allow(cs, cl, ce, t)) {
      ++stats_.closure_bonds;
      graph_.add_bond(cs, cl, ce, t);
      add_group_bond(nc, joints, cindex_[cs], cindex_[cl], ce);
      ++stats_.bonds;
    }
  }
  bond_energy_ += potential_energy(nc) - before;
  G.joints = std::move(joints);
  G.released = std::move(released);
  if (box_.periodic) {
    Vec3 com = Vec3::Zero();
    double mass = 0.0;
    for (const CompliantBody& b : nc.bodies) com += b.mass * b.x, mass += b.mass;
    com /= mass;
    double extent = 0.0;
    for (const CompliantBody& b : nc.bodies) extent = std::max(extent, (b.x - com).norm() + b.radius + b.half_length);
    check_cluster_extent(articulated_ ? "articulated" : "compliant", extent, t);
  }
  start_group(id, std::move(nc), t);
  monitor_.set(t, graph_.N_t());
}

EnergyBudget Simulation::energy_budget() const {
  EnergyBudget e;
  e.initial = initial_energy_;
  e.bonds_in = bond_energy_;
  e.kinetic = mechanical_totals(bodies_, now_).energy;
  e.potential = compliant_potential(now_);
  e.contacts = stats_.lost_contacts;
  e.rigid_merges = stats_.lost_rigid_merges;
  e.relaxed = stats_.lost_relaxed;
  e.bursts = stats_.lost_bursts;
  e.joint_impulses = stats_.lost_joint_impulses;
  e.projections = stats_.lost_projections;
  e.dampers = e.initial + e.bonds_in - e.kinetic - e.potential - e.contacts - e.rigid_merges - e.relaxed - e.bursts -
              e.joint_impulses - e.projections;
  return e;
}

double Simulation::compliant_potential(double t) const {
  double e = 0.0;
  for (std::size_t g = 0; g < cgroups_.size(); ++g) {
    const CompliantGroup& G = cgroups_[g];
    if (!G.alive) continue;
    // Relaxed: carried rigidly with its pose (and strain) frozen. (Not
    // `!G.integ`: the end of a run retires every integrator, the tracks stay.)
    if (bodies_.cgroup[G.members[0]] != static_cast<int>(g)) {
      e += G.frozen_potential;
      continue;
    }
    CompliantCluster st = G.model;
    for (std::size_t k = 0; k < G.members.size(); ++k)
      st.bodies[k] = member_state(bodies_, G.members[k], t, G.model.bodies[k], G.shift);
    e += potential_energy(st);
  }
  return e;
}

}  // namespace ringsim
