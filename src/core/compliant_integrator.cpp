#include "core/compliant_integrator.hpp"

#include <arkode/arkode_erkstep.h>
#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_band.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_band.h>
#include <sunmatrix/sunmatrix_dense.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/constrained_dynamics.hpp"
#include "core/serial_vector_ops.hpp"

namespace ringsim {
namespace {

constexpr int kSphereSize = 6;
constexpr int kLinkerSize = 13;
// Relaxation rate of |q| toward 1 (per time unit); see the header.
constexpr double kQuatRestore = 1.0;

// ---- RAII owners of SUNDIALS handles -----------------------------------------

struct ContextFree {
  void operator()(SUNContext c) const { SUNContext_Free(&c); }
};
struct VectorFree {
  void operator()(N_Vector v) const { N_VDestroy(v); }
};
struct MatrixFree {
  void operator()(SUNMatrix m) const { SUNMatDestroy(m); }
};
struct LinSolFree {
  void operator()(SUNLinearSolver s) const { SUNLinSolFree(s); }
};
struct NonlinSolFree {
  void operator()(SUNNonlinearSolver s) const { SUNNonlinSolFree(s); }
};
template <typename Handle, typename Free>
using Owned = std::unique_ptr<std::remove_pointer_t<Handle>, Free>;

// Solver memory of CVODE or ERKStep (a void*), freed with the matching call.
class SolverMemory {
 public:
  SolverMemory() = default;
  SolverMemory(const SolverMemory&) = delete;
  SolverMemory& operator=(const SolverMemory&) = delete;
  ~SolverMemory() { release(); }
  void reset(void* mem, bool cvode) {
    release();
    mem_ = mem;
    cvode_ = cvode;
  }
  void* get() const { return mem_; }

 private:
  void release() {
    if (mem_ == nullptr) return;
    if (cvode_) {
      CVodeFree(&mem_);
    } else {
      ERKStepFree(&mem_);
    }
    mem_ = nullptr;
  }
  void* mem_ = nullptr;
  bool cvode_ = true;
};

std::string flag_name(bool cvode, int flag) {
  char* name = cvode ? CVodeGetReturnFlagName(flag) : ERKStepGetReturnFlagName(flag);
  std::string s = name != nullptr ? name : "?";
  std::free(name);  // SUNDIALS allocates the name with malloc
  return s + " (" + std::to_string(flag) + ")";
}

std::string format_g(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", x);
  return buf;
}

}  // namespace

const char* to_string(Method m) {
  switch (m) {
    case Method::Bdf: return "bdf";
    case Method::Adams: return "adams";
    case Method::ExplicitRk: return "erk";
  }
  return "?";
}

const char* to_string(IntegratorStatus s) {
  switch (s) {
    case IntegratorStatus::Ok: return "ok";
    case IntegratorStatus::StepLimit: return "step_limit";
    case IntegratorStatus::NonFinite: return "non_finite";
    case IntegratorStatus::SolverError: return "solver_error";
  }
  return "?";
}

struct ClusterIntegrator::Impl {
  CompliantCluster cluster;
  IntegratorOptions options;
  double t = 0.0;
  IntegratorStats stats;        // totals reported
  IntegratorStats base;         // totals of solver lives ended by reinit
  AdvanceResult failure;        // first failure, sticky
  std::vector<int> offset;      // state offset of each body
  int n = 0;
  int half_band = 0;
  bool band = false;
  bool cvode = true;
  // Right-hand-side scratch (no allocation per call).
  std::vector<BodyMotion> motion;
  std::vector<Vec3> force, torque;
  // Articulated: the joints, and the bodies' poses and velocities at the
  // state being evaluated (the constraint rows need full orientations).
  JointSet joints;
  std::vector<CompliantBody> work;
  ConstraintLoads constraint_loads;
  // present_loads' state and rates, for the solver's first right-hand side
  // after a restart (the same function of the same state: the same rates).
  bool memo = false;
  std::vector<double> memo_state, memo_rate;
  MultiplierSolve projection_solve;  // project_onto_joints' workspace (its analysis kept)
  bool non_finite = false;
  double non_finite_t = 0.0;
  // BDF: the total momentum and the mass-weighted sum of positions of the
  // state the solver started from at t_start (create, restart); every state it
  // returns is put back on the centre-of-mass motion they define (below).
  Vec3 momentum0 = Vec3::Zero(), moment0 = Vec3::Zero();
  double t_start = 0.0;
  double rhs_seconds = 0.0;  // time inside the right-hand side, whole life
  long rhs_reused = 0;       // right-hand sides served by the memo, whole life
  std::string last_message;  // last SUNDIALS error/warning text

