#include "core/pivoted_ldlt.hpp"

#include <utility>

namespace ringsim {

void PivotedLdlt::compute(const Eigen::MatrixXd& a, double cut) {
  // Left-looking, as LAPACK's dpstf2: the Schur complement's diagonal is
  // kept up to date in schur_ (n operations a step), the pivot chosen
  // on it, and column k computed when it is reached, by one matrix-vector
  // product with the columns before it (n^3/6 operations in all).
  const int n = int(a.rows());
  a_ = a;
  d_.setZero(n);
  schur_ = a.diagonal();
  work_.resize(n);
  perm_.resize(n);
  for (int i = 0; i < n; ++i) perm_[i] = i;
  rank_ = n;
  double first = 0.0;
  for (int k = 0; k < n; ++k) {
    Eigen::Index j = 0;
    const double biggest = schur_.tail(n - k).maxCoeff(&j);
    j += k;
    if (k == 0) first = biggest;
    if (!(biggest > cut * first) || !(biggest > 0.0)) {  // also stops on NaN
      rank_ = k;
      break;
    }
    if (j != k) {
      // Symmetric swap of k and j in the lower triangle (the factored
      // columns' rows k and j, and the rest of rows and columns k and j).
      a_.row(k).head(k).swap(a_.row(j).head(k));
      std::swap(a_(k, k), a_(j, j));
      for (Eigen::Index i = k + 1; i < j; ++i) std::swap(a_(i, k), a_(j, i));
      for (Eigen::Index i = j + 1; i < n; ++i) std::swap(a_(i, k), a_(i, j));
      std::swap(schur_[k], schur_[j]);
      std::swap(perm_[k], perm_[j]);
    }
    // w = D L(k, 0:k)^T; d_k = a_kk - L(k, 0:k) w; column k of L.
    auto w = work_.head(k);
    w = d_.head(k).cwiseProduct(a_.row(k).head(k).transpose());
    d_[k] = a_(k, k) - a_.row(k).head(k).dot(w);
    const int m = n - k - 1;
    if (m == 0) continue;
    auto l = a_.col(k).tail(m);
    l.noalias() -= a_.bottomLeftCorner(m, k) * w;
    l /= d_[k];
    schur_.tail(m) -= d_[k] * l.cwiseAbs2();
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
