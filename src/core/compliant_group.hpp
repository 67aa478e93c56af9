#pragma once
// A compliant cluster inside the event loop (MODEL.md, "Two bond regimes",
// compliant; docs/COMPLIANT.md, "Coupling"): its bodies' state is integrated
// by a ClusterIntegrator in *slices*. A slice [ta, tb] is integrated ahead of
// the event loop; each member then moves on the cubic Hermite interpolant of
// the integrator's states at ta and tb (Track, core/body.hpp), which is a pure
// function of time with proven bounds on its motion (core/track.hpp), so
// contacts, walls, cell exits and captures are predicted on it by
// conservative advancement exactly like any other body (core/pose.hpp). At
// tb the next slice starts from the integrator's own state (positions and
// velocities are continuous). An impulse or a bond at t inside a slice cuts
// it: the members' states at t are read from their tracks, the integrator is
// restarted there, the jump applied, and a new slice begins at t.

#include <limits>
#include <memory>
#include <vector>

#include "core/body.hpp"
#include "core/compliant.hpp"
#include "core/compliant_integrator.hpp"

namespace ringsim {

// One end of a slice: the members' integrator states and their second time
// derivatives (centre, and a linker's axis) under the cluster's field:
// forces, torques and the gyroscopic term.
struct SliceEnd {
  std::vector<CompliantBody> bodies;
  std::vector<Vec3> center_accel, axis_accel;
};
SliceEnd slice_end(const CompliantCluster& c, const JointSet& joints = {});
// The same from the loads on every member (cluster_loads' force and torque).
SliceEnd slice_end(const CompliantCluster& c, const std::vector<Vec3>& force, const std::vector<Vec3>& torque);

struct CompliantGroup {
  bool alive = false;
  std::vector<int> members;  // body ids; model.bodies[k] is body members[k]
  CompliantCluster model;    // terms and parameters (its state is not kept up to date)
  std::unique_ptr<ClusterIntegrator> integ;
  // World positions = integrator positions + shift (periodic boxes: keeps the
  // group's centre of mass in the box without touching the integrator).
  Vec3 shift = Vec3::Zero();
  double ta = 0.0, tb = 0.0;  // the present slice
  bool pending = false;       // the integrator stands at ta with a changed state: a slice must begin
  // Longest slice compliant.track_tolerance allowed lately (infinity: none
  // was shortened by it); Simulation::begin_slice.
  double track_slice = std::numeric_limits<double>::infinity();
  // The present slice's end state with its accelerations (when the check
  // computed them): the next slice's start, unless a cut comes first.
  SliceEnd end;
  bool end_cached = false;
  // Relaxed-cluster switch (core/compliant_group.cpp): start of the present
  // quiet stretch (internal kinetic energy below the tolerance at every slice
  // boundary since then); NaN while not quiet.
  double quiet_since = std::numeric_limits<double>::quiet_NaN();
  double frozen_potential = 0.0;  // potential energy while carried rigidly (relaxed)
  // Contact bursts (core/compliant_events.cpp): time of the last impulse and
  // the length of the present run of impulses less than compliant.burst_time apart.
  double burst_last = -std::numeric_limits<double>::infinity();
  int burst_count = 0;
  // After a contact burst the rigid cluster is held (contacts do not wake it)
  // until no contact has come for burst_time.
  double hold_until = -std::numeric_limits<double>::infinity();
  // Articulated bonds (bonding.joint = articulated; docs/ARTICULATED.md): the
  // joints, indices into model.bodies (model's terms are then the topology
  // only: no springs). rigid: the joints leave no internal freedom, so the
  // group always moves as one rigid body (dormant from its formation; only a
  // new bond wakes it); frozen_rot: each member's orientation in that rigid
  // body's frame, kept while dormant (the roll of off-axis anchors).
  bool articulated = false;
  bool rigid = false;
  JointSet joints;
  // Held angles and dihedrals a rank test removed from `joints` (implied by
  // the others at the time: drop_redundant_held_rows), kept to report how far
  // they stray from their held values (SimStats::released_residual).
  JointSet released;
  double readmit_above = 0.0;  // Simulation::readmit_rows tests them when one strays above this
  std::vector<Quat> frozen_rot;

  // The joints in force during the present slice, saved before its end
  // first changes them (a row released or held again there:
  // Simulation::release_weak_rows, readmit_rows). A rejected attempt at the
  // slice (Simulation::begin_slice) and a cut inside it
  // (Simulation::cut_group) take the state back to a time before that
  // change, so they take these back too; a change that belongs to the
  // slice's start is committed instead.
  void save_slice_joints() {
    if (slice_changed_joints) return;
    slice_joints = joints;
    slice_released = released;
    slice_readmit_above = readmit_above;
    slice_changed_joints = true;
  }
  bool restore_slice_joints() {  // true: the joints changed (the integrator needs them)
    if (!slice_changed_joints) return false;
    joints = std::move(slice_joints);
    released = std::move(slice_released);
    readmit_above = slice_readmit_above;
    slice_changed_joints = false;
    return true;
  }
  void commit_slice_joints() { slice_changed_joints = false; }

 private:
  bool slice_changed_joints = false;
  JointSet slice_joints, slice_released;
  double slice_readmit_above = 0.0;
};

// Tracks of every member of g over [ta, tb] from the slice ends a at ta and
// b at tb (shift applied): for an articulated group, quintic when both ends
// carry their accelerations; otherwise cubic (core/track.hpp). Returns the smallest lower
// bound of the interpolated axis' length over the slice (1 when there is no
// linker); the caller shortens the slice when it is small (a turn of more
// than ~1 rad).
double set_tracks(BodyStore& b, const CompliantGroup& g, const SliceEnd& a, double ta, const SliceEnd& e, double tb);

// An estimate of how far the cubic Hermite through the slice ends (without
// their accelerations) strays from the motion the integrator followed: for
// every member, the distance at the slice's midpoint between that cubic and
// the quintic that also matches the accelerations at both ends, for the
// centre plus the axis scaled by the linker's half length (an end point);
// the largest over the members. The quintic minus the cubic at the midpoint
// is D (v_a - v_b) / 32 + D^2 (a_a + a_b) / 64: zero for every cubic motion,
// and like the cubic's own error it grows as D^4 times the motion's fourth
// derivative (halving D divides it by ~16). The tracks themselves are the
// quintics (set_tracks), whose error is higher order: the estimate bounds
// it from above with a wide margin.
double track_error_estimate(const SliceEnd& a, const SliceEnd& b, double D);

// State of member i at t (inside its slice) from its track, in the
// integrator's frame (shift removed). `model` supplies the body's constants.
// A linker's orientation: full_orientation, with its roll (an articulated
// cluster's anchors); else the standard one of its axis (compliant terms see
// the axis only).
CompliantBody member_state(const BodyStore& b, int i, double t, const CompliantBody& model, const Vec3& shift,
                           bool full_orientation = false);

// Kinetic energy of the cluster's motion relative to the rigid motion with
// the same momentum and angular momentum (centre of mass, composite inertia
// tensor of the present pose): zero exactly when every body moves rigidly.
double internal_kinetic_energy(const CompliantCluster& c);

}  // namespace ringsim
