#include "core/joints.hpp"

#include <algorithm>
#include <cmath>

#include "core/bond_rules.hpp"

namespace ringsim {
namespace {

Vec3 outward(const CompliantBody& linker, int end) { return outward_axis(linker.axis(), end); }

// Dihedral about unit u between unit n0, n1 (dihedral_deg's convention, in
// radians): phi = atan2(u.(a x b), a.b), a = u x n0, b = u x n1.
double dihedral(const Vec3& u, const Vec3& n0, const Vec3& n1) {
  const Vec3 a = u.cross(n0), b = u.cross(n1);
  return std::atan2(u.dot(a.cross(b)), a.dot(b));
}

}  // namespace

BallJoint make_ball_joint(const std::vector<CompliantBody>& bodies, int sphere, int linker) {
  const CompliantBody& l = bodies[linker];
  return {sphere, linker, l.q.conjugate() * (bodies[sphere].x - l.x)};
}

HeldAngle make_held_angle(const std::vector<CompliantBody>& bodies, int sphere, int linker_a, int end_a,
                          int linker_b, int end_b) {
  const Vec3 na = outward(bodies[linker_a], end_a), nb = outward(bodies[linker_b], end_b);
  return {sphere, linker_a, end_a, linker_b, end_b, std::atan2(na.cross(nb).norm(), na.dot(nb))};
}

HeldDihedral make_held_dihedral(const std::vector<CompliantBody>& bodies, int linker, int nb0, int nb0_end,
                                int nb1, int nb1_end) {
  const double phi = dihedral(bodies[linker].axis(), outward(bodies[nb0], nb0_end), outward(bodies[nb1], nb1_end));
  return {linker, nb0, nb0_end, nb1, nb1_end, phi};
}

void add_articulated_bond(CompliantCluster& cluster, JointSet& joints, int sphere, int linker, int end,
                          const BondingParams& bonding) {
  const std::size_t nb = cluster.bonds.size(), na = cluster.angles.size(), nd = cluster.dihedrals.size();
  add_compliant_bond(cluster, sphere, linker, end, bonding);
  const std::vector<CompliantBody>& b = cluster.bodies;
  for (std::size_t k = nb; k < cluster.bonds.size(); ++k)
    joints.balls.push_back(make_ball_joint(b, cluster.bonds[k].sphere, cluster.bonds[k].linker));
  for (std::size_t k = na; k < cluster.angles.size(); ++k) {
    const CompliantAngle& a = cluster.angles[k];
    joints.angles.push_back(make_held_angle(b, a.sphere, a.linker_a, a.end_a, a.linker_b, a.end_b));
  }
  for (std::size_t k = nd; k < cluster.dihedrals.size(); ++k) {
    const CompliantDihedral& d = cluster.dihedrals[k];
    joints.dihedrals.push_back(make_held_dihedral(b, d.linker, d.nb0, d.nb0_end, d.nb1, d.nb1_end));
  }
}

std::string check_joints(const std::vector<CompliantBody>& bodies, const JointSet& joints) {
  const int n = int(bodies.size());
  auto is = [&](int i, Shape s) { return i >= 0 && i < n && bodies[i].shape == s; };
  auto end_ok = [](int e) { return e == 0 || e == 1; };
  for (std::size_t k = 0; k < joints.balls.size(); ++k) {
    const BallJoint& j = joints.balls[k];
    if (!is(j.sphere, Shape::Sphere) || !is(j.linker, Shape::Linker)) {
      return "ball joint " + std::to_string(k) + ": sphere " + std::to_string(j.sphere) + ", linker " +
             std::to_string(j.linker) + " of " + std::to_string(n) + " bodies";
    }
  }
  for (std::size_t k = 0; k < joints.angles.size(); ++k) {
    const HeldAngle& a = joints.angles[k];
    if (!is(a.linker_a, Shape::Linker) || !is(a.linker_b, Shape::Linker) || !end_ok(a.end_a) || !end_ok(a.end_b)) {
      return "held angle " + std::to_string(k) + ": linkers " + std::to_string(a.linker_a) + ", " +
             std::to_string(a.linker_b) + " of " + std::to_string(n) + " bodies";
    }
    if (!held_angle_defined(a.theta0)) {
      return "held angle " + std::to_string(k) + ": theta0 = " + std::to_string(a.theta0) +
             " rad is within 2 degrees of 0 or 180";
    }
  }
  for (std::size_t k = 0; k < joints.dihedrals.size(); ++k) {
    const HeldDihedral& d = joints.dihedrals[k];
    if (!is(d.linker, Shape::Linker) || !is(d.nb0, Shape::Linker) || !is(d.nb1, Shape::Linker) ||
        !end_ok(d.nb0_end) || !end_ok(d.nb1_end)) {
      return "held dihedral " + std::to_string(k) + ": linkers " + std::to_string(d.linker) + ", " +
             std::to_string(d.nb0) + ", " + std::to_string(d.nb1) + " of " + std::to_string(n) + " bodies";
    }
  }
  return "";
}

bool held_angle_defined(double theta0) { return std::sin(theta0) >= kHeldMinSine; }

void append_held_at_present(JointSet& to, const JointSet& rows, const std::vector<CompliantBody>& bodies) {
  for (const HeldAngle& a : rows.angles)
    to.angles.push_back(make_held_angle(bodies, a.sphere, a.linker_a, a.end_a, a.linker_b, a.end_b));
  for (const HeldDihedral& d : rows.dihedrals)
    to.dihedrals.push_back(make_held_dihedral(bodies, d.linker, d.nb0, d.nb0_end, d.nb1, d.nb1_end));
}

void append_joints(JointSet& to, const JointSet& from, int base) {
  for (BallJoint x : from.balls) to.balls.push_back({x.sphere + base, x.linker + base, x.anchor});
  for (HeldAngle x : from.angles)
    to.angles.push_back({x.sphere + base, x.linker_a + base, x.end_a, x.linker_b + base, x.end_b, x.theta0});
  for (HeldDihedral x : from.dihedrals)
    to.dihedrals.push_back({x.linker + base, x.nb0 + base, x.nb0_end, x.nb1 + base, x.nb1_end, x.phi0});
}

bool held_dihedral_defined(const Vec3& u, const Vec3& n0, const Vec3& n1) {
  return u.cross(n0).norm() >= kHeldMinSine && u.cross(n1).norm() >= kHeldMinSine;
}

double min_joint_sine(const std::vector<CompliantBody>& bodies, const JointSet& joints) {
  double m = 1.0;
  for (const HeldAngle& a : joints.angles) {
    m = std::min(m, outward(bodies[a.linker_a], a.end_a).cross(outward(bodies[a.linker_b], a.end_b)).norm());
  }
  for (const HeldDihedral& d : joints.dihedrals) {
    const Vec3 u = bodies[d.linker].axis();
    m = std::min(m, std::max(u.cross(bodies[d.nb0].axis()).norm(), u.cross(bodies[d.nb1].axis()).norm()));
  }
  return m;
}

VelocityLayout::VelocityLayout(const std::vector<CompliantBody>& bodies) { assign(bodies); }

void VelocityLayout::assign(const std::vector<CompliantBody>& bodies) {
  offset.resize(bodies.size());
  size = 0;
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    offset[i] = size;
    size += width(bodies[i].shape);
  }
}

