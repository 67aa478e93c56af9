#include "core/joint_projection.hpp"

#include <algorithm>
#include <cmath>

#include "core/constrained_dynamics.hpp"
#include "core/sparse_ldlt.hpp"

namespace ringsim {
namespace {

double max_abs(const Eigen::VectorXd& x) { return x.size() == 0 ? 0.0 : x.cwiseAbs().maxCoeff(); }

// The M-smallest correction dnu with G dnu = -r (r: one value per joint row,
// in joint_rows' order): dnu = -M^-1 G^T S^+ r, solved with each sphere riding
// on its host (HostedProblem). A host joint's rows fix a hosted sphere's
// part given its host's, v_S = v_H + omega_H x arm - r_H, so every dnu that
// meets them is T y + e with e the -r_H on the hosted spheres' rows;
// min |T y + e|_M over G_r y = b, b = -r_O - G_O e (the other rows, whose
// only sphere columns are a ball row's +1 on its sphere), is
// y = y0 + M_r^-1 G_r^T lambda, y0 = -M_r^-1 T^T M e, S_r lambda = b - G_r y0:
// the full problem's minimizer (the same feasible set), with 3 rows fewer per
// bonded sphere. Used for the velocity projection (r = G nu) and the
// position steps (r = C).
// any_solution: r is known to lie in the range of G (r = G nu), so any
// multipliers give the same correction (MultiplierSolve::Options). `solve`
// is the caller's, kept from call to call (its sparse analysis with it),
// or the correction's own.
class HostedCorrection {
 public:
  HostedCorrection(const std::vector<CompliantBody>& bodies, const JointSet& joints, const MassMatrix& m,
                   bool any_solution, MultiplierSolve* solve)
      : joints_(joints), m_(m), p_(bodies, joints, m), solve_(solve ? *solve : own_) {
    hosted_joint_rows(bodies, p_.columns, joints, g_, nullptr);  // no bias: a projection has no accelerations
    MultiplierSolve::Options options;
    options.any_solution = any_solution;
    solve_.compute(g_, p_.minv, options);
  }

  Eigen::VectorXd operator()(const Eigen::VectorXd& r) const {
    const HostedColumns& hc = p_.columns;
    Eigen::VectorXd e = Eigen::VectorXd::Zero(m_.layout.size);
    for (std::size_t k = 0; k < joints_.balls.size(); ++k)
      if (hc.host_ball[k]) e.segment<3>(m_.layout.offset[joints_.balls[k].sphere]) = -r.segment<3>(3 * int(k));
    Eigen::VectorXd b(hc.rows);
    int row = 0;
    for (std::size_t k = 0; k < joints_.balls.size(); ++k) {
      if (hc.host_ball[k]) continue;
      b.segment<3>(row) = -r.segment<3>(3 * int(k)) - e.segment<3>(m_.layout.offset[joints_.balls[k].sphere]);
      row += 3;
    }
    const int held = hc.rows - row;
    b.tail(held) = -r.tail(held);
    // y = y0 + M_r^-1 G_r^T lambda, S_r lambda = b - G_r y0.
    Eigen::VectorXd y = -p_.minv.times(p_.gather(m_, m_.times(e)));
    Eigen::VectorXd gy = Eigen::VectorXd::Zero(hc.rows);
    g_.add_times(y, gy);
    Eigen::VectorXd lambda = b - gy;
    solve_.solve_in_place(lambda);
    Eigen::VectorXd gtl = Eigen::VectorXd::Zero(hc.size);
    g_.add_transpose_times(lambda, gtl);
    y += p_.minv.times(gtl);
    return p_.scatter(m_, y) + e;
  }

  const HostedProblem& problem() const { return p_; }
  const BlockRows& g() const { return g_; }
  const MultiplierSolve& solve() const { return solve_; }

