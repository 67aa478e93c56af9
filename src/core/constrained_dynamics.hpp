#pragma once
// Constrained rigid-body dynamics of one articulated cluster in maximal
// coordinates (docs/ARTICULATED.md): the mass matrix, the rank-revealing
// multiplier solve, the constraint loads that keep C'' = 0, and the count of
// the cluster's internal degrees of freedom.
//
// Lagrange-multiplier form (Baraff 1996, "Linear-time dynamics using Lagrange
// multipliers"; Featherstone, "Rigid Body Dynamics Algorithms", ch. 8):
//   M nu' = f + G^T lambda,   G nu' + (dG/dt) nu = 0
//   =>  S lambda = -(dG/dt) nu - G M^-1 f,   S = G M^-1 G^T,
// with nu the velocity coordinates of core/joints.hpp, M block-diagonal
// (m 1 per body, the world inertia tensor I = I_perp 1 + (I_axial - I_perp) u u^T
// per linker) and f the applied forces and, per linker, tau - omega x (I omega)
// (the gyroscopic term of d(I omega)/dt = tau in the world frame).
// S is singular when rows are redundant (a closed square ring is
// over-constrained: 32 rows, rank 30). The solve is Eigen's
// CompleteOrthogonalDecomposition with the pivot threshold kRankThreshold
// (relative to the largest pivot): the minimum-norm lambda, exact when the
// right-hand side lies in the range of S (consistent redundant rows), least
// squares otherwise. Rank decisions elsewhere (internal_dof) use the same
// threshold on the same matrix.
//
// S is stored dense and assembled body by body from G's nonzero rows (M is
// block diagonal, and a row touches 2 or 3 bodies), not by a dense product;
// the right-hand side and the projections keep G by its rows' body blocks
// (core/joints.hpp, BlockRows), the rest (rank tests, rare decisions) dense. From kSparseFromRows rows on S is factored sparse
// (core/sparse_ldlt.hpp), touching only its pattern and L's: a cluster is a
// tree of bonds with a few rings, and the dense factorization's O(rows^3)
// was the largest cost of Scenario 1's large clusters.

#include <vector>

#include <Eigen/Core>
#include <Eigen/Cholesky>
#include <Eigen/QR>

#include "core/joints.hpp"
#include "core/pivoted_ldlt.hpp"
#include "core/sparse_ldlt.hpp"

namespace ringsim {

// S is factored with its rows equilibrated, S~ = D^-1/2 S D^-1/2 with
// D = diag(S) (each row of G scaled to unit length in the M^-1 metric), so a
// pivot of S~ is the squared sine of the angle between a row and the span of
// the rows pivoted before it: a rank decision about directions, not sizes.
// Without it a held dihedral whose neighbour swings near its axis (gradient
// ~ |u x n|) or a light row counted as redundant and was left to drift
// (seen: a Scenario 3 chain's dihedral 0.8 from its held value). Pivots below
// kRankThreshold x the largest count as zero (an angle of ~3e-4 rad); a row
// with S_ii below kZeroRow x the largest is a zero row (not scaled).
constexpr double kRankThreshold = 1e-7;
constexpr double kZeroRow = 1e-16;

// From this many rows on, S is factored sparse first (core/sparse_ldlt.hpp:
// a fill-reducing order, pivots below kRankThreshold dropped as they come);
// below it, and when the sparse factors show S rank deficient and no
// solution but the minimum-norm one will do, the dense pivoted LDL^T.
// Chosen by bench_joints (BM_MultiplierFactor; docs/ARTICULATED.md, "Cost").
constexpr int kSparseFromRows = 6;

// M^-1 of a multiplier problem as diagonal blocks, one per body of the
// problem: width 3 (a point mass) or 6 (a rigid body: v then omega; a
// linker, or a linker carrying the spheres it hosts, whose block is dense).
struct InverseMassBlocks {
  std::vector<int> offset, width;
  std::vector<Eigen::Matrix<double, 6, 6>> inv;  // the top-left width x width is used
  int size = 0;

  void clear();  // no blocks (the storage is kept)
  void add(int width, const Eigen::Matrix<double, 6, 6>& inverse);
  Eigen::VectorXd times(const Eigen::VectorXd& f) const;
  void times(const Eigen::VectorXd& f, Eigen::VectorXd& x) const;  // x = M^-1 f (x not f)
};

// Block-diagonal mass matrix in the velocity layout (world frame, present pose).
struct MassMatrix {
  VelocityLayout layout;
  std::vector<double> mass;
  std::vector<char> linker;                // 1: the body has omega columns
  std::vector<Mat3> inertia, inv_inertia;  // linkers; identity for spheres (unused)

