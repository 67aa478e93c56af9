#include "core/free_rotation.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "core/fast_trig.hpp"

// Formulas and references
// -----------------------
// [LL]  Landau & Lifshitz, Mechanics, 3rd ed., section 37 (Euler's equations
//       solved in Jacobi elliptic functions).
// [vZS] R. van Zon and J. Schofield, "Numerical implementation of the exact
//       dynamics of free rigid bodies", J. Comput. Phys. 225, 145 (2007):
//       orientation = (fixed rotation taking L to z) x (rotation about z by
//       the precession angle psi) x (body rotation fixed by L_body(t)), with
//       psi an elliptic integral of the third kind.
// [AS]  Abramowitz & Stegun, Handbook, 16.4 (AGM evaluation of sn, cn, dn),
//       16.20 (quarter-period shift), 17.7 (third kind).
// [C95] B. C. Carlson, "Numerical computation of real or complex elliptic
//       integrals", Numer. Algorithms 10, 13 (1995); DLMF 19.36 (duplication
//       algorithms for R_F and R_J), DLMF 19.25.5 and 19.25.14 (Legendre
//       integrals in Carlson form).
//
// Solution of Euler's equations [LL 37], written for L instead of Omega and
// for signed amplitudes. Working principal frame X = (x, y, z), I_y the middle
// moment, z the axis that L circles. With d_xz = 1/I_x - 1/I_z etc. (all of one
// sign) and rho = d_yz / d_xz in [0, 1]:
//   L_x = a cn(u|m),  L_y = b sn(u|m),  L_z = c dn(u|m),  u = lambda t + u0,
//   a^2 = L_x^2 + rho L_y^2,   c^2 = L_z^2 + (1 - rho) L_y^2   (a^2 + c^2 = L^2),
//   lambda^2 = c^2 d_xz d_yz,  b = c a d_xz / lambda,
//   m  = a^2 d_xy / (c^2 d_yz),
//   m' = 1 - m = (L_z^2 d_yz - L_x^2 d_xy) / (c^2 d_yz).
// Substituting into L' = L x Omega checks all three equations. Every quantity
// above is a sum of terms of one sign except m', whose sign decides the regime
// (m' >= 0 for the chosen z); computing m' directly, not as 1 - m, keeps its
// relative accuracy near the separatrix m -> 1.
//
// Orientation [vZS]. Let l = L_body / |L| in a frame X' = (i, j, k), a cyclic
// relabelling of X with the "pole" k. G(l) is the rotation with rows
//   g1 = (l_i l_k, l_j l_k, -p^2) / p,  g2 = (-l_j, l_i, 0) / p,  g3 = l,
// p^2 = l_i^2 + l_j^2, so G l = e3. Any rotation taking l to e3 is Rz(psi) G(l),
// so R(t) = A Rz(psi(t)) G(l(t)) P^T with A = R0 P G(l(0))^T (psi(0) = 0). The
// e3 component of the angular velocity in the L frame is Omega.L/|L| = 2E/|L|;
// subtracting the part due to G' G^T gives
//   psi' = |L| (l_i^2/I_i + l_j^2/I_j) / (l_i^2 + l_j^2)
//        = |L|/I_k + (2E/|L| - |L|/I_k) / (1 - l_k^2)          ([LL] eq. 37.13).
// The pole is chosen as x or z, whichever has the smaller amplitude (a or c);
// since a^2 + c^2 = L^2, then |l_k| <= 1/sqrt 2 for all t and G is regular:
//   pole x: 1 - l_x^2 = (c^2/L^2)(1 - n sn^2),  n = -a^2/c^2     in [-1, 0];
//   pole z: 1 - l_z^2 = (a^2/L^2)(1 - n sn^2),  n = -m c^2/a^2   in [-m, 0].
// With 1/(1 - n sn^2) = 1 + n sn^2/(1 - n sn^2) and dt = du / lambda:
//   psi(t) = (|L|/I_k + kappa) t + (kappa n / lambda) (J(u) - J(u0)),
//   kappa = (2E/|L| - |L|/I_k) L^2 / (c^2 or a^2),
//   J(u)  = int_0^u sn^2 / (1 - n sn^2) du' = (Pi(n; am u|m) - u) / n
//         = (sn^3 / 3) R_J(cn^2, dn^2, 1, 1 - n sn^2)   for |u| <= K [DLMF 19.25.14],
//   J(u + 2K) = J(u) + 2 J(K)  (the integrand has period 2K).
// Boost's ellint_3(k, n, phi) uses the same sign of n (1 - n sin^2); the test
// cross-checks J against it. J is evaluated from sn, cn, dn (not from the
// amplitude phi), with cn, dn relatively accurate near u = K thanks to the
// quarter-period shift [AS 16.20] -- this keeps the accuracy near the
// separatrix, where dn(K) = k' is tiny and phi -> pi/2 is ill-conditioned.
//
// Separatrix (m = 1 exactly): sn = tanh u, cn = dn = sech u and
//   J(u) = (u - atan(sqrt(-n) tanh u) / sqrt(-n)) / (1 - n),
// from 1/(1 - n tanh^2) = (1/(1-n)) (1 - n sech^2 / (1 - n tanh^2)).