 private:
  const JointSet& joints_;
  const MassMatrix& m_;
  HostedProblem p_;
  BlockRows g_;
  MultiplierSolve own_;
  MultiplierSolve& solve_;
};

}  // namespace

VelocityProjection project_velocities(std::vector<CompliantBody>& bodies, const JointSet& joints, bool held_sines,
                                      MultiplierSolve* workspace) {
  VelocityProjection r;
  if (joints.empty()) return r;
  const MassMatrix m(bodies);
  const Eigen::VectorXd nu = velocity_vector(bodies, m.layout);
  Eigen::VectorXd gv;
  joint_rates(bodies, m.layout, joints, nu, gv);
  // The minimum of |nu1 - nu|_M over G nu1 = 0: nu plus the M-smallest
  // correction with G dnu = -G nu, on the hosted problem.
  const HostedCorrection correction(bodies, joints, m, true, workspace);
  const Eigen::VectorXd nu1 = nu + correction(gv);
  const HostedProblem& p = correction.problem();
  const BlockRows& g = correction.g();
  const MultiplierSolve& solve = correction.solve();
  const int balls = 3 * int(joints.balls.size()), held = joints.rows() - balls;
  if (held_sines && held > 0) {
    // A held row's squared sine to the span of every other row, in maximal
    // coordinates, is its part clear of that span (the Schur complement,
    // the same in both problems: T M_r^-1 T^T is M^-1 restricted to the host
    // joints' null space) over its own size g M^-1 g^T; the reduced solve
    // gives that part as sine_r^2 (S_r)_ii. The held rows come last, and
    // they touch linkers only, on their omega columns: g M^-1 g^T in
    // maximal coordinates is the sum over the row's linkers of
    // g_omega^T I^-1 g_omega, and (S_r)_ii the row's blocks' g M_r^-1 g^T.
    const Eigen::VectorXd s2 = solve.row_sines2(p.columns.rows - held);
    r.weakest_held_sine2 = s2.size() == 0 ? -1.0 : 1.0;
    if (s2.size() > 0) {
      std::vector<int> body_at(p.columns.size, -1), block_at(p.columns.size, -1);
      for (std::size_t i = 0; i < bodies.size(); ++i)
        if (p.columns.host[i] < 0) body_at[p.columns.offset[i]] = int(i);
      for (std::size_t i = 0; i < p.minv.offset.size(); ++i) block_at[p.minv.offset[i]] = int(i);
      for (int k = 0; k < int(s2.size()); ++k) {
        const int i = p.columns.rows - held + k;
        double s_full = 0.0, s_reduced = 0.0;
        for (int slot = 0; slot < 3; ++slot) {
          const int o = g.blocks[i][slot];
          if (o < 0) continue;
          const Eigen::Matrix<double, 6, 1> gi = g.values.block<1, 6>(i, 6 * slot).transpose();
          s_full += gi.tail<3>().dot(m.inv_inertia[body_at[o]] * gi.tail<3>());
          s_reduced += gi.dot(p.minv.inv[block_at[o]] * gi);
        }
        r.weakest_held_sine2 = std::min(r.weakest_held_sine2, s2[k] * s_reduced / s_full);
      }
    }
  }
  set_velocities(bodies, m.layout, nu1);
  Eigen::VectorXd gv1;
  joint_rates(bodies, m.layout, joints, nu1, gv1);
  r.residual_before = max_abs(gv);
  r.residual_after = max_abs(gv1);
  r.energy_change = 0.5 * (nu1.dot(m.times(nu1)) - nu.dot(m.times(nu)));
  return r;
}

Eigen::MatrixXd project_onto_joints_null_space(const std::vector<CompliantBody>& bodies, const JointSet& joints,
                                               const MassMatrix& m, Eigen::MatrixXd x, MultiplierSolve* workspace) {
  if (joints.empty()) return x;
  // Each column's G x lies in the range of G: any multipliers serve.
  const HostedCorrection correction(bodies, joints, m, true, workspace);
  Eigen::VectorXd gx;
  for (Eigen::Index col = 0; col < x.cols(); ++col) {
    const Eigen::VectorXd xc = x.col(col);
    joint_rates(bodies, m.layout, joints, xc, gx);
    x.col(col) += correction(gx);
  }
  return x;
}

RollFit fit_rolls(std::vector<CompliantBody>& bodies, const JointSet& joints, int max_iterations) {
  RollFit r;
  if (joints.empty()) return r;
  std::vector<int> roll(bodies.size(), -1);  // per body: its roll's unknown (linkers)
  int n = 0;
  for (std::size_t i = 0; i < bodies.size(); ++i)
    if (bodies[i].shape == Shape::Linker) roll[i] = n++;
  const VelocityLayout layout(bodies);
  RollJacobian a;
  Eigen::MatrixXd normal;
  Eigen::VectorXd d, scale;
  SparseLdlt ldlt;
  for (int it = 0;; ++it) {
    const Eigen::VectorXd c = joint_residual(bodies, joints);
    const double res = max_abs(c);
    if (it == 0) r.residual_before = res;
    r.residual_after = res;
    if (it == max_iterations || res == 0.0) break;
    // Least squares min |A d + C| on the rolls by the normal equations
    // A^T A d = -A^T C: A has at most three entries per row (the linkers of
    // a joint row), so A^T A is as sparse as the bonds, factored sparse
    // with its unit diagonal (equilibrated) and its nearly dependent rolls
    // dropped (core/sparse_ldlt.hpp; a roll that moves no anchor is a zero
    // row, its unknown zero). The dense least squares on A (complete
    // orthogonal decomposition of rows x linkers) was a fifth of a late
    // Scenario 1 replicate (docs/ARTICULATED.md, "Cost"). Squaring A's
    // condition is harmless here: the step is only kept when it lowers
    // max |C|.
    roll_jacobian(bodies, layout, joints, a);
    normal.setZero(n, n);
    d.setZero(n);
    for (std::size_t row = 0; row < a.linker.size(); ++row)
      for (int i = 0; i < 3; ++i) {
        const int li = a.linker[row][i];
        if (li < 0) continue;
        d[roll[li]] -= a.value[row][i] * c[Eigen::Index(row)];
        for (int j = 0; j < 3; ++j)
          if (a.linker[row][j] >= 0) normal(roll[li], roll[a.linker[row][j]]) += a.value[row][i] * a.value[row][j];
      }
    const double zero = kZeroRow * (n > 0 ? normal.diagonal().maxCoeff() : 0.0);
    scale = normal.diagonal().unaryExpr([zero](double x) { return x > zero ? 1.0 / std::sqrt(x) : 0.0; });
    normal = scale.asDiagonal() * normal * scale.asDiagonal();  // a zero row stays zero
    if (!ldlt.compute(normal, kRankThreshold)) break;
    d.array() *= scale.array();
    ldlt.solve_in_place(d);
    d.array() *= scale.array();
    std::vector<CompliantBody> trial = bodies;
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      if (roll[i] < 0 || d[roll[i]] == 0.0) continue;
      CompliantBody& b = trial[i];
      b.q = (Quat(Eigen::AngleAxisd(d[roll[i]], b.axis())) * b.q).normalized();
    }
    if (!(max_abs(joint_residual(trial, joints)) < res)) break;  // no gain: keep the better state
    bodies.swap(trial);
  }
  return r;
}

