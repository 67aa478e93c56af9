#pragma once
// LDL^T of a symmetric positive semi-definite matrix with diagonal pivoting
// on the Schur complement (at step k the largest diagonal of the matrix
// updated by the k pivots before is taken), stopped where the largest
// remaining pivot falls to `cut` x the first: P A P^T = L D L^T on the
// first rank() pivots, and what is left is below the cut (Higham, "Accuracy
// and Stability of Numerical Algorithms", 2nd ed., sec. 10.3, the pivoted
// Cholesky factorization; here without square roots, and left-looking as
// LAPACK's dpstf2: only the Schur complement's diagonal is updated ahead,
// each column of L is one matrix-vector product when it is reached).
//
// Why not Eigen::LDLT: it also pivots on the diagonal, but on the diagonal
// as it stood before the factorization (it updates a column only when it
// reaches it). On an equilibrated S (unit diagonal) that order is
// arbitrary, so a rank-deficient matrix's zero pivot can come anywhere,
// followed by rounding-sized ones, and its factors cannot be cut short.
// Here the pivots come in decreasing order, pivot k is the squared sine of
// row k to the span of the rows before it (for a unit diagonal), and a
// cut-short factorization solves any consistent system A x = b with the
// dropped pivots' unknowns zero.

#include <vector>

#include <Eigen/Core>

namespace ringsim {

class PivotedLdlt {
 public:
  // Factors a (only its lower triangle is read); storage kept between calls.
  void compute(const Eigen::MatrixXd& a, double cut);
  int rank() const { return rank_; }
  int size() const { return int(a_.rows()); }
  // x <- a solution of A x = b: exact when rank() = size(); otherwise the
  // one with the dropped pivots' unknowns zero (exact for b in the range of
  // A up to the cut).
  void solve_in_place(Eigen::VectorXd& x) const;
  const Eigen::VectorXd& pivots() const { return d_; }  // D, the first rank() entries in order

 private:
  Eigen::MatrixXd a_;  // L below the diagonal (unit diagonal implied), columns < rank_
  Eigen::VectorXd d_;
  std::vector<int> perm_;  // row i of P A P^T is row perm_[i] of A
  Eigen::VectorXd schur_;           // compute's scratch: the Schur complement's diagonal
  mutable Eigen::VectorXd work_;
  int rank_ = 0;
};

}  // namespace ringsim
