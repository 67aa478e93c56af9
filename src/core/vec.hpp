#pragma once
// Small linear-algebra vocabulary of the core: Eigen fixed-size types.
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ringsim {
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;
}  // namespace ringsim
