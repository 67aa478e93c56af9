#include "core/constrained_dynamics.hpp"

namespace ringsim {

MassMatrix::MassMatrix(const std::vector<CompliantBody>& bodies)
    : layout(bodies), mass(bodies.size()), linker(bodies.size()), inertia(bodies.size()), inv_inertia(bodies.size()) {
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const CompliantBody& b = bodies[i];
    mass[i] = b.mass;
    linker[i] = b.shape == Shape::Linker;
    if (b.shape != Shape::Linker) {
      inertia[i] = inv_inertia[i] = Mat3::Identity();
      continue;
    }
    const Vec3 u = b.axis();
    const Mat3 uu = u * u.transpose();
    inertia[i] = b.i_perp * Mat3::Identity() + (b.i_axial - b.i_perp) * uu;
    inv_inertia[i] = Mat3::Identity() / b.i_perp + (1.0 / b.i_axial - 1.0 / b.i_perp) * uu;
  }
}

Eigen::VectorXd MassMatrix::times(const Eigen::VectorXd& nu) const {
  Eigen::VectorXd f(layout.size);
  for (std::size_t i = 0; i < mass.size(); ++i) {
    const int o = layout.offset[i];
    f.segment<3>(o) = mass[i] * nu.segment<3>(o);
    if (linker[i]) f.segment<3>(o + 3) = inertia[i] * nu.segment<3>(o + 3);
  }
  return f;
}

namespace {
// M^-1 X block by block, X a vector or a matrix (column by column): 1/m on a
// body's velocity rows, the inverse inertia on a linker's omega rows.
template <class X>
X block_inverse_times(const MassMatrix& m, const X& f) {
  X x(f.rows(), f.cols());
  for (std::size_t i = 0; i < m.mass.size(); ++i) {
    const int o = m.layout.offset[i];
    x.middleRows(o, 3) = f.middleRows(o, 3) / m.mass[i];
    if (m.linker[i]) x.middleRows(o + 3, 3) = m.inv_inertia[i] * f.middleRows(o + 3, 3);
  }
  return x;
}
}  // namespace

Eigen::MatrixXd MassMatrix::inverse_times(const Eigen::MatrixXd& f) const { return block_inverse_times(*this, f); }
Eigen::VectorXd MassMatrix::inverse_times(const Eigen::VectorXd& f) const { return block_inverse_times(*this, f); }

Eigen::MatrixXd MassMatrix::dense() const {
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(layout.size, layout.size);
  for (std::size_t i = 0; i < mass.size(); ++i) {
    const int o = layout.offset[i];
    m.block<3, 3>(o, o) = mass[i] * Mat3::Identity();
    if (linker[i]) m.block<3, 3>(o + 3, o + 3) = inertia[i];
  }
  return m;
}

MultiplierSolve::MultiplierSolve(const Eigen::MatrixXd& g, const MassMatrix& m, bool rank_revealing)
    : rows_(int(g.rows())) {
  assemble(g, m);
  if (rows_ == 0) return;
  if (!rank_revealing) {
    ldlt_.compute(s_);
    if (ldlt_.info() == Eigen::Success) {
      const auto d = ldlt_.vectorD();
      full_ = d.minCoeff() > kRankThreshold * d.cwiseAbs().maxCoeff();
    }
    if (full_) return;
  }
  cod_.setThreshold(kRankThreshold);
  cod_.compute(s_);
}

void MultiplierSolve::assemble(const Eigen::MatrixXd& g, const MassMatrix& m) {
  minv_gt_.setZero(g.cols(), rows_);
  s_.setZero(rows_, rows_);
  std::vector<int> touched;  // the rows with a nonzero in body i's columns
  touched.reserve(rows_);
  for (std::size_t i = 0; i < m.mass.size(); ++i) {
    const int o = m.layout.offset[i];
    const bool linker = m.linker[i];
    touched.clear();
    for (int r = 0; r < rows_; ++r) {
      if ((g.block<1, 3>(r, o).array() != 0.0).any() || (linker && (g.block<1, 3>(r, o + 3).array() != 0.0).any()))
        touched.push_back(r);
    }
    // Body i's rows of M^-1 G^T (zero in the other columns): G_i,v^T / m_i,
    // and I_i^-1 G_i,omega^T for a linker.
    const double inv_mass = 1.0 / m.mass[i];
    for (const int r : touched) {
      minv_gt_.block<3, 1>(o, r) = inv_mass * g.block<1, 3>(r, o).transpose();
      if (linker) minv_gt_.block<3, 1>(o + 3, r) = m.inv_inertia[i] * g.block<1, 3>(r, o + 3).transpose();
    }
    // S += G_i M_i^-1 G_i^T on the touched rows and columns; each product is
    // computed once and added to both (a, c) and (c, a).
    for (std::size_t kc = 0; kc < touched.size(); ++kc) {
      const int c = touched[kc];
      for (std::size_t ka = kc; ka < touched.size(); ++ka) {
        const int a = touched[ka];
        double sac = g.block<1, 3>(a, o).dot(minv_gt_.block<3, 1>(o, c));
        if (linker) sac += g.block<1, 3>(a, o + 3).dot(minv_gt_.block<3, 1>(o + 3, c));
        s_(a, c) += sac;
        if (a != c) s_(c, a) += sac;
      }
    }
  }
}

