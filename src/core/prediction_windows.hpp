#pragma once
// Time windows of prediction: when two bounding spheres moving on straight
// lines overlap, and when a linearly moving point is near a wall; and the
// swept-support bounds of certified steps (a body's support or a point over a
// step, from its first-order motion, core/pose.hpp LocalMotion). Shared by
// prediction.cpp and prediction_clusters.cpp.

#include <algorithm>
#include <cmath>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/crossed_axes.hpp"
#include "core/pose.hpp"
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

// How long a closed window stays closed. A window found on the minimum image
// of t (the relative line dx + dv s) that has ended, or never opens, is closed
// for good on that image only: in a periodic box of edge L another image,
// dx + dv s - L k with k a non-zero integer vector, comes within R no earlier
// than |dv| s >= min_c (L - |dx_c|) - R, since some component of dx - L k has
// magnitude at least L - |dx_c| >= L/2. (|dv| is bounded by its 1-norm: no
// square root on a path taken for every neighbour.)
struct ImageReturn {
  double gap = 0.0, speed = 0.0;  // the return is no earlier than gap / speed
  ImageReturn(const Box& box, const Vec3& dx, const Vec3& dv, double R) {
    if (!box.periodic) return;
    gap = std::max(0.0, box.length - dx.cwiseAbs().maxCoeff() - R);
    speed = dv.cwiseAbs().sum();
  }
  // Relative time; kNever in a closed box or without relative motion; 0 when
  // nothing can be said (R >= L/2).
  double time() const { return speed > 0.0 ? gap / speed : kNever; }
  // Whether it comes before relative time s (s may be kNever).
  bool before(double s) const { return speed > 0.0 && gap < s * speed; }
};
// Where the proof of a window closed on the minimum image of t ends: the later
// of its closing (relative time `leave`; 0 when it never opens) and the
// return of another image.
inline double closed_window_end(const Box& box, const Vec3& dx, const Vec3& dv, double R, double t, double leave) {
  return t + std::max(leave, ImageReturn(box, dx, dv, R).time());
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

// Upper bound of the support of body i's solid along the unit direction n at
// s + tau, less the reference point's own motion n.(ref + v tau), from its pose
// and LocalMotion at s (core/pose.hpp). Each point obeys
//   n.x(s + tau) <= n.ref(s + tau) + n.r + tau n.(omega x r) + accel |r| tau^2 / 2
// and n.(omega x r) = r.(n x omega), so the maximum over the solid is its
// support about ref along the turned, unnormalised direction
// m = n + tau (n x omega): m.(c - ref) + h(m), h(m) = h |u.m| + r |u x m| for a
// cylinder (support functions are positively homogeneous) and r for a sphere,
// whose ball does not turn. A support function of an affine argument plus a
// convex quadratic: convex in tau.
struct SweptSupport {
  Vec3 n, turn, offset, axis;
  double radius = 0.0, half_length = 0.0, quad = 0.0;
  bool sphere = true;
  bool at_reference = false;  // offset == 0 (the centre is the reference point)

  SweptSupport(const BodyStore& b, int i, double s, const Vec3& dir, const Vec3& center, const Vec3& ref)
      : SweptSupport(b, i, s, dir, center, ref, b.shape[i] == Shape::Sphere ? Vec3(Vec3::UnitZ()) : body_axis(b, i, s)) {}
  // The same with a linker's axis at s already known (a sphere's is unused).
  SweptSupport(const BodyStore& b, int i, double s, const Vec3& dir, const Vec3& center, const Vec3& ref,
               const Vec3& axis_at_s) {
    const Species& sp = b.sp(i);
    const LocalMotion lm = local_motion(b, i, s);
    n = dir;
    turn = dir.cross(lm.omega);
    offset = center - ref;
    at_reference = offset == Vec3::Zero();
    sphere = sp.shape == Shape::Sphere;
    radius = sp.radius;
    half_length = sp.half_length;
    if (!sphere) axis = axis_at_s;
    // |r| over the solid: the centre's offset plus the body's own extent
    // (a sphere: only its centre moves the ball).
    const double rho = offset.norm() + (sphere ? 0.0 : sp.bounding_radius);
    quad = 0.5 * lm.accel * rho;
  }
  // (A free body's centre is its reference point: offset is exactly zero,
  // and its dot product, +-0, adds nothing to quad tau^2 >= +0.)
  double at(double tau) const {
    const Vec3 m = n + tau * turn;
    double h = quad * tau * tau;
    if (!at_reference) h = dot3(m, offset) + h;
    if (sphere) return h + radius;
    return h + half_length * std::abs(dot3(axis, m)) + radius * cross_norm(axis, m);
  }
};

// Two linkers' swept supports whose centres are their reference points (free
// linkers: at_reference, not spheres), evaluated side by side in the two lanes
// of SSE2 registers: each lane does SweptSupport::at's operations in its
// order (no fused multiply-add in this build: -O2 for x86-64, no -mfma), so
// the same bits, with one square root instruction for both. usable() false:
// the caller evaluates them one by one.
struct SweptSupportPair {
  explicit SweptSupportPair(const SweptSupport& a, const SweptSupport& b)
      : ok(!a.sphere && !b.sphere && a.at_reference && b.at_reference) {
#if defined(__SSE2__)
    if (!ok) return;
    for (int c = 0; c < 3; ++c) {
      n[c] = _mm_set_pd(b.n[c], a.n[c]);
      turn[c] = _mm_set_pd(b.turn[c], a.turn[c]);
      axis[c] = _mm_set_pd(b.axis[c], a.axis[c]);
    }
    quad = _mm_set_pd(b.quad, a.quad);
    half_length = _mm_set_pd(b.half_length, a.half_length);
    radius = _mm_set_pd(b.radius, a.radius);
#else
    ok = false;
#endif
  }
  bool usable() const { return ok; }
#if defined(__SSE2__)
  // a.at(tau) + ... : *ha = a.at(tau), *hb = b.at(tau).
  [[gnu::always_inline]] void at(double tau, double* ha, double* hb) const {
    const __m128d t = _mm_set1_pd(tau);
    // m = n + tau turn
    const __m128d m0 = _mm_add_pd(n[0], _mm_mul_pd(t, turn[0]));
    const __m128d m1 = _mm_add_pd(n[1], _mm_mul_pd(t, turn[1]));
    const __m128d m2 = _mm_add_pd(n[2], _mm_mul_pd(t, turn[2]));
    // h = quad tau tau
    const __m128d h = _mm_mul_pd(_mm_mul_pd(quad, t), t);
    // dot3(axis, m) = (a0 m0 + a1 m1) + a2 m2
    const __m128d d = _mm_add_pd(_mm_add_pd(_mm_mul_pd(axis[0], m0), _mm_mul_pd(axis[1], m1)), _mm_mul_pd(axis[2], m2));
    const __m128d abs_d = _mm_andnot_pd(_mm_set1_pd(-0.0), d);
    // cross_norm(axis, m)
    const __m128d x = _mm_sub_pd(_mm_mul_pd(axis[1], m2), _mm_mul_pd(axis[2], m1));
    const __m128d y = _mm_sub_pd(_mm_mul_pd(axis[2], m0), _mm_mul_pd(axis[0], m2));
    const __m128d z = _mm_sub_pd(_mm_mul_pd(axis[0], m1), _mm_mul_pd(axis[1], m0));
    const __m128d cn = _mm_sqrt_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(x, x), _mm_mul_pd(y, y)), _mm_mul_pd(z, z)));
    // h + half_length |d| + radius cn
    const __m128d r = _mm_add_pd(_mm_add_pd(h, _mm_mul_pd(half_length, abs_d)), _mm_mul_pd(radius, cn));
    *ha = _mm_cvtsd_f64(r);
    *hb = _mm_cvtsd_f64(_mm_unpackhi_pd(r, r));
  }
  __m128d n[3], turn[3], axis[3], quad, half_length, radius;
