#pragma once
// Articulated bonds as holonomic constraints (MODEL.md, "Two bond regimes",
// articulated; docs/ARTICULATED.md): the constraint functions C(poses) of one
// cluster, their Jacobians G and the velocity-product terms (dG/dt) v.
//
// Joints (indices are into the cluster's bodies, the same as CompliantCluster):
//  - BallJoint (3 rows): the sphere's centre stays at its capture position
//    fixed in the linker's body frame,
//      C = x_S - (x_L + R(q_L) a),   a = the anchor in the linker's body frame;
//  - HeldAngle (1 row): the angle theta between the outward axes n_A, n_B of
//    two linkers at a sphere (core/bond_rules.hpp: n = outward_axis(u, end),
//    pointing away from the sphere) held at theta0, written as
//      C = (cos theta0 - n_A . n_B) / sin theta0      (= theta - theta0 + O(dtheta^2)),
//    so that the row is in radians and of unit size near the held pose. Its
//    gradient is |n_A x n_B| / sin theta0: it vanishes at theta = 0 or 180
//    degrees, where one scalar cannot hold an angle (there the held set is
//    a point of the two-sphere, two conditions); held_angle_defined() refuses
//    theta0 within kHeldMinSine of those (the rules must not create such a
//    hold; with the study's filter, theta0 = 90 +- 5 degrees, it never comes up);
//  - HeldDihedral (1 row): the dihedral phi about linker M between the outward
//    axes n0, n1 of its neighbours (dihedral_deg's convention, radians) held
//    at phi0, written with a = u x n0, b = u x n1 as
//      C = |a| |b| sin(phi - phi0) = cos(phi0) u.(n0 x n1) - sin(phi0) (u x n0).(u x n1),
//    a polynomial in the three axes. Why not C = phi - phi0: its gradient
//    has size 1/|a| (1/|b|) and blows up where a neighbour turns parallel to
//    M's axis; with a held dihedral and a free bond angle (Scenario 3's
//    filters) a planar chain swings a neighbour through that pose within a
//    few time units (measured: every one of 6 seeds within t < 27, where
//    the integrator then stalled), and there phi jumps by pi (cis <-> trans).
//    The polynomial's gradient stays finite and nonzero there (its size is
//    ~ max(|a|, |b|)), its zero set holds phi0 and phi0 + pi, the two branches
//    a planar swing passes between, and it vanishes only when both
//    neighbours are parallel to the axis (codimension 4). Near the held pose
//    C = |a||b| (phi - phi0) + O(dphi^3): radians times the two sines.
//    held_dihedral_defined() refuses a hold whose phi0 cannot be measured
//    (a neighbour within kHeldMinSine of the axis at the check);
//    min_joint_sine() reports how close a held pose has come to a singular one.
// Nothing else is held.
//
// Velocity coordinates (VelocityLayout), body by body in the cluster's
// order: a sphere v (3; a point mass on its joints, no spin column), a linker
// v then world omega (6). Rows of G act on that vector: C' = G nu, and
// C'' = G nu' + (dG/dt) nu, where the bias (dG/dt) nu is evaluated with the
// present velocities (Baraff 1996, "Linear-time dynamics using Lagrange
// multipliers", eq. for the acceleration-level constraint). Row order: the ball
// joints (3 rows each), then the angles, then the dihedrals.
//
// Gradients with respect to a body's rotation: a body turning at omega moves a
// vector r fixed in it at omega x r; d(f)/dt = G_omega . omega defines the
// omega columns.

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/compliant.hpp"
#include "core/vec.hpp"

namespace ringsim {

// Smallest sine allowed between the two axes of a held angle (at theta0) and
// between a held dihedral's axis and either neighbour: sin 2 degrees. Below
// it the row's gradient is within a factor ~30 of vanishing (angle) or
// exploding (dihedral); the rules refuse such a hold.
constexpr double kHeldMinSine = 0.03489949670250097;  // sin(2 degrees)

struct BallJoint {
  int sphere;
  int linker;
  Vec3 anchor;  // the sphere centre in the linker's body frame (length units)
};
struct HeldAngle {
  int sphere;           // the common sphere (no row depends on it; bookkeeping)
  int linker_a, end_a;  // the two linkers and their ends at the sphere
  int linker_b, end_b;
  double theta0;        // radians, sin(theta0) >= kHeldMinSine
};
struct HeldDihedral {
  int linker;        // the central linker M
  int nb0, nb0_end;  // neighbour at the sphere on M's end-0 side, its end there
  int nb1, nb1_end;  // neighbour at the end-1 side
  double phi0;       // radians, in (-pi, pi]
};

struct JointSet {
  std::vector<BallJoint> balls;
  std::vector<HeldAngle> angles;
  std::vector<HeldDihedral> dihedrals;

