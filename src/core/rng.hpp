#pragma once
// Counter-based random streams (Philox4x64-10, Salmon et al., SC'11, via
// Random123). Every stream is keyed by (base seed, replicate, stream id), so
// a replicate's numbers depend on nothing else: not on the MPI rank, not on
// the order replicates run in, not on the standard library. The distributions
// are written here (not <random>'s), for the same reason.

#include <cstdint>

#include "core/vec.hpp"

namespace ringsim {

// All stream ids of the project, in one place (HOOMD's RNGIdentifiers idea).
enum class Stream : std::uint32_t {
  Placement = 1,     // positions and orientations of the initial scene
  Velocities = 2,    // initial linear and angular velocities
  PlacementGrid = 3, // order of fallback grid sites
};

class Rng {
 public:
  Rng(std::uint64_t seed, std::uint64_t replicate, Stream stream);

  std::uint64_t next_u64();
  double uniform();                           // [0, 1), 53 random bits
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  double normal();                            // N(0, 1), Box-Muller
  Vec3 unit_vector();                         // uniform on the unit sphere
  std::uint64_t below(std::uint64_t n);       // uniform integer in [0, n)

 private:
  void refill();
  std::uint64_t key_[2];
  std::uint64_t counter_[4];
  std::uint64_t block_[4];
  int used_ = 4;
  bool has_spare_normal_ = false;
  double spare_normal_ = 0.0;
};

}  // namespace ringsim
