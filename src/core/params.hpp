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

struct BondingParams {
  bool enabled = false;  // bonding arrives with issue 3; only false is accepted now
};

struct RunParams {
  double t_max = 5000.0;
  std::int64_t max_events = 0;        // event budget; 0 = unlimited
  double contact_tolerance = 1e-9;    // gap at which a non-closed-form contact fires
  double tc_time = 1e-7;              // TC model (Luding & McNamara 1998) collision-time window
  double cell_size = 0.0;             // neighbour-cell edge; 0 = automatic
  bool validate = false;              // check invariants after every event
  QueueKind queue = QueueKind::Fast;
};

struct SimParams {
  GeometryParams geometry;
  ContactParams contact;
  InitParams init;
  BondingParams bonding;
  RunParams run;
};

const char* to_string(Boundary b);
const char* to_string(CombineRule r);
const char* to_string(VelocityInit v);
const char* to_string(QueueKind q);

}  // namespace ringsim
