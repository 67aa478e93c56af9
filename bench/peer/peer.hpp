#pragma once
// ringsim_peer: a time-stepped peer of the model on the Bullet engine, for
// the comparison of methods (issue 35, docs/PEER.md). Bench-only: nothing in
// src/ depends on it.
//
// What it shares with ringsim, so that both methods start from the identical
// state for a seed and measure the same things:
//  - the configuration (src/ensemble/config.hpp: TOML + --set);
//  - the scene (core/scene.hpp: build_scene with the same seed and replicate
//    gives the same positions, axes, velocities and angular velocities);
//  - species mass and inertia (core/scene.hpp: make_species), the pair
//    coefficient rules (core/contact.hpp: combine);
//  - the capture gap (core/prediction.hpp: Predictor::capture_gap on a
//    BodyStore holding the engine's poses of this step);
//  - the bond rules' geometry (core/bond_rules.hpp) and the bond graph with
//    its observables (core/bond_graph.hpp);
//  - the steady-state monitor (analysis/mser.hpp).
// What differs is the mechanics: Bullet's fixed time step, its collision
// detection with penetration, its sequential-impulse solver, and bonds as
// Bullet constraints (JointReading) instead of exact rigid clusters.

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "core/params.hpp"

namespace ringsim::peer {

// How a bond holds its two bodies (docs/PEER.md, "Bonds").
//  - Welded: one btFixedConstraint per bond, holding the relative pose at
//    capture (ringsim's rigid reading). As in ringsim, a capture needs the
//    two bodies in different clusters; rings close only in the scan of a
//    merge.
//  - Articulated: a btPoint2PointConstraint per bond (the ball joint at the
//    sphere's centre), and the held rows ringsim's add_articulated_bond
//    names: with bonding.angle_filter on a held bond angle per pair of
//    linkers on one sphere (held_angle.hpp, a one-row constraint); with
//    bonding.coplanarity_filter on a held dihedral per pair of neighbours
//    about a linker bonded at both ends (held_dihedral.hpp: a three-body row,
//    which a Bullet constraint row between two bodies cannot express, solved
//    by a subclass of Bullet's solver inside its Gauss-Seidel sweeps).
//    Captures inside a cluster are bonds (ring closure by a chain folding);
//    contacts follow bonding.exclusions (1-3 or 1-2) inside clusters too.
enum class JointReading { Welded, Articulated };

const char* to_string(JointReading j);
// "welded" or "articulated"; throws std::invalid_argument otherwise.
JointReading joint_reading_from_string(const std::string& s);

struct PeerOptions {
  double dt = 0.01;  // the fixed time step
  JointReading joint = JointReading::Welded;
  // Bullet's stock contact settings (restitution threshold 0.2, split impulse
  // only below 0.04 of penetration, speculative contacts, margins 0.04)
  // instead of the peer's elastic ones; for the record of how they fail.
  bool bullet_defaults = false;
  int solver_iterations = 10;  // Bullet's default
};

// One replicate on the engine; the JSON object has the fields of
// `ringsim replicate --json` that have a meaning here (docs/PEER.md), plus
// "peer" (the engine's settings, errors and failures). Never throws for a
// failure of the engine: a non-finite state ends the run with termination
// "error". Throws ConfigError / SceneError / std::invalid_argument on bad
// input, as ringsim does.
nlohmann::json run_peer(const SimParams& params, std::uint64_t seed, std::uint64_t replicate,
                        const PeerOptions& opt);

}  // namespace ringsim::peer
