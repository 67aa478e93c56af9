#pragma once
// A unit vector turning uniformly about a fixed axis, for one (u, w) and many
// times: Rodrigues' formula (core/motion.hpp, rotate_about) split once into
// the part of u along k = w/|w|, a = k (k.u), which does not turn, and the
// two perpendicular components b = u - a and c = k x u, so that
//   u(dt) = a + b cos(|w| dt) + c sin(|w| dt)
// costs one sine and cosine and three multiply-adds per component. The same
// vector as rotate_about(u, w, dt) up to rounding. A free linker's axis
// (precession Omega) and the normal of a co-rotating plane turn this way.

#include "core/fast_trig.hpp"
#include "core/vec.hpp"

namespace ringsim {

struct AxisRotation {
  Vec3 u = Vec3::UnitZ();  // at dt = 0 (returned exactly when no angle)
  Vec3 a = Vec3::Zero(), b = Vec3::Zero(), c = Vec3::Zero();
  double rate = 0.0;

  static AxisRotation of(const Vec3& u, const Vec3& w) {
    AxisRotation r;
    r.u = u;
    r.rate = w.norm();
    if (r.rate == 0.0) return r;
    const Vec3 k = w / r.rate;
    r.a = k * k.dot(u);
    r.b = u - r.a;
    r.c = k.cross(u);
    return r;
  }

  // (Always inlined: an out-of-line call returns the vector through memory,
  // and the co-rotating plane's two turns per evaluation are independent
  // chains that the processor overlaps only when both are in view.)
  [[gnu::always_inline]] Vec3 at(double dt) const {
    const double angle = rate * dt;
    if (angle == 0.0) return u;
    double s, co;
    sin_cos(angle, &s, &co);
    return a + b * co + c * s;
  }
};

}  // namespace ringsim
