#include "core/shapes.hpp"

#include <cmath>

namespace ringsim {

namespace {
constexpr double kPi = 3.14159265358979323846;
}

MassProps sphere_mass_props(double r, double rho) {
  const double m = 4.0 / 3.0 * kPi * r * r * r * rho;
  const double i = 0.4 * m * r * r;
  return {m, i, i};
}

MassProps cylinder_mass_props(double r, double l, double rho) {
  const double m = rho * kPi * r * r * l;
  return {m, 0.5 * m * r * r, m * (3.0 * r * r + l * l) / 12.0};
}

double cylinder_bounding_radius(double r, double l) { return std::hypot(r, 0.5 * l); }

}  // namespace ringsim
