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
//  5. a capture (a linker end entering a sphere's capture shell) is checked
//     against the bond rules after the event is taken; a bond updates the
//     bond graph, merges the two groups into one rigid cluster, checks every
//     pair the merge put inside one cluster (ring closure), and re-predicts
//     every member. A cluster member's impulse moves the whole cluster, so all
//     its members' counters change and all are re-predicted;
//  6. the steady-state monitor samples N_t(t); the run ends at MSER steady
//     state, when no bond is possible any more, at t_max or on an error;
//  7. validation mode: check every invariant at the event time.
// Prediction never changes state; state changes only in steps 3 and 5.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "analysis/mser.hpp"
#include "core/body.hpp"
#include "core/bond_graph.hpp"
#include "core/cell_grid.hpp"
#include "core/compliant_group.hpp"
#include "core/contact.hpp"
#include "core/event_queue.hpp"
#include "core/params.hpp"
#include "core/prediction.hpp"

namespace ringsim {

// Slice: a compliant member's slice end (core/compliant_group.hpp).
enum class EventType : std::uint8_t { None, Collision, Wall, CellCross, Capture, Slice };

// One pending event: a small value record owned by its body.
struct Event {
  double time = kNever;
  int partner = -1;                  // body id (Collision, Capture)
  std::uint32_t partner_counter = 0; // partner's impulse counter at prediction
  EventType type = EventType::None;
  std::int8_t dim = 0;               // Wall, CellCross (-1: relocate a cluster member); Capture: linker end
  std::int8_t dir = 0;
};

struct RunStats {
  std::int64_t events = 0;           // processed events of every kind
  std::int64_t collisions = 0;       // body-body contacts
  std::int64_t wall_collisions = 0;
  std::int64_t cell_crossings = 0;   // neighbour-structure refreshes
  std::int64_t stale = 0;            // invalidated events discarded
  std::int64_t memo_resumed = 0;     // pair searches resumed from an earlier proof
  std::int64_t tc_collisions = 0;    // contacts made elastic by the TC model
  std::int64_t floored = 0;          // contacts topped up to run.min_separation_speed
  std::int64_t stick = 0, slide = 0; // frictional contact modes
  std::int64_t captures = 0;         // capture events taken (bond formed or not)
  std::int64_t bonds = 0;            // bonds formed (captures that passed the rules, ring closures)
  std::int64_t closure_bonds = 0;    // of which formed by ring closure inside a merged cluster
  std::int64_t rejected_valency = 0, rejected_angle = 0, rejected_coplanarity = 0;
  std::uint64_t ca_steps = 0;        // conservative-advancement distance evaluations
  std::int64_t plane_evaluations = 0; // separating-plane bound evaluations
  // Compliant clusters (docs/COMPLIANT.md, "Coupling").
  std::int64_t slices = 0;           // slices integrated ahead
  std::int64_t slice_cuts = 0;       // slices cut by an impulse or a bond
  std::int64_t relaxed = 0;          // switches of a relaxed cluster to a rigid body
  std::int64_t woken = 0;            // relaxed clusters returned to the integrator
  std::int64_t bursts = 0;           // clusters made rigid by a contact burst
  // Articulated bonds (docs/ARTICULATED.md): clusters formed or changed by a
  // bond, by what their joints leave them (internal_dof 0: moved as one rigid
  // body; else integrated with its constraints); slice-end projections and
  // the largest joint residual they found (|C|, before) and the largest
  // correction (M-norm of the position change).
  std::int64_t joint_rigid = 0, joint_articulated = 0;
  std::int64_t projections = 0;
  std::int64_t dropped_rows = 0;  // held angles and dihedrals implied by the others (drop_redundant_held_rows)
  std::int64_t released_rows = 0;  // of those, the ones released later, when a projection stalled on them
  std::int64_t failed_slices = 0;  // articulated slices whose integration failed and were retried (halved)
  std::int64_t readmitted_rows = 0;  // dropped rows held again once independent (Simulation::readmit_rows)
  double released_residual = 0.0;  // largest |C| of a dropped row at a slice end (radians-like: how far it strayed)
  double joint_residual = 0.0;
  double joint_residual_after = 0.0;  // largest |C| a projection left (above bonding.joint_tolerance: singular poses)
  double projection_size = 0.0;
  double cut_residual = 0.0;  // largest |C| at a cut (track error), after the rolls' fit
  std::int64_t sundials_steps = 0;   // integrator steps, all clusters
  std::int64_t sundials_rhs = 0;     // right-hand-side evaluations, all clusters
  double sundials_seconds = 0.0;     // wall time inside the integrators
  // Energy ledger (Simulation::energy_budget): kinetic energy taken out by
  // each discrete mechanism, summed over the run (negative = put in).
  double lost_contacts = 0.0;        // body-body and wall impulses (restitution < 1, friction; the floor adds)
  double lost_rigid_merges = 0.0;    // rigid bonds: perfectly inelastic merges
  double lost_relaxed = 0.0;         // relaxed-cluster switches to rigid motion
  double lost_bursts = 0.0;          // contact bursts ending in rigid motion
  double lost_joint_impulses = 0.0;  // articulated bonds: impulses making new joints' velocities consistent
  double lost_projections = 0.0;     // articulated clusters: velocity projections at cuts and slice ends
};

// Where a run's time goes (ringsim replicate --profile; docs/OUTPUT.md,
// "profile"): the work each kind of event caused, and the general path's pair
// searches by their work. Only counted when enabled (Simulation::enable_profile),
// and it changes nothing else: a profiled run has the same events.
struct EventProfile {
  // collision: a contact or capture that fired; stale: one discarded (its
  // partner moved since; not in RunStats::events); wall; relocation: a cell
  // crossing, a member's relocation or a re-check; slice: a compliant slice end.
  enum Kind { kCollision, kStale, kWall, kRelocation, kSlice, kKinds };
  static constexpr const char* kNames[kKinds] = {"collision", "stale", "wall", "relocation", "slice"};
  struct PerKind {
    std::int64_t events = 0;
    std::int64_t predictions = 0;       // bodies predicted again
    std::int64_t pair_searches = 0;     // contact searches run (not answered by the pair memo alone)
    std::int64_t capture_searches = 0;  // capture searches (a linker end against a sphere)
    double seconds = 0.0;               // wall time of these events, their predictions included
  };
  PerKind kind[kKinds];
  // Pair searches by their work w (distance evaluations plus separating-plane
  // evaluations): bin k holds kWorkBins[k - 1] < w <= kWorkBins[k] (bin 0: w = 0,
  // the last: above 1 000). `found` sums the searches that found a contact
  // (found.searches: their number), `all` every search of the bin.
  static constexpr int kBins = 8;
  static constexpr std::int64_t kWorkBins[kBins - 1] = {0, 3, 10, 30, 100, 300, 1000};
  struct Work {
    std::int64_t searches = 0;
    std::int64_t work = 0;
    std::int64_t exact_distances = 0;  // steps from the exact distance (not a capsule bound)
    std::int64_t plane_evaluations = 0;
    double seconds = 0.0;
  };
  struct Bin {
    Work all, found;
  };
  Bin bin[kBins];
};

// Where the energy went, at the present time (docs/OUTPUT.md, "energy_budget"):
// initial + bonds_in = kinetic + potential + the losses. Every term but
// `dampers` is counted where it happens; `dampers` is the rest: the energy the
// compliant dampers took out (MODEL.md, "Two bond regimes"), plus the
// integrators' error (rtol) and the separation floor's additions (tiny). In a
// run without compliant bonds it is round-off only.
struct EnergyBudget {
  double initial = 0.0;    // kinetic energy at t = 0
  double bonds_in = 0.0;   // potential energy compliant bonds brought in when they formed (stretched at r_c)
  double kinetic = 0.0;    // now
  double potential = 0.0;  // compliant clusters' springs, now
  double contacts = 0.0, rigid_merges = 0.0, relaxed = 0.0, bursts = 0.0;  // RunStats::lost_*
  double joint_impulses = 0.0, projections = 0.0;                          // RunStats::lost_*
  double dampers = 0.0;    // the rest
};

// Interrupted: stopped from outside (set_stop_flag), e.g. by SIGTERM; the
// replicate is incomplete and an ensemble does not record it.
enum class Termination { Running, TimeLimit, SteadyState, NoBondPossible, EventBudget, Error, Interrupted };
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
  const Predictor::SearchCounts& predictor_counts() const { return predictor_.search_counts(); }
  Termination termination() const { return termination_; }
  const std::string& error() const { return error_; }
  const SimParams& params() const { return params_; }
  const Box& box() const { return box_; }
  const CellGrid& grid() const { return grid_; }
  const BondGraph& graph() const { return graph_; }
  // The sampled N_t(t) series and the MSER result behind a steady-state end.
  const SteadyStateMonitor& monitor() const { return monitor_; }

