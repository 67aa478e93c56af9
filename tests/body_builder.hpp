#pragma once
// Hand-built scenes for tests: bodies with given centre, velocity, axis and
// angular velocity (the simulator fills in counters and cluster data).

#include <vector>

#include "core/body.hpp"
#include "core/motion.hpp"
#include "core/params.hpp"
#include "core/scene.hpp"

namespace ringsim {
namespace test {

struct Init {
  Shape shape;
  Vec3 x, v, axis, omega;
};

// With bonding, spheres must come first (ids: spheres, then linkers).
inline BodyStore make_bodies(const SimParams& p, const std::vector<Init>& init) {
  BodyStore b;
  b.species[0] = make_species(Shape::Sphere, p);
  b.species[1] = make_species(Shape::Linker, p);
  for (const Init& in : init) {
    b.shape.push_back(in.shape);
    Kinematics k = make_kinematics(in.x, in.v, in.axis.normalized());
    set_angular_velocity(k, b.species[static_cast<int>(in.shape)], in.omega);
    b.kin.push_back(k);
  }
  return b;
}

}  // namespace test
}  // namespace ringsim