  int rows() const { return 3 * int(balls.size()) + int(angles.size()) + int(dihedrals.size()); }
  bool empty() const { return balls.empty() && angles.empty() && dihedrals.empty(); }
};

// Joints holding the present pose: the anchor, theta0, phi0 measured now.
BallJoint make_ball_joint(const std::vector<CompliantBody>& bodies, int sphere, int linker);
HeldAngle make_held_angle(const std::vector<CompliantBody>& bodies, int sphere, int linker_a, int end_a,
                          int linker_b, int end_b);
HeldDihedral make_held_dihedral(const std::vector<CompliantBody>& bodies, int linker, int nb0, int nb0_end,
                                int nb1, int nb1_end);

// Empty when every index of `joints` names a body of the right shape (a
// sphere, linkers, ends 0 or 1) and every held angle is defined; else what is wrong.
// A new rigid bond (sphere, linker end) in the articulated reading (MODEL.md,
// "Two bond regimes"): adds the bond's topology terms to `cluster` with
// add_compliant_bond (the same rules decide which angles and dihedrals a bond
// creates, whatever holds them) and, for each term it added, the joint that
// holds it at the present pose: a ball joint at the sphere's centre, a held
// angle at its present value, a held dihedral at its present value.
void add_articulated_bond(CompliantCluster& cluster, JointSet& joints, int sphere, int linker, int end,
                          const BondingParams& bonding);

std::string check_joints(const std::vector<CompliantBody>& bodies, const JointSet& joints);

// Predicates for the bond rules: can this value be held? (unit axes; angle in radians)
bool held_angle_defined(double theta0);
// Appends `from`'s joints to `to` with every body index moved by `base`
// (two clusters' bodies laid end to end in one).
void append_joints(JointSet& to, const JointSet& from, int base);
// Appends `rows`' held angles and dihedrals to `to`, each held at its value
// at the present pose (a released row held again).
void append_held_at_present(JointSet& to, const JointSet& rows, const std::vector<CompliantBody>& bodies);
bool held_dihedral_defined(const Vec3& u, const Vec3& n0, const Vec3& n1);
// The smallest of sin(theta) over the held angles and of max(|u x n0|,
// |u x n1|) over the held dihedrals at the present pose (1 when there are
// none): the size of the smallest row's gradient, near 0 only near a
// singular pose.
double min_joint_sine(const std::vector<CompliantBody>& bodies, const JointSet& joints);

// Offsets of each body's velocity coordinates (see the header).
struct VelocityLayout {
  std::vector<int> offset;
  int size = 0;

