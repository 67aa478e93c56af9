// The separating-plane bounds used by prediction must be rigorous: the plane
// value never exceeds the true distance, and its interval lower bound never
// exceeds the plane's values inside the interval (checked by dense sampling).

#include <gtest/gtest.h>

#include "core/geometry.hpp"
#include "core/motion.hpp"
#include "core/rng.hpp"
#include "core/scene.hpp"
#include "core/separating_plane.hpp"
#include "core/corotating_plane.hpp"
#include "core/crossed_axes.hpp"

namespace ringsim {
namespace {

Kinematics random_linker(Rng& rng, const Species& s, const Vec3& x) {
  const Vec3 v(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
  Kinematics k = make_kinematics(x, v, rng.unit_vector());
  set_angular_velocity(k, s, 2.0 * Vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)));
  return k;
}

TEST(SeparatingPlane, SupportTrackMatchesCylinderSupport) {
  SimParams p;
  const Species L = make_species(Shape::Linker, p);
  Rng rng(5, 0, Stream::Placement);
  for (int trial = 0; trial < 200; ++trial) {
    const Kinematics k = random_linker(rng, L, Vec3::Zero());
    const Vec3 n = rng.unit_vector();
    const double t0 = rng.uniform(0, 2);
    const SupportTrack tr = SupportTrack::of(k, L, n, t0);
    for (double t = t0; t < t0 + 5; t += 0.37) {
      EXPECT_NEAR(tr.at(t), geom::cylinder_support(cylinder_at(k, L, t), n), 1e-12);
    }
  }
}

TEST(SeparatingPlane, IntervalMaximumIsAnUpperBound) {
  SimParams p;
  const Species L = make_species(Shape::Linker, p);
  Rng rng(6, 0, Stream::Placement);
  for (int trial = 0; trial < 500; ++trial) {
    const Kinematics k = random_linker(rng, L, Vec3::Zero());
    const Vec3 n = rng.unit_vector();
    const SupportTrack tr = SupportTrack::of(k, L, n, 0.0);
    const double t1 = rng.uniform(0, 3), t2 = t1 + rng.uniform(0, 1) * rng.uniform(0, 1) * 4.0;
    const double bound = tr.max_over(t1, t2);
    double sampled = -1e300;
    for (int m = 0; m <= 2000; ++m) sampled = std::max(sampled, tr.at(t1 + (t2 - t1) * m / 2000.0));
    EXPECT_GE(bound, sampled - 1e-14) << "trial " << trial;
    // and it is tight: the exact maximum, not a loose envelope
    EXPECT_LE(bound, sampled + 1e-3 * (t2 - t1) + 1e-12) << "trial " << trial;
  }
}

TEST(SeparatingPlane, AdvanceReturnsWhenNoStepCanMoveTheTime) {
  // A turning linker against a wall, its gap at round-off level (2e-15) at
  // t = 475, where one ulp of t is 6e-14: the safe step (gap / bound) cannot
  // move t. advance_plane must hand back at once (the caller floors the
  // step), not spin through its budget (it did: a replicate hung for ever).
  SimParams p;
  const Species L = make_species(Shape::Linker, p);
  Rng rng(3, 0, Stream::Placement);
  const Kinematics k = random_linker(rng, L, Vec3::Zero());
  const Vec3 n = Vec3::UnitX();
  SeparatingPlane pl;
  pl.t0 = 475.0;
  pl.a = SupportTrack::of(k, L, n, 0.0);
  pl.b = SupportTrack::constant(0.0);
  pl.slope = 0.0;
  pl.offset = pl.a.at(475.0) + 2.2e-15;
  const double s = pl.at(475.0);
  ASSERT_GT(s, 0.0);
  ASSERT_LT(s, 1e-14);
  long evaluations = 0;
  const double t = advance_plane(pl, 475.0, 476.0, 0.5 * s, 0.75 * s, 10.0, &evaluations, 1 << 22);
  EXPECT_EQ(t, 475.0);
  EXPECT_LT(evaluations, 100);
}

TEST(SeparatingPlane, AdvanceReturnsWhenOnlyStepsBelowTheResolutionAreCertified) {
  // The same with a first trial that does move t: a gap of 5.6e-16 closing at
  // 0.43 at t = 10.68 (one ulp 1.8e-15). The trial of 0.9 gap / rate = 1.1e-15
  // rounds up to one ulp, where the gap would be negative: rejected, halved
  // to 5.5e-16, which rounds to no move at all and so is "certified" (an
  // interval of zero width). t never moved and the search spun through its
  // budget, 2^30 for a wall: a linker lying flat on a wall after a contact at
  // restitution 0 hung a replicate (found by the energy-ledger sweep).
  SeparatingPlane pl;
  pl.t0 = 10.679877415302142;
  pl.offset = 5.551e-16;
  pl.slope = -0.4299;
  pl.a = SupportTrack::constant(0.0);
  pl.b = SupportTrack::constant(0.0);
  const double s = pl.at(pl.t0);
  long evaluations = 0;
  const double t = advance_plane(pl, pl.t0, 11.8389, 0.05 * s, 0.075 * s, 2.27314, &evaluations, 1 << 22);
  EXPECT_EQ(t, pl.t0);
  EXPECT_LT(evaluations, 100);
}

TEST(SeparatingPlane, PlaneNeverExceedsTrueDistance) {
  SimParams p;
  const Species L = make_species(Shape::Linker, p);
  Rng rng(7, 0, Stream::Placement);
  int checked = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Kinematics a = random_linker(rng, L, Vec3::Zero());
    const Kinematics b = random_linker(rng, L, 5.0 * rng.unit_vector());
    const geom::Separation sep0 = geom::cylinder_cylinder(cylinder_at(a, L, 0.0), cylinder_at(b, L, 0.0));
    if (sep0.distance <= 0.0) continue;
    const Vec3 n = sep0.normal;
    SeparatingPlane pl;
    pl.t0 = 0.0;
    pl.offset = n.dot(b.x - a.x);
    pl.slope = n.dot(b.v - a.v);
    pl.a = SupportTrack::of(a, L, n, 0.0);
    pl.b = SupportTrack::of(b, L, -n, 0.0);
    EXPECT_NEAR(pl.at(0.0), sep0.distance, 1e-9);
    for (double t = 0.0; t < 2.0; t += 0.05) {
      const geom::Separation s = geom::cylinder_cylinder(cylinder_at(a, L, t), cylinder_at(b, L, t));
      if (s.distance > 0.0) {
        EXPECT_LE(pl.at(t), s.distance + 1e-9);
        ++checked;
      }
      const double lb = pl.lower_bound(t, t + 0.05, pl.at(t));
      for (int m = 0; m <= 50; ++m) EXPECT_LE(lb, pl.at(t + 0.001 * m) + 1e-13);
    }
  }
  EXPECT_GT(checked, 1000);
}

