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
// Study "scenario": the clusters a Scenario 5 replicate integrates. Seed 1
// runs to t = --collect (default 300) with Scenario 5's constants; every
// compliant cluster a bond creates or changes is recorded in its state at the
// bond (stretched at the capture distance: the stiff transient). Each is then
// integrated over [0, T] with k = k_omega in {1e2 .. 1e6}, c = k / 10, as
// above; a row sums the work over all clusters, its error is the largest over
// them, its status the first failure's.
//
// Study "replicate": the same replicate (seed 1) through the event loop to
// t = --replicate-span (default 10) with each k and method: the solver's
// steps and right-hand sides, the replicate's wall time, and its end: a
// failure is the replicate's error (as an ensemble would record it).
//
// Output: CSV on stdout (one header, one row per run). Usage:
//   bench_compliant [--repeat R] [--span T] [--collect T] [--replicate-span T]
//                   [--studies LIST: stiffness,bandwidth (default), scenario] [--quick]
// ("scenario" runs both Scenario 5 studies.)
// Plot: bench/plot_compliant.py CSV docs/compliant_stability.png

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "compliant_chain.hpp"
#include "core/compliant_integrator.hpp"
#include "core/scene.hpp"
#include "core/simulation.hpp"

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

struct Variant {
  Method method;
  LinearSolver solver;
  const char* solver_name;
};

