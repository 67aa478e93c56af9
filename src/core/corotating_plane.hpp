#pragma once
// A separating plane that turns with one of the two bodies (docs/PREDICTION.md).
//
// When the contact lies on a flat face or the lateral surface of body X, a
// fixed separating direction is a poor bound once X tilts: its support along
// the fixed direction jumps to the far rim (measured: the fixed plane falls at
// 3.5 while the true gap closes at 0.5). Turning the direction with X,
//     n(t) = R_X(t - t0) n0     (R_X: rotation about X's precession vector),
// keeps X's support along n constant, and
//     s(t) = n(t).(x_Y(t) - x_X(t)) - h_Y(n(t), t) - h_X  <=  d(t)
// is still a lower bound of the distance at every t (any unit direction
// separates). Between kinks of h_Y (where n is normal to Y's axis, c = 0, or
// along it, |n x u_Y| = 0) s is twice differentiable with
//     |s''| <= M = |W_X|^2 |dx| + 2 |W_X| |dv|
//                  + (a_Y + r_Y (1/g^3 + 1/g)) (|W_X| + |W_Y|)^2,
// (g the smallest |n x u_Y| on the interval), so
//     s(t + h) >= s(t) + s'(t) h - M h^2 / 2,
// a certified step that converges like Newton's method near a transversal
// contact. Where a kink may lie inside a step the step is not taken (the
// caller falls back to the fixed plane).
//
// Bodies that are not free (compliant members) are handed in as their
// first-order motion at t0 (centre velocity, the axis' turning rate as the
// precession), exact in value and first derivative; their true motion departs
// from it within second-order bounds (Remainder), which add to M:
//     c_x + c_y + 2 a_x (|dx| + r_x' + r_y') + 2 a_y r_y'
// (centre accelerations c; a >= |Omega'| + |Omega|^2 of each body's turning;
// r' the bodies' bounding radii): a direction turned by the true rotation
// and by the frozen one differ by at most 2 a h^2 / 2 (both second
// derivatives are bounded by a), which moves the plane's normal and each
// support; |c'| grows to at most |W| + (a_x + a_y) h over a step.

#include "core/axis_rotation.hpp"
#include "core/body.hpp"
#include "core/vec.hpp"

namespace ringsim {

// Second-order departure of the bodies' true motion from the first-order one
// handed in (zero for free bodies).
struct CorotatingRemainder {
  double c_x = 0.0, c_y = 0.0;  // centre acceleration bounds
  double a_x = 0.0, a_y = 0.0;  // turning-acceleration bounds
};

class CorotatingPlane {
 public:
  // X carries the contact face/side, Y is the other body; n0 is the unit
  // direction from X towards Y at t0; dx = x_Y - x_X at t0 (minimum image).
  using Remainder = CorotatingRemainder;
  CorotatingPlane(const Kinematics& x, const Species& sx, const Kinematics& y, const Species& sy, const Vec3& n0,
                  const Vec3& dx, double t0, const Remainder& rem = {});
  // The same with the bodies' axes at t0 already known (ux0 = axis_at(x, t0),
  // uy0 = axis_at(y, t0), as the searches have them from the pair's
  // geometry; a sphere's is not read): two Rodrigues rotations fewer.
  CorotatingPlane(const Kinematics& x, const Species& sx, const Kinematics& y, const Species& sy, const Vec3& n0,
                  const Vec3& dx, double t0, const Vec3& ux0, const Vec3& uy0, const Remainder& rem = {});

  double at(double t) const;
  // Advance from t while the quadratic bound certifies s > target; return the
  // time reached when s <= stop, when `end` is reached, when a kink blocks the
  // step, or after `budget` steps.
  double advance(double t, double end, double target, double stop, long* evaluations, int budget) const;

 private:
  struct State {
    double s, rate;   // s(t), s'(t)
    double c, g;      // n.u_Y, |n x u_Y|
    double cdot;      // dc/dt
    double dx_norm;   // |x_Y - x_X|
  };
  State state(double t) const;

  Vec3 n0_, dx0_, dv_, wx_, wy_, uy0_;
  AxisRotation nx_rot_, uy_rot_;  // n(t) and Y's axis(t): n0_ about wx_, uy0_ about wy_
  double t0_;
  double hx_;               // X's (constant) support along n
  double ay_, ry_;          // Y's half length and radius (sphere: 0, radius)
  bool y_is_sphere_;
  double wx_norm_, wy_norm_, dv_norm_;
  Remainder rem_;
  bool has_rem_;            // some remainder bound is not zero
  double bx_, by_;          // bounding radii
};

}  // namespace ringsim