  // Moves every body's reference time to t (after the last processed event).
  void synchronize(double t);

  // Impulse the walls have given the bodies (reflective boxes): total linear
  // impulse and its moment about the origin, for the conservation checks.
  const Vec3& external_impulse() const { return ext_impulse_; }
  const Vec3& external_angular_impulse() const { return ext_angular_; }
  // Compliant bonds: potential energy of every compliant cluster at t, and
  // the potential energy bonds brought in when they formed (a bond forms at
  // the capture distance, stretched), for the energy balance of validation.
  double compliant_potential(double t) const;
  double bond_energy() const { return bond_energy_; }
  // The energy ledger at the present time (after synchronize or at the end).
  EnergyBudget energy_budget() const;
  // Articulated bonds: the clusters standing now (two bodies or more), by
  // what their joints leave them: no internal freedom (carried as one rigid
  // body) or some (integrated with their constraints), with their bodies.
  struct ClusterShare {
    int rigid = 0, rigid_bodies = 0, articulated = 0, articulated_bodies = 0;
  };
  ClusterShare cluster_share() const;
  // 1-2 and 1-3 pairs of the bond graph (a sphere and a linker bonded to it,
  // two linkers on one sphere, two spheres on one linker): never in contact;
  // with bonding.exclusions = 1-2 only the 1-2 pairs.
  bool contact_excluded(int i, int j) const;
  // A refused capture of end `end` of l by s still waiting for the end to
  // leave the shell (Predictor::capture_refused).
  bool capture_refused(int l, int end, int s) const { return predictor_.capture_is_refused(l, end, s); }
  // Integrator work so far (stats().sundials_*), including live clusters.
  void collect_integrator_stats();

