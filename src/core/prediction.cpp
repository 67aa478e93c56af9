#include "core/prediction.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>

#include "core/contact.hpp"
#include "core/corotating_plane.hpp"
#include "core/motion.hpp"
#include "core/pose.hpp"
#include "core/prediction_windows.hpp"
#include "core/separating_plane.hpp"

namespace ringsim {

using detail::axis_motion;
using detail::concave_reach;
using detail::own_motion;
using detail::closed_window_end;
using detail::ImageReturn;
using detail::sphere_window;
using detail::SweptSupport;
using detail::wall_window_impl;

namespace {


// Plane evaluations before a fresh exact distance and normal are fetched.
// Measured on the periodic 600-body box (docs/PERFORMANCE.md): 3 -> 4.9k,
// 6 -> 5.1k, 16 -> 3.8k, 32 -> 3.6k collisions/s (median of three seeds).
constexpr int kPlaneBudget = 6;

Vec3 support_point_of(const BodyStore& b, int i, double t, const Vec3& n) {
  const Species& s = b.sp(i);
  const Vec3 c = body_center(b, i, t);
  if (s.shape == Shape::Sphere) return c + s.radius * n;
  const Vec3 u = body_axis(b, i, t);
  const double un = u.dot(n);
  Vec3 p = c + (un >= 0.0 ? s.half_length : -s.half_length) * u;
  const Vec3 radial = n - un * u;
  const double rn = radial.norm();
  if (rn > 1e-12) p += s.radius * radial / rn;
  return p;
}

// Well-conditioned contact normals from the closest features. A normal taken
// as (point_b - point_a) / d loses all accuracy as d -> 0, and the plane bound
// with a normal off by e is low by about e * R; the feature normals below do
// not depend on d: a face's axis, the lateral surface's radial direction, and
// for two rims (an edge-edge contact) the cross product of their tangents.
struct FeatureNormal {
  bool has_normal = false;  // outward normal of the body at the point
  Vec3 normal;
  bool on_rim = false;      // rim tangent available
  Vec3 tangent;
};

FeatureNormal feature_at(const Vec3& p, const Vec3& center, const Vec3& axis, const Species& s) {
  FeatureNormal f;
  if (s.shape == Shape::Sphere) {
    f.has_normal = true;
    f.normal = (p - center).normalized();
    return f;
  }
  const Vec3 d = p - center;
  const double a = d.dot(axis);
  const Vec3 radial = d - a * axis;
  const double rho = radial.norm();
  const double tol = 1e-7 * (s.radius + s.half_length);
  const bool on_face = std::abs(std::abs(a) - s.half_length) <= tol;
  const bool on_side = std::abs(rho - s.radius) <= tol;
  if (on_face && on_side) {
    f.on_rim = true;
    f.tangent = axis.cross(radial / rho);
  } else if (on_face) {
    f.has_normal = true;
    f.normal = a > 0.0 ? axis : Vec3(-axis);
  } else if (on_side && rho > 0.0) {
    f.has_normal = true;
    f.normal = radial / rho;
  }
  return f;
}

}  // namespace

double Predictor::sphere_sphere(int i, int j, double t, const Vec3& xi, double limit) const {
  const Kinematics &ki = b_.kin[i], &kj = b_.kin[j];
  const Vec3 dv = kj.v - ki.v;
  const double sigma = b_.sp(i).radius + b_.sp(j).radius;
  Vec3 dx = box_.min_image(position_at(kj, t) - xi);
  double s = sphere_touch_time(dx, dv, sigma);
  if (!box_.periodic || limit == kNever) return t + s;
  // In a periodic box another image may touch first, but not before its
  // return (ImageReturn): solve again from there, on the relative position
  // carried along the line and reduced to its nearest image, while that comes
  // before the contact found and the limit. (With no limit the other body,
  // which moves and has one, covers the rest.)
  for (double s0 = 0.0;;) {
    const ImageReturn back(box_, dx, dv, sigma);
    if (back.gap == 0.0 || !back.before(std::min(s, limit - t) - s0)) return t + s;
    const double ds = back.time();
    s0 += ds;
    dx += ds * dv;
    for (int c = 0; c < 3; ++c) dx[c] -= box_.length * std::nearbyint(dx[c] / box_.length);
    s = s0 + sphere_touch_time(dx, dv, sigma);
  }
}

void Predictor::fail(const char* what, int i, int j, double t, double reached, double gap, double bound) {
  failed_ = true;
  if (!failure_.empty()) return;  // the first failure is the one to report
  auto body = [&](int k) {
    std::string d = "body " + std::to_string(k) + " (" + (b_.shape[k] == Shape::Sphere ? "sphere" : "linker");
    if (b_.cgroup[k] >= 0) d += ", compliant group " + std::to_string(b_.cgroup[k]);
    else if (b_.group[k] >= 0) d += ", rigid cluster " + std::to_string(b_.group[k]);
    return d + ")";
  };
  char buf[320];
  std::snprintf(buf, sizeof buf, " from t = %.17g to t = %.17g (%.3g), rate bound %.3g, smallest step %.3g", t,
                reached, reached - t, bound, bound > 0.0 ? min_step(bound) : 0.0);
  failure_ = std::string(what) + " search of " + body(i) + (j >= 0 ? " and " + body(j) : std::string()) + buf;
  if (gap >= 0.0) {
    std::snprintf(buf, sizeof buf, ", gap there %.3g (contact tolerance %.3g)", gap, delta_);
    failure_ += buf;
  }
}

Predictor::WindowSelf Predictor::window_self(int i, const Vec3& xi) const {
  return {xi, reference_velocity(b_, i), reference_radius(b_, i)};
}

double Predictor::window_enter(const WindowSelf& self, int j, double t) const {
  // self.x: i's reference point at t (its centre, or its cluster's centre of
  // mass). In a periodic box another image may come into range first
  // (ImageReturn).
  const ReferencePoint other = reference_point(b_, j, t);
  const Vec3 dx = box_.min_image(other.x - self.x);
  const Vec3 dv = other.v - self.v;
  const double R = self.radius + other.radius + delta_;
  double enter, leave;
  const bool open = sphere_window(dx, dv, R, &enter, &leave);
  if (!box_.periodic || R <= image_safe_radius_) return open ? t + enter : kNever;
  if (!open) enter = kNever;
  const ImageReturn back(box_, dx, dv, R);
  return t + (back.before(enter) ? back.time() : enter);
}

double Predictor::cone_enter(int i, const WindowSelf& self, const Vec3& ci, int j, double t) const {
  if (b_.cgroup[i] >= 0 || b_.cgroup[j] >= 0) return t;
  if (box_.periodic && self.radius + reference_radius(b_, j) + delta_ > image_safe_radius_) return t;
  const Vec3 cj = body_center(b_, j, t);
  // Periodic: on the image of the window (window_enter: the reference
  // points' minimum image), the only one that can come within range in the
  // search; the centres' own minimum image may be another when the members
  // lie far out on their clusters.
  auto on_window_image = [&] {
    const Vec3 rj = reference_center(b_, j, t);
    return Vec3(box_.min_image(rj - self.x) + (cj - rj) - (ci - self.x));
  };
  const Vec3 dx = box_.periodic ? on_window_image() : Vec3(cj - ci);
  const Vec3 dv = reference_velocity(b_, j) - self.v;
  const double B = b_.sp(i).bounding_radius + b_.sp(j).bounding_radius + delta_;
  const double K = point_rotation_bound(b_, i, 0.0) + point_rotation_bound(b_, j, 0.0);
  return t + detail::cone_reach(dx, dv, B, K);
}

double Predictor::pair(int i, int j, double t, double limit, const Vec3& xi) {
  const bool generic = in_cluster(b_, i) || in_cluster(b_, j);
  if (!generic && b_.shape[i] == Shape::Sphere && b_.shape[j] == Shape::Sphere) {
    const double tc = sphere_sphere(i, j, t, xi, limit);
    proven_until_ = tc;
    return tc < limit ? tc : kNever;
  }
  return across_images(t, limit, [&](double from) {
    return generic ? advance_generic(i, j, from, limit) : advance_pair(i, j, from, limit);
  });
}

ContactGeometry Predictor::contact_geometry(int i, int j, double t) const { return bound_geometry(i, j, t, kNever); }

ContactGeometry Predictor::bound_geometry(int i, int j, double t, double far) const {
  const Species &si = b_.sp(i), &sj = b_.sp(j);
  ContactGeometry g;
  g.center_a = body_center(b_, i, t);
  g.center_b = g.center_a + box_.min_image(body_center(b_, j, t) - g.center_a);
  const Shape a = si.shape, b = sj.shape;
  if (a == Shape::Sphere && b == Shape::Sphere) {
    const Vec3 d = g.center_b - g.center_a;
    const double r = d.norm();
    g.sep.normal = d / r;
    g.sep.distance = r - si.radius - sj.radius;
    g.sep.point_a = g.center_a + si.radius * g.sep.normal;
    g.sep.point_b = g.center_b - sj.radius * g.sep.normal;
  } else if (a == Shape::Sphere) {
    g.axis_b = body_axis(b_, j, t);
    g.sep = geom::sphere_cylinder(g.center_a, si.radius, geom::Cylinder{g.center_b, g.axis_b, sj.radius, sj.half_length});
  } else if (b == Shape::Sphere) {
    g.axis_a = body_axis(b_, i, t);
    geom::Separation s = geom::sphere_cylinder(g.center_b, sj.radius, geom::Cylinder{g.center_a, g.axis_a, si.radius, si.half_length});
    g.sep = geom::Separation{s.distance, s.point_b, s.point_a, -s.normal};
  } else {
    g.axis_a = body_axis(b_, i, t);
    g.axis_b = body_axis(b_, j, t);
    const geom::Cylinder ca{g.center_a, g.axis_a, si.radius, si.half_length};
    const geom::Cylinder cb{g.center_b, g.axis_b, sj.radius, sj.half_length};
    if (far < kNever) {
      // Each cylinder lies inside its capsule, so the capsules' distance is a
      // lower bound of the cylinders'; far from contact it is good enough to
      // step from, at ~200 instructions against ~4 600 for the exact distance.
      g.sep = geom::capsule_capsule(ca, cb);
      // Along the capsules' normal the cylinders' separating plane (weak
      // duality: any unit normal bounds the distance from below) is at least
      // the capsules' distance, and much closer to the cylinders' when a rim
      // or face is nearest (capsule caps reach up to a radius further).
      const Vec3& n = g.sep.normal;
      const double plane = n.dot(cb.center - ca.center) - geom::cylinder_support(ca, n) - geom::cylinder_support(cb, -n);
      g.sep.distance = std::max(g.sep.distance, plane);
      if (g.sep.distance > far) {
        g.exact = false;
        return g;
      }
    }
    g.sep = geom::cylinder_cylinder(ca, cb, 1e-10, &g.certified);
  }
  return g;
}

double Predictor::approach_rate(int i, int j, double t, const ContactGeometry& g) const {
  // In the frame the impulse will use (contact_frame: polished normal, point
  // on both axis planes, where a linker's spin has no normal component), so
  // that a contact found approaching is answered by a push. With the closest
  // points' normal instead, a pair meeting at a normal speed ~1e-10 could be
  // "approaching" here and separating in the response frame, whose impulse
  // then pulled it together: Scenario 5 replicates with two clusters at rest
  // against each other met the same contact again and again at one instant.
  const ContactFrame f = contact_frame(i, j, t, g);
  const Vec3 ua = material_point_velocity(b_, i, t, f.point, g.center_a);
  const Vec3 ub = material_point_velocity(b_, j, t, f.point, g.center_b);
  return f.normal.dot(ub - ua);
}

double Predictor::advance_pair(int i, int j, double t, double limit) {
  const Kinematics &ki = b_.kin[i], &kj = b_.kin[j];
  const Species &si = b_.sp(i), &sj = b_.sp(j);
  const Vec3 dx = box_.min_image(position_at(kj, t) - position_at(ki, t));
  const Vec3 dv = kj.v - ki.v;
  const double R = si.bounding_radius + sj.bounding_radius + delta_;
  double enter, leave;
  if (!sphere_window(dx, dv, R, &enter, &leave)) {
    proven_until_ = closed_window_end(box_, dx, dv, R, t, 0.0);
    image_closed_ = true;
    return kNever;
  }
  image_closed_ = false;
  proven_until_ = kNever;
  double s = t + enter;
  const double end = std::min(limit, t + leave);
  const double bound = dv.norm() + shape_rotation_speed(ki, si) + shape_rotation_speed(kj, sj);
  if (bound == 0.0) return kNever;  // rigidly fixed relative pose: the gap never changes
  for (int step = 0; step < kMaxSteps; ++step) {
    if (s >= end) {
      // The limit reached, or the window closed (on this image only).
      image_closed_ = t + leave < limit;
      proven_until_ = image_closed_ ? closed_window_end(box_, dx, dv, R, t, leave) : s;
      return kNever;
    }
    ++ca_iterations_;
    // Far from contact: the capsules' lower bound, as in advance_generic
    // (every step below is certified by a lower bound along some unit normal;
    // the feature normals of the capsules' points are just fewer candidates).
    const ContactGeometry g = bound_geometry(i, j, s, capsule_far());
    if (!g.exact) ++counts_.pair_capsule;
    const double d = g.sep.distance;
    if (d <= delta_ && approach_rate(i, j, s, g) < 0.0) return s;
    if (d <= 0.0) {
      // Touching within rounding and separating: creep by the minimum step.
      s += min_step(bound);
      continue;
    }
    // Outside the contact band aim at delta/2; inside it (separating after a
    // contact) aim at half the current gap, so the gap never closes unseen.
    const double gap = std::min(d, delta_);
    const double target = 0.5 * gap, stop = 0.75 * gap;
    // A step every branch below may take at least: the plane along the
    // closest points' normal with both supports swept by the precession
    // (SweptSupport, prediction_windows.hpp), certified on its own.
    double swept_to = s;
    {
      const Vec3& n = g.sep.normal;
      const SweptSupport sa(b_, i, s, n, g.center_a, g.center_a, g.axis_a), sb(b_, j, s, -n, g.center_b, g.center_b, g.axis_b);
      const double gap0 = n.dot(g.center_b - g.center_a), rate = n.dot(dv);
      // (Two free linkers: both supports in one two-lane evaluation, the same bits.)
      const detail::SweptSupportPair both(sa, sb);
      auto lower = [&](double tau) {
        double ha, hb;
        if (both.usable()) {
          both.at(tau, &ha, &hb);
        } else {
          ha = sa.at(tau);
          hb = sb.at(tau);
        }
        return gap0 + rate * tau - ha - hb;
      };
      swept_to = s + concave_reach(lower, target, std::max((d - target) / bound, min_step(bound)), end - s, &plane_evaluations_);
    }
    // Proven free to the end of the search (the usual way a search ends
    // without a contact): the tighter planes below could only prove more of
    // what is no longer asked (they would raise proven_until_, which a later
    // resumption of the search starts from; measured: not worth their cost).
    if (swept_to >= end) {
      s = swept_to;
      continue;
    }
    // Two linkers side to side: the plane normal to both axes has no kink
    // (crossed_axes.hpp) and converges like Newton's method.
    if (si.shape == Shape::Linker && sj.shape == Shape::Linker) {
      // (Its geometry first: in about half of the steps that reach here the
      // plane is below the stop level, and the motion is not needed.)
      const Vec3 dxy = g.center_b - g.center_a;
      CrossedAxesPlane xp(g.axis_a, si.radius, g.axis_b, sj.radius, dxy);
      if (xp.usable() && xp.value() > stop) {
        xp.set_motion(axis_motion(g.axis_a, si.radius, own_motion(b_, i, s)), axis_motion(g.axis_b, sj.radius, own_motion(b_, j, s)), dxy);
        const double h = xp.step(target, end - s);
        if (h > (d - target) / bound) {
          s = std::max(s + h, swept_to);
          continue;
        }
      }
    }
    const RankedNormals r = rank_normals(i, j, s, g);
    // A contact on a linker's face or side: a plane turning with that linker
    // (corotating_plane.hpp) converges like Newton's method.
    if (r.feature >= 0 && r.value[r.feature] >= r.value[r.best] - 1e-12 && r.value[r.feature] > stop) {
      const int x = r.owner[r.feature] == 1 ? i : j;
      if (b_.shape[x] == Shape::Linker) {
        const int y = x == i ? j : i;
        const Vec3 n0 = x == i ? r.normal[r.feature] : Vec3(-r.normal[r.feature]);
        const Vec3 dxy = x == i ? Vec3(g.center_b - g.center_a) : Vec3(g.center_a - g.center_b);
        // (g's axes are body_axis at s: the same bits as axis_at; a sphere's
        // is not read.)
        const CorotatingPlane cp(b_.kin[x], b_.sp(x), b_.kin[y], b_.sp(y), n0, dxy, s, x == i ? g.axis_a : g.axis_b,
                                 y == i ? g.axis_a : g.axis_b);
        const double reached = cp.advance(s, end, target, stop, &plane_evaluations_, kPlaneBudget);
        // Worth it only when it beats the plain conservative step.
        if (reached - s > (d - target) / bound) {
          s = std::max(reached, swept_to);
          continue;
        }
      }
    }
    if (r.value[r.best] <= stop) {
      // No plane is tighter than the stop level: take the plain conservative
      // step, from a proven lower bound only: an unproven distance may be too
      // large (FCL's GJK near contact), and stepping by it could pass a contact.
      const double proven = g.certified ? d : r.value[r.best];
      s = std::max(s + std::max((proven - target) / bound, min_step(bound)), swept_to);
      continue;
    }
    const SeparatingPlane plane = plane_along(i, j, s, g, r.normal[r.best]);
    s = std::max({s + min_step(bound), swept_to,
                  advance_plane(plane, s, end, target, stop, bound, &plane_evaluations_, kPlaneBudget)});
  }
  fail("pair", i, j, t, s, contact_geometry(i, j, s).sep.distance, bound);
  return kNever;
}

double Predictor::plane_value(int i, int j, const ContactGeometry& g, const Vec3& n) const {
  // The plane's value at g's time only: supports of those poses, no tracks.
  auto support = [&](int b, const Vec3& center, const Vec3& axis, const Vec3& m) {
    const Species& sp = b_.sp(b);
    if (sp.shape == Shape::Sphere) return sp.radius;
    return geom::cylinder_support(geom::Cylinder{center, axis, sp.radius, sp.half_length}, m);
  };
  return n.dot(g.center_b - g.center_a) - support(i, g.center_a, g.axis_a, n) - support(j, g.center_b, g.axis_b, -n);
}

SeparatingPlane Predictor::plane_along(int i, int j, double t, const ContactGeometry& g, const Vec3& n) const {
  SeparatingPlane plane;
  plane.t0 = t;
  plane.offset = n.dot(g.center_b - g.center_a);
  plane.slope = n.dot(b_.kin[j].v - b_.kin[i].v);
  // (g's axes are body_axis at t, the same bits as axis_at; a sphere's is not read.)
  plane.a = SupportTrack::of(b_.kin[i], b_.sp(i), n, t, g.axis_a);
  plane.b = SupportTrack::of(b_.kin[j], b_.sp(j), -n, t, g.axis_b);
  return plane;
}

Predictor::RankedNormals Predictor::rank_normals(int i, int j, double t, const ContactGeometry& g) const {
  RankedNormals r;
  const Vec3& n = g.sep.normal;
  auto add = [&](const Vec3& v, int owner) {
    r.normal[r.count] = v;
    r.owner[r.count] = owner;
    r.value[r.count] = plane_value(i, j, g, v);
    if (r.value[r.count] > r.value[r.best]) r.best = r.count;
    if (owner != 0 && (r.feature < 0 || r.value[r.count] > r.value[r.feature])) r.feature = r.count;
    ++r.count;
  };
  add(n, 0);
  const FeatureNormal fa = feature_at(g.sep.point_a, g.center_a, g.axis_a, b_.sp(i));
  const FeatureNormal fb = feature_at(g.sep.point_b, g.center_b, g.axis_b, b_.sp(j));
  if (fa.has_normal && fa.normal.dot(n) > 0.0) add(fa.normal, 1);
  if (fb.has_normal && -fb.normal.dot(n) > 0.0) add(-fb.normal, 2);
  if (fa.on_rim && fb.on_rim) {
    const Vec3 c = fa.tangent.cross(fb.tangent);
    if (c.squaredNorm() > 1e-12) add(c.dot(n) >= 0.0 ? Vec3(c.normalized()) : Vec3(-c.normalized()), 0);
  }
  return r;
}

namespace {

// Outward normal of cylinder c's lateral surface at the point nearest p
// (radial direction from the axis): well conditioned, |radial| ~ radius.
Vec3 lateral_normal(const Vec3& p, const Vec3& center, const Vec3& axis) {
  Vec3 r = p - center;
  r -= r.dot(axis) * axis;
  return r.normalized();
}

// Polish a rim point P of cylinder X (rim centre C, axis u, radius r) in
// contact with the lateral surface of Y: at the closest pair the rim tangent
// is normal to Y's radial direction, f'(th) = radial_Y(P(th)) . P'(th) = 0.
// Secant iterations from the solver's angle (which is certified in distance
// only, i.e. to ~sqrt(1e-12) in angle).
Vec3 polish_rim_against_side(const Vec3& P0, const Vec3& C, const Vec3& u, double r, const Vec3& y_center,
                             const Vec3& y_axis) {
  const Vec3 e1 = (P0 - C).normalized();
  const Vec3 e2 = u.cross(e1);
  auto point = [&](double th) { return C + r * (std::cos(th) * e1 + std::sin(th) * e2); };
  auto slope = [&](double th) {
    const Vec3 tangent = r * (-std::sin(th) * e1 + std::cos(th) * e2);
    return lateral_normal(point(th), y_center, y_axis).dot(tangent);
  };
  double a = 0.0, fa = slope(a);
  double b = 1e-6, fb = slope(b);
  for (int it = 0; it < 8 && std::abs(fb) > 1e-15 * r && fb != fa; ++it) {
    const double c = b - fb * (b - a) / (fb - fa);
    a = b, fa = fb;
    b = c, fb = slope(b);
  }
  return std::abs(fb) <= std::abs(fa) ? point(b) : point(a);
}

}  // namespace

ContactFrame Predictor::on_axis_planes(int i, int j, double t, const ContactGeometry& g, ContactFrame frame) const {
  // A smooth contact's line of action must meet each cylinder's axis (every
  // normal of a cylinder of revolution lies in a plane through its axis), or
  // the impulse turns the linker about its own axis. At gaps ~1e-9 the
  // midpoint of two closest points can sit ~1e-10 off those planes, which
  // changed spins by ~5e-9 (rim-rim contacts). Move the point, by about the
  // gap, onto the plane spanned by the normal and each linker's axis: solve
  //   m_A.(p + a m_A + b m_B - x_A) = 0,  m_B.(p + a m_A + b m_B - x_B) = 0,
  // m = n x u / |n x u| (a face contact, n || u, needs no correction).
  auto plane_normal = [&](int b, const Vec3& center, double* offset) {
    if (b_.sp(b).shape != Shape::Linker) return Vec3(Vec3::Zero());
    const Vec3 m = frame.normal.cross(b == i ? g.axis_a : g.axis_b);
    const double len = m.norm();
    if (len < 1e-6) return Vec3(Vec3::Zero());
    *offset = (m / len).dot(frame.point - center);
    return Vec3(m / len);
  };
  double ra = 0.0, rb = 0.0;
  const Vec3 ma = plane_normal(i, g.center_a, &ra), mb = plane_normal(j, g.center_b, &rb);
  const double c = ma.dot(mb), det = 1.0 - c * c;
  if (det > 1e-12) {
    frame.point += ((-ra + c * rb) / det) * ma + ((-rb + c * ra) / det) * mb;
  } else {
    frame.point -= ra * ma + (ma.squaredNorm() == 0.0 ? rb * mb : Vec3(Vec3::Zero()));
  }
  return frame;
}

ContactFrame Predictor::contact_frame(int i, int j, double t, const ContactGeometry& g) const {
  assert(g.exact && "contact_frame: a capsule lower bound is no contact geometry");
  // The true normal maximises the separation along it (weak duality), so the
  // candidate with the largest plane value is the most accurate one.
  const RankedNormals r = rank_normals(i, j, t, g);
  const Vec3& best = r.normal[r.best];
  ContactFrame frame{best, 0.5 * (g.sep.point_a + g.sep.point_b)};
  // A rim against a lateral surface: make the rim point exact, so that the
  // line of action meets both axes (no spurious torque about either axis).
  const Species &si = b_.sp(i), &sj = b_.sp(j);
  if (si.shape != Shape::Linker || sj.shape != Shape::Linker) return on_axis_planes(i, j, t, g, frame);
  const Vec3 &ua = g.axis_a, &ub = g.axis_b;
  const FeatureNormal fa = feature_at(g.sep.point_a, g.center_a, ua, si);
  const FeatureNormal fb = feature_at(g.sep.point_b, g.center_b, ub, sj);
  auto on_side = [](const Vec3& p, const Vec3& c, const Vec3& u, const Species& s) {
    return std::abs((p - c).dot(u)) < s.half_length - 1e-7 * (s.radius + s.half_length);
  };
  auto rim_centre = [](const Vec3& p, const Vec3& c, const Vec3& u, const Species& s) {
    return c + ((p - c).dot(u) > 0.0 ? s.half_length : -s.half_length) * u;
  };
  auto on_face = [](const FeatureNormal& fn, const Vec3& u) { return fn.has_normal && std::abs(fn.normal.dot(u)) > 0.5; };
  if (fa.on_rim && on_face(fb, ub)) {
    // Rim against an end face: the face normal is exact; the rim point is the
    // rim's extreme point along it (closed form).
    frame.normal = -fb.normal;
    frame.point = support_point_of(b_, i, t, frame.normal);
  } else if (fb.on_rim && on_face(fa, ua)) {
    frame.normal = fa.normal;
    // (shifted into the contact's minimum-image frame)
    frame.point = support_point_of(b_, j, t, -frame.normal) + (g.center_b - body_center(b_, j, t));
  } else if (fa.on_rim && on_side(g.sep.point_b, g.center_b, ub, sj)) {
    const Vec3 P = polish_rim_against_side(g.sep.point_a, rim_centre(g.sep.point_a, g.center_a, ua, si), ua, si.radius,
                                           g.center_b, ub);
    frame.normal = -lateral_normal(P, g.center_b, ub);
    frame.point = P;
  } else if (fb.on_rim && on_side(g.sep.point_a, g.center_a, ua, si)) {
    const Vec3 P = polish_rim_against_side(g.sep.point_b, rim_centre(g.sep.point_b, g.center_b, ub, sj), ub, sj.radius,
                                           g.center_a, ua);
    frame.normal = lateral_normal(P, g.center_a, ua);
    frame.point = P;
  }
  return on_axis_planes(i, j, t, g, frame);
}

bool Predictor::wall_contact(int i, double t, const Vec3& n, Vec3* point) const {
  // Where the solid touches the wall plane the support set along n may be a
  // point, a segment (a side lying parallel to the wall: both ends) or a disc
  // (an end face parallel to it: its rim). Every candidate within delta of the
  // support plane is a contact point; the one approaching fastest is used, by
  // prediction and response alike, so the impulse is always repulsive.
  //
  // "Approaching" is judged by the shape velocity (v + precession x r: a
  // linker's spin about its axis moves no surface), but the wall's impulse
  // (process_wall, fired_contact) acts on the material velocity (v + omega x
  // r, spin included). The two agree at the exact support point, not at the
  // other candidates: a rim sample within delta of a tilted face's support
  // point (up to sqrt(2 delta / (R |n_perp|)) ~ 1e-4 rad along the rim)
  // differs by ~ spin R |n_perp| times that angle. So a contact approaching
  // by the shape velocity may separate materially; the response then gives
  // it no impulse, or only the separation floor's top-up to
  // min_separation_speed. When it would do nothing at all (the point
  // already separates materially at least at the floor), the state is
  // unchanged and the search would fire the same contact at the same
  // instant for ever: a turning linker on its rim at a wall with
  // restitution 0, left by the TC model's elastic repeat separating
  // materially at 1.3e-5 and approaching by the shape velocity at 2.7e-7,
  // stopped time ("time stopped at t = 11.689"; test
  // InelasticCollapse.LinkerRimAtAWallDoesNotFreezeTime). Such a contact
  // does not fire; the candidate approaching fastest materially is used
  // instead, when the response acts on it. Every other contact fires as
  // before, at the same point, so runs that did not stop are unchanged
  // (bit-identical in the checks of the commit that made this change).
  const Species& s = b_.sp(i);
  const Vec3 c = body_center(b_, i, t);
  struct Candidate {
    Vec3 p;
    double shape_rate, rate;  // n . velocity, shape and material (positive: towards the wall)
  };
  auto candidate = [&](const Vec3& p) {
    return Candidate{p, n.dot(shape_point_velocity(b_, i, t, p, c)), n.dot(material_point_velocity(b_, i, t, p, c))};
  };
  // (rate is the approach speed: the normal speed of separation is -rate.)
  auto answered = [&](const Candidate& k) { return response_acts(-k.rate, min_separation_); };
  const Vec3 p0 = support_point_of(b_, i, t, n);
  Candidate by_shape = candidate(p0), fastest = by_shape;
  if (s.shape == Shape::Linker) {
    const Vec3 u = body_axis(b_, i, t);
    const double level = n.dot(p0);
    auto consider = [&](const Vec3& p) {
      if (level - n.dot(p) > delta_) return;  // not touching
      const Candidate k = candidate(p);
      if (k.shape_rate > by_shape.shape_rate) by_shape = k;
      if (k.rate > fastest.rate) fastest = k;
    };
    const double un = u.dot(n);
    consider(p0 - (un >= 0.0 ? 2.0 : -2.0) * s.half_length * u);  // other end of a parallel side line
    const Vec3 face = c + (un >= 0.0 ? s.half_length : -s.half_length) * u;
    const Vec3 e1 = (std::abs(u.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(u).normalized(), e2 = u.cross(e1);
    for (int m = 0; m < 16; ++m) {  // rim of a face parallel to the wall
      const double a = 2.0 * M_PI * m / 16.0;
      consider(face + s.radius * (std::cos(a) * e1 + std::sin(a) * e2));
    }
  }
  if (by_shape.shape_rate <= 0.0) {  // not approaching
    if (point) *point = by_shape.p;
    return false;
  }
  const Candidate& best = answered(by_shape) ? by_shape : fastest;
  if (point) *point = best.p;
  return answered(best);
}


WallHit Predictor::wall(int i, double t, double limit) {
  if (in_cluster(b_, i)) return wall_generic(i, t, limit);
  const Kinematics& k = b_.kin[i];
  const Species& s = b_.sp(i);
  const double L = box_.length;
  const Vec3 x = position_at(k, t);
  WallHit best;
  best.time = limit;
  if (s.shape == Shape::Sphere) {
    for (int d = 0; d < 3; ++d) {
      double dt = kNever;
      if (k.v[d] > 0.0) dt = (L - s.radius - x[d]) / k.v[d];
      else if (k.v[d] < 0.0) dt = (s.radius - x[d]) / k.v[d];
      dt = std::max(dt, 0.0);
      if (t + dt < best.time) best = {t + dt, d, k.v[d] > 0.0 ? +1 : -1};
    }
  } else {
    const double R = s.bounding_radius;
    const double rot = shape_rotation_speed(k, s);
    for (int d = 0; d < 3; ++d) {
      for (int dir : {-1, +1}) {
        double sc, end = best.time;
        if (!wall_window(x[d], k.v[d], dir, R + delta_, t, &sc, &end)) continue;
        const double bound = std::abs(k.v[d]) + rot;
        if (bound == 0.0) continue;
        Vec3 n = Vec3::Zero();
        n[d] = dir;  // from the body towards the wall
        // The wall is a half-space: along its normal the plane bound is the
        // exact gap, g(t) = offset + slope (t - t0) - support(n, t).
        SeparatingPlane plane;
        plane.t0 = sc;
        plane.offset = dir > 0 ? L - position_at(k, sc)[d] : position_at(k, sc)[d];
        plane.slope = dir > 0 ? -k.v[d] : k.v[d];  // rate of change of the centre's gap
        plane.a = SupportTrack::of(k, s, n, sc);
        plane.b = SupportTrack::constant(0.0);
        const double step_floor = min_step(bound);
        for (int step = 0; step < kMaxSteps && sc < end; ++step) {
          ++ca_iterations_;
          const double g = plane.at(sc);
          if (g <= delta_) {
            if (wall_contact(i, sc, n, nullptr)) {
              best = {sc, d, dir};
              break;
            }
          }
          const double gap = std::min(g, delta_);
          if (gap <= 0.0) {
            sc += step_floor;
            continue;
          }
          sc = std::max(sc + step_floor,
                        advance_plane(plane, sc, end, 0.5 * gap, 0.75 * gap, bound, &plane_evaluations_, 1 << 30));
          if (step + 1 == kMaxSteps) fail("wall", i, -1, t, sc, g, bound);
        }
      }
    }
  }
  if (best.time >= limit) best.time = kNever;
  return best;
}

}  // namespace ringsim