TEST(SeparatingPlane, RateBoundIsAnUpperBoundOfTheDerivative) {
  SimParams p;
  const Species L = make_species(Shape::Linker, p);
  Rng rng(8, 0, Stream::Placement);
  int bounded = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const Kinematics k = random_linker(rng, L, Vec3::Zero());
    const Vec3 n = rng.unit_vector();
    const SupportTrack tr = SupportTrack::of(k, L, n, 0.0);
    const double t1 = rng.uniform(0, 3), t2 = t1 + 0.2 * rng.uniform(0, 1);
    const double bound = tr.max_rate_over(t1, t2);
    if (!std::isfinite(bound)) continue;
    ++bounded;
    // Finite-difference slopes on a fine grid never exceed the bound.
    const double h = (t2 - t1) / 400.0;
    for (int m = 0; m < 400; ++m) {
      const double a = t1 + m * h;
      EXPECT_LE((tr.at(a + h) - tr.at(a)) / h, bound + 1e-7) << "trial " << trial;
    }
  }
  EXPECT_GT(bounded, 400);
}

TEST(CorotatingPlane, IsALowerBoundAndAdvanceNeverSkipsTheTarget) {
  SimParams p;
  const Species L = make_species(Shape::Linker, p);
  const Species S = make_species(Shape::Sphere, p);
  Rng rng(9, 0, Stream::Placement);
  int advanced = 0, checked = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const Kinematics x = random_linker(rng, L, Vec3::Zero());
    const bool y_sphere = trial % 3 == 0;
    Kinematics y = random_linker(rng, L, 4.5 * rng.unit_vector());
    const Species& sy = y_sphere ? S : L;
    // The direction from X towards Y given by X's feature normal at its
    // closest point: the radial or axial normal, as the predictor uses it.
    geom::Separation sep = y_sphere ? geom::sphere_cylinder(y.x, S.radius, cylinder_at(x, L, 0.0))
                                    : geom::cylinder_cylinder(cylinder_at(x, L, 0.0), cylinder_at(y, L, 0.0));
    if (sep.distance <= 0.05) continue;
    Vec3 n0 = y_sphere ? Vec3(-sep.normal) : sep.normal;
    const CorotatingPlane cp(x, L, y, sy, n0, y.x - x.x, 0.0);
    const double target = 0.5 * 1e-3, stop = 0.75 * 1e-3;
    long evals = 0;
    const double reached = cp.advance(0.0, 3.0, target, stop, &evals, 1000);
    if (reached > 0.0) ++advanced;
    for (int m = 0; m <= 400; ++m) {
      const double t = reached * m / 400.0;
      // certified: the plane stays above the target up to the time reached
      EXPECT_GT(cp.at(t), target - 1e-12) << "trial " << trial << " t " << t;
      // and the plane is a lower bound of the true distance
      const double d = y_sphere ? geom::sphere_cylinder(position_at(y, t), S.radius, cylinder_at(x, L, t)).distance
                                : geom::cylinder_cylinder(cylinder_at(x, L, t), cylinder_at(y, L, t)).distance;
      if (d > 0.0) {
        EXPECT_LE(cp.at(t), d + 1e-9) << "trial " << trial << " t " << t;
        ++checked;
      }
    }
  }
  EXPECT_GT(advanced, 100);
  EXPECT_GT(checked, 10000);
}


