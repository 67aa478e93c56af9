#include "core/compliant_group.hpp"

#include <algorithm>
#include <cmath>

#include "core/constrained_dynamics.hpp"
#include "core/track.hpp"

namespace ringsim {

double set_tracks(BodyStore& b, const CompliantGroup& g, const SliceEnd& ea, double ta, const SliceEnd& eb,
                  double tb) {
  const double D = tb - ta;
  // Compliant clusters keep the cubic: the figures of docs/COMPLIANT.md were
  // measured with it, and over a slice spanning stiff bond periods no
  // polynomial follows the motion (the track-error check halves those).
  const bool quintic = g.articulated && D > 0.0 && !ea.center_accel.empty() && !eb.center_accel.empty();
  double min_len = 1.0;
  for (std::size_t k = 0; k < g.members.size(); ++k) {
    const CompliantBody &a = ea.bodies[k], &e = eb.bodies[k];
    Track& tr = b.track[g.members[k]];
    tr.ta = ta;
    tr.tb = tb;
    tr.xa = a.x + g.shift;
    tr.va = a.v;
    tr.xb = e.x + g.shift;
    tr.vb = e.v;
    tr.vbar = D > 0.0 ? Vec3((tr.xb - tr.xa) / D) : tr.va;
    // core/track.hpp: the cubic c has |c - chord| <= D/4 max(|A|, |B|) and
    // |c' - vbar| <= |A| + |B|; c''(t) = [(6 s - 4) A + (6 s - 2) B] / D
    // (vectors A, B), linear in s: largest at an end. The quintic term
    // w = p(s) [(1 - s) alpha + s beta] adds at most m / 16 to the first,
    // (m / (3 sqrt 3) + |beta - alpha| / 16) / D to the second and
    // (2 m + 2 |beta - alpha| / (3 sqrt 3)) / D^2 to the third,
    // m = max(|alpha|, |beta|).
    const Vec3 Av = tr.va - tr.vbar, Bv = tr.vb - tr.vbar;
    const double A = Av.norm(), B = Bv.norm();
    tr.dev = 0.25 * D * std::max(A, B);
    tr.center_speed = A + B;
    tr.center_accel = D > 0.0 ? std::max((4.0 * Av + 2.0 * Bv).norm(), (2.0 * Av + 4.0 * Bv).norm()) / D : 0.0;
    tr.quintic = quintic;
    tr.xc0 = tr.xc1 = Vec3::Zero();
    if (quintic) {
      tr.xc0 = 0.5 * D * (D * ea.center_accel[k] + 4.0 * Av + 2.0 * Bv);
      tr.xc1 = 0.5 * D * (D * eb.center_accel[k] - 2.0 * Av - 4.0 * Bv);
      const double m = std::max(tr.xc0.norm(), tr.xc1.norm()), d = (tr.xc1 - tr.xc0).norm();
      tr.dev += m / 16.0;
      tr.center_speed += (kQuinticSlopeMax * m + d / 16.0) / D;
      tr.center_accel += (2.0 * m + 2.0 * kQuinticSlopeMax * d) / (D * D);
    }
    if (a.shape == Shape::Sphere) {
      tr.sphere_omega = a.omega;
      tr.axis_rate = 0.0;
      continue;
    }
    tr.ua = a.axis();
    tr.ub = e.axis();
    tr.wa = a.omega.cross(tr.ua);
    tr.wb = e.omega.cross(tr.ub);
    tr.spin_a = a.omega.dot(tr.ua);
    tr.spin_b = e.omega.dot(tr.ub);
    tr.qa = a.q;
    tr.ubar = D > 0.0 ? Vec3((tr.ub - tr.ua) / D) : tr.wa;
    const Vec3 WAv = tr.wa - tr.ubar, WBv = tr.wb - tr.ubar;
    tr.uc0 = tr.uc1 = Vec3::Zero();
    double um = 0.0, ud = 0.0;
    if (quintic) {
      tr.uc0 = 0.5 * D * (D * ea.axis_accel[k] + 4.0 * WAv + 2.0 * WBv);
      tr.uc1 = 0.5 * D * (D * eb.axis_accel[k] - 2.0 * WAv - 4.0 * WBv);
      um = std::max(tr.uc0.norm(), tr.uc1.norm());
      ud = (tr.uc1 - tr.uc0).norm();
    }
    // The roll: the rotation left between qb and the shortest turn of qa,
    // about ub. Its rate at ta is the spin there (the shortest-turn frame
    // does not spin at ua); at tb the spin minus the frame's spin
    // (shortest_turn_spin). The angle is taken on the branch (mod 2 pi)
    // nearest the one the mean rate predicts.
    {
      const Quat rest = e.q * (Quat::FromTwoVectors(tr.ua, tr.ub) * a.q).conjugate();
      tr.roll_rate_b = tr.spin_b - shortest_turn_spin(tr.ua, tr.ub, tr.wb);
      const double roll = 2.0 * std::atan2(rest.vec().dot(tr.ub), rest.w());
      const double predicted = 0.5 * D * (tr.spin_a + tr.roll_rate_b);
      constexpr double kTwoPi = 6.283185307179586;
      tr.roll_b = roll + kTwoPi * std::round((predicted - roll) / kTwoPi);
    }
    // The interpolated axis h(t) stays within D/4 max(|wa - ubar|, |wb - ubar|)
    // + um / 16 of the chord (1 - s) ua + s ub, whose length is at least
    // sqrt((1 + ua.ub) / 2) (at s = 1/2); |h'| <= |ubar| + |wa - ubar| +
    // |wb - ubar| + (the quintic term's slope), and |d(h/|h|)/dt| <= |h'| / |h|.
    const double Wa = WAv.norm(), Wb = WBv.norm();
    const double len =
        std::sqrt(std::max(0.0, 0.5 * (1.0 + tr.ua.dot(tr.ub)))) - 0.25 * D * std::max(Wa, Wb) - um / 16.0;
    min_len = std::min(min_len, len);
    const double h1 = tr.ubar.norm() + Wa + Wb + (D > 0.0 ? (kQuinticSlopeMax * um + ud / 16.0) / D : 0.0);
    tr.axis_rate = len > 0.0 ? h1 / len : std::numeric_limits<double>::infinity();
    // u = h / |h|: |u''| <= (|h''| + 3 |h'|^2 / |h|) / |h| (differentiate
    // P h' / |h|, P = 1 - u u^T, |P'| <= 2 |u'|); the turning rate of the
    // shape is Omega = u x u', |Omega'| <= |u''|, and a point at distance rho
    // from the centre accelerates relative to it by at most (|Omega'| + |Omega|^2) rho.
    const double h2 = D > 0.0 ? std::max((4.0 * WAv + 2.0 * WBv).norm(), (2.0 * WAv + 4.0 * WBv).norm()) / D +
                                    (2.0 * um + 2.0 * kQuinticSlopeMax * ud) / (D * D)
                              : 0.0;
    tr.axis_accel = len > 0.0 ? (h2 + 3.0 * h1 * h1 / len) / len + tr.axis_rate * tr.axis_rate
                              : std::numeric_limits<double>::infinity();
  }
  return min_len;
}

// A linker's angular momentum L changes at the torque's rate, and
// omega = I^-1(u) L with I^-1 = 1/I_perp + (1/I_axial - 1/I_perp) u u^T, so
// omega' = I^-1 tau + (1/I_axial - 1/I_perp) (u' (u.L) + u (u'.L)), u' = omega x u,
// and u'' = omega' x u + omega x u'.
SliceEnd slice_end(const CompliantCluster& c, const JointSet& joints) {
  std::vector<Vec3> force, torque;
  cluster_loads(c, joints, force, torque);
  return slice_end(c, force, torque);
}

SliceEnd slice_end(const CompliantCluster& c, const std::vector<Vec3>& force, const std::vector<Vec3>& torque) {
  const std::vector<BodyMotion> motion = body_motions(c);
  SliceEnd e;
  e.bodies = c.bodies;
  e.center_accel.resize(c.bodies.size());
  e.axis_accel.assign(c.bodies.size(), Vec3::Zero());
  for (std::size_t k = 0; k < c.bodies.size(); ++k) {
    const CompliantBody& b = c.bodies[k];
    e.center_accel[k] = force[k] / b.mass;
    if (b.shape == Shape::Sphere) continue;
    const Vec3 u = motion[k].u, w = motion[k].omega;
    const double a_perp = 1.0 / b.i_perp, a_diff = 1.0 / b.i_axial - a_perp;
    const Vec3 L = b.angular_momentum();
    const Vec3 du = w.cross(u);
    const Vec3 dw = a_perp * torque[k] + a_diff * (torque[k].dot(u) * u + du * u.dot(L) + u * du.dot(L));
    e.axis_accel[k] = dw.cross(u) + w.cross(du);
  }
  return e;
}

double track_error_estimate(const SliceEnd& a, const SliceEnd& b, double D) {
  double worst = 0.0;
  for (std::size_t k = 0; k < a.bodies.size(); ++k) {
    const CompliantBody &p = a.bodies[k], &q = b.bodies[k];
    const Vec3 ex = D / 32.0 * (p.v - q.v) + D * D / 64.0 * (a.center_accel[k] + b.center_accel[k]);
    double e = ex.norm();
    if (p.shape != Shape::Sphere) {
      const Vec3 wp = p.omega.cross(p.axis()), wq = q.omega.cross(q.axis());
      const Vec3 eu = D / 32.0 * (wp - wq) + D * D / 64.0 * (a.axis_accel[k] + b.axis_accel[k]);
      e += p.half_length * eu.norm();
    }
    worst = std::max(worst, e);
  }
  return worst;
}

CompliantBody member_state(const BodyStore& b, int i, double t, const CompliantBody& model, const Vec3& shift,
                           bool full_orientation) {
  const Track& tr = b.track[i];
  CompliantBody s = model;
  s.x = track_center(tr, t) - shift;
  s.v = track_velocity(tr, t);
  if (s.shape == Shape::Sphere) {
    s.omega = tr.sphere_omega;
    return s;
  }
  s.q = full_orientation ? track_orientation(tr, t) : orientation_from_axis(track_axis(tr, t));
  s.omega = track_omega(tr, t);
  return s;
}

double internal_kinetic_energy(const CompliantCluster& c) {
  // Rigid motion fitted to the pose velocities by least squares, weighted by
  // mass and transverse inertia: V the centre-of-mass velocity, Omega from
  //   [sum m (|r|^2 1 - r r^T) + sum_linkers I_perp (1 - u u^T)] Omega
  //     = sum m r x (v - V) + sum_linkers I_perp u x u'.
  // Spins about own axes (a sphere's, a linker's about its axis) do not move
  // the pose and are left out: no compliant load acts on them.
  double M = 0.0;
  Vec3 X = Vec3::Zero(), V = Vec3::Zero();
  for (const CompliantBody& b : c.bodies) {
    M += b.mass;
    X += b.mass * b.x;
    V += b.mass * b.v;
  }
  X /= M;
  V /= M;
  Mat3 J = Mat3::Zero();
  Vec3 rhs = Vec3::Zero();
  for (const CompliantBody& b : c.bodies) {
    const Vec3 r = b.x - X;
    J += b.mass * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
    rhs += b.mass * r.cross(b.v - V);
    if (b.shape == Shape::Linker) {
      const Vec3 u = b.axis();
      J += b.i_perp * (Mat3::Identity() - u * u.transpose());
      rhs += b.i_perp * u.cross(b.omega.cross(u));
    }
  }
  const Vec3 W = J.ldlt().solve(rhs);
  double e = 0.0;
  for (const CompliantBody& b : c.bodies) {
    const Vec3 r = b.x - X;
    e += 0.5 * b.mass * (b.v - V - W.cross(r)).squaredNorm();
    if (b.shape == Shape::Linker) {
      const Vec3 u = b.axis();
      e += 0.5 * b.i_perp * (b.omega.cross(u) - W.cross(u)).squaredNorm();
    }
  }
  return e;
}

}  // namespace ringsim