#else
  void at(double, double*, double*) const {}
#endif
  bool ok;
};

// For a concave f: a tau in [0, tau_max] with f >= level on all of [0, tau]
// (f(0) >= level and f(tau) >= level suffice, by concavity), as large as
// cheaply found; 0 when f(0) or f(tau0) is below level (then no step beyond
// tau0 is provable: f stays below level past it). Doubling from tau0, then
// regula falsi on the last bracket: for a concave f the chord lies below f, so
// a chord root is again a point with f >= level (each is checked anyway).
template <class F>
double concave_reach(const F& f, double level, double tau0, double tau_max, long* evaluations) {
  constexpr int kDoublings = 24, kChords = 3;
  double good = std::min(tau0, tau_max);
  *evaluations += 2;
  if (!(f(0.0) >= level)) return 0.0;
  double f_good = f(good);
  if (!(f_good >= level)) return 0.0;
  double bad = 0.0, f_bad = 0.0;
  for (int k = 0; k < kDoublings && good < tau_max; ++k) {
    const double next = std::min(2.0 * good, tau_max);
    ++*evaluations;
    const double fn = f(next);
    if (!(fn >= level)) {
      bad = next, f_bad = fn;
      break;
    }
    good = next, f_good = fn;
  }
  if (bad == 0.0) return good;
  for (int k = 0; k < kChords && bad - good > 0.05 * good; ++k) {
    const double c = good + (f_good - level) * (bad - good) / (f_good - f_bad);
    if (!(c > good && c < bad)) break;
    ++*evaluations;
    const double fc = f(c);
    if (fc >= level) good = c, f_good = fc;
    else bad = c, f_bad = fc;
  }
  return good;
}

