#pragma once
// Initial scene (MODEL.md section I): species from the geometry, positions
// routed by the mixing degree alpha, hard-overlap rejection with a lattice
// fallback for dense requests, uniform or thermal velocities, and the
// realized mixing fraction.
//
// Routing: the box splits into B_S (x < L/2) and B_L (x >= L/2). A body of
// species tau draws its centre in B_tau with probability 1 - alpha, else in
// the whole box. A trial that overlaps a placed body or a wall (reflective
// boxes) is redrawn. After `kRejectionTrials` failed trials in a row a body
// switches to the fallback: the sites of a jittered cubic lattice of spacing
// 2 R (R its bounding radius) over the same routed region, visited in random
// order, each tried with fresh orientations. Only when no site is left does
// set-up fail, naming the packing fraction reached.

#include <cstdint>
#include <stdexcept>
#include <string>

#include "core/body.hpp"
#include "core/params.hpp"

namespace ringsim {

class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SceneReport {
  double packing_fraction = 0.0;  // solid volume / box volume
  double mixing = 0.0;            // fraction of bodies whose nearest neighbour is of the other species
  int fallback_placements = 0;    // bodies placed by the lattice fallback
};

// Species constants (shape, mass and inertia from density, contact material).
Species make_species(Shape shape, const SimParams& p);

// Refuses a scene no placement can realise: throws SceneError when the bodies'
// solid volume exceeds random close packing of the box. Depends on the
// parameters only, so `run` checks it once before any replicate starts;
// build_scene checks it first (the same message either way).
void check_scene_packing(const SimParams& p);

// Builds the scene; ids: spheres 0 .. N_S-1, then linkers. Throws SceneError.
BodyStore build_scene(const SimParams& p, std::uint64_t seed, std::uint64_t replicate, SceneReport* report);

// Nearest-neighbour mixing fraction of the current positions (by centre).
double mixing_fraction(const BodyStore& b, double box_length, bool periodic);

inline constexpr int kRejectionTrials = 2000;

}  // namespace ringsim