  // Declaration order = reverse destruction order: the context outlives all.
  Owned<SUNContext, ContextFree> ctx;
  Owned<N_Vector, VectorFree> y;
  Owned<SUNMatrix, MatrixFree> A;
  Owned<SUNLinearSolver, LinSolFree> ls;
  Owned<SUNNonlinearSolver, NonlinSolFree> nls;
  SolverMemory mem;

  void check(int flag, const char* function) const {
    if (flag < 0) {
      throw SundialsError(std::string(function) + " failed: " + flag_name(cvode, flag) +
                          (last_message.empty() ? "" : ": " + last_message));
    }
  }
  template <typename T>
  T* check_ptr(T* p, const char* function) const {
    if (p == nullptr) throw SundialsError(std::string(function) + " returned NULL");
    return p;
  }

  static void error_handler(int, const char* module, const char* function, char* msg, void* data) {
    auto* self = static_cast<Impl*>(data);
    self->last_message = std::string("[") + (module ? module : "") + "] " + (function ? function : "") + ": " +
                         (msg ? msg : "");
  }

  static int rhs(sunrealtype t, N_Vector yv, N_Vector ydot, void* data) {
    auto* self = static_cast<Impl*>(data);
    if (self->memo) {  // the solver's first call after present_loads, at the same state: its rates
      self->memo = false;
      const double* s = N_VGetArrayPointer(yv);
      if (std::equal(s, s + self->n, self->memo_state.begin())) {
        std::copy(self->memo_rate.begin(), self->memo_rate.end(), N_VGetArrayPointer(ydot));
        ++self->rhs_reused;
        return 0;
      }
    }
    if (!self->options.time_rhs) return self->evaluate(t, N_VGetArrayPointer(yv), N_VGetArrayPointer(ydot));
    const auto start = std::chrono::steady_clock::now();
    const int flag = self->evaluate(t, N_VGetArrayPointer(yv), N_VGetArrayPointer(ydot));
    self->rhs_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return flag;
  }

  // --- state layout -------------------------------------------------------------

  void layout() {
    offset.resize(cluster.bodies.size());
    n = 0;
    for (std::size_t i = 0; i < cluster.bodies.size(); ++i) {
      offset[i] = n;
      n += cluster.bodies[i].shape == Shape::Sphere ? kSphereSize : kLinkerSize;
    }
    // Every unknown of a term's bodies may depend on every other one (and a
    // body's unknowns on each other): the half bandwidth is the widest span
    // of state indices touched by one term.
    auto span = [&](std::initializer_list<int> bodies) {
      int lo = n, hi = 0;
      for (const int b : bodies) {
        lo = std::min(lo, offset[b]);
        hi = std::max(hi, offset[b] + size_of(b) - 1);
      }
      return hi - lo;
    };
    half_band = 0;
    for (std::size_t i = 0; i < cluster.bodies.size(); ++i) half_band = std::max(half_band, size_of(int(i)) - 1);
    for (const CompliantBond& b : cluster.bonds) half_band = std::max(half_band, span({b.sphere, b.linker}));
    for (const CompliantAngle& a : cluster.angles) half_band = std::max(half_band, span({a.linker_a, a.linker_b}));
    for (const CompliantDihedral& d : cluster.dihedrals) {
      half_band = std::max(half_band, span({d.linker, d.nb0, d.nb1}));
    }
    motion.resize(cluster.bodies.size());
    work = cluster.bodies;
  }
  int size_of(int b) const { return cluster.bodies[b].shape == Shape::Sphere ? kSphereSize : kLinkerSize; }

