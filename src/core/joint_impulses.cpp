#include "core/joint_impulses.hpp"

#include "core/constrained_dynamics.hpp"
#include "core/joint_projection.hpp"

namespace ringsim {

Eigen::MatrixXd point_velocity_rows(const std::vector<CompliantBody>& bodies, const VelocityLayout& layout, int body,
                                    const Vec3& arm) {
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(3, layout.size);
  const int o = layout.offset[body];
  c.block<3, 3>(0, o) = Mat3::Identity();
  if (bodies[body].shape == Shape::Linker) {
    // omega x r = -[r]x omega
    Mat3 s;
    s << 0.0, -arm.z(), arm.y(), arm.z(), 0.0, -arm.x(), -arm.y(), arm.x(), 0.0;
    c.block<3, 3>(0, o + 3) = -s;
  }
  return c;
}

Eigen::MatrixXd constrained_inverse_mass(const std::vector<CompliantBody>& bodies, const JointSet& joints) {
  const MassMatrix m(bodies);
  const Eigen::MatrixXd minv = m.inverse_times(Eigen::MatrixXd(Eigen::MatrixXd::Identity(m.layout.size, m.layout.size)));
  if (joints.empty()) return minv;
  JointRows rows;
  joint_rows(bodies, m.layout, joints, rows);
  const MultiplierSolve solve(rows.g, m);
  // M^-1 G^T S^+ G M^-1 = B S^+ B^T with B = M^-1 G^T.
  const Eigen::MatrixXd& b = solve.minv_gt();
  Eigen::MatrixXd sb(b.cols(), b.rows());
  const Eigen::MatrixXd bt = b.transpose();
  for (int k = 0; k < bt.cols(); ++k) sb.col(k) = solve.solve(bt.col(k));
  Eigen::MatrixXd w = minv - b * sb;
  return 0.5 * (w + w.transpose());  // symmetric to round-off
}

Mat3 collision_matrix(const std::vector<CompliantBody>& bodies, const JointSet& joints, int body, const Vec3& arm) {
  const VelocityLayout layout(bodies);
  const Eigen::MatrixXd c = point_velocity_rows(bodies, layout, body, arm);
  return c * constrained_inverse_mass(bodies, joints) * c.transpose();
}

Mat3 collision_matrix(const std::vector<CompliantBody>& bodies, const JointSet& joints, int body_a,
                      const Vec3& arm_a, int body_b, const Vec3& arm_b) {
  const VelocityLayout layout(bodies);
  const Eigen::MatrixXd c =
      point_velocity_rows(bodies, layout, body_b, arm_b) - point_velocity_rows(bodies, layout, body_a, arm_a);
  return c * constrained_inverse_mass(bodies, joints) * c.transpose();
}

void apply_impulse(std::vector<CompliantBody>& bodies, const JointSet& joints, const Eigen::MatrixXd& c,
                   const Eigen::VectorXd& p) {
  const MassMatrix m(bodies);
  set_velocities(bodies, m.layout, velocity_vector(bodies, m.layout) + m.inverse_times(Eigen::VectorXd(c.transpose() * p)));
  project_velocities(bodies, joints);
}

void apply_point_impulse(std::vector<CompliantBody>& bodies, const JointSet& joints, int body, const Vec3& arm,
                         const Vec3& impulse) {
  const VelocityLayout layout(bodies);
  apply_impulse(bodies, joints, point_velocity_rows(bodies, layout, body, arm), impulse);
}

}  // namespace ringsim