// A linker's AxisMotion at t: free (precession Omega, constant velocity) or a
// rigid-cluster member (turning at constant omega about a centre of mass at
// -r0 from its centre, moving at V): the bounds of core/crossed_axes.hpp.
struct MovingLinker {
  Vec3 com, V, r0, u0, omega;  // member: centre(t) = com + V t + R(t) r0
  double slack = 1.0;          // >= 1: looser (still valid) acceleration bounds, as a cluster's max_rate gives
  Vec3 center(double t) const { return com + V * t + rotate_about(r0, omega, t); }
  Vec3 axis(double t) const { return rotate_about(u0, omega, t); }
  AxisMotion motion(double t, double radius) const {
    AxisMotion a;
    a.x = center(t);
    a.u = axis(t);
    a.v = V + omega.cross(rotate_about(r0, omega, t));
    a.du = omega.cross(a.u);
    a.center_accel = slack * omega.squaredNorm() * r0.norm();
    a.axis_accel = slack * omega.squaredNorm();
    a.radius = radius;
    return a;
  }
  geom::Cylinder cylinder(double t, const Species& s) const { return {center(t), axis(t), s.radius, s.half_length}; }
};

MovingLinker random_moving_linker(Rng& rng, double arm) {
  MovingLinker m;
  m.V = Vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
  m.omega = Vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
  m.r0 = arm * rng.unit_vector();
  m.u0 = rng.unit_vector();
  return m;
}

