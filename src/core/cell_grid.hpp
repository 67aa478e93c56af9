#pragma once
// Uniform cell grid over the box, the neighbour structure of the event loop.
//
// Invariants: a body is listed in exactly one cell, the one containing its
// centre at its reference time (up to rounding at a boundary just crossed);
// the cell edge is at least the largest interaction range (sum of the two
// largest bounding radii), so every possible contact partner of a body lies in
// its own or one of the (up to) 26 adjacent cells. A body changing cell is an
// event (neighbour refresh), so the cost of one prediction does not depend on N.
// Lists are intrusive doubly linked (head per cell, next/prev per body): O(1)
// insert and remove, no allocation in the event loop.

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "core/intrusive_lists.hpp"
#include "core/params.hpp"
#include "core/vec.hpp"

namespace ringsim {

class CellGrid {
 public:
  CellGrid() = default;
  CellGrid(double box_length, double min_cell, int bodies, bool periodic);

  int cells_per_side() const { return n_; }
  double cell_width() const { return w_; }
  int cell_of_body(int i) const { return cell_[i]; }
  std::array<int, 3> coords(int cell) const { return {cell % n_, (cell / n_) % n_, cell / (n_ * n_)}; }
  int index(int ix, int iy, int iz) const { return ix + n_ * (iy + n_ * iz); }

  void insert(int body, const Vec3& x);
  void move(int body, int new_cell);
  // Cell containing x (clamped into the grid).
  int locate(const Vec3& x) const;

  // Time until the body at x (velocity v) leaves cell c, and where it goes:
  // dim 0..2 and direction +1/-1. Infinity if v = 0. An outer face of a
  // closed grid counts only until the centre is on it.
  struct Exit { double dt; int dim; int dir; };
  Exit exit_time(int cell, const Vec3& x, const Vec3& v) const;
  // Neighbour cell across face (dim, dir); -1 outside a non-periodic box.
  // `wrapped` is set when the step crosses the periodic boundary.
  int step(int cell, int dim, int dir, bool* wrapped) const;

  // Calls f(j) for every body j in the cells adjacent to (and including) c.
  // The wrapped (or clipped) coordinates are found once per axis, not once
  // per cell (walk).
  template <class F>
  void for_each_near(int c, F&& f) const {
    const auto cc = coords(c);
    Block blk;
    for (int d = 0; d < 3; ++d)
      for (int k = 0; k < n_axis_; ++k) blk.add(*this, d, cc[d] + axis_offsets_[k], 1);
    walk(blk, [&](int j, int) { f(j); });
  }

  // Calls f(j, near_a, near_b) once for every body j in the union of the
  // neighbourhoods (27 cells) of cells a and b, visiting each cell once;
  // near_a: j's cell is adjacent to (or is) a. Needs a and b at most one cell
  // apart along each axis and, in a periodic box, at least 4 cells per side
  // (so the union's up to 4 rows per axis are distinct); otherwise it returns
  // false without calling f.
  template <class F>
  bool for_each_near_pair(int a, int b, F&& f) const {
    if (periodic_ && n_ < 4) return false;
    const auto ca = coords(a), cb = coords(b);
    Block blk;
    for (int d = 0; d < 3; ++d) {
      int delta = cb[d] - ca[d];
      if (periodic_) delta = delta > 1 ? delta - n_ : (delta < -1 ? delta + n_ : delta);
      if (delta < -1 || delta > 1) return false;
      for (int o = std::min(0, delta) - 1; o <= std::max(0, delta) + 1; ++o)
        blk.add(*this, d, ca[d] + o, (o >= -1 && o <= 1 ? 1 : 0) | (o - delta >= -1 && o - delta <= 1 ? 2 : 0));
    }
    walk(blk, [&](int j, int m) { f(j, (m & 1) != 0, (m & 2) != 0); });
    return true;
  }

  // True when the 27 cells around any cell are distinct (a periodic box needs
  // at least 3 cells per side), which for_each_face relies on.
  bool faces_distinct() const { return !periodic_ || n_ >= 3; }

