#include "core/scene.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "core/cell_grid.hpp"
#include "core/geometry.hpp"
#include "core/motion.hpp"
#include "core/prediction.hpp"
#include "core/rng.hpp"
#include "core/shapes.hpp"

namespace ringsim {

Species make_species(Shape shape, const SimParams& p) {
  const GeometryParams& g = p.geometry;
  const ContactParams& c = p.contact;
  Species s{};
  s.shape = shape;
  if (shape == Shape::Sphere) {
    const MassProps m = sphere_mass_props(g.sphere_radius, g.density);
    s.radius = g.sphere_radius;
    s.half_length = 0.0;
    s.bounding_radius = g.sphere_radius;
    s.mass = m.mass;
    s.i_axial = m.i_axial;
    s.i_perp = m.i_perp;
    s.restitution = c.restitution_sphere;
    s.static_friction = c.static_friction_sphere;
    s.dynamic_friction = c.dynamic_friction_sphere;
  } else {
    const MassProps m = cylinder_mass_props(g.linker_radius, g.linker_length, g.density);
    s.radius = g.linker_radius;
    s.half_length = 0.5 * g.linker_length;
    s.bounding_radius = cylinder_bounding_radius(g.linker_radius, g.linker_length);
    s.mass = m.mass;
    s.i_axial = m.i_axial;
    s.i_perp = m.i_perp;
    s.restitution = c.restitution_linker;
    s.static_friction = c.static_friction_linker;
    s.dynamic_friction = c.dynamic_friction_linker;
  }
  return s;
}

namespace {

double solid_volume(const Species& s) {
  return s.shape == Shape::Sphere ? 4.0 / 3.0 * M_PI * std::pow(s.radius, 3) : M_PI * s.radius * s.radius * 2.0 * s.half_length;
}

// Incremental hard-body placement against a cell grid of the placed bodies.
class Placer {
 public:
  Placer(const SimParams& p, BodyStore& b, double margin)
      : p_(p), b_(b), box_{p.geometry.box_length, p.geometry.boundary == Boundary::Periodic}, margin_(margin) {
    double rmax = std::max(b.species[0].bounding_radius, b.species[1].bounding_radius);
    grid_ = CellGrid(box_.length, 2.0 * rmax + margin, b.size(), box_.periodic);
  }

  // Can body i sit at centre x with axis u?
  bool fits(int i, const Vec3& x, const Vec3& u) const {
    const Species& s = b_.sp(i);
    if (!box_.periodic) {
      for (int d = 0; d < 3; ++d) {
        Vec3 e = Vec3::Zero();
        e[d] = 1.0;
        const double ext = s.shape == Shape::Sphere ? s.radius : geom::cylinder_support({x, u, s.radius, s.half_length}, e);
        if (x[d] - ext < margin_ || x[d] + ext > box_.length - margin_) return false;
      }
    }
    bool ok = true;
    grid_.for_each_near(grid_.locate(x), [&](int j) {
      if (!ok) return;
      const Species& t = b_.sp(j);
      const Vec3 xj = x + box_.min_image(b_.kin[j].x - x);
      const double reach = s.bounding_radius + t.bounding_radius + margin_;
      if ((xj - x).squaredNorm() >= reach * reach) return;
      double d;
      if (s.shape == Shape::Sphere && t.shape == Shape::Sphere) d = (xj - x).norm() - s.radius - t.radius;
      else if (s.shape == Shape::Sphere) d = geom::sphere_cylinder(x, s.radius, {xj, b_.kin[j].axis, t.radius, t.half_length}).distance;
      else if (t.shape == Shape::Sphere) d = geom::sphere_cylinder(xj, t.radius, {x, u, s.radius, s.half_length}).distance;
      else d = geom::cylinder_cylinder({x, u, s.radius, s.half_length}, {xj, b_.kin[j].axis, t.radius, t.half_length}).distance;
      if (d <= margin_) ok = false;
    });
    return ok;
  }

  void place(int i, const Vec3& x, const Vec3& u) {
    b_.kin[i].x = x;
    b_.kin[i].axis = u;
    grid_.insert(i, x);
    volume_ += solid_volume(b_.sp(i));
  }
  double volume() const { return volume_; }

