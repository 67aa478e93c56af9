#pragma once
// Certified lower bounds on the gap between two moving bodies, from a fixed
// separating direction (used by the conservative advancement in
// prediction.cpp; see docs/PREDICTION.md).
//
// For any unit vector n, the separation of two convex solids A and B along n,
//     s(t) = n.(x_B(t) - x_A(t)) - h_A(n, t) - h_B(-n, t),
// is a lower bound of their distance d(t) (h = support of the solid about its
// centre). Between events every shape moves as a uniform translation plus a
// uniform rotation about a fixed axis (a free linker's axis precesses rigidly
// about L; a sphere's rotation does not move its shape), so for a fixed n
//  - the centre term is linear in t;
//  - a linker's support is H = a|c| + r |n x u| with
//    c(t) = n.u(t) = alpha + rho cos(w (t - t0) - phi), a sinusoid, and
//    n x u(t) = A + B cos(th) + C sin(th). The sine part is evaluated from the
//    vector, not as sqrt(1 - c^2): near face-on poses (c -> +-1) the latter
//    turns a rounding error of 1e-16 in c into 1.5e-8 in the support, enough
//    to step a face contact into overlap.
// H is concave on each side of c = 0, with its maximum at
// c = +-a / sqrt(a^2 + r^2); the exact maximum of H over the range of c on a
// time interval is therefore a handful of evaluations. That gives a rigorous
// lower bound of s on any interval, which the advancement uses to take steps
// as long as the geometry allows, instead of the global rate bound of plain
// conservative advancement (Mirtich 1996), which is kept as the fallback
// step that guarantees progress.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "core/body.hpp"
#include "core/fast_trig.hpp"
#include "core/vec.hpp"

namespace ringsim {

// Support value of one body along a fixed world direction, over time.
class SupportTrack {
 public:
  // Constant support (a sphere of this radius; 0 for a wall plane).
  static SupportTrack constant(double value);
  // Body k (its shape in species s) along unit direction m, from time t0.
  static SupportTrack of(const Kinematics& k, const Species& s, const Vec3& m, double t0);
  // The same with a linker's axis at t0 already known (u0 = axis_at(k, t0)).
  static SupportTrack of(const Kinematics& k, const Species& s, const Vec3& m, double t0, const Vec3& u0);

  double at(double t) const;
  // Upper bound (exact maximum up to rounding) of the support over [t1, t2].
  double max_over(double t1, double t2) const;
  // Upper bound of the support's rate of change d/dt over [t1, t2] (interval
  // arithmetic on the derivative; +infinity where it cannot be bounded, i.e.
  // when the axis passes within 1e-3 rad of the direction). t1 == t2 gives
  // the derivative itself (the larger one-sided value at a kink).
  double max_rate_over(double t1, double t2) const;

 private:
  double theta(double t) const { return rate_ * (t - t0_); }
  double c_of(double th) const {
    double s, c;
    shifted_.get(th - phi_, &s, &c);
    return alpha_ + rho_ * c;
  }
  // The last two sines and cosines computed, by argument bits: one plane
  // step asks for the same angles several times (the value, the rate and the
  // interval bounds at its start; each trial's end in two bounds), and
  // sin_cos is a pure function, so the memo returns the same bits.
  struct SinCosMemo {
    std::uint64_t key[2] = {0x7ff8dead0000beefULL, 0x7ff8dead0000beefULL};  // NaNs no argument here has
    double s[2] = {0.0, 0.0}, c[2] = {0.0, 0.0};
    int next = 0;  // the slot to overwrite
    void get(double x, double* sx, double* cx) {
      std::uint64_t bits;
      std::memcpy(&bits, &x, sizeof bits);
      int k = bits == key[0] ? 0 : (bits == key[1] ? 1 : -1);
      if (k < 0) {
        k = next;
        next ^= 1;
        sin_cos(x, &s[k], &c[k]);
        key[k] = bits;
      }
      *sx = s[k];
      *cx = c[k];
    }
  };
  mutable SinCosMemo shifted_, plain_;  // sin_cos(th - phi), sin_cos(th)
  double h_at_theta(double th) const;
  double h_at(double th, double c) const;  // h_at_theta with c = c_of(th) given
  double h_of_c(double c) const;
  bool constant_ = true;
  double value_ = 0.0;  // constant case
  double t0_ = 0.0, rate_ = 0.0, alpha_ = 0.0, rho_ = 0.0, phi_ = 0.0;
  double a_ = 0.0, r_ = 0.0;
  double cs_ = 0.0, h_cs_ = 0.0;  // H's maximiser a / hypot(a, r) in c, and H there
  Vec3 cross0_, cross_cos_, cross_sin_;  // n x u(th) = cross0 + cross_cos cos(th) + cross_sin sin(th)
};

// s(t) = offset + slope (t - t0) - a(t) - b(t).
struct SeparatingPlane {
  double t0 = 0.0;
  double offset = 0.0;
  double slope = 0.0;
  SupportTrack a, b;

  double at(double t) const { return offset + slope * (t - t0) - a.at(t) - b.at(t); }
  // Two rigorous lower bounds of s over [t1, t2], the larger returned:
  //  - values: min of the linear part minus the maxima of the supports;
  //  - rates: s(t1) + (t2 - t1) * min ds/dt, with min ds/dt = slope - the
  //    maxima of the supports' rates. Its pessimism vanishes as t2 -> t1,
  //    so near a contact the steps approach Newton steps.
  // `s1` is s(t1) (already known to the caller).
  double lower_bound(double t1, double t2, double s1) const {
    const double lin = offset + slope * ((slope < 0.0 ? t2 : t1) - t0);
    const double by_value = lin - a.max_over(t1, t2) - b.max_over(t1, t2);
    const double min_rate = slope - a.max_rate_over(t1, t2) - b.max_rate_over(t1, t2);
    const double by_rate = min_rate < 0.0 ? s1 + (t2 - t1) * min_rate : s1;
    return std::max(by_value, by_rate);
  }
  // ds/dt at t, the smaller one-sided value at a kink.
  double rate_at(double t) const { return slope - a.max_rate_over(t, t) - b.max_rate_over(t, t); }
};

// Starting at t (where s(t) > target), advance while the plane certifies
// s > target, and return the first certified time at which s(t) <= stop
// (target < stop), or `end` if the window closes first, or the time reached
// after `budget` evaluations (a fixed normal stops being a tight bound once the
// closest features move on; a fresh one costs about as much as ten
// evaluations). `rate_bound` bounds |ds/dt| and guarantees progress.
// `evaluations` counts plane evaluations.
double advance_plane(const SeparatingPlane& plane, double t, double end, double target, double stop,
                     double rate_bound, long* evaluations, int budget);

}  // namespace ringsim
