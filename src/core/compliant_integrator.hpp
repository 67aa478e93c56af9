#pragma once
// Integration of one compliant cluster's equations of motion between two
// times with SUNDIALS 6.4 (docs/COMPLIANT.md has the measurements behind the
// choices).
//
// State (world frame), body by body in the cluster's order, so that a chain
// listed along its backbone gives a banded Jacobian:
//   sphere: x (3), v (3)                           -- 6 values
//   linker: x (3), q (4: w, x, y, z), v (3), L (3) -- 13 values
// L is the linker's world angular momentum about its centre. Equations:
//   dx/dt = v,  dv/dt = F / m,  dL/dt = tau             (world frame)
//   dq/dt = (1/2) (0, omega) (x) q + kappa (1 - |q|^2) q,
//   omega = L / I_perp + (1/I_axial - 1/I_perp) (L . u) u,  u = R(q / |q|) e_z,
// with F, tau from core/compliant.hpp evaluated on the normalized q. Why
// angular momentum rather than Euler's body-frame equations: no gyroscopic
// term, dL_total/dt = sum (x_i x F_i + tau_i) = 0 holds identically in the
// right-hand side, and (precession = L / I_perp, spin) is exactly the core's
// lazy Kinematics of a free linker (body.hpp). Quaternions: the right-hand
// side uses q / |q|; (0, omega) (x) q is tangent to the sphere |q| = const,
// so the exact flow keeps |q|; the kappa term (kappa = 1 per time unit, well
// below every mechanical rate, so it adds no stiffness) pulls the solver's
// drift of |q| back to 1 and cannot change the physics (only the direction
// of q is used); q is renormalized whenever the state is (re)loaded.
//
// Methods (enum Method):
//  - Bdf: CVODE, variable-order BDF (orders 1-5) with Newton iterations and a
//    direct linear solver on a difference-quotient (DQ) Jacobian: dense, or
//    banded when the term structure makes the band narrower than the matrix
//    (LinearSolver::Auto; a four-corner chain's dihedral terms reach across 5
//    bodies, half bandwidth 50 of its 76 unknowns, so it is dense; long
//    chains go banded). Measured: the right-hand side is ~4 % of BDF's time
//    (the dense LU dominates), so an analytic Jacobian could save at most the
//    ~2-3 % the DQ columns cost; none is provided;
//  - Adams: CVODE, variable-order Adams-Moulton (orders 1-12) with fixed-point
//    (functional) iteration: the classical non-stiff pairing;
//  - ExplicitRk: ARKODE ERKStep, Dormand-Prince 5(4) with adaptive steps (or
//    a fixed step when IntegratorOptions::fixed_step > 0).
//
// Failure is a status, never garbage or a hang: each advance_to() is capped
// at max_steps internal steps (SUNDIALS mxstep), and the right-hand side
// refuses a non-finite state (returns an unrecoverable error). The reason
// text names the time, the cap and the stiffness. Setup errors (SUNDIALS
// creation or option calls failing) throw SundialsError naming the function
// and its return flag; every SUNDIALS return code is checked.
//
// Articulated clusters (core/joints.hpp, docs/ARTICULATED.md): with a
// nonempty JointSet the right-hand side adds the constraint loads G^T lambda
// after the force field (cluster_loads, core/constrained_dynamics.hpp), so the
// flow keeps C'' = 0; nothing pulls C or C' back (no Baumgarte terms), so the
// caller removes the drift with project_onto_joints() where the state is the
// integrator's own (slice ends); it restarts the method.
//
// Events: advance_to(t) lands exactly on t (SUNDIALS stop time), so the state
// is the solver's own, not an interpolation. An impulse: advance_to(t_event),
// change velocities through state(), reinit() (CVodeReInit / ERKStepReInit:
// the method restarts at order 1). A change of the cluster's size needs a new
// ClusterIntegrator. Counters survive reinit (accumulated).

#include <memory>
#include <stdexcept>
#include <string>

#include "core/compliant.hpp"
#include "core/joint_projection.hpp"
#include "core/joints.hpp"