  void pack() { pack(N_VGetArrayPointer(y.get())); }
  void pack(double* s) {
    for (std::size_t i = 0; i < cluster.bodies.size(); ++i) {
      CompliantBody& b = cluster.bodies[i];
      double* p = s + offset[i];
      for (int k = 0; k < 3; ++k) p[k] = b.x[k];
      if (b.shape == Shape::Sphere) {
        for (int k = 0; k < 3; ++k) p[3 + k] = b.v[k];
        continue;
      }
      b.q.normalize();
      p[3] = b.q.w(), p[4] = b.q.x(), p[5] = b.q.y(), p[6] = b.q.z();
      const Vec3 L = b.angular_momentum();
      for (int k = 0; k < 3; ++k) p[7 + k] = b.v[k], p[10 + k] = L[k];
    }
  }

  void unpack() {
    const double* s = N_VGetArrayPointer(y.get());
    for (std::size_t i = 0; i < cluster.bodies.size(); ++i) {
      CompliantBody& b = cluster.bodies[i];
      const double* p = s + offset[i];
      b.x = Vec3(p[0], p[1], p[2]);
      if (b.shape == Shape::Sphere) {
        b.v = Vec3(p[3], p[4], p[5]);
        continue;
      }
      b.q = Quat(p[3], p[4], p[5], p[6]).normalized();
      b.v = Vec3(p[7], p[8], p[9]);
      const Vec3 L(p[10], p[11], p[12]);
      const Vec3 u = b.axis();
      b.omega = L / b.i_perp + (1.0 / b.i_axial - 1.0 / b.i_perp) * L.dot(u) * u;
    }
  }

  // --- right-hand side ------------------------------------------------------------

  int evaluate(double time, const double* s, double* f) {
    for (int k = 0; k < n; ++k) {
      if (!std::isfinite(s[k])) {
        non_finite = true;
        non_finite_t = time;
        return -1;  // unrecoverable: the solver stops with *_RHSFUNC_FAIL
      }
    }
    for (std::size_t i = 0; i < cluster.bodies.size(); ++i) {
      const CompliantBody& b = cluster.bodies[i];
      const double* p = s + offset[i];
      BodyMotion& m = motion[i];
      m.x = Vec3(p[0], p[1], p[2]);
      if (b.shape == Shape::Sphere) {
        m.v = Vec3(p[3], p[4], p[5]);
        m.u = Vec3::UnitZ();
        m.omega = b.omega;  // constant spin of a smooth sphere
        continue;
      }
      const Quat q = Quat(p[3], p[4], p[5], p[6]).normalized();
      m.u = q * Vec3::UnitZ();
      m.v = Vec3(p[7], p[8], p[9]);
      const Vec3 L(p[10], p[11], p[12]);
      m.omega = L / b.i_perp + (1.0 / b.i_axial - 1.0 / b.i_perp) * L.dot(m.u) * m.u;
    }
    compliant_loads(cluster, motion, true, force, torque);
    if (!joints.empty()) {
      for (std::size_t i = 0; i < cluster.bodies.size(); ++i) {
        const double* p = s + offset[i];
        CompliantBody& w = work[i];
        w.x = motion[i].x;
        w.v = motion[i].v;
        if (w.shape == Shape::Sphere) continue;
        w.q = Quat(p[3], p[4], p[5], p[6]).normalized();
        w.omega = motion[i].omega;
      }
      constraint_loads.add(work, joints, force, torque);
    }
    for (std::size_t i = 0; i < cluster.bodies.size(); ++i) {
      const CompliantBody& b = cluster.bodies[i];
      const double* p = s + offset[i];
      double* d = f + offset[i];
      const Vec3 acc = force[i] / b.mass;
      if (b.shape == Shape::Sphere) {
        for (int k = 0; k < 3; ++k) d[k] = p[3 + k], d[3 + k] = acc[k];
        continue;
      }
      // dq/dt = (1/2) (0, omega) (x) q  [world-frame omega multiplies on the
      // left], plus the norm restoring term kappa (1 - |q|^2) q.
      const double qw = p[3];
      const Vec3 qv(p[4], p[5], p[6]);
      const Vec3& w = motion[i].omega;
      const double restore = kQuatRestore * (1.0 - (qw * qw + qv.squaredNorm()));
      const Vec3 dqv = 0.5 * (qw * w + w.cross(qv)) + restore * qv;
      d[3] = -0.5 * w.dot(qv) + restore * qw;
      for (int k = 0; k < 3; ++k) {
        d[k] = p[7 + k];
        d[4 + k] = dqv[k];
        d[7 + k] = acc[k];
        d[10 + k] = torque[i][k];
      }
    }
    return 0;
  }

