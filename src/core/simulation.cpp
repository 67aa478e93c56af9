#include "core/simulation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "core/bond_rules.hpp"
#include "core/cluster.hpp"
#include "core/contact.hpp"
#include "core/interaction_range.hpp"
#include "core/joint_impulses.hpp"
#include "core/pose.hpp"
#include "core/motion.hpp"
#include "core/validation.hpp"

namespace ringsim {

const char* to_string(Termination t) {
  switch (t) {
    case Termination::Running: return "running";
    case Termination::TimeLimit: return "t_max";
    case Termination::SteadyState: return "steady_state";
    case Termination::NoBondPossible: return "no_bond_possible";
    case Termination::EventBudget: return "event_budget";
    case Termination::Error: return "error";
    case Termination::Interrupted: return "interrupted";
  }
  return "?";
}

namespace {
// The bond graph numbers spheres first, then linkers (as build_scene does).
int count_spheres(const BodyStore& b, bool bonding) {
  int n = 0;
  while (n < b.size() && b.shape[n] == Shape::Sphere) ++n;
  for (int i = n; i < b.size(); ++i) {
    if (b.shape[i] != Shape::Sphere) continue;
    if (bonding) throw std::invalid_argument("bonding needs body ids ordered spheres first, then linkers");
    ++n;  // without bonding the graph only counts objects (all monomers)
  }
  return n;
}

const char* event_kind(EventType type) {
  switch (type) {
    case EventType::Collision: return "collision";
    case EventType::Capture: return "capture";
    case EventType::Wall: return "wall contact";
    case EventType::CellCross: return "cell crossing";
    case EventType::Slice: return "compliant slice";
    case EventType::None: break;
  }
  return "event";
}

// Why the run stops when time does (Simulation::kFrozenEvents). The remedy
// comes first: result files keep the first 100 characters of an error.
std::string frozen_time_message(const Event& ev, int body, const SimParams& p) {
  std::ostringstream out;
  out.precision(6);
  out << "time stopped at t = " << ev.time;
  if (p.run.min_separation_speed == 0.0)
    out << " (resting contact: run.min_separation_speed = 0; set it > 0, e.g. 1e-04)";
  if (p.run.tc_time == 0.0) out << " (inelastic collapse: run.tc_time = 0; set it > 0, e.g. 1e-04)";
  out << ": more than " << Simulation::kFrozenEvents << " events in a row at this instant, the last a "
      << event_kind(ev.type) << " of body " << body;
  if (ev.type == EventType::Collision || ev.type == EventType::Capture) out << " with body " << ev.partner;
  return out.str();
}
}  // namespace

Simulation::Simulation(const SimParams& params, BodyStore bodies)
    : params_(params),
      bodies_(std::move(bodies)),
      box_{params.geometry.box_length, params.geometry.boundary == Boundary::Periodic},
      queue_(make_queue(params.run.queue)),
      predictor_(bodies_, box_, params.run.contact_tolerance, params.run.min_separation_speed),
      n_spheres_(count_spheres(bodies_, params.bonding.enabled)),
      graph_(n_spheres_, bodies_.size() - n_spheres_),
      monitor_(params.run.sample_interval, static_cast<std::size_t>(params.run.mser_min_samples),
               static_cast<std::size_t>(params.run.mser_check_every), static_cast<std::size_t>(params.run.mser_batch)) {
  const int n = bodies_.size();
  // Contacts, captures and the cell slack of cluster members, of the species
  // present (core/interaction_range.hpp). Loading refuses a smaller periodic
  // box with the same function (ensemble/config.cpp); this is the safety net
  // for settings built in code.
  const InteractionRange reach = interaction_range(params, bodies_);
  const double range = reach.range();
  if (box_.periodic && !(box_.length > reach.periodic_min_box()))
    throw std::invalid_argument("geometry.box_length = " + std::to_string(box_.length) + ": must be > " +
                                std::to_string(reach.periodic_min_box()) +
                                " with geometry.boundary = periodic (twice the interaction range, minimum image)");
  predictor_.set_capture_site(params.bonding.capture_site);
  const double cell = std::max(range, params.run.cell_size);
  grid_ = CellGrid(box_.length, cell, n, box_.periodic);
  if (params.run.partner_horizon) {
    // A pair search ends by the next event of either body, and a body's next
    // event comes before its reference point has moved sqrt(3) cell widths (a
    // free body: its cell's diagonal; a member: one width, its horizon). So in
    // a search the relative motion stays below 2 sqrt(3) w, and another image,
    // at least L/2 - R away, cannot come within R when that is longer.
    const double w = grid_.cell_width();
    predictor_.set_image_safe_radius(0.5 * box_.length - 2.0 * (std::sqrt(3.0) * w + Predictor::cell_slack()) - 1e-9 * box_.length);
  }
  events_.assign(n, Event{});
  bodies_.counter.assign(n, 0);
  bodies_.last_collision.assign(n, -kNever);
  bodies_.free_all();
  articulated_ = articulated_bonds(params_);
  compliant_ = (params_.bonding.enabled && params_.compliant.enabled()) || articulated_;
  cindex_.assign(n, -1);
  memo_.assign(n, {});
  wall_memo_.assign(n, WallMemo{});
  for (int i = 0; i < n; ++i) grid_.insert(i, bodies_.kin[i].x);
  initial_energy_ = mechanical_totals(bodies_, 0.0).energy;  // every body free
  monitor_.set(0.0, graph_.N_t());
  if (params_.bonding.enabled) check_initial_captures();
  // Compliant clusters formed at t = 0 start their first slice.
  for (int g = 0; g < static_cast<int>(cgroups_.size()); ++g)
    if (cgroups_[g].alive && cgroups_[g].pending && termination_ == Termination::Running) begin_slice(g, 0.0);
  const int k_max = params_.run.sphere_candidates;
  // The gas keeps each pair's closed form from the scan that saw the pair come
  // into its neighbourhood, on the minimum image of then. In a periodic box
  // that stays right while a pair that changes images must first leave the
  // neighbourhood and re-enter it (a new scan): at least 4 cells a side. With
  // fewer, the neighbourhood is the whole box: the general path, whose closed
  // form follows the images (Predictor::sphere_sphere).
  sphere_gas_ = k_max > 0 && !params_.bonding.enabled && n_spheres_ == n &&
                (!box_.periodic || grid_.cells_per_side() >= 4);
  smooth_gas_ = sphere_gas_ && n > 0 && bodies_.sp(0).static_friction == 0.0 && bodies_.sp(0).dynamic_friction == 0.0;
  if (sphere_gas_) {
    sphere_list_.assign(static_cast<std::size_t>(n) * k_max, SphereCandidate{kNever, -1, 0});
    sphere_count_.assign(n, 0);
    sphere_floor_.assign(n, kNever);
    sphere_own_.assign(n, Event{});
  }
  queue_->reset(n);
  for (int i = 0; i < n; ++i) predict(i, 0.0);
  if (params_.bonding.enabled && termination_ == Termination::Running && !bond_possible())
    termination_ = Termination::NoBondPossible;
}

Simulation::~Simulation() = default;

Event Simulation::free_body_exit(int i, double t, const Vec3& xi) {
  Event e;
  e.type = EventType::CellCross;
  const Kinematics& k = bodies_.kin[i];
  const CellGrid::Exit ex = grid_.exit_time(grid_.cell_of_body(i), xi, k.v);
  e.time = t + ex.dt;
  e.dim = static_cast<std::int8_t>(ex.dim);
  e.dir = static_cast<std::int8_t>(ex.dir);
  // Every search of the body ends by its next event. A body that barely
  // translates leaves its cell late or never, yet a turning linker's gap to a
  // neighbour can stay small for ever (a linker spinning on the spot next to
  // a sphere at rest), and a search over such a window takes ~window / (gap /
  // rate) steps: with init.v_max = 0, tens of millions. So the body is
  // re-checked (a relocation event, as for cluster members) once its fastest
  // point could have moved kRecheckWidths cell widths. A sphere's exit always
  // comes first (it is at most sqrt(3) w / |v| away): nothing to compute on
  // the hard-sphere gas's path.
  const double speed = bodies_.shape[i] == Shape::Sphere ? 0.0 : k.v.norm() + shape_rotation_speed(k, bodies_.sp(i));
  if (speed > 0.0) {
    const double recheck = t + kRecheckWidths * grid_.cell_width() / speed;
    if (recheck < e.time) {
      e.time = recheck;
      e.dim = -1;
      e.dir = 0;
    }
  }
  take_earlier_wall(i, t, &e);
  return e;
}

void Simulation::take_earlier_wall(int i, double t, Event* e) {
  if (box_.periodic) return;
  const double limit = e->time;
  WallMemo& m = wall_memo_[i];
  WallHit w;
  // Compliant members move by slices (the search stops at the slice's end):
  // no memo for them.
  if (bodies_.cgroup[i] < 0 && m.valid && m.counter == bodies_.counter[i] && m.from <= t && m.hit.time >= t) {
    if (m.hit.time < kNever) {
      // The first contact after m.from, hence also the first after t.
      if (m.hit.time < limit) w = m.hit;
    } else if (m.until < limit) {
      w = predictor_.wall(i, m.until, limit);
      if (w.time < kNever) m.hit = w;
      else m.until = limit;
    }
  } else {
    w = predictor_.wall(i, t, limit);
    m.counter = bodies_.counter[i];
    m.valid = bodies_.cgroup[i] < 0;
    m.from = t;
    m.until = w.time < kNever ? w.time : limit;
    m.hit = w;
  }
  if (w.time < e->time) {
    e->time = w.time;
    e->type = EventType::Wall;
    e->dim = static_cast<std::int8_t>(w.dim);
    e->dir = static_cast<std::int8_t>(w.dir);
  }
}

// One body's candidate list being filled by a scan: the pair loop in scalars,
// the box's minimum image hoisted out of it (Box::min_image's arithmetic).
// The count and floor live here during the scan and are stored by commit().
struct Simulation::SphereFill {
  SphereFill(Simulation& s, int i, double time, bool reset)
      : self(i),
        t(time),
        k_max(s.params_.run.sphere_candidates),
        list(s.sphere_list(i)),
        n(reset ? 0 : s.sphere_count_[i]),
        floor(reset ? kNever : s.sphere_floor_[i]),
        periodic(s.box_.periodic),
        box(s.box_.length),
        half(0.5 * s.box_.length) {
    const Kinematics& k = s.bodies_.kin[i];
    xi = position_at(k, time);
    x0 = xi[0], x1 = xi[1], x2 = xi[2], v0 = k.v[0], v1 = k.v[1], v2 = k.v[2];
    const double sigma = 2.0 * s.bodies_.sp(i).radius;  // one species: every body is a sphere
    sigma_sq = sigma * sigma;
  }
  double wrap(double d) const { return d > half ? d - box : (d < -half ? d + box : d); }
  // Partner j (impulse counter c) at position p, velocity u at time t.
  // Inlined into each scan by force: as a call the gas benchmark ran 3 % more
  // instructions.
  [[gnu::always_inline]] void insert(int j, std::uint32_t c, const Vec3& p, const Vec3& u) {
    double d0 = p[0] - x0, d1 = p[1] - x1, d2 = p[2] - x2;
    if (periodic) {
      d0 = wrap(d0);
      d1 = wrap(d1);
      d2 = wrap(d2);
    }
    const double w0 = u[0] - v0, w1 = u[1] - v1, w2 = u[2] - v2;
    const double tc = t + sphere_touch_time(d0 * w0 + d1 * w1 + d2 * w2, d0 * d0 + d1 * d1 + d2 * d2 - sigma_sq,
                                            w0 * w0 + w1 * w1 + w2 * w2);
    if (tc >= kNever) return;
    if (n == k_max) {
      // The latest of the K + 1 leaves the list; it bounds all left out.
      if (tc >= list[n - 1].time) {
        floor = std::min(floor, tc);
        return;
      }
      floor = std::min(floor, list[n - 1].time);
      --n;
    }
    int k = n++;
    for (; k > 0 && list[k - 1].time > tc; --k) list[k] = list[k - 1];
    list[k] = SphereCandidate{tc, j, c};
  }
  void commit(Simulation& s) const {
    s.sphere_count_[self] = n;
    s.sphere_floor_[self] = floor;
  }

