#pragma once
// Small linear-algebra vocabulary of the core: Eigen fixed-size types.
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ringsim {
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;

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
