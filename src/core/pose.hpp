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

#include "core/body.hpp"
#include "core/geometry.hpp"
#include "core/motion.hpp"

namespace ringsim {

inline bool in_cluster(const BodyStore& b, int i) { return b.group[i] >= 0; }

// Centre at t (cluster members: not wrapped into a periodic box).
inline Vec3 body_center(const BodyStore& b, int i, double t) {
  const int g = b.group[i];
  if (g < 0) return position_at(b.kin[i], t);
  const Cluster& c = b.clusters[g];
  return c.x + c.v * (t - c.t) + c.orientation_at(t) * b.offset[i];
}

inline Vec3 body_axis(const BodyStore& b, int i, double t) {
  const int g = b.group[i];
  if (g < 0) return axis_at(b.kin[i], t);
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
  const int g = b.group[i];
  if (g < 0) return position_at(b.kin[i], t);
  const Cluster& c = b.clusters[g];
  return c.x + c.v * (t - c.t);
}
inline const Vec3& reference_velocity(const BodyStore& b, int i) {
  const int g = b.group[i];
  return g < 0 ? b.kin[i].v : b.clusters[g].v;
}
// Radius about the reference point containing the solid at all times.
inline double reference_radius(const BodyStore& b, int i) {
  return b.sp(i).bounding_radius + (b.group[i] < 0 ? 0.0 : b.reach[i]);
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
struct LocalMotion {
  Vec3 omega;    // angular velocity of the solid at s (world)
  double accel;  // bound on |r''| / |r| for all times
};
LocalMotion local_motion(const BodyStore& b, int i, double s);

geom::Cylinder body_cylinder(const BodyStore& b, int i, double t);

// World inverse inertia tensor and mass of what an impulse on body i moves:
// the body itself, or its whole cluster.
double moving_mass(const BodyStore& b, int i);
Mat3 moving_inverse_inertia(const BodyStore& b, int i, double t);
// Centre of what moves (the body's centre or the cluster's centre of mass)
// in the image of `center`, the body's centre at t.
Vec3 moving_center(const BodyStore& b, int i, double t, const Vec3& center);

}  // namespace ringsim