Eigen::VectorXd velocity_vector(const std::vector<CompliantBody>& bodies, const VelocityLayout& layout) {
  Eigen::VectorXd nu(layout.size);
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    nu.segment<3>(layout.offset[i]) = bodies[i].v;
    if (bodies[i].shape == Shape::Linker) nu.segment<3>(layout.offset[i] + 3) = bodies[i].omega;
  }
  return nu;
}

void set_velocities(std::vector<CompliantBody>& bodies, const VelocityLayout& layout, const Eigen::VectorXd& nu) {
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    bodies[i].v = nu.segment<3>(layout.offset[i]);
    if (bodies[i].shape == Shape::Linker) bodies[i].omega = nu.segment<3>(layout.offset[i] + 3);
  }
}

void displace(std::vector<CompliantBody>& bodies, const VelocityLayout& layout, const Eigen::VectorXd& dnu) {
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    CompliantBody& b = bodies[i];
    b.x += dnu.segment<3>(layout.offset[i]);
    if (b.shape != Shape::Linker) continue;
    const Vec3 w = dnu.segment<3>(layout.offset[i] + 3);
    const double angle = w.norm();
    if (angle > 0.0) b.q = (Eigen::AngleAxisd(angle, w / angle) * b.q).normalized();
  }
}

Eigen::VectorXd joint_residual(const std::vector<CompliantBody>& bodies, const JointSet& joints) {
  Eigen::VectorXd c(joints.rows());
  int row = 0;
  for (const BallJoint& j : joints.balls) {
    const CompliantBody& l = bodies[j.linker];
    c.segment<3>(row) = bodies[j.sphere].x - l.x - l.q * j.anchor;
    row += 3;
  }
  for (const HeldAngle& a : joints.angles) {
    const Vec3 na = outward(bodies[a.linker_a], a.end_a), nb = outward(bodies[a.linker_b], a.end_b);
    c[row++] = (std::cos(a.theta0) - na.dot(nb)) / std::sin(a.theta0);
  }
  for (const HeldDihedral& d : joints.dihedrals) {
    const Vec3 u = bodies[d.linker].axis();
    const Vec3 n0 = outward(bodies[d.nb0], d.nb0_end), n1 = outward(bodies[d.nb1], d.nb1_end);
    c[row++] = held_dihedral_residual(u, n0, n1, d.phi0);
  }
  return c;
}

