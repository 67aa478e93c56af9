#include "core/separating_plane.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/fast_trig.hpp"
#include "core/motion.hpp"

namespace ringsim {

SupportTrack SupportTrack::constant(double value) {
  SupportTrack s;
  s.constant_ = true;
  s.value_ = value;
  return s;
}

SupportTrack SupportTrack::of(const Kinematics& k, const Species& sp, const Vec3& m, double t0) {
  if (sp.shape == Shape::Sphere) return constant(sp.radius);
  return of(k, sp, m, t0, axis_at(k, t0));
}

SupportTrack SupportTrack::of(const Kinematics& k, const Species& sp, const Vec3& m, double t0, const Vec3& u) {
  if (sp.shape == Shape::Sphere) return constant(sp.radius);
  SupportTrack s;
  s.constant_ = false;
  s.t0_ = t0;
  s.a_ = sp.half_length;
  s.r_ = sp.radius;
  s.cs_ = s.a_ / std::hypot(s.a_, s.r_);
  s.h_cs_ = s.h_of_c(s.cs_);
  const double w = k.precession.norm();
  if (w == 0.0) {
    // No rotation: c is constant.
    s.rate_ = 0.0;
    s.alpha_ = m.dot(u);
    s.rho_ = 0.0;
    s.cross0_ = m.cross(u);
    s.cross_cos_ = s.cross_sin_ = Vec3::Zero();
    return s;
  }
  // u(t) = e (e.u0) + cos(th) u_perp + sin(th) (e x u0), th = w (t - t0)
  // (Rodrigues), so c = m.u = alpha + P cos(th) + Q sin(th)
  //                       = alpha + rho cos(th - phi).
  const Vec3 e = k.precession / w;
  const double eu = e.dot(u);
  s.rate_ = w;
  s.alpha_ = m.dot(e) * eu;
  const double P = m.dot(u - eu * e);
  const double Q = m.dot(e.cross(u));
  s.rho_ = std::hypot(P, Q);
  s.phi_ = std::atan2(Q, P);
  s.cross0_ = eu * m.cross(e);
  s.cross_cos_ = m.cross(u - eu * e);
  s.cross_sin_ = m.cross(e.cross(u));
  return s;
}

double SupportTrack::h_at_theta(double th) const { return h_at(th, c_of(th)); }

double SupportTrack::h_at(double th, double c) const {
  double s, c_th;
  plain_.get(th, &s, &c_th);
  const double sine = (cross0_ + cross_cos_ * c_th + cross_sin_ * s).norm();
  return a_ * std::abs(c) + r_ * std::min(1.0, sine);
}

double SupportTrack::h_of_c(double c) const {
  // Only used away from c = +-1 (at the interior maximiser), where it is well conditioned.
  return a_ * std::abs(c) + r_ * std::sqrt(std::max(0.0, 1.0 - c * c));
}

double SupportTrack::at(double t) const { return constant_ ? value_ : h_at_theta(theta(t)); }

double SupportTrack::max_over(double t1, double t2) const {
  if (constant_) return value_;
  const double th1 = theta(t1), th2 = theta(t2);
  // H depends on time only through c(th) = alpha + rho cos(th - phi). Its
  // maximum over [th1, th2] is at an end, at an extremum of c inside the
  // interval, or where c passes a maximiser of H(c) = a|c| + r sqrt(1 - c^2),
  // which is concave on [-1, 0] and on [0, 1] with maxima at c = +-a/sqrt(a^2 + r^2).
  const double c1 = c_of(th1), c2 = c_of(th2);  // one cosine per end, for h and for the range
  double best = std::max(h_at(th1, c1), h_at(th2, c2));
  double lo = std::min(c1, c2), hi = std::max(c1, c2);
  if (rho_ > 0.0 && rate_ > 0.0) {
    const double two_pi = 2.0 * M_PI;
    const double th_max = phi_ + two_pi * std::ceil((th1 - phi_) / two_pi);
    if (th_max <= th2) {
      hi = alpha_ + rho_;
      best = std::max(best, h_at_theta(th_max));
    }
    const double th_min = phi_ + M_PI + two_pi * std::ceil((th1 - phi_ - M_PI) / two_pi);
    if (th_min <= th2) {
      lo = alpha_ - rho_;
      best = std::max(best, h_at_theta(th_min));
    }
  }
  // (cs and H there, h_of_c(cs) = h_of_c(-cs) bit for bit, depend on the
  // shape only: computed once in of().)
  const double cs = cs_;
  if (lo <= cs && cs <= hi) best = std::max(best, h_cs_);
  if (lo <= -cs && -cs <= hi) best = std::max(best, h_cs_);
  // Guard the rounding of the evaluations above (values are O(a + r)).
  return best + 8.0 * 2.2e-16 * (a_ + r_);
}

namespace {

struct Interval {
  double lo, hi;
};

// The smallest and largest of the four products, folded left to right as
// std::min_element and std::max_element over {ll, lh, hl, hh} do (the first
// of equal values kept, the same comparisons), so the same result; in
// registers: the array version stored the products and reloaded them as
// pairs, and perf found two thirds of its samples stalled on those loads.
[[gnu::always_inline]] inline Interval operator*(Interval a, Interval b) {
  const double ll = a.lo * b.lo, lh = a.lo * b.hi, hl = a.hi * b.lo, hh = a.hi * b.hi;
  return {std::min(std::min(std::min(ll, lh), hl), hh), std::max(std::max(std::max(ll, lh), hl), hh)};
}

// Range over [th1, th2] (amp >= 0) of a sinusoid whose values at the ends
// are v1, v2 and which peaks at th = phase (mod 2 pi), bottoming out at
// phase + pi: mean + amp cos(th - phase).
Interval sinusoid_range(double v1, double v2, double mean, double amp, double phase, double th1, double th2) {
  Interval r{std::min(v1, v2), std::max(v1, v2)};
  if (amp > 0.0) {
    const double two_pi = 2.0 * M_PI;
    if (phase + two_pi * std::ceil((th1 - phase) / two_pi) <= th2) r.hi = mean + amp;
    if (phase + M_PI + two_pi * std::ceil((th1 - phase - M_PI) / two_pi) <= th2) r.lo = mean - amp;
  }
  return r;
}

}  // namespace

double SupportTrack::max_rate_over(double t1, double t2) const {
  if (constant_ || rate_ == 0.0 || rho_ == 0.0) return 0.0;
  const double th1 = theta(t1), th2 = theta(t2);
  // H = a|c| + r g with g = sqrt(1 - c^2); dH/dth = (a sgn(c) - r c / g) c'
  // with c' = dc/dth = -rho sin(th - phi) = rho cos(th - (phi - pi/2)).
  // c = alpha + rho cos(th - phi) and dc = rho cos(th - (phi - pi/2)) =
  // -rho sin(th - phi): one sine and cosine per end serve both.
  double sin1, cos1, sin2, cos2;
  shifted_.get(th1 - phi_, &sin1, &cos1);
  shifted_.get(th2 - phi_, &sin2, &cos2);
  const Interval c = sinusoid_range(alpha_ + rho_ * cos1, alpha_ + rho_ * cos2, alpha_, rho_, phi_, th1, th2);
  const Interval dc = sinusoid_range(-rho_ * sin1, -rho_ * sin2, 0.0, rho_, phi_ - 0.5 * M_PI, th1, th2);
  const double c2max = std::max(c.lo * c.lo, c.hi * c.hi);
  const double gmin = std::sqrt(std::max(0.0, 1.0 - c2max));
  if (gmin < 1e-3) return std::numeric_limits<double>::infinity();
  const double c2min = (c.lo <= 0.0 && c.hi >= 0.0) ? 0.0 : std::min(c.lo * c.lo, c.hi * c.hi);
  const double gmax = std::sqrt(std::max(0.0, 1.0 - c2min));
  Interval sign{c.lo >= 0.0 ? 1.0 : -1.0, c.hi <= 0.0 ? -1.0 : 1.0};
  if (c.lo > 0.0) sign = {1.0, 1.0};
  if (c.hi < 0.0) sign = {-1.0, -1.0};
  const Interval term1 = Interval{a_ * sign.lo, a_ * sign.hi} * dc;
  const Interval inv_g{1.0 / gmax, 1.0 / gmin};
  const Interval term2 = (c * dc) * inv_g;  // enters with factor -r
  const double hi = term1.hi - r_ * term2.lo;
  // Guard rounding (relative 1e-12 of the scale of the rate).
  return rate_ * (hi + 1e-12 * (a_ + r_ / gmin) * rho_);
}

double advance_plane(const SeparatingPlane& plane, double t, double end, double target, double stop,
                     double rate_bound, long* evaluations, int budget) {
  // Cold start: offer a sixteenth of the window first (rejected trials halve),
  // not the safe step, which right after a contact is ~1e-10 and would take
  // ~30 doublings to reach the scale of the motion.
  double step = std::isfinite(end) ? (end - t) / 16.0 : 0.0;
  const long first = *evaluations;
  while (t < end) {
    if (*evaluations - first >= budget) return t;  // the normal has gone stale: let the caller refresh it
    const double s = plane.at(t);
    ++*evaluations;
    if (s <= stop) return t;
    // Always safe: s cannot fall by more than rate_bound * h in time h.
    const double safe = (s - target) / rate_bound;
    // First guess: the Newton step to the target when approaching, else keep
    // growing the last accepted step.
    const double rate = plane.rate_at(t);
    double trial = std::max(step, safe);
    if (rate < 0.0) trial = std::max(safe, std::min(2.0 * std::max(step, safe), 0.9 * (s - target) / -rate));
    // A step below the resolution of t (a gap at round-off level, e.g. 1e-15
    // at t = 475 where one ulp is 6e-14) cannot move t: return and let the
    // caller take its floor step (every caller floors at min_step), instead of
    // spinning through the budget (S4 seed 3: one wall prediction for ever).
    if (t + std::max(trial, safe) == t) return t;
    for (;;) {
      if (trial <= safe) {
        t += safe;
        step = 2.0 * safe;
        break;
      }
      ++*evaluations;
      if (plane.lower_bound(t, t + trial, s) > target) {
        // A trial halved below the resolution of t is certified trivially
        // (an interval of zero width) and does not move t: the same state
        // again, for the whole budget. Hand back as above.
        if (t + trial == t) return t;
        t += trial;
        step = 2.0 * trial;
        break;
      }
      trial *= 0.5;
    }
  }
  return end;
}

}  // namespace ringsim
