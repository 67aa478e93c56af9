// Articulated joints (core/joints.hpp) and the constrained dynamics built on
// them (core/constrained_dynamics.hpp): Jacobians and velocity-product terms
// against finite differences, the held values measured at construction, the
// singular-pose predicates, the rank-revealing multiplier solve and the count
// of internal degrees of freedom.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include <Eigen/LU>
#include <Eigen/SVD>

#include "articulated_chain.hpp"
#include "core/bond_rules.hpp"
#include "core/constrained_dynamics.hpp"
#include "core/joint_projection.hpp"
#include "core/joints.hpp"
#include "core/pivoted_ldlt.hpp"
#include "core/sparse_ldlt.hpp"

namespace ringsim {
namespace {

constexpr double kPi = 3.14159265358979323846;

// C at the pose displaced by t nu (every body moved at constant v and omega
// for time t from the reference pose).
Eigen::VectorXd residual_along(const std::vector<CompliantBody>& bodies, const JointSet& joints,
                               const VelocityLayout& layout, const Eigen::VectorXd& nu, double t) {
  std::vector<CompliantBody> b = bodies;
  displace(b, layout, t * nu);
  return joint_residual(b, joints);
}

// A four-corner open chain with every kind of row, strongly perturbed (random
// numbers from `seed`) so that no row sits at a special value, with random
// velocities.
test::Articulated every_row_chain(std::uint64_t seed = 9) {
  test::Articulated a = test::open_chain(4, 0.3, true, true);
  test::jitter_velocities(a.cluster, 0.7, 0.9, 3);
  // Move the pose away from the held one (rows nonzero, wrap away from the cusp).
  test::Jitter rng(seed);
  for (CompliantBody& b : a.bodies()) {
    b.x += 0.2 * rng.vec();
    if (b.shape == Shape::Linker) b.q = (Eigen::AngleAxisd(0.2, rng.vec().normalized()) * b.q).normalized();
  }
  return a;
}

TEST(Joints, ChainHasItsRows) {
  const test::Articulated a = test::open_chain(4, 0.3, true, true);
  EXPECT_EQ(a.joints.balls.size(), 7u);
  EXPECT_EQ(a.joints.angles.size(), 3u);
  EXPECT_EQ(a.joints.dihedrals.size(), 2u);
  EXPECT_EQ(a.joints.rows(), 26);
  // Built holding the present pose: every row zero.
  EXPECT_LT(joint_residual(a.cluster.bodies, a.joints).cwiseAbs().maxCoeff(), 1e-14);
  for (const HeldAngle& h : a.joints.angles) EXPECT_NEAR(h.theta0, 0.5 * kPi, 0.3);
  for (const HeldDihedral& d : a.joints.dihedrals) EXPECT_NEAR(d.phi0, 0.0, 0.5);  // cis
  // theta0 and phi0 are the rules' measures (core/bond_rules.hpp), in radians.
  const auto& b = a.cluster.bodies;
  const HeldAngle& h = a.joints.angles[0];
  EXPECT_NEAR(h.theta0 * 180.0 / kPi,
              bond_angle_deg(outward_axis(b[h.linker_a].axis(), h.end_a), outward_axis(b[h.linker_b].axis(), h.end_b)),
              1e-12);
  const HeldDihedral& d = a.joints.dihedrals[0];
  EXPECT_NEAR(d.phi0 * 180.0 / kPi,
              *dihedral_deg(b[d.linker].axis(), outward_axis(b[d.nb0].axis(), d.nb0_end),
                            outward_axis(b[d.nb1].axis(), d.nb1_end)),
              1e-10);
}

// G's columns by central differences of C along each velocity coordinate
// (an omega column: a small rotation of that body about the world axis).
TEST(Joints, JacobianMatchesFiniteDifferences) {
  const test::Articulated a = every_row_chain();
  const VelocityLayout layout(a.cluster.bodies);
  JointRows rows;
  joint_rows(a.cluster.bodies, layout, a.joints, rows);
  ASSERT_EQ(rows.g.rows(), a.joints.rows());
  ASSERT_EQ(rows.g.cols(), layout.size);
  EXPECT_LT((rows.c - joint_residual(a.cluster.bodies, a.joints)).norm(), 1e-15);
  EXPECT_GT(rows.c.cwiseAbs().minCoeff(), 1e-4);  // the perturbed pose violates every row

  const double h = 1e-6;
  double worst = 0.0;
  for (int k = 0; k < layout.size; ++k) {
    const Eigen::VectorXd e = Eigen::VectorXd::Unit(layout.size, k);
    const Eigen::VectorXd fd = (residual_along(a.cluster.bodies, a.joints, layout, e, h) -
                                residual_along(a.cluster.bodies, a.joints, layout, e, -h)) /
                               (2.0 * h);
    worst = std::max(worst, (fd - rows.g.col(k)).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-8) << "largest |G_fd - G|";
}

// Along the motion at constant v and omega, C(t) has C' = G nu and
// C'' = (dG/dt) nu (the bias): second differences, and first differences of G nu.
TEST(Joints, VelocityProductTermMatchesFiniteDifferences) {
  const test::Articulated a = every_row_chain();
  const VelocityLayout layout(a.cluster.bodies);
  const Eigen::VectorXd nu = velocity_vector(a.cluster.bodies, layout);
  JointRows rows;
  joint_rows(a.cluster.bodies, layout, a.joints, rows);
  EXPECT_GT(rows.bias.cwiseAbs().minCoeff(), 1e-4);  // every row has a bias to check

  const double h = 1e-4;
  const Eigen::VectorXd c0 = joint_residual(a.cluster.bodies, a.joints);
  const Eigen::VectorXd cp = residual_along(a.cluster.bodies, a.joints, layout, nu, h);
  const Eigen::VectorXd cm = residual_along(a.cluster.bodies, a.joints, layout, nu, -h);
  EXPECT_LT(((cp - cm) / (2.0 * h) - rows.g * nu).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT(((cp - 2.0 * c0 + cm) / (h * h) - rows.bias).cwiseAbs().maxCoeff(), 1e-5);

  // d/dt (G nu) at fixed nu, with G re-evaluated on the displaced poses.
  const double e = 1e-6;
  auto g_nu_at = [&](double t) {
    std::vector<CompliantBody> b = a.cluster.bodies;
    displace(b, layout, t * nu);
    set_velocities(b, layout, nu);
    JointRows r;
    joint_rows(b, layout, a.joints, r);
    return Eigen::VectorXd(r.g * nu);
  };
  EXPECT_LT(((g_nu_at(e) - g_nu_at(-e)) / (2.0 * e) - rows.bias).cwiseAbs().maxCoeff(), 1e-7);
}

TEST(Joints, SingularPosePredicates) {
  EXPECT_TRUE(held_angle_defined(0.5 * kPi));
  EXPECT_TRUE(held_angle_defined(kPi * 170.0 / 180.0));
  EXPECT_FALSE(held_angle_defined(kPi * 179.0 / 180.0));
  EXPECT_FALSE(held_angle_defined(kPi * 1.0 / 180.0));
  const Vec3 u = Vec3::UnitZ();
  EXPECT_TRUE(held_dihedral_defined(u, Vec3::UnitX(), Vec3::UnitY()));
  const Vec3 near_axis = Vec3(std::sin(kPi / 180.0), 0.0, -std::cos(kPi / 180.0));  // 1 degree off -u
  EXPECT_FALSE(held_dihedral_defined(u, near_axis, Vec3::UnitY()));
  EXPECT_FALSE(held_dihedral_defined(u, Vec3::UnitX(), near_axis));
  const Vec3 three = Vec3(std::sin(3.0 * kPi / 180.0), 0.0, std::cos(3.0 * kPi / 180.0));
  EXPECT_TRUE(held_dihedral_defined(u, three, Vec3::UnitY()));

  const test::Articulated a = test::open_chain(4, 0.0, true, true);  // right angles
  EXPECT_NEAR(min_joint_sine(a.cluster.bodies, a.joints), 1.0, 1e-12);
}

// Mass matrix blocks, and the multiplier solve on redundant rows: a ball
// joint listed twice makes S singular; lambda is the minimum-norm solution and
// the constrained accelerations are those of the single joint.
TEST(ConstrainedDynamics, RedundantRowsAreTolerated) {
  test::Articulated a = test::lsl(0.5 * kPi, 0.2, false);
  test::jitter_velocities(a.cluster, 0.5, 0.8, 2);
  const MassMatrix m(a.cluster.bodies);
  EXPECT_EQ(m.layout.size, 15);
  const Eigen::MatrixXd md = m.dense();
  EXPECT_LT((m.inverse_times(Eigen::MatrixXd(md)) - Eigen::MatrixXd::Identity(15, 15)).norm(), 1e-14);

  // Some applied loads.
  std::vector<Vec3> f = {Vec3(1, 2, 0), Vec3(0, -1, 3), Vec3(-2, 0.5, 1)};
  std::vector<Vec3> tau = {Vec3(0.3, 0, -1), Vec3::Zero(), Vec3(0, 2, 0.5)};
  std::vector<Vec3> f1 = f, tau1 = tau, f2 = f, tau2 = tau;
  add_constraint_loads(a.cluster.bodies, a.joints, f1, tau1);
  JointSet twice = a.joints;
  twice.balls.push_back(a.joints.balls[0]);
  add_constraint_loads(a.cluster.bodies, twice, f2, tau2);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT((f1[i] - f2[i]).norm(), 1e-10);
    EXPECT_LT((tau1[i] - tau2[i]).norm(), 1e-10);
  }
  // Minimum norm: the duplicated rows share the multiplier equally.
  JointRows both;
  joint_rows(a.cluster.bodies, m.layout, twice, both);
  const Eigen::VectorXd lambda = MultiplierSolve(both.g, m).solve(
      -both.bias - both.g * m.inverse_times(generalized_force(a.cluster.bodies, m, f, tau)));
  EXPECT_LT((lambda.segment<3>(0) - lambda.segment<3>(6)).norm(), 1e-9);
  // Any solution (the loads' path): the pivoted LDL^T cut short at its three
  // negligible pivots, a different lambda with the same load G^T lambda.
  MultiplierSolve any;
  MultiplierSolve::Options options;
  options.any_solution = true;
  any.compute(both.g, m.inverse_blocks(), options);
  EXPECT_EQ(any.rank(), int(both.g.rows()) - 3);
  const Eigen::VectorXd lambda_any = any.solve(
      -both.bias - both.g * m.inverse_times(generalized_force(a.cluster.bodies, m, f, tau)));
  EXPECT_GT((lambda_any - lambda).norm(), 1e-3 * lambda.norm());
  EXPECT_LT((both.g.transpose() * (lambda_any - lambda)).norm(), 1e-10 * (both.g.transpose() * lambda).norm());

  // The constrained accelerations satisfy G nu' + bias = 0.
  JointRows rows;
  joint_rows(a.cluster.bodies, m.layout, a.joints, rows);
  const Eigen::VectorXd acc = m.inverse_times(generalized_force(a.cluster.bodies, m, f1, tau1));
  EXPECT_LT((rows.g * acc + rows.bias).cwiseAbs().maxCoeff(), 1e-12);
  // Internal: the constraint loads add no net force or torque about the origin.
  Vec3 net_f = Vec3::Zero(), net_t = Vec3::Zero();
  for (int i = 0; i < 3; ++i) {
    net_f += f1[i] - f[i];
    net_t += a.cluster.bodies[i].x.cross(f1[i] - f[i]) + (tau1[i] - tau[i]);
  }
  EXPECT_LT(net_f.norm(), 1e-12);
  EXPECT_LT(net_t.norm(), 1e-12);
}

// The constraint loads are solved with every sphere riding on its host
// linker (core/constrained_dynamics.hpp): against the accelerations of the
// full problem in maximal coordinates, from the dense saddle-point system
// [M G^T; G 0] (nu', -lambda) = (f, -b) solved here by a complete orthogonal
// decomposition (minimum norm where rows are redundant), on clusters with
// every kind of row (at random velocities, on the joints and moved off
// them), a closed held square (redundant rows) and a sphere on three linkers.
TEST(ConstrainedDynamics, SpheresRidingOnHostsGiveTheFullAccelerations) {
  auto check = [](const test::Articulated& a, const char* what) {
    const std::vector<CompliantBody>& b = a.cluster.bodies;
    const int n = int(b.size());
    std::vector<Vec3> f(n), tau(n);
    for (int i = 0; i < n; ++i) {  // some applied loads
      f[i] = Vec3(std::sin(1.0 + i), std::cos(2.0 * i), 0.5 - 0.1 * i);
      tau[i] = Vec3(0.2 * i - 1.0, std::sin(3.0 * i), 0.7);
    }
    std::vector<Vec3> f1 = f, tau1 = tau;
    add_constraint_loads(b, a.joints, f1, tau1);
    const Eigen::VectorXd acc = [&] {
      const MassMatrix m(b);
      return Eigen::VectorXd(m.inverse_times(generalized_force(b, m, f1, tau1)));
    }();

    const MassMatrix m(b);
    JointRows rows;
    joint_rows(b, m.layout, a.joints, rows);
    const int nv = m.layout.size, nr = int(rows.g.rows());
    const Eigen::MatrixXd kkt = test::kkt_matrix(m, rows.g);
    Eigen::VectorXd rhs(nv + nr);
    rhs << generalized_force(b, m, f, tau), -rows.bias;
    const Eigen::VectorXd ref = kkt.completeOrthogonalDecomposition().solve(rhs).head(nv);
    EXPECT_LT((acc - ref).cwiseAbs().maxCoeff(), 1e-10 * std::max(1.0, ref.cwiseAbs().maxCoeff())) << what;
    EXPECT_LT((rows.g * acc + rows.bias).cwiseAbs().maxCoeff(), 1e-10) << what;  // C'' = 0
  };

  test::Articulated chain = every_row_chain();
  check(chain, "chain with every row");
  // Redundant rows are consistent only where the velocities keep the joints
  // (C' = 0): the square's random velocities projected onto G's null space.
  test::Articulated square = test::square(0.15, true, true);
  test::jitter_velocities(square.cluster, 0.5, 0.8, 4);
  {
    const VelocityLayout layout(square.bodies());
    JointRows rows;
    joint_rows(square.bodies(), layout, square.joints, rows);
    Eigen::VectorXd nu = velocity_vector(square.bodies(), layout);
    nu -= rows.g.completeOrthogonalDecomposition().solve(rows.g * nu);
    set_velocities(square.bodies(), layout, nu);
  }
  check(square, "held square (redundant rows)");
  // Off the joints: every body moved a little at random, so C != 0 and C' != 0.
  std::uint64_t state = 77;
  auto next = [&state] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return double(state >> 11) / double(1ULL << 53) - 0.5;
  };
  for (CompliantBody& body : chain.bodies()) {
    body.x += 0.02 * Vec3(next(), next(), next());
    body.q = (Eigen::AngleAxisd(0.02 * next(), Vec3(next(), next(), next()).normalized()) * body.q).normalized();
  }
  check(chain, "moved off the joints");
  // A sphere on three linkers (a branch: valency raised), two of its ball
  // joints not its host's, and a sphere at the far end of the third linker.
  test::Articulated branch = test::lsl(0.5 * kPi, 0.2, true);
  const double d = test::reach();
  branch.cluster.bodies.push_back(test::linker_at(Vec3(0.1, 0.2, d), Vec3::UnitZ(), 0.3));
  branch.cluster.bodies.push_back(test::sphere_at(Vec3(0.1, 0.2, 2.0 * d)));
  branch.joints.balls.push_back(make_ball_joint(branch.bodies(), 1, 3));
  branch.joints.balls.push_back(make_ball_joint(branch.bodies(), 4, 3));
  test::jitter_velocities(branch.cluster, 0.5, 0.8, 6);
  check(branch, "branch");
}

// S = G M^-1 G^T as MultiplierSolve assembles it (body by body, on the rows
// that touch each body) against the dense product with MassMatrix::dense(),
// and M^-1 G^T likewise, on random poses of a four-corner chain with ball
// joints, held angles and held dihedrals.
TEST(ConstrainedDynamics, BlockAssembledSMatchesDenseProduct) {
  for (const std::uint64_t seed : {9u, 21u, 77u}) {
    const test::Articulated a = every_row_chain(seed);
    ASSERT_GT(a.joints.balls.size(), 0u);
    ASSERT_GT(a.joints.angles.size(), 0u);
    ASSERT_GT(a.joints.dihedrals.size(), 0u);
    const MassMatrix m(a.cluster.bodies);
    JointRows rows;
    joint_rows(a.cluster.bodies, m.layout, a.joints, rows);
    const MultiplierSolve solve(rows.g, m);

    const Eigen::MatrixXd minv_gt = m.dense().inverse() * rows.g.transpose();
    const Eigen::MatrixXd s = rows.g * minv_gt;
    EXPECT_LT((solve.minv_gt() - minv_gt).norm(), 1e-12 * minv_gt.norm()) << "seed " << seed;
    EXPECT_LT((solve.s() - s).norm(), 1e-12 * s.norm()) << "seed " << seed;
    EXPECT_TRUE(solve.s() == solve.s().transpose()) << "seed " << seed;  // exactly symmetric
  }
}

// The right-hand side's assembly finds the rows that touch each body from
// the joints (hosted_joint_rows' RowBlocks), not by reading G: the same S
// and M^-1 G^T bit for bit as the assembly that reads G, and S against the
// dense product G_r M_r^-1 G_r^T. One added dihedral names the same
// neighbour at both ends (a ring of two linkers does): its block is counted once.
TEST(ConstrainedDynamics, RowBlocksGiveTheSameAssembly) {
  test::Articulated a = every_row_chain(21);
  HeldDihedral twice = a.joints.dihedrals.front();
  twice.nb1 = twice.nb0;
  twice.nb1_end = 1 - twice.nb0_end;
  a.joints.dihedrals.push_back(twice);
  const test::HostedRows h(a);
  const HostedProblem& p = h.p;
  const Eigen::MatrixXd& g = h.g;
  const RowBlocks& blocks = h.blocks;
  ASSERT_EQ(blocks.size(), std::size_t(g.rows()));
  MultiplierSolve read, given;
  read.compute(g, p.minv, MultiplierSolve::Options());
  MultiplierSolve::Options with_blocks;
  with_blocks.blocks = &blocks;
  given.compute(g, p.minv, with_blocks);
  EXPECT_TRUE(read.s() == given.s());
  EXPECT_TRUE(read.minv_gt() == given.minv_gt());

  Eigen::MatrixXd minv = Eigen::MatrixXd::Zero(p.minv.size, p.minv.size);
  for (std::size_t i = 0; i < p.minv.offset.size(); ++i) {
    const int o = p.minv.offset[i], w = p.minv.width[i];
    minv.block(o, o, w, w) = p.minv.inv[i].topLeftCorner(w, w);
  }
  const Eigen::MatrixXd s = g * minv * g.transpose();
  EXPECT_LT((given.s() - s).norm(), 1e-12 * s.norm());

  // G stored by row blocks (the right-hand side's): the same entries, the
  // same blocks, S to rounding (the products M_i^-1 g_r^T read contiguous
  // rows instead of strided ones, so the compiler may sum them in another
  // order), and its products against the dense G's.
  BlockRows gb;
  Eigen::VectorXd bias;
  hosted_joint_rows(a.cluster.bodies, p.columns, a.joints, gb, &bias);
  EXPECT_TRUE(gb.dense() == g);
  EXPECT_TRUE(bias == h.bias);
  EXPECT_TRUE(gb.blocks == blocks);
  MultiplierSolve from_blocks;
  MultiplierSolve::Options no_minv_gt;
  no_minv_gt.keep_minv_gt = false;
  from_blocks.compute(gb, p.minv, no_minv_gt);
  EXPECT_LT((from_blocks.s() - given.s()).norm(), 1e-15 * given.s().norm());
  EXPECT_TRUE(from_blocks.s() == from_blocks.s().transpose());
  std::mt19937_64 gen(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd x(g.cols()), l(g.rows());
  for (Eigen::Index i = 0; i < x.size(); ++i) x[i] = u(gen);
  for (Eigen::Index i = 0; i < l.size(); ++i) l[i] = u(gen);
  Eigen::VectorXd gx = Eigen::VectorXd::Ones(g.rows()), gtl = Eigen::VectorXd::Ones(g.cols());
  gb.add_times(x, gx);
  gb.add_transpose_times(l, gtl);
  const Eigen::VectorXd gx_dense = (g * x).array() + 1.0, gtl_dense = (g.transpose() * l).array() + 1.0;
  EXPECT_LT((gx - gx_dense).norm(), 1e-14 * gx_dense.norm());
  EXPECT_LT((gtl - gtl_dense).norm(), 1e-14 * gtl_dense.norm());
}

// The pivoted LDL^T (core/pivoted_ldlt.hpp) on equilibrated Gram matrices
// S~ = D^-1/2 G G^T D^-1/2 of random rows: full rank, the solve against a
// dense one and the pivots in decreasing order (each a squared sine, so in
// (0, 1]); with rows repeated and combined (rank 5 of 9), the rank, a
// consistent system solved exactly with the dropped unknowns zero, where
// Eigen's LDLT (pivoting on the diagonal as it stood) meets its zero pivots
// before the end.
TEST(PivotedLdlt, SolvesAndRevealsTheRank) {
  std::mt19937_64 gen(11);
  std::normal_distribution<double> N(0.0, 1.0);
  auto random_rows = [&](int r, int c) {
    Eigen::MatrixXd g(r, c);
    for (int i = 0; i < r; ++i)
      for (int j = 0; j < c; ++j) g(i, j) = N(gen);
    return g;
  };
  auto equilibrated = [](const Eigen::MatrixXd& g) {
    Eigen::MatrixXd s = g * g.transpose();
    const Eigen::VectorXd d = s.diagonal().cwiseSqrt().cwiseInverse();
    return Eigen::MatrixXd(d.asDiagonal() * s * d.asDiagonal());
  };
  const Eigen::MatrixXd full = equilibrated(random_rows(9, 14));
  PivotedLdlt f;
  f.compute(full, 1e-7);
  ASSERT_EQ(f.rank(), 9);
  for (int k = 1; k < 9; ++k) EXPECT_LE(f.pivots()[k], f.pivots()[k - 1]);
  EXPECT_LE(f.pivots()[0], 1.0 + 1e-15);
  Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(9, -1.0, 2.0), x = b;
  f.solve_in_place(x);
  EXPECT_LT((x - full.fullPivLu().solve(b)).norm(), 1e-10 * x.norm());

  Eigen::MatrixXd g(9, 14);
  g.topRows(5) = random_rows(5, 14);
  g.row(5) = g.row(0);
  g.row(6) = g.row(1) - 0.5 * g.row(3);
  g.row(7) = 2.0 * g.row(2) + g.row(4);
  g.row(8) = g.row(1);
  const Eigen::MatrixXd deficient = equilibrated(g);
  f.compute(deficient, 1e-7);
  EXPECT_EQ(f.rank(), 5);
  const Eigen::VectorXd consistent = deficient * Eigen::VectorXd::LinSpaced(9, 0.5, -1.5);
  x = consistent;
  f.solve_in_place(x);
  EXPECT_LT((deficient * x - consistent).norm(), 1e-12 * consistent.norm());
  EXPECT_EQ(int((x.array() == 0.0).count()), 4);  // the dropped unknowns

  const Eigen::LDLT<Eigen::MatrixXd> eigen(deficient);
  const Eigen::VectorXd d = eigen.vectorD().cwiseAbs();
  int first_small = 0;
  while (d[first_small] > 1e-7 * d.maxCoeff()) ++first_small;
  EXPECT_LT(first_small, 5) << "Eigen's LDLT reached a negligible pivot only after all kept ones";
}

// Equilibrated Gram matrix of rows that each touch two or three of `bodies`
// blocks of 3 columns (the pattern of a cluster's S), random entries.
Eigen::MatrixXd sparse_rows(int rows, int bodies, std::mt19937_64& gen) {
  std::normal_distribution<double> N(0.0, 1.0);
  std::uniform_int_distribution<int> body(0, bodies - 1);
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(rows, 3 * bodies);
  for (int r = 0; r < rows; ++r)
    for (int k = 0; k < 2 + r % 2; ++k) {
      const int b = body(gen);
      for (int c = 0; c < 3; ++c) g(r, 3 * b + c) = N(gen);
    }
  return g;
}
Eigen::MatrixXd equilibrated_gram(const Eigen::MatrixXd& g) {
  const Eigen::MatrixXd s = g * g.transpose();
  const Eigen::VectorXd d = s.diagonal().cwiseSqrt().cwiseInverse();
  return d.asDiagonal() * s * d.asDiagonal();
}

// The sparse LDL^T (core/sparse_ldlt.hpp): a full-rank sparse system solved
// as a dense LU solves it; a chain's matrix numbered in a scrambled order
// factored without fill (the minimum-degree order finds its ends) and
// without a delayed row; the analysis kept while the pattern stays and
// redone when it changes; with rows repeated and combined, the dependent
// rows delayed, the rank of the pivoted dense factorization and a
// consistent system solved exactly with the dropped unknowns zero.
TEST(SparseLdlt, SolvesOrdersAndDropsDependentRows) {
  std::mt19937_64 gen(17);
  const Eigen::MatrixXd s = equilibrated_gram(sparse_rows(40, 25, gen));
  SparseLdlt f;
  ASSERT_TRUE(f.compute(s, 1e-7));
  ASSERT_EQ(f.rank(), 40);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(40, -1.0, 2.0);
  Eigen::VectorXd x = b;
  f.solve_in_place(x);
  EXPECT_LT((x - s.fullPivLu().solve(b)).norm(), 1e-10 * x.norm());
  EXPECT_LT(f.factor_entries(), 40 * 39 / 4) << "far from dense";

  // The same pattern, other values: the analysis is kept.
  Eigen::MatrixXd s2 = s;
  for (int j = 0; j < 40; ++j)
    for (int i = j + 1; i < 40; ++i) s2(i, j) = s2(j, i) = 0.9 * s(i, j);
  ASSERT_TRUE(f.compute(s2, 1e-7));
  EXPECT_EQ(f.analyses(), 1);
  x = b;
  f.solve_in_place(x);
  EXPECT_LT((x - s2.fullPivLu().solve(b)).norm(), 1e-10 * x.norm());

  // A chain (each row coupled to the next), numbered in a scrambled order.
  const int n = 30;
  std::vector<int> at(n);
  for (int i = 0; i < n; ++i) at[i] = (7 * i) % n;  // 7 and 30 coprime
  Eigen::MatrixXd chain = Eigen::MatrixXd::Identity(n, n);
  for (int i = 0; i + 1 < n; ++i) chain(at[i], at[i + 1]) = chain(at[i + 1], at[i]) = 0.45;
  ASSERT_TRUE(f.compute(chain, 1e-7));
  EXPECT_EQ(f.analyses(), 2);
  EXPECT_EQ(f.factor_entries(), n - 1) << "no fill";
  EXPECT_EQ(f.delayed(), 0);
  x = Eigen::VectorXd::LinSpaced(n, 1.0, -1.0);
  f.solve_in_place(x);
  EXPECT_LT((chain * x - Eigen::VectorXd::LinSpaced(n, 1.0, -1.0)).norm(), 1e-12);

  // Rank 12 of 18: rows 12-17 repeat or combine earlier ones (sharing their
  // bodies, so the pattern stays sparse).
  Eigen::MatrixXd g = sparse_rows(18, 12, gen);
  g.row(12) = g.row(0);
  g.row(13) = g.row(1) - 0.5 * g.row(3);
  g.row(14) = 2.0 * g.row(2) + g.row(4);
  g.row(15) = g.row(5);
  g.row(16) = g.row(7) + g.row(8);
  g.row(17) = -g.row(11);
  const Eigen::MatrixXd deficient = equilibrated_gram(g);
  PivotedLdlt dense;
  dense.compute(deficient, 1e-7);
  ASSERT_TRUE(f.compute(deficient, 1e-7));
  EXPECT_EQ(dense.rank(), 12);
  EXPECT_EQ(f.rank(), 12);
  const Eigen::VectorXd consistent = deficient * Eigen::VectorXd::LinSpaced(18, 0.5, -1.5);
  x = consistent;
  f.solve_in_place(x);
  EXPECT_LT((deficient * x - consistent).norm(), 1e-10 * consistent.norm());
  EXPECT_EQ(int((x.array() == 0.0).count()), 6);  // the dropped unknowns
  EXPECT_GE(f.delayed(), 6);

  // All zero (rows of G that vanish): rank 0, the solution zero.
  ASSERT_TRUE(f.compute(Eigen::MatrixXd::Zero(5, 5), 1e-7));
  EXPECT_EQ(f.rank(), 0);
  x = Eigen::VectorXd::Ones(5);
  f.solve_in_place(x);
  EXPECT_TRUE(x.isZero(0.0));

  Eigen::MatrixXd nan = s;
  nan(3, 3) = std::nan("");
  EXPECT_FALSE(f.compute(nan, 1e-7));
}

// MultiplierSolve with S factored sparse and dense: on an open chain of 16
// corners with held angles and dihedrals (full rank) the same multipliers;
// on a closed square holding every angle and dihedral (rank deficient, as
// the right-hand side's loads solve it: any solution) the same G^T lambda
// for a consistent right-hand side, and the same rank. One sparse solve is
// reused, as a right-hand side reuses it: the chain, the chain moved (the
// same pattern: S cleared on it only), the square (a new pattern), the
// chain again.
TEST(ConstrainedDynamics, SparseAndDenseFactorsAgree) {
  test::Articulated moved = test::open_chain(16, 0.2, true, true);
  test::jitter_velocities(moved.cluster, 0.5, 0.8, 3);
  displace(moved.cluster.bodies, VelocityLayout(moved.cluster.bodies),
           0.05 * velocity_vector(moved.cluster.bodies, VelocityLayout(moved.cluster.bodies)));
  const std::vector<test::Articulated> cases = {test::open_chain(16, 0.2, true, true), moved,
                                                test::square(0.2, true, true), test::open_chain(16, 0.2, true, true)};
  MultiplierSolve sparse;
  for (std::size_t c = 0; c < cases.size(); ++c) {
    const bool ring = c == 2;
    const test::HostedRows h(cases[c]);
    const Eigen::MatrixXd& g = h.g;
    MultiplierSolve::Options options;
    options.blocks = &h.blocks;
    options.any_solution = true;
    options.sparse_from_rows = 0;
    sparse.compute(g, h.p.minv, options);
    options.sparse_from_rows = 1 << 30;
    MultiplierSolve dense;
    dense.compute(g, h.p.minv, options);
    ASSERT_TRUE(sparse.sparse());
    ASSERT_FALSE(dense.sparse());
    EXPECT_TRUE(sparse.s() == dense.s()) << "case " << c;
    EXPECT_EQ(sparse.rank(), dense.rank()) << "case " << c;
    EXPECT_EQ(sparse.rank() < g.rows(), ring);
    const Eigen::VectorXd rhs = dense.s() * Eigen::VectorXd::LinSpaced(g.rows(), -1.0, 1.0);
    const Eigen::VectorXd ls = sparse.solve(rhs), ld = dense.solve(rhs);
    const Eigen::VectorXd fs = g.transpose() * ls, fd = g.transpose() * ld;
    EXPECT_LT((fs - fd).norm(), 1e-9 * fd.norm()) << "case " << c;
    if (!ring) EXPECT_LT((ls - ld).norm(), 1e-9 * ld.norm()) << "case " << c;
  }
}

// Internal degrees of freedom = velocity coordinates - rank(G) - 6.
TEST(ConstrainedDynamics, InternalDegreesOfFreedom) {
  // S-L: 3 + 6 - 3 - 6 = 0 (the sphere is a point: it cannot turn about its joint).
  test::Articulated sl;
  sl.cluster.bodies = {test::sphere_at(Vec3::Zero()), test::linker_at(Vec3(test::reach(), 0.2, 0), Vec3::UnitX())};
  sl.joints.balls = {make_ball_joint(sl.cluster.bodies, 0, 1)};
  EXPECT_EQ(internal_dof(sl.cluster.bodies, sl.joints), 0);

  // S-L-S: 12 - 6 - 6 = 0 (turning the linker about the line through its
  // anchors is the rigid rotation about that line).
  test::Articulated sls = sl;
  sls.cluster.bodies.push_back(test::sphere_at(Vec3(2.0 * test::reach(), 0.1, 0.0)));
  sls.joints.balls.push_back(make_ball_joint(sls.cluster.bodies, 2, 1));
  EXPECT_EQ(internal_dof(sls.cluster.bodies, sls.joints), 0);

  // L-S-L: 15 - 6 - 6 = 3 (L1 turns about the sphere relative to L0); the
  // held angle removes one.
  EXPECT_EQ(internal_dof(test::lsl(0.5 * kPi, 0.2, false).cluster.bodies, test::lsl(0.5 * kPi, 0.2, false).joints), 3);
  const test::Articulated held = test::lsl(0.5 * kPi, 0.2, true);
  EXPECT_EQ(internal_dof(held.cluster.bodies, held.joints), 2);

  // Closed square, 4 S + 4 L: 12 + 24 = 36 velocity coordinates.
  // No filters: the 8 ball joints (24 rows) are independent. The linkers
  // form a closed loop of 4 rigid bodies with 4 spherical joints:
  // 4 x 6 - 4 x 3 - 6 = 6 internal DOF: each linker turns about the line
  // through its two anchors (4), and the quadrilateral of the sphere centres
  // (4 points, 4 fixed side lengths: 12 - 4 - 6 = 2) folds about a diagonal
  // and shears in its plane (2).
  const test::Articulated free_square = test::square(0.15, false, false);
  EXPECT_EQ(internal_dof(free_square.cluster.bodies, free_square.joints), 6);
  // Both filters: 4 angles + 4 dihedrals = 8 more rows. They see only the
  // four axes, whose relative orientation has 4 x 2 - 3 = 5 coordinates, so
  // at most 5 of the 8 are independent and one of the 6 freedoms survives
  // (rank 24 + 5 = 29 of 32 rows): NOT rigid. By hand: keep every axis fixed
  // and let linker i translate by v_i and spin about its own axis at s_i;
  // sphere i joins linker i-1's end-0 anchor to linker i's end-1 anchor:
  //   v_{i-1} + s_{i-1} u_{i-1} x r_{i-1,0} = v_i + s_i u_i x r_{i,1},
  // 12 equations in 16 unknowns (v_i, s_i), minus the 3 common translations:
  // 1 mechanism, in which the off-axis anchors turn about the axes while the
  // linkers slide. It is finite, not only infinitesimal: closing the loop is
  // 3 equations on the 4 spin angles. (Holding every linker's roll would make
  // the square rigid, but no rule names the roll: docs/ARTICULATED.md.)
  const test::Articulated held_square = test::square(0.15, true, true);
  EXPECT_EQ(internal_dof(held_square.cluster.bodies, held_square.joints), 1);
  {
    const MassMatrix m(held_square.cluster.bodies);
    JointRows rows;
    joint_rows(held_square.cluster.bodies, m.layout, held_square.joints, rows);
    EXPECT_EQ(rows.g.rows(), 32);
    const MultiplierSolve solve(rows.g, m);
    EXPECT_EQ(solve.rank(), 29);
    // The rank is not a threshold artefact: a wide gap in S's spectrum.
    const Eigen::VectorXd sv = Eigen::JacobiSVD<Eigen::MatrixXd>(solve.s()).singularValues();
    std::printf("held square: S's singular values, largest %.3g, 29th %.3g, 30th %.3g\n", sv[0], sv[28], sv[29]);
    EXPECT_GT(sv[28], 1e-6 * sv[0]);  // small: the anchors are only ~0.15 off the axes
    EXPECT_LT(sv[29], 1e-14 * sv[0]);
    // The 3 surplus held rows go; the 29 left are independent and leave the
    // same single freedom.
    JointSet kept = held_square.joints, removed;
    EXPECT_EQ(drop_redundant_held_rows(held_square.cluster.bodies, kept, &removed), 3);
    EXPECT_EQ(kept.rows(), 29);
    EXPECT_EQ(removed.rows(), 3);  // handed back (the event loop keeps them: Simulation::readmit_rows)
    EXPECT_TRUE(removed.balls.empty());
    EXPECT_EQ(kept.balls.size(), held_square.joints.balls.size());
    JointRows kept_rows;
    joint_rows(held_square.cluster.bodies, m.layout, kept, kept_rows);
    EXPECT_EQ(MultiplierSolve(kept_rows.g, m, true).rank(), 29);
    EXPECT_EQ(internal_dof(held_square.cluster.bodies, kept), 1);
  }
  {
    // An open chain of four corners with both filters: its held rows are all
    // independent, nothing goes.
    test::Articulated open = test::open_chain(4, 0.15, true, true);
    ASSERT_GT(open.joints.angles.size() + open.joints.dihedrals.size(), 0u);
    JointSet kept = open.joints;
    EXPECT_EQ(drop_redundant_held_rows(open.cluster.bodies, kept), 0);
    EXPECT_EQ(kept.rows(), open.joints.rows());
  }
  // Anchors exactly on the axes (captures at the faces' centres, measure
  // zero): each linker's spin about its own axis moves nothing any row sees,
  // so the 4 spins stay free even with both filters (the 2 shape freedoms go).
  const test::Articulated on_axis = test::square(0.0, true, true);
  EXPECT_EQ(internal_dof(on_axis.cluster.bodies, on_axis.joints), 4);
  const test::Articulated on_axis_free = test::square(0.0, false, false);
  EXPECT_EQ(internal_dof(on_axis_free.cluster.bodies, on_axis_free.joints), 6);
}

// The rank decision is about directions, not sizes: S is equilibrated before
// it is factored (core/constrained_dynamics.hpp). A held row scaled down by
// 1e-6 (as small as a dihedral's gradient with a neighbour 1e-6 rad from the
// axis) keeps the rank, the independence and the constraint loads; without
// the equilibration its pivot would be ~1e-12 of the largest, far below
// kRankThreshold, and the row would count as redundant (the dynamics would
// stop holding it).
TEST(ConstrainedDynamics, RankDoesNotDependOnTheSizeOfARow) {
  for (const std::uint64_t seed : {9u, 21u, 77u}) {
    const test::Articulated a = every_row_chain(seed);
    const MassMatrix m(a.cluster.bodies);
    JointRows rows;
    joint_rows(a.cluster.bodies, m.layout, a.joints, rows);
    const int n = int(rows.g.rows()), last = n - 1;  // a held dihedral
    ASSERT_GT(a.joints.dihedrals.size(), 0u);
    const MultiplierSolve full(rows.g, m);
    ASSERT_EQ(MultiplierSolve(rows.g, m, true).rank(), n) << "seed " << seed;
    Eigen::MatrixXd g = rows.g;
    g.row(last) *= 1e-6;
    const MultiplierSolve small(g, m);
    EXPECT_EQ(MultiplierSolve(g, m, true).rank(), n) << "seed " << seed;
    ASSERT_EQ(full.row_sines2().size(), n);
    ASSERT_EQ(small.row_sines2().size(), n);
    const double weakest = full.row_sines2().minCoeff();
    EXPECT_GT(weakest, 0.0);
    EXPECT_NEAR(small.row_sines2().minCoeff(), weakest, 1e-9 * weakest) << "seed " << seed;
    // The same loads G^T lambda for the same constraint (its right-hand side
    // scaled with its row): lambda' = lambda / 1e-6 on that row.
    Eigen::VectorXd rhs = rows.bias, rhs_small = rows.bias;
    rhs_small[last] *= 1e-6;
    const Eigen::VectorXd f = rows.g.transpose() * full.solve(rhs);
    const Eigen::VectorXd f_small = g.transpose() * small.solve(rhs_small);
    EXPECT_LT((f - f_small).norm(), 1e-8 * f.norm()) << "seed " << seed;
  }
}

// MultiplierSolve::row_sines2 gives, for each of two rows, the squared sine
// of the angle between them (on one body the M^-1 metric is a multiple of
// the identity), whatever the rows' lengths; none once the rows are
// dependent to within kRankThreshold.
// The velocity projection measures the held rows' squared sines on its
// reduced problem (spheres riding on their hosts) and converts them to the
// maximal-coordinate ones the release thresholds are defined on: against
// MultiplierSolve::row_sines2 on every row at the same pose, on chains
// with held angles and dihedrals, one strongly perturbed.
TEST(ConstrainedDynamics, ProjectionMeasuresTheHeldRowsSinesOfTheFullProblem) {
  for (test::Articulated a : {every_row_chain(), test::open_chain(5, 0.3, true, true)}) {
    const MassMatrix m(a.cluster.bodies);
    JointRows rows;
    joint_rows(a.cluster.bodies, m.layout, a.joints, rows);
    const int balls = 3 * int(a.joints.balls.size());
    const double expected = MultiplierSolve(rows.g, m).row_sines2(balls).minCoeff();
    ASSERT_GT(expected, 0.0);
    const VelocityProjection pr = project_velocities(a.bodies(), a.joints, true);
    EXPECT_NEAR(pr.weakest_held_sine2, expected, 1e-10 * expected);
  }
}

TEST(ConstrainedDynamics, IndependenceIsTheSquaredSineBetweenTwoRows) {
  const std::vector<CompliantBody> one = {test::sphere_at(Vec3::Zero())};
  const MassMatrix m(one);
  for (const double alpha : {1.2, 0.3, 1e-3}) {
    Eigen::MatrixXd g(2, 3);
    g.row(0) << 1.0, 0.0, 0.0;
    g.row(1) << 7.0 * std::cos(alpha), 7.0 * std::sin(alpha), 0.0;
    const MultiplierSolve solve(g, m);
    const double s2 = std::sin(alpha) * std::sin(alpha);
    ASSERT_EQ(solve.row_sines2().size(), 2);
    EXPECT_NEAR(solve.row_sines2()[0], s2, 1e-12 + 1e-9 * s2) << "alpha " << alpha;
    EXPECT_NEAR(solve.row_sines2()[1], s2, 1e-12 + 1e-9 * s2) << "alpha " << alpha;
    EXPECT_EQ(MultiplierSolve(g, m, true).rank(), 2) << "alpha " << alpha;
  }
  Eigen::MatrixXd g(2, 3);
  g.row(0) << 1.0, 0.0, 0.0;
  g.row(1) << 3.0 * std::cos(1e-5), 3.0 * std::sin(1e-5), 0.0;  // sin^2 = 1e-10 < kRankThreshold
  EXPECT_EQ(MultiplierSolve(g, m).row_sines2().size(), 0);  // rank deficient: none
  EXPECT_EQ(MultiplierSolve(g, m, true).rank(), 1);
}

}  // namespace
// fit_rolls (used at every cut of an articulated slice): the rolls of an
// open chain turned off the joints by up to 1e-3 rad about their axes come
// back onto them by the rolls alone (the normal equations on the sparse
// roll Jacobian, three Gauss-Newton steps at most), nothing else moving.
// A linker of a ring of two shares its spheres with the chain's first: its
// roll and the first's are coupled, and the fit still converges.
TEST(ConstrainedDynamics, RollFitPutsTheJointsBack) {
  for (const bool ringed : {false, true}) {
    test::Articulated a = test::open_chain(16, 0.2, false, false);
    if (ringed) {
      const CompliantBody& l0 = a.cluster.bodies[1];
      a.cluster.bodies.push_back(test::linker_at(l0.x + 0.3 * test::perpendicular(l0.axis()), l0.axis(), 0.4));
      const int extra = int(a.cluster.bodies.size()) - 1;
      a.joints.balls.push_back(make_ball_joint(a.bodies(), 0, extra));
      a.joints.balls.push_back(make_ball_joint(a.bodies(), 2, extra));
    }
    std::vector<CompliantBody> bodies = a.cluster.bodies;
    std::mt19937_64 gen(11);
    std::uniform_real_distribution<double> turn(-1e-3, 1e-3);
    for (CompliantBody& b : bodies)
      if (b.shape == Shape::Linker) b.q = (Quat(Eigen::AngleAxisd(turn(gen), b.axis())) * b.q).normalized();
    const RollFit fit = fit_rolls(bodies, a.joints);
    EXPECT_GT(fit.residual_before, 1e-5) << "ringed " << ringed;
    EXPECT_LT(fit.residual_after, 1e-10) << "ringed " << ringed;
    EXPECT_LT(joint_residual(bodies, a.joints).cwiseAbs().maxCoeff(), 1e-10) << "ringed " << ringed;
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      EXPECT_TRUE(bodies[i].x == a.cluster.bodies[i].x);
      EXPECT_LT((bodies[i].axis() - a.cluster.bodies[i].axis()).norm(), 1e-14) << "body " << i;
    }
  }
}

}  // namespace ringsim