  // --- setup ------------------------------------------------------------------------

  void create(double t0) {
    cvode = options.method != Method::ExplicitRk;
    SUNContext c = nullptr;
    if (SUNContext_Create(nullptr, &c) != 0 || c == nullptr) throw SundialsError("SUNContext_Create failed");
    ctx.reset(c);
    y.reset(check_ptr(N_VNew_Serial(n, ctx.get()), "N_VNew_Serial"));
    // Before any solver clones y, so that its work vectors inherit them.
    use_one_pass_operations(y.get());
    pack();
    remember_centre_of_mass_motion();

    switch (options.method) {
      case Method::Bdf: {
        mem.reset(check_ptr(CVodeCreate(CV_BDF, ctx.get()), "CVodeCreate"), true);
        init_cvode(t0);
        // Auto: band as soon as the band is narrower than the matrix; measured
        // (docs/COMPLIANT.md) no slower than dense even when it barely is, and
        // 1.5x / 5x / 12x faster at 171 / 627 / 1235 unknowns.
        band = options.linear_solver == LinearSolver::Band ||
               (options.linear_solver == LinearSolver::Auto && 2 * half_band + 1 < n);
        if (band) {
          A.reset(check_ptr(SUNBandMatrix(n, half_band, half_band, ctx.get()), "SUNBandMatrix"));
          ls.reset(check_ptr(SUNLinSol_Band(y.get(), A.get(), ctx.get()), "SUNLinSol_Band"));
        } else {
          A.reset(check_ptr(SUNDenseMatrix(n, n, ctx.get()), "SUNDenseMatrix"));
          ls.reset(check_ptr(SUNLinSol_Dense(y.get(), A.get(), ctx.get()), "SUNLinSol_Dense"));
        }
        // No Jacobian function: CVODE's difference-quotient Jacobian (dense:
        // n right-hand sides; band: 2 half_band + 1), docs/COMPLIANT.md.
        check(CVodeSetLinearSolver(mem.get(), ls.get(), A.get()), "CVodeSetLinearSolver");
        break;
      }
      case Method::Adams: {
        mem.reset(check_ptr(CVodeCreate(CV_ADAMS, ctx.get()), "CVodeCreate"), true);
        init_cvode(t0);
        nls.reset(check_ptr(SUNNonlinSol_FixedPoint(y.get(), 0, ctx.get()), "SUNNonlinSol_FixedPoint"));
        check(CVodeSetNonlinearSolver(mem.get(), nls.get()), "CVodeSetNonlinearSolver");
        break;
      }
      case Method::ExplicitRk: {
        mem.reset(check_ptr(ERKStepCreate(&Impl::rhs, t0, y.get(), ctx.get()), "ERKStepCreate"), false);
        check(ERKStepSetErrHandlerFn(mem.get(), &Impl::error_handler, this), "ERKStepSetErrHandlerFn");
        check(ERKStepSetUserData(mem.get(), this), "ERKStepSetUserData");
        check(ERKStepSStolerances(mem.get(), options.rtol, options.atol), "ERKStepSStolerances");
        check(ERKStepSetMaxNumSteps(mem.get(), options.max_steps), "ERKStepSetMaxNumSteps");
        check(ERKStepSetTableNum(mem.get(), ARKODE_DORMAND_PRINCE_7_4_5), "ERKStepSetTableNum");
        if (options.fixed_step > 0.0) check(ERKStepSetFixedStep(mem.get(), options.fixed_step), "ERKStepSetFixedStep");
        break;
      }
    }
  }