//
// Theta series (the fast path, 0 <= m <~ 0.985). With the nome
// q = exp(-pi K'/K) and zeta = pi v / (2K) [DLMF 22.2.1], the theta functions
// [DLMF 20.2.1-4] give sn, cn, dn as quotients [DLMF 22.2.4-6]:
//   sn = (theta3(0)/theta2(0)) theta1(zeta)/theta4(zeta),
//   cn = (theta4(0)/theta2(0)) theta2(zeta)/theta4(zeta),
//   dn = (theta4(0)/theta3(0)) theta3(zeta)/theta4(zeta),
// with terms q^(k^2) (theta3, theta4) and q^(k(k+1)) (theta1, theta2 after the
// common factor 2 q^(1/4) is divided out): for q <= 0.25 (m <~ 0.985) the
// terms fall below 2^-60 by k = 6. The harmonics cos, sin of (2k) zeta and (2k+1) zeta come
// from one sincos by complex multiplication with e^(2 i zeta), whose error grows
// only linearly in k while the coefficients fall like q^(k^2).
// The precession integral: Jacobi's third-kind integral [Whittaker & Watson,
// Modern Analysis, sec. 22.74] is, differentiated,
//   m sn a cn a dn a sn^2 u / (1 - m sn^2 a sn^2 u) = Z(a) + (Z(u-a) - Z(u+a))/2,
// Z = (pi/2K) theta4'/theta4 the Jacobi zeta function. Our n = m sn^2 a <= 0
// needs an imaginary a = i b, 0 <= b < K'; by Jacobi's imaginary
// transformation [DLMF 22.6(iv)] sn^2(ib|m) = -sc^2(b|m'), so sc^2(b|m') = -n/m,
// |m sn a cn a dn a| = D = sqrt(-n (m - n) (1 - n)), and [DLMF 19.25.5 with the
// homogeneity of R_F]
//   b = sqrt(-n) R_F(m, m(1-n), m-n),   x = K' - b = R_F(-n, m-n, 1-n).
// Integrating, J(v) = (J(K)/K) v + P(v) with the odd, 2K-periodic
//   P(v) = -arg theta4(zeta + i beta) / D,   beta = pi b / (2K),
//   theta4(zeta + i beta) = 1 + sum_k 2 (-1)^k q^(k^2) [cosh(2k beta) cos 2k zeta
//                                                       - i sinh(2k beta) sin 2k zeta],
// where q^(k^2) e^(+-2k beta) = exp(-(pi/K) k ((k -+ 1) K' +- b)): also at most a
// few terms (the first is exp(-pi x/K) <= exp(-pi^2/4K) since x >= pi/4).
// The real part stays above 1 - sum |coefficients| > 0 (checked in the
// constructor), so arg = atan(Im/Re) with no branch. As n -> 0, b, the
// sinh terms and D vanish together; the constructor stores Im/D, whose limit
// at n = 0 is the Fourier series of -Z(u)/m [DLMF 20.5.13] (J = (u - E(u))/m).
// The slope J(K)/K comes from the same R_J value as the reference path, so the
// secular part of psi is shared; the series changes only the bounded
// periodic part. Near the separatrix (q > 0.25) the reference path is used:
// theta4 approaches zero there (theta4(0)^2 = k' 2K/pi) and the terms of the
// precession series approach 1.
//
// Long times. The phase grows like t; its rounding would grow like 1e-16 t.
// The constants that multiply t or the period count (lambda, 2K, and the
// advance of psi per 2K of u) are computed in long double and kept as
// unevaluated sums hi + lo; the evaluation splits lambda_hi * dt exactly with
// an FMA (Dekker/Ogita-Rump-Oishi two-product), subtracts the whole periods,
// and reduces the secular part of psi modulo 2 pi the same way. Everything
// that is then evaluated in double has bounded arguments.