double held_dihedral_residual(const Vec3& u, const Vec3& n0, const Vec3& n1, double phi0) {
  return std::cos(phi0) * u.dot(n0.cross(n1)) - std::sin(phi0) * (n0.dot(n1) - u.dot(n0) * u.dot(n1));
}

// C = cos(phi0) A - sin(phi0) B with the triple product A = u.(n0 x n1)
// = |a||b| sin(phi) and B = (u x n0).(u x n1) = n0.n1 - (u.n0)(u.n1)
// = |a||b| cos(phi) (a = u x n0, b = u x n1). A rotation omega_k of the body
// carrying vector w moves it at omega_k x w, and x.(y x z) is invariant
// under cyclic shifts, so with c0 = u.n0, c1 = u.n1:
//   dA: omega_M . u x (n0 x n1) + omega_0 . n0 x (n1 x u) + omega_1 . n1 x (u x n0),
//   dB: omega_0 . (n0 x n1 - c1 n0 x u) + omega_1 . (n1 x n0 - c0 n1 x u)
//       - omega_M . (c1 u x n0 + c0 u x n1).
void held_dihedral_gradient(const Vec3& u, const Vec3& n0, const Vec3& n1, double phi0, Vec3& g_m, Vec3& g_0,
                            Vec3& g_1) {
  const double cp = std::cos(phi0), sp = std::sin(phi0);
  const double c0 = u.dot(n0), c1 = u.dot(n1);
  const Vec3 ga_m = u.cross(n0.cross(n1)), ga_0 = n0.cross(n1.cross(u)), ga_1 = n1.cross(u.cross(n0));
  const Vec3 gb_0 = n0.cross(n1) - c1 * n0.cross(u), gb_1 = n1.cross(n0) - c0 * n1.cross(u);
  const Vec3 gb_m = -(c1 * u.cross(n0) + c0 * u.cross(n1));
  g_m = cp * ga_m - sp * gb_m;
  g_0 = cp * ga_0 - sp * gb_0;
  g_1 = cp * ga_1 - sp * gb_1;
}

HostedColumns::HostedColumns(const std::vector<CompliantBody>& bodies, const JointSet& joints) {
  assign(bodies, joints);
}