  // Attach an invariant checker run after every processed event.
  void set_validator(Validator* v) { validator_ = v; }
  // The run ends with Termination::Interrupted soon after *flag turns true
  // (checked every kStopCheckEvents events: a relaxed atomic load).
  void set_stop_flag(const std::atomic<bool>* flag) { stop_flag_ = flag; }
  static constexpr std::uint64_t kStopCheckEvents = 1024;
  // The run ends with Termination::Error once this many events in a row
  // happen at one and the same instant: time has stopped (a resting contact
  // firing again and again with nothing to separate it), and the run would
  // never end. No physical sequence of events repeats one instant this often.
  static constexpr std::int64_t kFrozenEvents = 100'000;

  // Called with every compliant cluster a bond creates or changes (merge or
  // ring closure), in its state at the bond, before it is integrated: the
  // stability study (bench/bench_compliant.cpp) replays them.
  using ClusterObserver = std::function<void(const CompliantCluster&, double)>;
  void set_cluster_observer(ClusterObserver f) { cluster_observer_ = std::move(f); }

  // Event log for tests comparing queue implementations: (time, kind, i, j).
  struct LoggedEvent { double time; EventType type; int a; int b; };
  void enable_log(bool on) { log_on_ = on; }
  // Counts where the run's time goes (EventProfile) from the next event on;
  // costs two clock reads per event and per pair search.
  void enable_profile(bool on) { profiling_ = on; }
  const EventProfile& profile() const { return profile_; }
  const std::vector<LoggedEvent>& log() const { return log_; }

