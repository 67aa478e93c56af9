#pragma once
// Event prediction: when will two bodies touch, or a body hit a wall?
//
// - sphere-sphere, sphere-wall: closed form (a quadratic / a linear equation);
//   contact at zero gap.
// - every pair involving a linker, linker-wall: conservative advancement
//   (Mirtich 1996; Zhang, Lee, Kim & Manocha 2006) on the exact distance
//   function d(t). Over a step h, d can fall by at most B h, where B bounds the
//   rate of approach of any two surface points:
//       B = |v_B - v_A| + s_A + s_B,
//   s = |Omega| (h sin(psi) + r) the largest speed of a linker's surface due to
//   its rotation (core/motion.hpp). Stepping by (d - delta/2) / B can never
//   step through a contact, and the search stops at the first time with
//   d <= delta (the contact tolerance, run.contact_tolerance) and an approach
//   rate n.(u_B - u_A) < 0. A search is restricted to the one interval in
//   which the bounding spheres overlap (their centres move on straight lines)
//   and to the caller's horizon (the body's current earliest event), which is
//   what keeps it cheap. Every step may be lengthened by a swept-support
//   bound (prediction_windows.hpp): a concave lower bound of the plane value
//   along the closest points' normal, from each body's first-order rotation
//   at its present angular velocity plus a Taylor remainder (core/pose.hpp,
//   LocalMotion). There is no iteration cap that can miss a contact: a
//   search that cannot finish reports failure and the replicate stops with an
//   error.
//   Far from contact (a certified lower bound above capsule_far()), linker
//   pairs step from the distance of the capsules around the cylinders plus a
//   separating plane (bound_geometry) instead of the exact distance; the
//   exact distance takes over below it, and only it fires contacts.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "core/body.hpp"
#include "core/geometry.hpp"
#include "core/params.hpp"
#include "core/separating_plane.hpp"

namespace ringsim {

inline constexpr double kNever = std::numeric_limits<double>::infinity();

struct Box {
  double length;
  bool periodic;
  // Minimum image of a separation. Free bodies' centres stay within [0, L)
  // up to the motion since their last cell event (they wrap when they cross
  // the box face), so one conditional shift per component usually suffices.
  // A rigid cluster's centre of mass is wrapped only when it takes an impulse
  // (core/cluster.cpp): in free flight it, and its members' centres, move on
  // without bound, so a separation still out of range after the shift is
  // reduced by the nearest multiple of L.
  Vec3 min_image(Vec3 d) const {
    if (periodic) {
      const double half = 0.5 * length;
      for (int k = 0; k < 3; ++k) {
        if (d[k] > half) {
          d[k] -= length;
          if (d[k] > half) d[k] -= length * std::nearbyint(d[k] / length);
        } else if (d[k] < -half) {
          d[k] += length;
          if (d[k] < -half) d[k] -= length * std::nearbyint(d[k] / length);
        }
      }
    }
    return d;
  }
};

// Time until two spheres with centre distance sigma at contact first touch,
// from relative position dx and relative velocity dv (B minus A): the
// smaller root of |dx + dv s| = sigma, in the cancellation-free form
// c / (-b + sqrt(b^2 - a c)); 0 if touching and approaching, infinity if they
// do not approach or miss. The first form takes b = dx.dv, c = |dx|^2 -
// sigma^2 and vv = |dv|^2 (the gas's scalar pair loop computes these itself).
inline double sphere_touch_time(double b, double c, double vv) {
  if (b >= 0.0) return kNever;  // not approaching
  if (c <= 0.0) return 0.0;     // touching (rounding) and approaching
  const double disc = b * b - vv * c;
  if (disc < 0.0) return kNever;
  return c / (-b + std::sqrt(disc));
}
inline double sphere_touch_time(const Vec3& dx, const Vec3& dv, double sigma) {
  return sphere_touch_time(dx.dot(dv), dx.squaredNorm() - sigma * sigma, dv.squaredNorm());
}

// Geometry of a contact between bodies a and b at time t, in a's image frame.
struct ContactGeometry {
  geom::Separation sep;  // A = body a, B = body b
  Vec3 center_a;
  Vec3 center_b;         // minimum image relative to center_a
  bool certified = true; // distance proven by the solver (else: FCL's estimate)
  // false (bound_geometry): sep is the separation of the two linkers'
  // capsules, its distance raised to the cylinders' separating-plane value
  // along the capsules' normal if larger: a lower bound of the distance, not
  // the distance. Its points are not on the solids. It may step a search but
  // never fire a contact or set a contact frame.
  bool exact = true;
  // The linkers' axes at the geometry's time (a sphere's entry is unused):
  // every plane value, feature normal and contact frame at that time needs
  // them, and body_axis evaluates a turning axis anew for each new time.
  Vec3 axis_a = Vec3::UnitZ();
  Vec3 axis_b = Vec3::UnitZ();
};

struct ContactFrame {
  Vec3 normal;  // unit, A to B
  Vec3 point;   // where the impulse acts
};

struct WallHit {
  double time = kNever;
  int dim = 0;
  int dir = 0;  // +1: wall at L, -1: wall at 0
};

class Predictor {
 public:
  // min_separation_speed: the response's separation floor
  // (run.min_separation_speed; wall_contact).
  Predictor(const BodyStore& bodies, Box box, double contact_tolerance, double min_separation_speed = 0.0)
      : b_(bodies), box_(box), delta_(contact_tolerance), min_separation_(min_separation_speed) {}

