#include "core/corotating_plane.hpp"

#include <algorithm>
#include <cmath>

#include "core/motion.hpp"

namespace ringsim {

CorotatingPlane::CorotatingPlane(const Kinematics& x, const Species& sx, const Kinematics& y, const Species& sy,
                                 const Vec3& n0, const Vec3& dx, double t0, const Remainder& rem)
    : CorotatingPlane(x, sx, y, sy, n0, dx, t0, sx.shape == Shape::Sphere ? Vec3(Vec3::UnitZ()) : axis_at(x, t0),
                      sy.shape == Shape::Sphere ? Vec3(Vec3::UnitZ()) : axis_at(y, t0), rem) {}

CorotatingPlane::CorotatingPlane(const Kinematics& x, const Species& sx, const Kinematics& y, const Species& sy,
                                 const Vec3& n0, const Vec3& dx, double t0, const Vec3& ux0, const Vec3& uy0,
                                 const Remainder& rem)
    : n0_(n0), dx0_(dx), dv_(y.v - x.v), t0_(t0), rem_(rem), bx_(sx.bounding_radius), by_(sy.bounding_radius) {
  // A sphere's rotation does not move its shape: its plane does not turn.
  wx_ = sx.shape == Shape::Linker ? x.precession : Vec3::Zero();
  wy_ = sy.shape == Shape::Linker ? y.precession : Vec3::Zero();
  y_is_sphere_ = sy.shape == Shape::Sphere;
  ay_ = y_is_sphere_ ? 0.0 : sy.half_length;
  ry_ = sy.radius;
  uy0_ = uy0;
  if (sx.shape == Shape::Sphere) {
    hx_ = sx.radius;
  } else {
    hx_ = sx.half_length * std::abs(n0.dot(ux0)) + sx.radius * n0.cross(ux0).norm();
  }
  has_rem_ = !(rem.c_x == 0.0 && rem.c_y == 0.0 && rem.a_x == 0.0 && rem.a_y == 0.0);
  nx_rot_ = AxisRotation::of(n0_, wx_);
  uy_rot_ = AxisRotation::of(uy0_, wy_);
  wx_norm_ = wx_.norm();
  wy_norm_ = wy_.norm();
  dv_norm_ = dv_.norm();
}

// (Always inlined into advance: its State returns through memory otherwise.)
[[gnu::always_inline]] inline CorotatingPlane::State CorotatingPlane::state(double t) const {
  const double tau = t - t0_;
  const Vec3 n = nx_rot_.at(tau);
  const Vec3 dx = dx0_ + dv_ * tau;
  const Vec3 ndot = wx_.cross(n);
  State st;
  st.dx_norm = dx.norm();
  const double lin = n.dot(dx), lin_rate = ndot.dot(dx) + n.dot(dv_);
  if (y_is_sphere_) {
    st.c = 0.0;
    st.g = 1.0;
    st.cdot = 0.0;
    st.s = lin - ry_ - hx_;
    st.rate = lin_rate;
    return st;
  }
  const Vec3 u = uy_rot_.at(tau);
  st.c = dot3(n, u);
  st.g = cross_norm(n, u);
  const double cdot = ndot.dot(u) + n.dot(wy_.cross(u));
  st.cdot = cdot;
  const double hy = ay_ * std::abs(st.c) + ry_ * st.g;
  // d/dt (a|c| + r g) with g' = -c c' / g (the caller never steps where g is tiny).
  const double hy_rate = (ay_ * (st.c >= 0.0 ? 1.0 : -1.0) - (st.g > 0.0 ? ry_ * st.c / st.g : 0.0)) * cdot;
  st.s = lin - hy - hx_;
  st.rate = lin_rate - hy_rate;
  return st;
}

double CorotatingPlane::at(double t) const { return state(t).s; }

double CorotatingPlane::advance(double t, double end, double target, double stop, long* evaluations,
                                int budget) const {
  const double W = wx_norm_ + wy_norm_;  // bound on |c'| and sqrt|c''|
  constexpr double kMinSine = 1e-3;      // keep away from Y's face-on kink
  for (int k = 0; k < budget; ++k) {
    if (t >= end) return end;
    const State st = state(t);
    ++*evaluations;
    if (st.s <= stop) return t;
    double h_max = end - t;
    if (st.rate < 0.0) h_max = std::min(h_max, 2.0 * (st.s - target) / -st.rate);
    if (!y_is_sphere_ && W > 0.0) {
      const double h_face = (st.g - kMinSine) / W;
      if (h_face <= 0.0) return t;  // Y face-on to the plane: let the fixed plane handle it
      h_max = std::min(h_max, h_face);
    }
    // The bound M grows with the interval (through g_min and |dx|), so try
    // intervals h_max, h_max/4, ... and keep the longest certified step
    // min(h, first root of the quadratic bound on [t, t + h]). (A candidate
    // is at most its h: once the step kept reaches h, no shorter interval
    // can give a longer one.)
    double step = 0.0;
    for (double h = h_max; h > 1e-6 * h_max && h > step; h *= 0.25) {
      double g_min = 1.0;
      bool both_branches = false;
      const double Wh = W + (rem_.a_x + rem_.a_y) * h;  // bound on the true |c'| over the step
      if (!y_is_sphere_ && Wh > 0.0) {
        g_min = st.g - Wh * h;
        if (g_min <= 0.0) continue;  // may reach Y's face-on kink: a shorter step
        // The two smooth branches of a|c|: the sign of c at t, and the other
        // one too if c may reach 0 within the step (the support's kink).
        both_branches = std::abs(st.c) <= Wh * h;
      }
      double M = wx_norm_ * wx_norm_ * (st.dx_norm + dv_norm_ * h) + 2.0 * wx_norm_ * dv_norm_;
      if (!y_is_sphere_) M += (ay_ + ry_ * (1.0 / (g_min * g_min * g_min) + 1.0 / g_min)) * W * W;
      // (Free bodies: every remainder bound is +0, the sum +0, and M + 0 = M.)
      if (has_rem_) M += rem_.c_x + rem_.c_y + 2.0 * rem_.a_x * (st.dx_norm + dv_norm_ * h + bx_ + by_) + 2.0 * rem_.a_y * by_;
      auto first_root = [&](double s0, double rate) {
        // First root of (s0 - target) + rate h - M h^2 / 2 (s0 > target).
        const double d = s0 - target;
        if (d <= 0.0) return 0.0;
        if (M == 0.0) return rate < 0.0 ? d / -rate : h;
        return 2.0 * d / (-rate + std::sqrt(rate * rate + 2.0 * M * d));
      };
      double candidate = std::min(h, first_root(st.s, st.rate));
      if (both_branches) {
        // The other branch, a|c| -> -a sign(c) c: it starts higher, at
        // s + 2 a |c|, with rate s' + 2 a sign(c) c'; past c = 0 it is the
        // true (lower) one.
        const double sgn = st.c >= 0.0 ? 1.0 : -1.0;
        candidate = std::min(candidate, first_root(st.s + 2.0 * ay_ * std::abs(st.c), st.rate + 2.0 * ay_ * sgn * st.cdot));
      }
      step = std::max(step, candidate);
      if (candidate >= 0.5 * h) break;  // shorter intervals cannot do much better
    }
    if (!(step > 1e-15 * std::max(1.0, std::abs(t)))) return t;
    t += step;
  }
  return t;
}

}  // namespace ringsim
