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

Mat3 collision_matrix(const std::vector<CompliantBody>& bodies, const JointSet& joints, const Eigen::MatrixXd& c) {
  const MassMatrix m(bodies);
  const Eigen::MatrixXd minv_ct = m.inverse_times(Eigen::MatrixXd(c.transpose()));  // M^-1 C^T
  Mat3 k = c * minv_ct;
  if (!joints.empty()) {
    // C M^-1 G^T S^+ G M^-1 C^T = B^T S^+ B with B = G M^-1 C^T: three
    // solves, not W's n.
    JointRows rows;
    joint_rows(bodies, m.layout, joints, rows);
    // B's columns lie in the range of S (B = G X), so any solution gives
    // the same B^T lambda = C M^-1 (G^T lambda): the LDL^T cut short serves
    // where S is rank deficient, not the complete orthogonal decomposition.
    MultiplierSolve::Options options;
    options.any_solution = true;
    MultiplierSolve solve;
    solve.compute(rows.g, m.inverse_blocks(), options);
    const Eigen::MatrixXd b = rows.g * minv_ct;
    Eigen::MatrixXd sb(b.rows(), 3);
    for (int col = 0; col < 3; ++col) sb.col(col) = solve.solve(b.col(col));
    k -= b.transpose() * sb;
  }
  return 0.5 * (k + k.transpose());  // symmetric to round-off
}

Mat3 collision_matrix(const std::vector<CompliantBody>& bodies, const JointSet& joints, int body, const Vec3& arm) {
  const VelocityLayout layout(bodies);
  return collision_matrix(bodies, joints, point_velocity_rows(bodies, layout, body, arm));
}

Mat3 collision_matrix(const std::vector<CompliantBody>& bodies, const JointSet& joints, int body_a,
                      const Vec3& arm_a, int body_b, const Vec3& arm_b) {
  const VelocityLayout layout(bodies);
  return collision_matrix(bodies, joints,
                          point_velocity_rows(bodies, layout, body_b, arm_b) -
                              point_velocity_rows(bodies, layout, body_a, arm_a));
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