  // Earliest contact of i and j in [t, limit); kNever if none. xi is body i's
  // centre at t (hoisted out of the caller's neighbour loop).
  double pair(int i, int j, double t, double limit, const Vec3& xi);
  // When the bounding spheres of i and j (plus delta) first overlap, from t;
  // kNever if they never do. No contact can happen before it. i's part (its
  // reference point xi at t, its velocity and radius) is computed once for a
  // neighbour loop: window_self(i, xi).
  struct WindowSelf {
    Vec3 x, v;
    double radius;
  };
  WindowSelf window_self(int i, const Vec3& xi) const;
  double window_enter(const WindowSelf& self, int j, double t) const;
  // Earliest time >= t at which i and j can touch judged by their centres
  // alone (self: window_self(i, .) at t; ci: i's centre at t): each centre moves with its reference point
  // (a rigid member: its cluster's centre of mass) and strays from that
  // straight line at most at point_rotation_bound(., 0) (cone_reach in
  // prediction_windows.hpp), and each solid lies within its bounding radius
  // of its centre. Much later than window_enter for members far from their
  // cluster's centre that turn slowly. t (no bound) for compliant members,
  // and in a periodic box whose windows are not image-safe; there, on the
  // window's image.
  double cone_enter(int i, const WindowSelf& self, const Vec3& ci, int j, double t) const;
  // Windows of radius at most this need no look at other periodic images in
  // window_enter: the caller's limits keep the relative motion in a search
  // shorter than the way to another image (Simulation, with the partner
  // horizon). -infinity (the default): always look.
  void set_image_safe_radius(double r) { image_safe_radius_ = r; }
  // Earliest wall contact of i in [t, limit) (reflective boxes).
  WallHit wall(int i, double t, double limit);

  // Earliest time in [t, limit) at which the centre of cluster member i leaves
  // the cell [lo, lo + w]^3 (periodic boxes: its wrapped centre); kNever if none.
  // Fires between 1/2 and 3/4 of cell_slack() outside a face.
  double leave_cell(int i, double t, double limit, const Vec3& lo, double w);
  // How far a member's centre may stray outside its cell; the cells are made
  // this much wider on each side (Simulation), so neighbour search stays exact.
  static constexpr double cell_slack() { return 0.01; }