  MassMatrix() = default;
  explicit MassMatrix(const std::vector<CompliantBody>& bodies);
  void assign(const std::vector<CompliantBody>& bodies);  // as the constructor, reusing the storage
  Eigen::VectorXd times(const Eigen::VectorXd& nu) const;           // M nu
  Eigen::VectorXd inverse_times(const Eigen::VectorXd& f) const;    // M^-1 f
  Eigen::MatrixXd inverse_times(const Eigen::MatrixXd& f) const;    // M^-1 F (column by column)
  Eigen::MatrixXd dense() const;
  InverseMassBlocks inverse_blocks() const;  // 1/m (spheres), diag(1/m, I^-1) (linkers)
};

// S = G M^-1 G^T factorized once, solved for any right-hand side.
// S is the sum over bodies i of G_i M_i^-1 G_i^T (G_i: G's columns of body i),
// each added on the rows with a nonzero in those columns only; it is exactly
// symmetric (each product G_a M_i^-1 G_c^T is added to both (a, c) and (c, a)).
// S is symmetric positive semi-definite. A Cholesky factorization (LDL^T:
// sparse with its nearly dependent rows pivoted last, core/sparse_ldlt.hpp,
// from kSparseFromRows rows on; below that, or where the sparse one finds S
// rank deficient and any_solution is not given, dense with diagonal
// pivoting on the Schur complement, core/pivoted_ldlt.hpp) serves when its
// pivots all stay above kRankThreshold x the largest (full rank: the
// solution is unique and the same); otherwise, and always when
// rank_revealing (internal_dof's rank decision), the complete orthogonal
// decomposition gives the minimum-norm solution, unless any_solution lets
// the factorization serve cut short. Measured: the LDL^T path cuts an articulated Scenario 1 run's
// wall time by about a third (docs/ARTICULATED.md, "Cost").
class MultiplierSolve {
 public:
  MultiplierSolve() = default;
  MultiplierSolve(const Eigen::MatrixXd& g, const MassMatrix& m, bool rank_revealing = false);
  MultiplierSolve(const Eigen::MatrixXd& g, const InverseMassBlocks& minv, bool rank_revealing = false);
  struct Options {
    bool rank_revealing = false;  // always the complete orthogonal decomposition (internal_dof)
    // false: minv_gt() is not kept (empty), which spares zeroing and
    // filling a columns x rows matrix a caller does not read.
    bool keep_minv_gt = true;
    // G's body blocks row by row (hosted_joint_rows'), so that the assembly
    // need not read G to find them.
    const RowBlocks* blocks = nullptr;
    // Any solution, not the minimum-norm one, where S is rank deficient:
    // the pivoted LDL^T cut short (the dropped rows' multipliers zero)
    // instead of the complete orthogonal decomposition. For a right-hand
    // side in the range of S every solution gives the same G^T lambda
    // (S d = 0 implies G^T d = 0), which is all the constraint loads use;
    // off it (the integrator's drift on redundant rows) the two differ at
    // the order of that drift.
    bool any_solution = false;
    // S is factored sparse from this many rows on (kSparseFromRows; tests
    // and benchmarks set 0 or a large value to compare the two).
    int sparse_from_rows = kSparseFromRows;
  };
  // Factors S for new G and M^-1 in this object's storage (no allocation
  // when the sizes are those of the last call: the right-hand side's case).
  void compute(const Eigen::MatrixXd& g, const InverseMassBlocks& minv, const Options& options);
  // The same from G stored by row blocks (options.blocks and keep_minv_gt
  // are not read: the blocks are G's own, and M^-1 G^T is not kept).
  void compute(const BlockRows& g, const InverseMassBlocks& minv, const Options& options);
  Eigen::VectorXd solve(const Eigen::VectorXd& rhs) const;  // minimum-norm lambda of S lambda = rhs
  void solve_in_place(Eigen::VectorXd& x) const;  // x <- solve(x)
  int rank() const {
    return rows_ == 0 ? 0 : sparse_ ? sparse_ldlt_.rank() : full_ || cut_short_ ? ldlt_.rank() : int(cod_.rank());
  }
  bool sparse() const { return sparse_; }  // the sparse factors serve (full rank or cut short)
  const Eigen::MatrixXd& minv_gt() const { return minv_gt_; }  // M^-1 G^T (empty unless kept)
  Eigen::MatrixXd s() const;  // S = G M^-1 G^T (a copy: the solve keeps S~)
  // Each row's squared sine to the span of all the others (1 / (S~^-1)_ii),
  // rows from `first` on; empty when rank deficient (the LDL^T did not
  // serve). O(rows^2 (rows - first)): for slice ends and rare decisions, not
  // for every right-hand side.
  Eigen::VectorXd row_sines2(int first = 0) const;

