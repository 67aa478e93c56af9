#include "core/compliant.hpp"

#include <cmath>
#include <limits>

#include "core/bond_rules.hpp"

namespace ringsim {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Below this |sin| (angle) or projection length (dihedral) a term's gradient
// direction is undefined: the term applies no load (see the header).
constexpr double kSingular = 1e-12;

double sign_of_end(int end) { return end == 0 ? 1.0 : -1.0; }

// Distance a from a linker's centre to the target point of a sphere bonded at
// one of its ends: half length + sphere radius + target gap.
double target_reach(const CompliantBody& linker, const CompliantBody& sphere, double gap) {
  return linker.half_length + sphere.radius + gap;
}

// wrap(x) in (-pi, pi] for x in (-3 pi, 3 pi].
double wrap_angle(double x) {
  if (x > kPi) x -= 2.0 * kPi;
  if (x <= -kPi) x += 2.0 * kPi;
  return x;
}

// Angle term geometry: theta and the unit normal w = nA x nB / |nA x nB|, so
// that d theta / d(rotation of A) = -w and d theta / d(rotation of B) = +w
// (a rotation of B about w turns nB away from nA). valid = false when the
// axes are parallel.
struct AngleGeom {
  double theta;
  Vec3 w;
  bool valid;
};
AngleGeom angle_geom(const Vec3& na, const Vec3& nb) {
  const Vec3 cr = na.cross(nb);
  const double s = cr.norm();
  AngleGeom g;
  g.theta = std::atan2(s, na.dot(nb));
  g.valid = s >= kSingular;
  g.w = g.valid ? Vec3(cr / s) : Vec3::Zero();
  return g;
}

// Dihedral geometry about unit axis u with neighbour unit outward axes n0
// (end-0 side) and n1 (end-1 side), the convention of core/bond_rules.hpp:
// phi = atan2(u.(a x b), a.b), a = u x n0, b = u x n1 (the projections turned
// by 90 degrees about u), i.e. phi = alpha1 - alpha0 with alpha the azimuths
// of n0 and n1 about u. A rotation delta of the body carrying n0 changes
// alpha0 by [u - (u.n0) n0] . delta / |u x n0|^2 (the azimuth rate of a unit
// vector about u), so
//   G0 = d phi / d(rotation of n0's linker) = -(u - (u.n0) n0) / |u x n0|^2,
//   G1 = d phi / d(rotation of n1's linker) = +(u - (u.n1) n1) / |u x n1|^2,
//   Gu = -(G0 + G1)   (phi is invariant under a global rotation).
// (Equivalent to the Cartesian dihedral gradient of Blondel & Karplus,
// J. Comput. Chem. 17, 1132 (1996), written for rotations of rigid axes.)
struct DihedralGeom {
  double phi;
  Vec3 g0, g1, gu;
  bool valid;
};
DihedralGeom dihedral_geom(const Vec3& u, const Vec3& n0, const Vec3& n1) {
  const Vec3 a = u.cross(n0);
  const Vec3 b = u.cross(n1);
  const double a2 = a.squaredNorm(), b2 = b.squaredNorm();
  DihedralGeom g;
  g.valid = a2 >= kSingular * kSingular && b2 >= kSingular * kSingular;
  if (!g.valid) {
    g.phi = std::numeric_limits<double>::quiet_NaN();
    g.g0 = g.g1 = g.gu = Vec3::Zero();
    return g;
  }
  g.phi = std::atan2(u.dot(a.cross(b)), a.dot(b));
  g.g0 = -(u - u.dot(n0) * n0) / a2;
  g.g1 = (u - u.dot(n1) * n1) / b2;
  g.gu = -(g.g0 + g.g1);
  return g;
}

int sphere_at(const CompliantCluster& c, int linker, int end) {
  for (const CompliantBond& b : c.bonds) {
    if (b.linker == linker && b.end == end) return b.sphere;
  }
  return -1;
}

bool has_dihedral(const CompliantCluster& c, const CompliantDihedral& d) {
  for (const CompliantDihedral& e : c.dihedrals) {
    if (e.linker == d.linker && e.nb0 == d.nb0 && e.nb0_end == d.nb0_end && e.nb1 == d.nb1 &&
        e.nb1_end == d.nb1_end) {
      return true;
    }
  }
  return false;
}

}  // namespace

Vec3 CompliantBody::angular_momentum() const {
  if (shape == Shape::Sphere) return i_perp * omega;
  const Vec3 u = axis();
  const double w_ax = omega.dot(u);
  return i_perp * omega + (i_axial - i_perp) * w_ax * u;
}

CompliantBody make_compliant_body(const Species& sp, const Vec3& x, const Vec3& v, const Vec3& axis,
                                  const Vec3& omega) {
  CompliantBody b;
  b.shape = sp.shape;
  b.mass = sp.mass;
  b.i_axial = sp.i_axial;
  b.i_perp = sp.i_perp;
  b.radius = sp.radius;
  b.half_length = sp.half_length;
  b.x = x;
  b.v = v;
  b.q = sp.shape == Shape::Linker ? orientation_from_axis(axis.normalized()) : Quat::Identity();
  b.omega = omega;
  return b;
}