  // Where capture gaps are measured (bonding.capture_site); EndFace unless set.
  void set_capture_site(CaptureSite site) { capture_site_ = site; }
  CaptureSite capture_site() const { return capture_site_; }
  // Capture (MODEL.md, "Capture and bond formation"): earliest time in
  // [t, limit) at which the capture gap g between end `end` of linker l and
  // sphere s falls through `rc`, i.e. g <= rc + delta while decreasing. The
  // end is the face centred at p = x + h u (end 0) or x - h u (end 1), normal
  // +-u; g = dist(x_S, face disk) - r_S (EndFace) or |p - x_S| - r_S
  // (EndPoint). Hysteresis: a pair
  // whose capture was refused (capture_refused) must leave the shell
  // (g > rc + 2 delta) before it can fire again. Any other pair that starts in
  // the firing band closing fires at t: the search was re-started (a cell
  // crossing, a partner's event) between the gap's entry into the band and
  // the capture predicted before it.
  double capture(int l, int end, int s, double t, double limit, double rc);
  // The rules refused the capture of end `end` of l by s (or a pair already
  // inside the shell at t = 0 or at a merge): it may fire again only after
  // the end has left the shell; forgotten by the first search of the pair
  // that starts outside it.
  void capture_refused(int l, int end, int s);
  // Capture gap g - rc at t (minimum image).
  double capture_gap(int l, int end, int s, double t, double rc) const;
  // The pair's capture geometry at t: the face centre p, the closest point q
  // of the capture site (q = p with EndPoint), the sphere's centre cs in q's
  // periodic image, the linker's centre cl, and g - rc = |cs - q| - r_S - rc.
  struct CaptureGeometry {
    Vec3 p, q, cs, cl, axis;
    double gap;
  };
  CaptureGeometry capture_geometry(int l, int end, int s, double t, double rc) const;
  // The farthest point of a linker's capture site from its centre: the end
  // point at h, or the face's rim at sqrt(h^2 + r_L^2), its bounding radius
  // (the windows of capture searches, the interaction range).
  static double capture_arm(const Species& linker, CaptureSite site);
  // Whether a refused capture of end `end` of l by s is still waiting for
  // the end to leave the shell (validation's missed-capture check).
  bool capture_is_refused(int l, int end, int s) const { return refused(l, end, s); }

  ContactGeometry contact_geometry(int i, int j, double t) const;
  // For a search step: contact_geometry, unless both are linkers whose lower
  // bound below exceeds `far`; then that bound, with exact = false: the
  // capsules' separation (geom::capsule_capsule; a cylinder lies inside its
  // capsule, so their distance is a lower bound), raised to the cylinders'
  // separating-plane value along the capsules' normal (weak duality). About
  // 20x cheaper than the exact distance.
  ContactGeometry bound_geometry(int i, int j, double t, double far) const;
  // Contact normal (A to B) and point for the impulse: among the solver's
  // normal and the well-conditioned feature normals (face axis, lateral radial
  // direction, rim-tangent cross product for rim-rim contacts), the one with
  // the largest separation; a rim point against a lateral surface is polished
  // to the exact closest point. The line of action then meets the axis of each
  // cylinder, so smooth contacts leave the spin about the axis unchanged.
  ContactFrame contact_frame(int i, int j, double t, const ContactGeometry& g) const;
  // Rate of change of the gap at the contact (negative: approaching).
  double approach_rate(int i, int j, double t, const ContactGeometry& g) const;

  // Contact with a wall of outward normal n (from the body to the wall), of
  // a body in the contact band: whether it fires (a touching point approaches
  // and the wall's response will act on it), and the point the response
  // uses (optional).
  bool wall_contact(int i, double t, const Vec3& n, Vec3* point) const;

  std::uint64_t ca_iterations() const { return ca_iterations_; }
  // Distance evaluations by kind of search (all included in ca_iterations).
  struct SearchCounts {
    std::uint64_t capture = 0, cluster_pair = 0, cluster_wall = 0, cell = 0;  // evaluations
    std::uint64_t capture_searches = 0, cluster_pair_searches = 0;             // searches started
    std::uint64_t cluster_pair_capsule = 0;  // cluster_pair steps taken from the capsule bound
    std::uint64_t pair_capsule = 0;          // free pairs' steps taken from the capsule bound
  };
  const SearchCounts& search_counts() const { return counts_; }
  long plane_evaluations() const { return plane_evaluations_; }
  bool failed() const { return failed_; }
  // After failed(): which search, of which bodies, from when to where, at
  // what gap and rate bound (for the error message of the replicate).
  const std::string& failure() const { return failure_; }
  // After pair() found no contact before its limit: no contact before this
  // time either (>= the limit; infinity when the bounding spheres never meet
  // again in a closed box, or the pair never touches). A search stops at the
  // first step that reaches its limit, and that step is certified to its end,
  // so the proof often reaches beyond the limit; the pair memo
  // (Simulation::memo_pair) keeps it, so a later prediction with a later
  // horizon resumes from there. In a periodic box a closed window proves the
  // pair free only until another image can come back (ImageReturn); with no
  // limit (kNever) the proof may end there, below the limit. (Two free
  // spheres, a closed form on the minimum image, are not for the memo.)
  double proven_until() const { return proven_until_; }

  // Safety net against a search that cannot converge (it reports, never skips).
  static constexpr int kMaxSteps = 10'000'000;

