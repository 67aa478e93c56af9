#pragma once
// Evaluation of a compliant member's slice trajectory (Track, core/body.hpp):
// quintic Hermite interpolation of positions, velocities and accelerations
// at the slice ends.
//
// With s = (t - ta) / D, D = tb - ta, and the chord velocity vbar = (xb - xa) / D,
// the cubic Hermite polynomial through (xa, va) and (xb, vb) is, in a form
// without cancellation (expand h00 .. h11 of the standard basis),
//   c(t)  = xa + vbar (t - ta) + D s (1 - s) [(1 - s) A - s B],
//   c'(t) = vbar + (1 - s)(1 - 3 s) A - s (2 - 3 s) B,     A = va - vbar, B = vb - vbar,
// and its second derivative at the ends is c''(ta) = -(4 A + 2 B) / D,
// c''(tb) = (2 A + 4 B) / D. The quintic that also matches the accelerations
// aa, ab adds a term with zero value and slope at both ends,
//   x(t) = c(t) + p(s) [(1 - s) alpha + s beta],   p(s) = s^2 (1 - s)^2,
// whose second derivative is 2 alpha / D^2 at ta and 2 beta / D^2 at tb:
//   alpha = D (D aa + 4 A + 2 B) / 2,   beta = D (D ab - 2 A - 4 B) / 2
// (both O(D^3 x''') : what the accelerations add to the cubic). Its error is
// O(D^6 x^(6)) against the cubic's O(D^4 x''''), which is what lets a slice
// be long (docs/ARTICULATED.md, "Slices and tracks"). With the accelerations
// unknown (alpha = beta = 0) it is the cubic.
// On [0, 1]: s (1 - s) <= 1/4, |(1 - s) A - s B| <= max(|A|, |B|),
// |(1 - s)(1 - 3 s)|, |s (2 - 3 s)| <= 1, p <= 1/16, |p'| <= 1 / (3 sqrt 3),
// |p''| <= 2, which give the bounds of Track (core/compliant_group.cpp).
// The axis uses the same polynomial on (ua, wa = dua/dt, ua'') and
// (ub, wb, ub''), then is normalized (h'' = u'' at an end makes the
// normalized curve's second derivative u'' there, since u . u'' = -|u'|^2).

#include <cmath>

#include "core/body.hpp"

