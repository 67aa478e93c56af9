#pragma once
// Free motion between events: ballistic translation and exact torque-free
// rotation of a symmetric top (a linker) or a sphere.
//
// A free symmetric top keeps its angular momentum L; its axis u precesses
// rigidly about L at the constant rate |L| / I_perp (Landau & Lifshitz,
// Mechanics, section 33). The rotation is therefore exact: Rodrigues' formula
// applied to the stored axis, no integration error.

#include "core/axis_rotation.hpp"
#include "core/body.hpp"
#include "core/geometry.hpp"

namespace ringsim {

// Rotate unit vector u about the axis of w by angle |w| * dt (Rodrigues).
Vec3 rotate_about(const Vec3& u, const Vec3& w, double dt);

inline Vec3 position_at(const Kinematics& k, double t) { return k.x + k.v * (t - k.t); }
inline Vec3 axis_at(const Kinematics& k, double t) { return rotate_about(k.axis, k.precession, t - k.t); }
inline Vec3 omega_at(const Kinematics& k, double t) { return k.precession + k.spin * axis_at(k, t); }

// Move the reference time of a body to t (same trajectory).
void advance(Kinematics& k, double t);
// The same for a free body of the given shape: a sphere's axis carries no
// information (it keeps (0, 0, 1)), so only its centre moves and no
// rotation is evaluated.
inline void advance(Kinematics& k, double t, Shape shape) {
  if (shape != Shape::Sphere) {
    advance(k, t);
    return;
  }
  k.x += k.v * (t - k.t);
  k.t = t;
}

// Angular momentum and kinetic energy of a body at its reference time.
Vec3 angular_momentum(const Kinematics& k, const Species& s);
double rotational_energy(const Kinematics& k, const Species& s);
inline double translational_energy(const Kinematics& k, const Species& s) {
  return 0.5 * s.mass * k.v.squaredNorm();
}

// World-frame inverse inertia tensor at axis u.
Mat3 inverse_inertia(const Species& s, const Vec3& u);

// Set the angular velocity omega (world) of a body at its reference time,
// recomputing precession and spin so that omega = precession + spin * axis.
void set_angular_velocity(Kinematics& k, const Species& s, const Vec3& omega);

// Largest speed of any point of the *shape* due to rotation, about the centre:
// |Omega| times the largest distance of the solid from the precession axis
// through the centre (constant during free flight). Spheres: 0, since a
// rotating sphere keeps its shape.
double shape_rotation_speed(const Kinematics& k, const Species& s);

geom::Cylinder cylinder_at(const Kinematics& k, const Species& s, double t);

}  // namespace ringsim