  void init_cvode(double t0) {
    check(CVodeSetErrHandlerFn(mem.get(), &Impl::error_handler, this), "CVodeSetErrHandlerFn");
    check(CVodeInit(mem.get(), &Impl::rhs, t0, y.get()), "CVodeInit");
    check(CVodeSetUserData(mem.get(), this), "CVodeSetUserData");
    check(CVodeSStolerances(mem.get(), options.rtol, options.atol), "CVodeSStolerances");
    check(CVodeSetMaxNumSteps(mem.get(), options.max_steps), "CVodeSetMaxNumSteps");
  }

  // --- statistics ---------------------------------------------------------------------

  IntegratorStats solver_counts() const {
    IntegratorStats s;
    long v = 0;
    if (cvode) {
      check(CVodeGetNumSteps(mem.get(), &v), "CVodeGetNumSteps");
      s.steps = v;
      check(CVodeGetNumRhsEvals(mem.get(), &v), "CVodeGetNumRhsEvals");
      s.rhs_evals = v;
      check(CVodeGetNumNonlinSolvIters(mem.get(), &v), "CVodeGetNumNonlinSolvIters");
      s.nonlinear_iterations = v;
      check(CVodeGetNumNonlinSolvConvFails(mem.get(), &v), "CVodeGetNumNonlinSolvConvFails");
      s.nonlinear_failures = v;
      check(CVodeGetNumErrTestFails(mem.get(), &v), "CVodeGetNumErrTestFails");
      s.error_test_failures = v;
      if (options.method == Method::Bdf) {
        check(CVodeGetNumLinRhsEvals(mem.get(), &v), "CVodeGetNumLinRhsEvals");
        s.rhs_evals_jacobian = v;
        s.rhs_evals += v;
        check(CVodeGetNumJacEvals(mem.get(), &v), "CVodeGetNumJacEvals");
        s.jacobian_evals = v;
        check(CVodeGetNumLinSolvSetups(mem.get(), &v), "CVodeGetNumLinSolvSetups");
        s.linear_setups = v;
      }
    } else {
      check(ERKStepGetNumSteps(mem.get(), &v), "ERKStepGetNumSteps");
      s.steps = v;
      check(ERKStepGetNumRhsEvals(mem.get(), &v), "ERKStepGetNumRhsEvals");
      s.rhs_evals = v;
      check(ERKStepGetNumErrTestFails(mem.get(), &v), "ERKStepGetNumErrTestFails");
      s.error_test_failures = v;
    }
    return s;
  }

  void refresh_stats(double wall) {
    const IntegratorStats c = solver_counts();
    const double total_wall = stats.wall_seconds + wall;
    stats = base;
    stats += c;  // (the solver's own counts carry no times)
    stats.wall_seconds = total_wall;
    stats.rhs_seconds = rhs_seconds;
    stats.rhs_reused = rhs_reused;
  }

  // --- stepping -----------------------------------------------------------------------

  AdvanceResult advance(double tout) {
    if (!failure.ok()) return failure;
    AdvanceResult r;
    r.t = r.t_stopped = t;
    if (!(tout >= t)) {
      r.status = IntegratorStatus::SolverError;
      r.reason = "advance_to(" + format_g(tout) + ") is before the integrator's time " + format_g(t);
      return r;
    }
    // Closer than CVODE can resolve (it would refuse with CV_TOO_CLOSE):
    // nothing to integrate.
    if (tout - t <= 4.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, std::abs(tout))) return r;

