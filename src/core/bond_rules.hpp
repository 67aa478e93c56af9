#pragma once
// Geometry of the bond rules (MODEL.md, "Capture and bond formation", rules 2
// and 3) as pure functions of axes and angles. Which bonds a capture would
// create, and which linkers then need a dihedral check, is the caller's
// business; these functions only measure and compare.
//
// Conventions (all vectors world frame; angles in degrees)
// - A linker with centre x, unit axis u and half length h = l_L / 2 has two
//   ends at the centres of its end faces (MODEL.md: p = x_L +- (l_L/2) u):
//     end 0 ("a"): x + h u,    end 1 ("b"): x - h u.
// - The outward axis of a linker at its end e, bonded (or about to be bonded)
//   to a sphere there, is the unit vector from that end towards the other
//   end, i.e. pointing away from the sphere: end 0 -> -u, end 1 -> +u.
// - Bond angle theta in [0, 180]: the angle between the outward axes of the
//   two linkers bonded at one sphere (a square corner: 90).
// - Dihedral phi in (-180, 180] about a linker of axis u: n0 is the outward
//   axis of the neighbouring linker at the sphere on the end-0 side, n1 the
//   neighbour's outward axis at the end-1 side; both are projected on the
//   plane normal to u and phi is the signed angle from the projection of n0
//   to that of n1, counter-clockwise about +u. A planar square ring gives
//   phi = 0 (cis: both neighbours on the same side), a planar zigzag chain
//   phi = 180 (trans). phi does not depend on which end is called 0: flipping
//   u and swapping n0, n1 gives the same value.
// - Degenerate dihedral: when a neighbour is parallel to u (projection of
//   length < 1e-12 |n|) the dihedral is undefined (std::nullopt) and the
//   coplanarity rule FAILS. Reasons: the rule is stated as a bound on phi,
//   which does not exist there, so planarity cannot be certified; near such a
//   pose phi is dominated by rounding, so no value would be meaningful; the
//   pose has measure zero in a simulation (no statistical effect) and with
//   the angle filter on it is rejected anyway (theta = 0 or 180). A failed
//   capture changes nothing, so failing is the conservative choice.
//
// Tolerances: a rule's boundary is inclusive and resolved to kAngleSlackDeg
// = 1e-12 degrees, so a pose built at exactly theta0 + dtheta (whose computed
// angle carries ~1e-14 degrees of rounding) passes, while one 1e-9 degrees
// beyond fails.

#include <optional>

#include "core/params.hpp"
#include "core/vec.hpp"

namespace ringsim {

// Absolute slack, in degrees, added to every angular tolerance (see above).
constexpr double kAngleSlackDeg = 1e-12;

// Position of end `end` (0 or 1) of a linker with centre x, unit axis u and
// half length h.
Vec3 linker_end(const Vec3& x, const Vec3& u, double half_length, int end);

// Outward axis of a linker with unit axis u at its end `end` (0 or 1):
// -u for end 0, +u for end 1.
Vec3 outward_axis(const Vec3& u, int end);

// Angle in [0, 180] degrees between two nonzero vectors (they need not be
// unit), as atan2(|n1 x n2|, n1 . n2): accurate near 0 and 180, where acos
// of the dot product loses half the digits.
double bond_angle_deg(const Vec3& n1, const Vec3& n2);

// Dihedral about axis u (nonzero) between the neighbour outward axes n0 (end-0
// side) and n1 (end-1 side), in (-180, 180] degrees; nullopt when either
// projection on the plane normal to u is degenerate (|projection| < 1e-12 |n|).
std::optional<double> dihedral_deg(const Vec3& u, const Vec3& n0, const Vec3& n1);

// Deviation of a dihedral from planarity, in degrees: CisOrTrans
// min(|phi|, 180 - |phi|) in [0, 90]; Cis |phi| in [0, 180].
double planarity_deviation_deg(double phi_deg, CoplanarityMode mode);

// Rule 2: true when the angle filter is off or |theta - theta0| <= dtheta.
bool angle_ok(double theta_deg, const BondingParams& bonding);

// Rule 3 for one linker: true when the coplanarity filter is off or the
// deviation of phi is <= dphi; an undefined (degenerate) phi fails when the
// filter is on.
bool planarity_ok(std::optional<double> phi_deg, const BondingParams& bonding);

}  // namespace ringsim
