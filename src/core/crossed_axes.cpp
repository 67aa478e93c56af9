#include "core/crossed_axes.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ringsim {

CrossedAxesPlane::CrossedAxesPlane(const AxisMotion& x, const AxisMotion& y, const Vec3& dx)
    : CrossedAxesPlane(x.u, x.radius, y.u, y.radius, dx) {
  set_motion(x, y, dx);
}

CrossedAxesPlane::CrossedAxesPlane(const Vec3& ux, double rx, const Vec3& uy, double ry, const Vec3& dx) {
  w_ = ux.cross(uy);
  rho0_ = w_.norm();
  if (!usable()) return;
  m_ = w_ / rho0_;
  if (m_.dot(dx) < 0.0) m_ = -m_;  // sigma: from X towards Y
  s0_ = m_.dot(dx) - rx - ry;
}

void CrossedAxesPlane::set_motion(const AxisMotion& x, const AxisMotion& y, const Vec3& dx) {
  if (!usable()) return;
  const Vec3& m = m_;
  const Vec3 dv = y.v - x.v;
  // w' = u_X' x u_Y + u_X x u_Y'; m' = (w' - m (m.w')) / |w| (the sign of m
  // carried by w' along with w).
  const double sigma = m.dot(w_) > 0.0 ? 1.0 : -1.0;
  const Vec3 dw = sigma * (x.du.cross(y.u) + x.u.cross(y.du));
  const Vec3 dm = (dw - m * m.dot(dw)) / rho0_;
  rate0_ = dm.dot(dx) + m.dot(dv);
  q_rate0_ = m.dot(dw);
  d_norm_ = dx.norm();
  dv_norm_ = dv.norm();
  c_ = x.center_accel + y.center_accel;
  r_sum_ = x.radius + y.radius;
  wx0_ = x.du.norm();
  wy0_ = y.du.norm();
  ax_ = x.axis_accel;
  ay_ = y.axis_accel;
}

CrossedAxesPlane::StepBounds CrossedAxesPlane::step_bounds(double h) const {
  StepBounds k;
  const double wx = wx0_ + ax_ * h, wy = wy0_ + ay_ * h;
  k.dw = wx + wy;
  k.rho = rho0_ - k.dw * h;
  k.usable = k.rho >= 0.25 * rho0_;
  k.ddw = ax_ + ay_ + 2.0 * wx * wy;
  k.D = d_norm_ + dv_norm_ * h + 0.5 * c_ * h * h;
  k.dD = dv_norm_ + c_ * h;
  return k;
}

double CrossedAxesPlane::curvature_of_s(const StepBounds& k) const {
  if (!k.usable) return std::numeric_limits<double>::infinity();
  const double dm = k.dw / k.rho, ddm = 2.0 * k.ddw / k.rho + 5.0 * k.dw * k.dw / (k.rho * k.rho);
  return ddm * k.D + 2.0 * dm * k.dD + c_;
}

double CrossedAxesPlane::curvature_of_f(const StepBounds& k, double level) const {
  if (!k.usable) return std::numeric_limits<double>::infinity();
  // |P''| <= |w''| |D| + 2 |w'| |D'| + |w| |D''| with |w| <= 1; |Q''| <= |w''| + |w'|^2 / |w|.
  return k.ddw * k.D + 2.0 * k.dw * k.dD + c_ + (r_sum_ + level) * (k.ddw + k.dw * k.dw / k.rho);
}

double CrossedAxesPlane::curvature_bound(double h) const { return curvature_of_s(step_bounds(h)); }

double CrossedAxesPlane::scaled_curvature_bound(double h, double level) const {
  return curvature_of_f(step_bounds(h), level);
}

namespace {
// The largest tau with e + r tau - M tau^2 / 2 >= 0 (e > 0), in forms
// without cancellation; h when M <= 0 and r >= 0.
double quadratic_root(double e, double r, double M, double h) {
  if (M <= 0.0) return r >= 0.0 ? h : e / -r;
  const double root = std::sqrt(r * r + 2.0 * M * e);
  return r >= 0.0 ? (r + root) / M : 2.0 * e / (root - r);
}
}  // namespace

double CrossedAxesPlane::step(double target, double h_max) const {
  if (!usable() || s0_ <= target || !(h_max > 0.0)) return 0.0;
  // Two certificates over a step of length h, each valid up to min(h, tau)
  // for its own tau, so their larger tau is certified:
  //  - s itself: the largest tau with s0 + r tau - M tau^2 / 2 >= target;
  //  - F = P - (r_X + r_Y + target) Q >= 0 (header), whose curvature bound
  //    has no 1 / |w|^2 terms: F(0) = rho0 (s0 - target),
  //    F'(0) = rho0 s'(0) + Q'(0) (s0 - target) (from P = |w| (s + r_X + r_Y)).
  auto reach = [&](double h) {
    const StepBounds k = step_bounds(h);
    if (!k.usable) return 0.0;
    const double by_s = quadratic_root(s0_ - target, rate0_, curvature_of_s(k), h);
    const double by_f = quadratic_root(scaled_value(target), scaled_rate(target), curvature_of_f(k, target), h);
    return std::max(by_s, by_f);
  };
  // A first trial that keeps |w| >= rho0 / 2, (turn + A h) h <= rho0 / 2, so
  // that M is finite; if the bound certifies less than the trial, that much
  // is certified (M(h) holds on [0, h]); otherwise grow the trial
  // geometrically while it is certified whole.
  const double turn = wx0_ + wy0_, accel = ax_ + ay_;
  double h0 = h_max;
  if (accel > 0.0) h0 = std::min(h0, 2.0 * (0.5 * rho0_) / (turn + std::sqrt(turn * turn + 4.0 * accel * 0.5 * rho0_)));
  else if (turn > 0.0) h0 = std::min(h0, 0.5 * rho0_ / turn);
  const double r0 = reach(h0);
  if (r0 < h0) return r0;
  double best = h0;
  for (int k = 0; k < 40 && best < h_max; ++k) {
    const double trial = std::min(h_max, 2.0 * best);
    const double r = reach(trial);
    if (r < trial) {
      if (r > best) best = r;
      break;
    }
    best = trial;
  }
  return best;
}

}  // namespace ringsim
