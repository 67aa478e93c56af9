#include "core/validation.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <vector>

#include "core/geometry.hpp"
#include "core/cluster.hpp"
#include "core/motion.hpp"
#include "core/pose.hpp"
#include "core/simulation.hpp"

namespace ringsim {
namespace {

// f(i, j), i < j, for every pair of points x (wrapped into the box) whose
// cells of width >= w are neighbours: a fresh spatial hash, sharing nothing
// with the simulator's grid. Pairs closer than w are all among them.
template <class F>
void for_each_close_pair(const std::vector<Vec3>& x, const Box& box, double w, F f) {
  const int n = static_cast<int>(x.size());
  int m = std::max(1, static_cast<int>(box.length / w));
  if (m < 3) m = 1;  // one cell: all pairs, and no periodic neighbour is seen twice
  const int reach_cells = m >= 3 ? 1 : 0;
  auto key = [&](int a, int c, int d) { return (static_cast<long long>(a) * m + c) * m + d; };
  std::unordered_map<long long, std::vector<int>> cells;
  auto coord = [&](double v) { return std::clamp(static_cast<int>(std::floor(v / box.length * m)), 0, m - 1); };
  for (int i = 0; i < n; ++i) cells[key(coord(x[i][0]), coord(x[i][1]), coord(x[i][2]))].push_back(i);
  for (int i = 0; i < n; ++i) {
    const int cx = coord(x[i][0]), cy = coord(x[i][1]), cz = coord(x[i][2]);
    for (int dx = -reach_cells; dx <= reach_cells; ++dx)
      for (int dy = -reach_cells; dy <= reach_cells; ++dy)
        for (int dz = -reach_cells; dz <= reach_cells; ++dz) {
          int a = cx + dx, c = cy + dy, d = cz + dz;
          if (box.periodic) {
            a = (a + m) % m; c = (c + m) % m; d = (d + m) % m;
          } else if (a < 0 || c < 0 || d < 0 || a >= m || c >= m || d >= m) {
            continue;
          }
          auto it = cells.find(key(a, c, d));
          if (it == cells.end()) continue;
          for (int j : it->second)
            if (j > i) f(i, j);
        }
  }
}

}  // namespace

// Centres (wrapped into a periodic box) and axes of every body at t, computed
// once per check for both of its searches.
Validator::Poses Validator::poses_at(const Simulation& sim, double t) {
  const BodyStore& b = sim.bodies();
  const Box& box = sim.box();
  const int n = b.size();
  Poses q;
  q.x.resize(n);
  q.u.resize(n);
  for (int i = 0; i < n; ++i) {
    q.x[i] = body_center(b, i, t);
    if (box.periodic)
      for (int d = 0; d < 3; ++d) q.x[i][d] -= box.length * std::floor(q.x[i][d] / box.length);
    q.u[i] = body_axis(b, i, t);
  }
  return q;
}

Validator::Validator(const Simulation& sim, double slack) : slack_(slack) {
  const ContactParams& c = sim.params().contact;
  // A periodic box has no walls: their restitution and friction do not act.
  const bool periodic = sim.box().periodic;
  const bool walls_smooth = periodic || (c.static_friction_wall == 0 && c.dynamic_friction_wall == 0);
  const bool frictionless = c.static_friction_sphere == 0 && c.static_friction_linker == 0 && c.dynamic_friction_sphere == 0 &&
                            c.dynamic_friction_linker == 0 && walls_smooth;
  const bool walls_elastic = periodic || c.restitution_wall == 1.0;
  // Bonds are perfectly inelastic merges: with bonding, energy may only fall.
  elastic_ = frictionless && walls_elastic && c.restitution_sphere == 1.0 && c.restitution_linker == 1.0 &&
             !sim.params().bonding.enabled;
  initial_ = totals(sim, sim.time());
  // Errors are relative to the momentum and angular momentum the system can
  // carry, not only to those it starts with: bodies that start at rest and
  // spin (init.v_max = 0) have no momentum, yet collisions turn spin into
  // translation. The energy that can become motion, E (kinetic, plus the
  // compliant springs' potential), gives sum |p_i| <= sqrt(2 M E)
  // (Cauchy-Schwarz), and positions in the box give the lever, L / 2.
  const BodyStore& b = sim.bodies();
  double mass = 0.0;
  for (int i = 0; i < b.size(); ++i) mass += b.sp(i).mass;
  const double e = mechanical_totals(b, sim.time()).energy + sim.compliant_potential(sim.time());
  const double p_motion = std::sqrt(2.0 * mass * std::max(e, 0.0));
  p_scale_ = std::max(initial_.p_scale, p_motion);
  l_scale_ = std::max(initial_.l_scale, 0.5 * sim.box().length * p_motion);
}

Validator::Totals Validator::totals(const Simulation& sim, double t) {
  const MechanicalTotals m = mechanical_totals(sim.bodies(), t);
  // Compliant bonds: kinetic plus the springs' potential energy, less what
  // bonds brought in when they formed (stretched at the capture distance);
  // damping, inelastic merges and contacts may only lower it.
  const double energy = m.energy + sim.compliant_potential(t) - sim.bond_energy();
  return Totals{m.momentum, m.angular_momentum, energy, m.p_scale, m.l_scale};
}

std::int64_t Validator::count_overlaps(const Simulation& sim, double t, double slack, double* max_axis_error) {
  return count_overlaps(sim, poses_at(sim, t), slack, max_axis_error);
}

std::int64_t Validator::count_overlaps(const Simulation& sim, const Poses& poses, double slack, double* max_axis_error) {
  const BodyStore& b = sim.bodies();
  const Box& box = sim.box();
  const int n = b.size();
  double rmax = 0.0;
  const std::vector<Vec3>&x = poses.x, &u = poses.u;
  for (int i = 0; i < n; ++i) {
    if (max_axis_error && b.shape[i] == Shape::Linker)
      *max_axis_error = std::max(*max_axis_error, std::abs(u[i].norm() - 1.0));
    rmax = std::max(rmax, b.sp(i).bounding_radius);
  }
  std::int64_t overlaps = 0;
  for_each_close_pair(x, box, 2.0 * rmax, [&](int i, int j) {
    // One rigid cluster: frozen relative pose, bonded neighbours may
    // touch by construction (1-2 and 1-3 exclusions).
    if (b.group[i] >= 0 && b.group[i] == b.group[j]) return;
    // One compliant cluster: its bodies move relative to each other,
    // only bonded neighbours are excluded.
    if (b.cgroup[i] >= 0 && b.cgroup[i] == b.cgroup[j] && sim.contact_excluded(i, j)) return;
    const Species &si = b.sp(i), &sj = b.sp(j);
    const Vec3 xj = x[i] + box.min_image(x[j] - x[i]);
    const double reach = si.bounding_radius + sj.bounding_radius;
    if ((xj - x[i]).squaredNorm() >= reach * reach) return;
    bool hit;
    if (si.shape == Shape::Sphere && sj.shape == Shape::Sphere) {
      hit = (xj - x[i]).norm() < si.radius + sj.radius - 2.0 * slack;
    } else if (si.shape == Shape::Sphere) {
      hit = geom::fcl_sphere_cylinder_overlap(x[i], si.radius, {xj, u[j], sj.radius, sj.half_length}, slack);
    } else if (sj.shape == Shape::Sphere) {
      hit = geom::fcl_sphere_cylinder_overlap(xj, sj.radius, {x[i], u[i], si.radius, si.half_length}, slack);
    } else {
      hit = geom::fcl_cylinders_overlap({x[i], u[i], si.radius, si.half_length}, {xj, u[j], sj.radius, sj.half_length}, slack);
    }
    overlaps += hit;
  });
  // Walls (reflective): the solid must stay inside the box.
  if (!box.periodic) {
    for (int i = 0; i < n; ++i) {
      const Species& s = b.sp(i);
      for (int d = 0; d < 3; ++d) {
        Vec3 e = Vec3::Zero();
        e[d] = 1.0;
        const double ext = s.shape == Shape::Sphere ? s.radius : geom::cylinder_support({x[i], u[i], s.radius, s.half_length}, e);
        if (x[i][d] - ext < -slack || x[i][d] + ext > box.length + slack) ++overlaps;
      }
    }
  }
  return overlaps;
}

std::int64_t Validator::count_missed_captures(const Simulation& sim, double t, CaptureSite site) {
  return count_missed_captures(sim, poses_at(sim, t), site);
}

std::int64_t Validator::count_missed_captures(const Simulation& sim, const Poses& poses, CaptureSite site) {
  const SimParams& p = sim.params();
  if (!p.bonding.enabled || p.bonding.end_valency < 1) return 0;
  const BodyStore& b = sim.bodies();
  const BondGraph& graph = sim.graph();
  const Box& box = sim.box();
  const double rc = p.bonding.capture_distance;
  const std::vector<Vec3>&x = poses.x, &u = poses.u;
  double reach = 0.0;  // the largest sphere-linker centre distance at a capture
  for (int i = 0; i < b.size(); ++i) reach = std::max(reach, b.sp(i).bounding_radius);
  reach = 2.0 * reach + rc;
  std::int64_t missed = 0;
  for_each_close_pair(x, box, reach, [&](int i, int j) {
    if ((b.shape[i] == Shape::Sphere) == (b.shape[j] == Shape::Sphere)) return;
    const int s = b.shape[i] == Shape::Sphere ? i : j, l = s == i ? j : i;
    if (graph.degree(s) >= p.bonding.sphere_valency) return;
    if (b.group[s] >= 0 && b.group[s] == b.group[l]) return;
    if (b.cgroup[s] >= 0 && b.cgroup[s] == b.cgroup[l] && sim.contact_excluded(s, l)) return;
    const Species& sl = b.sp(l);
    const double rs = b.sp(s).radius;
    const Vec3 d = box.min_image(x[s] - x[l]);
    if (d.norm() > sl.bounding_radius + rs + rc) return;
    const Vec3 cs = x[l] + d;
    for (int e = 0; e < 2; ++e) {
      if (graph.sphere_of(l, e) >= 0 || sim.capture_refused(l, e, s)) continue;
      const Vec3 face = x[l] + (e == 0 ? sl.half_length : -sl.half_length) * u[l];
      const double dist = site == CaptureSite::EndFace ? geom::point_disk_distance_search(cs, face, u[l], sl.radius)
                                                       : (cs - face).norm();
      missed += dist - rs < rc - kMissedCaptureMargin;
    }
  });
  return missed;
}

void Validator::check(const Simulation& sim, double t) {
  ++report_.checks;
  const Poses poses = poses_at(sim, t);
  const std::int64_t ov = count_overlaps(sim, poses, slack_, &report_.max_axis_error);
  if (ov > 0 && report_.overlaps == 0) report_.first_overlap_time = t;
  report_.overlaps += ov;
  const std::int64_t missed = count_missed_captures(sim, poses, sim.params().bonding.capture_site);
  if (missed > 0 && report_.missed_captures == 0) report_.first_missed_capture_time = t;
  report_.missed_captures += missed;
  const Totals now = totals(sim, t);
  const Vec3 dp = now.momentum - initial_.momentum - sim.external_impulse();
  report_.max_momentum_error = std::max(report_.max_momentum_error, dp.norm() / std::max(p_scale_, 1e-300));
  if (!sim.box().periodic) {
    const Vec3 dl = now.angular_momentum - initial_.angular_momentum - sim.external_angular_impulse();
    report_.max_angular_momentum_error = std::max(report_.max_angular_momentum_error, dl.norm() / std::max(l_scale_, 1e-300));
  }
  const double de = (now.energy - initial_.energy) / std::max(initial_.energy, 1e-300);
  report_.max_energy_error = std::max(report_.max_energy_error, elastic_ ? std::abs(de) : std::max(0.0, de));
}

}  // namespace ringsim
