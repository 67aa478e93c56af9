#include "core/motion.hpp"

#include <cmath>

namespace ringsim {

Vec3 rotate_about(const Vec3& u, const Vec3& w, double dt) {
  // Rodrigues: u cos + (k x u) sin + k (k.u)(1 - cos), k = w/|w|, evaluated
  // as AxisRotation does, so that one-off and repeated evaluations agree to
  // the last bit.
  return AxisRotation::of(u, w).at(dt);
}

void advance(Kinematics& k, double t) {
  if (t == k.t) return;
  k.x += k.v * (t - k.t);
  k.axis = rotate_about(k.axis, k.precession, t - k.t);
  k.axis.normalize();  // keeps |u| = 1 against accumulated rounding
  k.t = t;
}

Mat3 inverse_inertia(const Species& s, const Vec3& u) {
  if (s.shape == Shape::Sphere) return Mat3::Identity() / s.i_perp;
  const Mat3 uu = u * u.transpose();
  return (Mat3::Identity() - uu) / s.i_perp + uu / s.i_axial;
}

Vec3 angular_momentum(const Kinematics& k, const Species& s) {
  // L = I_perp * Omega by construction of the precession vector (spheres:
  // precession is omega and I_perp the moment).
  return s.i_perp * k.precession;
}

double rotational_energy(const Kinematics& k, const Species& s) {
  const Vec3 omega = k.precession + k.spin * k.axis;
  return 0.5 * omega.dot(angular_momentum(k, s));
}

void set_angular_velocity(Kinematics& k, const Species& s, const Vec3& omega) {
  if (s.shape == Shape::Sphere) {
    k.precession = omega;
    k.spin = 0.0;
    return;
  }
  const double w_ax = omega.dot(k.axis);
  const Vec3 L = s.i_perp * (omega - w_ax * k.axis) + s.i_axial * w_ax * k.axis;
  k.precession = L / s.i_perp;
  k.spin = L.dot(k.axis) * (1.0 / s.i_axial - 1.0 / s.i_perp);
}

double shape_rotation_speed(const Kinematics& k, const Species& s) {
  if (s.shape == Shape::Sphere) return 0.0;
  const double rate = k.precession.norm();
  if (rate == 0.0) return 0.0;
  // A point s*u + r*w (|s| <= h, w unit and normal to u) lies at most
  // h sin(psi) + r from the precession axis, psi = angle(u, Omega).
  const double c = k.precession.dot(k.axis) / rate;
  const double sin_psi = std::sqrt(std::max(0.0, 1.0 - c * c));
  return rate * (s.half_length * sin_psi + s.radius);
}

geom::Cylinder cylinder_at(const Kinematics& k, const Species& s, double t) {
  return geom::Cylinder{position_at(k, t), axis_at(k, t), s.radius, s.half_length};
}

}  // namespace ringsim