namespace ringsim {

namespace elliptic {
namespace {

// Truncation settings for the duplication algorithms, by precision: the
// series after M duplications has error ~ (deviation)^6 [C95], so iterate
// until 4^-M Q < |A| with Q = (relative tolerance r)^(-1/6) max deviation.
template <class T>
struct CarlsonTol;
template <>
struct CarlsonTol<double> {
  static constexpr double rf = 386.0;   // (3 r)^(-1/6), r = 1e-16
  static constexpr double rj = 584.0;   // (r / 4)^(-1/6), r = 1e-16
  static constexpr double rc_series = 2e-3;  // |e|^6 / 13 < 1e-17
};
template <>
struct CarlsonTol<long double> {
  static constexpr long double rf = 1793.0L;  // r = 1e-20
  static constexpr long double rj = 2715.0L;
  static constexpr long double rc_series = 1e-4L;  // |e|^6 / 13 < 1e-25
};

// R_C(1, 1 + e) for e > -1: atan(sqrt e)/sqrt e, or atanh for e < 0 [DLMF 19.2.18-19].
template <class T>
T rc1(T e) {
  if (std::abs(e) < CarlsonTol<T>::rc_series) {
    return 1 + e * (T(-1) / 3 + e * (T(1) / 5 + e * (T(-1) / 7 + e * (T(1) / 9 + e * (T(-1) / 11)))));
  }
  if (e > 0) {
    const T s = std::sqrt(e);
    return std::atan(s) / s;
  }
  const T s = std::sqrt(-e);
  return std::atanh(s) / s;
}

// Carlson's R_F(x, y, z) [C95 algorithm for R_F; DLMF 19.36.1].
template <class T>
T rf(T x, T y, T z) {
  const T A0 = (x + y + z) / 3;
  const T Q = std::max({std::abs(A0 - x), std::abs(A0 - y), std::abs(A0 - z)}) * CarlsonTol<T>::rf;
  T A = A0, fac = 1;
  const T x0 = x, y0 = y;
  while (Q * fac >= std::abs(A)) {
    const T sx = std::sqrt(x), sy = std::sqrt(y), sz = std::sqrt(z);
    const T lam = sx * sy + sy * sz + sz * sx;
    x = (x + lam) / 4;
    y = (y + lam) / 4;
    z = (z + lam) / 4;
    A = (A + lam) / 4;
    fac /= 4;
  }
  const T X = (A0 - x0) * fac / A, Y = (A0 - y0) * fac / A, Z = -(X + Y);
  const T E2 = X * Y - Z * Z, E3 = X * Y * Z;
  return (1 - E2 / 10 + E3 / 14 + E2 * E2 / 24 - 3 * E2 * E3 / 44) / std::sqrt(A);
}

// Carlson's R_J(x, y, z, p), p > 0 [C95 eq. (2.18); DLMF 19.36.2-3]:
// R_J = 4^-M A_M^-3/2 (1 - 3E2/14 + E3/6 + 9E2^2/88 - 3E4/22 - 9E2E3/52 + 3E5/26)
//     + 6 sum_{m<M} 4^-m R_C(1, 1 + e_m) / d_m,
// d_m = (sqrt p + sqrt x)(sqrt p + sqrt y)(sqrt p + sqrt z), e_m = 4^-3m delta / d_m^2.
template <class T>
T rj(T x, T y, T z, T p) {
  const T A0 = (x + y + z + 2 * p) / 5;
  const T delta = (p - x) * (p - y) * (p - z);
  const T Q = std::max({std::abs(A0 - x), std::abs(A0 - y), std::abs(A0 - z), std::abs(A0 - p)}) *
              CarlsonTol<T>::rj;
  const T x0 = x, y0 = y, z0 = z;
  T A = A0, fac = 1, sum = 0;
  while (Q * fac >= std::abs(A)) {
    const T sx = std::sqrt(x), sy = std::sqrt(y), sz = std::sqrt(z), sp = std::sqrt(p);
    const T lam = sx * sy + sy * sz + sz * sx;
    const T d = (sp + sx) * (sp + sy) * (sp + sz);
    sum += fac * rc1(delta * (fac * fac * fac) / (d * d)) / d;
    x = (x + lam) / 4;
    y = (y + lam) / 4;
    z = (z + lam) / 4;
    p = (p + lam) / 4;
    A = (A + lam) / 4;
    fac /= 4;
  }
  const T X = (A0 - x0) * fac / A, Y = (A0 - y0) * fac / A, Z = (A0 - z0) * fac / A;
  const T P = -(X + Y + Z) / 2;
  const T XYZ = X * Y * Z, P2 = P * P;
  const T E2 = X * Y + X * Z + Y * Z - 3 * P2;
  const T E3 = XYZ + 2 * E2 * P + 4 * P2 * P;
  const T E4 = (2 * XYZ + E2 * P + 3 * P2 * P) * P;
  const T E5 = XYZ * P2;
  const T series = 1 - 3 * E2 / 14 + E3 / 6 + 9 * E2 * E2 / 88 - 3 * E4 / 22 - 9 * E2 * E3 / 52 + 3 * E5 / 26;
  return fac * series / (A * std::sqrt(A)) + 6 * sum;
}

}  // namespace

double carlson_rf(double x, double y, double z) { return rf(x, y, z); }
double carlson_rj(double x, double y, double z, double p) { return rj(x, y, z, p); }

}  // namespace elliptic

namespace {

using LD = long double;

// 2 pi as hi + lo.
constexpr double kTwoPiHi = 6.283185307179586232;
constexpr double kTwoPiLo = 2.4492935982947064e-16;

// std::nearbyint in the default rounding mode (ties to even) without the
// library call: for |x| < 2^51, x + 1.5 * 2^52 has no fraction bits left, so
// the sum is rounded to the nearest integer and subtracting the shift is exact.
double round_nearest(double x) {
  constexpr double kShift = 0x1.8p52;
  if (!(std::abs(x) < 0x1p51)) return std::nearbyint(x);
  return (x + kShift) - kShift;
}

// Whether the integer-valued j is odd (|j| < 2^53 converts exactly).
bool is_odd(double j) {
  if (!(std::abs(j) < 0x1p53)) return false;  // every double this large is even
  return (static_cast<long long>(j) & 1) != 0;
}

// 1/I_a - 1/I_b with no cancellation beyond that of I_b - I_a (exact for close moments).
LD inv_diff(LD Ia, LD Ib) { return (Ib - Ia) / (Ia * Ib); }

void split(LD x, double& hi, double& lo) {
  hi = static_cast<double>(x);
  lo = static_cast<double>(x - hi);
}

constexpr LD kPi = 3.141592653589793238462643383279502884L;

// The series path is used for nomes up to this value (m <= ~0.985): terms
// q^(k^2) fall below 2^-60 by k = 6, and theta4 >= theta4(0) = 1 - 2q + 2q^4 - ... > 0.5.
constexpr LD kNomeMax = 0.25L;
constexpr LD kSeriesTol = 8.7e-19L;  // 2^-60

// Arithmetic-geometric mean of a, b >= 0 [DLMF 19.8.1], to long double accuracy.
LD agm(LD a, LD b) {
  for (int i = 0; i < 64 && std::abs(a - b) > 1e-12L * a; ++i) {  // then (a+b)/2 is exact to ~1e-25
    const LD a_next = (a + b) / 2;
    b = std::sqrt(a * b);
    a = a_next;
  }
  return (a + b) / 2;
}

}  // namespace

FreeRotation::FreeRotation(const Vec3& principal_moments, const Mat3& R0, const Vec3& L_world)
    : moments_(principal_moments), R0_(R0), L_world_(L_world) {
  assert(principal_moments.minCoeff() > 0.0);
  const Vec3& I = principal_moments;
  const Vec3 Lb = R0.transpose() * L_world;  // from here on taken as exact
  energy_ = 0.5 * (Lb.array().square() / I.array()).sum();
  omega_body0_ = Lb.cwiseQuotient(I);
  const double L2 = Lb.squaredNorm();
  const double Lnorm = std::sqrt(L2);
  if (L2 == 0.0) {
    mode_ = Mode::Rest;
    return;
  }
  auto set_uniform = [&] {
    // omega parallel to L: rotation about L at the rate Omega.L/|L| = 2E/|L|.
    mode_ = Mode::Uniform;
    axis_world_ = L_world / L_world.norm();
    rate_ = 2.0 * energy_ / Lnorm;
    max_rate_ = omega_body0_.norm() * (1.0 + 1e-12);
  };

  // Principal axes sorted by moment: s[0] smallest, s[2] largest.
  std::array<int, 3> s = {0, 1, 2};
  std::sort(s.begin(), s.end(), [&](int p, int q) { return I[p] < I[q]; });
  if (I[s[0]] == I[s[2]]) {  // spherical top
    set_uniform();
    return;
  }
  // L within rounding of a principal axis: stationary rotation. The input
  // cannot state an exact principal-axis rotation through a rotated R0 (R0^T L
  // carries ~1e-16 |L| off-axis noise), and about the middle axis that noise
  // would otherwise grow like exp(lambda t).
  for (int k = 0; k < 3; ++k) {
    const double off_axis2 = Lb[(k + 1) % 3] * Lb[(k + 1) % 3] + Lb[(k + 2) % 3] * Lb[(k + 2) % 3];
    if (off_axis2 <= 1e-29 * L2) {  // off-axis part below ~3e-15 |L|
      set_uniform();
      return;
    }
  }

  // Regime [LL 37]: L circles the largest axis iff L^2 > 2 E I2, i.e.
  // L1^2 (1/I1 - 1/I2) < L3^2 (1/I2 - 1/I3) (each side free of cancellation).
  // Ties (the separatrix) go to the smallest axis; with a symmetric top
  // I2 = I3 this keeps the symmetry axis as z.
  const LD I1 = I[s[0]], I2 = I[s[1]], I3 = I[s[2]];
  // L in the body frame in long double: the constants below then belong to the
  // given (R0, L) to ~1e-19, not to a rounded R0^T L (whose 1e-16 error would
  // shift the frequencies and so the phase by ~1e-16 per radian).
  std::array<LD, 3> Lbl{};
  for (int i = 0; i < 3; ++i)
    Lbl[i] = LD(R0(0, i)) * L_world[0] + LD(R0(1, i)) * L_world[1] + LD(R0(2, i)) * L_world[2];
  const LD L1 = Lbl[s[0]], L3 = Lbl[s[2]];
  const bool circle_largest = L1 * L1 * inv_diff(I1, I2) < L3 * L3 * inv_diff(I2, I3);
  const int ix = circle_largest ? s[0] : s[2];
  const int iy = s[1];
  const int iz = circle_largest ? s[2] : s[0];
  Mat3 Px = Mat3::Zero();  // body <- X: columns e_ix, sigma e_iy, e_iz, det +1
  Px(ix, 0) = 1.0;
  Px(iy, 1) = 1.0;
  Px(iz, 2) = 1.0;
  if (Px.determinant() < 0) Px(iy, 1) = -1.0;
  const LD Lx = Lbl[ix], Ly = Px(iy, 1) * Lbl[iy], Lz = Lbl[iz];  // L in X
  const LD Ix = I[ix], Iy = I[iy], Iz = I[iz];

  const LD dxz = inv_diff(Ix, Iz), dyz = inv_diff(Iy, Iz), dxy = inv_diff(Ix, Iy);
  const LD rho = dyz / dxz, rho_c = dxy / dxz;
  const LD a2 = Lx * Lx + rho * Ly * Ly;
  const LD c2 = Lz * Lz + rho_c * Ly * Ly;
  // a = 0: L along z or in the degenerate y-z plane; c = 0: likewise for x-y.
  if (a2 == 0 || c2 == 0 || dyz == 0) {
    set_uniform();
    return;
  }
  const LD mc = std::max(LD(0), (Lz * Lz * dyz - Lx * Lx * dxy) / (c2 * dyz));
  const LD m = std::min(LD(1), a2 * dxy / (c2 * dyz));
  const LD lam = std::sqrt(c2 * dxz * dyz);
  const LD a = std::copysign(std::sqrt(a2), Lx);  // cn(u0) >= 0, so |u0| <= K
  const LD c = Lz < 0 ? -std::sqrt(c2) : std::sqrt(c2);
  const LD b = c * a * dxz / lam;
  mc_ = static_cast<double>(mc);
  m_ = static_cast<double>(m);
  kc_ = std::sqrt(mc_);
  amp_a_ = static_cast<double>(a);
  amp_b_ = static_cast<double>(b);
  amp_c_ = static_cast<double>(c);
  split(lam, lam_hi_, lam_lo_);
  inv_L_ = 1.0 / Lnorm;

  // Phase u0: (sn u0, cn u0) = (L_y / b, L_x / a), renormalised against rounding.
  double sn0 = static_cast<double>(Ly / b), cn0 = static_cast<double>(Lx / a);
  const double r = std::hypot(sn0, cn0);
  sn0 /= r;
  cn0 /= r;
  if (mc_ == 0.0 && cn0 == 0.0) {  // stationary rotation about the middle axis
    set_uniform();
    return;
  }
  const double dn0 = std::sqrt(cn0 * cn0 + mc_ * sn0 * sn0);

  // Maximum of |omega|^2 = (a cn/I_x)^2 + (b sn/I_y)^2 + (c dn/I_z)^2, linear in sn^2.
  const LD w_sn0 = a2 / (Ix * Ix) + c2 / (Iz * Iz);
  const LD w_sn1 = b * b / (Iy * Iy) + c2 * mc / (Iz * Iz);
  max_rate_ = static_cast<double>(std::sqrt(std::max(w_sn0, w_sn1))) * (1.0 + 1e-12);

  // Pole and characteristic n (see the comment at the top of this file).
  pole_x_ = a2 <= c2;
  const LD Ik = pole_x_ ? Ix : Iz;
  const LD Ln = std::sqrt(LD(Lx * Lx) + Ly * Ly + Lz * Lz);
  // 2E/|L| - |L|/I_k = sum_i L_i^2 (1/I_i - 1/I_k) / |L|.
  const LD excess = (pole_x_ ? -(Ly * Ly * dxy + Lz * Lz * dxz) : (Lx * Lx * dxz + Ly * Ly * dyz)) / Ln;
  const LD kappa = excess * Ln * Ln / (pole_x_ ? c2 : a2);
  const LD n = pole_x_ ? -a2 / c2 : -m * c2 / a2;
  const LD rate_lin = Ln / Ik + kappa;
  const LD coef_j = kappa * n / lam;
  n_ = static_cast<double>(n);
  rate_lin_ = static_cast<double>(rate_lin);
  coef_j_ = static_cast<double>(coef_j);

  // X' = X (pole z) or (y, z, x) (pole x); P = body <- X'.
  if (pole_x_) {
    P_.col(0) = Px.col(1);
    P_.col(1) = Px.col(2);
    P_.col(2) = Px.col(0);
  } else {
    P_ = Px;
  }
  A_ = R0 * P_ * body_rotation(P_.transpose() * Lb * inv_L_).transpose();
  for (int row = 0; row < 3; ++row) {
    for (int k = 0; k < 3; ++k) {
      if (P_(row, k) != 0.0) {
        perm_[row] = k;
        perm_sign_[row] = P_(row, k);
      }
    }
  }

  if (mc_ == 0.0) {
    mode_ = Mode::Separatrix;
    u0_ = std::asinh(sn0 / cn0);  // F(phi|1) = atanh(sin phi) = asinh(tan phi)
    J0_ = integral_j(u0_, Jacobi{sn0, cn0, dn0});
    return;
  }

  mode_ = Mode::Elliptic;
  // AGM [AS 16.4]: a_0 = 1, b_0 = k', c_0 = k; c_{i+1} = c_i^2 / (4 a_{i+1})
  // avoids the cancellation in (a_i - b_i)/2 when k is small. K = pi / (2 a_N).
  // The double tables stop once c_i/a_i < 1e-17; K continues to long double accuracy.
  LD ag = 1, bg = std::sqrt(mc), cg = std::sqrt(m);
  int levels = 0;
  agm_n_ = -1;
  while (cg > 1e-21L * ag && levels < 60) {
    if (agm_n_ < 0 && cg <= 1e-17L * ag) {
      agm_n_ = levels;
      agm_scale_ = static_cast<double>(std::ldexp(ag, levels));
    }
    const LD a_next = (ag + bg) / 2;
    bg = std::sqrt(ag * bg);
    cg = cg * cg / (4 * a_next);
    ag = a_next;
    ++levels;
    if (levels < static_cast<int>(agm_ratio_.size())) agm_ratio_[levels] = static_cast<double>(cg / ag);
  }
  if (agm_n_ < 0) {
    agm_n_ = std::min(levels, static_cast<int>(agm_ratio_.size()) - 1);
    agm_scale_ = static_cast<double>(std::ldexp(ag, agm_n_));
  }
  const LD pi = 3.141592653589793238462643383279502884L;
  const LD K = pi / (2 * ag);
  K_ = static_cast<double>(K);
  split(2 * K, two_k_hi_, two_k_lo_);
  // u0 = F(phi0|m) = sn0 R_F(cn0^2, dn0^2, 1), |phi0| <= pi/2 [DLMF 19.25.5].
  u0_ = sn0 * elliptic::carlson_rf(cn0 * cn0, dn0 * dn0, 1.0);
  J0_ = integral_j(u0_, Jacobi{sn0, cn0, dn0});
  // psi advances by rate_lin 2K/lambda + coef_j 2 J(K) per 2K of u; J(K) = R_J(0, m', 1, 1 - n)/3.
  const LD Jc = elliptic::rj<LD>(0, mc, 1, 1 - n) / 3;
  split(2 * K / lam, t_half_hi_, t_half_lo_);
  split(rate_lin * 2 * K / lam + coef_j * 2 * Jc, psi_half_hi_, psi_half_lo_);
  init_series(m, n, K, Jc);
  if (series_) {
    double jp;
    jacobi_series(u0_, &jp);
    J0_series_ = j_slope_ * u0_ + jp;
  }
}

void FreeRotation::init_series(LD m, LD n, LD K, LD Jc) {
  series_ = false;
  // Nome q = exp(-pi K'/K) [DLMF 22.2.1], K' = K(m') = pi / (2 AGM(1, k)).
  const LD Kp = m > 0 ? kPi / (2 * agm(1, std::sqrt(m))) : LD(INFINITY);
  const LD q = m > 0 ? std::exp(-kPi * Kp / K) : LD(0);
  if (!(q <= kNomeMax)) return;
  const LD pk = kPi / K;

  // Precession series: Re, Im/D of theta4(zeta + i beta) (see the top of the file).
  // e_plus(k) = q^(k^2) e^(2k beta), e_minus(k) = q^(k^2) e^(-2k beta).
  LD D = 0, x = 0, b = 0;
  if (n < 0) {
    D = std::sqrt(-n * (m - n) * (1 - n));
    x = elliptic::rf<LD>(-n, m - n, 1 - n);
    b = m > 0 ? std::sqrt(-n) * elliptic::rf<LD>(m, m * (1 - n), m - n) : LD(INFINITY);
  }
  // q / m, finite as m -> 0 (q = m/16 + O(m^2) [DLMF 19.5.6-7]).
  const LD q_over_m = m > 0 ? q / m : LD(1) / 16;

  // Powers by recurrence (no pow): qk = q^k, qk2 = q^(k^2), qkm = q^(k(k-1)).
  const LD r = n < 0 ? std::exp(-pk * x) : LD(0);     // e^(-pi x / K)
  const LD theta = pk * b;                             // 2 beta
  const bool small_beta = n < 0 && theta <= 1;
  const LD s_exp = n < 0 ? std::exp(-theta) : LD(0);  // e^(-2 beta)
  const LD sh1 = small_beta ? std::sinh(theta) : LD(0), ch1 = small_beta ? std::cosh(theta) : LD(1);
  std::array<SeriesTerm, kSeriesTerms + 1> t{};
  LD th3_0 = 1, th4_0 = 1, t2_0 = 1, re_bound = 1;
  LD qk = 1, qk2 = 1, qkm = 1, rk = 1, sk = 1, shk = 0, chk = 1;
  int terms = 0;
  for (int k = 1; k <= kSeriesTerms + 1; ++k) {
    const LD sign = (k % 2 != 0) ? -1 : 1;
    if (k > 1) qkm *= qk * qk;  // q^(k(k-1)) = q^((k-1)(k-2)) q^(2(k-1))
    qk2 *= qk * qk * q;         // q^(k^2) = q^((k-1)^2) q^(2k-1)
    qk *= q;
    rk *= r;
    sk *= s_exp;
    const LD shk_next = shk * ch1 + chk * sh1;  // sinh(k theta), cosh(k theta)
    chk = chk * ch1 + shk * sh1;
    shk = shk_next;
    const LD qkk = qk2 * qk;  // q^(k(k+1))
    LD cosh_part, sinh_over_d;  // q^(k^2) cosh(2k beta), q^(k^2) sinh(2k beta) / D
    if (n == 0) {
      // b = 0: sinh(2k beta)/D -> k pi / (K m); q^(k^2)/m = (q/m) q^(k^2-1).
      cosh_part = qk2;
      const LD qk2_over_q = k == 1 ? LD(1) : (q > 0 ? qk2 / q : LD(0));
      sinh_over_d = q_over_m * qk2_over_q * k * pk;
    } else if (small_beta) {
      cosh_part = qk2 * chk;
      sinh_over_d = qk2 * shk / D;
    } else {
      // q^(k^2) e^(+-2k beta) = q^(k(k-1)) r^k, q^(k^2) e^(-2k beta); e_minus <= e^-2 e_plus.
      const LD e_plus = qkm * rk, e_minus = qk2 * sk;
      cosh_part = (e_plus + e_minus) / 2;
      sinh_over_d = (e_plus - e_minus) / (2 * D);
    }
    const bool negligible = qk2 < kSeriesTol && qkk < kSeriesTol && cosh_part < kSeriesTol &&
                            2 * sinh_over_d < kSeriesTol * Jc;
    if (negligible) break;
    if (k > kSeriesTerms) return;  // too many terms: keep the reference path
    terms = k;
    t[k].th3 = static_cast<double>(2 * qk2);
    t[k].th4 = static_cast<double>(2 * sign * qk2);
    t[k].t1 = static_cast<double>(sign * qkk);
    t[k].t2 = static_cast<double>(qkk);
    t[k].jr = static_cast<double>(2 * sign * cosh_part);
    t[k].ji = static_cast<double>(-2 * sign * sinh_over_d);
    th3_0 += 2 * qk2;
    th4_0 += 2 * sign * qk2;
    t2_0 += qkk;
    re_bound -= 2 * cosh_part;
  }
  // Re theta4(zeta + i beta) >= re_bound: keep atan(Im/Re) on its principal branch
  // and well conditioned.
  if (re_bound < 0.25L) return;
  ser_ = t;
  ser_n_ = terms;
  zeta_scale_ = static_cast<double>(pk / 2);
  c_sn_ = static_cast<double>(th3_0 / t2_0);
  c_cn_ = static_cast<double>(th4_0 / t2_0);
  c_dn_ = static_cast<double>(th4_0 / th3_0);
  j_slope_ = static_cast<double>(Jc / K);
  j_d_ = static_cast<double>(D);
  series_ = true;
}

double FreeRotation::body_period() const {
  return mode_ == Mode::Elliptic ? 2.0 * two_k_hi_ / lam_hi_ : 0.0;
}

double FreeRotation::reduced_argument(double dt, double& j) const {
  // u = lambda dt + u0 with lambda = lam_hi + lam_lo; lam_hi dt = p + e exactly.
  const double p = lam_hi_ * dt;
  const double e = std::fma(lam_hi_, dt, -p);
  const double rest = e + lam_lo_ * dt + u0_;
  if (mode_ == Mode::Separatrix) {
    j = 0.0;
    return p + rest;
  }
  j = round_nearest((p + rest) / two_k_hi_);
  // p - j 2K_hi is small, so the fma rounds only once, at the scale of K.
  return std::fma(-j, two_k_hi_, p) + (rest - j * two_k_lo_);
}

FreeRotation::Jacobi FreeRotation::jacobi_agm(double w) const {
  // Descending recurrence of the amplitude [AS 16.4.3]:
  // phi_N = 2^N a_N w, phi_{i-1} = (phi_i + asin((c_i/a_i) sin phi_i)) / 2.
  double phi = agm_scale_ * w;
  for (int i = agm_n_; i >= 1; --i) phi = 0.5 * (phi + std::asin(agm_ratio_[i] * std::sin(phi)));
  const double sn = std::sin(phi), cn = std::cos(phi);
  return {sn, cn, std::sqrt(cn * cn + mc_ * sn * sn)};
}

FreeRotation::Jacobi FreeRotation::jacobi(double v) const {
  if (mode_ == Mode::Separatrix) {
    const double sech = 1.0 / std::cosh(v);  // 0 once cosh overflows
    return {std::tanh(v), sech, sech};
  }
  const double w = std::abs(v);
  Jacobi f;
  if (w <= 0.5 * K_) {
    f = jacobi_agm(w);
  } else {
    // Quarter-period shift [AS 16.20]: sn(K-w) = cn w/dn w, cn(K-w) = k' sn w/dn w,
    // dn(K-w) = k'/dn w: relatively accurate cn, dn near K.
    const Jacobi g = jacobi_agm(std::max(0.0, K_ - w));
    f = {g.cn / g.dn, kc_ * g.sn / g.dn, kc_ / g.dn};
  }
  if (v < 0) f.sn = -f.sn;
  return f;
}

FreeRotation::Jacobi FreeRotation::jacobi_series(double v, double* jp) const {
  const double zeta = zeta_scale_ * v;
  double s1, c1;
  sin_cos(zeta, &s1, &c1);
  const double c2 = (c1 - s1) * (c1 + s1), s2 = 2.0 * s1 * c1;  // e^(2 i zeta)
  double ce = 1.0, se = 0.0;  // e^(2 i k zeta)
  double co = c1, so = s1;    // e^(i (2k+1) zeta)
  double th3 = 1.0, th4 = 1.0, t1 = s1, t2 = c1, re = 1.0, im = 0.0;
  for (int k = 1; k <= ser_n_; ++k) {
    const SeriesTerm& a = ser_[k];
    const double ce_next = ce * c2 - se * s2;
    se = se * c2 + ce * s2;
    ce = ce_next;
    const double co_next = co * c2 - so * s2;
    so = so * c2 + co * s2;
    co = co_next;
    th3 += a.th3 * ce;
    th4 += a.th4 * ce;
    t1 += a.t1 * so;
    t2 += a.t2 * co;
    re += a.jr * ce;
    im += a.ji * se;
  }
  const double inv4 = 1.0 / th4;
  if (jp) {
    // P(v) = -arg theta4(zeta + i beta) / D, Re > 0; im holds Im / D.
    const double r = im / re;
    *jp = j_d_ > 0.0 ? -std::atan(j_d_ * r) / j_d_ : -r;
  }
  return {c_sn_ * t1 * inv4, c_cn_ * t2 * inv4, c_dn_ * th3 * inv4};
}

double FreeRotation::integral_j(double v, const Jacobi& f) const {
  if (mode_ == Mode::Separatrix) {
    const double sq = std::sqrt(-n_);
    const double h = sq > 0 ? std::atan(sq * f.sn) / sq : f.sn;
    return (v - h) / (1.0 - n_);
  }
  const double s2 = f.sn * f.sn;
  return f.sn * s2 / 3.0 * elliptic::carlson_rj(f.cn * f.cn, f.dn * f.dn, 1.0, 1.0 - n_ * s2);
}

Vec3 FreeRotation::momentum_xp(double j, const Jacobi& f) const {
  // sn and cn change sign with every half period 2K; dn does not (j is an
  // integer).
  const double sign = is_odd(j) ? -1.0 : 1.0;
  const double Lx = sign * amp_a_ * f.cn, Ly = sign * amp_b_ * f.sn, Lz = amp_c_ * f.dn;
  return pole_x_ ? Vec3(Ly, Lz, Lx) : Vec3(Lx, Ly, Lz);
}

Mat3 FreeRotation::body_rotation(const Vec3& l) const {
  const double p2 = l[0] * l[0] + l[1] * l[1];  // >= 1/2 by the choice of the pole
  const double ip = 1.0 / std::sqrt(p2);
  Mat3 G;
  G << l[0] * l[2] * ip, l[1] * l[2] * ip, -p2 * ip,  //
      -l[1] * ip, l[0] * ip, 0.0,                    //
      l[0], l[1], l[2];
  return G;
}

Mat3 FreeRotation::compose(double psi, const Vec3& l) const {
  // With the columns a0, a1, a2 of A and the rows g1, g2, g3 = l of G:
  // A Rz(psi) G = (c a0 + s a1) g1^T + (c a1 - s a0) g2^T + a2 l^T, and the
  // product with P^T is a signed permutation of the rows g_i (columns of the result).
  double s, c;
  sin_cos(psi, &s, &c);
  const double p2 = l[0] * l[0] + l[1] * l[1];  // >= 1/2 by the choice of the pole
  const double ip = 1.0 / std::sqrt(p2);
  const double g1[3] = {l[0] * l[2] * ip, l[1] * l[2] * ip, -p2 * ip};
  const double g2[3] = {-l[1] * ip, l[0] * ip, 0.0};
  Mat3 R;
#pragma GCC unroll 3
  for (int col = 0; col < 3; ++col) {
    const int k = perm_[col];
    const double sg = perm_sign_[col];
    const double x1 = sg * g1[k], x2 = sg * g2[k], x3 = sg * l[k];
    const double e = c * x1 - s * x2, f = s * x1 + c * x2;  // (Rz G P^T)(0..1, col)
#pragma GCC unroll 3
    for (int row = 0; row < 3; ++row) R(row, col) = A_(row, 0) * e + A_(row, 1) * f + A_(row, 2) * x3;
  }
  return R;
}

Vec3 FreeRotation::angular_momentum_body_impl(double dt, bool series) const {
  if (mode_ == Mode::Rest || mode_ == Mode::Uniform) return R0_.transpose() * L_world_;
  double j;
  const double v = reduced_argument(dt, j);
  return P_ * momentum_xp(j, series ? jacobi_series(v, nullptr) : jacobi(v));
}

Vec3 FreeRotation::angular_momentum_body(double dt) const { return angular_momentum_body_impl(dt, series_); }

Vec3 FreeRotation::omega_body(double dt) const {
  if (mode_ == Mode::Rest || mode_ == Mode::Uniform) return omega_body0_;
  return angular_momentum_body_impl(dt, series_).cwiseQuotient(moments_);
}

Vec3 FreeRotation::omega_body_reference(double dt) const {
  if (mode_ == Mode::Rest || mode_ == Mode::Uniform) return omega_body0_;
  return angular_momentum_body_impl(dt, false).cwiseQuotient(moments_);
}

Mat3 FreeRotation::orientation(double dt) const { return orientation_impl(dt, series_); }
Mat3 FreeRotation::orientation_reference(double dt) const { return orientation_impl(dt, false); }

Mat3 FreeRotation::orientation_impl(double dt, bool series) const {
  switch (mode_) {
    case Mode::Rest:
      return R0_;
    case Mode::Uniform:
      return Eigen::AngleAxisd(rate_ * dt, axis_world_).toRotationMatrix() * R0_;
    case Mode::Elliptic:
    case Mode::Separatrix:
      break;
  }
  double j;
  const double v = reduced_argument(dt, j);
  Jacobi f;
  double J_rel;  // J(v) - J(u0)
  if (series) {
    double jp;
    f = jacobi_series(v, &jp);
    J_rel = (j_slope_ * v + jp) - J0_series_;
  } else {
    f = jacobi(v);
    J_rel = integral_j(v, f) - J0_;
  }
  const Vec3 l = momentum_xp(j, f) * inv_L_;
  double psi;
  if (mode_ == Mode::Separatrix) {
    psi = rate_lin_ * dt + coef_j_ * J_rel;
  } else {
    // psi = j psi_half (mod 2 pi) + rate_lin (dt - j T_half) + coef_j (J(v) - J(u0)),
    // T_half = 2K/lambda. (Not (v - u0)/lambda: that loses all accuracy when
    // lambda is tiny, as for a nearly symmetric top.)
    const double q = j * psi_half_hi_;
    const double q_err = std::fma(j, psi_half_hi_, -q);
    const double turns = round_nearest(q / kTwoPiHi);
    const double secular = std::fma(-turns, kTwoPiHi, q) + (q_err + j * psi_half_lo_ - turns * kTwoPiLo);
    const double t_local = std::fma(-j, t_half_hi_, dt) - j * t_half_lo_;
    psi = secular + rate_lin_ * t_local + coef_j_ * J_rel;
  }
  return compose(psi, l);
}

Vec3 FreeRotation::omega_world(double dt) const { return orientation(dt) * omega_body(dt); }

}  // namespace ringsim
