#pragma once
// Evaluation of a compliant member's slice trajectory (Track, core/body.hpp):
// cubic Hermite interpolation of positions and velocities at the slice ends.
//
// With s = (t - ta) / D, D = tb - ta, and the chord velocity vbar = (xb - xa) / D,
// the cubic Hermite polynomial through (xa, va) and (xb, vb) is, in a form
// without cancellation (expand h00 .. h11 of the standard basis),
//   x(t)  = xa + vbar (t - ta) + D s (1 - s) [(1 - s) A - s B],
//   x'(t) = vbar + (1 - s)(1 - 3 s) A - s (2 - 3 s) B,     A = va - vbar, B = vb - vbar.
// On [0, 1]: s (1 - s) <= 1/4, |(1 - s) A - s B| <= max(|A|, |B|), and
// |(1 - s)(1 - 3 s)|, |s (2 - 3 s)| <= 1, which gives the bounds of Track.
// The axis uses the same polynomial on (ua, wa = dua/dt) and (ub, wb), then
// is normalized.

#include <cmath>

#include "core/body.hpp"

namespace ringsim {

namespace detail {
inline Vec3 hermite(const Vec3& a, const Vec3& bar, const Vec3& da, const Vec3& db, double ta, double tb, double t) {
  const double D = tb - ta;
  if (!(D > 0.0)) return a;
  const double s = (t - ta) / D;
  return a + bar * (t - ta) + (D * s * (1.0 - s)) * ((1.0 - s) * (da - bar) - s * (db - bar));
}
inline Vec3 hermite_rate(const Vec3& bar, const Vec3& da, const Vec3& db, double ta, double tb, double t) {
  const double D = tb - ta;
  if (!(D > 0.0)) return da;
  const double s = (t - ta) / D;
  return bar + ((1.0 - s) * (1.0 - 3.0 * s)) * (da - bar) - (s * (2.0 - 3.0 * s)) * (db - bar);
}
}  // namespace detail

inline Vec3 track_center(const Track& k, double t) {
  return detail::hermite(k.xa, k.vbar, k.va, k.vb, k.ta, k.tb, t);
}
inline Vec3 track_velocity(const Track& k, double t) {
  return detail::hermite_rate(k.vbar, k.va, k.vb, k.ta, k.tb, t);
}
inline Vec3 track_axis(const Track& k, double t) {
  return detail::hermite(k.ua, k.ubar, k.wa, k.wb, k.ta, k.tb, t).normalized();
}
namespace detail {
// The unit axis u = h / |h| and its derivative at t.
inline void track_axis_and_rate(const Track& k, double t, Vec3* u, Vec3* du) {
  const Vec3 h = hermite(k.ua, k.ubar, k.wa, k.wb, k.ta, k.tb, t);
  const double n = h.norm();
  *u = h / n;
  const Vec3 dh = hermite_rate(k.ubar, k.wa, k.wb, k.ta, k.tb, t);
  *du = (dh - u->dot(dh) * *u) / n;  // derivative of h / |h|
}
}  // namespace detail

// Angular velocity of the axis direction, axis x d(axis)/dt, plus the spin
// along the axis (linear in time between its end values).
inline Vec3 track_omega(const Track& k, double t) {
  Vec3 u, du;
  detail::track_axis_and_rate(k, t, &u, &du);
  const double D = k.tb - k.ta;
  const double s = D > 0.0 ? (t - k.ta) / D : 0.0;
  return u.cross(du) + ((1.0 - s) * k.spin_a + s * k.spin_b) * u;
}
// A linker's full orientation at t: qa carried along the shortest turn from
// ua to the track's axis, then rolled about that axis by the roll at tb
// times the elapsed share of the slice (linear in time). Exact at both ends;
// inside the slice the roll is interpolated (the event loop never sees it;
// an articulated cluster cut there projects its joints' velocities and
// carries the small anchor residual to the next slice end's projection).
inline Quat track_orientation(const Track& k, double t) {
  const Vec3 u = track_axis(k, t);
  const double D = k.tb - k.ta;
  const double s = D > 0.0 ? (t - k.ta) / D : 0.0;
  return (Quat(Eigen::AngleAxisd(s * k.roll_b, u)) * Quat::FromTwoVectors(k.ua, u) * k.qa).normalized();
}

// Velocity of the shape's point p (the axis turning, spin left out: it does
// not move a cylinder of revolution).
inline Vec3 track_shape_velocity(const Track& k, double t, const Vec3& p, const Vec3& center) {
  Vec3 u, du;
  detail::track_axis_and_rate(k, t, &u, &du);
  return track_velocity(k, t) + u.cross(du).cross(p - center);
}

}  // namespace ringsim
