#pragma once
// Mass properties of the two solid shapes (uniform density). Body frame: the
// centre of mass at the origin; for the cylinder the symmetry axis is the
// body z axis, so its inertia tensor is diag(i_perp, i_perp, i_axial).
// For the sphere all three principal moments equal i_axial == i_perp.

namespace ringsim {

struct MassProps {
  double mass;
  double i_axial;  // moment about the symmetry axis
  double i_perp;   // moment about any axis through the centre perpendicular to it
};

// Solid sphere of radius r: m = (4/3) pi r^3 rho, I = (2/5) m r^2.
MassProps sphere_mass_props(double r, double rho);

// Solid cylinder of radius r and length l (end face to end face):
// m = rho pi r^2 l, I_axial = m r^2 / 2, I_perp = m (3 r^2 + l^2) / 12.
MassProps cylinder_mass_props(double r, double l, double rho);

// Radius of the smallest centred sphere containing the cylinder:
// sqrt(r^2 + (l/2)^2) (distance from the centre to a rim point).
double cylinder_bounding_radius(double r, double l);

}  // namespace ringsim
