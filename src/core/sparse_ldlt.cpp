#include "core/sparse_ldlt.hpp"

#include <algorithm>
#include <cmath>

namespace ringsim {

bool SparseLdlt::compute(const Eigen::MatrixXd& a, double cut) {
  // a's pattern as cliques of two (its nonzero pairs below the diagonal).
  const int n = int(a.rows());
  scan_.clear();
  for (int j = 0; j < n; ++j)
    for (int i = j + 1; i < n; ++i)
      if (a(i, j) != 0.0) {
        scan_.push_back(j);
        scan_.push_back(i);
      }
  if (n != n_ || analyses_ == 0 || scan_ != pairs_) {
    pairs_.swap(scan_);
    std::vector<int> start(pairs_.size() / 2 + 1);
    for (std::size_t c = 0; c < start.size(); ++c) start[c] = int(2 * c);
    analyse(n, start, pairs_);
  }
  return factor(a, cut);
}

bool SparseLdlt::factor(const Eigen::MatrixXd& a, double cut) {
  // Right-looking, on L's pattern: work_ holds the Schur complement at
  // (row eliminated later, row eliminated earlier). A delayed row r keeps
  // its Schur row dense at work_(r, j) (j not yet eliminated: the places the
  // static order never writes), and the delayed rows' coupling among
  // themselves in delayed_block_.
  const int n = n_;
  work_.resize(n, n);
  for_each_entry([this, &a](int i, int j) { work_(i, j) = a(i, j); });
  l_.resize(l_rows_.size());
  d_.assign(n, 0.0);
  delayed_.clear();
  dl_start_.assign(1, 0);
  dl_rows_.clear();
  dl_.clear();
  rank_ = 0;
  const double largest = n == 0 ? 0.0 : a.diagonal().maxCoeff();
  if (std::isnan(largest)) return false;
  const double floor = cut * largest, delay = kDelaySine2 * largest;
  std::vector<double>& ld = delayed_l_;
  for (int k = 0; k < n; ++k) {
    const int p = order_[k];
    const double dk = work_(p, p);
    if (std::isnan(dk)) return false;
    const int b = l_start_[k], e = l_start_[k + 1];
    const int nd = int(delayed_.size());
    if (!(dk >= delay) || !(dk > 0.0)) {
      // Delayed to the trailing block: its row (column p of work_ on its
      // pattern, zero elsewhere) moves to row p, its coupling to the rows
      // delayed before it to delayed_block_ (grown as needed, its top-left
      // square in use).
      if (delayed_block_.rows() <= nd) delayed_block_.conservativeResize(2 * nd + 4, 2 * nd + 4);
      for (int j = 0; j < n; ++j)
        if (pos_[j] > k) work_(p, j) = 0.0;
      for (int t = b; t < e; ++t) work_(p, l_rows_[t]) = work_(l_rows_[t], p);
      for (int r = 0; r < nd; ++r) delayed_block_(nd, r) = delayed_block_(r, nd) = work_(delayed_[r], p);
      delayed_block_(nd, nd) = dk;
      delayed_.push_back(p);
      dl_start_.push_back(int(dl_rows_.size()));
      continue;
    }
    d_[k] = dk;
    ++rank_;
    for (int t = b; t < e; ++t) l_[t] = work_(l_rows_[t], p) / dk;
    for (int s = b; s < e; ++s) {
      const int j = l_rows_[s];
      const double ljd = l_[s] * dk;
      for (int t = s; t < e; ++t) work_(l_rows_[t], j) -= l_[t] * ljd;
    }
    // The delayed rows' entries of this column, and their updates.
    ld.resize(nd);
    for (int r = 0; r < nd; ++r) ld[r] = work_(delayed_[r], p) / dk;
    for (int r = 0; r < nd; ++r) {
      if (ld[r] == 0.0) continue;
      const int dr = delayed_[r];
      dl_rows_.push_back(dr);
      dl_.push_back(ld[r]);
      const double lrd = ld[r] * dk;
      for (int t = b; t < e; ++t) work_(dr, l_rows_[t]) -= l_[t] * lrd;
      for (int q = 0; q <= r; ++q) delayed_block_(r, q) -= ld[q] * lrd;
    }
    dl_start_.push_back(int(dl_rows_.size()));
  }
  // The trailing block, pivoted (its dropped rows' unknowns zero), with the
  // same absolute floor as the steps before it.
  const int nd = int(delayed_.size());
  if (nd > 0) {
    for (int r = 0; r < nd; ++r)
      for (int q = 0; q < r; ++q) delayed_block_(q, r) = delayed_block_(r, q);
    const Eigen::MatrixXd block = delayed_block_.topLeftCorner(nd, nd);
    const double first = block.diagonal().maxCoeff();
    if (std::isnan(first)) return false;
    trailing_.compute(block, first > 0.0 ? floor / first : 1.0);
    rank_ += trailing_.rank();
  }
  return true;
}

void SparseLdlt::analyse(int n_rows, const std::vector<int>& start, const std::vector<int>& rows) {
  // Minimum degree on the elimination graph, one bit row per row of the
  // matrix (the clusters' problems have at most a few hundred rows).
  n_ = n_rows;
  const int n = n_, words = (n + 63) / 64;
  ++analyses_;
  adj_.assign(std::size_t(n) * words, 0);
  auto row = [this, words](int i) { return adj_.data() + std::size_t(i) * words; };
  auto set = [](std::uint64_t* r, int j) { r[j / 64] |= std::uint64_t(1) << (j % 64); };
  for (std::size_t c = 0; c + 1 < start.size(); ++c)
    for (int x = start[c]; x < start[c + 1]; ++x)
      for (int y = start[c]; y < x; ++y)
        if (rows[x] != rows[y]) {
          set(row(rows[x]), rows[y]);
          set(row(rows[y]), rows[x]);
        }
  alive_.assign(words, 0);
  for (int i = 0; i < n; ++i) set(alive_.data(), i);
  std::vector<int> degree(n);
  auto count = [this, words, &row](int i) {
    int c = 0;
    const std::uint64_t* r = row(i);
    for (int w = 0; w < words; ++w) c += __builtin_popcountll(r[w] & alive_[w]);
    return c;
  };
  for (int i = 0; i < n; ++i) degree[i] = count(i);

  order_.resize(n);
  pos_.assign(n, -1);
  l_start_.assign(n + 1, 0);
  l_rows_.clear();
  std::vector<int> nbrs;
  std::vector<std::uint64_t> mask(words);
  for (int k = 0; k < n; ++k) {
    int v = -1;
    for (int i = 0; i < n; ++i)
      if (pos_[i] < 0 && (v < 0 || degree[i] < degree[v])) v = i;
    order_[k] = v;
    pos_[v] = k;
    alive_[v / 64] &= ~(std::uint64_t(1) << (v % 64));
    // v's neighbours still to come: L's column k; joined pairwise.
    nbrs.clear();
    const std::uint64_t* rv = row(v);
    for (int w = 0; w < words; ++w) {
      mask[w] = rv[w] & alive_[w];
      for (std::uint64_t bits = mask[w]; bits; bits &= bits - 1) nbrs.push_back(64 * w + __builtin_ctzll(bits));
    }
    for (const int u : nbrs) {
      std::uint64_t* ru = row(u);
      for (int w = 0; w < words; ++w) ru[w] |= mask[w];
      ru[u / 64] &= ~(std::uint64_t(1) << (u % 64));
      degree[u] = count(u);
    }
    l_rows_.insert(l_rows_.end(), nbrs.begin(), nbrs.end());
    l_start_[k + 1] = int(l_rows_.size());
  }
  // Each column's rows in the order they are eliminated (the update loop
  // writes at (later, earlier)).
  for (int k = 0; k < n; ++k)
    std::sort(l_rows_.begin() + l_start_[k], l_rows_.begin() + l_start_[k + 1],
              [this](int a, int b) { return pos_[a] < pos_[b]; });
}

void SparseLdlt::solve_in_place(Eigen::VectorXd& x) const {
  // L = [L11 0; L21 L22] with the delayed rows last: forward through the
  // kept columns (their entries on delayed rows too), the trailing block's
  // own solve on the delayed rows, the kept pivots, back through the kept
  // columns.
  for (int k = 0; k < n_; ++k) {
    if (d_[k] == 0.0) continue;
    const double xp = x[order_[k]];
    for (int t = l_start_[k]; t < l_start_[k + 1]; ++t) x[l_rows_[t]] -= l_[t] * xp;
    for (int t = dl_start_[k]; t < dl_start_[k + 1]; ++t) x[dl_rows_[t]] -= dl_[t] * xp;
  }
  const int nd = int(delayed_.size());
  if (nd > 0) {
    Eigen::VectorXd& z = trailing_x_;
    z.resize(nd);
    for (int r = 0; r < nd; ++r) z[r] = x[delayed_[r]];
    trailing_.solve_in_place(z);
    for (int r = 0; r < nd; ++r) x[delayed_[r]] = z[r];
  }
  for (int k = 0; k < n_; ++k)
    if (d_[k] != 0.0) x[order_[k]] /= d_[k];
  for (int k = n_ - 1; k >= 0; --k) {
    if (d_[k] == 0.0) continue;
    double s = x[order_[k]];
    for (int t = l_start_[k]; t < l_start_[k + 1]; ++t) s -= l_[t] * x[l_rows_[t]];
    for (int t = dl_start_[k]; t < dl_start_[k + 1]; ++t) s -= dl_[t] * x[dl_rows_[t]];
    x[order_[k]] = s;
  }
}

}  // namespace ringsim