  // Calls f(j) for every body j in the 9 cells that became adjacent when a
  // body entered cell c across face (dim, dir): those at offset dir along dim.
  template <class F>
  void for_each_face(int c, int dim, int dir, F&& f) const {
    const auto cc = coords(c);
    Block blk;
    for (int d = 0; d < 3; ++d) {
      if (d == dim) blk.add(*this, d, cc[d] + dir, 1);
      else
        for (int o = -1; o <= 1; ++o) blk.add(*this, d, cc[d] + o, 1);
    }
    walk(blk, [&](int j, int) { f(j); });
  }

 private:
  int wrap(int i) const { return i < 0 ? i + n_ : (i >= n_ ? i - n_ : i); }
  // A block of cells given by up to 4 coordinates per axis (wrapped, or
  // dropped outside a non-periodic box), each pre-multiplied by the axis'
  // stride in the cell lists (row) and in occupied_ (occ: y + n_ z), each with a
  // mask of the neighbourhoods it belongs to (bit 0: the first, bit 1: the
  // second; a cell belongs to those of all three of its coordinates).
  struct Block {
    int row[3][4], occ[3][4];
    int near[3][4];
    int count[3] = {0, 0, 0};
    unsigned select[4] = {0, 0, 0, 0};  // select[m]: the x entries in a neighbourhood of m
    void add(const CellGrid& g, int d, int q, int mask) {
      if (g.periodic_) q = g.wrap(q);
      else if (q < 0 || q >= g.n_) return;
      if (d == 0)
        for (int m = 1; m < 4; ++m)
          if (mask & m) select[m] |= 1u << count[0];
      row[d][count[d]] = d == 0 ? q : (d == 1 ? q * g.n_ : q * g.n_ * g.n_);
      occ[d][count[d]] = d == 0 ? 0 : (d == 1 ? q : q * g.n_);
      near[d][count[d]++] = mask;
    }
  };
  // Calls f(j, m) for every body j of a cell of the block in at least one
  // neighbourhood, m its cell's mask. Rows along x, z slowest; in each only
  // the cells that hold a body (occupied_in_row), x fastest.
  template <class F>
  void walk(const Block& blk, F&& f) const {
    if (blk.count[0] == 0) return;  // outside a non-periodic box
    for (int z = 0; z < blk.count[2]; ++z)
      for (int y = 0; y < blk.count[1]; ++y) {
        const int myz = blk.near[1][y] & blk.near[2][z];
        if (!myz) continue;
        const int r = blk.row[1][y] + blk.row[2][z];  // the row's cell at x = 0
        for (unsigned bits = occupied_in_row(r, blk.occ[1][y] + blk.occ[2][z], blk.row[0], blk.count[0]) & blk.select[myz];
             bits; bits &= bits - 1) {
          const int x = __builtin_ctz(bits);
          const int m = myz & blk.near[0][x];
          for (int j = lists_.head[r + blk.row[0][x]]; j >= 0; j = lists_.next[j]) f(j, m);
        }
      }
  }
  // Bit k set: cell r + xs[k] of the row starting at cell r (row index
  // `occ_row` into occupied_) holds a body; k < nx <= 4. From the row's bit
  // mask when there is one (no load per cell), else from the list heads.
  unsigned occupied_in_row(int r, int occ_row, const int* xs, int nx) const {
    unsigned bits = 0;
    if (!occupied_.empty()) {
      const std::uint64_t w = occupied_[occ_row];
      // Consecutive coordinates (no wrap inside the window): one shift.
      if (xs[nx - 1] - xs[0] == nx - 1) return static_cast<unsigned>(w >> xs[0]) & ((1u << nx) - 1);
      for (int k = 0; k < nx; ++k) bits |= static_cast<unsigned>((w >> xs[k]) & 1) << k;
    } else {
      for (int k = 0; k < nx; ++k) bits |= (lists_.head[r + xs[k]] >= 0 ? 1u : 0u) << k;
    }
    return bits;
  }
  void unlink(int body);
  void link(int body, int cell);

  int n_ = 1;
  double w_ = 0.0;
  double box_ = 0.0;
  bool periodic_ = false;
  IntrusiveLists lists_;  // the bodies of each cell
  std::vector<int> cell_;
  // Bit x of occupied_[y + n_ z]: cell (x, y, z) holds a body. Only with at
  // most 64 cells per side (else empty, and the scans read the list heads).
  std::vector<std::uint64_t> occupied_;
  int axis_offsets_[3] = {-1, 0, 1};  // the distinct offsets along each axis
  int n_axis_ = 3;
};

}  // namespace ringsim
