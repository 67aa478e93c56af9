#include "core/bond_rules.hpp"

#include <algorithm>
#include <cmath>

namespace ringsim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegPerRad = 180.0 / kPi;

// Relative length below which a projection on the plane normal to the axis
// counts as degenerate (see the header).
constexpr double kDegenerateProjection = 1e-12;

}  // namespace

Vec3 linker_end(const Vec3& x, const Vec3& u, double half_length, int end) {
  return end == 0 ? Vec3(x + half_length * u) : Vec3(x - half_length * u);
}

Vec3 outward_axis(const Vec3& u, int end) { return end == 0 ? Vec3(-u) : u; }

double bond_angle_deg(const Vec3& n1, const Vec3& n2) {
  // atan2 of (|sin|, cos), both scaled by |n1||n2|: no normalization needed.
  return std::atan2(n1.cross(n2).norm(), n1.dot(n2)) * kDegPerRad;
}

std::optional<double> dihedral_deg(const Vec3& u, const Vec3& n0, const Vec3& n1) {
  const Vec3 uh = u.normalized();
  // u x n is the projection of n on the plane normal to u turned by 90 degrees
  // about u; turning both projections by the same rotation keeps their signed
  // angle, and the cross product gets the projection's length without the
  // cancellation of n - (n.u) u.
  const Vec3 a = uh.cross(n0);
  const Vec3 b = uh.cross(n1);
  const double na = a.norm(), nb = b.norm();
  if (na == 0.0 || nb == 0.0 || na < kDegenerateProjection * n0.norm() ||
      nb < kDegenerateProjection * n1.norm()) {
    return std::nullopt;
  }
  double phi = std::atan2(uh.dot(a.cross(b)), a.dot(b)) * kDegPerRad;
  // atan2 gives [-pi, pi]; -180 (a signed zero sine) is the same dihedral as 180.
  if (phi <= -180.0) phi = 180.0;
  return std::min(phi, 180.0);
}

double planarity_deviation_deg(double phi_deg, CoplanarityMode mode) {
  const double a = std::abs(phi_deg);
  switch (mode) {
    case CoplanarityMode::CisOrTrans: return std::min(a, 180.0 - a);
    case CoplanarityMode::Cis: return a;
  }
  return a;
}

bool angle_ok(double theta_deg, const BondingParams& bonding) {
  if (!bonding.angle_filter) return true;
  return std::abs(theta_deg - bonding.theta0_deg) <= bonding.dtheta_deg + kAngleSlackDeg;
}

bool planarity_ok(std::optional<double> phi_deg, const BondingParams& bonding) {
  if (!bonding.coplanarity_filter) return true;
  if (!phi_deg) return false;  // undefined dihedral: the rule fails (header)
  return planarity_deviation_deg(*phi_deg, bonding.coplanarity_mode) <= bonding.dphi_deg + kAngleSlackDeg;
}

}  // namespace ringsim
