#pragma once
// Narrow-phase geometry of the two shapes: solid spheres and solid right
// circular cylinders (the linkers). All distances are between the solids
// (0 or negative when they overlap); closest points are in world coordinates.
//
// Error budget (see docs/GEOMETRY.md): sphere-sphere and sphere-cylinder are
// analytic (rounding only, ~1e-15 relative); cylinder-cylinder is
// semi-analytic with an a-posteriori (duality-gap) error bound, ~1e-12 on
// separated pairs, checked against tests/data/cylinder_distance.json.

#include "core/vec.hpp"

namespace ringsim::geom {

struct Cylinder {
  Vec3 center;
  Vec3 axis;           // unit
  double radius;
  double half_length;  // half of end-face-to-end-face length
};

struct Separation {
  double distance;  // > 0 separated; <= 0 touching/overlapping (value then not a depth)
  Vec3 point_a;     // closest point on shape A
  Vec3 point_b;     // closest point on shape B
  Vec3 normal;      // unit, from A towards B (direction of point_b - point_a when separated)
};

// Distance from a point to the solid cylinder; closest point on the cylinder.
// Inside the solid: distance 0 and the point itself.
double point_cylinder_distance(const Vec3& p, const Cylinder& c, Vec3* closest);

// Sphere (A) versus cylinder (B), analytic.
Separation sphere_cylinder(const Vec3& center, double radius, const Cylinder& cyl);

// Cylinder versus cylinder. `tolerance` is the absolute distance accuracy.
// Uses cylinder_cylinder_features (certified to ~1e-12, ~0.5 us); if its
// duality gap exceeds max(tolerance, 1e-9) -- in practice only overlapping
// pairs it cannot certify -- the answer comes from cylinder_cylinder_fcl.
// *certified (optional): false when neither the feature solver (both argument
// orders) could prove its result and FCL's answer was returned instead.
Separation cylinder_cylinder(const Cylinder& a, const Cylinder& b, double tolerance = 1e-10, bool* certified = nullptr);

// The two cylinder-cylinder solvers behind cylinder_cylinder(), exposed so
// tests and benchmarks can compare them.
//
// Feature-based solver (see geometry.cpp): lateral-lateral contact is the
// segment-segment problem; every other closest pair involves a rim circle and
// is found by a global 1-D minimisation over the rim angle. Accuracy ~1e-12,
// independent of `tolerance`. If `gap` is non-null it receives an a-posteriori
// error bound: (returned distance) - (separating-plane lower bound along the
// returned normal, snapped onto the supports' kinks only when the plain normal
// leaves more than 1e-12); 0 when the result certifies an overlap.
Separation cylinder_cylinder_features(const Cylinder& a, const Cylinder& b, double* gap = nullptr);

// FCL 0.7 GJK (GST_INDEP) with distance_tolerance = tolerance; overlapping
// pairs get FCL's signed (EPA) distance. Points are returned in world frame.
Separation cylinder_cylinder_fcl(const Cylinder& a, const Cylinder& b, double tolerance = 1e-10);

// Number of cylinder_cylinder() calls on this thread whose feature-solver
// result failed its duality-gap check and were answered by FCL instead.
long cylinder_cylinder_fallbacks();

// Closest points of two segments, each given as centre c, unit direction u
// and half length h (the points c + s u, |s| <= h); parameters s_a, s_b.
// Exact up to rounding for any pose, parallel and degenerate ones included.
struct SegmentPair {
  double distance;
  double s_a, s_b;  // parameters of the closest points along each segment
  Vec3 point_a, point_b;
};
SegmentPair segment_segment(const Vec3& ca, const Vec3& ua, double ha, const Vec3& cb, const Vec3& ub, double hb);

// Distance between the capsules around two cylinders (the axis segment swept
// by a ball of the cylinder's radius). A cylinder lies inside its capsule, so
// this is a lower bound of cylinder_cylinder's distance, equal to it when the
// closest points of the solids are on both lateral surfaces. About 20 ns.
// normal: unit, from A towards B, the direction between the axis segments'
// closest points (any unit vector if the axes meet); along it the separating
// plane of the capsules, hence of the cylinders, is >= the returned distance.
// point_a, point_b lie on the capsules' surfaces, not on the cylinders.
Separation capsule_capsule(const Cylinder& a, const Cylinder& b);

// Support value: max over points x of the solid of n.(x - center), |n| = 1:
// h |u.n| + r sqrt(1 - (u.n)^2), with sqrt(1 - (u.n)^2) = |u x n| for unit
// n: the cross product keeps full precision when n is nearly +-u, where
// 1 - (u.n)^2 cancels catastrophically (error ~1e-8 instead of ~1e-16).
// Inline (the plane bounds of every search call it): the same bits as
// h |u.dot(n)| + r |u.cross(n)| (vec.hpp, dot3 and cross_norm).
inline double cylinder_support(const Cylinder& c, const Vec3& n) {
  return c.half_length * std::abs(dot3(c.axis, n)) + c.radius * cross_norm(c.axis, n);
}

// Independent overlap oracle (FCL collide) used by the validation mode:
// true when the solids, each shrunk by `slack` on every surface, intersect.
bool fcl_cylinders_overlap(const Cylinder& a, const Cylinder& b, double slack);
bool fcl_sphere_cylinder_overlap(const Vec3& center, double radius, const Cylinder& c, double slack);

}  // namespace ringsim::geom