 private:
  const SimParams& p_;
  BodyStore& b_;
  Box box_;
  double margin_;
  CellGrid grid_;
  double volume_ = 0.0;
};

struct Region {
  Vec3 lo, hi;  // admissible centre range
};

}  // namespace

void check_scene_packing(const SimParams& p) {
  const int ns = p.init.spheres, nl = p.init.linkers;
  const double L = p.geometry.box_length;
  const double requested =
      (ns * solid_volume(make_species(Shape::Sphere, p)) + nl * solid_volume(make_species(Shape::Linker, p))) /
      (L * L * L);
  // Random packings of hard convex bodies jam well below space filling; this
  // bound is generous (random close packing of spheres is ~0.64).
  constexpr double kMaxPacking = 0.64;
  if (requested > kMaxPacking) {
    char msg[400];
    std::snprintf(msg, sizeof msg,
                  "cannot place init.spheres = %d spheres and init.linkers = %d linkers in a box of edge "
                  "geometry.box_length = %g: their solid volume is a packing fraction %.4g of the box, which must be "
                  "<= %.2g (random close packing). Use fewer bodies or a larger geometry.box_length.",
                  ns, nl, L, requested, kMaxPacking);
    throw SceneError(msg);
  }
}

BodyStore build_scene(const SimParams& p, std::uint64_t seed, std::uint64_t replicate, SceneReport* report) {
  check_scene_packing(p);
  const int ns = p.init.spheres, nl = p.init.linkers, n = ns + nl;
  const double L = p.geometry.box_length;
  BodyStore b;
  b.species[0] = make_species(Shape::Sphere, p);
  b.species[1] = make_species(Shape::Linker, p);
  b.kin.assign(n, make_kinematics(Vec3::Zero(), Vec3::Zero(), Vec3(0, 0, 1)));
  b.shape.assign(n, Shape::Sphere);
  for (int i = ns; i < n; ++i) b.shape[i] = Shape::Linker;
  b.counter.assign(n, 0);
  b.last_collision.assign(n, -kNever);

  const double box_volume = L * L * L;
  const double requested = (ns * solid_volume(b.species[0]) + nl * solid_volume(b.species[1])) / box_volume;

  const bool periodic = p.geometry.boundary == Boundary::Periodic;
  const double margin = 10.0 * p.run.contact_tolerance;  // start clear of the contact band
  Placer placer(p, b, margin);
  Rng rng(seed, replicate, Stream::Placement);
  Rng grid_rng(seed, replicate, Stream::PlacementGrid);

  auto region_of = [&](const Species& s, bool routed_to_own_half) {
    // Centre ranges: reflective walls need the bounding radius only as a first
    // filter (fits() checks the exact solid); periodic boxes wrap.
    const double lo = periodic ? 0.0 : std::min(s.radius, 0.5 * L);
    const double hi = periodic ? L : L - lo;
    Region r{Vec3::Constant(lo), Vec3::Constant(hi)};
    if (routed_to_own_half) {
      if (s.shape == Shape::Sphere) r.hi.x() = std::min(r.hi.x(), 0.5 * L);
      else r.lo.x() = std::max(r.lo.x(), 0.5 * L);
    }
    return r;
  };
  auto draw_in = [&](const Region& r) {
    return Vec3(rng.uniform(r.lo.x(), r.hi.x()), rng.uniform(r.lo.y(), r.hi.y()), rng.uniform(r.lo.z(), r.hi.z()));
  };

  // Lattice fallback, one per (species, routing) region, built on first use.
  struct Lattice { std::vector<Vec3> sites; std::size_t next = 0; bool built = false; };
  Lattice lattices[2][2];
  auto lattice_site = [&](const Species& s, int species, bool own, Vec3* out) -> bool {
    Lattice& lat = lattices[species][own];
    if (!lat.built) {
      const Region r = region_of(s, own);
      // A fine jittered grid (a quarter of the body's bounding diameter) finds
      // the holes random placement leaves; a site that fails once stays
      // blocked (bodies are only added), so one pass over the shuffled sites
      // suffices for all bodies of the region.
      const double a = 0.5 * s.bounding_radius;
      for (double x = r.lo.x() + 0.5 * a; x < r.hi.x(); x += a)
        for (double y = r.lo.y() + 0.5 * a; y < r.hi.y(); y += a)
          for (double z = r.lo.z() + 0.5 * a; z < r.hi.z(); z += a)
            lat.sites.emplace_back(std::min(x + a * (grid_rng.uniform() - 0.5), r.hi.x()),
                                   std::min(y + a * (grid_rng.uniform() - 0.5), r.hi.y()),
                                   std::min(z + a * (grid_rng.uniform() - 0.5), r.hi.z()));
      for (std::size_t k = lat.sites.size(); k > 1; --k) std::swap(lat.sites[k - 1], lat.sites[grid_rng.below(k)]);
      lat.built = true;
    }
    if (lat.next >= lat.sites.size()) return false;
    *out = lat.sites[lat.next++];
    return true;
  };

  int fallback = 0;
  // Linkers first: the larger bodies are the harder ones to fit.
  std::vector<int> order;
  for (int i = ns; i < n; ++i) order.push_back(i);
  for (int i = 0; i < ns; ++i) order.push_back(i);
  int placed = 0;
  for (int i : order) {
    const Species& s = b.sp(i);
    const int species = static_cast<int>(s.shape);
    const bool own = rng.uniform() >= p.init.alpha;  // probability 1 - alpha: own half
    const Region region = region_of(s, own);
    bool done = false;
    // Once rejection has failed in a region, it stays inefficient there (the
    // region only fills up): later bodies go straight to the grid.
    const int trials = lattices[species][own].built ? 0 : kRejectionTrials;
    for (int trial = 0; trial < trials && !done; ++trial) {
      const Vec3 x = draw_in(region);
      const Vec3 u = s.shape == Shape::Linker ? rng.unit_vector() : Vec3(0, 0, 1);
      if (placer.fits(i, x, u)) {
        placer.place(i, x, u);
        done = true;
      }
    }
    Vec3 site;
    while (!done && lattice_site(s, species, own, &site)) {
      for (int k = 0; k < 16 && !done; ++k) {
        const Vec3 u = s.shape == Shape::Linker ? rng.unit_vector() : Vec3(0, 0, 1);
        if (placer.fits(i, site, u)) {
          placer.place(i, site, u);
          done = true;
          ++fallback;
        }
      }
    }
    if (!done) {
      char msg[320];
      std::snprintf(msg, sizeof msg,
                    "cannot place the initial scene: placed %d of %d bodies (%d spheres, %d linkers requested) in a box of "
                    "edge %g; packing fraction reached %.4g of the %.4g requested. Use fewer bodies or a larger "
                    "geometry.box_length.",
                    placed, n, ns, nl, L, placer.volume() / box_volume, requested);
      throw SceneError(msg);
    }
    ++placed;
  }

  // Velocities, independent of positions.
  Rng vr(seed, replicate, Stream::Velocities);
  const InitParams& in = p.init;
  for (int i = 0; i < n; ++i) {
    Kinematics& k = b.kin[i];
    const Species& s = b.sp(i);
    Vec3 v, w;
    if (in.velocity == VelocityInit::Uniform) {
      for (int d = 0; d < 3; ++d) v[d] = vr.uniform(-in.v_max, in.v_max);
      for (int d = 0; d < 3; ++d) w[d] = vr.uniform(-in.omega_max, in.omega_max);
    } else {
      const double sv = std::sqrt(in.temperature / s.mass);
      for (int d = 0; d < 3; ++d) v[d] = sv * vr.normal();
      // Principal frame: axis u and two transverse directions.
      const Vec3 u = k.axis;
      const Vec3 e1 = (std::abs(u.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(u).normalized();
      const Vec3 e2 = u.cross(e1);
      w = std::sqrt(in.temperature / s.i_axial) * vr.normal() * u + std::sqrt(in.temperature / s.i_perp) * vr.normal() * e1 +
          std::sqrt(in.temperature / s.i_perp) * vr.normal() * e2;
    }
    k.v = v;
    set_angular_velocity(k, s, w);
  }

  if (report) {
    report->packing_fraction = placer.volume() / box_volume;
    report->mixing = mixing_fraction(b, L, periodic);
    report->fallback_placements = fallback;
  }
  return b;
}

double mixing_fraction(const BodyStore& b, double box_length, bool periodic) {
  const int n = b.size();
  if (n < 2) return 0.0;
  const Box box{box_length, periodic};
  // Grid with about two bodies per cell; search shells of cells outwards until
  // the nearest candidate is provably nearest.
  const int m = std::max(1, std::min(static_cast<int>(std::cbrt(n / 2.0)), 1024));
  const double w = box_length / m;
  std::vector<std::vector<int>> cells(static_cast<std::size_t>(m) * m * m);
  auto cidx = [&](int a, int c, int d) { return (static_cast<std::size_t>(a) * m + c) * m + d; };
  auto coord = [&](double v) { return std::clamp(static_cast<int>(std::floor(v / w)), 0, m - 1); };
  for (int i = 0; i < n; ++i) cells[cidx(coord(b.kin[i].x[0]), coord(b.kin[i].x[1]), coord(b.kin[i].x[2]))].push_back(i);
  int cross = 0;
  for (int i = 0; i < n; ++i) {
    const Vec3& x = b.kin[i].x;
    const int c0[3] = {coord(x[0]), coord(x[1]), coord(x[2])};
    double best = std::numeric_limits<double>::infinity();
    int nearest = -1;
    for (int shell = 0; shell <= m; ++shell) {
      // Anything in shell s is at least (s - 1) w away.
      if (nearest >= 0 && (shell - 1) * w > std::sqrt(best)) break;
      for (int a = -shell; a <= shell; ++a)
        for (int c = -shell; c <= shell; ++c)
          for (int d = -shell; d <= shell; ++d) {
            if (std::max({std::abs(a), std::abs(c), std::abs(d)}) != shell) continue;
            int ia = c0[0] + a, ic = c0[1] + c, id = c0[2] + d;
            if (periodic) {  // wrapped shells may revisit cells: harmless for a minimum
              ia = ((ia % m) + m) % m; ic = ((ic % m) + m) % m; id = ((id % m) + m) % m;
            } else if (ia < 0 || ic < 0 || id < 0 || ia >= m || ic >= m || id >= m) {
              continue;
            }
            for (int j : cells[cidx(ia, ic, id)]) {
              if (j == i) continue;
              const double d2 = box.min_image(b.kin[j].x - x).squaredNorm();
              if (d2 < best || (d2 == best && j < nearest)) {
                best = d2;
                nearest = j;
              }
            }
          }
    }
    if (nearest >= 0 && b.shape[nearest] != b.shape[i]) ++cross;
  }
  return static_cast<double>(cross) / n;
}

}  // namespace ringsim
