#pragma once
// Validated simulation settings for one replicate. Field names follow the
// configuration keys (section.key) of docs/CONFIG.md; the defaults are the
// study's tables (MODEL.md, sections G, I, D). Units are reduced: length =
// sphere radius, mass from unit density, time from length and speed.
//
// Loading and range checks live in src/ensemble/config.cpp; the core trusts
// these values.

#include <cstdint>
#include <string>

namespace ringsim {

enum class Boundary { Reflective, Periodic };
enum class CombineRule { Min, Max, Product, Mean };
enum class VelocityInit { Uniform, Thermal };
enum class QueueKind { Fast, Reference };
// Which dihedrals the coplanarity filter accepts (MODEL.md, capture rule 3):
// CisOrTrans, deviation min(|phi|, 180 - |phi|) (the Decision); Cis, |phi|.
enum class CoplanarityMode { CisOrTrans, Cis };
// Where the capture gap is measured on a linker end (MODEL.md, "Capture and
// bond formation"): EndFace, the surface distance from the sphere to the end
// face's disk (the Decision); EndPoint, the distance to the face's centre.
enum class CaptureSite { EndFace, EndPoint };
// What a rigid bond holds (MODEL.md, "Two bond regimes", rigid):
// Articulated, a ball joint at the capture position plus the held angle and
// dihedral the filters name (the Decision; docs/ARTICULATED.md); Welded, the
// two clusters frozen into one rigid body in the capture pose.
enum class BondJoint { Articulated, Welded };
// Which bonded pairs never collide (MODEL.md, "Contacts"): OneThree, bonded
// pairs and pairs bonded to a common partner (the Decision: the usual
// force-field exclusions); OneTwo, bonded pairs only, so that two linkers
// on one sphere collide as the hard bodies they are (articulated bonds
// only; docs/ARTICULATED.md, "Exclusions").
enum class Exclusions { OneThree, OneTwo };
// Integrator of compliant clusters (docs/COMPLIANT.md, stability study).
enum class CompliantMethod { Auto, Bdf, Adams, Erk };

struct GeometryParams {
  double sphere_radius = 1.0;
  double linker_radius = 1.0;
  double linker_length = 4.0;  // end face to end face
  double box_length = 50.0;    // box = [0, L]^3
  Boundary boundary = Boundary::Reflective;
  double density = 1.0;        // mass density of both species
};

struct ContactParams {
  double restitution_sphere = 1.0;
  double restitution_linker = 1.0;
  double restitution_wall = 1.0;
  double static_friction_sphere = 0.0;
  double static_friction_linker = 0.0;
  double static_friction_wall = 0.0;
  double dynamic_friction_sphere = 0.0;
  double dynamic_friction_linker = 0.0;
  double dynamic_friction_wall = 0.0;
  CombineRule restitution_rule = CombineRule::Min;
  CombineRule friction_rule = CombineRule::Product;
};

struct InitParams {
  int spheres = 300;
  int linkers = 300;
  double alpha = 1.0;  // 0 segregated, 1 fully mixed
  VelocityInit velocity = VelocityInit::Uniform;
  double v_max = 1.0;
  double omega_max = 1.0;
  double temperature = 1.0;  // k_B = 1
};

// Capture and bond formation (MODEL.md, "Capture and bond formation"). The
// defaults are the study's Scenario 4 (= 6-2): both filters on, rigid bonds.
// Angles in degrees; the geometry of the rules is in core/bond_rules.hpp.
struct BondingParams {
  bool enabled = true;            // false: hard bodies only, no captures
  double capture_distance = 0.1;  // r_c: a capture is the gap g falling through r_c
  // g = dist(x_S, end-face disk) - r_S (EndFace) or |p - x_S| - r_S (EndPoint)
  CaptureSite capture_site = CaptureSite::EndFace;
  int sphere_valency = 2;         // v_S: bonds a sphere can carry
  // v_aL = v_bL: bonds one linker end can carry. At most 1: an end face meets
  // at most one sphere, and the rules (bond angle, dihedral) assume one.
  int end_valency = 1;
  bool angle_filter = true;  // rule 2: |theta - theta0| <= dtheta at a sphere with two bonds
  double theta0_deg = 90.0;
  double dtheta_deg = 5.0;
  bool coplanarity_filter = true;  // rule 3: dihedral deviation from planarity <= dphi
  double dphi_deg = 5.0;
  CoplanarityMode coplanarity_mode = CoplanarityMode::CisOrTrans;
  // Rigid regime only (compliant bonds have their own terms).
  BondJoint joint = BondJoint::Articulated;
  // Articulated clusters: largest joint residual |C| (length, or radians for
  // held angles) left by the position projection at every slice end.
  double joint_tolerance = 1e-10;
  // Articulated clusters: longest slice (time) integrated ahead of the event
  // loop (compliant.slice serves compliant clusters). Measured
  // (docs/ARTICULATED.md, "Slices and tracks"): at 0.2 the quintic tracks
  // stray from the joints by less than the integrator's own drift.
  double joint_slice = 0.2;
  Exclusions exclusions = Exclusions::OneThree;
};

// Compliant bonds (MODEL.md, "Two bond regimes", compliant): spring-damper
// terms toward the target pose, core/compliant.hpp. All zero (the default) is
// the rigid regime; any of k, k_omega > 0 selects the compliant one.
// Units: k in force/length (mass/time^2), c in mass/time, k_omega in
// energy/rad^2, c_omega in energy*time/rad^2, target_gap in length.
struct CompliantParams {
  double k = 0.0;           // bond spring on the sphere-to-target-point vector
  double c = 0.0;           // bond damper on the relative velocity at the sphere centre
  double k_omega = 0.0;     // angle and dihedral springs (on the deviation in radians)
  double c_omega = 0.0;     // angle and dihedral dampers (on the rate in rad/time)
  double target_gap = 0.0;  // target gap between the sphere surface and the end face
  // Integration inside the event loop (core/compliant_group.hpp).
  CompliantMethod method = CompliantMethod::Auto;  // Auto: ERK up to k, k_omega = 1e4, BDF above
  double rtol = 1e-6;
  double atol = 1e-8;
  double slice = 0.05;  // longest slice integrated ahead of the event loop (time)
  // Largest estimated distance (length) between a member's cubic track and
  // the integrated motion at a slice's midpoint; longer slices are halved
  // (core/compliant_group.hpp, track_error_estimate). 0 = no check.
  double track_tolerance = 0.01;
  // Relaxed-cluster switch: a cluster whose internal kinetic energy stayed
  // at or below relax_energy for relax_time is carried as a rigid body until
  // a contact or a bond disturbs it; relax_energy = 0 never switches.
  double relax_energy = 1e-4;
  double relax_time = 2.0;
  // Contact bursts: a cluster whose members take burst_contacts impulses
  // within burst_time (a member pressed by its springs against another body:
  // bounces that shrink towards a resting contact, infinitely many in finite
  // time) is carried as a rigid body from the last of them, until the next
  // disturbance; burst_contacts = 0 never does.
  int burst_contacts = 8;
  double burst_time = 0.05;
  bool enabled() const { return k > 0.0 || k_omega > 0.0; }
};

// Run control. A replicate ends at t_max or, with steady_state, when MSER-b
// (White 1997, batch size b = mser_batch) on the N_t series sampled every
// sample_interval puts its truncation point in the first half of the series
// (MODEL.md, "Protocol"). The test runs once mser_min_samples samples exist,
// then after every mser_check_every new samples.
struct RunParams {
  double t_max = 5000.0;              // the study's 5e5 steps of 0.01
  bool steady_state = true;           // stop at MSER steady state; false = run to t_max
  double sample_interval = 1.0;       // time between samples of N_t
  int mser_batch = 5;                 // MSER batch size b (MSER-5)
  // Samples before the first test; >= 2 mser_batch, so that the series holds
  // the 2 batch means MSER needs (the candidates d = 0 .. k-2 keep >= 2).
  int mser_min_samples = 200;
  int mser_check_every = 50;          // samples between tests
  std::int64_t max_events = 0;        // event budget; 0 = unlimited
  double contact_tolerance = 1e-9;    // gap at which a non-closed-form contact fires
  double tc_time = 1e-4;              // TC model (Luding & McNamara 1998) collision-time window (docs/ARCHITECTURE.md)
  // Floor of a contact's normal separation speed (ContactLaw). 1e-4 since
  // 2026-11-26 (was 1e-6): Scenario 5's resting contacts then cost ~4x less,
  // with the same observables (docs/ARCHITECTURE.md, "Contact response").
  double min_separation_speed = 1e-4;
  double cell_size = 0.0;             // neighbour-cell edge; 0 = automatic
  int sphere_candidates = 4;          // hard-sphere gas: collisions kept per body (Simulation::predict_sphere); 0 = off
  // Pair and capture searches stop at the partner's pending event, where the
  // partner re-predicts the pair (Simulation::predict); false: at the body's
  // own horizon only (the earlier scheme, for testing).
  bool partner_horizon = true;
  bool validate = false;              // check invariants after every event
  QueueKind queue = QueueKind::Fast;
};

struct SimParams {
  GeometryParams geometry;
  ContactParams contact;
  InitParams init;
  BondingParams bonding;
  CompliantParams compliant;
  RunParams run;
};

// Rigid bonds read as articulated joints: bonding on, no compliant springs,
// bonding.joint = articulated (docs/ARTICULATED.md).
inline bool articulated_bonds(const SimParams& p) {
  return p.bonding.enabled && !p.compliant.enabled() && p.bonding.joint == BondJoint::Articulated;
}

const char* to_string(Boundary b);
const char* to_string(CombineRule r);
const char* to_string(VelocityInit v);
const char* to_string(QueueKind q);
const char* to_string(CoplanarityMode m);
const char* to_string(CaptureSite s);
const char* to_string(BondJoint j);
const char* to_string(Exclusions e);
const char* to_string(CompliantMethod m);

}  // namespace ringsim
