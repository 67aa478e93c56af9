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

namespace {

// s_ij *= (a_i a_j): the product a_i a_j is the same both ways, so a
// symmetric matrix stays exactly symmetric.
void scale_symmetric(Eigen::MatrixXd& s, const Eigen::VectorXd& a) {
  for (Eigen::Index j = 0; j < s.cols(); ++j)
    for (Eigen::Index i = 0; i < s.rows(); ++i) s(i, j) *= a[i] * a[j];
}

}  // namespace

MultiplierSolve::MultiplierSolve(const Eigen::MatrixXd& g, const MassMatrix& m, bool rank_revealing)
    : rows_(int(g.rows())) {
  assemble(g, m);
  if (rows_ == 0) return;
  // Equilibrated in place: s_ holds S~ from here on (s() gives S back).
  const double zero_row = kZeroRow * s_.diagonal().maxCoeff();
  scale_ = s_.diagonal().unaryExpr([zero_row](double x) { return x > zero_row ? 1.0 / std::sqrt(x) : 1.0; });
  scale_symmetric(s_, scale_);
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

Eigen::MatrixXd MultiplierSolve::s() const {
  if (rows_ == 0) return s_;
  Eigen::MatrixXd s = s_;
  scale_symmetric(s, scale_.cwiseInverse());  // D^1/2 (1 on zero rows, which are zero)
  return s;
}

Eigen::VectorXd MultiplierSolve::row_sines2(int first) const {
  if (rows_ == 0 || !full_) return Eigen::VectorXd(0);
  // Row i's squared sine to the others' span is 1 / (S~^-1)_ii (S~ has a
  // unit diagonal: the Schur complement of the other rows); the columns
  // from `first` on only.
  const int k = rows_ - first;
  const Eigen::MatrixXd cols = ldlt_.solve(Eigen::MatrixXd::Identity(rows_, rows_).rightCols(k));
  return cols.bottomRows(k).diagonal().cwiseInverse();
}

Eigen::VectorXd MultiplierSolve::solve(const Eigen::VectorXd& rhs) const {
  if (rows_ == 0) return Eigen::VectorXd(0);
  Eigen::VectorXd x = scale_.cwiseProduct(rhs);
  if (full_) ldlt_.solveInPlace(x);
  else x = cod_.solve(x);
  x.array() *= scale_.array();
  return x;
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

namespace {

// One held row of `from` (angles first, then dihedrals) as a JointSet.
JointSet held_row(const JointSet& from, std::size_t k) {
  JointSet one;
  if (k < from.angles.size()) one.angles.push_back(from.angles[k]);
  else one.dihedrals.push_back(from.dihedrals[k - from.angles.size()]);
  return one;
}

}  // namespace

double sine2_to_span(const std::vector<CompliantBody>& bodies, const JointSet& base, const JointSet& row) {
  JointSet all = base;
  append_joints(all, row, 0);
  const MassMatrix m(bodies);
  JointRows rows;
  joint_rows(bodies, m.layout, all, rows);
  // Rows are in joint_rows' order (balls, angles, dihedrals): an appended
  // angle comes after base's angles, a dihedral last.
  const int n = int(rows.g.rows()) - 1;
  const int r = row.angles.empty() ? n : 3 * int(base.balls.size()) + int(base.angles.size());
  const MultiplierSolve solve(rows.g, m);
  const Eigen::MatrixXd& s = solve.s();
  const double srr = s(r, r);
  if (!(srr > kZeroRow * s.diagonal().maxCoeff())) return 0.0;
  if (n == 0) return 1.0;
  // Equilibrated: S~ = D^-1/2 S D^-1/2; the row's squared sine to the span
  // of the others is its Schur complement 1 - b^T S~_base^+ b.
  std::vector<int> others;
  for (int k = 0; k <= n; ++k)
    if (k != r) others.push_back(k);
  Eigen::VectorXd d(n), b(n);
  for (int k = 0; k < n; ++k) {
    const double x = s(others[k], others[k]);
    d[k] = x > kZeroRow * srr ? 1.0 / std::sqrt(x) : 0.0;
    b[k] = d[k] * s(others[k], r) / std::sqrt(srr);
  }
  Eigen::MatrixXd sb(n, n);
  for (int j = 0; j < n; ++j)
    for (int k = 0; k < n; ++k) sb(k, j) = d[k] * s(others[k], others[j]) * d[j];
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod;
  cod.setThreshold(kRankThreshold);
  cod.compute(sb);
  return std::max(0.0, 1.0 - b.dot(cod.solve(b)));
}

JointSet take_independent_rows(const std::vector<CompliantBody>& bodies, const JointSet& base,
                               JointSet& candidates, double min_sine2) {
  JointSet taken, left, with = base;
  const std::size_t held = candidates.angles.size() + candidates.dihedrals.size();
  for (std::size_t k = 0; k < held; ++k) {
    const JointSet row = held_row(candidates, k);
    const bool take = sine2_to_span(bodies, with, row) >= min_sine2;
    append_joints(take ? taken : left, row, 0);
    if (take) append_joints(with, row, 0);
  }
  candidates = std::move(left);
  return taken;
}

int drop_redundant_held_rows(const std::vector<CompliantBody>& bodies, JointSet& joints, JointSet* removed,
                             double min_sine2) {
  if (joints.angles.empty() && joints.dihedrals.empty()) return 0;
  JointSet held = joints;
  held.balls.clear();
  JointSet kept;
  kept.balls = joints.balls;
  append_joints(kept, take_independent_rows(bodies, kept, held, min_sine2), 0);
  joints = std::move(kept);
  const int dropped = int(held.angles.size() + held.dihedrals.size());
  if (removed) append_joints(*removed, held, 0);
  return dropped;
}

}  // namespace ringsim
