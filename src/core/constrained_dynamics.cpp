#include "core/constrained_dynamics.hpp"

namespace ringsim {

MassMatrix::MassMatrix(const std::vector<CompliantBody>& bodies) { assign(bodies); }

void MassMatrix::assign(const std::vector<CompliantBody>& bodies) {
  layout.assign(bodies);
  mass.resize(bodies.size());
  linker.resize(bodies.size());
  inertia.resize(bodies.size());
  inv_inertia.resize(bodies.size());
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

void InverseMassBlocks::clear() {
  offset.clear();
  width.clear();
  inv.clear();
  size = 0;
}

void InverseMassBlocks::add(int w, const Eigen::Matrix<double, 6, 6>& inverse) {
  offset.push_back(size);
  width.push_back(w);
  inv.push_back(inverse);
  size += w;
}

Eigen::VectorXd InverseMassBlocks::times(const Eigen::VectorXd& f) const {
  Eigen::VectorXd x;
  times(f, x);
  return x;
}

void InverseMassBlocks::times(const Eigen::VectorXd& f, Eigen::VectorXd& x) const {
  x.resize(size);
  for (std::size_t i = 0; i < offset.size(); ++i) {
    const int o = offset[i];
    if (width[i] == 6) x.segment<6>(o) = inv[i] * f.segment<6>(o);
    else x.segment<3>(o) = inv[i].topLeftCorner<3, 3>() * f.segment<3>(o);
  }
}

InverseMassBlocks MassMatrix::inverse_blocks() const {
  InverseMassBlocks b;
  b.offset.reserve(mass.size());
  b.width.reserve(mass.size());
  b.inv.reserve(mass.size());
  for (std::size_t i = 0; i < mass.size(); ++i) {
    Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Zero();
    a.topLeftCorner<3, 3>() = Mat3::Identity() / mass[i];
    if (linker[i]) a.bottomRightCorner<3, 3>() = inv_inertia[i];
    b.add(linker[i] ? 6 : 3, a);
  }
  return b;
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
    : MultiplierSolve(g, m.inverse_blocks(), rank_revealing) {}

MultiplierSolve::MultiplierSolve(const Eigen::MatrixXd& g, const InverseMassBlocks& minv, bool rank_revealing) {
  Options options;
  options.rank_revealing = rank_revealing;
  compute(g, minv, options);
}

void MultiplierSolve::start(int rows, bool keep_minv_gt, const Options& options) {
  rows_ = rows;
  keep_minv_gt_ = keep_minv_gt;
  full_ = cut_short_ = sparse_ = false;
  plan_sparse_ = !options.rank_revealing && rows_ > 0 && rows_ >= options.sparse_from_rows;
}

void MultiplierSolve::compute(const Eigen::MatrixXd& g, const InverseMassBlocks& minv, const Options& options) {
  start(int(g.rows()), options.keep_minv_gt, options);
  assemble(g, minv, options.blocks);
  factor(options);
}

void MultiplierSolve::compute(const BlockRows& g, const InverseMassBlocks& minv, const Options& options) {
  start(g.rows(), false, options);
  assemble(g, minv);
  factor(options);
}

void MultiplierSolve::factor(const Options& options) {
  if (rows_ == 0) return;
  // Equilibrated in place: s_ holds S~ from here on (s() gives S back).
  const double zero_row = kZeroRow * s_.diagonal().maxCoeff();
  scale_ = s_.diagonal().unaryExpr([zero_row](double x) { return x > zero_row ? 1.0 / std::sqrt(x) : 1.0; });
  if (plan_sparse_) {  // S is zero outside the analysed pattern: scaled there only
    sparse_ldlt_.for_each_entry([this](int i, int j) {
      const double a = scale_[i] * scale_[j];
      s_(i, j) *= a;
      if (i != j) s_(j, i) *= a;
    });
  } else {
    scale_symmetric(s_, scale_);
  }
  if (plan_sparse_ && sparse_ldlt_.factor(s_, kRankThreshold)) {
    full_ = sparse_ldlt_.rank() == rows_;
    cut_short_ = !full_ && options.any_solution;
    sparse_ = full_ || cut_short_;
    if (sparse_) return;
  }
  if (!options.rank_revealing) {
    ldlt_.compute(s_, kRankThreshold);
    full_ = ldlt_.rank() == rows_;
    cut_short_ = !full_ && options.any_solution;
    if (full_ || cut_short_) return;
  }
  cod_.setThreshold(kRankThreshold);
  cod_.compute(s_);
}

namespace {

// One block's share of the assembly: S += G_i M_i^-1 G_i^T on the rows that
// touch block i, each product computed once and added to both (a, c) and
// (c, a); row_at(k) is G's row of the k-th touched row in block i's
// columns; agt (W x rows scratch) receives M_i^-1 g_r^T of the k-th touched
// row in its column k, and, when minv_gt is given, body i's rows of M^-1 G^T
// (zero in the other columns).
template <int W, class RowAt>
void add_block(const RowAt& row_at, const Eigen::Matrix<double, 6, 6>& inv, int o, const int* touched, int n,
               Eigen::Matrix<double, 6, Eigen::Dynamic>& agt, Eigen::MatrixXd* minv_gt, Eigen::MatrixXd& s) {
  const Eigen::Matrix<double, W, W> a = inv.topLeftCorner<W, W>();
  for (int k = 0; k < n; ++k) agt.block<W, 1>(0, k) = a * row_at(k).transpose();
  if (minv_gt)
    for (int k = 0; k < n; ++k) minv_gt->block<W, 1>(o, touched[k]) = agt.block<W, 1>(0, k);
  for (int kc = 0; kc < n; ++kc) {
    const int c = touched[kc];
    for (int ka = kc; ka < n; ++ka) {
      const int r = touched[ka];
      const double src = row_at(ka).dot(agt.block<W, 1>(0, kc));
      s(r, c) += src;
      if (r != c) s(c, r) += src;
    }
  }
}

}  // namespace

void MultiplierSolve::find_touched(const Eigen::MatrixXd* g, const InverseMassBlocks& minv, const RowBlocks* blocks,
                                   int cols) {
  const int nb = int(minv.offset.size());
  // touched_[start_[i], start_[i + 1]): the rows with entries in block i's
  // columns, in increasing order. From `blocks` when given (O(rows));
  // otherwise read from G (each column in one contiguous sweep).
  start_.assign(nb + 1, 0);
  touched_.clear();
  if (blocks) {
    block_at_.assign(cols, -1);
    for (int i = 0; i < nb; ++i) block_at_[minv.offset[i]] = i;
    for (int r = 0; r < rows_; ++r)
      for (const int o : (*blocks)[r])
        if (o >= 0) ++start_[block_at_[o] + 1];
    for (int i = 0; i < nb; ++i) start_[i + 1] += start_[i];
    touched_.resize(start_[nb]);
    touched_slot_.resize(start_[nb]);
    fill_.assign(start_.begin(), start_.end() - 1);
    for (int r = 0; r < rows_; ++r)
      for (int k = 0; k < 3; ++k) {
        const int o = (*blocks)[r][k];
        if (o < 0) continue;
        const int at = fill_[block_at_[o]]++;
        touched_[at] = r;
        touched_slot_[at] = k;
      }
  } else {
    for (int i = 0; i < nb; ++i) {
      const int o = minv.offset[i], w = minv.width[i];
      for (int r = 0; r < rows_; ++r) {
        bool any = false;
        for (int k = 0; k < w; ++k) any |= g->data()[Eigen::Index(o + k) * rows_ + r] != 0.0;
        if (any) touched_.push_back(r);
      }
      start_[i + 1] = int(touched_.size());
    }
  }
  // S starts from zero: on a planned sparse factorization with the pattern
  // of the last one (the right-hand sides of a slice), only the pattern is
  // cleared (S is zero elsewhere since); otherwise all of it, and a new
  // pattern is analysed.
  const bool same_pattern = plan_sparse_ && s_is_pattern_ && s_.rows() == rows_ && start_ == pattern_start_ &&
                            touched_ == pattern_rows_;
  if (same_pattern) {
    sparse_ldlt_.for_each_entry([this](int i, int j) { s_(i, j) = s_(j, i) = 0.0; });
  } else {
    s_.setZero(rows_, rows_);
    if (plan_sparse_) {
      sparse_ldlt_.analyse(rows_, start_, touched_);
      pattern_start_ = start_;
      pattern_rows_ = touched_;
    }
  }
  s_is_pattern_ = plan_sparse_;
}

void MultiplierSolve::assemble(const Eigen::MatrixXd& g, const InverseMassBlocks& minv, const RowBlocks* blocks) {
  if (keep_minv_gt_) minv_gt_.setZero(g.cols(), rows_);
  else minv_gt_.resize(0, 0);
  Eigen::MatrixXd* minv_gt = keep_minv_gt_ ? &minv_gt_ : nullptr;
  agt_.resize(6, rows_);
  find_touched(&g, minv, blocks, int(g.cols()));
  for (int i = 0; i < int(minv.offset.size()); ++i) {
    const int o = minv.offset[i], n = start_[i + 1] - start_[i];
    const int* rows = touched_.data() + start_[i];
    if (minv.width[i] == 6)
      add_block<6>([&](int k) { return g.block<1, 6>(rows[k], o); }, minv.inv[i], o, rows, n, agt_, minv_gt, s_);
    else
      add_block<3>([&](int k) { return g.block<1, 3>(rows[k], o); }, minv.inv[i], o, rows, n, agt_, minv_gt, s_);
  }
}

void MultiplierSolve::assemble(const BlockRows& g, const InverseMassBlocks& minv) {
  minv_gt_.resize(0, 0);
  agt_.resize(6, rows_);
  find_touched(nullptr, minv, &g.blocks, g.cols);
  for (int i = 0; i < int(minv.offset.size()); ++i) {
    const int o = minv.offset[i], n = start_[i + 1] - start_[i];
    if (n == 0) continue;  // a sphere with no joint (width 3): in no row
    const int* rows = touched_.data() + start_[i];
    const int* slots = touched_slot_.data() + start_[i];
    add_block<6>([&](int k) { return g.values.block<1, 6>(rows[k], 6 * slots[k]); }, minv.inv[i], o, rows, n, agt_,
                 nullptr, s_);
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
  Eigen::VectorXd s2(k), e(rows_);
  for (int i = 0; i < k; ++i) {
    e.setZero();
    e[first + i] = 1.0;
    solve_factors(e);
    s2[i] = 1.0 / e[first + i];
  }
  return s2;
}

Eigen::VectorXd MultiplierSolve::solve(const Eigen::VectorXd& rhs) const {
  Eigen::VectorXd x = rhs;
  solve_in_place(x);
  return x;
}

void MultiplierSolve::solve_in_place(Eigen::VectorXd& x) const {
  if (rows_ == 0) return;
  x.array() *= scale_.array();
  if (full_ || cut_short_) solve_factors(x);
  else x = cod_.solve(x);
  x.array() *= scale_.array();
}

void MultiplierSolve::solve_factors(Eigen::VectorXd& x) const {
  if (sparse_) sparse_ldlt_.solve_in_place(x);
  else ldlt_.solve_in_place(x);
}

Eigen::VectorXd generalized_force(const std::vector<CompliantBody>& bodies, const MassMatrix& m,
                                  const std::vector<Vec3>& force, const std::vector<Vec3>& torque) {
  Eigen::VectorXd f;
  generalized_force(bodies, m, force, torque, f);
  return f;
}

void generalized_force(const std::vector<CompliantBody>& bodies, const MassMatrix& m, const std::vector<Vec3>& force,
                       const std::vector<Vec3>& torque, Eigen::VectorXd& f) {
  f.resize(m.layout.size);
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const int o = m.layout.offset[i];
    f.segment<3>(o) = force[i];
    if (bodies[i].shape != Shape::Linker) continue;
    const Vec3& w = bodies[i].omega;
    f.segment<3>(o + 3) = torque[i] - w.cross(m.inertia[i] * w);
  }
}

namespace {

// The inverse of a rigid body's mass matrix about a point other than its
// centre of mass, [[a 1, B], [B^T, C]] (a the mass, B = -B^T): by the Schur
// complement K = C - B^T B / a (the inertia about the centre of mass),
// [[1/a + B K^-1 B^T / a^2, -B K^-1 / a], [-K^-1 B^T / a, K^-1]]. A point
// mass (B = C = 0) gives 1/a in the top-left block only.
Eigen::Matrix<double, 6, 6> inverse_rigid_mass(const Eigen::Matrix<double, 6, 6>& m) {
  Eigen::Matrix<double, 6, 6> inv = Eigen::Matrix<double, 6, 6>::Zero();
  const double a = m(0, 0);
  const Mat3 b = m.topRightCorner<3, 3>(), c = m.bottomRightCorner<3, 3>();
  if (c.isZero(0.0)) {
    inv.topLeftCorner<3, 3>() = Mat3::Identity() / a;
    return inv;
  }
  const Mat3 k_inv = (c - b.transpose() * b / a).inverse();
  const Mat3 bk = b * k_inv / a;
  inv.topLeftCorner<3, 3>() = Mat3::Identity() / a + bk * b.transpose() / a;
  inv.topRightCorner<3, 3>() = -bk;
  inv.bottomLeftCorner<3, 3>() = -bk.transpose();
  inv.bottomRightCorner<3, 3>() = k_inv;
  return inv;
}

}  // namespace

HostedProblem::HostedProblem(const std::vector<CompliantBody>& bodies, const JointSet& joints, const MassMatrix& m) {
  assign(bodies, joints, m);
}

void HostedProblem::assign(const std::vector<CompliantBody>& bodies, const JointSet& joints, const MassMatrix& m) {
  columns.assign(bodies, joints);
  // M_r = T^T M T block by block: a linker's own diag(m 1, I), plus for each
  // sphere it hosts (mass m_S at arm r) [[m_S 1, -m_S [r]x], [m_S [r]x,
  // -m_S [r]x^2]]; a sphere without a joint keeps m 1.
  const int n = int(bodies.size());
  std::vector<Eigen::Matrix<double, 6, 6>>& mass = mass_;
  mass.resize(n);
  for (int i = 0; i < n; ++i) {
    if (columns.host[i] >= 0) continue;
    mass[i].setZero();
    mass[i].topLeftCorner<3, 3>() = m.mass[i] * Mat3::Identity();
    if (m.linker[i]) mass[i].bottomRightCorner<3, 3>() = m.inertia[i];
  }
  for (int i = 0; i < n; ++i) {
    if (columns.host[i] < 0) continue;
    const double mi = m.mass[i];
    const Mat3 rx = cross_matrix(columns.arm[i]);
    Eigen::Matrix<double, 6, 6>& mh = mass[columns.host[i]];
    mh.topLeftCorner<3, 3>() += mi * Mat3::Identity();
    mh.topRightCorner<3, 3>() -= mi * rx;
    mh.bottomLeftCorner<3, 3>() += mi * rx;
    mh.bottomRightCorner<3, 3>() -= mi * rx * rx;
  }
  minv.clear();
  minv.offset.reserve(n);
  minv.width.reserve(n);
  minv.inv.reserve(n);
  for (int i = 0; i < n; ++i)
    if (columns.host[i] < 0) minv.add(m.linker[i] ? 6 : 3, inverse_rigid_mass(mass[i]));
}

Eigen::VectorXd HostedProblem::gather(const MassMatrix& m, const Eigen::VectorXd& x) const {
  Eigen::VectorXd y;
  gather(m, x, y);
  return y;
}

void HostedProblem::gather(const MassMatrix& m, const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
  y.resize(columns.size);
  const int n = int(columns.host.size());
  for (int i = 0; i < n; ++i)
    if (columns.host[i] < 0) {
      const int w = m.linker[i] ? 6 : 3;
      y.segment(columns.offset[i], w) = x.segment(m.layout.offset[i], w);
    }
  for (int i = 0; i < n; ++i)
    if (columns.host[i] >= 0) {  // a force on the sphere acts on its host, with its moment about the host's centre
      const Vec3 e = x.segment<3>(m.layout.offset[i]);
      y.segment<3>(columns.offset[i]) += e;
      y.segment<3>(columns.offset[i] + 3) += columns.arm[i].cross(e);
    }
}

Eigen::VectorXd HostedProblem::scatter(const MassMatrix& m, const Eigen::VectorXd& y) const {
  Eigen::VectorXd x;
  scatter(m, y, x);
  return x;
}

void HostedProblem::scatter(const MassMatrix& m, const Eigen::VectorXd& y, Eigen::VectorXd& x) const {
  x.resize(m.layout.size);
  for (std::size_t i = 0; i < columns.host.size(); ++i) {
    const int o = m.layout.offset[i], r = columns.offset[i];
    if (columns.host[i] >= 0) x.segment<3>(o) = y.segment<3>(r) + Vec3(y.segment<3>(r + 3)).cross(columns.arm[i]);
    else x.segment(o, m.linker[i] ? 6 : 3) = y.segment(r, m.linker[i] ? 6 : 3);
  }
}

void add_constraint_loads(const std::vector<CompliantBody>& bodies, const JointSet& joints,
                          std::vector<Vec3>& force, std::vector<Vec3>& torque) {
  ConstraintLoads().add(bodies, joints, force, torque);
}

void ConstraintLoads::add(const std::vector<CompliantBody>& bodies, const JointSet& joints, std::vector<Vec3>& force,
                          std::vector<Vec3>& torque) {
  if (joints.empty()) return;
  m_.assign(bodies);
  const MassMatrix& m = m_;
  generalized_force(bodies, m, force, torque, f_);
  p_.assign(bodies, joints, m);
  const HostedColumns& hc = p_.columns;

  // f_r = T^T (f - M c): c, a hosted sphere's acceleration at zero host
  // acceleration, only on the hosted spheres' rows.
  x_ = f_;
  for (std::size_t i = 0; i < bodies.size(); ++i)
    if (hc.host[i] >= 0) x_.segment<3>(m.layout.offset[i]) -= m.mass[i] * hc.c[i];
  p_.gather(m, x_, fr_);

  hosted_joint_rows(bodies, hc, joints, g_, &bias_);
  MultiplierSolve::Options options;
  options.any_solution = true;  // the loads read G^T lambda only
  solve_.compute(g_, p_.minv, options);
  p_.minv.times(fr_, y_);
  lambda_ = bias_;
  g_.add_times(y_, lambda_);
  lambda_ = -lambda_;
  solve_.solve_in_place(lambda_);
  g_.add_transpose_times(lambda_, fr_);  // the reduced load f_r + G_r^T lambda
  p_.minv.times(fr_, y_);
  p_.scatter(m, y_, acc_);
  for (std::size_t i = 0; i < bodies.size(); ++i)
    if (hc.host[i] >= 0) acc_.segment<3>(m.layout.offset[i]) += hc.c[i];

  // Back to every body: the loads that give these accelerations, M nu' - f
  // (a linker's torque I omega' + omega x I omega, so that dL/dt is right).
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const int o = m.layout.offset[i];
    force[i] += Vec3(m.mass[i] * acc_.segment<3>(o) - f_.segment<3>(o));
    if (m.linker[i]) torque[i] += Vec3(m.inertia[i] * acc_.segment<3>(o + 3) - f_.segment<3>(o + 3));
  }
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
