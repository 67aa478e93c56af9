// Narrow-phase geometry: sphere-cylinder (analytic), cylinder-cylinder
// (feature-based solver with an FCL fallback), segment-segment and the capsule
// distance (a cheap lower bound of cylinder-cylinder), FCL overlap oracles.
//
// Cylinder-cylinder method. For two disjoint convex solids a closest pair
// (p, q) exists with p on the boundary of A and q on the boundary of B. The
// boundary of a cylinder consists of two open end faces, the open lateral
// surface and two rim circles. Classifying p and q:
//   * p (or q) on a rim: min over the rim angle of the point-to-solid distance
//     to the other cylinder finds it exactly (point-to-cylinder is analytic).
//   * p and q both on open lateral surfaces, axes not parallel: the normal is
//     perpendicular to both axes, so p, q are the closest points of the two
//     axis LINES (offset by the radii) with parameters inside both segments.
//   * face-face, face-lateral, or lateral-lateral with parallel axes: the set
//     of closest pairs is a flat region/segment whose boundary contains a rim
//     point, so the rim searches find an equally close pair.
// Hence distance = min(lateral-lateral candidate, 4 rim searches). Every
// candidate is a feasible pair (p in A, q in B), so the result can only err
// upwards; the separating-plane bound n.(c_b - c_a) - S_A(n) - S_B(-n) <= d
// (weak duality, S the support function) bounds the error from the other side
// and is evaluated after each search phase: once the gap is <= 1e-12 the
// result is certified and the search stops. Phases, over the rims in order of
// a cheap lower bound: (1) 3 samples facing the other solid + polish, (2) 12
// samples + polish, (3) branch and bound. Separated pairs are nearly always
// certified in phase 1 (~7 point-to-cylinder evaluations per query on the
// reference set). An uncertified result (some overlaps, see cylinder_cylinder)
// is handed to FCL.
//
// Rim search: f(t) = sd_B(C + r (cos t e1 + sin t e2)) with sd_B the signed
// distance to B. sd_B is convex and 1-Lipschitz, so f is C1 where positive
// and f'' >= -r (the circle's curvature term is the only concave part). That
// semi-convexity gives a rigorous lower bound of f on any angle interval from
// the end values and slopes, used to prune intervals (branch and bound); local
// minima are polished by Illinois regula falsi on f' (Dowell & Jarratt 1971).
#include "core/geometry.hpp"

#include <fcl/fcl.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "core/fast_trig.hpp"

