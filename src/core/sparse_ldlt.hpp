#pragma once
// LDL^T of a sparse symmetric positive semi-definite matrix, eliminated in a
// fill-reducing order, its nearly dependent rows delayed to a dense block
// factored last with pivoting, where those below `cut` x the largest
// diagonal are dropped: the articulated clusters' multiplier solve
// (core/constrained_dynamics.hpp, MultiplierSolve).
//
// Why: S = G M^-1 G^T of a cluster has an entry only where two rows share
// a body, and a cluster is a tree of bonds with a few rings, so eliminated
// leaves first S fills in hardly at all; the dense factorization spends
// O(rows^3) on it (the largest item of a Scenario 1 run once its clusters
// have tens of linkers, docs/ARTICULATED.md, "Cost"), this one the sum of
// L's squared column counts.
//
// Order: minimum degree on the graph of S (George and Liu, "The evolution
// of the minimum degree ordering algorithm", SIAM Review 31, 1989): the row
// with the fewest neighbours in the elimination graph goes next (ties: the
// lowest index), its neighbours then joined pairwise (the fill). The order
// and L's pattern depend on the pattern of S only, which is kept while it
// does not change (every right-hand side of a slice: the same joints).
//
// Small pivots are delayed (Duff and Reid's delayed pivoting, "The
// multifrontal solution of indefinite sparse symmetric linear equations",
// ACM TOMS 9, 1983): a row whose pivot, the Schur complement's diagonal
// after the rows before it (for a unit diagonal: its squared sine to their
// span), is below kDelaySine2 x the largest diagonal is not eliminated in
// its turn but moved to a trailing block, factored last by the pivoted
// dense LDL^T (core/pivoted_ldlt.hpp), which keeps the largest pivots first
// and drops those below `cut` (their unknowns zero). So the rank decision
// is made as the dense factorization makes it, among the rows that are
// nearly dependent, and every step of the sparse order divides by a pivot
// of at least kDelaySine2 (L's entries stay below 1 / sqrt(kDelaySine2)).
// Why: with the rows dropped where they fall in the order, a redundant row
// (a ring of two linkers holds its spheres' distance twice) could be met
// before the last row of its dependency, leave a pivot of rounding size
// amplified past the cut on that row, and give multipliers of 1e7: an
// articulated Scenario 1 run took 5x the right-hand sides and failed 50
// slices. A cluster's trailing block holds its redundant rows, a few.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/pivoted_ldlt.hpp"

namespace ringsim {

constexpr double kDelaySine2 = 1e-2;  // relative to the largest diagonal

class SparseLdlt {
 public:
  // The pattern as cliques: the rows rows[start[c], start[c + 1]) are
  // pairwise coupled (S: the rows that touch one body). Orders the rows and
  // finds L's pattern; kept until the next call.
  void analyse(int n, const std::vector<int>& start, const std::vector<int>& rows);
  // Factors a (symmetric, zero outside the analysed pattern: only the
  // pattern is read). false when a pivot is not a number (nothing can be
  // solved then).
  bool factor(const Eigen::MatrixXd& a, double cut);
  // analyse on a's own pattern (its exact zeros) when it is not the last
  // one analysed, then factor.
  bool compute(const Eigen::MatrixXd& a, double cut);
  int rank() const { return rank_; }
  int size() const { return n_; }
  // x <- the solution with the trailing block's dropped unknowns zero.
  void solve_in_place(Eigen::VectorXd& x) const;
  // f(i, j) once for every entry of L's pattern (i eliminated after j) and
  // once for each diagonal entry (i = j): every place a matrix analysed
  // here can be nonzero, each pair once.
  template <class F>
  void for_each_entry(F f) const {
    for (int k = 0; k < n_; ++k) {
      const int p = order_[k];
      f(p, p);
      for (int t = l_start_[k]; t < l_start_[k + 1]; ++t) f(l_rows_[t], p);
    }
  }
  // Entries of L below the unit diagonal in the analysed pattern: the fill
  // measure of the order (tests, benchmarks).
  int factor_entries() const { return int(l_rows_.size()); }
  int analyses() const { return analyses_; }  // analyses made so far
  int delayed() const { return int(delayed_.size()); }  // rows in the last trailing block

 private:
  int n_ = 0, rank_ = 0, analyses_ = 0;
  std::vector<int> pairs_, scan_;  // compute's pattern: the last a's, the new a's (row pairs)
  std::vector<int> order_;    // order_[k]: the row eliminated at step k
  std::vector<int> pos_;      // pos_[i]: the step of row i
  // Column k of L (step k): rows l_rows_[l_start_[k], l_start_[k + 1]), in
  // increasing step order, original indices; l_ the values.
  std::vector<int> l_start_, l_rows_;
  std::vector<double> l_;
  std::vector<double> d_;  // per step: the pivot, 0 when delayed
  // The delayed rows in order, and each step's entries of L on them:
  // rows dl_rows_[dl_start_[k], dl_start_[k + 1]), values dl_.
  std::vector<int> delayed_, dl_start_, dl_rows_;
  std::vector<double> dl_, delayed_l_;
  Eigen::MatrixXd delayed_block_;  // their Schur complement (top-left square)
  PivotedLdlt trailing_;           // ... factored
  mutable Eigen::VectorXd trailing_x_;
  Eigen::MatrixXd work_;   // the Schur complement, read at (later, earlier) step pairs
  std::vector<std::uint64_t> adj_, alive_;  // analyse's elimination graph (bit rows)
};

}  // namespace ringsim
