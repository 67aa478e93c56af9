#include "core/pose.hpp"

namespace ringsim {

Vec3 body_omega(const BodyStore& b, int i, double t) {
  const int g = b.group[i];
  if (g < 0) return omega_at(b.kin[i], t);
  const Cluster& c = b.clusters[g];
  return c.rot.omega_world(t - c.t);
}

Vec3 shape_point_velocity(const BodyStore& b, int i, double t, const Vec3& p, const Vec3& center) {
  const int g = b.group[i];
  if (g < 0) return b.kin[i].v + b.kin[i].precession.cross(p - center);
  const Cluster& c = b.clusters[g];
  return c.v + c.rot.omega_world(t - c.t).cross(p - moving_center(b, i, t, center));
}

Vec3 material_point_velocity(const BodyStore& b, int i, double t, const Vec3& p, const Vec3& center) {
  if (b.group[i] >= 0) return shape_point_velocity(b, i, t, p, center);
  return b.kin[i].v + omega_at(b.kin[i], t).cross(p - center);
}

double rotation_bound(const BodyStore& b, int i) {
  const int g = b.group[i];
  const Species& s = b.sp(i);
  if (g < 0) return shape_rotation_speed(b.kin[i], s);
  return b.clusters[g].max_rate * (b.reach[i] + (s.shape == Shape::Sphere ? 0.0 : s.bounding_radius));
}

double point_rotation_bound(const BodyStore& b, int i, double arm) {
  const int g = b.group[i];
  if (g < 0) return b.shape[i] == Shape::Sphere ? 0.0 : b.kin[i].precession.norm() * arm;
  return b.clusters[g].max_rate * (b.reach[i] + arm);
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
  if (g < 0) return inverse_inertia(b.sp(i), axis_at(b.kin[i], t));
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
