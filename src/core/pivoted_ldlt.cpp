#include "core/pivoted_ldlt.hpp"

#include <utility>

namespace ringsim {

void PivotedLdlt::compute(const Eigen::MatrixXd& a, double cut) {
  const int n = int(a.rows());
  a_ = a;
  d_.setZero(n);
  perm_.resize(n);
  for (int i = 0; i < n; ++i) perm_[i] = i;
  rank_ = n;
  double first = 0.0;
  for (int k = 0; k < n; ++k) {
    Eigen::Index j = 0;
    const double biggest = a_.diagonal().tail(n - k).maxCoeff(&j);
    j += k;
    if (k == 0) first = biggest;
    if (!(biggest > cut * first) || !(biggest > 0.0)) {  // also stops on NaN
      rank_ = k;
      break;
    }
    if (j != k) {
      // Symmetric swap of k and j in the lower triangle (rows and columns
      // of the trailing block; the L entries of rows k and j as they are).
      a_.row(k).head(k).swap(a_.row(j).head(k));
      std::swap(a_(k, k), a_(j, j));
      for (Eigen::Index i = k + 1; i < j; ++i) std::swap(a_(i, k), a_(j, i));
      for (Eigen::Index i = j + 1; i < n; ++i) std::swap(a_(i, k), a_(i, j));
      std::swap(perm_[k], perm_[j]);
    }
    d_[k] = a_(k, k);
    const int m = n - k - 1;
    if (m == 0) continue;
    // Trailing block -= a21 a21^T / d (lower triangle), then L's column k.
    auto a21 = a_.col(k).tail(m);
    for (int c = 0; c < m; ++c) {
      const double f = a21[c] / d_[k];
      a_.col(k + 1 + c).tail(m - c) -= f * a21.tail(m - c);
    }
    a21 /= d_[k];
  }
}

void PivotedLdlt::solve_in_place(Eigen::VectorXd& x) const {
  const int n = size(), r = rank_;
  work_.resize(n);
  for (int i = 0; i < n; ++i) work_[i] = x[perm_[i]];
  for (int k = 0; k < r; ++k) work_.tail(n - k - 1) -= work_[k] * a_.col(k).tail(n - k - 1);
  work_.head(r).array() /= d_.head(r).array();
  work_.tail(n - r).setZero();
  for (int k = r - 1; k >= 0; --k) work_[k] -= a_.col(k).tail(n - k - 1).dot(work_.tail(n - k - 1));
  for (int i = 0; i < n; ++i) x[perm_[i]] = work_[i];
}

}  // namespace ringsim