CompliantBody compliant_body_from(const Kinematics& kin, const Species& sp) {
  const Vec3 omega = sp.shape == Shape::Linker ? Vec3(kin.precession + kin.spin * kin.axis) : kin.precession;
  return make_compliant_body(sp, kin.x, kin.v, kin.axis, omega);
}

Kinematics kinematics_from(const CompliantBody& b, double t) {
  Kinematics k = make_kinematics(b.x, b.v, b.shape == Shape::Linker ? b.axis() : Vec3::UnitZ());
  k.t = t;
  if (b.shape == Shape::Sphere) {
    k.precession = b.omega;
    k.spin = 0.0;
  } else {
    // body.hpp: precession = L / I_perp, spin = (L.u)(1/I_axial - 1/I_perp).
    const Vec3 L = b.angular_momentum();
    k.precession = L / b.i_perp;
    k.spin = L.dot(k.axis) * (1.0 / b.i_axial - 1.0 / b.i_perp);
  }
  return k;
}

void add_compliant_bond(CompliantCluster& cluster, int sphere, int linker, int end, const BondingParams& bonding) {
  cluster.bonds.push_back({sphere, linker, end});

  if (bonding.angle_filter) {
    for (const CompliantBond& b : cluster.bonds) {
      if (b.sphere != sphere || (b.linker == linker && b.end == end)) continue;
      cluster.angles.push_back({sphere, b.linker, b.end, linker, end, bonding.theta0_deg * kPi / 180.0});
    }
  }
  if (!bonding.coplanarity_filter) return;

  // Linkers whose dihedral may have just become defined: the new one and
  // every linker already on the capturing sphere.
  std::vector<int> candidates{linker};
  for (const CompliantBond& b : cluster.bonds) {
    if (b.sphere == sphere && b.linker != linker) candidates.push_back(b.linker);
  }
  for (const int M : candidates) {
    const int s0 = sphere_at(cluster, M, 0), s1 = sphere_at(cluster, M, 1);
    if (s0 < 0 || s1 < 0) continue;
    for (const CompliantBond& p : cluster.bonds) {
      if (p.sphere != s0 || p.linker == M) continue;
      for (const CompliantBond& q : cluster.bonds) {
        if (q.sphere != s1 || q.linker == M) continue;
        CompliantDihedral d{M, p.linker, p.end, q.linker, q.end, 0.0};
        if (has_dihedral(cluster, d)) continue;
        const double phi = term_dihedral(cluster, d);
        // The planar value nearest to the dihedral the bond formed with
        // (MODEL.md); `cis` mode accepts only cis, so its target is cis.
        const bool trans = bonding.coplanarity_mode == CoplanarityMode::CisOrTrans && std::isfinite(phi) &&
                           std::abs(phi) > 0.5 * kPi;
        d.phi0 = trans ? kPi : 0.0;
        cluster.dihedrals.push_back(d);
      }
    }
  }
}

std::vector<BodyMotion> body_motions(const CompliantCluster& cluster) {
  std::vector<BodyMotion> m(cluster.bodies.size());
  for (std::size_t i = 0; i < m.size(); ++i) {
    const CompliantBody& b = cluster.bodies[i];
    m[i].x = b.x;
    m[i].v = b.v;
    m[i].u = b.shape == Shape::Linker ? b.axis() : Vec3::UnitZ();
    m[i].omega = b.omega;
  }
  return m;
}