 private:
  void predict(int i, double t);
  // The impulse of a contact that fired (process_collision, process_wall),
  // counted in the stats; nullopt when there is none to apply.
  std::optional<ContactResult> fired_contact(const ContactSide& a, const ContactSide& b, const Vec3& n,
                                             const ContactLaw& law);
  void predict_group(int i, double t);  // i and, for a member, its whole cluster
  // f(m) for every body that moves with i: its compliant group's members, its
  // rigid cluster's members, or i alone.
  template <class F>
  void for_each_in_group(int i, F&& f) {
    if (const int cg = bodies_.cgroup[i]; cg >= 0) {
      for (int m : cgroups_[cg].members) f(m);
    } else if (const int g = bodies_.group[i]; g >= 0) {
      for (int m : bodies_.clusters[g].members) f(m);
    } else {
      f(i);
    }
  }
  // Marks the pending events of i's group (the body, its rigid cluster or its
  // compliant group) as ending at t, just before the group is re-predicted at
  // t: other bodies' searches stop there (run.partner_horizon), since the
  // group's own predictions cover those pairs. The queue keeps the old times
  // until then.
  void expire_group(int i, double t);
  // A free body's own event: leaving its cell, or hitting a wall first, or a
  // re-check once its fastest point could have crossed kRecheckWidths cells.
  Event free_body_exit(int i, double t, const Vec3& xi);
  static constexpr double kRecheckWidths = 64.0;
  // Replaces *e by i's wall hit (reflective box) if that comes first.
  void take_earlier_wall(int i, double t, Event* e);
  // Hard-sphere gas (no linkers, no bonding; run.sphere_candidates = K > 0).
  // Every body keeps the K earliest collisions of its neighbourhood, each
  // found without a horizon, and `floor`: no pair left out of the list (with
  // both trajectories unchanged) collides before it. A pair whose partner's
  // trajectory has changed since is dropped: the partner's own prediction
  // after that change saw this body on its present trajectory. So a cell
  // crossing scans only the 9 cells that became adjacent (Crossing), and a
  // stale collision falls back on the next candidate (Stale); only when the
  // earliest remaining one lies past `floor` is the full neighbourhood
  // scanned again (Full, also after every impulse).
  enum class SphereScan { Full, Stale, Crossing };
  void predict_sphere(int i, double t, SphereScan scan, int dim = 0, int dir = 0);
  // Both bodies of a collision (Full scans) in one pass over the union of
  // their neighbourhoods, each partner's state read once; the lists come out
  // as two predict_sphere calls would leave them (the K earliest and the
  // floor do not depend on the order of the scan).
  void predict_sphere_pair(int i, int j, double t);
  // predict_sphere's ending: the own event (crossing or wall), the check of
  // the list against its floor, the queue entry.
  void finish_sphere(int i, double t, SphereScan scan, const Vec3& xi);
  struct SphereFill;  // one body's list during a scan (simulation.cpp)
  struct SphereCandidate {
    double time;
    int partner;
    std::uint32_t partner_counter;
  };
  SphereCandidate* sphere_list(int i) {  // body i's run.sphere_candidates entries
    return &sphere_list_[static_cast<std::size_t>(i) * params_.run.sphere_candidates];
  }
  void bump(int i, double t);           // trajectory of i's group changed at t
  void process_capture(int i, const Event& ev, double t);
  // Bond rules (MODEL.md) for sphere s and end `end` of linker l at time t.
  // A refusal is the pair's capture hysteresis too: it may capture again only
  // after the end has left the shell (Predictor::capture_refused).
  bool rules_allow(int s, int l, int end, double t);
  bool rules_pass(int s, int l, int end, double t);
  // Forms the bond, merges groups and closes rings; re-predicts the cluster.
  void form_bond(int s, int l, int end, double t);
  void check_initial_captures();
  // The pending capture ev of body i repeats one the rules have refused
  // since (found from the other side): stale.
  bool repeats_a_refusal(int i, const Event& ev) const;
  bool bond_possible() const;
  void process_collision(int i, int j, double t);
  // The contact law of pair (i, j) at t: combined restitution and friction,
  // the TC rule (counted) and the separation floor.
  ContactLaw pair_law(int i, int j, double t);
  // process_collision for the frictionless sphere gas (smooth_gas_).
  void collide_smooth_spheres(int i, int j, double t);
  void process_wall(int i, const Event& ev, double t);
  void process_cell(int i, const Event& ev, double t);
  void apply_impulse(int i, const Vec3& J, const Vec3& arm);
  // Articulated members among the contact's bodies i and j (j < 0: a wall):
  // their sides take the integrator's velocities and the constrained
  // collision matrix.
  void constrain_sides(int i, int j, ContactSide* a, ContactSide* b) const;
  // Makes body b's state at t current before an impulse or a bond: a free
  // body advanced (a rigid cluster needs nothing: cluster_impulse re-bases
  // it), a compliant cluster cut (its
  // integrator state set from the tracks), a relaxed one woken.
  // An impulse (not a bond) may end a contact burst (compliant.burst_*).
  void touch(int b, double t, bool impulse = true);
  // Compliant clusters (core/compliant_events.cpp).
  void cut_group(int g, double t);
  bool begin_slice(int g, double t);
  void process_slice(int i, const Event& ev, double t);
  // Why a group becomes a rigid body: it relaxed, a contact burst ended, or
  // (articulated) its joints leave it no internal freedom.
  enum class Freeze { Relaxed, Burst, Rigid };
  // st: the group's state at t (its integrator's, or a new group's model).
  void relax_group(int g, const CompliantCluster& st, double t, Freeze why);
  void wake_cluster(int cluster, double t);
  void form_compliant_bond(int s, int l, int end, double t);
  // Adds the bond's terms to the group's model (compliant springs, or
  // articulated joints: the topology is the same code).
  void add_group_bond(CompliantCluster& model, JointSet& joints, int s, int l, int end);
  // The group's integrator for the state `model` at t (articulated: the
  // joints, no spring terms), or, when its joints leave no internal freedom,
  // the group frozen into one rigid body. The new bonds' velocity impulse
  // (articulated) is applied first.
  void start_group(int g, CompliantCluster model, double t);
  bool release_weak_rows(CompliantGroup& G, bool stalled, double weakest);
  bool stalled_on_held_row(const CompliantGroup& G) const;
  bool readmit_rows(CompliantGroup& G);
  IntegratorOptions integrator_options() const;
  // Periodic boxes: a cluster wider than a quarter of the box ends the run
  // with an error (minimum images would be ambiguous).
  void check_cluster_extent(const char* kind, double extent, double t);
  void retire_integrator(CompliantGroup& g);

