#pragma once
// One replicate's event-driven dynamics.
//
// Order of work in one event (docs/ARCHITECTURE.md):
//  1. pop the body with the earliest pending event (time, then body id);
//  2. a collision whose partner has had an impulse since the prediction is
//     stale: re-predict the body from the event time and continue;
//  3. otherwise advance the involved bodies to the event time, apply the
//     impulse (or move to the new cell), bump their impulse counters;
//  4. re-predict the involved bodies against their neighbourhoods;
//  5. validation mode: check every invariant at the event time.
// Prediction never changes state; state changes only in step 3.

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/body.hpp"
#include "core/cell_grid.hpp"
#include "core/event_queue.hpp"
#include "core/params.hpp"
#include "core/prediction.hpp"

namespace ringsim {

enum class EventType : std::uint8_t { None, Collision, Wall, CellCross };

// One pending event: a small value record owned by its body.
struct Event {
  double time = kNever;
  int partner = -1;                  // body id (Collision)
  std::uint32_t partner_counter = 0; // partner's impulse counter at prediction
  EventType type = EventType::None;
  std::int8_t dim = 0;               // Wall, CellCross
  std::int8_t dir = 0;
};

struct RunStats {
  std::int64_t events = 0;           // processed events of every kind
  std::int64_t collisions = 0;       // body-body contacts
  std::int64_t wall_collisions = 0;
  std::int64_t cell_crossings = 0;   // neighbour-structure refreshes
  std::int64_t stale = 0;            // invalidated events discarded
  std::int64_t tc_collisions = 0;    // contacts made elastic by the TC model
  std::int64_t stick = 0, slide = 0; // frictional contact modes
  std::uint64_t ca_steps = 0;        // conservative-advancement distance evaluations
  std::int64_t plane_evaluations = 0; // separating-plane bound evaluations
};

enum class Termination { Running, TimeLimit, EventBudget, Error };
const char* to_string(Termination t);

class Validator;

class Simulation {
 public:
  Simulation(const SimParams& params, BodyStore bodies);
  ~Simulation();

  // Process events until t_max, the event budget, or an error.
  Termination run();
  // Process one event (or discard one stale event); false once finished.
  bool step();

  double time() const { return now_; }
  const BodyStore& bodies() const { return bodies_; }
  BodyStore& bodies_mutable() { return bodies_; }
  const RunStats& stats() const { return stats_; }
  Termination termination() const { return termination_; }
  const std::string& error() const { return error_; }
  const SimParams& params() const { return params_; }
  const Box& box() const { return box_; }
  const CellGrid& grid() const { return grid_; }

  // Moves every body's reference time to t (after the last processed event).
  void synchronize(double t);

  // Impulse the walls have given the bodies (reflective boxes): total linear
  // impulse and its moment about the origin, for the conservation checks.
  const Vec3& external_impulse() const { return ext_impulse_; }
  const Vec3& external_angular_impulse() const { return ext_angular_; }

  // Attach an invariant checker run after every processed event.
  void set_validator(Validator* v) { validator_ = v; }

  // Event log for tests comparing queue implementations: (time, kind, i, j).
  struct LoggedEvent { double time; EventType type; int a; int b; };
  void enable_log(bool on) { log_on_ = on; }
  const std::vector<LoggedEvent>& log() const { return log_; }

 private:
  void predict(int i, double t);
  void process_collision(int i, int j, double t);
  void process_wall(int i, const Event& ev, double t);
  void process_cell(int i, const Event& ev, double t);
  void apply_impulse(int i, const Vec3& J, const Vec3& arm);

  SimParams params_;
  BodyStore bodies_;
  Box box_;
  CellGrid grid_;
  std::unique_ptr<EventQueue> queue_;
  Predictor predictor_;
  std::vector<Event> events_;
  std::vector<std::pair<double, int>> candidates_;  // scratch of predict()
  double now_ = 0.0;
  RunStats stats_;
  Termination termination_ = Termination::Running;
  std::string error_;
  Vec3 ext_impulse_ = Vec3::Zero();
  Vec3 ext_angular_ = Vec3::Zero();
  Validator* validator_ = nullptr;
  bool log_on_ = false;
  std::vector<LoggedEvent> log_;
};

}  // namespace ringsim