 private:
  // Smallest step of a search: delta / (100 B). It keeps time representable
  // (a certified step can fall below one ulp of t inside the contact band)
  // and lets a gap close by at most delta / 100 before a contact fires.
  double min_step(double bound) const { return delta_ / (100.0 * bound); }
  // Lower bound above which linker pairs step from the capsule bound instead
  // of the exact distance (bound_geometry; 0.02 measured, docs/PERFORMANCE.md).
  // Never below 1e3 delta, where the steps switch to the ranked feature
  // normals, so no contact can fire from the bound.
  double capsule_far() const { return std::max(kCapsuleFar, 1e3 * delta_); }
  static constexpr double kCapsuleFar = 0.02;
  // Below this distance the cluster pair search (advance_generic) tries the
  // planes that follow a resting contact (crossed axes, a plane turning with
  // a linker); 1e5 delta, never beyond the exact distances (capsule_far).
  double plane_band() const { return std::min(kPlaneBand * delta_, capsule_far()); }
  static constexpr double kPlaneBand = 1e5;
  // Two free spheres: their first contact at or after t, closed form (xi:
  // i's centre at t); kNever if none. In a periodic box exact up to `limit`
  // on every image (beyond it, on the minimum image of t only).
  double sphere_sphere(int i, int j, double t, const Vec3& xi, double limit) const;
  double advance_pair(int i, int j, double t, double limit);
  bool wall_window(double x, double v, int dir, double reach, double t, double* start, double* end) const;
  // Pairs and walls with a cluster member: plain conservative advancement with
  // the reference-motion bounds of core/pose.hpp.
  double advance_generic(int i, int j, double t, double limit);
  // capture() on the minimum image of t (sets image_closed_, proven_until_
  // as the pair searches do).
  // `now`: the search starts at the caller's time (not at the end of an
  // earlier image's proof), where the hysteresis state applies.
  double capture_on_image(int l, int end, int s, double t, double limit, double rc, bool now);
  bool refused(int l, int end, int s) const;
  void forget_refused(int l, int end, int s);
  // A search on the minimum image of its start, search(from), run again from
  // where its proof ends while it ends on a window closed before `limit`: in a
  // periodic box another image can come back (ImageReturn). With no limit at
  // all the proof stops there; the other body, which moves, has a finite one.
  template <class Search>
  double across_images(double t, double limit, Search search) {
    double tc = search(t);
    while (tc == kNever && image_closed_ && proven_until_ < limit && proven_until_ > t && limit < kNever && !failed_) {
      t = proven_until_;
      tc = search(t);
    }
    return tc;
  }
  WallHit wall_generic(int i, double t, double limit);
  // Candidate normals at a contact geometry, with their plane values: the
  // solver's normal, the feature normals of i (owner 1) and of j (owner 2), the
  // rim-tangent cross product (owner 0). best: the largest value; feature: the
  // largest among the feature normals (-1 if none).
  struct RankedNormals {
    Vec3 normal[4];
    int owner[4];
    double value[4];
    int count = 0, best = 0, feature = -1;
  };
  // Marks the search as failed and says what it was: `what` names the search
  // ("pair", "cluster pair", "wall", "cluster wall", "cell exit", "capture");
  // j < 0 when there is no partner; gap < 0 when not known.
  void fail(const char* what, int i, int j, double t, double reached, double gap, double bound);
  ContactFrame on_axis_planes(int i, int j, double t, const ContactGeometry& g, ContactFrame frame) const;
  RankedNormals rank_normals(int i, int j, double t, const ContactGeometry& g) const;
  double plane_value(int i, int j, const ContactGeometry& g, const Vec3& n) const;  // at g's time
  SeparatingPlane plane_along(int i, int j, double t, const ContactGeometry& g, const Vec3& n) const;

  const BodyStore& b_;
  Box box_;
  double delta_;
  double min_separation_;  // the separation floor (wall_contact)
  CaptureSite capture_site_ = CaptureSite::EndFace;
  std::uint64_t ca_iterations_ = 0;
  SearchCounts counts_;
  long plane_evaluations_ = 0;
  bool failed_ = false;
  std::string failure_;
  double proven_until_ = 0.0;
  // The last pair search ended on a window closed on its minimum image, so
  // proven_until_ may stop short of its limit (periodic box, ImageReturn).
  bool image_closed_ = false;
  double image_safe_radius_ = -kNever;
  // Refused captures still inside their shell: sphere ids per linker end
  // (index 2 l + end), almost always empty.
  std::vector<std::vector<int>> refused_;
};

}  // namespace ringsim
