// Searches for bodies in rigid clusters (plain conservative advancement with
// the reference-motion bounds of core/pose.hpp), cluster members' cell exits,
// and capture events. Part of class Predictor (core/prediction.hpp).
#include <algorithm>
#include <cmath>

#include "core/corotating_plane.hpp"
#include "core/crossed_axes.hpp"
#include "core/motion.hpp"
#include "core/pose.hpp"
#include "core/prediction.hpp"
#include "core/prediction_windows.hpp"

namespace ringsim {

using detail::axis_motion;
using detail::concave_reach;
using detail::closed_window_end;
using detail::point_motion;
using detail::PointMotion;
using detail::quadratic_reach;
using detail::sphere_window;
using detail::SweptSupport;
using detail::wall_window_impl;
using detail::OwnMotion;
using detail::own_motion;

bool Predictor::wall_window(double x, double v, int dir, double reach, double t, double* start, double* end) const {
  return wall_window_impl(box_.length, x, v, dir, reach, t, start, end);
}

double Predictor::advance_generic(int i, int j, double t, double limit) {
  // Past a compliant member's motion horizon its trajectory is not known yet.
  const double known = std::min(motion_horizon(b_, i), motion_horizon(b_, j));
  limit = std::min(limit, known);
  proven_until_ = known;
  const Vec3 dx = box_.min_image(reference_center(b_, j, t) - reference_center(b_, i, t));
  const Vec3 dv = reference_velocity(b_, j) - reference_velocity(b_, i);
  const double R = reference_radius(b_, i) + reference_radius(b_, j) + delta_;
  double enter, leave;
  if (!sphere_window(dx, dv, R, &enter, &leave)) {
    proven_until_ = std::min(known, closed_window_end(box_, dx, dv, R, t, 0.0));
    image_closed_ = proven_until_ < known;
    return kNever;
  }
  image_closed_ = false;
  ++counts_.cluster_pair_searches;
  double s = t + enter;
  const double end = std::min(limit, t + leave);
  // Any two surface points approach at most at this rate (core/pose.hpp).
  const double bound = dv.norm() + rotation_bound(b_, i) + rotation_bound(b_, j);
  if (bound == 0.0) return kNever;
  for (int step = 0; step < kMaxSteps; ++step) {
    if (s >= end) {
      // The limit reached, or the window closed (on this image only).
      if (t + leave < limit) {
        proven_until_ = std::min(known, closed_window_end(box_, dx, dv, R, t, leave));
        image_closed_ = proven_until_ < known;
      } else {
        proven_until_ = s;
      }
      return kNever;
    }
    ++ca_iterations_;
    ++counts_.cluster_pair;
    // Far from contact two linkers step from their capsules' distance, a
    // certified lower bound (bound_geometry): the Lipschitz step below and
    // the swept plane along the capsules' normal stay valid for any lower
    // bound and any unit normal. Beyond capsule_far() >= 1e3 delta no contact
    // can fire and the feature normals are not needed; nearer, the exact
    // distance decides as before.
    const ContactGeometry g = bound_geometry(i, j, s, capsule_far());
    if (!g.exact) ++counts_.cluster_pair_capsule;
    const double d = g.sep.distance;
    if (d <= delta_ && approach_rate(i, j, s, g) < 0.0) return s;
    if (d <= 0.0) {
      s += min_step(bound);
      continue;
    }
    const double target = 0.5 * std::min(d, delta_);
    double proven = d;
    Vec3 normal = g.sep.normal;
    // Below plane_band() (and whenever the distance is unproven) the
    // planes that follow a resting contact are tried: the crossed axes and the
    // plane turning with a linker's face or side. Up to 1e3 delta until
    // 2026-11-26: Scenario 5's chatter (a body resting on a turning linker's
    // side, 1e-6..1e-5 apart between micro-collisions) then crawled with the
    // swept plane alone, whose fixed normal sees the linker's ends tilt.
    if (!g.certified || d < plane_band()) {
      // An unproven distance may be too large: step from a separating plane.
      // Near contact the closest points' normal is ill-conditioned (off by
      // ~1e-6 at d ~ 1e-9, so its plane sits below zero); the feature normals
      // are not (rank_normals), and any unit normal's plane is a lower bound.
      const RankedNormals r = rank_normals(i, j, s, g);
      if (!g.certified) proven = r.value[r.best];
      normal = r.normal[r.best];
      const double stop = 0.75 * std::min(d, delta_);
      const OwnMotion mi = own_motion(b_, i, s), mj = own_motion(b_, j, s);
      // Two linkers side to side: the plane normal to both axes (no kink).
      if (b_.shape[i] == Shape::Linker && b_.shape[j] == Shape::Linker) {
        const CrossedAxesPlane xp(axis_motion(g.axis_a, b_.sp(i).radius, mi), axis_motion(g.axis_b, b_.sp(j).radius, mj),
                                  g.center_b - g.center_a);
        if (xp.usable() && xp.value() > stop) {
          const double h = xp.step(target, end - s);
          if (h > (d - target) / bound) {
            s += h;
            continue;
          }
        }
      }
      // A contact on a linker's face or side: a plane turning with that
      // linker, as in advance_pair; cluster members (rigid or compliant) enter
      // as their first-order motion plus its second-order remainder (one
      // certified step from s: the remainder counts from there).
      // The face or side normal of a linker among the tightest planes (a
      // sphere's radial normal often ties with it and does not turn).
      int face = -1;
      for (int q = 0; q < r.count; ++q) {
        if (r.owner[q] == 0 || b_.shape[r.owner[q] == 1 ? i : j] != Shape::Linker) continue;
        if (r.value[q] < r.value[r.best] - 1e-12 || r.value[q] <= stop) continue;
        if (face < 0 || r.value[q] > r.value[face]) face = q;
      }
      if (face >= 0) {
        const int x = r.owner[face] == 1 ? i : j;
        const int y = x == i ? j : i;
        const Vec3 n0 = x == i ? r.normal[face] : Vec3(-r.normal[face]);
        const Vec3 dxy = x == i ? Vec3(g.center_b - g.center_a) : Vec3(g.center_a - g.center_b);
        auto first_order = [&](int b, const Vec3& c) {
          const OwnMotion& m = b == i ? mi : mj;
          // (A sphere's axis is never read by the plane: it does not turn.)
          Kinematics k = make_kinematics(c, m.v, b == i ? g.axis_a : g.axis_b);
          k.t = s;
          k.precession = m.omega;
          return k;
        };
        // Free bodies turn exactly as the frozen rotation: no remainder.
        CorotatingPlane::Remainder rem;
        auto remainder = [&](int b, double* c, double* a) {
          if (!in_cluster(b_, b)) return;
          const OwnMotion& m = b == i ? mi : mj;
          *c = m.center_accel;
          *a = b_.shape[b] == Shape::Linker ? m.turning_accel : 0.0;
        };
        remainder(x, &rem.c_x, &rem.a_x);
        remainder(y, &rem.c_y, &rem.a_y);
        const Vec3 cx = x == i ? g.center_a : g.center_b, cy = x == i ? g.center_b : g.center_a;
        const CorotatingPlane cp(first_order(x, cx), b_.sp(x), first_order(y, cy), b_.sp(y), n0, dxy, s, rem);
        const double reached = cp.advance(s, end, target, stop, &plane_evaluations_, 1);
        if (reached - s > (d - target) / bound) {
          s = reached;
          continue;
        }
      }
    }
    double advance_by = std::max((proven - target) / bound, min_step(bound));
    if (s + advance_by < end) {
      // The separating plane along the closest points' normal, with each
      // body's support swept by its own rotation (SweptSupport): a concave
      // lower bound of d over the step that uses the actual directions of the
      // angular velocities and the signed approach rate n.(v_B - v_A) instead
      // of the largest speed of any point.
      // (Compliant members: about their own centres, RefMotion.)
      const Vec3& n = normal;
      const RefMotion ma = ref_motion(b_, i, s), mb = ref_motion(b_, j, s);
      const Vec3 ref_a = g.center_a + ma.offset, ref_b = g.center_b + mb.offset;
      const SweptSupport sa(b_, i, s, n, g.center_a, ref_a, g.axis_a), sb(b_, j, s, -n, g.center_b, ref_b, g.axis_b);
      const double gap0 = n.dot(ref_b - ref_a), rate = n.dot(mb.v - ma.v), q = 0.5 * (ma.accel + mb.accel);
      auto lower = [&](double tau) { return gap0 + (rate - q * tau) * tau - sa.at(tau) - sb.at(tau); };
      advance_by = std::max(advance_by, concave_reach(lower, target, advance_by, end - s, &plane_evaluations_));
      // Two linkers side to side outside the near band (the block above,
      // which tries this plane first, runs below plane_band() only): the plane
      // normal to both axes, as in advance_pair at every distance. The fixed
      // normal's swept supports above have a kink there (|u.m| at u.n = 0: the
      // linkers' ends tilting), so a linker resting across a turning one
      // (chatter) stepped by ~d per unit of the tilt rate; this plane has none.
      // Both are certified lower bounds over their steps: the longer holds.
      if (s + advance_by < end && b_.shape[i] == Shape::Linker && b_.shape[j] == Shape::Linker && g.certified &&
          d >= plane_band()) {
        const CrossedAxesPlane xp(axis_motion(g.axis_a, b_.sp(i).radius, own_motion(b_, i, s)),
                                  axis_motion(g.axis_b, b_.sp(j).radius, own_motion(b_, j, s)), g.center_b - g.center_a);
        if (xp.usable() && xp.value() > target) advance_by = std::max(advance_by, xp.step(target, end - s));
      }
    }
    s += advance_by;
  }
  fail("cluster pair", i, j, t, s, contact_geometry(i, j, s).sep.distance, bound);
  return kNever;
}

WallHit Predictor::wall_generic(int i, double t, double limit) {
  limit = std::min(limit, motion_horizon(b_, i));
  const double L = box_.length;
  const Vec3 X = reference_center(b_, i, t);
  const Vec3& V = reference_velocity(b_, i);
  const double reach = reference_radius(b_, i) + delta_;
  const double rot = rotation_bound(b_, i);
  const Species& sp = b_.sp(i);
  WallHit best;
  best.time = limit;
  for (int d = 0; d < 3; ++d) {
    for (int dir : {-1, +1}) {
      double sc, end = best.time;
      if (!wall_window(X[d], V[d], dir, reach, t, &sc, &end)) continue;
      const double bound = std::abs(V[d]) + rot;
      if (bound == 0.0) continue;
      Vec3 n = Vec3::Zero();
      n[d] = dir;
      const double step_floor = min_step(bound);
      for (int step = 0; sc < end; ++step) {
        if (step == kMaxSteps) {
          fail("cluster wall", i, -1, t, sc, -1.0, bound);
          break;
        }
        ++ca_iterations_;
        ++counts_.cluster_wall;
        const Vec3 c = body_center(b_, i, sc);
        const double support =
            sp.shape == Shape::Sphere ? sp.radius : geom::cylinder_support(geom::Cylinder{c, body_axis(b_, i, sc), sp.radius, sp.half_length}, n);
        const double g = (dir > 0 ? L - c[d] : c[d]) - support;
        if (g <= delta_ && wall_contact(i, sc, n, nullptr)) {
          best = {sc, d, dir};
          break;
        }
        if (g <= 0.0) {
          sc += step_floor;
          continue;
        }
        const double target = 0.5 * std::min(g, delta_);
        double advance_by = std::max((g - target) / bound, step_floor);
        if (sc + advance_by < end) {
          // The wall is a plane: gap = (L or 0) - (support along n), and the
          // swept support bounds the support over the step (SweptSupport).
          const RefMotion rm = ref_motion(b_, i, sc);
          const Vec3 ref = c + rm.offset;
          const SweptSupport sw(b_, i, sc, n, c, ref);
          const double gap0 = (dir > 0 ? L : 0.0) - n.dot(ref), rate = -n.dot(rm.v), q = 0.5 * rm.accel;
          auto lower = [&](double tau) { return gap0 + (rate - q * tau) * tau - sw.at(tau); };
          advance_by = std::max(advance_by, concave_reach(lower, target, advance_by, end - sc, &plane_evaluations_));
        }
        sc += advance_by;
      }
    }
  }
  if (best.time >= limit) best.time = kNever;
  return best;
}

double Predictor::leave_cell(int i, double t, double limit, const Vec3& lo, double w) {
  limit = std::min(limit, motion_horizon(b_, i));
  const double bound = reference_velocity(b_, i).norm() + point_rotation_bound(b_, i, 0.0);
  if (bound == 0.0) return kNever;
  // Fires once the centre is more than half the slack outside (so a centre
  // resting on a face does not fire again and again), at most 3/4 of it out.
  // The slack also sets the smallest step (slack / 4 over the speed bound), so
  // a centre gliding along a face costs a bounded number of steps.
  const double eps = cell_slack();
  const double floor_step = 0.25 * eps / bound;
  double s = t;
  for (int step = 0; step < kMaxSteps && s < limit; ++step) {
    ++counts_.cell;
    Vec3 x = body_center(b_, i, s);
    if (box_.periodic)
      for (int d = 0; d < 3; ++d) x[d] -= box_.length * std::floor(x[d] / box_.length);
    double f = kNever;  // distance to the nearest face, negative outside
    for (int d = 0; d < 3; ++d) f = std::min({f, x[d] - lo[d], lo[d] + w - x[d]});
    if (f <= -0.5 * eps) return s;
    double advance_by = std::max((f + 0.5 * eps) / bound, floor_step);
    if (s + advance_by < limit) {
      // Each face distance is bounded below by a concave quadratic from the
      // centre's first-order motion (PointMotion); step to the first time any
      // of them can reach -eps/2.
      const Vec3 c = body_center(b_, i, s);
      const PointMotion pm = point_motion(b_, i, s, c, reference_center(b_, i, s));
      double reach = kNever;
      for (int d = 0; d < 3; ++d) {
        reach = std::min(reach, quadratic_reach(x[d] - lo[d], pm.vel[d], pm.quad, -0.5 * eps));
        reach = std::min(reach, quadratic_reach(lo[d] + w - x[d], -pm.vel[d], pm.quad, -0.5 * eps));
      }
      advance_by = std::max(advance_by, reach);
    }
    s += advance_by;
  }
  if (s < limit) fail("cell exit", i, -1, t, s, -1.0, bound);
  return kNever;
}

double Predictor::capture_gap(int l, int end, int s, double t, double rc) const {
  return capture_geometry(l, end, s, t, rc).gap;
}

Predictor::CaptureGeometry Predictor::capture_geometry(int l, int end, int s, double t, double rc) const {
  const Species& sl = b_.sp(l);
  CaptureGeometry g;
  g.cl = body_center(b_, l, t);
  g.axis = body_axis(b_, l, t);
  g.p = g.cl + (end == 0 ? sl.half_length : -sl.half_length) * g.axis;
  const Vec3 d = box_.min_image(body_center(b_, s, t) - g.p);
  g.cs = g.p + d;
  double dist;
  if (capture_site_ == CaptureSite::EndFace) {
    dist = geom::point_disk_distance(g.cs, g.p, g.axis, sl.radius, &g.q);
  } else {
    g.q = g.p;
    dist = d.norm();
  }
  g.gap = dist - b_.sp(s).radius - rc;
  return g;
}

double Predictor::capture_arm(const Species& linker, CaptureSite site) {
  return site == CaptureSite::EndFace ? linker.bounding_radius : linker.half_length;
}

double Predictor::capture(int l, int end, int s, double t, double limit, double rc) {
  limit = std::min({limit, motion_horizon(b_, l), motion_horizon(b_, s)});
  // As in pair(). (Where a closed window's proof ends the gap exceeds
  // 2 delta, so the search from there starts armed.)
  return across_images(t, limit,
                       [&, t0 = t](double from) { return capture_on_image(l, end, s, from, limit, rc, from == t0); });
}

void Predictor::capture_refused(int l, int end, int s) {
  const std::size_t k = 2 * static_cast<std::size_t>(l) + static_cast<std::size_t>(end);
  if (refused_.size() <= k) refused_.resize(k + 1);
  if (!refused(l, end, s)) refused_[k].push_back(s);
}

bool Predictor::refused(int l, int end, int s) const {
  const std::size_t k = 2 * static_cast<std::size_t>(l) + static_cast<std::size_t>(end);
  return k < refused_.size() && std::find(refused_[k].begin(), refused_[k].end(), s) != refused_[k].end();
}

void Predictor::forget_refused(int l, int end, int s) {
  const std::size_t k = 2 * static_cast<std::size_t>(l) + static_cast<std::size_t>(end);
  if (k >= refused_.size()) return;
  auto& v = refused_[k];
  v.erase(std::remove(v.begin(), v.end(), s), v.end());
}

double Predictor::capture_on_image(int l, int end, int s, double t, double limit, double rc, bool now) {
  const bool face = capture_site_ == CaptureSite::EndFace;
  const double rs = b_.sp(s).radius, r_face = b_.sp(l).radius;
  const double arm = capture_arm(b_.sp(l), capture_site_);
  // Window: the site stays within arm (+ reach) of l's reference point, the
  // sphere's centre within its reach of its own.
  const double rl = reference_offset(b_, l) + arm;
  const double rsph = reference_offset(b_, s);
  const Vec3 dx = box_.min_image(reference_center(b_, s, t) - reference_center(b_, l, t));
  const Vec3 dv = reference_velocity(b_, s) - reference_velocity(b_, l);
  const double R = rl + rsph + rs + rc + 2.0 * delta_;
  double enter, leave;
  const bool window = sphere_window(dx, dv, R, &enter, &leave);
  // The gap at t. A window that is closed or opens later means it exceeds
  // 2 delta (the window's radius includes rc + 2 delta): no need to evaluate it.
  double g = !window || enter > 0.0 ? kNever : capture_gap(l, end, s, t, rc);
  // Outside the shell by more than 2 delta now: a refused capture has left it.
  if (now && g > 2.0 * delta_) forget_refused(l, end, s);
  if (!window) {
    proven_until_ = closed_window_end(box_, dx, dv, R, t, 0.0);
    image_closed_ = true;
    return kNever;
  }
  ++counts_.capture_searches;
  // A search that reaches `stop` below the limit ends on the closed window.
  image_closed_ = t + leave < limit;
  if (image_closed_) proven_until_ = closed_window_end(box_, dx, dv, R, t, leave);
  const double stop = std::min(limit, t + leave);
  // The gap is the distance from a point to a moving rigid set (point or
  // disk), less constants: it changes no faster than the point plus the
  // set's fastest point (the disk's spin about its own axis leaves it whole).
  const double bound = dv.norm() + point_rotation_bound(b_, l, arm) + point_rotation_bound(b_, s, 0.0);
  if (bound == 0.0) return kNever;
  const double floor_step = min_step(bound);
  double x = t;
  // The gap's rate at x along the line from the site's closest point q to
  // the sphere's centre (negative: closing). For a distance to a convex set
  // that line is the gradient, so the rate is the relative velocity of the
  // two material points along it.
  auto closing = [&](double at, const CaptureGeometry& cg) {
    const Vec3 n = (cg.cs - cg.q).normalized();
    return n.dot(shape_point_velocity(b_, s, at, cg.cs, cg.cs) - shape_point_velocity(b_, l, at, cg.q, cg.cl)) < 0.0;
  };
  // In the firing band and closing, not refused: the gap entered the band
  // since the last search (which stopped short of its capture), fire now.
  if (g <= delta_ && !(now && refused(l, end, s)) && closing(x, capture_geometry(l, end, s, x, rc))) return x;
  // Otherwise inside the shell or its firing band: first find the way out (to
  // beyond 2 delta, the hysteresis that keeps a refused capture from firing
  // again).
  for (int step = 0; g <= (step == 0 ? delta_ : 2.0 * delta_); ++step) {
    if (step == kMaxSteps) {
      fail("capture (leaving the shell)", l, s, t, x, g, bound);
      return kNever;
    }
    x += std::max((2.0 * delta_ - g) / bound, floor_step);
    if (x >= stop) return kNever;
    ++ca_iterations_;
    ++counts_.capture;
    g = capture_gap(l, end, s, x, rc);
  }
  x = std::max(x, t + enter);
  for (int step = 0; step < kMaxSteps; ++step) {
    if (x >= stop) return kNever;
    ++ca_iterations_;
    ++counts_.capture;
    const CaptureGeometry cg = capture_geometry(l, end, s, x, rc);
    g = cg.gap;
    if (g <= delta_) {
      // In the firing band: a capture if the gap is closing.
      if (closing(x, cg)) return x;
      x += floor_step;
      continue;
    }
    double advance_by = std::max((g - 0.5 * delta_) / bound, floor_step);
    if (x + advance_by < stop) {
      // The gap along the present direction n from the site's closest point
      // q to the sphere's centre bounds it from below. End point (q = p):
      // |c_S - p| >= n.(c_S - p). End face: every point of the disk lies
      // within n.p + r_L |n x u| along n (its support), so
      //   dist(c_S, disk) >= n.(c_S - p) - r_L |n x u|,
      // with equality now (n lies in the plane of u and q - p). Each point
      // follows its first-order motion within a quadratic remainder
      // (PointMotion), and so does the axis: u(x + tau) = u + tau omega x u
      // + e, |e| <= accel tau^2 / 2 (LocalMotion), so |n x u| grows at most
      // by tau |n x (omega x u)| + accel tau^2 / 2. Together a concave
      // quadratic lower bound of the gap.
      const Vec3 n = (cg.cs - cg.q).normalized();
      const PointMotion mp = point_motion(b_, l, x, cg.p, cg.cl + (reference_center(b_, l, x) - cg.cl));
      const PointMotion ms =
          point_motion(b_, s, x, cg.cs, cg.cs + (reference_center(b_, s, x) - body_center(b_, s, x)));
      double a = n.dot(cg.cs - cg.p) - rs - rc, rate = n.dot(ms.vel - mp.vel), quad = mp.quad + ms.quad;
      if (face) {
        const LocalMotion lm = local_motion(b_, l, x);
        a -= r_face * cross_norm(n, cg.axis);
        rate -= r_face * cross_norm(n, lm.omega.cross(cg.axis));
        quad += 0.5 * r_face * lm.accel;
      }
      advance_by = std::max(advance_by, quadratic_reach(a, rate, quad, 0.5 * delta_));
    }
    x += advance_by;
  }
  fail("capture", l, s, t, x, capture_gap(l, end, s, x, rc), bound);
  return kNever;
}

}  // namespace ringsim
