#pragma once
// Rigid-cluster mechanics (MODEL.md, "Two bond regimes", rigid): a bond merges
// two groups into one rigid body with the relative pose they had at capture.
// The merge is a perfectly inelastic collision: linear and angular momentum
// are conserved exactly, kinetic energy can only be lost. The cluster then
// moves as a free rigid body (ballistic centre of mass, exact torque-free
// rotation, core/free_rotation.hpp) until an impulse or another bond.

#include "core/body.hpp"
#include "core/prediction.hpp"

namespace ringsim {

// Merges the group of body a (its cluster, or a alone when free) with that of
// body b at time t into a new cluster and returns its id. Positions of b's
// group are taken in the periodic image nearest to a's. Every member gets its
// offset and body-frame axis; the old clusters are retired.
// sphere_inertia = false: spheres enter the inertia as point masses, their own
// rotational inertia left out. A relaxed compliant cluster carries its smooth
// spheres' spins aside (BodyStore::held_spin): they do not turn with it, and
// waking it gives each sphere its held spin back, so the rigid body must not
// hold a share of their rotation either (docs/COMPLIANT.md, "Relaxed-cluster
// switch").
int merge_groups(BodyStore& b, const Box& box, int a, int other, double t, bool sphere_inertia = true);

// Moves cluster c's reference time to t (same trajectory; periodic boxes: the
// centre of mass is wrapped into the box).
void rebase_cluster(Cluster& c, const Box& box, double t);

// Applies impulse J at arm (from the cluster's centre of mass) at time t.
void cluster_impulse(Cluster& c, const Box& box, double t, const Vec3& J, const Vec3& arm);

// Totals of the whole system at time t: momentum, angular momentum about the
// origin, kinetic energy, and the scales used for relative errors
// (sum |p| and sum (|x||p| + |L_own|)).
struct MechanicalTotals {
  Vec3 momentum = Vec3::Zero();
  Vec3 angular_momentum = Vec3::Zero();
  double energy = 0.0;  // kinetic: translational + rotational
  double translational = 0.0;
  double rotational = 0.0;
  double p_scale = 0.0;
  double l_scale = 0.0;
};
MechanicalTotals mechanical_totals(const BodyStore& b, double t);

// Kinetic energy of what body i moves with: its rigid cluster, or i alone
// when free (constant between events). Not for compliant-cluster members.
double group_kinetic_energy(const BodyStore& b, int i);

// Writes each cluster member's pose and velocity at t into its kin record
// (wrapped centre, axis, centre velocity, the cluster's angular velocity as
// `precession` with zero spin) for output and snapshots.
void snapshot_members(BodyStore& b, const Box& box, double t);

}  // namespace ringsim