 private:
  void assemble(const Eigen::MatrixXd& g, const InverseMassBlocks& minv, const RowBlocks* blocks);  // minv_gt_, s_
  void assemble(const BlockRows& g, const InverseMassBlocks& minv);                                // s_
  void start(int rows, bool keep_minv_gt, const Options& options);  // a compute's sizes and flags
  // touched_ and start_ (and touched_slot_ from blocks) for `blocks`, or
  // read from G's columns when null; then S cleared on its pattern or
  // wholly (a new pattern analysed).
  void find_touched(const Eigen::MatrixXd* g, const InverseMassBlocks& minv, const RowBlocks* blocks, int cols);
  void factor(const Options& options);
  void solve_factors(Eigen::VectorXd& x) const;  // x <- S~^-1 x by the LDL^T factors that serve

  int rows_ = 0;
  bool full_ = false;       // the LDL^T factors serve, full rank
  bool cut_short_ = false;  // any_solution: they serve cut short (rank deficient)
  bool sparse_ = false;     // the factors that serve are sparse_ldlt_'s, not ldlt_'s
  bool plan_sparse_ = false;  // this compute tries the sparse factors first
  // s_ is zero outside sparse_ldlt_'s analysed pattern, which is that of
  // the rows touching each block as pattern_start_ / pattern_rows_ list them
  // (start_ / touched_ of the call that analysed it).
  bool s_is_pattern_ = false;
  std::vector<int> pattern_start_, pattern_rows_;
  bool keep_minv_gt_ = true;
  // Assembly scratch: touched_[start_[i], start_[i + 1]) the rows that touch
  // block i; block_at_ a first column's block; fill_ the next free slot.
  std::vector<int> touched_, start_, block_at_, fill_;
  std::vector<int> touched_slot_;  // with blocks: each touched row's slot k (blocks[row][k] is the block)
  Eigen::Matrix<double, 6, Eigen::Dynamic> agt_;  // assembly scratch: M_i^-1 g_r^T of those rows
  Eigen::VectorXd scale_;  // D^-1/2: the factors are of S~ = D^-1/2 S D^-1/2
  Eigen::MatrixXd minv_gt_, s_;  // s_: S while assembled, then S~ (equilibrated)
  PivotedLdlt ldlt_;
  SparseLdlt sparse_ldlt_;
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod_;
};

// Generalized applied force: (F_i) per sphere, (F_i, tau_i - omega_i x I_i omega_i) per linker.
Eigen::VectorXd generalized_force(const std::vector<CompliantBody>& bodies, const MassMatrix& m,
                                  const std::vector<Vec3>& force, const std::vector<Vec3>& torque);
void generalized_force(const std::vector<CompliantBody>& bodies, const MassMatrix& m, const std::vector<Vec3>& force,
                       const std::vector<Vec3>& torque, Eigen::VectorXd& f);  // into f

// The constraint loads of the joints at the present pose and velocities
// (added to force and torque: torque about each body's centre, world frame),
// given the applied force and torque on every body: after the addition, the
// accelerations M^-1 (f + G^T lambda) keep C'' = 0.
//
// Solved on the cluster's rigid sub-assemblies (docs/ARTICULATED.md,
// "Spheres ride on their hosts"): a sphere is a point mass, so its first ball
// joint fixes it in that linker's frame (its host), and the pair moves as one
// rigid body. The multiplier problem is written for the linkers, each
// carrying its hosted spheres (a dense 6 x 6 mass block about the linker's
// centre), and the spheres that have no joint; the host joints' rows drop
// out (3 rows per bonded sphere: half the rows of a chain). With nu = T nu_r
// and nu' = T nu_r' + c (a hosted sphere's acceleration is its host's at the joint point,
// a_S = a_L + alpha_L x r + omega_L x (omega_L x r), r = R(q_L) a, exactly
// what the host row's C'' = 0 says), M_r = T^T M T, f_r = T^T (f - M c),
// G_r = G T and the bias b + G c: the accelerations are those of the full
// problem (unique whenever the rows are consistent) at any state, on the
// joints or off them, to rounding.
void add_constraint_loads(const std::vector<CompliantBody>& bodies, const JointSet& joints,
                          std::vector<Vec3>& force, std::vector<Vec3>& torque);

// The reduced problem of add_constraint_loads (and of the velocity
// projection, core/joint_projection.hpp): its columns, M_r^-1 = (T^T M T)^-1
// block by block (a linker carrying its hosted spheres: a dense 6 x 6 block
// about the linker's centre, inverted through its Schur complement), and the
// maps between the full velocity layout and its columns.
struct HostedProblem {
  HostedColumns columns;
  InverseMassBlocks minv;

