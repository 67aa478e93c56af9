// The articulated clusters' right-hand side: the constraint loads of an open
// chain of m corners (tests/articulated_chain.hpp; random velocities), as
// add_constraint_loads solves them (each sphere riding on its host linker,
// core/constrained_dynamics.hpp), against the same loads from the problem in
// maximal coordinates (every body its own columns, every ball joint three
// rows: the solve the right-hand side made before the hosted one).
// BM_ConstraintLoadsReused is the hosted solve as the integrator's
// right-hand side calls it: one ConstraintLoads kept from call to call (no
// allocation, no M^-1 G^T, the rows' body blocks from the joints).
// BM_MultiplierFactor: the hosted problem's S factored and solved once, the
// dense pivoted LDL^T (third argument 0) against the sparse one in its
// minimum-degree order (1): where kSparseFromRows comes from.
// On a chain closed by a ring of two linkers at its start (S rank
// deficient, as in most of Scenario 1's large clusters):
// BM_DeficientSolve, the minimum-norm solve (complete orthogonal
// decomposition, second argument 0) against any solution (the LDL^T cut
// short, 1); BM_ProjectVelocities, the velocity projection with a new
// solve per call (0) against a workspace kept from call to call (1);
// BM_CollisionMatrix and BM_FitRolls, a cut's other work on such a chain.
// Arguments: m, then 0 = ball joints only (Scenario 1), 1 = held angles and
// dihedrals too (Scenario 4). docs/ARTICULATED.md, "Cost".
//   bench_joints --benchmark_repetitions=5 --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "articulated_chain.hpp"
#include "core/allocator.hpp"
#include "core/constrained_dynamics.hpp"
#include "core/joint_impulses.hpp"
#include "core/joint_projection.hpp"

using namespace ringsim;

