#include "core/cluster.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>

#include "core/motion.hpp"
#include "core/pose.hpp"

namespace ringsim {

namespace {

Vec3 wrap_into(Vec3 x, const Box& box) {
  if (box.periodic)
    for (int d = 0; d < 3; ++d) x[d] -= box.length * std::floor(x[d] / box.length);
  return x;
}

// World inertia tensor of one body about its own centre.
Mat3 body_inertia(const Species& s, const Vec3& u) {
  if (s.shape == Shape::Sphere) return s.i_perp * Mat3::Identity();
  const Mat3 uu = u * u.transpose();
  return s.i_perp * (Mat3::Identity() - uu) + s.i_axial * uu;
}

// One group (a free body or a cluster) at time t: its members with centres in
// one consistent image, its momentum, own angular momentum (about its centre
// of mass) and centre of mass.
struct Part {
  std::vector<int> members;
  std::vector<Vec3> x;
  std::vector<Vec3> u;
  Vec3 com;
  Vec3 momentum;
  Vec3 spin;  // angular momentum about com
  double mass;
};

Part part_of(const BodyStore& b, int i, double t) {
  Part p;
  const int g = b.group[i];
  if (g < 0) {
    const Species& s = b.sp(i);
    p.members = {i};
    p.x = {body_center(b, i, t)};
    p.u = {body_axis(b, i, t)};
    p.com = p.x[0];
    p.mass = s.mass;
    p.momentum = s.mass * b.kin[i].v;
    p.spin = angular_momentum(b.kin[i], s);
    return p;
  }
  const Cluster& c = b.clusters[g];
  p.members = c.members;
  for (int m : c.members) {
    p.x.push_back(body_center(b, m, t));
    p.u.push_back(body_axis(b, m, t));
  }
  p.com = c.x + c.v * (t - c.t);
  p.mass = c.mass;
  p.momentum = c.mass * c.v;
  p.spin = c.rot.angular_momentum();
  return p;
}

}  // namespace

namespace {
// R pulled back onto the rotations once it has drifted. Every restart takes
// the orientation reached by the old record as the new one, so rounding
// accumulates along a cluster's chain of impulses: ~5e-17 per restart for a
// nearly symmetric top such as a sphere-linker pair (5e-12 after 1e5;
// tests/test_free_rotation.cpp, RestartChainStaysOrthonormal). Members' axes
// are R times fixed unit vectors, and the geometry takes them as unit. Past
// 1e-13 (largest entry of R^T R - 1) one step of the first-order iteration
// towards the nearest orthogonal matrix, R (3 - R^T R) / 2, squares the
// error (Bjorck & Bowie, SIAM J. Numer. Anal. 8, 358, 1971); below it R is
// left as it is.
Mat3 keep_orthonormal(const Mat3& R) {
  const Mat3 E = R.transpose() * R;
  if ((E - Mat3::Identity()).cwiseAbs().maxCoeff() <= 1e-13) return R;
  return R * (1.5 * Mat3::Identity() - 0.5 * E);
}

// The cluster's record restarted at t with angular momentum L (world): its
// centre and orientation at t from the old record, a new FreeRotation.
void restart_cluster(Cluster& c, const Box& box, double t, const Vec3& L) {
  const Mat3 R = keep_orthonormal(c.orientation_at(t));
  c.x = wrap_into(c.x + c.v * (t - c.t), box);
  c.rot = FreeRotation(c.moments, R, L);
  c.t = t;
  c.cache_t = t;
  c.cache_R = R;
}
}  // namespace

void rebase_cluster(Cluster& c, const Box& box, double t) {
  if (t == c.t) return;
  restart_cluster(c, box, t, c.rot.angular_momentum());
}

void cluster_impulse(Cluster& c, const Box& box, double t, const Vec3& J, const Vec3& arm) {
  // Re-based and given the new angular momentum in one step: one FreeRotation
  // (its construction, ~2 us, is the costly part of an impulse on a cluster).
  restart_cluster(c, box, t, c.rot.angular_momentum() + arm.cross(J));
  c.v += J / c.mass;
  c.max_rate = c.rot.max_rate();
}

int merge_groups(BodyStore& b, const Box& box, int a, int other, double t, bool sphere_inertia) {
  Part pa = part_of(b, a, t);
  Part pb = part_of(b, other, t);
  // Put b's group in the periodic image nearest to a's centre of mass.
  const Vec3 shift = pa.com + box.min_image(pb.com - pa.com) - pb.com;
  pb.com += shift;
  for (Vec3& x : pb.x) x += shift;

  // Momentum and angular momentum (about the new centre of mass) are
  // conserved: the merge is a perfectly inelastic collision.
  const double mass = pa.mass + pb.mass;
  const Vec3 com = (pa.mass * pa.com + pb.mass * pb.com) / mass;
  const Vec3 momentum = pa.momentum + pb.momentum;
  const Vec3 velocity = momentum / mass;
  Vec3 L = Vec3::Zero();
  Mat3 inertia = Mat3::Zero();
  for (const Part* p : {&pa, &pb}) {
    L += p->spin + (p->com - com).cross(p->momentum - p->mass * velocity);
    for (std::size_t k = 0; k < p->members.size(); ++k) {
      const Species& s = b.sp(p->members[k]);
      const Vec3 r = p->x[k] - com;
      // Parallel-axis theorem: I_com = I_own + m (|r|^2 1 - r r^T).
      const Mat3 own = sphere_inertia || s.shape != Shape::Sphere ? body_inertia(s, p->u[k]) : Mat3::Zero();
      inertia += own + s.mass * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
    }
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(inertia);
  Mat3 axes = eig.eigenvectors();  // columns: principal axes (world)
  if (axes.determinant() < 0.0) axes.col(2) = -axes.col(2);

  for (const Part* p : {&pa, &pb}) {
    const int g = b.group[p->members[0]];
    if (g >= 0) {
      b.clusters[g].alive = false;
      b.clusters[g].members.clear();
      b.clusters[g].members.shrink_to_fit();
    }
  }
  Cluster c;
  c.t = t;
  c.x = wrap_into(com, box);
  c.v = velocity;
  c.mass = mass;
  c.moments = eig.eigenvalues();
  c.rot = FreeRotation(c.moments, axes, L);
  c.max_rate = c.rot.max_rate();
  c.alive = true;
  c.cache_t = t;
  c.cache_R = axes;
  const int id = static_cast<int>(b.clusters.size());
  for (const Part* p : {&pa, &pb}) {
    for (std::size_t k = 0; k < p->members.size(); ++k) {
      const int m = p->members[k];
      c.members.push_back(m);
      b.group[m] = id;
      b.offset[m] = axes.transpose() * (p->x[k] - com);
      b.body_axis[m] = axes.transpose() * p->u[k];
      b.reach[m] = b.offset[m].norm();
    }
  }
  b.clusters.push_back(std::move(c));
  return id;
}

double group_kinetic_energy(const BodyStore& b, int i) {
  if (const int g = b.group[i]; g >= 0) {
    const Cluster& c = b.clusters[g];
    return 0.5 * c.mass * c.v.squaredNorm() + c.rot.energy();
  }
  return translational_energy(b.kin[i], b.sp(i)) + rotational_energy(b.kin[i], b.sp(i));
}

MechanicalTotals mechanical_totals(const BodyStore& b, double t) {
  MechanicalTotals r;
  for (int i = 0; i < b.size(); ++i) {
    if (b.group[i] >= 0) continue;
    const Species& s = b.sp(i);
    if (b.cgroup[i] >= 0) {
      // A compliant member: its own motion on its slice's track.
      const Vec3 x = body_center(b, i, t), v = track_velocity(b.track[i], t), w = body_omega(b, i, t);
      const Vec3 p = s.mass * v;
      const Vec3 own = s.shape == Shape::Sphere ? Vec3(s.i_perp * w) : Vec3(body_inertia(s, body_axis(b, i, t)) * w);
      r.momentum += p;
      r.angular_momentum += x.cross(p) + own;
      r.translational += 0.5 * s.mass * v.squaredNorm();
      r.rotational += 0.5 * w.dot(own);
      r.p_scale += p.norm();
      r.l_scale += x.norm() * p.norm() + own.norm();
      continue;
    }
    Kinematics k = b.kin[i];
    advance(k, t);
    const Vec3 p = s.mass * k.v;
    const Vec3 own = angular_momentum(k, s);
    r.momentum += p;
    r.angular_momentum += k.x.cross(p) + own;
    r.translational += translational_energy(k, s);
    r.rotational += rotational_energy(k, s);
    r.p_scale += p.norm();
    r.l_scale += k.x.norm() * p.norm() + own.norm();
  }
  // Spheres' spins held aside by rigid compliant clusters (BodyStore).
  for (std::size_t i = 0; i < b.held_spin.size(); ++i) {
    const Vec3& w = b.held_spin[i];
    if (w.isZero(0.0)) continue;
    const Species& s = b.sp(static_cast<int>(i));
    r.angular_momentum += s.i_perp * w;
    r.rotational += 0.5 * s.i_perp * w.squaredNorm();
    r.l_scale += s.i_perp * w.norm();
  }
  for (const Cluster& c : b.clusters) {
    if (!c.alive) continue;
    const Vec3 x = c.x + c.v * (t - c.t);
    const Vec3 p = c.mass * c.v;
    const Vec3& own = c.rot.angular_momentum();
    r.momentum += p;
    r.angular_momentum += x.cross(p) + own;
    r.translational += 0.5 * c.mass * c.v.squaredNorm();
    r.rotational += c.rot.energy();
    r.p_scale += p.norm();
    r.l_scale += x.norm() * p.norm() + own.norm();
  }
  r.energy = r.translational + r.rotational;
  return r;
}

void snapshot_members(BodyStore& b, const Box& box, double t) {
  for (int i = 0; i < b.size(); ++i) {
    if (b.cgroup[i] >= 0) {
      const Vec3 x = body_center(b, i, t);
      Kinematics& k = b.kin[i];
      k.v = track_velocity(b.track[i], t);
      k.x = wrap_into(x, box);
      k.axis = body_axis(b, i, t);
      k.precession = body_omega(b, i, t);
      k.spin = 0.0;
      k.t = t;
      continue;
    }
    if (b.group[i] < 0) continue;
    const Cluster& c = b.clusters[b.group[i]];
    const Vec3 x = body_center(b, i, t);
    Kinematics& k = b.kin[i];
    k.v = shape_point_velocity(b, i, t, x, x);
    k.x = wrap_into(x, box);
    k.axis = body_axis(b, i, t);
    k.precession = c.rot.omega_world(t - c.t);
    k.spin = 0.0;
    k.t = t;
  }
}

}  // namespace ringsim
