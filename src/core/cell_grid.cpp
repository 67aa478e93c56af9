#include "core/cell_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace ringsim {

CellGrid::CellGrid(double box_length, double min_cell, int bodies, bool periodic)
    : box_(box_length), periodic_(periodic) {
  n_ = std::max(1, static_cast<int>(std::floor(box_length / min_cell)));
  // Cap memory for tiny interaction ranges in huge boxes (~ a few cells per body).
  const int cap = std::max(1, static_cast<int>(std::cbrt(8.0 * std::max(bodies, 1))));
  n_ = std::min(n_, std::max(cap, 1));
  w_ = box_length / n_;
  lists_.reset(n_ * n_ * n_, bodies);
  cell_.assign(bodies, -1);
  if (n_ <= 64) occupied_.assign(static_cast<std::size_t>(n_) * n_, 0);
  // With fewer than 3 cells along a side of a periodic box, offsets -1 and +1
  // reach the same cell: keep each distinct cell once.
  if (periodic_ && n_ < 3) {
    n_axis_ = n_;  // {0, 1} or {0}
    axis_offsets_[0] = 0;
    axis_offsets_[1] = 1;
  }
}

int CellGrid::locate(const Vec3& x) const {
  int ic[3];
  for (int d = 0; d < 3; ++d) ic[d] = std::clamp(static_cast<int>(std::floor(x[d] / w_)), 0, n_ - 1);
  return index(ic[0], ic[1], ic[2]);
}

void CellGrid::link(int body, int cell) {
  cell_[body] = cell;
  lists_.push_front(body, cell);
  if (!occupied_.empty()) occupied_[cell / n_] |= std::uint64_t{1} << (cell % n_);
}

void CellGrid::unlink(int body) {
  const int c = cell_[body];
  lists_.remove(body, c);
  if (lists_.head[c] < 0 && !occupied_.empty()) occupied_[c / n_] &= ~(std::uint64_t{1} << (c % n_));
}

void CellGrid::insert(int body, const Vec3& x) { link(body, locate(x)); }

void CellGrid::move(int body, int new_cell) {
  unlink(body);
  link(body, new_cell);
}

CellGrid::Exit CellGrid::exit_time(int cell, const Vec3& x, const Vec3& v) const {
  const auto cc = coords(cell);
  Exit best{std::numeric_limits<double>::infinity(), 0, 0};
  // An outer face of a closed box is no exit once the centre is on it: the
  // wall turns the body back (its solid touches the wall before its centre
  // reaches the face, unless rounding puts both at one time, as for a sphere
  // of radius 1e-15: counted as an exit, the crossing "out" came again and
  // again at that instant, found by a sweep). Before that the face still
  // bounds the body's searches like any other.
  for (int d = 0; d < 3; ++d) {
    if (v[d] > 0.0) {
      const double dt = ((cc[d] + 1) * w_ - x[d]) / v[d];
      if (dt < best.dt && (dt > 0.0 || periodic_ || cc[d] + 1 < n_)) best = {dt, d, +1};
    } else if (v[d] < 0.0) {
      const double dt = (cc[d] * w_ - x[d]) / v[d];
      if (dt < best.dt && (dt > 0.0 || periodic_ || cc[d] > 0)) best = {dt, d, -1};
    }
  }
  if (best.dt < 0.0) best.dt = 0.0;  // rounding just after a crossing
  return best;
}

int CellGrid::step(int cell, int dim, int dir, bool* wrapped) const {
  auto cc = coords(cell);
  cc[dim] += dir;
  *wrapped = false;
  if (cc[dim] < 0 || cc[dim] >= n_) {
    if (!periodic_) return -1;
    cc[dim] = wrap(cc[dim]);
    *wrapped = true;
  }
  return index(cc[0], cc[1], cc[2]);
}

}  // namespace ringsim