    const auto start = std::chrono::steady_clock::now();
    double tret = t;
    int flag = 0;
    if (cvode) {
      check(CVodeSetStopTime(mem.get(), tout), "CVodeSetStopTime");
      flag = CVode(mem.get(), tout, y.get(), &tret, CV_NORMAL);
    } else {
      check(ERKStepSetStopTime(mem.get(), tout), "ERKStepSetStopTime");
      flag = ERKStepEvolve(mem.get(), tout, y.get(), &tret, ARK_NORMAL);
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    refresh_stats(wall);

    if (flag >= 0) {
      bool finite = true;
      const double* s = N_VGetArrayPointer(y.get());
      for (int k = 0; k < n; ++k) finite = finite && std::isfinite(s[k]);
      if (finite) {
        t = tret;
        unpack();
        if (options.method == Method::Bdf) restore_centre_of_mass_motion();
        r.t = r.t_stopped = t;
        return r;
      }
      non_finite = true;
      non_finite_t = tret;
    }
    // Failure: keep the last good state (y may hold a partial or bad step).
    // The solver's current time says how far it got.
    double reached = tret;
    if (cvode) {
      CVodeGetCurrentTime(mem.get(), &reached);
    } else {
      ERKStepGetCurrentTime(mem.get(), &reached);
    }
    pack();  // restore y from the last good state
    r.t = t;
    r.t_stopped = non_finite ? non_finite_t : reached;
    const std::string stiffness = "k = " + format_g(cluster.params.k) + ", k_omega = " +
                                  format_g(cluster.params.k_omega) + ", method " + to_string(options.method);
    const bool too_much_work = cvode ? flag == CV_TOO_MUCH_WORK : flag == ARK_TOO_MUCH_WORK;
    if (non_finite) {
      r.status = IntegratorStatus::NonFinite;
      r.reason = "non-finite state at t = " + format_g(non_finite_t) + " (" + stiffness + ")";
    } else if (too_much_work) {
      r.status = IntegratorStatus::StepLimit;
      r.reason = "step limit reached at t = " + format_g(reached) + " (" + std::to_string(options.max_steps) +
                 " steps toward t = " + format_g(tout) + "; " + stiffness + ")";
    } else {
      r.status = IntegratorStatus::SolverError;
      r.reason = std::string(cvode ? "CVode" : "ERKStepEvolve") + " failed at t = " + format_g(reached) + ": " +
                 flag_name(cvode, flag) + (last_message.empty() ? "" : ": " + last_message) + " (" + stiffness +
                 ")";
    }
    failure = r;
    return r;
  }

  // The internal forces sum to zero, so the exact flow keeps the total
  // momentum P and moves the centre of mass uniformly (sum m x = X0 + P t),
  // and so do Adams' fixed-point iteration and the explicit Runge-Kutta
  // stages (linear combinations of right-hand sides: to round-off). BDF's
  // Newton iteration does not: it stops at its convergence test on a matrix
  // from a difference-quotient Jacobian, and each step moves both sums by
  // about the solver tolerance (four-corner chain, k = 1e5, rtol 1e-6:
  // momentum 1.5e-10 relative in 10 time units). The members' cubic tracks
  // carry it into the event loop amplified: their momentum inside a slice
  // is the chord's, sum m (x_b - x_a) / D, so a position drift counts divided
  // by the slice length (validated periodic replicates with stiff compliant
  // clusters: momentum errors up to 9e-6). Each returned state gets both
  // drifts back as one velocity shift and one translation of every body (the
  // smallest changes in the mass-weighted norm); the solver's own history is
  // left as it is, so its steps are unchanged.
  void remember_centre_of_mass_motion() {
    momentum0 = total_momentum(cluster);
    moment0 = Vec3::Zero();
    for (const CompliantBody& b : cluster.bodies) moment0 += b.mass * b.x;
    t_start = t;
  }
  void restore_centre_of_mass_motion() {
    double mass = 0.0;
    Vec3 moment = Vec3::Zero();
    for (const CompliantBody& b : cluster.bodies) mass += b.mass, moment += b.mass * b.x;
    const Vec3 dv = (momentum0 - total_momentum(cluster)) / mass;
    const Vec3 dx = (moment0 + (t - t_start) * momentum0 - moment) / mass;
    for (CompliantBody& b : cluster.bodies) b.v += dv, b.x += dx;
  }

