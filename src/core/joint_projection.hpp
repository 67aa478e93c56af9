#pragma once
// Projections of an articulated cluster's state onto its joints
// (docs/ARTICULATED.md): velocities onto G nu = 0, positions onto C = 0.
// No Baumgarte terms anywhere: the integrator's drift is removed by these
// projections, which a caller runs where the state is the integrator's own
// (slice ends), and a new bond's impulse is the velocity projection.
//
// Both are minimum-norm corrections in the metric of the mass matrix M
// (core/constrained_dynamics.hpp), so they change the motion as little as the
// kinetic energy can measure:
//  - velocities: nu' = nu - M^-1 G^T S^+ G nu (S = G M^-1 G^T), the
//    M-orthogonal projection onto the null space of G, solved with each
//    sphere riding on its host (core/constrained_dynamics.hpp,
//    HostedProblem). It is the impulse
//    G^T mu (mu = -S^+ G nu) of perfectly inelastic joints: internal (the
//    joints are invariant under global translation and rotation, so the
//    impulses sum to zero force and zero torque about any point: momentum and
//    angular momentum are kept) and dissipative only in the held directions,
//    T' = T - (G nu)^T S^+ (G nu) / 2 <= T;
//  - positions: Gauss-Newton steps dnu = -M^-1 G^T S^+ C applied as a
//    displacement (core/joints.hpp, displace), until max |C| <= tolerance,
//    then the velocity projection at the new pose; each step solved on the
//    hosted problem like the velocities (the same M-smallest correction,
//    with G dnu = -C in place of -G nu). A step keeps the centre of
//    mass (sum of m dx = 0) and the total angular momentum's first-order
//    change is zero for the same reason as above.

#include <vector>

#include "core/joints.hpp"

namespace ringsim {

class MultiplierSolve;  // core/constrained_dynamics.hpp
struct MassMatrix;      // core/constrained_dynamics.hpp

struct VelocityProjection {
  double residual_before = 0.0;  // max |G nu| before
  double residual_after = 0.0;   // after
  double energy_change = 0.0;    // kinetic energy after - before (<= 0)
  // With held_sines: the smallest squared sine of a held row to the span of
  // the other rows, in maximal coordinates (from MultiplierSolve::row_sines2
  // on the projection's own reduced factors, converted: joint_projection.cpp),
  // -1 when S is rank deficient, 1 without held rows.
  double weakest_held_sine2 = 1.0;
};
// workspace (here and in project_positions): a MultiplierSolve the caller
// keeps from call to call, so that the sparse factorization's analysis is
// made once per pattern of joints (docs/ARTICULATED.md, "Cost"); null: one
// of the call's own. The results do not depend on it.
VelocityProjection project_velocities(std::vector<CompliantBody>& bodies, const JointSet& joints,
                                      bool held_sines = false, MultiplierSolve* workspace = nullptr);

// Each column of x (velocity coordinates in m's layout) projected
// M-orthogonally onto the null space of G, x - M^-1 G^T S^+ G x, on the
// hosted problem as project_velocities: with x = M^-1 C^T, the velocities
// an impulse C^T p leaves per unit p once the joints have answered it
// (core/joint_impulses.hpp, collision_matrix: K = C x).
Eigen::MatrixXd project_onto_joints_null_space(const std::vector<CompliantBody>& bodies, const JointSet& joints,
                                               const MassMatrix& m, Eigen::MatrixXd x,
                                               MultiplierSolve* workspace = nullptr);

// The linkers' rolls about their own axes that best satisfy the joints
// (Gauss-Newton on the roll angles alone, least squares, at most
// max_iterations steps, each kept only when it lowers max |C|). A roll moves
// nothing the event loop sees (a cylinder of revolution), so an articulated
// cluster cut inside a slice fits its rolls, which the tracks only
// interpolate, without moving any surface.
struct RollFit {
  double residual_before = 0.0, residual_after = 0.0;  // max |C|
};
RollFit fit_rolls(std::vector<CompliantBody>& bodies, const JointSet& joints, int max_iterations = 3);

struct PositionProjection {
  double residual_before = 0.0;  // max |C| before
  double residual_after = 0.0;   // after the last step
  double displacement = 0.0;     // M-norm of the total correction, sqrt(sum dnu^T M dnu) over steps
  int iterations = 0;            // Gauss-Newton steps taken
  bool converged = false;        // residual_after <= tolerance (else the steps stalled or ran out)
  VelocityProjection velocities; // the velocity projection that follows
};
// Gauss-Newton on positions (at most max_iterations steps, fewer when a step
// no longer halves the residual: a singular pose), then velocities (with
// held_sines, they also measure the held rows: VelocityProjection).
PositionProjection project_positions(std::vector<CompliantBody>& bodies, const JointSet& joints, double tolerance,
                                     int max_iterations = 8, bool held_sines = false,
                                     MultiplierSolve* workspace = nullptr);

}  // namespace ringsim
