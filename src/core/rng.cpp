#include "core/rng.hpp"

#include <Random123/philox.h>

#include <cmath>

namespace ringsim {

Rng::Rng(std::uint64_t seed, std::uint64_t replicate, Stream stream)
    : key_{seed, replicate}, counter_{static_cast<std::uint64_t>(stream), 0, 0, 0}, block_{} {}

void Rng::refill() {
  r123::Philox4x64 gen;
  r123::Philox4x64::ctr_type c = {{counter_[0], counter_[1], counter_[2], counter_[3]}};
  r123::Philox4x64::key_type k = {{key_[0], key_[1]}};
  const auto r = gen(c, k);
  for (int i = 0; i < 4; ++i) block_[i] = r.v[i];
  ++counter_[1];  // the block index; counter_[0] holds the stream id
  used_ = 0;
}

std::uint64_t Rng::next_u64() {
  if (used_ == 4) refill();
  return block_[used_++];
}

double Rng::uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }

double Rng::normal() {
  if (has_spare_normal_) {
    has_spare_normal_ = false;
    return spare_normal_;
  }
  // Box-Muller; 1 - u lies in (0, 1], so the log is finite.
  const double u1 = 1.0 - uniform();
  const double u2 = uniform();
  const double rad = std::sqrt(-2.0 * std::log(u1));
  const double ang = 2.0 * M_PI * u2;
  spare_normal_ = rad * std::sin(ang);
  has_spare_normal_ = true;
  return rad * std::cos(ang);
}

Vec3 Rng::unit_vector() {
  // Archimedes: z uniform in [-1, 1] and azimuth uniform give a uniform direction.
  const double z = uniform(-1.0, 1.0);
  const double phi = 2.0 * M_PI * uniform();
  const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
  return Vec3(s * std::cos(phi), s * std::sin(phi), z);
}

std::uint64_t Rng::below(std::uint64_t n) {
  // Lemire's nearly divisionless method would be faster; rejection is exact and simple.
  const std::uint64_t limit = UINT64_MAX - UINT64_MAX % n;
  std::uint64_t x;
  do x = next_u64(); while (x >= limit);
  return x % n;
}

}  // namespace ringsim