namespace {

test::Articulated chain(const benchmark::State& state) {
  const bool held = state.range(1) != 0;
  test::Articulated a = test::open_chain(int(state.range(0)), 0.2, held, held);
  test::jitter_velocities(a.cluster, 0.5, 0.8, 3);
  return a;
}

void BM_ConstraintLoadsHosted(benchmark::State& state) {
  const test::Articulated a = chain(state);
  const std::size_t n = a.cluster.bodies.size();
  for (auto _ : state) {
    std::vector<Vec3> f(n, Vec3::Zero()), tau(n, Vec3::Zero());
    add_constraint_loads(a.cluster.bodies, a.joints, f, tau);
    benchmark::DoNotOptimize(f.data());
  }
  state.counters["rows"] = HostedColumns(a.cluster.bodies, a.joints).rows;
}

void BM_ConstraintLoadsReused(benchmark::State& state) {
  const test::Articulated a = chain(state);
  const std::size_t n = a.cluster.bodies.size();
  ConstraintLoads loads;
  std::vector<Vec3> f(n), tau(n);
  for (auto _ : state) {
    std::fill(f.begin(), f.end(), Vec3::Zero());
    std::fill(tau.begin(), tau.end(), Vec3::Zero());
    loads.add(a.cluster.bodies, a.joints, f, tau);
    benchmark::DoNotOptimize(f.data());
  }
  state.counters["rows"] = HostedColumns(a.cluster.bodies, a.joints).rows;
}

void BM_ConstraintLoadsMaximal(benchmark::State& state) {
  const test::Articulated a = chain(state);
  const std::vector<CompliantBody>& b = a.cluster.bodies;
  const std::size_t n = b.size();
  for (auto _ : state) {
    std::vector<Vec3> f(n, Vec3::Zero()), tau(n, Vec3::Zero());
    const MassMatrix m(b);
    JointRows rows;
    joint_rows(b, m.layout, a.joints, rows);
    const MultiplierSolve solve(rows.g, m);
    const Eigen::VectorXd fg = generalized_force(b, m, f, tau);
    Eigen::VectorXd rhs = -rows.bias;
    rhs.noalias() -= rows.g * m.inverse_times(fg);
    const Eigen::VectorXd load = rows.g.transpose() * solve.solve(rhs);
    benchmark::DoNotOptimize(load.data());
  }
  state.counters["rows"] = a.joints.rows();
}

// S assembled, factored and solved for the bias, as often as the state
// asks, with `options` (its blocks those of h); counters: rows and rank.
void time_solve(benchmark::State& state, const test::HostedRows& h, MultiplierSolve::Options options) {
  options.blocks = &h.blocks;
  MultiplierSolve solve;
  Eigen::VectorXd x;
  for (auto _ : state) {
    solve.compute(h.g, h.p.minv, options);
    x = h.bias;
    solve.solve_in_place(x);
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["rows"] = double(h.g.rows());
  state.counters["rank"] = solve.rank();
}

void BM_MultiplierFactor(benchmark::State& state) {
  MultiplierSolve::Options options;
  options.keep_minv_gt = false;
  options.any_solution = true;
  options.sparse_from_rows = state.range(2) != 0 ? 0 : 1 << 30;
  time_solve(state, test::HostedRows(chain(state)), options);
}

// open_chain(m) plus a second linker beside the first, bonded to the
// same two spheres: a ring of two linkers.
test::Articulated ringed_chain(int m) {
  test::Articulated a = test::open_chain(m, 0.2, false, false);
  const CompliantBody& l0 = a.cluster.bodies[1];
  a.cluster.bodies.push_back(test::linker_at(l0.x + 0.3 * test::perpendicular(l0.axis()), l0.axis(), 0.4));
  const int extra = int(a.cluster.bodies.size()) - 1;
  a.joints.balls.push_back(make_ball_joint(a.bodies(), 0, extra));
  a.joints.balls.push_back(make_ball_joint(a.bodies(), 2, extra));
  test::jitter_velocities(a.cluster, 0.5, 0.8, 3);
  return a;
}

void BM_DeficientSolve(benchmark::State& state) {
  MultiplierSolve::Options options;
  options.any_solution = state.range(1) != 0;
  time_solve(state, test::HostedRows(ringed_chain(int(state.range(0)))), options);
}

void BM_ProjectVelocities(benchmark::State& state) {
  const test::Articulated a = ringed_chain(int(state.range(0)));
  MultiplierSolve workspace;
  MultiplierSolve* w = state.range(1) != 0 ? &workspace : nullptr;
  for (auto _ : state) {
    std::vector<CompliantBody> b = a.cluster.bodies;
    benchmark::DoNotOptimize(project_velocities(b, a.joints, false, w).energy_change);
  }
}

// A cut's work on a cluster (core/joint_impulses.hpp, joint_projection.hpp):
// the collision matrix at a point of the last linker, and the roll fit
// after every linker's roll was turned by up to 1e-3 rad.
void BM_CollisionMatrix(benchmark::State& state) {
  const test::Articulated a = ringed_chain(int(state.range(0)));
  const int last = int(a.cluster.bodies.size()) - 2;
  for (auto _ : state)
    benchmark::DoNotOptimize(collision_matrix(a.cluster.bodies, a.joints, last, Vec3(0.1, 0.2, 0.3)));
}

void BM_FitRolls(benchmark::State& state) {
  const test::Articulated a = ringed_chain(int(state.range(0)));
  std::vector<CompliantBody> turned = a.cluster.bodies;
  double t = 0.0;
  for (CompliantBody& b : turned)
    if (b.shape == Shape::Linker) b.q = (Quat(Eigen::AngleAxisd(1e-3 * std::sin(t += 1.0), b.axis())) * b.q).normalized();
  for (auto _ : state) {
    std::vector<CompliantBody> b = turned;
    benchmark::DoNotOptimize(fit_rolls(b, a.joints).residual_after);
  }
}

void chains(benchmark::internal::Benchmark* b) {
  for (const int held : {0, 1})
    for (const int m : {2, 4, 8, 16, 32, 64, 128}) b->Args({m, held});
}

}  // namespace

BENCHMARK(BM_ConstraintLoadsHosted)->Apply(chains);
BENCHMARK(BM_ConstraintLoadsReused)->Apply(chains);
BENCHMARK(BM_ConstraintLoadsMaximal)->Apply(chains);
BENCHMARK(BM_MultiplierFactor)->ArgsProduct({{2, 4, 6, 8, 12, 16, 32, 64}, {0, 1}, {0, 1}});
BENCHMARK(BM_DeficientSolve)->ArgsProduct({{8, 32, 64}, {0, 1}});
BENCHMARK(BM_ProjectVelocities)->ArgsProduct({{8, 32, 64, 128}, {0, 1}});
BENCHMARK(BM_CollisionMatrix)->Arg(8)->Arg(32)->Arg(64)->Arg(128);
BENCHMARK(BM_FitRolls)->Arg(8)->Arg(32)->Arg(64)->Arg(128);
int main(int argc, char** argv) {
  keep_freed_memory();  // as ringsim's main: the allocator is part of what is timed
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
