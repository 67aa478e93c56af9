#pragma once
// The compliant force field of one cluster of bonded bodies (MODEL.md, "Two
// bond regimes", compliant; docs/COMPLIANT.md has the derivations).
//
// Bodies keep their own degrees of freedom and feel spring-damper terms that
// pull the cluster toward its target pose:
//  - bond (k, c), one per sphere-linker bond, on the vector from the sphere
//    centre's target point to the sphere centre,
//      d = x_S - p*,  p* = x_L + s_e a u,  a = h + r_S + g0,
//    (s_e = +1 at end 0 = x + h u, -1 at end 1; g0 = target_gap), so the
//    target puts the sphere on the axis, touching the end face at gap g0:
//      U = k |d|^2 / 2.
//    Damping -c w on the relative velocity at the sphere centre,
//      w = v_S - v_L - omega_L x (x_S - x_L),
//    applied as an equal and opposite pair at x_S: a rigidly moving cluster
//    (w = 0) is not damped, whatever its strain;
//  - angle (k_omega, c_omega), one per pair of linkers at a sphere when
//    bonding.angle_filter is on: theta = angle between the outward axes
//    (core/bond_rules.hpp), U = k_omega (theta - theta0)^2 / 2;
//  - dihedral (k_omega, c_omega), one per linker with cornered spheres at both
//    ends when bonding.coplanarity_filter is on: phi as in dihedral_deg()
//    (radians), U = k_omega wrap(phi - phi0)^2 / 2, phi0 in {0, pi}, the
//    planar value nearest to phi when the term was created (always 0 in
//    `cis` mode).
// An angle or dihedral coordinate xi depends only on linker axes; with
// G_i = d xi / d(rotation of linker i) (a 3-vector, sum_i G_i = 0 because xi
// is invariant under global rotation), the term applies the torques
//      tau_i = -(k_omega (xi - xi0) + c_omega xi_dot) G_i,  xi_dot = sum_i G_i . omega_i,
// no forces. Every conservative load is minus the gradient of a potential
// that is invariant under global translation and rotation, and every damping
// load acts on a relative (objective) rate through equal and opposite pairs,
// so sum F = 0 and sum (x_i x F_i + tau_i) = 0 identically: the field
// conserves momentum and angular momentum exactly; damping only removes
// energy (power -c |w|^2 - c_omega xi_dot^2).
//
// Singular poses (measure zero, never near the target): an angle term whose
// two axes are parallel and a dihedral term whose neighbour is parallel to the
// central axis have no defined gradient direction; they then apply no load.
//
// Units: reduced (length = sphere radius, unit density); angles in radians
// internally (CompliantAngle::theta0, CompliantDihedral::phi0).

#include <vector>

#include "core/body.hpp"
#include "core/params.hpp"
#include "core/vec.hpp"

namespace ringsim {

// One body of a compliant cluster: constants, then state (world frame).
// Invariants: q is a unit quaternion (world <- body); a linker's symmetry axis
// is the body z axis, u = q e_z. Spheres ignore q and omega (smooth spheres:
// no load ever turns them).
struct CompliantBody {
  Shape shape = Shape::Sphere;
  double mass = 1.0;
  double i_axial = 1.0;      // linkers: moment about the axis
  double i_perp = 1.0;       // linkers: moment about a transverse axis
  double radius = 1.0;
  double half_length = 0.0;  // linkers: h = l_L / 2
  Vec3 x = Vec3::Zero();
  Vec3 v = Vec3::Zero();
  Quat q = Quat::Identity();
  Vec3 omega = Vec3::Zero();  // world-frame angular velocity

  Vec3 axis() const { return q * Vec3::UnitZ(); }
  // World angular momentum about the centre: I omega with
  // I = I_perp 1 + (I_axial - I_perp) u u^T (symmetric top).
  Vec3 angular_momentum() const;
};

// Body with the species' constants; a linker's orientation maps e_z to `axis`
// (its spin angle about the axis is irrelevant: nothing depends on it).
CompliantBody make_compliant_body(const Species& sp, const Vec3& x, const Vec3& v, const Vec3& axis,
                                  const Vec3& omega);

// The core's lazy state of a free body (Kinematics at its reference time)
// as a compliant body, and back (omega = precession + spin u; body.hpp).
CompliantBody compliant_body_from(const Kinematics& kin, const Species& sp);
Kinematics kinematics_from(const CompliantBody& b, double t);

// Terms; indices are into CompliantCluster::bodies.
struct CompliantBond {
  int sphere;
  int linker;
  int end;  // 0: x + h u, 1: x - h u
};
struct CompliantAngle {
  int sphere;
  int linker_a, end_a;  // the two linkers at the sphere, and their ends there
  int linker_b, end_b;
  double theta0;        // radians
};
struct CompliantDihedral {
  int linker;           // the central linker M
  int nb0, nb0_end;     // neighbour linker at the sphere on M's end-0 side, its end there
  int nb1, nb1_end;     // neighbour at the end-1 side
  double phi0;          // 0 (cis) or pi (trans), radians
};

// A cluster: bodies, the terms acting between them, and the parameters.
struct CompliantCluster {
  std::vector<CompliantBody> bodies;
  std::vector<CompliantBond> bonds;
  std::vector<CompliantAngle> angles;
  std::vector<CompliantDihedral> dihedrals;
  CompliantParams params;
};

// Adds the bond (sphere, linker end) and the angle and dihedral terms it
// creates (only those whose filter is on in `bonding`), with the dihedral
// targets taken from the present pose. Call in the order bonds form.
void add_compliant_bond(CompliantCluster& cluster, int sphere, int linker, int end, const BondingParams& bonding);

// Per-body world-frame motion the field is evaluated on.
struct BodyMotion {
  Vec3 x, v;
  Vec3 u;      // unit axis (linkers)
  Vec3 omega;  // world angular velocity (linkers)
};
std::vector<BodyMotion> body_motions(const CompliantCluster& cluster);

// Forces and torques (world frame, torques about each body's centre) on every
// body; `damping` false gives the conservative part only. force/torque are
// resized to the number of bodies.
void compliant_loads(const CompliantCluster& cluster, const std::vector<BodyMotion>& motion, bool damping,
                     std::vector<Vec3>& force, std::vector<Vec3>& torque);
double compliant_potential(const CompliantCluster& cluster, const std::vector<BodyMotion>& motion);

// Convenience on the cluster's own state.
double potential_energy(const CompliantCluster& cluster);
double kinetic_energy(const CompliantCluster& cluster);
Vec3 total_momentum(const CompliantCluster& cluster);
Vec3 total_angular_momentum(const CompliantCluster& cluster);  // about the origin, spin included

// Coordinates of the terms at the present pose (diagnostics, tests):
// theta of an angle term, phi of a dihedral (radians, in (-pi, pi]; NaN when
// undefined), and the bond vector d.
double term_angle(const CompliantCluster& cluster, const CompliantAngle& a);
double term_dihedral(const CompliantCluster& cluster, const CompliantDihedral& d);
Vec3 term_bond_vector(const CompliantCluster& cluster, const CompliantBond& b);

}  // namespace ringsim
