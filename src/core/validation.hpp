#pragma once
// Validation mode: whole-state invariant checks after every event (DynamO's
// checkSystem, Box2D's B2_VALIDATE). Independent of the simulator's own
// machinery: overlaps are found with a fresh spatial hash and FCL's collision
// test (not the simulator's distance code), and conservation is checked
// against the totals at t = 0 plus the impulses the walls delivered.
//
// Reported quantities (relative):
//  - overlaps: pairs whose solids, each shrunk by `slack`, intersect;
//  - momentum: |P - P0 - J_walls| / sum_i m_i |v_i|(0);
//  - angular momentum (reflective boxes only; periodic images break it):
//    |L - L0 - M_walls| / sum_i (|x_i| m_i |v_i| + |L_i|)(0), about the origin;
//  - energy (only meaningful when every restitution is 1, contacts are
//    smooth and bonding is off): |E - E0| / E0; otherwise the largest
//    relative *increase* (a rigid bond is a perfectly inelastic merge).
//  - missed captures (bonding on): pairs of a free linker end and a sphere
//    below its valency, not held together (one rigid cluster, a bonded
//    neighbour), whose capture gap, computed by search
//    (geom::point_disk_distance_search, or the plain point distance with
//    bonding.capture_site = end_point), lies below r_c by more than
//    kMissedCaptureMargin without a refusal on record: such a pair crossed r_c
//    without a capture event;
//  - axis length: the largest | |u| - 1 | of a linker's axis (the geometry
//    takes every axis as a unit vector; a rigid cluster keeps its members'
//    axes for good, so an error here would persist).

#include <cstdint>
#include <vector>

#include "core/params.hpp"
#include "core/vec.hpp"

namespace ringsim {

class Simulation;

struct ValidationReport {
  std::int64_t checks = 0;
  std::int64_t overlaps = 0;          // summed over checks
  // Relative to the larger of the initial sum |p_i| (sum |L_i|) and the most
  // that the initial energy could carry (Validator's constructor).
  double max_momentum_error = 0.0;
  double max_angular_momentum_error = 0.0;
  double max_energy_error = 0.0;      // elastic: |dE|/E0; inelastic: max(0, dE)/E0
  double max_axis_error = 0.0;        // max over checks and linkers of | |u| - 1 |
  double first_overlap_time = -1.0;
  std::int64_t missed_captures = 0;   // summed over checks
  double first_missed_capture_time = -1.0;
};

class Validator {
 public:
  Validator(const Simulation& sim, double slack = 1e-9);
  void check(const Simulation& sim, double t);
  const ValidationReport& report() const { return report_; }
  bool energy_conserving() const { return elastic_; }

  // Totals of the current state at time t (bodies advanced on copies).
  struct Totals { Vec3 momentum; Vec3 angular_momentum; double energy; double p_scale; double l_scale; };
  static Totals totals(const Simulation& sim, double t);
  // *max_axis_error (optional): raised to the largest | |u| - 1 | of a linker
  // axis among the poses it evaluates.
  static std::int64_t count_overlaps(const Simulation& sim, double t, double slack, double* max_axis_error = nullptr);
  // Pairs inside the capture shell that should have been captured (see
  // above), with the gap measured at `site` (the run's own, or another one
  // for tests). A pair is near when its centres are within the linker's
  // bounding radius + r_S + r_c.
  static std::int64_t count_missed_captures(const Simulation& sim, double t, CaptureSite site);
  // How far below r_c a gap must be to count (a capture fires at most
  // delta = 1e-9 above it and the gap then goes on falling, so any pair that
  // went through the event is bonded or refused long before this).
  static constexpr double kMissedCaptureMargin = 1e-7;

 private:
  // Centres (wrapped) and axes of every body at one time.
  struct Poses {
    std::vector<Vec3> x, u;
  };
  static Poses poses_at(const Simulation& sim, double t);
  static std::int64_t count_overlaps(const Simulation& sim, const Poses& poses, double slack, double* max_axis_error);
  static std::int64_t count_missed_captures(const Simulation& sim, const Poses& poses, CaptureSite site);

  double slack_;
  bool elastic_;
  double p_scale_ = 0.0, l_scale_ = 0.0;  // what the errors are relative to
  Totals initial_;
  ValidationReport report_;
};

}  // namespace ringsim
