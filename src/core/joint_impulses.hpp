#pragma once
// Impulses on an articulated cluster (docs/ARTICULATED.md): the constrained
// inverse mass seen by a contact, and an impulse applied together with the
// joint impulses it calls up.
//
// With M, G, S = G M^-1 G^T as in core/constrained_dynamics.hpp, an impulse
// C^T p on the velocity coordinates (C: the rows mapping nu to the velocities
// the impulse acts on) plus the joint impulses G^T mu that keep G nu' = 0 gives
//   nu' = nu + W C^T p,   W = M^-1 - M^-1 G^T S^+ G M^-1
// when G nu = 0 before (W is M^-1 followed by the M-orthogonal projection onto
// G nu = 0; S^+ the pseudo-inverse: redundant rows are harmless). So the
// contact law's collision matrix (core/contact.hpp) of an articulated side is
//   K = C W C^T,
// C = [1, -[r]x] on the body's (v, omega) columns for the velocity of a point
// at arm r; for two bodies of the same cluster C = C_B - C_A (the cross terms).

#include <vector>

#include <Eigen/Core>

#include "core/joints.hpp"

namespace ringsim {

class MultiplierSolve;  // core/constrained_dynamics.hpp

// The 3 x n rows of v_b + omega_b x arm (a sphere: v_b; arm ignored).
Eigen::MatrixXd point_velocity_rows(const std::vector<CompliantBody>& bodies, const VelocityLayout& layout, int body,
                                    const Vec3& arm);

// Collision matrix K = C W C^T (3 x 3, symmetric) for the rows c (3 x n)
// at the present pose, computed as C times W C^T, which is M^-1 C^T
// projected onto G's null space on the hosted problem
// (project_onto_joints_null_space: three corrections, one factorization;
// W itself is never formed). workspace, here and below: the cluster's
// MultiplierSolve kept from call to call (ClusterIntegrator::
// projection_workspace), so that its sparse analysis is made once per
// pattern of joints; null: one of the call's own. The results do not
// depend on it.
Mat3 collision_matrix(const std::vector<CompliantBody>& bodies, const JointSet& joints, const Eigen::MatrixXd& c,
                      MultiplierSolve* workspace = nullptr);
// K of a point of one body (contact with another cluster or a wall), and of
// the relative velocity between points of two bodies of the same cluster
// (u = v_B(point) - v_A(point)).
Mat3 collision_matrix(const std::vector<CompliantBody>& bodies, const JointSet& joints, int body, const Vec3& arm,
                      MultiplierSolve* workspace = nullptr);
Mat3 collision_matrix(const std::vector<CompliantBody>& bodies, const JointSet& joints, int body_a,
                      const Vec3& arm_a, int body_b, const Vec3& arm_b, MultiplierSolve* workspace = nullptr);

// Applies the impulse C^T p with the joint impulses: nu <- P (nu + M^-1 C^T p),
// P the M-orthogonal projection onto G nu = 0 (= nu + W C^T p when G nu = 0).
void apply_impulse(std::vector<CompliantBody>& bodies, const JointSet& joints, const Eigen::MatrixXd& c,
                   const Eigen::VectorXd& p, MultiplierSolve* workspace = nullptr);
// The same for an impulse J at a point of one body (J on that body).
void apply_point_impulse(std::vector<CompliantBody>& bodies, const JointSet& joints, int body, const Vec3& arm,
                         const Vec3& impulse, MultiplierSolve* workspace = nullptr);

}  // namespace ringsim