TEST(CrossedAxesPlane, StepStaysAboveTheTargetAndBelowTheTrueDistance) {
  SimParams p;
  const Species L = make_species(Shape::Linker, p);
  Rng rng(13, 0, Stream::Placement);
  int stepped = 0, checked = 0, tight = 0;
  for (int trial = 0; trial < 600; ++trial) {
    // X free (arm 0) or a member; Y a member of a cluster of reach up to 3,
    // placed side to side with X at a gap between 1e-9 and 1e-2.
    MovingLinker x = random_moving_linker(rng, trial % 2 == 0 ? 0.0 : rng.uniform(0.0, 3.0));
    MovingLinker y = random_moving_linker(rng, rng.uniform(0.0, 3.0));
    x.com = -x.r0;
    const Vec3 w = x.u0.cross(y.u0);
    if (w.norm() < 0.2) continue;
    const double gap = std::pow(10.0, rng.uniform(-9.0, -2.0));
    const Vec3 yc = (2.0 * L.radius + gap) * w.normalized() + rng.uniform(-0.5, 0.5) * L.half_length * x.u0 +
                    rng.uniform(-0.5, 0.5) * L.half_length * y.u0;
    y.com = yc - y.r0;
    const AxisMotion ax = x.motion(0.0, L.radius), ay = y.motion(0.0, L.radius);
    const CrossedAxesPlane xp(ax, ay, ay.x - ax.x);
    ASSERT_TRUE(xp.usable());
    const double d0 = geom::cylinder_cylinder(x.cylinder(0.0, L), y.cylinder(0.0, L)).distance;
    // Side to side the plane is the distance itself.
    EXPECT_NEAR(xp.value(), d0, 1e-12 + 1e-9 * d0) << "trial " << trial;
    if (std::abs(xp.value() - d0) < 1e-12 + 1e-9 * d0) ++tight;
    // The rate is the derivative of the plane along the true motion.
    const double e = 1e-6;
    auto plane_at = [&](double t) {
      const AxisMotion a = x.motion(t, L.radius), b = y.motion(t, L.radius);
      const CrossedAxesPlane q(a, b, b.x - a.x);
      return q.value();
    };
    EXPECT_NEAR(xp.rate(), (plane_at(e) - plane_at(-e)) / (2.0 * e), 1e-6) << "trial " << trial;
    const double target = 0.5 * std::min(gap, 1e-9);
    const double h = xp.step(target, 2.0);
    if (h <= 0.0) continue;
    ++stepped;
    const double M = xp.curvature_bound(h), MF = xp.scaled_curvature_bound(h, target);
    auto sine_at = [&](double t) {
      const AxisMotion a = x.motion(t, L.radius), b = y.motion(t, L.radius);
      return CrossedAxesPlane(a, b, b.x - a.x).sine();
    };
    // F's rate is its derivative along the true motion, F = |w| (s - target)
    auto scaled_at = [&](double t) { return sine_at(t) * (plane_at(t) - target); };
    EXPECT_NEAR(xp.scaled_rate(target), (scaled_at(e) - scaled_at(-e)) / (2.0 * e), 1e-6) << "trial " << trial;
    for (int m = 0; m <= 200; ++m) {
      const double t = h * m / 200.0;
      const double d = geom::cylinder_cylinder(x.cylinder(t, L), y.cylinder(t, L)).distance;
      EXPECT_GT(d, target - 1e-12) << "trial " << trial << " t " << t;
      // both quadratic bounds lie below their functions along the true motion
      EXPECT_LE(xp.value() + xp.rate() * t - 0.5 * M * t * t, plane_at(t) + 1e-12) << "trial " << trial << " t " << t;
      EXPECT_LE(xp.scaled_value(target) + xp.scaled_rate(target) * t - 0.5 * MF * t * t, scaled_at(t) + 1e-12)
          << "trial " << trial << " t " << t;
      ++checked;
    }
  }
  EXPECT_GT(tight, 200);
  EXPECT_GT(stepped, 200);
  EXPECT_GT(checked, 40000);
}

