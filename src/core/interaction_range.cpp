#include "core/interaction_range.hpp"

#include "core/prediction.hpp"
#include "core/scene.hpp"

namespace ringsim {

InteractionRange interaction_range(const SimParams& p, const Species& sphere, const Species& linker, bool has_spheres,
                                   bool has_linkers) {
  InteractionRange r;
  double r_max = 0.0;
  if (has_spheres && sphere.bounding_radius > r_max) r_max = sphere.bounding_radius;
  if (has_linkers && linker.bounding_radius > r_max) r_max = linker.bounding_radius;
  r.contact = 2.0 * r_max;
  // Captures, and the clusters they make, need a sphere and a linker.
  const bool bonds = p.bonding.enabled && has_spheres && has_linkers;
  if (bonds) r.capture = Predictor::capture_arm(linker, p.bonding.capture_site) + sphere.radius + p.bonding.capture_distance;
  r.tolerance = 2.0 * p.run.contact_tolerance;
  if (bonds) r.slack = 2.0 * Predictor::cell_slack();
  return r;
}

InteractionRange interaction_range(const SimParams& p) {
  return interaction_range(p, make_species(Shape::Sphere, p), make_species(Shape::Linker, p), p.init.spheres > 0,
                           p.init.linkers > 0);
}

InteractionRange interaction_range(const SimParams& p, const BodyStore& bodies) {
  bool has[2] = {false, false};
  for (int i = 0; i < bodies.size(); ++i) has[static_cast<int>(bodies.shape[i])] = true;
  return interaction_range(p, bodies.species[0], bodies.species[1], has[0], has[1]);
}

}  // namespace ringsim