  VelocityLayout() = default;
  explicit VelocityLayout(const std::vector<CompliantBody>& bodies);
  void assign(const std::vector<CompliantBody>& bodies);  // as the constructor, reusing the storage
  static int width(Shape s) { return s == Shape::Sphere ? 3 : 6; }
};

// nu (the velocity coordinates) of the bodies, and back (spheres keep their omega).
Eigen::VectorXd velocity_vector(const std::vector<CompliantBody>& bodies, const VelocityLayout& layout);
void set_velocities(std::vector<CompliantBody>& bodies, const VelocityLayout& layout, const Eigen::VectorXd& nu);

// Moves every body along the velocity coordinates dnu for unit time (x += dv,
// q <- exp(domega) q with the world rotation vector domega): the update of
// a position correction and of the finite-difference tests.
void displace(std::vector<CompliantBody>& bodies, const VelocityLayout& layout, const Eigen::VectorXd& dnu);

// The constraint residual C, in the row order of the header.
Eigen::VectorXd joint_residual(const std::vector<CompliantBody>& bodies, const JointSet& joints);

// One held dihedral's row from the three unit axes (u of the central linker,
// n0, n1 the neighbours' outward axes) and phi0: C, and its omega columns
// for the central linker and the two neighbours (g_m + g_0 + g_1 = 0: C is
// invariant under a common rotation). joint_residual and joint_rows are
// built on these, and so is the Bullet peer's three-body row
// (bench/peer/held_dihedral.hpp).
double held_dihedral_residual(const Vec3& u, const Vec3& n0, const Vec3& n1, double phi0);
void held_dihedral_gradient(const Vec3& u, const Vec3& n0, const Vec3& n1, double phi0, Vec3& g_m, Vec3& g_0,
                            Vec3& g_1);

// G nu (one value per joint row, in joint_rows' order) at the present pose
// for velocity coordinates nu in `layout`, row by row without forming G:
// O(rows) where G nu with the dense G is O(rows x columns).
void joint_rates(const std::vector<CompliantBody>& bodies, const VelocityLayout& layout, const JointSet& joints,
                 const Eigen::VectorXd& nu, Eigen::VectorXd& out);

// d C / d(roll of a linker about its own axis) = G's omega columns of that
// linker times its axis u, per joint row, for the linkers the row involves
// (at most three; -1 fills): linker[r][k] (an index into bodies), value[r][k].
struct RollJacobian {
  std::vector<std::array<int, 3>> linker;
  std::vector<std::array<double, 3>> value;
};
void roll_jacobian(const std::vector<CompliantBody>& bodies, const VelocityLayout& layout, const JointSet& joints,
                   RollJacobian& out);

// C, G (rows x layout.size) and the bias (dG/dt) nu at the present velocities.
struct JointRows {
  Eigen::VectorXd c;
  Eigen::MatrixXd g;
  Eigen::VectorXd bias;
};
void joint_rows(const std::vector<CompliantBody>& bodies, const VelocityLayout& layout, const JointSet& joints,
                JointRows& out);

// The columns of a multiplier problem in which each bonded sphere rides on
// its host, the linker of its first ball joint (core/constrained_dynamics.hpp,
// add_constraint_loads): a sphere is a point mass, so that joint fixes it in
// the host's frame and the pair moves rigidly. A hosted sphere has no columns
// of its own: its velocity is its host's at the joint point, v_S = v_H +
// omega_H x arm (arm = R(q_H) a), and its acceleration a_H + alpha_H x arm +
// c with c = omega_H x (omega_H x arm), exactly what the host joint's
// C'' = 0 says; a row's block on v_S goes to the host's columns and its c to
// the bias. The host joints have no rows (3 rows fewer per bonded sphere).
struct HostedColumns {
  std::vector<int> offset;      // per body: its first column (a hosted sphere: its host's)
  std::vector<int> host;        // per body: the host of a hosted sphere, -1 otherwise
  std::vector<Vec3> arm, c;     // per hosted sphere
  std::vector<char> host_ball;  // per ball joint: 1 when it is its sphere's host joint
  int size = 0;                 // columns: 6 per linker, 3 per sphere without a joint
  int rows = 0;                 // the joints' rows less the host joints'

  HostedColumns() = default;
  HostedColumns(const std::vector<CompliantBody>& bodies, const JointSet& joints);
  void assign(const std::vector<CompliantBody>& bodies, const JointSet& joints);  // reusing the storage
};
// Per row of G, the first columns of the (at most three) bodies it has
// entries in, each once, -1 where a row has fewer: G's sparsity by body
// blocks, known from the joints without reading G.
using RowBlocks = std::vector<std::array<int, 3>>;

// G and the bias (dG/dt) nu on those columns, in joint_rows' row order
// without the host joints' rows (no residual: the right-hand side needs
// none); blocks, when given, receives each row's body blocks.
void hosted_joint_rows(const std::vector<CompliantBody>& bodies, const HostedColumns& columns,
                       const JointSet& joints, Eigen::MatrixXd& g, Eigen::VectorXd& bias,
                       RowBlocks* blocks = nullptr);

// The hosted problem's G stored by its rows' body blocks: every body a row
// touches there has six columns (a linker, or a linker with the spheres it
// hosts; a sphere with no joint is in no row), so row r holds its entries
// in columns blocks[r][k] .. blocks[r][k] + 5 as values(r, 6k .. 6k + 5)
// and is zero elsewhere. Storage, zeroing and products are O(rows) where
// the dense G's are O(rows x columns): at 381 rows (a chain of 128
// corners) the dense G's zeroing and its two products were 60 % of the
// right-hand side (docs/ARTICULATED.md, "Cost").
struct BlockRows {
  int cols = 0;
  RowBlocks blocks;
  Eigen::Matrix<double, Eigen::Dynamic, 18, Eigen::RowMajor> values;

  int rows() const { return int(values.rows()); }
  void add_times(const Eigen::VectorXd& x, Eigen::VectorXd& y) const;            // y += G x
  void add_transpose_times(const Eigen::VectorXd& l, Eigen::VectorXd& y) const;  // y += G^T l
  Eigen::MatrixXd dense() const;
};
void hosted_joint_rows(const std::vector<CompliantBody>& bodies, const HostedColumns& columns,
                       const JointSet& joints, BlockRows& g, Eigen::VectorXd* bias);  // bias: null when not needed

}  // namespace ringsim