// First tau >= 0 at which |dx + dv tau| <= B + K tau can hold (kNever if
// never): two points whose separation is dx now, moving apart at dv, each
// free to stray from its straight line by at most K tau in all (K: the sum of
// their speeds about their reference points), cannot come within B sooner.
// A lower bound: B is widened by 1e-12 relative and tau shortened as much.
inline double cone_reach(const Vec3& dx, const Vec3& dv, double B, double K) {
  B *= 1.0 + 1e-12;
  const double c = dx.squaredNorm() - B * B;
  if (c <= 0.0) return 0.0;
  // |dx + dv tau|^2 - (B + K tau)^2 = a tau^2 + 2 bq tau + c, c > 0: its first root.
  const double a = dv.squaredNorm() - K * K, bq = dx.dot(dv) - B * K;
  double tau;
  if (a < 0.0) {
    tau = c / (std::sqrt(bq * bq - a * c) - bq);  // the positive root (the roots' product c / a < 0)
  } else {
    const double disc = bq * bq - a * c;
    if (bq >= 0.0 || disc < 0.0) return kNever;  // (a = 0: the linear case, the same formula)
    tau = c / (std::sqrt(disc) - bq);
  }
  return tau * (1.0 - 1e-12);
}

// Largest tau >= 0 with a + b tau - c tau^2 >= level (c >= 0, a >= level): the
// larger root of the concave quadratic, in the form without cancellation.
inline double quadratic_reach(double a, double b, double c, double level) {
  const double room = a - level;
  if (!(room >= 0.0)) return 0.0;
  if (b < 0.0) return 2.0 * room / (std::sqrt(b * b + 4.0 * c * room) - b);
  if (c > 0.0) return (b + std::sqrt(b * b + 4.0 * c * room)) / (2.0 * c);
  return kNever;
}

// First-order motion of one material point x of body i at s (LocalMotion):
// velocity and the bound on the remainder, |x(s + tau) - x - vel tau| <= quad tau^2.
struct PointMotion {
  Vec3 vel;
  double quad;
};
inline PointMotion point_motion(const BodyStore& b, int i, double s, const Vec3& x, const Vec3& ref) {
  const LocalMotion lm = local_motion(b, i, s);
  if (is_compliant(b, i)) {
    // About the member's own centre, which moves within its track's bound.
    const Vec3 c = body_center(b, i, s);
    const Track& k = b.track[i];
    return {track_velocity(k, s) + lm.omega.cross(x - c), 0.5 * (k.center_accel + lm.accel * (x - c).norm())};
  }
  const Vec3 r = x - ref;
  return {reference_velocity(b, i) + lm.omega.cross(r), 0.5 * lm.accel * r.norm()};
}

// Body i's first-order motion at s about its own centre: the centre's
// velocity and the solid's angular velocity (LocalMotion), with bounds on the
// second order that hold up to its motion horizon: the centre's acceleration
// (a compliant member's track bound; a rigid member's centre turns about the
// cluster's centre of mass at distance reach, |x''| <= accel reach; a free
// body's centre moves on a line) and the turning's, |Omega'| + |Omega|^2 >= |u''|
// (LocalMotion's accel).
struct OwnMotion {
  Vec3 v, omega;
  double center_accel, turning_accel;
};
inline OwnMotion own_motion(const BodyStore& b, int i, double s) {
  const RefMotion m = ref_motion(b, i, s);
  const LocalMotion l = local_motion(b, i, s);
  // ref_motion's offset = reference point - centre (a rigid member's
  // reference point is its cluster's centre of mass).
  const Vec3 v = m.v - l.omega.cross(m.offset);
  double c = 0.0;
  if (is_compliant(b, i)) c = b.track[i].center_accel;
  else if (b.group[i] >= 0) c = l.accel * b.reach[i];
  return {v, l.omega, c, l.accel};
}

// A linker's data for CrossedAxesPlane (core/crossed_axes.hpp) at s: its axis
// u and radius there, and its own motion m at s.
inline AxisMotion axis_motion(const Vec3& u, double radius, const OwnMotion& m) {
  AxisMotion a;
  a.u = u;
  a.v = m.v;
  a.du = m.omega.cross(a.u);
  a.center_accel = m.center_accel;
  a.axis_accel = m.turning_accel;
  a.radius = radius;
  return a;
}

}  // namespace detail
}  // namespace ringsim