Eigen::VectorXd MultiplierSolve::solve(const Eigen::VectorXd& rhs) const {
  if (rows_ == 0) return Eigen::VectorXd(0);
  return full_ ? Eigen::VectorXd(ldlt_.solve(rhs)) : Eigen::VectorXd(cod_.solve(rhs));
}

Eigen::VectorXd generalized_force(const std::vector<CompliantBody>& bodies, const MassMatrix& m,
                                  const std::vector<Vec3>& force, const std::vector<Vec3>& torque) {
  Eigen::VectorXd f(m.layout.size);
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const int o = m.layout.offset[i];
    f.segment<3>(o) = force[i];
    if (bodies[i].shape != Shape::Linker) continue;
    const Vec3& w = bodies[i].omega;
    f.segment<3>(o + 3) = torque[i] - w.cross(m.inertia[i] * w);
  }
  return f;
}

Eigen::VectorXd add_constraint_loads(const std::vector<CompliantBody>& bodies, const JointSet& joints,
                                     std::vector<Vec3>& force, std::vector<Vec3>& torque) {
  if (joints.empty()) return Eigen::VectorXd(0);
  const MassMatrix m(bodies);
  JointRows rows;
  joint_rows(bodies, m.layout, joints, rows);
  const MultiplierSolve solve(rows.g, m);
  const Eigen::VectorXd f = generalized_force(bodies, m, force, torque);
  Eigen::VectorXd rhs = -rows.bias;
  rhs.noalias() -= rows.g * m.inverse_times(f);
  const Eigen::VectorXd lambda = solve.solve(rhs);
  const Eigen::VectorXd load = rows.g.transpose() * lambda;
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const int o = m.layout.offset[i];
    force[i] += load.segment<3>(o);
    if (bodies[i].shape == Shape::Linker) torque[i] += load.segment<3>(o + 3);
  }
  return lambda;
}

void cluster_loads(const CompliantCluster& cluster, const JointSet& joints, std::vector<Vec3>& force,
                   std::vector<Vec3>& torque) {
  compliant_loads(cluster, body_motions(cluster), true, force, torque);
  add_constraint_loads(cluster.bodies, joints, force, torque);
}

int internal_dof(const std::vector<CompliantBody>& bodies, const JointSet& joints) {
  const MassMatrix m(bodies);
  JointRows rows;
  joint_rows(bodies, m.layout, joints, rows);
  const MultiplierSolve solve(rows.g, m, true);
  return m.layout.size - solve.rank() - 6;
}

int drop_redundant_held_rows(const std::vector<CompliantBody>& bodies, JointSet& joints) {
  if (joints.angles.empty() && joints.dihedrals.empty()) return 0;
  const MassMatrix m(bodies);
  auto rank_of = [&](const JointSet& j) {
    JointRows rows;
    joint_rows(bodies, m.layout, j, rows);
    return MultiplierSolve(rows.g, m, true).rank();
  };
  JointSet kept;
  kept.balls = joints.balls;
  int rank = rank_of(kept);
  int dropped = 0;
  for (const HeldAngle& a : joints.angles) {
    kept.angles.push_back(a);
    const int r = rank_of(kept);
    if (r > rank) rank = r;
    else kept.angles.pop_back(), ++dropped;
  }
  for (const HeldDihedral& d : joints.dihedrals) {
    kept.dihedrals.push_back(d);
    const int r = rank_of(kept);
    if (r > rank) rank = r;
    else kept.dihedrals.pop_back(), ++dropped;
  }
  joints = std::move(kept);
  return dropped;
}

}  // namespace ringsim
