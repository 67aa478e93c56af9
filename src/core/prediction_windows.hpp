#pragma once
// Time windows of prediction: when two bounding spheres moving on straight
// lines overlap, and when a linearly moving point is near a wall. Shared by
// prediction.cpp and prediction_clusters.cpp.

#include <algorithm>
#include <cmath>

#include "core/prediction.hpp"
#include "core/vec.hpp"

namespace ringsim {
namespace detail {

// Interval [enter, leave] (relative times >= 0) during which |dx + dv s| <= R.
// Returns false when the distance never falls to R.
inline bool sphere_window(const Vec3& dx, const Vec3& dv, double R, double* enter, double* leave) {
  const double a = dv.squaredNorm();
  const double b = dx.dot(dv);
  const double c = dx.squaredNorm() - R * R;
  if (a == 0.0) {
    if (c > 0.0) return false;
    *enter = 0.0;
    *leave = kNever;
    return true;
  }
  const double disc = b * b - a * c;
  if (disc < 0.0) return false;
  const double root = std::sqrt(disc);
  const double s_leave = (-b + root) / a;
  if (s_leave < 0.0) return false;
  // Stable form of the smaller root (avoids cancellation when b < 0).
  *enter = c <= 0.0 ? 0.0 : (b < 0.0 ? c / (-b + root) : kNever);
  if (*enter == kNever) return false;
  *leave = s_leave;
  return true;
}

// The window in which a body whose reference point moves linearly (x + v s
// along one axis) can touch the wall at 0 (dir -1) or at L (dir +1): while
// that point is within `reach` of the wall. Narrows [*start, *end) from t;
// false when the point never comes that close.
inline bool wall_window_impl(double L, double x, double v, int dir, double reach, double t, double* start, double* end) {
  const double gap_c = dir > 0 ? L - x : x;
  const double rate_c = dir > 0 ? -v : v;
  if (rate_c < 0.0) {
    *start = t + std::max(0.0, gap_c - reach) / -rate_c;
  } else if (gap_c <= reach) {
    *start = t;
    if (rate_c > 0.0) *end = std::min(*end, t + (reach - gap_c) / rate_c);
  } else {
    return false;
  }
  return true;
}

}  // namespace detail
}  // namespace ringsim
