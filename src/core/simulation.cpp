#include "core/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/contact.hpp"
#include "core/motion.hpp"
#include "core/validation.hpp"

namespace ringsim {

const char* to_string(Termination t) {
  switch (t) {
    case Termination::Running: return "running";
    case Termination::TimeLimit: return "t_max";
    case Termination::EventBudget: return "event_budget";
    case Termination::Error: return "error";
  }
  return "?";
}

namespace {
double interaction_range(const BodyStore& b) {
  double r = 0.0;
  for (int i = 0; i < b.size(); ++i) r = std::max(r, b.sp(i).bounding_radius);
  return 2.0 * r;
}
}  // namespace

Simulation::Simulation(const SimParams& params, BodyStore bodies)
    : params_(params),
      bodies_(std::move(bodies)),
      box_{params.geometry.box_length, params.geometry.boundary == Boundary::Periodic},
      queue_(make_queue(params.run.queue)),
      predictor_(bodies_, box_, params.run.contact_tolerance) {
  const int n = bodies_.size();
  const double range = interaction_range(bodies_) + 2.0 * params.run.contact_tolerance;
  if (box_.periodic && 2.0 * range >= box_.length)
    throw std::invalid_argument("geometry.box_length = " + std::to_string(box_.length) + ": must be > " +
                                std::to_string(2.0 * range) +
                                " with geometry.boundary = periodic (twice the interaction range, minimum image)");
  const double cell = std::max(range, params.run.cell_size);
  grid_ = CellGrid(box_.length, cell, n, box_.periodic);
  events_.assign(n, Event{});
  bodies_.counter.assign(n, 0);
  bodies_.last_collision.assign(n, -kNever);
  for (int i = 0; i < n; ++i) grid_.insert(i, bodies_.kin[i].x);
  queue_->reset(n);
  for (int i = 0; i < n; ++i) predict(i, 0.0);
}

Simulation::~Simulation() = default;

void Simulation::predict(int i, double t) {
  const Kinematics& k = bodies_.kin[i];
  const Vec3 xi = position_at(k, t);
  const CellGrid::Exit ex = grid_.exit_time(grid_.cell_of_body(i), xi, k.v);
  Event best;
  best.time = t + ex.dt;
  best.type = EventType::CellCross;
  best.dim = static_cast<std::int8_t>(ex.dim);
  best.dir = static_cast<std::int8_t>(ex.dir);
  if (!box_.periodic) {
    const WallHit w = predictor_.wall(i, t, best.time);
    if (w.time < best.time) {
      best.time = w.time;
      best.type = EventType::Wall;
      best.dim = static_cast<std::int8_t>(w.dim);
      best.dir = static_cast<std::int8_t>(w.dir);
    }
  }
  auto consider = [&](int j, double tc) {
    if (tc < best.time) {
      best.time = tc;
      best.type = EventType::Collision;
      best.partner = j;
      best.partner_counter = bodies_.counter[j];
    }
  };
  // Closed forms at once; searches (pairs with a linker) later, in order of
  // their bounding-sphere entry times, so that an early contact cuts the
  // horizon of the rest before they cost anything.
  candidates_.clear();
  const bool sphere_i = bodies_.shape[i] == Shape::Sphere;
  grid_.for_each_near(grid_.cell_of_body(i), [&](int j) {
    if (j == i) return;
    if (sphere_i && bodies_.shape[j] == Shape::Sphere) {
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
    const double enter = predictor_.window_enter(i, j, t, xi);
    if (enter < best.time) candidates_.push_back({enter, j});
  });
  std::sort(candidates_.begin(), candidates_.end());
  for (const auto& [enter, j] : candidates_) {
    if (enter >= best.time) break;
    consider(j, predictor_.pair(i, j, t, best.time, xi));
  }
  events_[i] = best;
  queue_->update(i, best.time);
}

void Simulation::apply_impulse(int i, const Vec3& J, const Vec3& arm) {
  Kinematics& k = bodies_.kin[i];
  const Species& s = bodies_.sp(i);
  k.v += J / s.mass;
  const Vec3 omega = k.precession + k.spin * k.axis;
  set_angular_velocity(k, s, omega + inverse_inertia(s, k.axis) * arm.cross(J));
}

void Simulation::process_collision(int i, int j, double t) {
  advance(bodies_.kin[i], t);
  advance(bodies_.kin[j], t);
  const ContactGeometry g = predictor_.contact_geometry(i, j, t);
  const ContactFrame frame = predictor_.contact_frame(i, j, t, g);
  const Vec3& p = frame.point;
  const Species &si = bodies_.sp(i), &sj = bodies_.sp(j);
  const Kinematics &ki = bodies_.kin[i], &kj = bodies_.kin[j];
  ContactSide a{1.0 / si.mass, inverse_inertia(si, ki.axis), p - g.center_a, ki.v, ki.precession + ki.spin * ki.axis};
  ContactSide b{1.0 / sj.mass, inverse_inertia(sj, kj.axis), p - g.center_b, kj.v, kj.precession + kj.spin * kj.axis};
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
  const ContactResult r = solve_contact(a, b, frame.normal, law);
  apply_impulse(i, -r.impulse, a.arm);
  apply_impulse(j, r.impulse, b.arm);
  if (r.mode == ContactMode::Stick) ++stats_.stick;
  if (r.mode == ContactMode::Slide) ++stats_.slide;
  ++bodies_.counter[i];
  ++bodies_.counter[j];
  bodies_.last_collision[i] = bodies_.last_collision[j] = t;
  ++stats_.collisions;
  predict(i, t);
  predict(j, t);
}

void Simulation::process_wall(int i, const Event& ev, double t) {
  advance(bodies_.kin[i], t);
  Kinematics& k = bodies_.kin[i];
  const Species& s = bodies_.sp(i);
  Vec3 n = Vec3::Zero();
  n[ev.dim] = ev.dir;  // from the body towards the wall
  Vec3 p;
  predictor_.wall_contact(i, t, n, &p);
  ContactSide body{1.0 / s.mass, inverse_inertia(s, k.axis), p - k.x, k.v, k.precession + k.spin * k.axis};
  ContactSide wall{0.0, Mat3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  const ContactParams& cp = params_.contact;
  ContactLaw law{combine(cp.restitution_rule, s.restitution, cp.restitution_wall),
                 combine(cp.friction_rule, s.static_friction, cp.static_friction_wall),
                 combine(cp.friction_rule, s.dynamic_friction, cp.dynamic_friction_wall)};
  if (t - bodies_.last_collision[i] < params_.run.tc_time) {
    if (law.restitution < 1.0) ++stats_.tc_collisions;
    law.restitution = 1.0;
  }
  const ContactResult r = solve_contact(body, wall, n, law);
  apply_impulse(i, -r.impulse, body.arm);
  ext_impulse_ -= r.impulse;
  ext_angular_ += p.cross(-r.impulse);
  ++bodies_.counter[i];
  bodies_.last_collision[i] = t;
  ++stats_.wall_collisions;
  predict(i, t);
}

void Simulation::process_cell(int i, const Event& ev, double t) {
  advance(bodies_.kin[i], t);
  bool wrapped = false;
  const int next = grid_.step(grid_.cell_of_body(i), ev.dim, ev.dir, &wrapped);
  if (next >= 0) {
    if (wrapped) bodies_.kin[i].x[ev.dim] -= ev.dir * box_.length;
    grid_.move(i, next);
  }
  ++stats_.cell_crossings;
  predict(i, t);
}

bool Simulation::step() {
  // Search counters up to now (also the work of stale re-predictions).
  stats_.ca_steps = predictor_.ca_iterations();
  stats_.plane_evaluations = predictor_.plane_evaluations();
  if (termination_ != Termination::Running) return false;
  const int i = queue_->top();
  const Event ev = events_[i];
  if (ev.time > params_.run.t_max) {
    termination_ = Termination::TimeLimit;
    now_ = params_.run.t_max;
    return false;
  }
  if (params_.run.max_events > 0 && stats_.events >= params_.run.max_events) {
    termination_ = Termination::EventBudget;
    return false;
  }
  now_ = ev.time;
  switch (ev.type) {
    case EventType::Collision:
      if (bodies_.counter[ev.partner] != ev.partner_counter) {
        ++stats_.stale;
        predict(i, ev.time);
        return true;
      }
      if (log_on_) log_.push_back({ev.time, ev.type, i, ev.partner});
      process_collision(i, ev.partner, ev.time);
      break;
    case EventType::Wall:
      if (log_on_) log_.push_back({ev.time, ev.type, i, ev.dim * 2 + (ev.dir > 0)});
      process_wall(i, ev, ev.time);
      break;
    case EventType::CellCross:
      if (log_on_) log_.push_back({ev.time, ev.type, i, ev.dim * 2 + (ev.dir > 0)});
      process_cell(i, ev, ev.time);
      break;
    case EventType::None:
      termination_ = Termination::TimeLimit;  // nothing can ever happen
      now_ = params_.run.t_max;
      return false;
  }
  ++stats_.events;
  if (predictor_.failed()) {
    termination_ = Termination::Error;
    error_ = "conservative advancement did not converge (more than " + std::to_string(Predictor::kMaxSteps) +
             " steps in one search) near t = " + std::to_string(now_);
    return false;
  }
  if (validator_) validator_->check(*this, now_);
  return true;
}

Termination Simulation::run() {
  while (step()) {
  }
  if (termination_ != Termination::Error) synchronize(now_);
  return termination_;
}

void Simulation::synchronize(double t) {
  for (auto& k : bodies_.kin) advance(k, t);
}

}  // namespace ringsim