  HostedProblem() = default;
  HostedProblem(const std::vector<CompliantBody>& bodies, const JointSet& joints, const MassMatrix& m);
  void assign(const std::vector<CompliantBody>& bodies, const JointSet& joints, const MassMatrix& m);  // reusing the storage
  // T^T x: a generalized force x (full layout) on the reduced columns (a
  // hosted sphere's force moves to its host with its moment about the host's centre).
  Eigen::VectorXd gather(const MassMatrix& m, const Eigen::VectorXd& x) const;
  void gather(const MassMatrix& m, const Eigen::VectorXd& x, Eigen::VectorXd& y) const;  // y = T^T x (y not x)
  // T y: full velocity coordinates from reduced ones (v_S = v_H + omega_H x arm).
  Eigen::VectorXd scatter(const MassMatrix& m, const Eigen::VectorXd& y) const;
  void scatter(const MassMatrix& m, const Eigen::VectorXd& y, Eigen::VectorXd& x) const;  // x = T y (x not y)

 private:
  std::vector<Eigen::Matrix<double, 6, 6>> mass_;  // assign's scratch: M_r block by block
};

// add_constraint_loads with its storage kept from one call to the next: an
// articulated cluster's right-hand side is evaluated ~10 times per slice on
// bodies and joints of unchanged sizes, so after the first call nothing is
// allocated (the allocator's share of a Scenario 1 run was ~15 %;
// docs/ARTICULATED.md, "Cost"). The same loads, to the last bit.
class ConstraintLoads {
 public:
  void add(const std::vector<CompliantBody>& bodies, const JointSet& joints, std::vector<Vec3>& force,
           std::vector<Vec3>& torque);

 private:
  MassMatrix m_;
  HostedProblem p_;
  MultiplierSolve solve_;
  BlockRows g_;
  Eigen::VectorXd f_, x_, fr_, y_, bias_, lambda_, acc_;
};

// Every load on the bodies of a cluster at its present state: the compliant
// force field (core/compliant.hpp, dampers included) plus the constraint
// loads of `joints`. The one definition of the accelerations, for the
// integrator's right-hand side and the slice-error check (slice_end): with
// no joints it is compliant_loads.
void cluster_loads(const CompliantCluster& cluster, const JointSet& joints, std::vector<Vec3>& force,
                   std::vector<Vec3>& torque);

// Internal degrees of freedom: velocity coordinates (3 per sphere, 6 per
// linker) - rank(G) - 6 at the present pose. 0: the cluster can only move
// rigidly (carry it as one rigid body). A single sphere gives -3 (no rotation).
int internal_dof(const std::vector<CompliantBody>& bodies, const JointSet& joints);

// Held angles and dihedrals are held only while their rows stay clear of
// the span of the others: a row within kHoldSine2 (squared sine, an angle of
// 0.01 rad in the M^-1 metric) of it is nearly implied by them, and held it
// would take multipliers ~ 1 / sine^2 (the integrator's steps collapse) for
// a value the others already hold to first order. A released row is held
// again (at the value it has then) once it is kReadmitSine2 clear: the gap
// between the two keeps a row near the limit from going back and forth.
// docs/ARTICULATED.md, "Released rows".
constexpr double kHoldSine2 = 1e-4;
constexpr double kReadmitSine2 = 1e-3;

// The squared sine of the angle between the single held row of `row` and
// the span of `base`'s rows, in the M^-1 metric, at the present pose (0:
// implied by them; 1: orthogonal to them).
double sine2_to_span(const std::vector<CompliantBody>& bodies, const JointSet& base, const JointSet& row);

// Greedy: the held rows of `candidates` in order (angles, then dihedrals),
// each taken when its sine^2 to the span of `base` and the rows taken
// before it is at least min_sine2. Returns the taken rows; `candidates`
// keeps the others.
JointSet take_independent_rows(const std::vector<CompliantBody>& bodies, const JointSet& base,
                               JointSet& candidates, double min_sine2);

// Keeps the ball joints and, in order, the held rows that are at least
// min_sine2 clear of the span of the rows kept before them; removes the
// others. A ring closed under the filters holds more angles and dihedrals
// than its axes have relative freedoms (docs/ARTICULATED.md, "Multipliers,
// rank, degrees of freedom"): the surplus rows are implied by the others to
// first order, and kept they leave the position projection a residual in
// G's left null space that no Gauss-Newton step removes (seen: a closed
// Scenario 3 square whose joint drifted 1e-4 apart by t = 128). Returns the
// number removed; `removed`, when given, receives them.
int drop_redundant_held_rows(const std::vector<CompliantBody>& bodies, JointSet& joints,
                             JointSet* removed = nullptr, double min_sine2 = kHoldSine2);

}  // namespace ringsim