namespace ringsim::geom {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kOracleGjkTolerance = 1e-13;

// A unit vector perpendicular to the unit vector u.
Vec3 any_perpendicular(const Vec3& u) {
  const Vec3 t = std::abs(u.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  return u.cross(t).normalized();
}

// Signed distance from p to the surface of the solid cylinder (negative
// inside). *q: nearest point of the solid (outside) or of its surface
// (inside). *grad: unit outward gradient of the signed distance at p.
// Computed in the (axial a, radial rho) half-plane of the cylinder, where
// the solid is the rectangle [-h, h] x [0, r].
// (Always inlined: the rim search's evaluation point then stays in
// registers instead of being stored and reloaded across the call. Its dot
// product and norm in the scalar forms of vec.hpp, the same bits.)
[[gnu::always_inline]] inline double signed_point_cylinder(const Vec3& p, const Cylinder& c, Vec3* q, Vec3* grad) {
  const Vec3 d = p - c.center;
  const double a = dot3(d, c.axis);
  const Vec3 radial = d - a * c.axis;
  const double rho = norm3(radial);
  const double sa = a >= 0.0 ? 1.0 : -1.0;
  const double da = std::abs(a) - c.half_length;  // > 0: beyond an end-face plane
  const double dr = rho - c.radius;               // > 0: outside the lateral surface
  if (da <= 0.0 && dr <= 0.0) {  // inside or on the surface: nearest surface
    if (da >= dr) {
      *q = p - da * sa * c.axis;
      *grad = sa * c.axis;
      return da;
    }
    const Vec3 e = rho > 0.0 ? Vec3(radial / rho) : any_perpendicular(c.axis);
    *q = p - dr * e;
    *grad = e;
    return dr;
  }
  if (dr <= 0.0) {  // beyond an end face, within the radius: the face
    *q = p - da * sa * c.axis;
    *grad = sa * c.axis;
    return da;
  }
  const Vec3 e = radial / rho;  // rho > r > 0 here
  if (da <= 0.0) {  // beside the lateral surface
    *q = p - dr * e;
    *grad = e;
    return dr;
  }
  const double dist = std::sqrt(da * da + dr * dr);  // rim; no over/underflow at these scales
  *grad = (da * sa * c.axis + dr * e) / dist;
  *q = p - da * sa * c.axis - dr * e;
  return dist;
}

struct Candidate {
  double d = kInf;
  Vec3 pa = Vec3::Zero(), pb = Vec3::Zero(), n = Vec3::Zero();
};

// Lateral-lateral candidate: closest points of the two axis lines (solve the
// 2x2 normal equations of min |r + s ua - t ub|^2, r = ca - cb), accepted only
// when both parameters are inside the segments; otherwise a rim is involved.
void lateral_candidate(const Cylinder& A, const Cylinder& B, Candidate& best) {
  const Vec3 r = A.center - B.center;
  const double b = A.axis.dot(B.axis), c = A.axis.dot(r), f = B.axis.dot(r);
  const double denom = A.axis.cross(B.axis).squaredNorm();  // 1 - b^2, accurately
  double s;
  if (denom > 1e-13) {
    s = (b * f - c) / denom;
  } else {
    // (Nearly) parallel: the middle of the axial overlap of the two segments.
    const double s0 = -c, hb = B.half_length * std::abs(b);
    const double lo = std::max(-A.half_length, s0 - hb), hi = std::min(A.half_length, s0 + hb);
    if (lo > hi) return;
    s = 0.5 * (lo + hi);
  }
  const Vec3 ps = A.center + s * A.axis;
  const double t = (ps - B.center).dot(B.axis);  // foot of ps on B's axis line
  if (std::abs(s) > A.half_length || std::abs(t) > B.half_length) return;
  const Vec3 qt = B.center + t * B.axis;
  const Vec3 w = qt - ps;
  const double len = w.norm();
  const double d = len - A.radius - B.radius;
  if (d >= best.d) return;
  Vec3 n = len > 0.0 ? Vec3(w / len) : Vec3(A.axis.cross(B.axis));
  if (len <= 0.0) n = n.squaredNorm() > 0.0 ? n.normalized() : any_perpendicular(A.axis);
  best = {d, ps + A.radius * n, qt - B.radius * n, n};
}

// One evaluation of the rim function f(t) and its slope, with the gradient
// of the other solid's signed distance there (the points themselves are only
// read when they improve the best candidate, so they are not kept).
struct RimSample {
  double f, fp;
  Vec3 g;
};

class RimSearch {
 public:
  // Rim circle centre C, rim plane normal u, radius r, against solid `other`;
  // `toward`: the point of `other` nearest to C (angle 0 faces it).
  // rim_on_b: the rim belongs to B (swap point roles, normal A->B = +grad).
  // (Default-constructed and then initialised: the caller keeps four of these
  // on the stack, and value-initialising their sample arrays costs as much as
  // a whole query.)
  void init(const Vec3& C, const Vec3& u, double r, const Cylinder& other, const Vec3& toward,
            bool rim_on_b, Candidate& best) {
    C_ = C, r_ = r, other_ = &other, rim_on_b_ = rim_on_b, best_ = &best;
    have_ = {}, polished_ = {};
    Vec3 t = toward - C;
    t -= t.dot(u) * u;
    e1_ = t.squaredNorm() > 1e-24 ? Vec3(t.normalized()) : any_perpendicular(u);
    e2_ = u.cross(e1_);
  }

  // Phase 1: the samples at 0 and +-30 degrees around the direction of the
  // other solid, polishing a local minimum found there. Usually this already
  // is the global minimum, which the caller certifies by the duality gap.
  void local() {
    for (int i : {0, 1, N - 1}) sample(i);
    polish_bracket(N - 1);
    polish_bracket(0);
  }

  // Phase 2: all N samples, polishing every bracket of a local minimum.
  void global() {
    for (int i = 0; i < N && best_->d > 0.0; ++i) sample(i);
    for (int i = 0; i < N && best_->d > 0.0; ++i) polish_bracket(i);
  }

  // Phase 3 (when phase 2 could not be certified): branch and bound on the
  // intervals whose semi-convexity lower bound is below the best value. This
  // finds minima hidden between samples, e.g. two minima 0.04 rad apart around
  // a flat local maximum (a lateral line grazing a rim). Bisection depth and
  // evaluations are capped; what remains shows in the duality gap.
  void branch_and_bound() {
    budget_ = 400;
    for (int i = 0; i < N && best_->d > 0.0; ++i)
      if (!is_min_bracket(s_[i], s_[i + 1])) bnb(th_[i], s_[i], th_[i + 1], s_[i + 1], 12);
  }

 private:
  static constexpr int N = 12;           // samples per rim
  // cos, sin of 2 pi i / 12.
  static constexpr double kC = 0.86602540378443864676;  // sqrt(3)/2
  static constexpr double kCos[N] = {1, kC, 0.5, 0, -0.5, -kC, -1, -kC, -0.5, 0, 0.5, kC};
  static constexpr double kSin[N] = {0, 0.5, kC, 1, kC, 0.5, 0, -0.5, -kC, -1, -kC, -0.5};
  static constexpr double kEps = 1e-13;  // improvements below this are irrelevant

  void sample(int i) {
    if (have_[i] || best_->d <= 0.0) return;
    have_[i] = true;
    s_[i] = eval(th_[i], kCos[i], kSin[i]);
    if (i == 0) s_[N] = s_[0];
  }

  // Polish interval i if it brackets a local minimum that can still improve.
  void polish_bracket(int i) {
    if (polished_[i] || best_->d <= 0.0 || !have_[i] || !have_[(i + 1) % N]) return;
    const RimSample &a = s_[i], &b = s_[i + 1];
    if (is_min_bracket(a, b) && lower_bound(th_[i], a, th_[i + 1], b) < best_->d - kEps) {
      polished_[i] = true;
      double lo = th_[i], f_lo = a.fp, hi = th_[i + 1], f_hi = b.fp;
      face_edge(a, b, &lo, &f_lo, &hi, &f_hi);
      polish(lo, f_lo, hi, f_hi);
    }
  }

  // One end of the bracket faces an end face of the other solid (gradient =
  // its axis, exactly) and the other does not: the minimum is usually where
  // the rim passes that face's edge, and f' jumps there from one region's
  // slope to the other's within an angle ~ f, which regula falsi closes in
  // on only linearly. Sample where the rim crosses the face's plane (closed
  // form: a sinusoid of the angle) and shrink the bracket to it.
  void face_edge(const RimSample& sa, const RimSample& sb, double* lo, double* f_lo, double* hi, double* f_hi) {
    // (signed_point_cylinder sets a face's gradient to +-axis exactly)
    auto on_face = [&](const Vec3& g) { return g == other_->axis || g == Vec3(-other_->axis); };
    const bool face_a = on_face(sa.g);
    if (face_a == on_face(sb.g)) return;
    const Vec3& g = face_a ? sa.g : sb.g;  // the face's outward normal
    // g.(p(t) - c) - h = k + u cos t + v sin t, zero where the rim crosses the plane.
    const double k = g.dot(C_ - other_->center) - other_->half_length;
    const double u = r_ * g.dot(e1_), v = r_ * g.dot(e2_), m = std::hypot(u, v);
    if (!(m > std::abs(k))) return;
    const double phase = std::atan2(v, u), spread = std::acos(-k / m);
    for (const double t0 : {phase - spread, phase + spread}) {
      double t = t0;  // t0 (mod 2 pi) in [lo, lo + 2 pi]
      while (t < *lo) t += 2.0 * kPi;
      while (t > *lo + 2.0 * kPi) t -= 2.0 * kPi;
      if (!(t > *lo && t < *hi)) continue;
      const RimSample s = eval(t);
      if (best_->d <= 0.0) return;
      if (s.fp > 0.0) *hi = t, *f_hi = s.fp;
      else *lo = t, *f_lo = s.fp;
      return;
    }
  }

  // f' noise level: the gradient is a unit vector known to ~1e-16.
  bool is_min_bracket(const RimSample& a, const RimSample& b) const {
    const double z = 1e-15 * r_;
    return a.fp < -z && b.fp > z;
  }

  RimSample eval(double t) {
    double st, ct;
    sin_cos(t, &st, &ct);
    return eval(t, ct, st);
  }

  RimSample eval(double t, double ct, double st) {
    RimSample s;
    const Vec3 p = C_ + r_ * (ct * e1_ + st * e2_);
    Vec3 q;
    s.f = signed_point_cylinder(p, *other_, &q, &s.g);
    s.fp = r_ * s.g.dot(ct * e2_ - st * e1_);
    if (s.f < best_->d) {
      if (rim_on_b_) *best_ = {s.f, q, p, s.g};
      else *best_ = {s.f, p, q, -s.g};
    }
    return s;
  }

  // Lower bound of f on [a, b]: g(t) = f(t) + r/2 (t - a)(t - b) is convex
  // (f'' >= -r) and <= f on the interval, so g's two end tangents bound f.
  double lower_bound(double a, const RimSample& sa, double b, const RimSample& sb) const {
    const double h = 0.5 * r_ * (b - a);
    const double ga = sa.fp - h, gb = sb.fp + h;  // g'(a), g'(b)
    if (ga >= 0.0) return sa.f;
    if (gb <= 0.0) return sb.f;
    // Intersection of the tangents f(a) + ga (t - a) and f(b) + gb (t - b).
    const double tx = (sb.f - sa.f + ga * a - gb * b) / (ga - gb);
    return sa.f + ga * (tx - a);
  }

  // Root of f' in (a, b) with f'(a) < 0 < f'(b): Illinois regula falsi.
  void polish(double a, double fa, double b, double fb) {
    int side = 0;
    for (int it = 0; it < 60; ++it) {
      double c = (a * fb - b * fa) / (fb - fa);
      if (!(c > a && c < b)) c = 0.5 * (a + b);
      const RimSample s = eval(c);
      // Converge f' to its noise level: at a kink of the support function
      // (face contacts) the normal, hence the duality gap, is first-order in
      // the angle error, so stopping on a small step alone is not enough.
      if (best_->d <= 0.0 || std::abs(s.fp) <= 1e-15 * r_ || b - a < 1e-14) return;
      if (s.fp > 0.0) {
        b = c, fb = s.fp;
        if (side == 1) fa *= 0.5;
        side = 1;
      } else {
        a = c, fa = s.fp;
        if (side == -1) fb *= 0.5;
        side = -1;
      }
    }
  }

  void bnb(double a, const RimSample& sa, double b, const RimSample& sb, int depth) {
    if (best_->d <= 0.0) return;
    if (lower_bound(a, sa, b, sb) >= best_->d - kEps) return;
    if (is_min_bracket(sa, sb)) {
      polish(a, sa.fp, b, sb.fp);
      return;
    }
    if (depth == 0 || --budget_ < 0) return;
    const double m = 0.5 * (a + b);
    const RimSample sm = eval(m);
    bnb(a, sa, m, sm, depth - 1);
    bnb(m, sm, b, sb, depth - 1);
  }

  Vec3 C_, e1_, e2_;
  double r_ = 0.0;
  const Cylinder* other_ = nullptr;
  bool rim_on_b_ = false;
  Candidate* best_ = nullptr;
  static constexpr std::array<double, N + 1> th_ = {
      0 * kPi / 6, 1 * kPi / 6, 2 * kPi / 6, 3 * kPi / 6,  4 * kPi / 6,  5 * kPi / 6, 6 * kPi / 6,
      7 * kPi / 6, 8 * kPi / 6, 9 * kPi / 6, 10 * kPi / 6, 11 * kPi / 6, 12 * kPi / 6};
  std::array<RimSample, N + 1> s_;
  std::array<bool, N> have_{}, polished_{};
  int budget_ = 0;
};

// Separating-plane (weak duality) lower bound on the distance: for ANY unit
// n, n.(q - p) >= n.(c_b - c_a) - S_A(n) - S_B(-n) for all p in A, q in B.
double plane_bound_at(const Cylinder& a, const Cylinder& b, const Vec3& n) {
  return n.dot(b.center - a.center) - cylinder_support(a, n) - cylinder_support(b, -n);
}

// Best bound from the candidate normal n and its snaps onto the kinks of the
// support functions (n = +-axis: face contacts; n perpendicular to an axis:
// contacts on a lateral surface). At a kink the bound is first-order in the
// normal's error, so a normal off by 1e-9 would otherwise "lose" 1e-9.
// `lb` is plane_bound_at(a, b, n), when the caller has it.
double plane_bound(const Cylinder& a, const Cylinder& b, const Vec3& n, double lb) {
  for (const Vec3* u : {&a.axis, &b.axis}) {
    const double c = n.dot(*u);
    if (std::abs(c) > 1.0 - 1e-8) lb = std::max(lb, plane_bound_at(a, b, c > 0.0 ? *u : Vec3(-*u)));
    if (std::abs(c) < 1e-4) lb = std::max(lb, plane_bound_at(a, b, (n - c * *u).normalized()));
  }
  return lb;
}
double plane_bound(const Cylinder& a, const Cylinder& b, const Vec3& n) { return plane_bound(a, b, n, plane_bound_at(a, b, n)); }

// The duality gap of a separated candidate (distance d > 0, normal n) as far
// as a search needs it: the plain normal's gap when that is already at most
// `enough` (the snaps could only make a gap that certifies smaller still, and
// each costs two supports, i.e. two square roots), else the snapped bound's.
// So the gap returned never decides differently from plane_bound's at the
// threshold `enough` or any larger one.
double search_gap(const Cylinder& a, const Cylinder& b, double d, const Vec3& n, double enough) {
  const double plain = plane_bound_at(a, b, n);
  if (d - plain <= enough) return d - plain;
  return d - plane_bound(a, b, n, plain);
}

Separation to_separation(const Candidate& c) { return {c.d, c.pa, c.pb, c.n}; }

// ---- FCL ------------------------------------------------------------------

// FCL cylinders are centred at the origin along local z; map z to the axis.
fcl::Transform3d fcl_pose(const Vec3& center, const Vec3& axis) {
  fcl::Transform3d tf = fcl::Transform3d::Identity();
  tf.linear() = orientation_from_axis(axis).toRotationMatrix();
  tf.translation() = center;
  return tf;
}

// Per-thread geometry objects reused across calls; rebuilt only when the
// dimensions change (FCL shapes cache a local AABB computed at construction).
template <int Slot>
const fcl::Cylinderd& cached_cylinder(double radius, double length) {
  thread_local fcl::Cylinderd cyl(1.0, 1.0);
  if (cyl.radius != radius || cyl.lz != length) cyl = fcl::Cylinderd(radius, length);
  return cyl;
}

const fcl::Sphered& cached_sphere(double radius) {
  thread_local fcl::Sphered sph(1.0);
  if (sph.radius != radius) sph = fcl::Sphered(radius);
  return sph;
}

thread_local long g_fallbacks = 0;

}  // namespace

double point_cylinder_distance(const Vec3& p, const Cylinder& c, Vec3* closest) {
  Vec3 q, g;
  const double d = signed_point_cylinder(p, c, &q, &g);
  if (d <= 0.0) {
    if (closest) *closest = p;
    return 0.0;
  }
  if (closest) *closest = q;
  return d;
}

double point_disk_distance(const Vec3& x, const Vec3& c, const Vec3& n, double radius, Vec3* closest) {
  const Vec3 d = x - c;
  const double a = n.dot(d);
  const Vec3 radial = d - a * n;
  const double rho = radial.norm();
  if (rho <= radius) {
    if (closest) *closest = c + radial;
    return std::abs(a);
  }
  if (closest) *closest = c + (radius / rho) * radial;
  return std::hypot(a, rho - radius);
}

double point_disk_distance_search(const Vec3& x, const Vec3& c, const Vec3& n, double radius, int samples) {
  // An orthonormal frame (e1, e2) of the disk's plane.
  const Vec3 helper = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 e1 = n.cross(helper).normalized(), e2 = n.cross(e1);
  const Vec3 d = x - c;
  auto squared = [&](double phi) {
    const Vec3 e = std::cos(phi) * e1 + std::sin(phi) * e2;
    const double s = std::clamp(d.dot(e), 0.0, radius);
    return (d - s * e).squaredNorm();
  };
  const double two_pi = 2.0 * M_PI, step = two_pi / samples;
  int best = 0;
  double fbest = squared(0.0);
  for (int k = 1; k < samples; ++k) {
    const double f = squared(k * step);
    if (f < fbest) fbest = f, best = k;
  }
  // Golden section on [phi_best - step, phi_best + step].
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double lo = (best - 1) * step, hi = (best + 1) * step;
  double a = hi - g * (hi - lo), b = lo + g * (hi - lo), fa = squared(a), fb = squared(b);
  for (int it = 0; it < 200 && hi - lo > 1e-15; ++it) {
    if (fa < fb) {
      hi = b, b = a, fb = fa;
      a = hi - g * (hi - lo), fa = squared(a);
    } else {
      lo = a, a = b, fa = fb;
      b = lo + g * (hi - lo), fb = squared(b);
    }
  }
  return std::sqrt(std::min({fbest, fa, fb}));
}

Separation sphere_cylinder(const Vec3& center, double radius, const Cylinder& cyl) {
  Vec3 q, g;
  const double d = signed_point_cylinder(center, cyl, &q, &g);
  // The normal A->B is minus the outward gradient of B's signed distance; for
  // a centre inside B it points through B's nearest surface, i.e. the
  // direction in which B would have to move to push the sphere out.
  return {d - radius, center - radius * g, q, -g};
}

Separation cylinder_cylinder_features(const Cylinder& a, const Cylinder& b, double* gap) {
  // Certified optimal (or overlapping): stop searching. 1e-12 is well below
  // any tolerance the simulation asks for and above the rounding of the bound.
  constexpr double kCertify = 1e-12;
  Candidate best;
  // The duality gap of the best candidate, re-evaluated only when it changed
  // (search_gap: one to three plane bounds of two supports each; the final gap
  // below reuses it when the candidate is still the one checked, which is how
  // most searches end).
  double checked = std::numeric_limits<double>::quiet_NaN();
  Vec3 checked_n = Vec3::Zero();
  double checked_gap = 0.0;
  auto certified = [&] {
    if (best.d != checked) {
      checked = best.d;
      checked_n = best.n;
      checked_gap = best.d <= 0.0 ? 0.0 : search_gap(a, b, best.d, best.n, kCertify);
    }
    return checked_gap <= kCertify;
  };
  lateral_candidate(a, b, best);
  if (!certified()) {
    // Rims in order of the lower bound sd(rim centre, other) - r (f is
    // 1-Lipschitz in space); a rim whose bound exceeds the best is skipped.
    struct Rim {
      Vec3 c;
      const Cylinder* own;
      const Cylinder* other;
      bool on_b;
      double lb = 0.0;  // lower bound of the rim's distance to `other`
      Vec3 toward = Vec3::Zero();  // point of `other` nearest to c
    };
    std::array<Rim, 4> rims = {Rim{a.center + a.half_length * a.axis, &a, &b, false},
                               Rim{a.center - a.half_length * a.axis, &a, &b, false},
                               Rim{b.center + b.half_length * b.axis, &b, &a, true},
                               Rim{b.center - b.half_length * b.axis, &b, &a, true}};
    for (Rim& r : rims) {
      Vec3 g;
      r.lb = signed_point_cylinder(r.c, *r.other, &r.toward, &g) - r.own->radius;
    }
    std::sort(rims.begin(), rims.end(), [](const Rim& x, const Rim& y) { return x.lb < y.lb; });
    // Escalate the phases over all rims that can still improve on the best;
    // stop as soon as the result is certified.
    std::array<RimSearch, 4> search;
    std::array<bool, 4> started{};
    for (int phase = 0; phase < 3 && !certified(); ++phase) {
      for (int i = 0; i < 4 && !certified(); ++i) {
        const Rim& r = rims[i];
        if (r.lb >= best.d) break;
        if (!started[i]) {
          started[i] = true;
          search[i].init(r.c, r.own->axis, r.own->radius, *r.other, r.toward, r.on_b, best);
        }
        if (phase == 0) search[i].local();
        if (phase == 1) search[i].global();
        if (phase == 2) search[i].branch_and_bound();
      }
    }
  }
  if (gap) {
    if (best.d <= 0.0) {
      *gap = 0.0;
    } else if (best.d == checked && best.n == checked_n) {
      *gap = checked_gap;
    } else {
      *gap = search_gap(a, b, best.d, best.n, kCertify);
    }
  }
  return to_separation(best);
}

Separation cylinder_cylinder_fcl(const Cylinder& a, const Cylinder& b, double tolerance) {
  const fcl::Cylinderd& ga = cached_cylinder<0>(a.radius, 2.0 * a.half_length);
  const fcl::Cylinderd& gb = cached_cylinder<1>(b.radius, 2.0 * b.half_length);
  const fcl::Transform3d ta = fcl_pose(a.center, a.axis), tb = fcl_pose(b.center, b.axis);
  fcl::DistanceRequestd req;
  req.enable_nearest_points = true;
  req.gjk_solver_type = fcl::GST_INDEP;
  req.distance_tolerance = tolerance;
  // Not enable_signed_distance: with GST_INDEP, libfcl then runs collide()
  // and asserts (aborts) when the deepest contact has zero depth.
  fcl::DistanceResultd res;
  fcl::distance(&ga, ta, &gb, tb, req, res);
  if (res.min_distance > 0.0) {
    // FCL 0.7 returns nearest_points in the world frame (checked by
    // tests/test_geometry.cpp: FclNearestPointsAreWorldFrame).
    const Vec3 pa = res.nearest_points[0], pb = res.nearest_points[1];
    const Vec3 w = pb - pa;
    const double len = w.norm();
    return {res.min_distance, pa, pb, len > 0.0 ? Vec3(w / len) : Vec3::UnitZ()};
  }
  // Overlap (FCL reports -1): take the deepest EPA contact for the points.
  fcl::CollisionRequestd creq(16, true);
  creq.gjk_solver_type = fcl::GST_INDEP;
  fcl::CollisionResultd cres;
  fcl::collide(&ga, ta, &gb, tb, creq, cres);
  Separation s{0.0, 0.5 * (a.center + b.center), 0.5 * (a.center + b.center), b.center - a.center};
  double depth = -1.0;
  for (std::size_t i = 0; i < cres.numContacts(); ++i) {
    const fcl::Contactd& c = cres.getContact(i);
    if (c.penetration_depth > depth && c.pos.allFinite() && c.normal.allFinite()) {
      depth = c.penetration_depth;
      s = {-std::max(depth, 0.0), c.pos, c.pos, c.normal};  // FCL's normal points from o1 to o2
    }
  }
  const double nn = s.normal.norm();
  s.normal = nn > 0.0 ? Vec3(s.normal / nn) : Vec3::UnitZ();
  return s;
}

namespace {

// Outward normal of the solid cylinder at a boundary point p when it is
// well defined by the feature (face: +-axis; lateral surface: radial), or the
// rim tangent when p lies on a rim. These do not depend on the gap, unlike a
// normal taken from (q - p) / |q - p| at gaps ~1e-9.
struct FeatureDirection {
  bool normal = false, rim = false;
  Vec3 v;
};

FeatureDirection feature_direction(const Cylinder& c, const Vec3& p) {
  FeatureDirection f;
  const Vec3 d = p - c.center;
  const double a = d.dot(c.axis);
  const Vec3 radial = d - a * c.axis;
  const double rho = radial.norm();
  const double tol = 1e-7 * (c.radius + c.half_length);
  const bool face = std::abs(std::abs(a) - c.half_length) <= tol;
  const bool side = std::abs(rho - c.radius) <= tol && rho > 0.0;
  if (face && side) {
    f.rim = true;
    f.v = c.axis.cross(radial / rho);
  } else if (face) {
    f.normal = true;
    f.v = a > 0.0 ? c.axis : Vec3(-c.axis);
  } else if (side) {
    f.normal = true;
    f.v = radial / rho;
  }
  return f;
}

// Tighten the duality gap of a separated result with the feature normals;
// returns the new gap and updates s.normal when a feature normal does better.
double certify_with_features(const Cylinder& a, const Cylinder& b, Separation& s, double gap) {
  if (s.distance <= 0.0) return gap;
  const FeatureDirection fa = feature_direction(a, s.point_a), fb = feature_direction(b, s.point_b);
  Vec3 candidates[3];
  int count = 0;
  if (fa.normal) candidates[count++] = fa.v;
  if (fb.normal) candidates[count++] = -fb.v;
  if (fa.rim && fb.rim) {
    const Vec3 c = fa.v.cross(fb.v);
    if (c.squaredNorm() > 1e-12) candidates[count++] = c.dot(s.normal) >= 0.0 ? Vec3(c.normalized()) : Vec3(-c.normalized());
  }
  for (int k = 0; k < count; ++k) {
    if (candidates[k].dot(s.normal) <= 0.0) continue;
    const double g = s.distance - plane_bound(a, b, candidates[k]);
    if (g < gap) {
      gap = g;
      s.normal = candidates[k];
    }
  }
  return gap;
}

}  // namespace

Separation cylinder_cylinder(const Cylinder& a, const Cylinder& b, double tolerance, bool* certified) {
  double gap = 0.0;
  Separation s = cylinder_cylinder_features(a, b, &gap);
  if (!(gap <= std::max(tolerance, 1e-9))) gap = certify_with_features(a, b, s, gap);
  if (!(gap <= std::max(tolerance, 1e-9))) {
    // The search is not symmetric in its arguments: with the roles swapped it
    // may certify a pose it could not (seen at gaps ~1e-9, where a normal
    // taken from the closest points is ill-conditioned).
    double gap_swapped = 0.0;
    const Separation t = cylinder_cylinder_features(b, a, &gap_swapped);
    Separation swapped{t.distance, t.point_b, t.point_a, -t.normal};
    gap_swapped = certify_with_features(a, b, swapped, gap_swapped);
    if (gap_swapped < gap) {
      gap = gap_swapped;
      s = swapped;
    }
  }
  if (certified) *certified = gap <= std::max(tolerance, 1e-9);
  // The feature solver certifies its result to ~1e-12 on separated pairs
  // (600k random and degenerate poses). A larger gap means an overlap it
  // could not certify (a face cut by the other's lateral surface with no rim
  // or axis involved) or, in principle, a missed rim minimum: ask FCL.
  if (!(gap <= std::max(tolerance, 1e-9))) {
    ++g_fallbacks;
    return cylinder_cylinder_fcl(a, b, tolerance);
  }
  return s;
}

long cylinder_cylinder_fallbacks() { return g_fallbacks; }

SegmentPair segment_segment(const Vec3& ca, const Vec3& ua, double ha, const Vec3& cb, const Vec3& ub, double hb) {
  // Minimise F(s, t) = |r + s u_a - t u_b|^2, r = c_a - c_b, over the box
  // |s| <= h_a, |t| <= h_b (Lumelsky, "On fast computation of distance between
  // line segments", Inf. Process. Lett. 21, 1985; the clamping order as in
  // Ericson, "Real-Time Collision Detection", 2005, sec. 5.1.9). With
  // b = u_a.u_b, c = u_a.r, f = u_b.r the partial minimisers are
  //   t(s) = b s + f,   s(t) = b t - c,
  // and the free minimum has s0 = (b f - c) / (1 - b^2).
  //  1. s = clamp(s0): it minimises H(s) = min over all real t of F, a convex
  //     parabola, over |s| <= h_a. If t(s) is inside B, (s, t(s)) is optimal,
  //     since F >= H everywhere.
  //  2. Otherwise the optimum has t on the bound t(s) crossed (F is convex
  //     along the segment from any feasible pair to (s, t(s)), whose value
  //     H(s) is the smallest), and s = clamp(s(t)) is optimal for that t.
  // Parallel axes (1 - b^2 = 0): H is constant and any s will do. Near
  // parallel, s0 loses digits, but H is then flat (H'' = 2 (1 - b^2)), so the
  // distance does not: its error stays at rounding level.
  const Vec3 r = ca - cb;
  const double b = ua.dot(ub), c = ua.dot(r), f = ub.dot(r);
  const double denom = ua.cross(ub).squaredNorm();  // 1 - b^2, without cancellation
  auto clamp = [](double x, double h) { return std::min(std::max(x, -h), h); };
  double s = denom > 0.0 ? clamp((b * f - c) / denom, ha) : clamp(-c, ha);
  double t = b * s + f;
  if (std::abs(t) > hb) {
    t = clamp(t, hb);
    s = clamp(b * t - c, ha);
  }
  const Vec3 pa = ca + s * ua, pb = cb + t * ub;
  return {(pb - pa).norm(), s, t, pa, pb};
}

Separation capsule_capsule(const Cylinder& a, const Cylinder& b) {
  const SegmentPair p = segment_segment(a.center, a.axis, a.half_length, b.center, b.axis, b.half_length);
  // The closest points of two convex sets define a separating direction:
  // n.x <= n.p_a on segment A and n.y >= n.p_b on segment B. Adding the balls
  // shifts each support by the radius, so the capsules' plane value along n
  // is their distance, and the cylinders' (smaller supports) is at least that.
  Vec3 n = p.point_b - p.point_a;
  if (p.distance > 0.0) {
    n /= p.distance;
  } else {  // axes meet: deep overlap, any unit normal
    n = a.axis.cross(b.axis);
    n = n.squaredNorm() > 1e-24 ? Vec3(n.normalized()) : any_perpendicular(a.axis);
  }
  return {p.distance - a.radius - b.radius, p.point_a + a.radius * n, p.point_b - b.radius * n, n};
}

bool fcl_cylinders_overlap(const Cylinder& a, const Cylinder& b, double slack) {
  const double ra = a.radius - slack, la = 2.0 * (a.half_length - slack);
  const double rb = b.radius - slack, lb = 2.0 * (b.half_length - slack);
  if (ra <= 0.0 || la <= 0.0 || rb <= 0.0 || lb <= 0.0) return false;  // shrunk to nothing
  const fcl::Cylinderd& ga = cached_cylinder<0>(ra, la);
  const fcl::Cylinderd& gb = cached_cylinder<1>(rb, lb);
  fcl::CollisionRequestd req;
  req.gjk_solver_type = fcl::GST_INDEP;
  // FCL's default GJK tolerance (1e-6) reports bodies 1e-7 apart as
  // colliding; the oracle must resolve the contact band (1e-9).
  req.gjk_tolerance = kOracleGjkTolerance;
  fcl::CollisionResultd res;
  fcl::collide(&ga, fcl_pose(a.center, a.axis), &gb, fcl_pose(b.center, b.axis), req, res);
  return res.isCollision();
}

bool fcl_sphere_cylinder_overlap(const Vec3& center, double radius, const Cylinder& c, double slack) {
  const double rs = radius - slack, rc = c.radius - slack, lc = 2.0 * (c.half_length - slack);
  if (rs <= 0.0 || rc <= 0.0 || lc <= 0.0) return false;
  const fcl::Sphered& gs = cached_sphere(rs);
  const fcl::Cylinderd& gc = cached_cylinder<0>(rc, lc);
  fcl::Transform3d ts = fcl::Transform3d::Identity();
  ts.translation() = center;
  fcl::CollisionRequestd req;
  req.gjk_solver_type = fcl::GST_INDEP;
  // FCL's default GJK tolerance (1e-6) reports bodies 1e-7 apart as
  // colliding; the oracle must resolve the contact band (1e-9).
  req.gjk_tolerance = kOracleGjkTolerance;
  fcl::CollisionResultd res;
  fcl::collide(&gs, ts, &gc, fcl_pose(c.center, c.axis), req, res);
  return res.isCollision();
}

}  // namespace ringsim::geom