  void restart() {
    memo = false;
    refresh_stats(0.0);
    base = stats;
    base.reinits += 1;
    pack();
    remember_centre_of_mass_motion();
    if (cvode) {
      check(CVodeReInit(mem.get(), t, y.get()), "CVodeReInit");
    } else {
      // Articulated clusters restart at every slice end (the projection):
      // a one-step method loses nothing there but its step size, which the
      // solver would estimate again from scratch (extra right-hand sides).
      // Start from the step its controller proposed next (not the last one
      // taken, often cut short to land on the slice end). Scenario 1 to
      // t = 100: 2.34 M right-hand sides -> 1.03 M. Compliant clusters keep
      // the estimate: their trajectories stay as they were.
      double h = 0.0;
      if (!joints.empty()) ERKStepGetCurrentStep(mem.get(), &h);
      check(ERKStepReInit(mem.get(), &Impl::rhs, t, y.get()), "ERKStepReInit");
      if (h > 0.0) check(ERKStepSetInitStep(mem.get(), h), "ERKStepSetInitStep");
    }
    stats = base;
  }
};

ClusterIntegrator::ClusterIntegrator(const CompliantCluster& cluster, double t0, const IntegratorOptions& options,
                                     JointSet joints)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.cluster = cluster;
  m.joints = std::move(joints);
  m.options = options;
  m.t = t0;
  m.failure.t = t0;
  if (cluster.bodies.empty()) throw SundialsError("ClusterIntegrator: empty cluster");
  if (!(options.rtol > 0.0) || !(options.atol > 0.0) || options.max_steps <= 0) {
    throw SundialsError("ClusterIntegrator: rtol, atol and max_steps must be > 0");
  }
  const std::string bad = check_joints(cluster.bodies, m.joints);
  if (!bad.empty()) throw SundialsError("ClusterIntegrator: " + bad);
  m.layout();
  m.create(t0);
}

ClusterIntegrator::~ClusterIntegrator() = default;
ClusterIntegrator::ClusterIntegrator(ClusterIntegrator&&) noexcept = default;
ClusterIntegrator& ClusterIntegrator::operator=(ClusterIntegrator&&) noexcept = default;

AdvanceResult ClusterIntegrator::advance_to(double t) { return impl_->advance(t); }
double ClusterIntegrator::time() const { return impl_->t; }
const CompliantCluster& ClusterIntegrator::state() const { return impl_->cluster; }
CompliantCluster& ClusterIntegrator::mutable_state() {
  impl_->memo = false;
  return impl_->cluster;
}
void ClusterIntegrator::reinit() { impl_->restart(); }
void ClusterIntegrator::reinit_at(double t) {
  impl_->t = t;
  impl_->restart();
}
MultiplierSolve& ClusterIntegrator::projection_workspace() { return impl_->projection_solve; }
void ClusterIntegrator::present_loads(std::vector<Vec3>& force, std::vector<Vec3>& torque) {
  Impl& m = *impl_;
  m.memo_state.resize(m.n);
  m.memo_rate.resize(m.n);
  m.pack(m.memo_state.data());
  const bool non_finite = m.non_finite;
  const double non_finite_t = m.non_finite_t;
  m.memo = m.evaluate(m.t, m.memo_state.data(), m.memo_rate.data()) == 0;
  m.non_finite = non_finite, m.non_finite_t = non_finite_t;  // a failure here is the caller's to see (non-finite loads)
  force = m.force;
  torque = m.torque;
}
PositionProjection ClusterIntegrator::project_onto_joints(double tolerance, bool held_sines) {
  PositionProjection r =
      project_positions(impl_->cluster.bodies, impl_->joints, tolerance, 8, held_sines, &impl_->projection_solve);
  impl_->restart();
  return r;
}
const JointSet& ClusterIntegrator::joints() const { return impl_->joints; }
void ClusterIntegrator::set_joints(JointSet joints) {
  impl_->joints = std::move(joints);
  impl_->restart();
}
const IntegratorStats& ClusterIntegrator::stats() const { return impl_->stats; }
const IntegratorOptions& ClusterIntegrator::options() const { return impl_->options; }
int ClusterIntegrator::state_size() const { return impl_->n; }
int ClusterIntegrator::half_bandwidth() const { return impl_->half_band; }
bool ClusterIntegrator::banded() const { return impl_->band; }

}  // namespace ringsim