void HostedColumns::assign(const std::vector<CompliantBody>& bodies, const JointSet& joints) {
  offset.assign(bodies.size(), -1);
  host.assign(bodies.size(), -1);
  arm.resize(bodies.size());
  c.resize(bodies.size());
  host_ball.assign(joints.balls.size(), 0);
  size = 0;
  rows = joints.rows();
  for (std::size_t k = 0; k < joints.balls.size(); ++k) {
    const BallJoint& j = joints.balls[k];
    if (host[j.sphere] >= 0) continue;
    const CompliantBody& l = bodies[j.linker];
    host[j.sphere] = j.linker;
    arm[j.sphere] = l.q * j.anchor;
    c[j.sphere] = l.omega.cross(l.omega.cross(arm[j.sphere]));
    host_ball[k] = 1;
    rows -= 3;
  }
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    if (host[i] >= 0) continue;
    offset[i] = size;
    size += VelocityLayout::width(bodies[i].shape);
  }
  for (std::size_t i = 0; i < bodies.size(); ++i)
    if (host[i] >= 0) offset[i] = offset[host[i]];
}

namespace {

// Where write_rows puts G's entries: add(row, body, inner, m) adds the
// block m (1 or 3 rows, 3 columns) at the row `row` and the columns
// body + inner .. + 2 (body: the body's first column; inner: 0 for v,
// 3 for omega).
struct DenseSink {
  Eigen::MatrixXd& g;
  template <class M>
  void add(int row, int body, int inner, const M& m) {
    g.block<M::RowsAtCompileTime, 3>(row, body + inner) += m;
  }
};
// G nu without G: each block times nu's entries in its columns.
struct ProductSink {
  const Eigen::VectorXd& nu;
  Eigen::VectorXd& out;
  template <class M>
  void add(int row, int body, int inner, const M& m) {
    out.segment<M::RowsAtCompileTime>(row) += m * nu.segment<3>(body + inner);
  }
};
// The rows' omega blocks times their linker's axis (roll_jacobian).
struct RollSink {
  const std::vector<CompliantBody>& bodies;
  const std::vector<int>& body_at;  // per column: the body whose first column it is
  RollJacobian& out;
  template <class M>
  void add(int row, int body, int inner, const M& m) {
    if (inner != 3) return;
    const int b = body_at[body];
    const Eigen::Matrix<double, M::RowsAtCompileTime, 1> d = m * bodies[b].axis();
    for (int i = 0; i < M::RowsAtCompileTime; ++i) {
      std::array<int, 3>& l = out.linker[row + i];
      const int k = l[0] == b || l[0] < 0 ? 0 : l[1] == b || l[1] < 0 ? 1 : 2;
      l[k] = b;
      out.value[row + i][k] += d[i];
    }
  }
};
// Into BlockRows: the body's slot in the row's blocks (marked before).
struct BlockSink {
  BlockRows& g;
  template <class M>
  void add(int row, int body, int inner, const M& m) {
    const std::array<int, 3>& b = g.blocks[row];
    const int k = b[0] == body ? 0 : b[1] == body ? 1 : 2;
    g.values.block<M::RowsAtCompileTime, 3>(row, 6 * k + inner) += m;
  }
};

// G and, when `bias` is given (sized to the rows), the bias (dG/dt) nu on
// the columns `offset` (per body), the rows of the host joints left out; a
// hosted sphere's point velocity is its host's at the joint point
// (HostedColumns). `hosted` null: every body has its own columns and every
// row is written.
template <class Sink>
void write_rows(const std::vector<CompliantBody>& bodies, const std::vector<int>& offset,
                const HostedColumns* hosted, const JointSet& joints, Sink& g, Eigen::VectorXd* bias,
                RowBlocks* blocks) {
  int row = 0;
  if (blocks) blocks->resize(hosted ? hosted->rows : joints.rows());
  // Each body block once (-1 for a repeat: a dihedral whose two
  // neighbours are one linker, in a ring of two, names it twice).
  auto mark = [blocks](int r, int a, int b, int c) {
    if (blocks) (*blocks)[r] = {a, b == a ? -1 : b, c == a || c == b ? -1 : c};
  };

  // Ball joint: C' = v_S - v_L - omega_L x r = v_S - v_L + [r]x omega_L,
  // r = R a; (dG/dt) nu = [r']x omega_L = (omega_L x r) x omega_L. A hosted
  // sphere: v_S = v_H - [arm]x omega_H, and its acceleration at zero host
  // acceleration, c, joins the bias.
  for (std::size_t k = 0; k < joints.balls.size(); ++k) {
    if (hosted && hosted->host_ball[k]) continue;
    const BallJoint& j = joints.balls[k];
    const CompliantBody& l = bodies[j.linker];
    const Vec3 r = l.q * j.anchor;
    const int os = offset[j.sphere], ol = offset[j.linker];
    for (int i = 0; i < 3; ++i) mark(row + i, os, ol, -1);
    g.add(row, os, 0, Mat3::Identity());
    if (bias) bias->segment<3>(row) = -l.omega.cross(l.omega.cross(r));
    if (hosted && hosted->host[j.sphere] >= 0) {
      g.add(row, os, 3, Mat3(-cross_matrix(hosted->arm[j.sphere])));
      if (bias) bias->segment<3>(row) += hosted->c[j.sphere];
    }
    g.add(row, ol, 0, Mat3(-Mat3::Identity()));
    g.add(row, ol, 3, cross_matrix(r));
    row += 3;
  }

  // Held angle: with c = n_A x n_B, d(n_A . n_B)/dt = (omega_A - omega_B) . c,
  // so G_A = -c / s0, G_B = +c / s0 (s0 = sin theta0), and the bias is
  // -c' . (omega_A - omega_B) / s0 with c' = (omega_A x n_A) x n_B + n_A x (omega_B x n_B).
  for (const HeldAngle& a : joints.angles) {
    const CompliantBody &la = bodies[a.linker_a], &lb = bodies[a.linker_b];
    const Vec3 na = outward(la, a.end_a), nb = outward(lb, a.end_b);
    const double s0 = std::sin(a.theta0);
    const Vec3 c = na.cross(nb);
    mark(row, offset[a.linker_a], offset[a.linker_b], -1);
    g.add(row, offset[a.linker_a], 3, Eigen::RowVector3d(-c.transpose() / s0));
    g.add(row, offset[a.linker_b], 3, Eigen::RowVector3d(c.transpose() / s0));
    if (bias) {
      const Vec3 dc = la.omega.cross(na).cross(nb) + na.cross(lb.omega.cross(nb));
      (*bias)[row] = -dc.dot(la.omega - lb.omega) / s0;
    }
    ++row;
  }

  // Held dihedral: G from held_dihedral_gradient (its derivation there).
  // Bias: C = cos(phi0) A - sin(phi0) B, A = u.(n0 x n1), B = n0.n1 -
  // (u.n0)(u.n1), polynomials in u, n0, n1, so (dG/dt) nu = C'' along the
  // motion at constant omegas (w' = omega x w, w'' = omega x w'), by the
  // product rule.
  for (const HeldDihedral& d : joints.dihedrals) {
    const CompliantBody &lm = bodies[d.linker], &l0 = bodies[d.nb0], &l1 = bodies[d.nb1];
    const Vec3 u = lm.axis(), n0 = outward(l0, d.nb0_end), n1 = outward(l1, d.nb1_end);
    Vec3 g_m, g_0, g_1;
    held_dihedral_gradient(u, n0, n1, d.phi0, g_m, g_0, g_1);
    mark(row, offset[d.linker], offset[d.nb0], offset[d.nb1]);
    g.add(row, offset[d.linker], 3, Eigen::RowVector3d(g_m.transpose()));
    g.add(row, offset[d.nb0], 3, Eigen::RowVector3d(g_0.transpose()));
    g.add(row, offset[d.nb1], 3, Eigen::RowVector3d(g_1.transpose()));
    if (!bias) {
      ++row;
      continue;
    }
    const double cp = std::cos(d.phi0), sp = std::sin(d.phi0);
    const double c0 = u.dot(n0), c1 = u.dot(n1);
    const Vec3 du = lm.omega.cross(u), dn0 = l0.omega.cross(n0), dn1 = l1.omega.cross(n1);
    const Vec3 ddu = lm.omega.cross(du), ddn0 = l0.omega.cross(dn0), ddn1 = l1.omega.cross(dn1);
    const double dda = ddu.dot(n0.cross(n1)) + u.dot(ddn0.cross(n1)) + u.dot(n0.cross(ddn1)) +
                       2.0 * (du.dot(dn0.cross(n1)) + du.dot(n0.cross(dn1)) + u.dot(dn0.cross(dn1)));
    const double dc0 = du.dot(n0) + u.dot(dn0), dc1 = du.dot(n1) + u.dot(dn1);
    const double ddc0 = ddu.dot(n0) + 2.0 * du.dot(dn0) + u.dot(ddn0);
    const double ddc1 = ddu.dot(n1) + 2.0 * du.dot(dn1) + u.dot(ddn1);
    const double ddb = ddn0.dot(n1) + 2.0 * dn0.dot(dn1) + n0.dot(ddn1) - (ddc0 * c1 + 2.0 * dc0 * dc1 + c0 * ddc1);
    (*bias)[row] = cp * dda - sp * ddb;
    ++row;
  }
}

}  // namespace

