#pragma once
// Small linear-algebra vocabulary of the core: Eigen fixed-size types.
#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ringsim {
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;

// The cross-product matrix: cross_matrix(r) v = r x v.
inline Mat3 cross_matrix(const Vec3& r) {
  Mat3 m;
  m << 0, -r.z(), r.y(), r.z(), 0, -r.x(), -r.y(), r.x(), 0;
  return m;
}

// Scalar forms of u.v and |u x v| for the hot support functions, the same
// bits as Eigen's u.dot(v) and u.cross(v).norm() (the same operations in the
// same order: (x + y) + z, no fused multiply-adds in this build), but written
// so that the compiler keeps every component in registers: with the Eigen
// expressions GCC stores the cross product's components one by one and reloads
// them as a pair for the squared norm, which stalls on store forwarding
// (perf on 600 linkers: the load after the store took more samples than the
// square root that follows).
inline double dot3(const Vec3& u, const Vec3& v) { return (u[0] * v[0] + u[1] * v[1]) + u[2] * v[2]; }
inline double norm3(const Vec3& v) { return std::sqrt((v[0] * v[0] + v[1] * v[1]) + v[2] * v[2]); }
inline double cross_norm(const Vec3& u, const Vec3& v) {
  const double x = u[1] * v[2] - u[2] * v[1];
  const double y = u[2] * v[0] - u[0] * v[2];
  const double z = u[0] * v[1] - u[1] * v[0];
  return std::sqrt((x * x + y * y) + z * z);
}

// The rotation that maps the z axis onto the unit vector `axis` (a linker's
// orientation from its axis; OVITO's particle Orientation for a cylinder whose
// rest axis is z). A rotation taking unit u onto unit a is q = (w, v) =
// (1 + u.a, u x a), normalised (half-angle form of axis-angle). With u = z
// this is (1 + a_z; -a_y, a_x, 0), |q|^2 = 2 (1 + a_z): fine for a_z >= 0 but
// degenerate as a -> -z. For a_z < 0 we instead compose a half turn about x
// (z -> -z, q_x = (0; 1, 0, 0)) with the rotation taking -z onto a,
// (1 - a_z; a_y, -a_x, 0); their product is (-a_y; 1 - a_z, 0, a_x), with
// |q|^2 = 2 (1 - a_z) >= 2. Both branches are exact rotations for a unit a
// and, with |q|^2 >= 2, lose no accuracy to cancellation (error ~ 1 ulp).
// Not Eigen's Quaternion::FromTwoVectors: near a = -z its 1 + z.a cancels,
// and q * z then comes out up to 3e-4 too long and 3e-6 off in direction
// (tests/test_compliant.cpp, AxisQuaternionNearMinusZ).
inline Quat orientation_from_axis(const Vec3& axis) {
  const double ax = axis.x(), ay = axis.y(), az = axis.z();
  // (0.0 - ay rather than -ay: no "-0" in snapshot files.)
  Quat q = (az >= 0.0) ? Quat(1.0 + az, 0.0 - ay, ax, 0.0) : Quat(0.0 - ay, 1.0 - az, 0.0, ax);
  q.normalize();
  return q;
}
}  // namespace ringsim