  SimParams params_;
  BodyStore bodies_;
  Box box_;
  CellGrid grid_;
  std::unique_ptr<EventQueue> queue_;
  Predictor predictor_;
  std::vector<Event> events_;
  int n_spheres_ = 0;
  BondGraph graph_;
  SteadyStateMonitor monitor_;
  const std::atomic<bool>* stop_flag_ = nullptr;
  std::vector<int> capture_partners_;  // scratch of predict()
  // A pair to search, from its window's entry (cone: from the cone's, a
  // proven start of the search); in order of entry, then partner.
  struct Candidate {
    double enter;
    int j;
    bool cone;
    bool operator<(const Candidate& o) const { return enter < o.enter || (enter == o.enter && j < o.j); }
  };
  std::vector<Candidate> candidates_;  // scratch of predict()
  // Pair-search memo. A search of pair (i, j) from `from` with horizon
  // `until` either proved no contact in [from, until) (hit false) or found the
  // first contact at `until` (hit true). While neither body's trajectory has
  // changed (both counters equal), a later search of the pair - from either
  // body, e.g. after a cell crossing - resumes from there instead of redoing
  // the work. memo_[i] keeps the entries of i's last prediction.
  struct PairMemo {
    int partner;
    std::uint32_t counter_self, counter_partner;
    double from, until;
    bool hit;
  };
  // start >= t: the pair cannot touch before it (a fresh or resumed search
  // begins there; the memo still records the proof from t).
  double memo_pair(int i, int j, double t, double limit, const Vec3& xi, double start);
  // Wall-search memo of a body (the same proof, for its walls): a search from
  // `from` either proved no wall contact before `until` or found the first at
  // hit.time. Valid while the body's counter is unchanged; a cell crossing or
  // a member's relocation then resumes from `until` instead of starting over.
  struct WallMemo {
    std::uint32_t counter = 0;
    bool valid = false;
    double from = 0.0, until = 0.0;
    WallHit hit;
  };
  std::vector<WallMemo> wall_memo_;
  std::vector<std::vector<PairMemo>> memo_;
  std::vector<PairMemo> memo_scratch_;
  bool sphere_gas_ = false;                    // predict_sphere applies
  bool smooth_gas_ = false;                    // ... and no friction: collide_smooth_spheres
  std::vector<SphereCandidate> sphere_list_;   // run.sphere_candidates per body, earliest first
  std::vector<int> sphere_count_;              // entries in use per body
  std::vector<double> sphere_floor_;
  std::vector<Event> sphere_own_;              // the body's crossing or wall hit
  double now_ = 0.0;
  std::int64_t frozen_ = 0;  // events in a row at the instant now_ (kFrozenEvents)
  RunStats stats_;
  Termination termination_ = Termination::Running;
  std::string error_;
  Vec3 ext_impulse_ = Vec3::Zero();
  Vec3 ext_angular_ = Vec3::Zero();
  // Integrated clusters: compliant bonds (params.compliant.enabled()) or
  // articulated ones (bonding.joint = articulated in the rigid regime).
  bool compliant_ = false;
  bool articulated_ = false;
  std::vector<CompliantGroup> cgroups_;  // by id; retired ones stay (alive false)
  std::vector<int> cindex_;              // body -> its index in its compliant group's model
  std::vector<int> dormant_;             // rigid cluster id -> the relaxed compliant group it carries, or -1
  double bond_energy_ = 0.0;
  double initial_energy_ = 0.0;
  Validator* validator_ = nullptr;
  ClusterObserver cluster_observer_;
  bool log_on_ = false;
  bool profiling_ = false;
  EventProfile profile_;
  EventProfile::Kind profile_kind_ = EventProfile::kRelocation;  // of the event being processed
  // predictor_.pair, timed and binned into profile_ when profiling.
  double search_pair(int i, int j, double t, double limit, const Vec3& xi);
  std::vector<LoggedEvent> log_;
};

}  // namespace ringsim
