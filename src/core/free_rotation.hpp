#pragma once
// Exact torque-free rotation of a rigid body with any principal moments
// (asymmetric, symmetric or spherical top).
//
// Angular momentum: the classical solution of Euler's equations in Jacobi
// elliptic functions (Landau & Lifshitz, Mechanics, section 37). In a
// "working" principal frame X = (x, y, z), with I_y the middle moment and z the
// axis that L circles (z = largest-moment axis if L^2 > 2 E I_mid, else the
// smallest):
//   L_x = a cn(u|m),  L_y = b sn(u|m),  L_z = c dn(u|m),  u = lambda t + u0.
// Orientation: the factorisation of van Zon & Schofield, J. Comput. Phys. 225,
// 145 (2007): R(t) = A Rz(psi(t)) G(l(t)) P^T, where G(l) is an explicit
// rotation taking the unit body angular momentum l = L_body/|L| to the pole e3,
// Rz(psi) a rotation about L by the precession angle psi (an incomplete
// elliptic integral of the third kind), and A, P constant. See
// free_rotation.cpp for the formulas and references.
//
// Invariants and units: moments in mass*length^2, times in the caller's unit,
// angular velocity in rad per time unit. Everything that does not depend on
// dt is computed in the constructor; the evaluation methods are const, free of
// allocation and exceptions, and reduce the elliptic argument and the
// precession angle by their periods with constants kept beyond double
// precision, so their accuracy does not degrade with |dt|: ~1e-14 after 1e4
// rotation periods against a 40-digit evaluation (tests/test_free_rotation.cpp).
// Evaluation: for m up to ~0.985 (nome q <= 0.25) by theta-function series
// whose coefficients the constructor precomputes (per call: two sincos, one
// atan, at most 6 recurrence steps); closer to the separatrix by the reference
// path (AGM for sn, cn, dn; Carlson R_J for the precession angle), which
// orientation_reference() also exposes. The two agree to ~1e-14 over 1e4
// periods (tests/test_free_rotation.cpp).
// Cost (development machine, bench/bench_geometry): ~0.11 us per orientation(),
// ~0.05 us per omega_body() on the series path; ~0.3-0.4 us and ~0.12-0.19 us
// on the reference path; ~2 us per construction (long double).

#include <array>

#include "core/vec.hpp"

namespace ringsim {

// Torque-free motion of a rigid body: orientation R(t) (world <- body) and
// angular velocity, exact, from the state at a reference time (dt = t - t0).
class FreeRotation {
 public:
  FreeRotation() = default;  // at rest, identity orientation, unit moments
  // principal_moments: body-frame principal moments (any order, all > 0; the body
  // frame is the one R0 maps to world). R0: orientation at t0 (proper rotation).
  // L: world angular momentum (conserved).
  FreeRotation(const Vec3& principal_moments, const Mat3& R0, const Vec3& L_world);

  Mat3 orientation(double dt) const;     // world <- body at t0 + dt
  Vec3 omega_body(double dt) const;      // body-frame angular velocity
  // The same by the reference path (AGM and Carlson R_J at every call), which
  // the series path falls back to near the separatrix; for tests.
  Mat3 orientation_reference(double dt) const;
  Vec3 omega_body_reference(double dt) const;
  // True if orientation() and omega_body() use the theta series.
  bool uses_series() const { return series_; }
  Vec3 omega_world(double dt) const;     // = orientation(dt) * omega_body(dt)
  Vec3 angular_momentum_body(double dt) const;  // L in the body frame
  const Vec3& angular_momentum() const { return L_world_; }  // world, constant
  double energy() const { return energy_; }  // rotational kinetic energy, constant
  // An upper bound on |omega(t)| valid for every t: the exact maximum over the
  // orbit (|omega|^2 is linear in sn^2), times (1 + 1e-12).
  double max_rate() const { return max_rate_; }

  const Vec3& principal_moments() const { return moments_; }
  const Mat3& initial_orientation() const { return R0_; }

  // Which closed form is used (for tests and diagnostics).
  enum class Mode {
    Rest,        // L = 0
    Uniform,     // omega parallel to L: spherical top, L in the degenerate plane
                 // of a symmetric top (exactly), or L along a principal axis
                 // (to 3e-15 |L|: below the rounding of R0^T L, which would
                 // otherwise grow like exp(lambda t) about the middle axis)
    Elliptic,    // general case, 0 <= m < 1
    Separatrix,  // L^2 = 2 E I_mid exactly (m = 1): hyperbolic functions
  };
  Mode mode() const { return mode_; }
  double parameter_m() const { return m_; }    // elliptic parameter m = k^2
  double parameter_mc() const { return mc_; }  // complementary 1 - m, computed directly
  // Period of the body-frame motion of L (4K/lambda); 0 at rest, uniform or
  // separatrix motion (no period).
  double body_period() const;

