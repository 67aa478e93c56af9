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
#include <vector>

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
  // dim 0..2 and direction +1/-1. Infinity if v = 0.
  struct Exit { double dt; int dim; int dir; };
  Exit exit_time(int cell, const Vec3& x, const Vec3& v) const;
  // Neighbour cell across face (dim, dir); -1 outside a non-periodic box.
  // `wrapped` is set when the step crosses the periodic boundary.
  int step(int cell, int dim, int dir, bool* wrapped) const;

  // Calls f(j) for every body j in the cells adjacent to (and including) c.
  // The wrapped (or clipped) coordinates are found once per axis, not once
  // per cell; the x offset varies slowest, the z offset fastest.
  template <class F>
  void for_each_near(int c, F&& f) const {
    const auto cc = coords(c);
    int row[3][3];  // per axis: the cell coordinates to visit, pre-multiplied
    int count[3];
    const int stride[3] = {1, n_, n_ * n_};
    for (int d = 0; d < 3; ++d) {
      count[d] = 0;
      for (int k = 0; k < n_axis_; ++k) {
        int q = cc[d] + axis_offsets_[k];
        if (periodic_) q = wrap(q);
        else if (q < 0 || q >= n_) continue;
        row[d][count[d]++] = q * stride[d];
      }
    }
    for (int a = 0; a < count[0]; ++a)
      for (int b = 0; b < count[1]; ++b)
        for (int e = 0; e < count[2]; ++e)
          for (int j = head_[row[0][a] + row[1][b] + row[2][e]]; j >= 0; j = next_[j]) f(j);
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
    int row[3][4];            // per axis: the union's cell coordinates, pre-multiplied
    unsigned char mask[3][4];  // bit 0: within one of a, bit 1: within one of b
    int count[3];
    const int stride[3] = {1, n_, n_ * n_};
    for (int d = 0; d < 3; ++d) {
      int delta = cb[d] - ca[d];
      if (periodic_) delta = delta > 1 ? delta - n_ : (delta < -1 ? delta + n_ : delta);
      if (delta < -1 || delta > 1) return false;
      count[d] = 0;
      for (int o = std::min(0, delta) - 1; o <= std::max(0, delta) + 1; ++o) {
        int q = ca[d] + o;
        if (periodic_) q = wrap(q);
        else if (q < 0 || q >= n_) continue;
        row[d][count[d]] = q * stride[d];
        mask[d][count[d]++] = static_cast<unsigned char>((o >= -1 && o <= 1 ? 1 : 0) | (o - delta >= -1 && o - delta <= 1 ? 2 : 0));
      }
    }
    for (int x = 0; x < count[0]; ++x)
      for (int y = 0; y < count[1]; ++y) {
        const int mxy = mask[0][x] & mask[1][y];
        if (!mxy) continue;
        for (int z = 0; z < count[2]; ++z) {
          const int m = mxy & mask[2][z];
          if (!m) continue;
          for (int j = head_[row[0][x] + row[1][y] + row[2][z]]; j >= 0; j = next_[j]) f(j, (m & 1) != 0, (m & 2) != 0);
        }
      }
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
    const int d1 = (dim + 1) % 3, d2 = (dim + 2) % 3;
    for (int a = -1; a <= 1; ++a) {
      for (int b = -1; b <= 1; ++b) {
        std::array<int, 3> q = cc;
        q[dim] += dir;
        q[d1] += a;
        q[d2] += b;
        if (periodic_) {
          for (int& x : q) x = wrap(x);
        } else if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= n_ || q[1] >= n_ || q[2] >= n_) {
          continue;
        }
        for (int j = head_[index(q[0], q[1], q[2])]; j >= 0; j = next_[j]) f(j);
      }
    }
  }

 private:
  int wrap(int i) const { return i < 0 ? i + n_ : (i >= n_ ? i - n_ : i); }
  void unlink(int body);
  void link(int body, int cell);

  int n_ = 1;
  double w_ = 0.0;
  double box_ = 0.0;
  bool periodic_ = false;
  std::vector<int> head_, next_, prev_, cell_;
  int axis_offsets_[3] = {-1, 0, 1};  // the distinct offsets along each axis
  int n_axis_ = 3;
};

}  // namespace ringsim