PositionProjection project_positions(std::vector<CompliantBody>& bodies, const JointSet& joints, double tolerance,
                                     int max_iterations, bool held_sines, MultiplierSolve* workspace) {
  PositionProjection r;
  if (joints.empty()) {
    r.converged = true;
    return r;
  }
  double moved2 = 0.0, last_moved2 = 0.0;
  std::vector<CompliantBody> last;  // before the latest step
  for (;;) {
    const Eigen::VectorXd c = joint_residual(bodies, joints);
    const double res = max_abs(c);
    if (r.iterations == 0) r.residual_before = res;
    // Stop at the tolerance, or when a step no longer halves the residual:
    // at a singular pose (a ring whose redundant rows lose rank, e.g. two
    // linkers side by side between the same two spheres) the part of C in
    // G's left null space is of second order and no Gauss-Newton step
    // removes it; the caller sees residual_after.
    if (r.iterations > 0 && res > 0.5 * r.residual_after) {
      if (res > r.residual_after) {  // the step made it worse (near a singular pose): undo it
        bodies = last;
        moved2 = last_moved2;
      } else {
        r.residual_after = res;
      }
      break;
    }
    r.residual_after = res;
    if (res <= tolerance || r.iterations >= max_iterations) break;
    const MassMatrix m(bodies);
    // C need not lie in the range of G (redundant rows drift apart):
    // the minimum-norm least-squares step.
    const Eigen::VectorXd dnu = HostedCorrection(bodies, joints, m, false, workspace)(c);
    last = bodies;
    last_moved2 = moved2;
    displace(bodies, m.layout, dnu);
    moved2 += dnu.dot(m.times(dnu));
    ++r.iterations;
  }
  r.converged = r.residual_after <= tolerance;
  r.displacement = std::sqrt(moved2);
  r.velocities = project_velocities(bodies, joints, held_sines, workspace);
  return r;
}

}  // namespace ringsim