  int self;
  double t;
  int k_max;
  SphereCandidate* list;
  int n;
  double floor;
  bool periodic;
  double box, half;
  Vec3 xi;
  double x0, x1, x2, v0, v1, v2, sigma_sq;
};

void Simulation::predict_sphere(int i, double t, SphereScan scan, int dim, int dir) {
  if (profiling_) ++profile_.kind[profile_kind_].predictions;
  if (scan != SphereScan::Full) {
    // Drop pairs whose partner has changed trajectory.
    SphereCandidate* list = sphere_list(i);
    int& n = sphere_count_[i];
    int kept = 0;
    for (int k = 0; k < n; ++k)
      if (bodies_.counter[list[k].partner] == list[k].partner_counter) list[kept++] = list[k];
    n = kept;
  }
  SphereFill fill(*this, i, t, scan == SphereScan::Full);
  auto insert = [&](int j) {
    if (j == i) return;
    const Kinematics& kj = bodies_.kin[j];
    fill.insert(j, bodies_.counter[j], position_at(kj, t), kj.v);
  };
  if (scan == SphereScan::Full) grid_.for_each_near(grid_.cell_of_body(i), insert);
  if (scan == SphereScan::Crossing) grid_.for_each_face(grid_.cell_of_body(i), dim, dir, insert);
  fill.commit(*this);
  finish_sphere(i, t, scan, fill.xi);
}

void Simulation::predict_sphere_pair(int i, int j, double t) {
  SphereFill a(*this, i, t, true), b(*this, j, t, true);
  const bool merged =
      grid_.for_each_near_pair(grid_.cell_of_body(i), grid_.cell_of_body(j), [&](int k, bool near_i, bool near_j) {
        const Kinematics& kk = bodies_.kin[k];
        const Vec3 p = position_at(kk, t);
        const std::uint32_t c = bodies_.counter[k];
        if (near_i && k != i) a.insert(k, c, p, kk.v);
        if (near_j && k != j) b.insert(k, c, p, kk.v);
      });
  if (!merged) {
    predict_sphere(i, t, SphereScan::Full);
    predict_sphere(j, t, SphereScan::Full);
    return;
  }
  if (profiling_) profile_.kind[profile_kind_].predictions += 2;
  a.commit(*this);
  b.commit(*this);
  finish_sphere(i, t, SphereScan::Full, a.xi);
  finish_sphere(j, t, SphereScan::Full, b.xi);
}

void Simulation::finish_sphere(int i, double t, SphereScan scan, const Vec3& xi) {
  const SphereCandidate* list = sphere_list(i);
  Event& own = sphere_own_[i];
  if (scan != SphereScan::Stale) own = free_body_exit(i, t, xi);
  const double first = sphere_count_[i] > 0 ? list[0].time : kNever;
  if (std::min(first, own.time) > sphere_floor_[i]) {
    // Pairs left out of the list may come first: scan everything again.
    predict_sphere(i, t, SphereScan::Full);
    return;
  }
  Event best = own;
  if (first <= own.time) {
    best.time = first;
    best.type = EventType::Collision;
    best.partner = list[0].partner;
    best.partner_counter = list[0].partner_counter;
  }
  events_[i] = best;
  queue_->update(i, best.time);
}

void Simulation::predict(int i, double t) {
  if (sphere_gas_) {
    predict_sphere(i, t, SphereScan::Full);
    return;
  }
  const int gi = bodies_.group[i];
  const int ci = bodies_.cgroup[i];
  const Vec3 xi = reference_center(bodies_, i, t);
  if (profiling_) ++profile_.kind[profile_kind_].predictions;
  Event best;
  if (gi < 0 && ci < 0) {
    best = free_body_exit(i, t, xi);
  } else {
    best.type = EventType::CellCross;
    // A member's centre turns with its cluster: find when it leaves its cell,
    // looking ahead at most the time to cross one cell at the largest speed
    // (then a relocation event re-checks), which also bounds every search below.
    const double w = grid_.cell_width();
    const auto cc = grid_.coords(grid_.cell_of_body(i));
    const Vec3 lo(cc[0] * w, cc[1] * w, cc[2] * w);
    const double speed = reference_velocity(bodies_, i).norm() + point_rotation_bound(bodies_, i, 0.0);
    const double horizon = speed > 0.0 ? t + w / speed : kNever;
    const double slice_end = motion_horizon(bodies_, i);  // compliant: the slice's end
    best.time = std::min(horizon, predictor_.leave_cell(i, t, horizon, lo, w));
    best.dim = -1;
    best.dir = 0;
    if (slice_end <= best.time) {
      best.time = slice_end;
      best.type = EventType::Slice;
    }
    take_earlier_wall(i, t, &best);
  }
  auto consider = [&](int j, double tc) {
    if (tc < best.time) {
      best.time = tc;
      best.type = EventType::Collision;
      best.partner = j;
      best.partner_counter = bodies_.counter[j];
    }
  };
  // A pair's search (and a capture's) need not reach past the partner's
  // pending event: every event re-predicts the body that holds it, whatever
  // its kind (an impulse, a cell crossing, a stale event, a capture, a slice),
  // and that prediction covers the pair from then on. So no contact of the
  // pair before that time is missed, and the work of searching beyond it is
  // saved when the partner's trajectory changes there (docs/PREDICTION.md).
  // run.partner_horizon = false searches to i's own horizon.
  const bool partner_horizon = params_.run.partner_horizon;
  auto pair_limit = [&](int j) { return partner_horizon ? std::min(best.time, events_[j].time) : best.time; };
  // The limit may be kNever: i has no event yet (at rest: no cell exit, no
  // re-check) and j has none either (at rest too, or not yet predicted: the
  // first pass at t = 0), or j's is not used (run.partner_horizon off). A
  // linker turning next to a sphere at rest may then never touch it, and its
  // search would never end: such a pair is searched until its points could
  // have approached by kRecheckWidths cell widths, and i is re-checked there
  // (unless an earlier event comes first).
  double recheck = kNever;
  auto bounded_limit = [&](int j) {
    const double limit = pair_limit(j);
    if (limit < kNever) return limit;
    const double rate = (reference_velocity(bodies_, j) - reference_velocity(bodies_, i)).norm() +
                        rotation_bound(bodies_, i) + rotation_bound(bodies_, j);
    if (rate == 0.0) return kNever;  // a fixed relative pose: every search ends at once
    recheck = std::min(recheck, t + kRecheckWidths * grid_.cell_width() / rate);
    return recheck;
  };
  // Closed forms at once; searches (pairs with a linker) later, in order of
  // their bounding-sphere entry times, so that an early contact cuts the
  // horizon of the rest before they cost anything.
  candidates_.clear();
  const bool sphere_i = bodies_.shape[i] == Shape::Sphere;
  const bool bonding = params_.bonding.enabled;
  capture_partners_.clear();
  const Predictor::WindowSelf window_self = predictor_.window_self(i, xi);
  const Vec3 centre_i = in_cluster(bodies_, i) ? body_center(bodies_, i, t) : xi;  // (xi: a member's cluster)
  grid_.for_each_near(grid_.cell_of_body(i), [&](int j) {
    if (j == i) return;
    if (gi >= 0 && bodies_.group[j] == gi) return;  // one rigid body: no relative motion
    if (ci >= 0 && bodies_.cgroup[j] == ci && contact_excluded(i, j)) return;  // bonded neighbours
    if (bonding && sphere_i != (bodies_.shape[j] == Shape::Sphere)) capture_partners_.push_back(j);
    if (sphere_i && bodies_.shape[j] == Shape::Sphere && !in_cluster(bodies_, i) && !in_cluster(bodies_, j)) {
      consider(j, predictor_.pair(i, j, t, best.time, xi));
      return;
    }
    // j's own pending event may be this very contact, predicted while i
    // had its present trajectory (i's counter unchanged): it is exact, reuse it.
    const Event& ej = events_[j];
    if (ej.type == EventType::Collision && ej.partner == i && ej.partner_counter == bodies_.counter[i]) {
      consider(j, ej.time);
      return;
    }
    double enter = predictor_.window_enter(window_self, j, t);
    if (!(enter < pair_limit(j))) return;
    // A rigid member's centre strays from its cluster's straight line no
    // faster than the cluster turns: often a later start than the sphere it
    // sweeps round the cluster's centre (Predictor::cone_enter).
    bool cone = false;
    if (gi >= 0 || bodies_.group[j] >= 0) {
      const double c = predictor_.cone_enter(i, window_self, centre_i, j, t);
      if (c > enter) {
        enter = c;
        cone = true;
        if (!(enter < pair_limit(j))) return;
      }
    }
    candidates_.push_back({enter, j, cone});
  });
  std::sort(candidates_.begin(), candidates_.end());
  memo_scratch_.clear();
  for (const Candidate& c : candidates_) {
    if (c.enter >= best.time) break;
    const double limit = bounded_limit(c.j);
    if (c.enter < limit) consider(c.j, memo_pair(i, c.j, t, limit, xi, c.cone ? c.enter : t));
  }
  memo_[i].swap(memo_scratch_);
  // Captures: only pairs that could still bond (a free end, a sphere with a
  // free valency, in different groups).
  const BondingParams& bp = params_.bonding;
  for (int j : capture_partners_) {
    const int l = sphere_i ? j : i, s = sphere_i ? i : j;
    if (graph_.degree(s) >= bp.sphere_valency || bp.end_valency < 1) continue;
    const double limit = bounded_limit(j);
    if (limit <= t) continue;  // j is re-predicted at t and covers the pair
    for (int e = 0; e < 2; ++e) {
      if (graph_.end_bonded(l, e)) continue;
      if (profiling_) ++profile_.kind[profile_kind_].capture_searches;
      const double tc = predictor_.capture(l, e, s, t, limit, bp.capture_distance);
      if (tc < best.time) {
        best.time = tc;
        best.type = EventType::Capture;
        best.partner = j;
        best.partner_counter = bodies_.counter[j];
        best.dim = static_cast<std::int8_t>(e);
      }
    }
  }
  if (recheck < best.time) {
    best = Event{};
    best.time = recheck;
    best.type = EventType::CellCross;
    best.dim = -1;
  }
  events_[i] = best;
  queue_->update(i, best.time);
}

double Simulation::search_pair(int i, int j, double t, double limit, const Vec3& xi) {
  if (!profiling_) return predictor_.pair(i, j, t, limit, xi);
  auto capsule_steps = [&] {
    const Predictor::SearchCounts& c = predictor_.search_counts();
    return static_cast<std::int64_t>(c.pair_capsule + c.cluster_pair_capsule);
  };
  const std::int64_t steps0 = static_cast<std::int64_t>(predictor_.ca_iterations());
  const std::int64_t planes0 = predictor_.plane_evaluations(), capsule0 = capsule_steps();
  const auto start = std::chrono::steady_clock::now();
  const double tc = predictor_.pair(i, j, t, limit, xi);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::int64_t steps = static_cast<std::int64_t>(predictor_.ca_iterations()) - steps0;
  const std::int64_t planes = predictor_.plane_evaluations() - planes0;
  const std::int64_t w = steps + planes;
  const std::int64_t* edge = EventProfile::kWorkBins;
  EventProfile::Bin& b = profile_.bin[std::lower_bound(edge, edge + EventProfile::kBins - 1, w) - edge];
  auto add = [&](EventProfile::Work& x) {
    ++x.searches;
    x.work += w;
    x.exact_distances += steps - (capsule_steps() - capsule0);
    x.plane_evaluations += planes;
    x.seconds += seconds;
  };
  add(b.all);
  if (tc < kNever) add(b.found);
  ++profile_.kind[profile_kind_].pair_searches;
  return tc;
}

double Simulation::memo_pair(int i, int j, double t, double limit, const Vec3& xi, double start) {
  const std::uint32_t ci = bodies_.counter[i], cj = bodies_.counter[j];
  const PairMemo* m = nullptr;
  for (const PairMemo& e : memo_[i])
    if (e.partner == j && e.counter_self == ci && e.counter_partner == cj) m = &e;
  if (!m)
    for (const PairMemo& e : memo_[j])
      if (e.partner == i && e.counter_self == cj && e.counter_partner == ci) m = &e;
  PairMemo out{j, ci, cj, t, limit, false};
  double tc = kNever;
  if (m && t >= m->from && (!m->hit || m->until >= t)) {
    out.from = m->from;
    if (m->hit) {
      // The first contact after m->from is m->until, so also after t.
      tc = m->until < limit ? m->until : kNever;
      out.until = m->until;
      out.hit = true;
    } else if (m->until >= limit) {
      out.until = m->until;  // proven free past the horizon
    } else {
      ++stats_.memo_resumed;
      const double from = std::max({t, m->until, start});
      tc = search_pair(i, j, from, limit, reference_center(bodies_, i, from));
      if (tc == kNever) out.until = predictor_.proven_until();
    }
  } else {
    const double from = std::max(t, start);
    tc = search_pair(i, j, from, limit, from > t ? reference_center(bodies_, i, from) : xi);
    if (tc == kNever) out.until = predictor_.proven_until();
  }
  if (tc < kNever) {
    out.until = tc;
    out.hit = true;
  }
  memo_scratch_.push_back(out);
  return tc;
}

void Simulation::bump(int i, double t) {
  // A compliant group: a new slice from the changed state (once per event) first.
  if (const int cg = bodies_.cgroup[i]; cg >= 0 && cgroups_[cg].pending && !begin_slice(cg, t)) return;
  for_each_in_group(i, [&](int m) {
    ++bodies_.counter[m];
    bodies_.last_collision[m] = t;
  });
}

void Simulation::expire_group(int i, double t) {
  for_each_in_group(i, [&](int m) {
    events_[m].time = t;
    events_[m].type = EventType::None;
  });
}

void Simulation::predict_group(int i, double t) {
  for_each_in_group(i, [&](int m) { predict(m, t); });
}

void Simulation::apply_impulse(int i, const Vec3& J, const Vec3& arm) {
  if (const int cg = bodies_.cgroup[i]; cg >= 0) {
    CompliantGroup& G = cgroups_[cg];
    if (G.articulated) {
      // With the joint impulses it calls up (core/joint_impulses.hpp).
      // cut_group projected the velocities (G nu = 0), so this is
      // nu + W C^T J and changes the energy by what the contact law counted.
      apply_point_impulse(G.integ->mutable_state().bodies, G.joints, cindex_[i], arm, J,
                          &G.integ->projection_workspace());
      return;
    }
    // The member alone takes the jump (its own mass and inertia); touch() put
    // the cluster's state at the event time into the integrator.
    CompliantBody& cb = G.integ->mutable_state().bodies[cindex_[i]];
    // (A smooth sphere's arm is parallel to J up to the contact frame's
    // polish, a linker feature's normal at a tie: its spin then changes a
    // little, as for a free sphere, and the energy ledger stays exact.)
    cb.v += J / cb.mass;
    cb.omega += inverse_inertia(bodies_.sp(i), cb.axis()) * arm.cross(J);
    return;
  }
  const int g = bodies_.group[i];
  if (g >= 0) {
    cluster_impulse(bodies_.clusters[g], box_, now_, J, arm);
    return;
  }
  Kinematics& k = bodies_.kin[i];
  const Species& s = bodies_.sp(i);
  k.v += J / s.mass;
  const Vec3 omega = k.precession + k.spin * k.axis;
  set_angular_velocity(k, s, omega + inverse_inertia(s, k.axis) * arm.cross(J));
}

namespace {
// The side of a contact that body i presents: what moves (the body or its
// cluster), with the arm from its centre of mass to the contact point p.
ContactSide contact_side(const BodyStore& b, int i, double t, const Vec3& p, const Vec3& center) {
  return ContactSide{1.0 / moving_mass(b, i), moving_inverse_inertia(b, i, t), p - moving_center(b, i, t, center),
                     moving_velocity(b, i, t), body_omega(b, i, t)};
}
}  // namespace

void Simulation::constrain_sides(int i, int j, ContactSide* a, ContactSide* b) const {
  // A member of an articulated cluster (not carried rigidly): its velocities
  // are the integrator's state at the contact (cut and projected onto the
  // joints), its share of the collision matrix C W C^T
  // (core/joint_impulses.hpp). Two members of one cluster: the whole K with
  // its cross terms on side a (the sum is what the contact law uses).
  auto member = [&](int k) -> const CompliantGroup* {
    const int cg = k >= 0 ? bodies_.cgroup[k] : -1;
    return cg >= 0 && cgroups_[cg].articulated ? &cgroups_[cg] : nullptr;
  };
  auto set_state = [&](int k, const CompliantGroup& G, ContactSide* s) {
    const CompliantBody& cb = G.integ->state().bodies[cindex_[k]];
    s->v = cb.v;
    s->omega = cb.shape == Shape::Sphere ? Vec3::Zero() : cb.omega;
    s->explicit_k = true;
  };
  const CompliantGroup* ga = member(i);
  const CompliantGroup* gb = member(j);
  if (ga) set_state(i, *ga, a);
  if (gb) set_state(j, *gb, b);
  if (ga && ga == gb) {
    a->k = collision_matrix(ga->integ->state().bodies, ga->joints, cindex_[i], a->arm, cindex_[j], b->arm,
                            &ga->integ->projection_workspace());
    b->k = Mat3::Zero();
    return;
  }
  if (ga)
    a->k = collision_matrix(ga->integ->state().bodies, ga->joints, cindex_[i], a->arm,
                            &ga->integ->projection_workspace());
  if (gb)
    b->k = collision_matrix(gb->integ->state().bodies, gb->joints, cindex_[j], b->arm,
                            &gb->integ->projection_workspace());
}

void Simulation::touch(int b, double t, bool impulse) {
  if (const int cg = bodies_.cgroup[b]; cg >= 0) {
    CompliantGroup& G = cgroups_[cg];
    if (impulse && !(G.pending && G.ta == t)) {  // once per event
      // Contact bursts: impulses less than burst_time after the previous one.
      G.burst_count = t - G.burst_last < params_.compliant.burst_time ? G.burst_count + 1 : 1;
      G.burst_last = t;
    }
    cut_group(cg, t);
    const int burst = params_.compliant.burst_contacts;
    if (impulse && burst > 0 && G.burst_count >= burst && !G.articulated) {
      // The end of a contact burst: the cluster takes this impulse, and
      // moves, as one rigid body (core/compliant_events.cpp).
      G.burst_count = 0;
      ++stats_.bursts;
      relax_group(cg, G.integ->state(), t, Freeze::Burst);
      G.hold_until = t + params_.compliant.burst_time;
    }
    return;
  }
  const int g = bodies_.group[b];
  if (g < 0) {
    advance(bodies_.kin[b], t, bodies_.shape[b]);
  } else if (compliant_ && g < static_cast<int>(dormant_.size()) && dormant_[g] >= 0) {
    CompliantGroup& G = cgroups_[dormant_[g]];
    // A rigid articulated cluster (no internal freedom) wakes only to bond:
    // a contact moves it as the rigid body it is.
    if (!impulse || (!G.rigid && t >= G.hold_until)) {
      wake_cluster(g, t);  // a relaxed compliant cluster returns to the integrator
    } else if (!G.rigid) {
      // Held rigid after a contact burst while the contacts go on.
      rebase_cluster(bodies_.clusters[g], box_, t);
      G.hold_until = t + params_.compliant.burst_time;
    }
  }
  // A rigid cluster's pose, velocities and inertia at t are pure functions of
  // its record (core/pose.hpp): nothing to do before the contact geometry;
  // cluster_impulse re-bases it when an impulse changes its motion.
}

ContactLaw Simulation::pair_law(int i, int j, double t) {
  const Species &si = bodies_.sp(i), &sj = bodies_.sp(j);
  const ContactParams& cp = params_.contact;
  ContactLaw law{combine(cp.restitution_rule, si.restitution, sj.restitution),
                 combine(cp.friction_rule, si.static_friction, sj.static_friction),
                 combine(cp.friction_rule, si.dynamic_friction, sj.dynamic_friction)};
  // TC model (Luding & McNamara, Granular Matter 1, 113 (1998)): a body hit
  // again within tc_time of its previous impulse collides elastically, which
  // stops inelastic collapse (infinitely many collisions in finite time).
  if (t - bodies_.last_collision[i] < params_.run.tc_time || t - bodies_.last_collision[j] < params_.run.tc_time) {
    if (law.restitution < 1.0) ++stats_.tc_collisions;
    law.restitution = 1.0;
  }
  law.min_separation = params_.run.min_separation_speed;
  return law;
}

void Simulation::collide_smooth_spheres(int i, int j, double t) {
  // Two free spheres without friction: the impulse acts along the line of
  // centres, where it exerts no torque, so the general solver (collision
  // matrix, Coulomb cone) reduces to Newton's law along n:
  //   J = -(1 + e) u_n / (1/m_i + 1/m_j) n   on j (and -J on i),
  // with the same law (pair_law), separation floor (floor_impulse) and
  // energy bookkeeping as process_collision, which gives these values up to
  // rounding.
  touch(i, t);
  touch(j, t);
  Kinematics &ki = bodies_.kin[i], &kj = bodies_.kin[j];
  const Vec3 n = box_.min_image(kj.x - ki.x).normalized();
  const double un = n.dot(kj.v - ki.v);
  const ContactLaw law = pair_law(i, j, t);
  const double mass = bodies_.sp(i).mass;  // one species in the gas
  const double k_nn = 2.0 / mass;          // n.K.n = 1/m_i + 1/m_j
  // Not approaching: only the separation floor, as in process_collision
  // (separation_floor, core/contact.hpp).
  double jn = un < 0.0 ? -(1.0 + law.restitution) * un / k_nn : 0.0;
  if (const double top_up = un < 0.0 ? floor_impulse(un + k_nn * jn, k_nn, law) : floor_impulse_at_rest(un, k_nn, law);
      top_up > 0.0) {
    jn += top_up;
    ++stats_.floored;
  }
  if (jn != 0.0) {
    stats_.lost_contacts += -jn * (un + 0.5 * k_nn * jn);
    ki.v -= (jn / mass) * n;
    kj.v += (jn / mass) * n;
  }
  bump(i, t);
  bump(j, t);
  ++stats_.collisions;
  predict_sphere_pair(i, j, t);
}

void Simulation::process_collision(int i, int j, double t) {
  if (smooth_gas_) {
    collide_smooth_spheres(i, j, t);
    return;
  }
  touch(i, t);
  touch(j, t);
  const ContactGeometry g = predictor_.contact_geometry(i, j, t);
  const ContactFrame frame = predictor_.contact_frame(i, j, t, g);
  const Vec3& p = frame.point;
  ContactSide a = contact_side(bodies_, i, t, p, g.center_a);
  ContactSide b = contact_side(bodies_, j, t, p, g.center_b);
  if (articulated_) constrain_sides(i, j, &a, &b);
  const ContactLaw law = pair_law(i, j, t);
  if (const std::optional<ContactResult> r = fired_contact(a, b, frame.normal, law)) {
    apply_impulse(i, -r->impulse, a.arm);
    apply_impulse(j, r->impulse, b.arm);
  }
  bump(i, t);
  bump(j, t);
  ++stats_.collisions;
  if (termination_ != Termination::Running) return;  // a compliant cluster's integrator failed
  // j's group is re-predicted right after i's, and its searches cover every
  // pair with i's group up to i's new events: i's need not search them too.
  if (params_.run.partner_horizon) expire_group(j, t);
  predict_group(i, t);
  predict_group(j, t);
}

std::optional<ContactResult> Simulation::fired_contact(const ContactSide& a, const ContactSide& b, const Vec3& n,
                                                      const ContactLaw& law) {
  // The prediction fired because the contact points approach along n
  // (Predictor::approach_rate), so the impulse pushes them apart; unless
  // touch() has just merged a compliant cluster at the end of a contact burst
  // (an inelastic merge changes the members' velocities) and they no longer
  // approach: then only the separation floor (a full impulse would pull them
  // together, or a body back to the wall), and the next prediction sees them
  // separate.
  const bool approaching = n.dot(relative_point_velocity(a, b)) < 0.0;
  const ContactResult r = approaching ? solve_contact(a, b, n, law) : separation_floor(a, b, n, law);
  if (!approaching && !r.floored) return std::nullopt;
  stats_.lost_contacts += r.energy_loss;
  if (r.floored) ++stats_.floored;
  if (r.mode == ContactMode::Stick) ++stats_.stick;
  if (r.mode == ContactMode::Slide) ++stats_.slide;
  return r;
}

void Simulation::process_wall(int i, const Event& ev, double t) {
  touch(i, t);
  const Species& s = bodies_.sp(i);
  Vec3 n = Vec3::Zero();
  n[ev.dim] = ev.dir;  // from the body towards the wall
  Vec3 p;
  predictor_.wall_contact(i, t, n, &p);
  ContactSide body = contact_side(bodies_, i, t, p, body_center(bodies_, i, t));
  ContactSide wall{0.0, Mat3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  if (articulated_) constrain_sides(i, -1, &body, &wall);
  const ContactParams& cp = params_.contact;
  ContactLaw law{combine(cp.restitution_rule, s.restitution, cp.restitution_wall),
                 combine(cp.friction_rule, s.static_friction, cp.static_friction_wall),
                 combine(cp.friction_rule, s.dynamic_friction, cp.dynamic_friction_wall)};
  if (t - bodies_.last_collision[i] < params_.run.tc_time) {
    if (law.restitution < 1.0) ++stats_.tc_collisions;
    law.restitution = 1.0;
  }
  law.min_separation = params_.run.min_separation_speed;
  if (const std::optional<ContactResult> r = fired_contact(body, wall, n, law)) {
    apply_impulse(i, -r->impulse, body.arm);
    ext_impulse_ -= r->impulse;
    ext_angular_ += p.cross(-r->impulse);
  }
  bump(i, t);
  ++stats_.wall_collisions;
  if (termination_ != Termination::Running) return;
  predict_group(i, t);
}

void Simulation::process_cell(int i, const Event& ev, double t) {
  SphereScan scan = SphereScan::Full;
  if (ev.dim < 0) {
    // A cluster member, or a free body's re-check (free_body_exit): re-file
    // it under the cell that holds its centre.
    Vec3 x = body_center(bodies_, i, t);
    if (box_.periodic)
      for (int d = 0; d < 3; ++d) x[d] -= box_.length * std::floor(x[d] / box_.length);
    const int c = grid_.locate(x);
    if (c != grid_.cell_of_body(i)) grid_.move(i, c);
  } else {
    // The trajectory does not change: its record stays at its reference time
    // (no re-basing, which would turn a linker's axis for nothing); only the
    // periodic wrap shifts its reference position by a box length.
    bool wrapped = false;
    const int next = grid_.step(grid_.cell_of_body(i), ev.dim, ev.dir, &wrapped);
    if (next >= 0) {
      if (wrapped) bodies_.kin[i].x[ev.dim] -= ev.dir * box_.length;
      grid_.move(i, next);
    }
    // A sphere of the gas scans only the 9 cells it has come next to.
    if (sphere_gas_ && next >= 0 && grid_.faces_distinct()) scan = SphereScan::Crossing;
  }
  ++stats_.cell_crossings;
  if (sphere_gas_) predict_sphere(i, t, scan, ev.dim, ev.dir);
  else predict(i, t);
}

bool Simulation::step() {
  // Search counters up to now (also the work of stale re-predictions).
  stats_.ca_steps = predictor_.ca_iterations();
  stats_.plane_evaluations = predictor_.plane_evaluations();
  if (termination_ != Termination::Running) return false;
  const int i = queue_->top();
  const Event ev = events_[i];
  const double t_end = params_.run.t_max;
  // N_t(t) is sampled whenever bonding is on (replicate --series); it ends
  // the run only with run.steady_state.
  if (params_.bonding.enabled && monitor_.advance(std::min(ev.time, t_end)) && params_.run.steady_state) {
    // N_t(t) is steady (MSER): the state is unchanged since the last event,
    // so the run ends at the last sample used.
    termination_ = Termination::SteadyState;
    now_ = std::max(now_, monitor_.steady_time());
    return false;
  }
  if (ev.time > t_end) {
    termination_ = Termination::TimeLimit;
    now_ = t_end;
    return false;
  }
  if (stop_flag_ && stats_.events % kStopCheckEvents == 0 && stop_flag_->load(std::memory_order_relaxed)) {
    termination_ = Termination::Interrupted;
    return false;
  }
  if (params_.run.max_events > 0 && stats_.events >= params_.run.max_events) {
    termination_ = Termination::EventBudget;
    return false;
  }
  frozen_ = ev.time == now_ ? frozen_ + 1 : 0;
  if (frozen_ > kFrozenEvents) {
    termination_ = Termination::Error;
    error_ = frozen_time_message(ev, i, params_);
    return false;
  }
  now_ = ev.time;
  // The profile's share of this event, taken when it ends (also by the early
  // return of a stale one; with a validator, its check is included).
  struct ProfileScope {
    explicit ProfileScope(Simulation& s) : sim(s), start(std::chrono::steady_clock::now()) {}
    ProfileScope(const ProfileScope&) = delete;
    ProfileScope& operator=(const ProfileScope&) = delete;
    Simulation& sim;
    std::chrono::steady_clock::time_point start;
    ~ProfileScope() {
      EventProfile::PerKind& k = sim.profile_.kind[sim.profile_kind_];
      ++k.events;
      k.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
  };
  std::optional<ProfileScope> profile_scope;
  if (profiling_ && ev.type != EventType::None) {
    profile_kind_ = ev.type == EventType::Wall        ? EventProfile::kWall
                    : ev.type == EventType::CellCross ? EventProfile::kRelocation
                    : ev.type == EventType::Slice     ? EventProfile::kSlice
                                                      : EventProfile::kCollision;
    profile_scope.emplace(*this);
  }
  switch (ev.type) {
    case EventType::Collision:
    case EventType::Capture:
      if (bodies_.counter[ev.partner] != ev.partner_counter || repeats_a_refusal(i, ev)) {
        profile_kind_ = EventProfile::kStale;
        ++stats_.stale;
        if (sphere_gas_) predict_sphere(i, ev.time, SphereScan::Stale);
        else predict(i, ev.time);
        return true;
      }
      if (log_on_) log_.push_back({ev.time, ev.type, i, ev.partner});
      if (ev.type == EventType::Collision) process_collision(i, ev.partner, ev.time);
      else process_capture(i, ev, ev.time);
      break;
    case EventType::Wall:
      if (log_on_) log_.push_back({ev.time, ev.type, i, ev.dim * 2 + (ev.dir > 0)});
      process_wall(i, ev, ev.time);
      break;
    case EventType::CellCross:
      if (log_on_) log_.push_back({ev.time, ev.type, i, ev.dim * 2 + (ev.dir > 0)});
      process_cell(i, ev, ev.time);
      break;
    case EventType::Slice:
      process_slice(i, ev, ev.time);
      break;
    case EventType::None:
      termination_ = Termination::TimeLimit;  // nothing can ever happen
      now_ = t_end;
      return false;
  }
  ++stats_.events;
  if (termination_ == Termination::Error) return false;  // set by the event (a compliant integrator)
  if (predictor_.failed()) {
    termination_ = Termination::Error;
    error_ = "conservative advancement did not converge (more than " + std::to_string(Predictor::kMaxSteps) +
             " steps in one search) near t = " + std::to_string(now_) + ": " + predictor_.failure();
    return false;
  }
  if (validator_) validator_->check(*this, now_);
  return true;
}

Termination Simulation::run() {
  while (step()) {
  }
  // Also after an error: the state stands where the run stopped (every
  // trajectory is defined there), which the snapshot and the output show.
  synchronize(now_);
  collect_integrator_stats();
  return termination_;
}

void Simulation::synchronize(double t) {
  for (int i = 0; i < bodies_.size(); ++i)
    if (!in_cluster(bodies_, i)) advance(bodies_.kin[i], t, bodies_.shape[i]);
  for (Cluster& c : bodies_.clusters)
    if (c.alive) rebase_cluster(c, box_, t);
  snapshot_members(bodies_, box_, t);
}

}  // namespace ringsim
