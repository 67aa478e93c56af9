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

Mat3 collision_matrix(const std::vector<CompliantBody>& bodies, const JointSet& joints, const Eigen::MatrixXd& c,
                      MultiplierSolve* workspace) {
  // K = C W C^T with W = M^-1 - M^-1 G^T S^+ G M^-1, the inverse mass the
  // joints leave: W C^T is M^-1 C^T projected M-orthogonally onto the null
  // space of G, three corrections on the hosted problem with one
  // factorization (any solution serves: G M^-1 C^T lies in the range of G).
  const MassMatrix m(bodies);
  const Eigen::MatrixXd w_ct = project_onto_joints_null_space(bodies, joints, m,
                                                              m.inverse_times(Eigen::MatrixXd(c.transpose())), workspace);
  const Mat3 k = c * w_ct;
  return 0.5 * (k + k.transpose());  // symmetric to round-off
}

Mat3 collision_matrix(const std::vector<CompliantBody>& bodies, const JointSet& joints, int body, const Vec3& arm,
                      MultiplierSolve* workspace) {
  const VelocityLayout layout(bodies);
  return collision_matrix(bodies, joints, point_velocity_rows(bodies, layout, body, arm), workspace);
}

Mat3 collision_matrix(const std::vector<CompliantBody>& bodies, const JointSet& joints, int body_a,
                      const Vec3& arm_a, int body_b, const Vec3& arm_b, MultiplierSolve* workspace) {
  const VelocityLayout layout(bodies);
  return collision_matrix(bodies, joints,
                          point_velocity_rows(bodies, layout, body_b, arm_b) -
                              point_velocity_rows(bodies, layout, body_a, arm_a),
                          workspace);
}

void apply_impulse(std::vector<CompliantBody>& bodies, const JointSet& joints, const Eigen::MatrixXd& c,
                   const Eigen::VectorXd& p, MultiplierSolve* workspace) {
  const MassMatrix m(bodies);
  set_velocities(bodies, m.layout, velocity_vector(bodies, m.layout) + m.inverse_times(Eigen::VectorXd(c.transpose() * p)));
  project_velocities(bodies, joints, false, workspace);
}

void apply_point_impulse(std::vector<CompliantBody>& bodies, const JointSet& joints, int body, const Vec3& arm,
                         const Vec3& impulse, MultiplierSolve* workspace) {
  const VelocityLayout layout(bodies);
  apply_impulse(bodies, joints, point_velocity_rows(bodies, layout, body, arm), impulse, workspace);
}

}  // namespace ringsim
