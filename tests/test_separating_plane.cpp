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

}  // namespace
}  // namespace ringsim
