#pragma once
// Sine and cosine of one argument for the event loop's hot paths (a free
// linker's precession, the corotating plane, the clusters' exact rotation,
// the support tracks, the rim search). glibc's sincos rounds correctly, which
// costs it ~100 instructions per call; this needs ~45 and stays within ~1.5 ulp
// (tests/test_fast_trig.cpp measures the error against long double). The
// results differ from glibc's in the last bit now and then, so trajectories
// change at rounding level, as any reordering of floating-point work does.
//
// Method (standard; e.g. Muller, "Elementary Functions", 3rd ed., ch. 11):
//  - reduction by Cody and Waite: k = nearest integer to x 2/pi, r = x - k pi/2
//    with pi/2 split into P1 + P2, P1 of 33 significant bits, so k P1 is
//    exact for |k| < 2^20 and x - k P1 is exact (Sterbenz); k P2 rounds by at
//    most 3e-21 and P2 itself is off by 3.5e-27 |k| < 2e-21; |r| <= pi/4;
//  - Taylor polynomials on |r| <= pi/4: sin through r^17 (truncation error
//    <= (pi/4)^19 / 19! < 1e-19), cos through r^16 (< 3e-18), evaluated by
//    Estrin's scheme (short dependency chains: these calls sit on the
//    critical path of the searches);
//    the coefficients 1/n! are correctly rounded quotients of exact integers;
//  - the quadrant k mod 4 selects and signs the two results.
// Arguments beyond kFastTrigLimit (and NaN, inf) go to std::sin and std::cos.
// Near a zero of sin or cos at large |x| the result keeps its absolute
// accuracy (~1e-16) rather than its relative one.

#include <cmath>
#include <cstdint>
#include <cstring>

namespace ringsim {

inline constexpr double kFastTrigLimit = 5.0e5;  // |x| 2/pi < 2^19

[[gnu::always_inline]] inline void sin_cos(double x, double* sin_x, double* cos_x) {
  if (!(std::abs(x) <= kFastTrigLimit)) {
    *sin_x = std::sin(x);
    *cos_x = std::cos(x);
    return;
  }
  // pi/2 = P1 + P2 to 3.5e-27 (constants computed with 300-bit mpmath).
  constexpr double P1 = 0x1.921fb54400000p+0;
  constexpr double P2 = 0x1.0b4611a626331p-34;
  constexpr double kTwoOverPi = 0x1.45f306dc9c883p-1;
  // Round x 2/pi to the nearest integer by the 1.5 * 2^52 shift (valid for
  // |x 2/pi| < 2^51 in the default rounding mode); the shifted value's low
  // mantissa bits hold k mod 4 in two's complement.
  constexpr double kShift = 0x1.8p52;
  const double shifted = x * kTwoOverPi + kShift;
  const double k = shifted - kShift;
  std::uint64_t bits;
  std::memcpy(&bits, &shifted, sizeof bits);
  const unsigned q = static_cast<unsigned>(bits) & 3u;
  const double r = (x - k * P1) - k * P2;
  // Both polynomials in z = r^2 by Estrin's scheme (pairs, then pairs of
  // pairs): a dependency chain of ~6 operations instead of Horner's ~16.
  const double z = r * r, z2 = z * z, z4 = z2 * z2;
  auto estrin = [&](double a0, double a1, double a2, double a3, double a4, double a5, double a6, double a7) {
    return ((a0 + a1 * z) + z2 * (a2 + a3 * z)) + z4 * ((a4 + a5 * z) + z2 * (a6 + a7 * z));
  };
  const double ps = estrin(-1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0, -1.0 / 39916800.0,
                           1.0 / 6227020800.0, -1.0 / 1307674368000.0, 1.0 / 355687428096000.0);
  const double pc = estrin(-0.5, 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0, -1.0 / 3628800.0, 1.0 / 479001600.0,
                           -1.0 / 87178291200.0, 1.0 / 20922789888000.0);
  const double s = r + (r * z) * ps;
  const double c = 1.0 + z * pc;
  // x = k pi/2 + r: quadrant 0 (s, c), 1 (c, -s), 2 (-s, -c), 3 (-c, s).
  const bool swap = (q & 1u) != 0;
  const double sv = swap ? c : s, cv = swap ? s : c;
  *sin_x = (q & 2u) ? -sv : sv;
  *cos_x = ((q + 1u) & 2u) ? -cv : cv;
}

}  // namespace ringsim