namespace ringsim {

enum class Method { Bdf, Adams, ExplicitRk };
enum class LinearSolver { Auto, Dense, Band };  // Bdf only

const char* to_string(Method m);

struct IntegratorOptions {
  Method method = Method::Bdf;
  double rtol = 1e-6;
  double atol = 1e-8;       // absolute tolerance on every state component
  long max_steps = 20000;   // internal steps allowed per advance_to()
  LinearSolver linear_solver = LinearSolver::Auto;
  double fixed_step = 0.0;  // ExplicitRk: > 0 = fixed step, no error control
  bool time_rhs = false;    // measure IntegratorStats::rhs_seconds (two clock reads per evaluation)
};

// Cumulative over the integrator's life (reinit included).
struct IntegratorStats {
  long steps = 0;
  long rhs_evals = 0;           // all right-hand-side evaluations, Jacobian DQ ones included
  long rhs_evals_jacobian = 0;  // of which for DQ Jacobians (Bdf)
  long jacobian_evals = 0;
  long linear_setups = 0;       // Newton matrix factorizations (Bdf)
  long nonlinear_iterations = 0;
  long nonlinear_failures = 0;  // convergence failures
  long error_test_failures = 0;
  long reinits = 0;
  long rhs_reused = 0;          // of rhs_evals: served from ClusterIntegrator::present_loads
  double wall_seconds = 0.0;    // inside the solver calls of advance_to()
  double rhs_seconds = 0.0;     // of which inside the right-hand side (IntegratorOptions::time_rhs)

  IntegratorStats& operator+=(const IntegratorStats& o) {  // every counter and time
    steps += o.steps;
    rhs_evals += o.rhs_evals;
    rhs_evals_jacobian += o.rhs_evals_jacobian;
    jacobian_evals += o.jacobian_evals;
    linear_setups += o.linear_setups;
    nonlinear_iterations += o.nonlinear_iterations;
    nonlinear_failures += o.nonlinear_failures;
    error_test_failures += o.error_test_failures;
    reinits += o.reinits;
    rhs_reused += o.rhs_reused;
    wall_seconds += o.wall_seconds;
    rhs_seconds += o.rhs_seconds;
    return *this;
  }
};

enum class IntegratorStatus { Ok, StepLimit, NonFinite, SolverError };
const char* to_string(IntegratorStatus s);

struct AdvanceResult {
  IntegratorStatus status = IntegratorStatus::Ok;
  double t = 0.0;          // time of state(): the target when ok, the last good time on failure
  double t_stopped = 0.0;  // where the solver stopped (= t when ok)
  std::string reason;      // empty when ok
  bool ok() const { return status == IntegratorStatus::Ok; }
};

class SundialsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class ClusterIntegrator {
 public:
  ClusterIntegrator(const CompliantCluster& cluster, double t0, const IntegratorOptions& options = {},
                    JointSet joints = {});
  ~ClusterIntegrator();
  ClusterIntegrator(ClusterIntegrator&&) noexcept;
  ClusterIntegrator& operator=(ClusterIntegrator&&) noexcept;
  ClusterIntegrator(const ClusterIntegrator&) = delete;
  ClusterIntegrator& operator=(const ClusterIntegrator&) = delete;

  // Integrates to t >= time(). After a failure the integrator keeps the last
  // good state and time and must not be advanced again (status stays).
  AdvanceResult advance_to(double t);

  double time() const;
  const CompliantCluster& state() const;  // at time()
  // For an impulse: change velocities (or positions) here, then reinit().
  CompliantCluster& mutable_state();
  void reinit();
  // The state in mutable_state() now stands at time t (before or after
  // time()): restart the method there (an impulse at an earlier time, read
  // from an interpolant).
  void reinit_at(double t);

  // Articulated: projects the state onto the joints (positions by
  // Gauss-Newton to max |C| <= tolerance, then velocities) and restarts the
  // method there (a reinit); returns the sizes of the correction.
  PositionProjection project_onto_joints(double tolerance, bool held_sines = false);
  // The multiplier solve project_onto_joints keeps (its sparse analysis
  // lasts while the joints do), for the cluster's other projections and
  // collision matrices (core/joint_impulses.hpp).
  MultiplierSolve& projection_workspace();
  // Every load on the members at the present state (the compliant field and
  // the constraint loads: the right-hand side's own evaluation, torques about
  // each centre with the gyroscopic term as in cluster_loads). The rates are
  // kept for the solver's first right-hand side after a restart at this
  // state (it would evaluate the same function at the same state): a slice
  // end's accelerations then cost the one evaluation the restart needs.
  void present_loads(std::vector<Vec3>& force, std::vector<Vec3>& torque);
  const JointSet& joints() const;
  // Articulated: hold these joints from now on (a subset of the present
  // ones: held rows released by a rank test) and restart the method.
  void set_joints(JointSet joints);

  const IntegratorStats& stats() const;
  const IntegratorOptions& options() const;
  int state_size() const;
  // Half bandwidths of the Jacobian implied by the terms (upper = lower).
  int half_bandwidth() const;
  bool banded() const;  // Bdf: the band solver was chosen

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ringsim