 private:
  struct Jacobi {
    double sn, cn, dn;
  };
  // The elliptic argument at t0 + dt reduced by its half period:
  // u = lambda dt + u0 = 2 j K + v, |v| <= K (j = 0 on the separatrix).
  double reduced_argument(double dt, double& j) const;
  // sn, cn, dn at v, |v| <= K (any v on the separatrix).
  Jacobi jacobi(double v) const;
  Vec3 momentum_xp(double j, const Jacobi& f) const;  // L in X' at u = 2jK + v
  // sn, cn, dn at v, |v| <= K, by theta quotients; with jp != nullptr also the
  // periodic part of J: J(v) = j_slope v + *jp (series_ only).
  Jacobi jacobi_series(double v, double* jp) const;
  void init_series(long double m, long double n, long double K, long double Jc);
  Vec3 angular_momentum_body_impl(double dt, bool series) const;
  Mat3 orientation_impl(double dt, bool series) const;
  // A Rz(psi) G(l) P^T without forming P^T or the intermediate products.
  Mat3 compose(double psi, const Vec3& l) const;
  // sn, cn, dn for 0 <= w <= K/2 by the AGM (Abramowitz & Stegun 16.4).
  Jacobi jacobi_agm(double w) const;
  // J(v) = int_0^v sn^2 / (1 - n sn^2) du for |v| <= K (m < 1), or any v (m = 1).
  double integral_j(double v, const Jacobi& f) const;
  Mat3 body_rotation(const Vec3& l) const;  // G(l) in the pole frame X'

  Mode mode_ = Mode::Rest;
  Vec3 moments_ = Vec3::Ones();
  Mat3 R0_ = Mat3::Identity();
  Vec3 L_world_ = Vec3::Zero();
  double energy_ = 0.0;
  double max_rate_ = 0.0;

  // Rest / Uniform: omega_body constant, R(t) = Rot(axis, rate t) R0.
  Vec3 omega_body0_ = Vec3::Zero();
  Vec3 axis_world_ = Vec3::UnitZ();
  double rate_ = 0.0;

  // Elliptic / Separatrix.
  Mat3 A_ = Mat3::Identity();  // world <- pole frame at t0: R0 P G(l0)^T
  Mat3 P_ = Mat3::Identity();  // body <- X' (signed permutation, det +1)
  bool pole_x_ = false;        // X' = (y, z, x) if true, else X' = (x, y, z)
  double amp_a_ = 0, amp_b_ = 0, amp_c_ = 0;  // L_x = a cn, L_y = b sn, L_z = c dn
  double inv_L_ = 0;           // 1 / |L|
  double u0_ = 0;
  double m_ = 0, mc_ = 1, kc_ = 1;  // m, m' = 1 - m, k' = sqrt(m')
  double K_ = 0;               // complete elliptic integral K(m)
  double n_ = 0;               // characteristic (<= 0): 1 / (1 - l_pole^2) ~ 1 / (1 - n sn^2)
  // psi = rate_lin t + coef_j (J(u) - J(u0)), J(u + 2K) = J(u) + 2 J(K).
  double rate_lin_ = 0, coef_j_ = 0, J0_ = 0;
  // The secular parts as unevaluated sums hi + lo (constants computed in long
  // double), so that the phase does not lose accuracy at large |dt|:
  // u = lambda dt + u0 is reduced by multiples of 2K, and psi advances by
  // psi_half per 2K of u, reduced modulo 2 pi.
  double lam_hi_ = 0, lam_lo_ = 0;
  double two_k_hi_ = 0, two_k_lo_ = 0;
  double t_half_hi_ = 0, t_half_lo_ = 0;  // 2K / lambda
  double psi_half_hi_ = 0, psi_half_lo_ = 0;
  // AGM tables: phi_N = scale * w; phi_{i-1} = (phi_i + asin(ratio[i] sin phi_i)) / 2.
  int agm_n_ = 0;
  double agm_scale_ = 1;
  std::array<double, 40> agm_ratio_{};

  // Theta series (series_ true; see free_rotation.cpp). zeta = zeta_scale v;
  // term k = 1..ser_n_ multiplies cos 2k zeta, sin 2k zeta or cos, sin of
  // (2k+1) zeta; the k = 0 terms are 1, sin zeta and cos zeta.
  struct SeriesTerm {
    double th3, th4;  // 2 q^(k^2) and 2 (-1)^k q^(k^2): theta_3, theta_4
    double t1, t2;    // (-1)^k q^(k(k+1)) and q^(k(k+1)): theta_1, theta_2 / (2 q^(1/4))
    double jr, ji;    // Re and Im / D of theta_4(zeta + i beta), see J
  };
  static constexpr int kSeriesTerms = 8;
  bool series_ = false;
  int ser_n_ = 0;
  double zeta_scale_ = 0;            // pi / (2K)
  double c_sn_ = 0, c_cn_ = 0, c_dn_ = 0;  // theta-constant prefactors
  double j_slope_ = 0, j_d_ = 0;     // J(K)/K; D of the periodic part
  double J0_series_ = 0;             // J(u0) by the series
  std::array<SeriesTerm, kSeriesTerms + 1> ser_{};  // index k; [0] unused
  // Body <- X' as a signed permutation: (P x)[r] = perm_sign[r] x[perm[r]].
  std::array<int, 3> perm_{{0, 1, 2}};
  std::array<double, 3> perm_sign_{{1, 1, 1}};
};

// Carlson's symmetric elliptic integrals [Carlson, Numer. Algorithms 10, 13
// (1995); DLMF 19.36], used by FreeRotation and exposed for its tests.
namespace elliptic {
double carlson_rf(double x, double y, double z);              // x, y, z >= 0, at most one 0
double carlson_rj(double x, double y, double z, double p);    // as R_F, and p > 0
}  // namespace elliptic

}  // namespace ringsim
