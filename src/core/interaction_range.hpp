#pragma once
// The interaction range: the largest centre distance at which two bodies of a
// run can interact, and the smallest periodic box that follows from it. One
// definition for the neighbour grid and its safety check (Simulation) and for
// the configuration check of geometry.box_length (ensemble/config.cpp;
// docs/CONFIG.md, "Rules that involve several keys").
//
//   range = max(2 R_max, capture) + 2 delta + slack
//
//  - R_max: the largest bounding radius among the species present (r_S for a
//    sphere, sqrt(r_L^2 + (l_L/2)^2) for a linker); a species with no body
//    sets nothing;
//  - capture = a + r_S + r_c, the largest linker-sphere centre distance at a
//    capture (r_c = bonding.capture_distance; a = sqrt(h^2 + r_L^2), the end
//    face's rim, with bonding.capture_site = end_face, a = h = l_L/2, the end
//    point, with end_point); only with bonding on and both species present,
//    else 0;
//  - 2 delta: the contact band (run.contact_tolerance) of both bodies;
//  - slack = 2 Predictor::cell_slack(): a cluster member may stray that far
//    outside its cell, so cells are that much wider; only when clusters can
//    form (bonding on, both species present), else 0.
//
// A periodic box needs l_B > 2 range: then every pair within range of each
// other is so on one image only (the minimum-image convention). Lengths in
// reduced units (sphere radius = 1).

#include "core/body.hpp"
#include "core/params.hpp"

namespace ringsim {

struct InteractionRange {
  double contact = 0.0;    // 2 R_max over the species present
  double capture = 0.0;    // a + r_S + r_c, or 0
  double tolerance = 0.0;  // 2 delta
  double slack = 0.0;      // 2 cell_slack, or 0
  double range() const { return (contact > capture ? contact : capture) + tolerance + slack; }
  // geometry.box_length must exceed this with geometry.boundary = periodic.
  double periodic_min_box() const { return 2.0 * range(); }
};

// From the two species' constants and which of them have bodies.
InteractionRange interaction_range(const SimParams& p, const Species& sphere, const Species& linker, bool has_spheres,
                                   bool has_linkers);
// Of the scene the settings describe: species from the geometry
// (make_species), present when init.spheres / init.linkers > 0.
InteractionRange interaction_range(const SimParams& p);
// Of the bodies of a built scene.
InteractionRange interaction_range(const SimParams& p, const BodyStore& bodies);

}  // namespace ringsim