namespace ringsim {

// max over [0, 1] of |p'(s)| = |2 s (1 - s)(1 - 2 s)|, at s = (3 - sqrt 3) / 6.
constexpr double kQuinticSlopeMax = 0.19245008972987526;  // 1 / (3 sqrt 3)

namespace detail {
inline Vec3 hermite(const Vec3& a, const Vec3& bar, const Vec3& da, const Vec3& db, const Vec3& c0, const Vec3& c1,
                    double ta, double tb, double t) {
  const double D = tb - ta;
  if (!(D > 0.0)) return a;
  const double s = (t - ta) / D, r = 1.0 - s;
  return a + bar * (t - ta) + (D * s * r) * (r * (da - bar) - s * (db - bar)) + (s * s * r * r) * (r * c0 + s * c1);
}
inline Vec3 hermite_rate(const Vec3& bar, const Vec3& da, const Vec3& db, const Vec3& c0, const Vec3& c1, double ta,
                         double tb, double t) {
  const double D = tb - ta;
  if (!(D > 0.0)) return da;
  const double s = (t - ta) / D, r = 1.0 - s;
  const double p = s * s * r * r, dp = 2.0 * s * r * (1.0 - 2.0 * s);
  return bar + (r * (1.0 - 3.0 * s)) * (da - bar) - (s * (2.0 - 3.0 * s)) * (db - bar) +
         (dp / D) * (r * c0 + s * c1) + (p / D) * (c1 - c0);
}
}  // namespace detail

inline Vec3 track_center(const Track& k, double t) {
  return detail::hermite(k.xa, k.vbar, k.va, k.vb, k.xc0, k.xc1, k.ta, k.tb, t);
}
inline Vec3 track_velocity(const Track& k, double t) {
  return detail::hermite_rate(k.vbar, k.va, k.vb, k.xc0, k.xc1, k.ta, k.tb, t);
}
inline Vec3 track_axis(const Track& k, double t) {
  return detail::hermite(k.ua, k.ubar, k.wa, k.wb, k.uc0, k.uc1, k.ta, k.tb, t).normalized();
}
namespace detail {
// The unit axis u = h / |h| and its derivative at t.
inline void track_axis_and_rate(const Track& k, double t, Vec3* u, Vec3* du) {
  const Vec3 h = hermite(k.ua, k.ubar, k.wa, k.wb, k.uc0, k.uc1, k.ta, k.tb, t);
  const double n = h.norm();
  *u = h / n;
  const Vec3 dh = hermite_rate(k.ubar, k.wa, k.wb, k.uc0, k.uc1, k.ta, k.tb, t);
  *du = (dh - u->dot(dh) * *u) / n;  // derivative of h / |h|
}
// The roll at t (radians, 0 at ta, roll_b at tb): the cubic Hermite through
// the roll rates at the ends (spin_a, roll_rate_b) (the same form as the centre's cubic), and its rate.
inline double roll_at(const Track& k, double t) {
  const double D = k.tb - k.ta;
  if (!(D > 0.0)) return 0.0;
  const double s = (t - k.ta) / D, r = 1.0 - s, bar = k.roll_b / D;
  return s * k.roll_b + D * s * r * (r * (k.spin_a - bar) - s * (k.roll_rate_b - bar));
}
inline double roll_rate_at(const Track& k, double t) {
  const double D = k.tb - k.ta;
  if (!(D > 0.0)) return k.spin_a;
  const double s = (t - k.ta) / D, bar = k.roll_b / D;
  return bar + ((1.0 - s) * (1.0 - 3.0 * s)) * (k.spin_a - bar) - (s * (2.0 - 3.0 * s)) * (k.roll_rate_b - bar);
}
}  // namespace detail

// The spin of the shortest-turn frame: the rotation carrying a fixed unit
// vector a onto a moving unit axis u along the shortest arc turns about u
// at -a . (u x u') / (1 + a . u) (differentiate the rotation by angle
// acos(a . u) about a x u / |a x u|; zero at u = a).
inline double shortest_turn_spin(const Vec3& a, const Vec3& u, const Vec3& du) {
  return -a.dot(u.cross(du)) / (1.0 + a.dot(u));
}

// Angular velocity: the axis' turning, axis x d(axis)/dt, plus the spin
// along the axis. Quintic (articulated) tracks: the roll's rate plus the
// shortest-turn frame's spin, so that it is the derivative of
// track_orientation. Cubic (compliant) tracks: linear in time between its
// end values (no compliant load turns a linker about its own axis, so the
// spin stays constant there).
inline Vec3 track_omega(const Track& k, double t) {
  Vec3 u, du;
  detail::track_axis_and_rate(k, t, &u, &du);
  if (k.quintic) return u.cross(du) + (detail::roll_rate_at(k, t) + shortest_turn_spin(k.ua, u, du)) * u;
  const double D = k.tb - k.ta;
  const double s = D > 0.0 ? (t - k.ta) / D : 0.0;
  return u.cross(du) + ((1.0 - s) * k.spin_a + s * k.spin_b) * u;
}
// A linker's full orientation at t (articulated members): qa carried along
// the shortest turn from ua to the track's axis, then rolled about that axis
// by the roll at t. Exact at both ends; inside the slice the roll is the
// cubic through the rolls and roll rates at the ends (the event loop never
// sees it; an articulated cluster cut there fits the rolls to its joints,
// core/joint_projection.hpp).
inline Quat track_orientation(const Track& k, double t) {
  const Vec3 u = track_axis(k, t);
  return (Quat(Eigen::AngleAxisd(detail::roll_at(k, t), u)) * Quat::FromTwoVectors(k.ua, u) * k.qa).normalized();
}

// Velocity of the shape's point p (the axis turning, spin left out: it does
// not move a cylinder of revolution).
inline Vec3 track_shape_velocity(const Track& k, double t, const Vec3& p, const Vec3& center) {
  Vec3 u, du;
  detail::track_axis_and_rate(k, t, &u, &du);
  return track_velocity(k, t) + u.cross(du).cross(p - center);
}

}  // namespace ringsim