void joint_rows(const std::vector<CompliantBody>& bodies, const VelocityLayout& layout, const JointSet& joints,
                JointRows& out) {
  out.c = joint_residual(bodies, joints);
  out.g.setZero(joints.rows(), layout.size);
  out.bias.setZero(joints.rows());
  DenseSink sink{out.g};
  write_rows(bodies, layout.offset, nullptr, joints, sink, &out.bias, nullptr);
}

void joint_rates(const std::vector<CompliantBody>& bodies, const VelocityLayout& layout, const JointSet& joints,
                 const Eigen::VectorXd& nu, Eigen::VectorXd& out) {
  out.setZero(joints.rows());
  ProductSink sink{nu, out};
  write_rows(bodies, layout.offset, nullptr, joints, sink, nullptr, nullptr);
}

void roll_jacobian(const std::vector<CompliantBody>& bodies, const VelocityLayout& layout, const JointSet& joints,
                   RollJacobian& out) {
  out.linker.assign(joints.rows(), {-1, -1, -1});
  out.value.assign(joints.rows(), {0.0, 0.0, 0.0});
  std::vector<int> body_at(layout.size, -1);
  for (std::size_t i = 0; i < bodies.size(); ++i) body_at[layout.offset[i]] = int(i);
  RollSink sink{bodies, body_at, out};
  write_rows(bodies, layout.offset, nullptr, joints, sink, nullptr, nullptr);
}

