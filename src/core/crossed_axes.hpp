#pragma once
// A separating plane for two linkers touching side to side
// (docs/PREDICTION.md).
//
// Two cylinders whose axes cross (w = u_X x u_Y != 0) are separated along
// m = sigma w / |w| (sigma = +-1, fixed so that m points from X towards Y at
// the start): m is perpendicular to both axes, so each support along m is
// just the radius and
//     s(t) = m(t).(x_Y(t) - x_X(t)) - r_X - r_Y  <=  d(t)
// at every t (any unit direction separates), with equality while the closest
// points lie on both lateral surfaces. A plane turning with one of the bodies
// (CorotatingPlane) has a kink exactly there (the other body's support along
// it is a|c| + r sqrt(1 - c^2), c = 0 at the contact), so its steps stall at
// side-to-side contacts; s has no kink: it is smooth while |w| > 0.
//
// Certified step of length h (Taylor with the Lagrange remainder):
//     s(h) >= s(0) + s'(0) h - M h^2 / 2,
//     |s''| <= |m''| |D| + 2 |m'| |D'| + |D''|,        D = x_Y - x_X,
// over the step, from the bodies' bounds (centre acceleration c_k >= |x_k''|,
// axis acceleration A_k >= |u_k''|):
//     |D''| <= C = c_X + c_Y, |D'| <= |D'(0)| + C h, |D| <= |D(0)| + |D'(0)| h + C h^2 / 2,
//     |u_k'| <= W_k = |u_k'(0)| + A_k h,
//     |w'| <= W_X + W_Y,  |w''| <= A_X + A_Y + 2 W_X W_Y,  |w| >= rho = |w(0)| - (W_X + W_Y) h,
//     |m'| <= |w'| / rho,  |m''| <= 2 |w''| / rho + 5 |w'|^2 / rho^2
// (m = w / |w| differentiated twice, every term bounded by the triangle
// inequality, with |d|w|/dt| <= |w'| and |d^2|w|/dt^2| <= |w''| + |w'|^2 / |w|).
//
// The 1 / |w|^2 terms make M large while the axes turn (the steps then shrink
// by a constant factor only, not quadratically). A second certificate avoids
// them: with P = sigma w.D and Q = |w| (so s = P / Q - r_X - r_Y),
//     s >= target  <=>  F = P - (r_X + r_Y + target) Q >= 0     (Q > 0),
//     |F''| <= |w''| |D| + 2 |w'| |D'| + |w| |D''| + (r_X + r_Y + target) (|w''| + |w'|^2 / |w|),
// with |w| <= 1 and the same bounds over the step. step() takes the longer of
// the two certified steps.

#include "core/vec.hpp"

namespace ringsim {

// One linker's motion at the start of a step: centre, its velocity, axis and
// the axis' rate (u' = omega x u), and bounds valid over the whole step.
struct AxisMotion {
  Vec3 x, v, u, du;
  double center_accel = 0.0;  // >= |x''|
  double axis_accel = 0.0;    // >= |u''|
  double radius = 0.0;
};

class CrossedAxesPlane {
 public:
  // dx = x_Y - x_X in the image of the contact (the bodies' x are ignored).
  CrossedAxesPlane(const AxisMotion& x, const AxisMotion& y, const Vec3& dx);
  // In two parts, for a caller that may not need the motion: the plane's
  // geometry from the axes and radii alone (usable(), value(), sine()), then
  // set_motion() with the same axes, radii and dx (the rest; step() needs it).
  // The same bits as the one-part constructor, which is made of these two.
  CrossedAxesPlane(const Vec3& ux, double rx, const Vec3& uy, double ry, const Vec3& dx);
  void set_motion(const AxisMotion& x, const AxisMotion& y, const Vec3& dx);
  // Axes far enough from parallel for m to be well conditioned.
  bool usable() const { return rho0_ >= kMinSine; }
  double value() const { return s0_; }
  double sine() const { return rho0_; }  // |w| = |u_X x u_Y|
  double rate() const { return rate0_; }
  // A step h in (0, h_max] over which s stays above `target` (certified by
  // the bound above), as long as the search finds; 0 when s(0) <= target.
  double step(double target, double h_max) const;
  // The bound's curvature over a step of length h (infinity if |w| may vanish).
  double curvature_bound(double h) const;
  // The bound on |F''| over a step of length h for the level `level` (header).
  double scaled_curvature_bound(double h, double level) const;
  // F's value and rate at the start for `level`: rho0 (s0 - level) and
  // rho0 s'(0) + |w|'(0) (s0 - level).
  double scaled_value(double level) const { return rho0_ * (s0_ - level); }
  double scaled_rate(double level) const { return rho0_ * rate0_ + q_rate0_ * (s0_ - level); }

  static constexpr double kMinSine = 0.05;  // |u_X x u_Y|: about 3 degrees

 private:
  // Bounds over a step of length h shared by both certificates: |w'| <= dw,
  // |w''| <= ddw, |w| >= rho (usable: rho >= rho0 / 4), |D| <= D, |D'| <= dD.
  struct StepBounds {
    double dw, ddw, rho, D, dD;
    bool usable;
  };
  StepBounds step_bounds(double h) const;
  double curvature_of_s(const StepBounds& k) const;
  double curvature_of_f(const StepBounds& k, double level) const;

  Vec3 m_ = Vec3::Zero(), w_ = Vec3::Zero();
  double s0_ = 0.0, rate0_ = 0.0, rho0_ = 0.0, q_rate0_ = 0.0, r_sum_ = 0.0;
  double d_norm_ = 0.0, dv_norm_ = 0.0, c_ = 0.0;
  double wx0_ = 0.0, wy0_ = 0.0, ax_ = 0.0, ay_ = 0.0;
};

}  // namespace ringsim