// The "scenario" and "replicate" studies (header comment).
void scenario_studies(const std::vector<double>& ks, const std::vector<Variant>& variants, double collect, double span,
                      double replicate_span, int repeat) {
  const SimParams p = test::scenario5_scene(collect);
  std::vector<CompliantCluster> clusters;
  {
    Simulation sim(p, build_scene(p, 1, 0, nullptr));
    sim.set_cluster_observer([&](const CompliantCluster& c, double) { clusters.push_back(c); });
    if (sim.run() == Termination::Error) std::fprintf(stderr, "collecting replicate failed: %s\n", sim.error().c_str());
  }
  std::size_t largest = 0;
  for (const CompliantCluster& c : clusters) largest = std::max(largest, c.bodies.size());
  std::fprintf(stderr, "scenario study: %zu clusters recorded (largest %zu bodies) in t <= %g\n", clusters.size(),
               largest, collect);
  for (const double k : ks) {
    std::vector<CompliantCluster> at_k = clusters;
    for (CompliantCluster& c : at_k) {
      c.params.k = c.params.k_omega = k;
      c.params.c = c.params.c_omega = k / 10.0;
    }
    IntegratorOptions ref_opt;
    ref_opt.rtol = 1e-12;
    ref_opt.atol = 1e-14;
    ref_opt.max_steps = 10000000;
    std::vector<CompliantCluster> ref_end;
    Run ref;
    for (const CompliantCluster& c : at_k) {
      Run r = run_once(c, ref_opt, span);
      if (!r.result.ok()) std::fprintf(stderr, "reference failed at k = %g: %s\n", k, r.result.reason.c_str());
      ref.stats += r.stats;
      ref_end.push_back(r.state);
    }
    print_row("scenario", k, static_cast<int>(at_k.size()), 0, "bdf-reference", "auto", ref, ref.stats.wall_seconds,
              0.0);
    for (const Variant& v : variants) {
      IntegratorOptions o;
      o.method = v.method;
      o.linear_solver = v.solver;
      Run total;
      double error = 0.0, wall = 1e300;
      bool failed = false;
      for (int rep = 0; rep < repeat; ++rep) {
        Run sum;
        double err = 0.0;
        bool fail = false;
        for (std::size_t i = 0; i < at_k.size(); ++i) {
          const Run r = run_once(at_k[i], o, span);
          sum.stats += r.stats;
          if (!r.result.ok() && !fail) {
            fail = true;
            sum.result = r.result;
            sum.result.reason = "cluster " + std::to_string(i) + " of " + std::to_string(at_k.size()) + ": " + r.result.reason;
          }
          if (r.result.ok()) err = std::max(err, pose_error(r.state, ref_end[i]));
        }
        if (!fail) sum.result.t_stopped = span;
        wall = std::min(wall, sum.stats.wall_seconds);
        total = sum;
        error = err;
        failed = fail;
      }
      print_row("scenario", k, static_cast<int>(at_k.size()), 0, to_string(v.method), v.solver_name, total, wall,
                failed ? -1.0 : error);
    }
  }

  // The replicate itself, through the event loop, with each k and method;
  // then the stiffest k once more with slices of 1 time unit, where a
  // method limited by stability meets the step cap of one advance (20000).
  std::vector<std::pair<double, double>> runs;  // (k, compliant.slice)
  for (const double k : ks) runs.emplace_back(k, SimParams().compliant.slice);
  runs.emplace_back(ks.back(), 1.0);
  for (const auto& [k, slice] : runs) {
    for (const Variant& v : variants) {
      if (v.solver == LinearSolver::Band) continue;  // the event loop picks the linear solver itself
      SimParams q = test::scenario5_scene(replicate_span);
      q.compliant.k = q.compliant.k_omega = k;
      q.compliant.c = q.compliant.c_omega = k / 10.0;
      q.compliant.slice = slice;
      q.compliant.method = v.method == Method::Bdf     ? CompliantMethod::Bdf
                           : v.method == Method::Adams ? CompliantMethod::Adams
                                                       : CompliantMethod::Erk;
      const auto start = std::chrono::steady_clock::now();
      Simulation sim(q, build_scene(q, 1, 0, nullptr));
      const Termination term = sim.run();
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const RunStats& st = sim.stats();
      Run r;
      r.stats.steps = st.sundials_steps;
      r.stats.rhs_evals = st.sundials_rhs;
      r.stats.rhs_seconds = st.sundials_seconds;  // (column reused: time inside the integrators)
      // The replicate's error names the solver's status (step limit,
      // non-finite state, or a SUNDIALS flag).
      r.result.status = term != Termination::Error                                 ? IntegratorStatus::Ok
                        : sim.error().find("step limit") != std::string::npos      ? IntegratorStatus::StepLimit
                        : sim.error().find("non-finite") != std::string::npos      ? IntegratorStatus::NonFinite
                                                                                    : IntegratorStatus::SolverError;
      r.result.t_stopped = sim.time();
      r.result.reason = term == Termination::Error ? sim.error()
                                                   : std::string(to_string(term)) + ", " + std::to_string(st.bonds) +
                                                         " bonds, " + std::to_string(st.slices) + " slices";
      print_row(slice < 1.0 ? "replicate" : "replicate-slice1", k, 600, 0, to_string(v.method), "auto", r, wall, -1.0);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  int repeat = 3;
  double span = 2.0;
  bool quick = false;
  double collect = 300.0, replicate_span = 10.0;
  std::string studies = "stiffness,bandwidth";
  // A positive time argument, or a message naming the option, value and range.
  auto positive = [&](const char* option, const char* text, double* out) {
    char* end = nullptr;
    const double v = std::strtod(text, &end);
    if (end == text || *end != '\0' || !(v > 0.0) || !std::isfinite(v)) {
      std::fprintf(stderr, "%s: %s = '%s': must be a number > 0\n", argv[0], option, text);
      return false;
    }
    *out = v;
    return true;
  };
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--repeat") == 0 && i + 1 < argc) {
      repeat = std::max(1, std::atoi(argv[++i]));
    } else if (std::strcmp(argv[i], "--span") == 0 && i + 1 < argc) {
      if (!positive("--span", argv[++i], &span)) return 2;
    } else if (std::strcmp(argv[i], "--collect") == 0 && i + 1 < argc) {
      if (!positive("--collect", argv[++i], &collect)) return 2;
    } else if (std::strcmp(argv[i], "--replicate-span") == 0 && i + 1 < argc) {
      if (!positive("--replicate-span", argv[++i], &replicate_span)) return 2;
    } else if (std::strcmp(argv[i], "--studies") == 0 && i + 1 < argc) {
      studies = argv[++i];
      std::string rest = studies + ",";
      for (std::size_t at = 0, comma; (comma = rest.find(',', at)) != std::string::npos; at = comma + 1) {
        const std::string name = rest.substr(at, comma - at);
        if (name != "stiffness" && name != "bandwidth" && name != "scenario") {
          std::fprintf(stderr, "%s: --studies = '%s': unknown study '%s' (valid: stiffness, bandwidth, scenario)\n",
                       argv[0], studies.c_str(), name.c_str());
          return 2;
        }
      }
    } else if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else {
      std::fprintf(stderr, "usage: %s [--repeat R] [--span T] [--collect T] [--replicate-span T] [--studies LIST] [--quick]\n", argv[0]);
      return 2;
    }
  }

  auto want = [&](const char* name) { return ("," + studies + ",").find("," + std::string(name) + ",") != std::string::npos; };
  std::printf(
      "study,k,bodies,unknowns,method,linear_solver,status,steps,rhs_evals,rhs_evals_jacobian,jacobian_evals,"
      "linear_setups,nonlinear_iterations,error_test_failures,wall_seconds,rhs_seconds,error,t_reached,reason\n");

  const BondingParams bonding;  // both filters: angle and dihedral terms
  test::ChainSetup setup;
  setup.dx = 0.2;
  setup.drot_deg = 4.0;
  setup.seed = 11;

  const std::vector<Variant> variants = {{Method::Bdf, LinearSolver::Dense, "dense"},
                              {Method::Bdf, LinearSolver::Band, "band"},
                              {Method::Adams, LinearSolver::Auto, "none"},
                              {Method::ExplicitRk, LinearSolver::Auto, "none"}};

  std::vector<double> ks = {1e2, 1e3, 1e4, 1e5, 1e6};
  if (quick) ks = {1e2, 1e4, 1e6};
  for (const double k : (want("stiffness") ? ks : std::vector<double>{})) {
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

  if (want("scenario")) scenario_studies(ks, variants, collect, span, replicate_span, repeat);

  // Band vs dense on longer chains at Scenario 5's constants.
  const CompliantParams s5 = test::scenario5_compliant();
  std::vector<int> corners = {4, 8, 16, 32, 64};
  if (quick) corners = {4, 16};
  if (!want("bandwidth")) corners.clear();
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