// Whenever the plane is above the target, a step is taken, however slowly or
// fast the bodies turn (Scenario 5, seed 1, t = 3213: axes turning at 0.03
// with a cluster acceleration bound of 0.4 once gave no step at all and left
// the search to 10^5 tiny fallback steps per collision).
TEST(CrossedAxesPlane, StepsWheneverThePlaneIsAboveTheTarget) {
  SimParams p;
  const Species L = make_species(Shape::Linker, p);
  Rng rng(17, 0, Stream::Placement);
  int trials = 0;
  for (int trial = 0; trial < 400; ++trial) {
    MovingLinker x = random_moving_linker(rng, rng.uniform(0.0, 3.0));
    MovingLinker y = random_moving_linker(rng, rng.uniform(0.0, 5.0));
    const double scale = std::pow(10.0, rng.uniform(-4.0, 0.5));  // turning rates 1e-4 .. 3
    x.omega *= scale;
    y.omega *= scale;
    x.slack = rng.uniform(1.0, 100.0);
    y.slack = rng.uniform(1.0, 100.0);
    x.com = -x.r0;
    const Vec3 w = x.u0.cross(y.u0);
    if (w.norm() < 0.2) continue;
    y.com = (2.0 * L.radius + 2e-9) * w.normalized() - y.r0;
    const AxisMotion ax = x.motion(0.0, L.radius), ay = y.motion(0.0, L.radius);
    const CrossedAxesPlane xp(ax, ay, ay.x - ax.x);
    ASSERT_GT(xp.value(), 0.5e-9);
    const double h = xp.step(0.5e-9, 1e3);
    EXPECT_GT(h, 0.0) << "trial " << trial << " scale " << scale;
    EXPECT_TRUE(std::isfinite(xp.curvature_bound(h))) << "trial " << trial;
    ++trials;
  }
  EXPECT_GT(trials, 200);
}

// The case that made the plane necessary (Scenario 5, seed 5, t = 44): a
// free linker riding on the side of a turning cluster's linker. After each
// elastic bounce the gap opens at 1e-4 and the turning closes it again within
// ~2e-4. A plane turning with either body has a kink exactly at this contact
// and stalled at ~1e-9 per step (10^5 distance evaluations per collision);
// the crossed-axes plane reaches the next contact in a few dozen steps,
// never below the target on the way.
TEST(CrossedAxesPlane, FollowsAGrazingSideContactToItsNextTouchInFewSteps) {
  SimParams p;
  const Species L = make_species(Shape::Linker, p);
  const double delta = 1e-9;
  MovingLinker x;  // free, at rest, along x
  x.com = Vec3::Zero();
  x.V = x.r0 = x.omega = Vec3::Zero();
  x.u0 = Vec3::UnitX();
  MovingLinker y;  // a member along y on top of it, its cluster turning about x
  y.u0 = Vec3::UnitY();
  y.omega = Vec3(1.0, 0.0, 0.0);
  y.r0 = Vec3(0.0, 0.0, 2.0);  // centre of mass 2 below
  y.com = Vec3(0.0, 0.0, 2.0 * L.radius + delta) - y.r0;
  // the cluster's centre of mass moving so that the gap opens at 1e-4
  y.V = Vec3(0.0, 0.0, 1e-4) - y.omega.cross(y.r0);
  auto dist = [&](double t) { return geom::cylinder_cylinder(x.cylinder(t, L), y.cylinder(t, L)).distance; };
  // the true times after the peak where d falls back to delta and to delta / 2
  auto falls_to = [&](double level) {
    double lo = 1e-5, hi = 1e-2;
    EXPECT_GT(dist(lo), delta);
    EXPECT_LT(dist(hi), 0.0);
    for (int k = 0; k < 200; ++k) {
      const double mid = 0.5 * (lo + hi);
      (dist(mid) > level ? lo : hi) = mid;
    }
    return lo;
  };
  const double touch = falls_to(delta), half = falls_to(0.5 * delta);
  double s = 0.0;
  int steps = 0;
  while (steps < 1000) {
    const double d = dist(s);
    ASSERT_GT(d, 0.5 * delta - 1e-15) << "step " << steps;
    if (d <= delta && s > 0.5 * touch) break;
    const AxisMotion a = x.motion(s, L.radius), b = y.motion(s, L.radius);
    const CrossedAxesPlane xp(a, b, b.x - a.x);
    const double h = xp.step(0.5 * std::min(d, delta), 1.0);
    ASSERT_GT(h, 0.0) << "step " << steps << " d " << d;
    s += h;
    ++steps;
  }
  // stopped inside the contact band (delta / 2, delta], where the search fires
  EXPECT_LT(steps, 60);
  EXPECT_GE(s, touch * (1.0 - 1e-9));
  EXPECT_LE(s, half);
  RecordProperty("steps", steps);
  std::printf("grazing side contact: next touch at %.6e after %d steps (reached %.6e)\n", touch, steps, s);
}

}  // namespace
}  // namespace ringsim
