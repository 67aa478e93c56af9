#include "core/joint_projection.hpp"

#include <cmath>

#include "core/constrained_dynamics.hpp"

namespace ringsim {
namespace {

double max_abs(const Eigen::VectorXd& x) { return x.size() == 0 ? 0.0 : x.cwiseAbs().maxCoeff(); }

}  // namespace

VelocityProjection project_velocities(std::vector<CompliantBody>& bodies, const JointSet& joints) {
  VelocityProjection r;
  if (joints.empty()) return r;
  const MassMatrix m(bodies);
  JointRows rows;
  joint_rows(bodies, m.layout, joints, rows);
  const MultiplierSolve solve(rows.g, m);
  const Eigen::VectorXd nu = velocity_vector(bodies, m.layout);
  const Eigen::VectorXd gv = rows.g * nu;
  const Eigen::VectorXd nu1 = nu - solve.minv_gt() * solve.solve(gv);
  set_velocities(bodies, m.layout, nu1);
  r.residual_before = max_abs(gv);
  r.residual_after = max_abs(rows.g * nu1);
  r.energy_change = 0.5 * (nu1.dot(m.times(nu1)) - nu.dot(m.times(nu)));
  return r;
}

PositionProjection project_positions(std::vector<CompliantBody>& bodies, const JointSet& joints, double tolerance,
                                     int max_iterations) {
  PositionProjection r;
  if (joints.empty()) {
    r.converged = true;
    return r;
  }
  double moved2 = 0.0;
  for (;;) {
    const MassMatrix m(bodies);
    JointRows rows;
    joint_rows(bodies, m.layout, joints, rows);
    const double res = max_abs(rows.c);
    if (r.iterations == 0) r.residual_before = res;
    r.residual_after = res;
    if (res <= tolerance || r.iterations >= max_iterations) break;
    const MultiplierSolve solve(rows.g, m);
    const Eigen::VectorXd dnu = -solve.minv_gt() * solve.solve(rows.c);
    displace(bodies, m.layout, dnu);
    moved2 += dnu.dot(m.times(dnu));
    ++r.iterations;
  }
  r.converged = r.residual_after <= tolerance;
  r.displacement = std::sqrt(moved2);
  r.velocities = project_velocities(bodies, joints);
  return r;
}

}  // namespace ringsim
