#include "core/contact.hpp"

#include <algorithm>
#include <cmath>

namespace ringsim {

namespace {
Vec3 point_velocity(const ContactSide& s) { return s.v + s.omega.cross(s.arm); }
}  // namespace

double combine(CombineRule rule, double a, double b) {
  switch (rule) {
    case CombineRule::Min: return std::min(a, b);
    case CombineRule::Max: return std::max(a, b);
    case CombineRule::Product: return a * b;
    case CombineRule::Mean: return 0.5 * (a + b);
  }
  return a;
}

namespace {

Mat3 side_matrix(const ContactSide& s) {
  if (s.explicit_k) return s.k;
  const Mat3 r = cross_matrix(s.arm);
  return s.inv_mass * Mat3::Identity() - r * s.inv_inertia * r;
}

Mat3 collision_matrix(const ContactSide& a, const ContactSide& b) {
  if (a.explicit_k || b.explicit_k) return side_matrix(a) + side_matrix(b);
  // (Summed in this order for the rigid bodies: the same bits as always.)
  const Mat3 ra = cross_matrix(a.arm), rb = cross_matrix(b.arm);
  return (a.inv_mass + b.inv_mass) * Mat3::Identity() - ra * a.inv_inertia * ra - rb * b.inv_inertia * rb;
}

// Newton's law along n alone (no friction): -(1 + e) u_n / (n.K.n) n.
Vec3 smooth_impulse(const Vec3& u, const Mat3& K, const Vec3& n, double e) {
  return (-(1.0 + e) * n.dot(u) / n.dot(K * n)) * n;
}

// Newton restitution and impulsive Coulomb friction (the header's laws), for
// relative contact-point velocity u and collision matrix K.
ContactResult newton_coulomb(const Vec3& u, const Mat3& K, const Vec3& n, const ContactLaw& law) {
  const double un = n.dot(u);
  const double e = law.restitution;

  const Vec3 ut = u - un * n;
  const bool frictional = law.static_friction > 0.0 || law.dynamic_friction > 0.0;
  if (frictional && ut.squaredNorm() > 0.0) {
    // Sticking: the impulse that leaves u' = -e un n.
    const Vec3 target = -e * un * n;
    const Vec3 J = K.fullPivLu().solve(target - u);
    const double jn = J.dot(n);
    const double jt = (J - jn * n).norm();
    if (jn > 0.0 && jt <= law.static_friction * jn) return {J, ContactMode::Stick};
    // Sliding: tangential impulse opposes the incoming tangential velocity.
    const Vec3 dir = n - law.dynamic_friction * ut.normalized();
    const double denom = n.dot(K * dir);
    if (denom > 0.0) {
      const double j = -(1.0 + e) * un / denom;
      return {j * dir, ContactMode::Slide};
    }
    // denom <= 0 (the Painleve-like configurations): fall through to smooth.
  }
  return {smooth_impulse(u, K, n, e), ContactMode::Smooth};
}

// -J . (u- + u+) / 2 with u+ = u- + K J (header).
double energy_loss(const Vec3& u, const Mat3& K, const Vec3& J) { return -J.dot(u + 0.5 * (K * J)); }

// Newton's restitution with Coulomb friction can put energy in where K
// couples the normal and tangential directions (Stronge, "Impact Mechanics",
// 2000, ch. 4: the kinematic coefficient is not energetically consistent
// with friction; e.g. a fast-spinning linker on a rough wall). The
// frictional impulse J and the smooth one J_s (loss >= 0 for e <= 1) give the
// same normal velocity afterwards, -e u_n, and both lie in the friction
// cone, so every J_s + lambda (J - J_s) does too; its loss,
//   c - b lambda - a lambda^2, c = loss(J_s), b = D.(u + K J_s),
//   a = D.K D / 2, D = J - J_s,
// is concave. When J would gain energy, the largest lambda in [0, 1] that
// loses none is taken: as much of the friction as keeps the energy.
Vec3 without_energy_gain(const Vec3& u, const Mat3& K, const Vec3& n, const ContactLaw& law, const Vec3& J) {
  if (energy_loss(u, K, J) >= 0.0) return J;
  const Vec3 js = smooth_impulse(u, K, n, law.restitution);
  const Vec3 d = J - js;
  const double a = 0.5 * d.dot(K * d), b = d.dot(u + K * js), c = std::max(0.0, energy_loss(u, K, js));
  // The positive root of a lambda^2 + b lambda - c = 0, in the form without
  // cancellation (c = 0 for e = 1: lambda = -b / a when b < 0).
  double lambda = 0.0;
  if (a > 0.0) {
    const double q = b + std::sqrt(b * b + 4.0 * a * c);
    lambda = b >= 0.0 ? (q > 0.0 ? 2.0 * c / q : 0.0) : (-b + std::sqrt(b * b + 4.0 * a * c)) / (2.0 * a);
  } else if (b > 0.0) {
    lambda = c / b;
  }
  // A hair inside the root, so that rounding cannot tip the loss below 0
  // (then only the smooth impulse would be left).
  lambda = std::clamp(lambda * (1.0 - 1e-9), 0.0, 1.0);
  const Vec3 blended = js + lambda * d;
  return energy_loss(u, K, blended) >= 0.0 ? blended : js;
}

}  // namespace

ContactResult solve_contact(const ContactSide& a, const ContactSide& b, const Vec3& n, const ContactLaw& law) {
  const Vec3 u = relative_point_velocity(a, b);
  const Mat3 K = collision_matrix(a, b);
  ContactResult r = newton_coulomb(u, K, n, law);
  if (r.mode != ContactMode::Smooth) r.impulse = without_energy_gain(u, K, n, law, r.impulse);
  if (law.min_separation > 0.0 && law.restitution >= 1.0) {
    const double top_up = floor_impulse(n.dot(u + K * r.impulse), n.dot(K * n), law);
    if (top_up > 0.0) {
      r.impulse += top_up * n;
      r.floored = true;
    }
  }
  r.energy_loss = energy_loss(u, K, r.impulse);
  return r;
}

ContactResult separation_floor(const ContactSide& a, const ContactSide& b, const Vec3& n, const ContactLaw& law) {
  const Vec3 u = relative_point_velocity(a, b);
  const Mat3 K = collision_matrix(a, b);
  const double top_up = floor_impulse_at_rest(n.dot(u), n.dot(K * n), law);
  ContactResult r{top_up * n, ContactMode::Smooth, top_up > 0.0, 0.0};
  r.energy_loss = energy_loss(u, K, r.impulse);
  return r;
}

double floor_impulse(double un_after, double k_nn, const ContactLaw& law) {
  return law.restitution < 1.0 ? 0.0 : floor_impulse_at_rest(un_after, k_nn, law);
}

double floor_impulse_at_rest(double un, double k_nn, const ContactLaw& law) {
  if (law.min_separation <= 0.0 || un >= law.min_separation) return 0.0;
  return (law.min_separation - un) / k_nn;
}

Vec3 relative_point_velocity(const ContactSide& a, const ContactSide& b) { return point_velocity(b) - point_velocity(a); }

double impulse_energy_loss(const ContactSide& a, const ContactSide& b, const Vec3& J) {
  return energy_loss(relative_point_velocity(a, b), collision_matrix(a, b), J);
}

}  // namespace ringsim