void compliant_loads(const CompliantCluster& cluster, const std::vector<BodyMotion>& m, bool damping,
                     std::vector<Vec3>& force, std::vector<Vec3>& torque) {
  const std::size_t n = cluster.bodies.size();
  force.assign(n, Vec3::Zero());
  torque.assign(n, Vec3::Zero());
  const CompliantParams& p = cluster.params;

  for (const CompliantBond& b : cluster.bonds) {
    const BodyMotion& s = m[b.sphere];
    const BodyMotion& l = m[b.linker];
    // Lever from the linker centre to the target point p* = x_L + s_e a u.
    const Vec3 r = sign_of_end(b.end) * target_reach(cluster.bodies[b.linker], cluster.bodies[b.sphere],
                                                     p.target_gap) * l.u;
    const Vec3 d = s.x - l.x - r;
    // U = k |d|^2 / 2: F_S = -k d at x_S; on the linker +k d acting at p*,
    // i.e. torque r x (k d) (minus the gradient with respect to its rotation).
    const Vec3 fs = -p.k * d;
    force[b.sphere] += fs;
    force[b.linker] -= fs;
    torque[b.linker] -= r.cross(fs);
    if (damping && p.c != 0.0) {
      // Relative velocity at the common point x_S (objective rate of d).
      const Vec3 arm = s.x - l.x;
      const Vec3 w = s.v - l.v - l.omega.cross(arm);
      const Vec3 fd = -p.c * w;
      force[b.sphere] += fd;
      force[b.linker] -= fd;
      torque[b.linker] -= arm.cross(fd);
    }
  }

  for (const CompliantAngle& a : cluster.angles) {
    const AngleGeom g = angle_geom(outward_axis(m[a.linker_a].u, a.end_a), outward_axis(m[a.linker_b].u, a.end_b));
    if (!g.valid) continue;
    double gen = p.k_omega * (g.theta - a.theta0);
    if (damping) gen += p.c_omega * g.w.dot(m[a.linker_b].omega - m[a.linker_a].omega);
    // tau_i = -gen G_i with G_A = -w, G_B = +w.
    torque[a.linker_a] += gen * g.w;
    torque[a.linker_b] -= gen * g.w;
  }

  for (const CompliantDihedral& d : cluster.dihedrals) {
    const DihedralGeom g = dihedral_geom(m[d.linker].u, outward_axis(m[d.nb0].u, d.nb0_end),
                                         outward_axis(m[d.nb1].u, d.nb1_end));
    if (!g.valid) continue;
    double gen = p.k_omega * wrap_angle(g.phi - d.phi0);
    if (damping) {
      gen += p.c_omega * (g.g0.dot(m[d.nb0].omega) + g.g1.dot(m[d.nb1].omega) + g.gu.dot(m[d.linker].omega));
    }
    torque[d.nb0] -= gen * g.g0;
    torque[d.nb1] -= gen * g.g1;
    torque[d.linker] -= gen * g.gu;
  }
}

double compliant_potential(const CompliantCluster& cluster, const std::vector<BodyMotion>& m) {
  const CompliantParams& p = cluster.params;
  double u_bond = 0.0, u_rot = 0.0;
  for (const CompliantBond& b : cluster.bonds) {
    const Vec3 r = sign_of_end(b.end) * target_reach(cluster.bodies[b.linker], cluster.bodies[b.sphere],
                                                     p.target_gap) * m[b.linker].u;
    u_bond += (m[b.sphere].x - m[b.linker].x - r).squaredNorm();
  }
  for (const CompliantAngle& a : cluster.angles) {
    const AngleGeom g = angle_geom(outward_axis(m[a.linker_a].u, a.end_a), outward_axis(m[a.linker_b].u, a.end_b));
    u_rot += (g.theta - a.theta0) * (g.theta - a.theta0);
  }
  for (const CompliantDihedral& d : cluster.dihedrals) {
    const DihedralGeom g = dihedral_geom(m[d.linker].u, outward_axis(m[d.nb0].u, d.nb0_end),
                                         outward_axis(m[d.nb1].u, d.nb1_end));
    if (!g.valid) continue;
    const double dev = wrap_angle(g.phi - d.phi0);
    u_rot += dev * dev;
  }
  return 0.5 * p.k * u_bond + 0.5 * p.k_omega * u_rot;
}

double potential_energy(const CompliantCluster& cluster) {
  return compliant_potential(cluster, body_motions(cluster));
}

double kinetic_energy(const CompliantCluster& cluster) {
  double e = 0.0;
  for (const CompliantBody& b : cluster.bodies) {
    // Spheres' spin is constant (no load turns a smooth sphere) but counted.
    e += 0.5 * b.mass * b.v.squaredNorm() + 0.5 * b.omega.dot(b.angular_momentum());
  }
  return e;
}

Vec3 total_momentum(const CompliantCluster& cluster) {
  Vec3 p = Vec3::Zero();
  for (const CompliantBody& b : cluster.bodies) p += b.mass * b.v;
  return p;
}

Vec3 total_angular_momentum(const CompliantCluster& cluster) {
  Vec3 l = Vec3::Zero();
  for (const CompliantBody& b : cluster.bodies) {
    l += b.mass * b.x.cross(b.v) + b.angular_momentum();
  }
  return l;
}

double term_angle(const CompliantCluster& cluster, const CompliantAngle& a) {
  return angle_geom(outward_axis(cluster.bodies[a.linker_a].axis(), a.end_a),
                    outward_axis(cluster.bodies[a.linker_b].axis(), a.end_b))
      .theta;
}

double term_dihedral(const CompliantCluster& cluster, const CompliantDihedral& d) {
  return dihedral_geom(cluster.bodies[d.linker].axis(), outward_axis(cluster.bodies[d.nb0].axis(), d.nb0_end),
                       outward_axis(cluster.bodies[d.nb1].axis(), d.nb1_end))
      .phi;
}

Vec3 term_bond_vector(const CompliantCluster& cluster, const CompliantBond& b) {
  const CompliantBody& s = cluster.bodies[b.sphere];
  const CompliantBody& l = cluster.bodies[b.linker];
  return s.x - l.x - sign_of_end(b.end) * target_reach(l, s, cluster.params.target_gap) * l.axis();
}

}  // namespace ringsim