void hosted_joint_rows(const std::vector<CompliantBody>& bodies, const HostedColumns& columns,
                       const JointSet& joints, Eigen::MatrixXd& g, Eigen::VectorXd& bias, RowBlocks* blocks) {
  g.setZero(columns.rows, columns.size);
  bias.setZero(columns.rows);
  DenseSink sink{g};
  write_rows(bodies, columns.offset, &columns, joints, sink, &bias, blocks);
}

void hosted_joint_rows(const std::vector<CompliantBody>& bodies, const HostedColumns& columns,
                       const JointSet& joints, BlockRows& g, Eigen::VectorXd* bias) {
  g.cols = columns.size;
  g.values.setZero(columns.rows, 18);
  if (bias) bias->setZero(columns.rows);
  BlockSink sink{g};
  write_rows(bodies, columns.offset, &columns, joints, sink, bias, &g.blocks);
}

void BlockRows::add_times(const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
  for (int r = 0; r < rows(); ++r)
    for (int k = 0; k < 3; ++k)
      if (blocks[r][k] >= 0) y[r] += values.block<1, 6>(r, 6 * k).dot(x.segment<6>(blocks[r][k]));
}

void BlockRows::add_transpose_times(const Eigen::VectorXd& l, Eigen::VectorXd& y) const {
  for (int r = 0; r < rows(); ++r)
    for (int k = 0; k < 3; ++k)
      if (blocks[r][k] >= 0) y.segment<6>(blocks[r][k]) += l[r] * values.block<1, 6>(r, 6 * k).transpose();
}

Eigen::MatrixXd BlockRows::dense() const {
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(rows(), cols);
  for (int r = 0; r < rows(); ++r)
    for (int k = 0; k < 3; ++k)
      if (blocks[r][k] >= 0) g.block<1, 6>(r, blocks[r][k]) = values.block<1, 6>(r, 6 * k);
  return g;
}

}  // namespace ringsim
