#pragma once
// Where is a body at time t, and how fast can it move? One answer for free
// bodies (their own Kinematics, core/motion.hpp) and for members of rigid
// clusters (the cluster's trajectory, core/body.hpp). Prediction, contact
// response and validation ask these functions, never how a body moves.
//
// Reference motion. Every body has a reference point that moves on a straight
// line (a free body: its centre; a cluster member: the cluster's centre of
// mass) and a radius about it that contains its solid at all times. Relative
// to the reference point, a point of the solid at distance rho moves at most
// rate * rho; rotation_bound() is that speed for the points that matter for
// distances (a sphere member: its centre; a linker: the whole solid). These
// bounds are what conservative advancement steps with.

#include <limits>

#include "core/body.hpp"
#include "core/geometry.hpp"
#include "core/motion.hpp"
#include "core/track.hpp"

namespace ringsim {

// A member of a rigid or a compliant cluster (its motion is not its own Kinematics).
inline bool in_cluster(const BodyStore& b, int i) { return b.group[i] >= 0 || b.cgroup[i] >= 0; }
inline bool is_compliant(const BodyStore& b, int i) { return b.cgroup[i] >= 0; }
// The end of the interval over which body i's present motion is known: a
// compliant member's slice end; never for the others. Every search involving
// the body stops there (the next slice bumps and re-predicts the member).
inline double motion_horizon(const BodyStore& b, int i) {
  return b.cgroup[i] >= 0 ? b.track[i].tb : std::numeric_limits<double>::infinity();
}

// Centre at t (cluster members: not wrapped into a periodic box).
inline Vec3 body_center(const BodyStore& b, int i, double t) {
  if (b.cgroup[i] >= 0) return track_center(b.track[i], t);
  const int g = b.group[i];
  if (g < 0) return position_at(b.kin[i], t);
  const Cluster& c = b.clusters[g];
  return c.x + c.v * (t - c.t) + c.orientation_at(t) * b.offset[i];
}

inline Vec3 body_axis(const BodyStore& b, int i, double t) {
  if (b.cgroup[i] >= 0) return b.shape[i] == Shape::Sphere ? Vec3(Vec3::UnitZ()) : track_axis(b.track[i], t);
  const int g = b.group[i];
  if (g < 0) {
    const Kinematics& k = b.kin[i];
    if (static_cast<std::size_t>(i) >= b.axis_memo.size()) return axis_at(k, t);
    BodyStore::AxisMemo& m = b.axis_memo[static_cast<std::size_t>(i)];
    const double dt = t - k.t;
    if (k.axis != m.turn.u || k.precession != m.precession) {
      m.turn = AxisRotation::of(k.axis, k.precession);
      m.precession = k.precession;
      m.dt = std::numeric_limits<double>::quiet_NaN();
    }
    if (dt != m.dt) {
      m.result = m.turn.at(dt);
      m.dt = dt;
    }
    return m.result;
  }
  return b.clusters[g].orientation_at(t) * b.body_axis[i];
}

// Angular velocity of the body (cluster members: the cluster's).
Vec3 body_omega(const BodyStore& b, int i, double t);

// Velocity of the material point p of body i's *shape* at t; `center` is the
// body's centre at t in the same periodic image as p. Free linkers: spin about
// the own axis does not move the shape and is left out (as in prediction).
Vec3 shape_point_velocity(const BodyStore& b, int i, double t, const Vec3& p, const Vec3& center);
// Velocity of the material point p including every rotation (for impulses).
Vec3 material_point_velocity(const BodyStore& b, int i, double t, const Vec3& p, const Vec3& center);

inline Vec3 reference_center(const BodyStore& b, int i, double t) {
  if (b.cgroup[i] >= 0) {
    const Track& k = b.track[i];
    return k.xa + k.vbar * (t - k.ta);
  }
  const int g = b.group[i];
  if (g < 0) return position_at(b.kin[i], t);
  const Cluster& c = b.clusters[g];
  return c.x + c.v * (t - c.t);
}
inline const Vec3& reference_velocity(const BodyStore& b, int i) {
  if (b.cgroup[i] >= 0) return b.track[i].vbar;
  const int g = b.group[i];
  return g < 0 ? b.kin[i].v : b.clusters[g].v;
}
// Radius about the reference point containing the solid at all times.
inline double reference_offset(const BodyStore& b, int i) {
  if (b.cgroup[i] >= 0) return b.track[i].dev;
  return b.group[i] < 0 ? 0.0 : b.reach[i];
}
inline double reference_radius(const BodyStore& b, int i) { return b.sp(i).bounding_radius + reference_offset(b, i); }
// The three together (reference point at t, its velocity, the radius), with
// one test of the body's kind: the neighbour loop's windows ask for them for
// every neighbour, most of them free bodies.
struct ReferencePoint {
  Vec3 x, v;
  double radius;
};
inline ReferencePoint reference_point(const BodyStore& b, int i, double t) {
  if (b.cgroup[i] < 0 && b.group[i] < 0) {
    const Kinematics& k = b.kin[i];
    return {position_at(k, t), k.v, b.sp(i).bounding_radius};
  }
  return {reference_center(b, i, t), reference_velocity(b, i), reference_radius(b, i)};
}
// Largest speed, relative to the reference point, of any point of the solid
// that can change a distance to this body (a sphere: its centre only).
double rotation_bound(const BodyStore& b, int i);
// Largest speed, relative to the reference point, of a point at distance
// `arm` from the body's centre (e.g. a linker end: arm = half length).
double point_rotation_bound(const BodyStore& b, int i, double arm);

// First-order motion of body i's solid at time s, for certified steps that
// use the direction of the rotation (core/prediction_clusters.cpp). The
// solid (a free linker: its shape, which its spin does not move) turns
// rigidly about the reference point, so r(t) = x(t) - ref(t) keeps its length,
// r' = omega x r and r'' = omega' x r + omega x (omega x r). By Taylor's
// theorem with the Lagrange remainder every material point x obeys
//   x(s + tau) = x(s) + tau (v + omega(s) x r(s)) + e,
//   |e| <= accel |r(s)| tau^2 / 2,  accel >= max_t (|omega'(t)| + |omega(t)|^2),
// with v = reference_velocity. Free sphere: omega = 0, accel = 0 (its ball
// never changes); free linker: omega = Omega, constant (core/motion.hpp).
// Compliant member: about its own centre (RefMotion below).
struct LocalMotion {
  Vec3 omega;    // angular velocity of the solid at s (world)
  double accel;  // bound on |r''| / |r| for all times
};
// Members of clusters only (compliant or rigid); local_motion below takes any body.
LocalMotion cluster_local_motion(const BodyStore& b, int i, double s);
inline LocalMotion local_motion(const BodyStore& b, int i, double s) {
  // A free body inline (the searches ask for it several times per step):
  // its precession, constant; a sphere's ball does not turn.
  if (b.cgroup[i] < 0 && b.group[i] < 0) {
    if (b.shape[i] == Shape::Sphere) return {Vec3::Zero(), 0.0};
    const Vec3& w = b.kin[i].precession;
    return {w, w.squaredNorm()};
  }
  return cluster_local_motion(b, i, s);
}
// The reference point of certified steps (LocalMotion): centre + offset,
// moving at v within accel tau^2 / 2. Free bodies and rigid clusters: the
// linear reference motion above (accel 0). Compliant members: their own
// centre with its velocity and the track's acceleration bound; their solid
// turns about it with the axis (LocalMotion: omega = axis x axis').
struct RefMotion {
  Vec3 offset;
  Vec3 v;
  double accel;
};
inline RefMotion ref_motion(const BodyStore& b, int i, double s) {
  if (b.cgroup[i] >= 0) return {Vec3::Zero(), track_velocity(b.track[i], s), b.track[i].center_accel};
  return {reference_center(b, i, s) - body_center(b, i, s), reference_velocity(b, i), 0.0};
}

geom::Cylinder body_cylinder(const BodyStore& b, int i, double t);

// World inverse inertia tensor and mass of what an impulse on body i moves:
// the body itself, or its whole cluster.
double moving_mass(const BodyStore& b, int i);
Mat3 moving_inverse_inertia(const BodyStore& b, int i, double t);
// Velocity of the centre of what moves: the body's (a compliant member's own,
// not its slice's chord) or its rigid cluster's centre of mass.
inline Vec3 moving_velocity(const BodyStore& b, int i, double t) {
  return b.cgroup[i] >= 0 ? track_velocity(b.track[i], t) : reference_velocity(b, i);
}
// Centre of what moves (the body's centre or the cluster's centre of mass)
// in the image of `center`, the body's centre at t.
Vec3 moving_center(const BodyStore& b, int i, double t, const Vec3& center);

}  // namespace ringsim
