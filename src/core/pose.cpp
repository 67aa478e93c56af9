#include "core/pose.hpp"

#include <cassert>
#include <cmath>

namespace ringsim {

Vec3 body_omega(const BodyStore& b, int i, double t) {
  if (b.cgroup[i] >= 0) return b.shape[i] == Shape::Sphere ? b.track[i].sphere_omega : track_omega(b.track[i], t);
  const int g = b.group[i];
  if (g < 0) return omega_at(b.kin[i], t);
  const Cluster& c = b.clusters[g];
  return c.rot.omega_world(t - c.t);
}

Vec3 shape_point_velocity(const BodyStore& b, int i, double t, const Vec3& p, const Vec3& center) {
  if (b.cgroup[i] >= 0) return track_shape_velocity(b.track[i], t, p, center);
  const int g = b.group[i];
  if (g < 0) return b.kin[i].v + b.kin[i].precession.cross(p - center);
  const Cluster& c = b.clusters[g];
  return c.v + c.rot.omega_world(t - c.t).cross(p - moving_center(b, i, t, center));
}

Vec3 material_point_velocity(const BodyStore& b, int i, double t, const Vec3& p, const Vec3& center) {
  if (b.cgroup[i] >= 0) return track_velocity(b.track[i], t) + body_omega(b, i, t).cross(p - center);
  if (b.group[i] >= 0) return shape_point_velocity(b, i, t, p, center);
  return b.kin[i].v + omega_at(b.kin[i], t).cross(p - center);
}

double rotation_bound(const BodyStore& b, int i) {
  const int g = b.group[i];
  const Species& s = b.sp(i);
  if (b.cgroup[i] >= 0) {
    // The centre strays from the chord at most at center_speed; the solid
    // turns with its axis, no point farther than bounding_radius from the centre.
    const Track& k = b.track[i];
    return k.center_speed + (s.shape == Shape::Sphere ? 0.0 : k.axis_rate * s.bounding_radius);
  }
  if (g < 0) return shape_rotation_speed(b.kin[i], s);
  return b.clusters[g].max_rate * (b.reach[i] + (s.shape == Shape::Sphere ? 0.0 : s.bounding_radius));
}

double point_rotation_bound(const BodyStore& b, int i, double arm) {
  if (b.cgroup[i] >= 0) return b.track[i].center_speed + (b.shape[i] == Shape::Sphere ? 0.0 : b.track[i].axis_rate * arm);
  const int g = b.group[i];
  if (g < 0) return b.shape[i] == Shape::Sphere ? 0.0 : b.kin[i].precession.norm() * arm;
  return b.clusters[g].max_rate * (b.reach[i] + arm);
}

LocalMotion cluster_local_motion(const BodyStore& b, int i, double s) {
  if (b.cgroup[i] >= 0) {
    if (b.shape[i] == Shape::Sphere) return {Vec3::Zero(), 0.0};
    const Track& k = b.track[i];
    const Vec3 w = track_omega(k, s);
    const Vec3 u = track_axis(k, s);
    return {w - w.dot(u) * u, k.axis_accel};  // the spin does not move the shape
  }
  assert(b.group[i] >= 0);  // a rigid member (local_motion takes free bodies)
  const Cluster& c = b.clusters[b.group[i]];
  // omega = I_world^-1 L = R diag(1/I) R^T L (L world and constant; R cached
  // by the caller's pose queries at s), without the elliptic functions.
  const Mat3& R = c.orientation_at(s);
  const Vec3 omega = R * (R.transpose() * c.rot.angular_momentum()).cwiseQuotient(c.moments);
  // |omega'|: Euler's equations in the principal frame (Landau & Lifshitz,
  // Mechanics, section 36), I_1 w_1' = (I_2 - I_3) w_2 w_3 and cyclic, with
  // |w_j w_k| <= |omega|^2 / 2; the world-frame derivative has the same norm
  // (d/dt (R w) = R w' since R' w = omega x omega = 0).
  const Vec3& I = c.moments;
  const double k1 = (I[1] - I[2]) / I[0], k2 = (I[2] - I[0]) / I[1], k3 = (I[0] - I[1]) / I[2];
  const double W2 = c.max_rate * c.max_rate;
  return {omega, W2 * (1.0 + 0.5 * std::sqrt(k1 * k1 + k2 * k2 + k3 * k3))};
}

geom::Cylinder body_cylinder(const BodyStore& b, int i, double t) {
  const Species& s = b.sp(i);
  return geom::Cylinder{body_center(b, i, t), body_axis(b, i, t), s.radius, s.half_length};
}

double moving_mass(const BodyStore& b, int i) {
  const int g = b.group[i];
  return g < 0 ? b.sp(i).mass : b.clusters[g].mass;
}

Mat3 moving_inverse_inertia(const BodyStore& b, int i, double t) {
  const int g = b.group[i];
  if (g < 0) return inverse_inertia(b.sp(i), body_axis(b, i, t));  // free or compliant: the body alone
  const Cluster& c = b.clusters[g];
  const Mat3& R = c.orientation_at(t);
  return R * c.moments.cwiseInverse().asDiagonal() * R.transpose();
}

Vec3 moving_center(const BodyStore& b, int i, double t, const Vec3& center) {
  const int g = b.group[i];
  if (g < 0) return center;
  return center - b.clusters[g].orientation_at(t) * b.offset[i];
}

}  // namespace ringsim
