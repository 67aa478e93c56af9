// Stability study of the compliant-cluster integrators (docs/COMPLIANT.md).
//
// Study "stiffness": one four-corner open chain (tests/compliant_chain.hpp),
// released 0.2 length units and 4 degrees off the square pose at rest, is
// integrated over [0, T] (T = 2: the stiff transient and part of the slow
// arm-bending mode) for k = k_omega in {1e2 .. 1e6}, c = c_omega = k / 10,
// by CVODE BDF (dense and band DQ Jacobians), CVODE Adams (fixed point) and
// ARKODE ERK (Dormand-Prince 5(4)), each in one advance_to(T) at
// rtol 1e-6, atol 1e-8 with the default step cap (20000 steps per advance).
// Error: the largest deviation of any body position or axis at T from a BDF
// reference at rtol 1e-12, atol 1e-14. Wall time: the fastest of --repeat runs.
//
// Study "bandwidth": BDF dense vs band on staircase chains of growing length
// at Scenario 5's constants (k = k_omega = 1000, c = c_omega = 100).
//
// Output: CSV on stdout (one header, one row per run). Usage:
//   bench_compliant [--repeat R] [--span T] [--quick]
// Plot: bench/plot_compliant.py CSV docs/compliant_stability.png

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "compliant_chain.hpp"
#include "core/compliant_integrator.hpp"

using namespace ringsim;

namespace {

struct Run {
  AdvanceResult result;
  IntegratorStats stats;
  CompliantCluster state;
};

Run run_once(const CompliantCluster& c, const IntegratorOptions& o, double span) {
  ClusterIntegrator integ(c, 0.0, o);
  Run r;
  r.result = integ.advance_to(span);
  r.stats = integ.stats();
  r.state = integ.state();
  return r;
}

double pose_error(const CompliantCluster& a, const CompliantCluster& b) {
  double e = 0.0;
  for (std::size_t i = 0; i < a.bodies.size(); ++i) {
    e = std::max(e, (a.bodies[i].x - b.bodies[i].x).norm());
    if (a.bodies[i].shape == Shape::Linker) e = std::max(e, (a.bodies[i].axis() - b.bodies[i].axis()).norm());
  }
  return e;
}

std::string csv_quote(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) out += ch == '"' ? std::string("\"\"") : std::string(1, ch);
  return out + "\"";
}

void print_row(const char* study, double k, int bodies, int unknowns, const char* method, const char* solver,
               const Run& r, double wall, double error) {
  std::printf("%s,%g,%d,%d,%s,%s,%s,%ld,%ld,%ld,%ld,%ld,%ld,%ld,%.6e,%.6e,%.3e,%.9g,%s\n", study, k, bodies, unknowns, method,
              solver, to_string(r.result.status), r.stats.steps, r.stats.rhs_evals, r.stats.rhs_evals_jacobian,
              r.stats.jacobian_evals, r.stats.linear_setups, r.stats.nonlinear_iterations, r.stats.error_test_failures, wall,
              r.stats.rhs_seconds, error,
              r.result.t_stopped, csv_quote(r.result.reason).c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  int repeat = 3;
  double span = 2.0;
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--repeat") == 0 && i + 1 < argc) {
      repeat = std::max(1, std::atoi(argv[++i]));
    } else if (std::strcmp(argv[i], "--span") == 0 && i + 1 < argc) {
      span = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else {
      std::fprintf(stderr, "usage: %s [--repeat R] [--span T] [--quick]\n", argv[0]);
      return 2;
    }
  }

  std::printf(
      "study,k,bodies,unknowns,method,linear_solver,status,steps,rhs_evals,rhs_evals_jacobian,jacobian_evals,"
      "linear_setups,nonlinear_iterations,error_test_failures,wall_seconds,rhs_seconds,error,t_reached,reason\n");

  const BondingParams bonding;  // both filters: angle and dihedral terms
  test::ChainSetup setup;
  setup.dx = 0.2;
  setup.drot_deg = 4.0;
  setup.seed = 11;

  struct Variant {
    Method method;
    LinearSolver solver;
    const char* solver_name;
  };
  const Variant variants[] = {{Method::Bdf, LinearSolver::Dense, "dense"},
                              {Method::Bdf, LinearSolver::Band, "band"},
                              {Method::Adams, LinearSolver::Auto, "none"},
                              {Method::ExplicitRk, LinearSolver::Auto, "none"}};

  std::vector<double> ks = {1e2, 1e3, 1e4, 1e5, 1e6};
  if (quick) ks = {1e2, 1e4, 1e6};
  for (const double k : ks) {
    CompliantParams cp;
    cp.k = cp.k_omega = k;
    cp.c = cp.c_omega = k / 10.0;
    const CompliantCluster chain = test::four_corner_chain(cp, bonding, setup);

    IntegratorOptions ref_opt;
    ref_opt.rtol = 1e-12;
    ref_opt.atol = 1e-14;
    ref_opt.max_steps = 10000000;
    ref_opt.linear_solver = LinearSolver::Dense;
    ref_opt.time_rhs = true;
    const Run ref = run_once(chain, ref_opt, span);
    if (!ref.result.ok()) {
      std::fprintf(stderr, "reference failed at k = %g: %s\n", k, ref.result.reason.c_str());
      return 1;
    }
    print_row("stiffness", k, static_cast<int>(chain.bodies.size()), 0, "bdf-reference", "dense", ref,
              ref.stats.wall_seconds, 0.0);

    for (const Variant& v : variants) {
      IntegratorOptions o;
      o.method = v.method;
      o.time_rhs = true;
      o.linear_solver = v.solver;
      Run best;
      double wall = 1e300;
      for (int rep = 0; rep < repeat; ++rep) {
        Run r = run_once(chain, o, span);
        wall = std::min(wall, r.stats.wall_seconds);
        best = std::move(r);
      }
      const double err = best.result.ok() ? pose_error(best.state, ref.state) : -1.0;
      ClusterIntegrator probe(chain, 0.0, o);
      print_row("stiffness", k, static_cast<int>(chain.bodies.size()), probe.state_size(), to_string(v.method),
                v.solver_name, best, wall, err);
    }
  }

  // Band vs dense on longer chains at Scenario 5's constants.
  CompliantParams s5;
  s5.k = s5.k_omega = 1000.0;
  s5.c = s5.c_omega = 100.0;
  std::vector<int> corners = {4, 8, 16, 32, 64};
  if (quick) corners = {4, 16};
  for (const int n : corners) {
    const CompliantCluster chain = test::staircase_chain(n, s5, bonding, setup);
    for (const LinearSolver ls : {LinearSolver::Dense, LinearSolver::Band}) {
      IntegratorOptions o;
      o.linear_solver = ls;
      o.time_rhs = true;
      Run best;
      double wall = 1e300;
      for (int rep = 0; rep < repeat; ++rep) {
        Run r = run_once(chain, o, span);
        wall = std::min(wall, r.stats.wall_seconds);
        best = std::move(r);
      }
      ClusterIntegrator probe(chain, 0.0, o);
      print_row("bandwidth", 1000.0, static_cast<int>(chain.bodies.size()), probe.state_size(), "bdf",
                ls == LinearSolver::Dense ? "dense" : "band", best, wall, -1.0);
    }
  }
  return 0;
}
