#pragma once
// Bodies: spheres and linkers (solid cylinders), in flat arrays indexed by a
// stable id (0 .. N-1; spheres first, then linkers).
//
// Kinematics are stored lazily ("delayed states", as in Smallenburg's EDMD):
// each body carries its own reference time t and its state at that time; the
// pose at any later time is a pure function of it (core/motion.hpp).
//
// Invariants of Kinematics, all world frame, reduced units:
//  - x: centre position at time t (periodic boxes: in [0, L) up to rounding);
//  - v: centre velocity, constant between events;
//  - axis: unit symmetry axis at time t (linkers; spheres keep (0,0,1));
//  - precession: the constant vector Omega = L / I_perp. A free symmetric top's
//    axis turns rigidly about Omega at rate |Omega| (so the *shape* of a
//    linker moves as a uniform rotation; its spin about the axis never moves
//    it). For spheres, precession is the (constant) angular velocity;
//  - spin: lambda = (L.axis)(1/I_axial - 1/I_perp), constant; the angular
//    velocity is omega(t) = Omega + lambda * axis(t). Spheres: 0.

#include <cstdint>
#include <limits>
#include <vector>

#include "core/axis_rotation.hpp"
#include "core/free_rotation.hpp"
#include "core/vec.hpp"

namespace ringsim {

enum class Shape : std::uint8_t { Sphere = 0, Linker = 1 };

// Field order and alignment put x, t and v (all a sphere-sphere prediction
// reads of its partner) in the first 64-byte cache line.
struct alignas(64) Kinematics {
  Vec3 x;
  double t;
  Vec3 v;
  Vec3 axis;
  Vec3 precession;
  double spin;
};

// A body at time 0 with the given centre, velocity and axis, not rotating.
inline Kinematics make_kinematics(const Vec3& x, const Vec3& v, const Vec3& axis) {
  Kinematics k;
  k.x = x;
  k.t = 0.0;
  k.v = v;
  k.axis = axis;
  k.precession = Vec3::Zero();
  k.spin = 0.0;
  return k;
}

// Per-species constants (shape, mass, inertia, contact material).
struct Species {
  Shape shape;
  double radius;
  double half_length;      // 0 for spheres
  double bounding_radius;  // max distance from centre to the solid
  double mass;
  double i_axial;          // moment about the symmetry axis (spheres: the moment)
  double i_perp;           // moment about a transverse axis (spheres: the moment)
  double restitution;
  double static_friction;
  double dynamic_friction;
};

// A rigid cluster (MODEL.md, "Two bond regimes", rigid): bonded bodies moving
// as one rigid body with the relative pose they had when they bonded.
//
// Invariants (world frame, reduced units):
//  - x: centre of mass at the reference time t (periodic boxes: wrapped into
//    [0, L) at every re-basing); v: its constant velocity;
//  - rot: exact torque-free rotation from t (core/free_rotation.hpp): the
//    orientation R(t) maps the body frame (principal axes) to the world; the
//    world angular momentum about the centre of mass is constant;
//  - a member i sits at x + v (t' - t) + R(t') offset[i] with axis
//    R(t') body_axis[i] (BodyStore);
//  - max_rate bounds |omega(t')| for all t' (rot.max_rate()).
// A cluster absorbed by a merge is left behind with no members (alive false).
struct Cluster {
  double t = 0.0;
  Vec3 x = Vec3::Zero();
  Vec3 v = Vec3::Zero();
  FreeRotation rot;
  Vec3 moments = Vec3::Ones();  // principal moments of inertia
  double mass = 0.0;
  double max_rate = 0.0;
  std::vector<int> members;
  bool alive = false;
  // Orientation cache: predictions evaluate many members at one time.
  mutable double cache_t = std::numeric_limits<double>::quiet_NaN();
  mutable Mat3 cache_R = Mat3::Identity();
  const Mat3& orientation_at(double t_abs) const {
    if (t_abs != cache_t) {
      cache_R = rot.orientation(t_abs - t);
      cache_t = t_abs;
    }
    return cache_R;
  }
};

// A compliant-cluster member's motion over its group's current slice
// [ta, tb] (core/compliant_group.hpp): the cubic Hermite interpolant of the
// integrator's states at both ends, for the centre and for the axis (a linker;
// normalized when evaluated). This polynomial *is* the member's trajectory for
// the event loop; positions and velocities are continuous across slices.
// Bounds over the slice (derivations in core/compliant_group.cpp):
//  - dev: |x(t) - (xa + vbar (t - ta))| <= dev (the chord is the reference
//    point of core/pose.hpp);
//  - center_speed: |x'(t) - vbar| <= center_speed;
//  - axis_rate: |d axis / dt| <= axis_rate;
//  - center_accel, axis_accel: second-order bounds for certified steps.
struct Track {
  double ta = 0.0, tb = 0.0;
  Vec3 xa = Vec3::Zero(), va = Vec3::Zero(), xb = Vec3::Zero(), vb = Vec3::Zero(), vbar = Vec3::Zero();
  Vec3 ua = Vec3::UnitZ(), wa = Vec3::Zero(), ub = Vec3::UnitZ(), wb = Vec3::Zero(), ubar = Vec3::Zero();
  // Quintic terms (core/track.hpp: alpha, beta) of the centre and the axis;
  // zero: the cubic. An articulated member's track is quintic, and its spin
  // follows the roll; a compliant member's is cubic, its spin linear in time
  // between spin_a and spin_b.
  bool quintic = false;
  Vec3 xc0 = Vec3::Zero(), xc1 = Vec3::Zero(), uc0 = Vec3::Zero(), uc1 = Vec3::Zero();
  double spin_a = 0.0, spin_b = 0.0;  // angular velocity along the axis at ta, tb
  // A linker's full orientation at ta, and its roll at tb about ub relative
  // to qa carried along the shortest turn from ua to ub (radians), with the
  // roll's rate at tb (at ta it is spin_a: the shortest-turn frame does not
  // spin at ua): the roll moves nothing in the event loop (a cylinder of
  // revolution) but an articulated cluster's off-axis joint anchors turn
  // with it (track_orientation, core/track.hpp).
  Quat qa = Quat::Identity();
  double roll_b = 0.0, roll_rate_b = 0.0;
  Vec3 sphere_omega = Vec3::Zero();   // a sphere's constant angular velocity (smooth: never changes)
  double dev = 0.0, center_speed = 0.0, axis_rate = 0.0;
  // Second-order bounds: |x''(t)| <= center_accel; the axis' turning,
  // |d/dt (axis x axis')| + |axis'|^2 <= axis_accel (core/compliant_group.cpp).
  double center_accel = 0.0, axis_accel = 0.0;
};

struct BodyStore {
  std::vector<Kinematics> kin;
  std::vector<Shape> shape;
  // Number of trajectory changes (impulses) so far: an event predicted against
  // a partner is valid only while the partner's counter is unchanged.
  std::vector<std::uint32_t> counter;
  std::vector<double> last_collision;  // time of the last impulse (TC model)
  Species species[2];
  // Rigid clusters. group[i] is body i's cluster, -1 for a free body (whose
  // trajectory is kin[i]); offset/body_axis: its centre relative to the
  // cluster's centre of mass and its axis, in the cluster's body frame;
  // reach[i] = |offset[i]|. Members' kin[i] is a snapshot for output only,
  // refreshed by Simulation::synchronize.
  std::vector<int> group;
  std::vector<Vec3> offset;
  std::vector<Vec3> body_axis;
  std::vector<double> reach;
  std::vector<Cluster> clusters;
  // Compliant clusters: cgroup[i] is body i's compliant group (-1: none; then
  // group[i] says free or rigid), track[i] its motion over the current slice.
  std::vector<int> cgroup;
  std::vector<Track> track;
  // A sphere's own angular velocity, carried aside while its compliant
  // cluster moves as a rigid body (relaxed or after a contact burst): a
  // smooth sphere's spin moves no pose and takes no impulse, so it is neither
  // merged into the cluster's tumbling nor lost; given back when the cluster
  // wakes. Zero otherwise (may be empty when no compliant cluster exists).
  std::vector<Vec3> held_spin;
  // A free body's axis at its last queried time, memoized on the exact
  // inputs of the rotation (record axis, precession, elapsed time): the
  // steps of one search ask for the same body at the same time several times
  // (distance, supports, planes), and the record's split of Rodrigues'
  // formula (AxisRotation) serves every elapsed time until the record
  // changes. A pure memo: the same bits as axis_at.
  struct AxisMemo {
    AxisRotation turn;  // of (turn.u = record axis, precession)
    Vec3 precession = Vec3::Zero(), result = Vec3::Zero();
    double dt = std::numeric_limits<double>::quiet_NaN();
  };
  mutable std::vector<AxisMemo> axis_memo;  // may be empty (then no memo)

  int size() const { return static_cast<int>(kin.size()); }
  const Species& sp(int i) const { return species[static_cast<int>(shape[i])]; }
  // Every body free: no rigid or compliant cluster, nothing held aside.
  void free_all() {
    const int n = size();
    group.assign(n, -1);
    offset.assign(n, Vec3::Zero());
    body_axis.assign(n, Vec3::UnitZ());
    reach.assign(n, 0.0);
    clusters.clear();
    cgroup.assign(n, -1);
    track.assign(n, Track{});
    held_spin.assign(n, Vec3::Zero());
    axis_memo.assign(n, AxisMemo{});
  }
};

}  // namespace ringsim
