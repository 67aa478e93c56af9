#include "core/bond_graph.hpp"

#include <algorithm>
#include <cassert>
#include <sstream>
#include <stdexcept>

namespace ringsim {

// ---- RingHistogram -------------------------------------------------------------

void RingHistogram::add(int m) {
  if (m < kMinBinned) {
    ++small;
  } else if (m > kMaxBinned) {
    ++overflow;
  } else {
    ++by_size[m - kMinBinned];
  }
}

int RingHistogram::count(int m) const {
  return (m < kMinBinned || m > kMaxBinned) ? 0 : by_size[m - kMinBinned];
}

int RingHistogram::cycles() const {
  int n = overflow;
  for (int c : by_size) n += c;
  return n;
}

// ---- BondGraph -------------------------------------------------------------------

BondGraph::BondGraph(int n_spheres, int n_linkers) : n_s_(n_spheres), n_l_(n_linkers) {
  if (n_spheres < 0 || n_linkers < 0 || n_spheres + n_linkers == 0) {
    throw std::invalid_argument("BondGraph: N_S = " + std::to_string(n_spheres) +
                                ", N_L = " + std::to_string(n_linkers) +
                                ": counts must be >= 0 with at least one body");
  }
  const int n = n_s_ + n_l_;
  sphere_adj_.resize(n_s_);
  linker_ends_.assign(n_l_, {-1, -1});
  degree_.assign(n, 0);
  sphere_degree_count_.assign(1, n_s_);
  parent_.resize(n);
  agg_.resize(n);
  for (int v = 0; v < n; ++v) {
    parent_[v] = v;
    if (is_sphere(v)) {
      agg_[v].spheres = 1;
    } else {
      agg_[v].linkers = 1;
    }
    tally(agg_[v], +1);
  }
  seen_.assign(n, 0);
  dist_.assign(n, 0);
  queue_.reserve(n);
}

BondGraph::Class BondGraph::classify(const Aggregate& a) {
  Class c{};
  c.nv1 = a.high_degree > 0;
  c.nv2 = a.bad_rings > 0;
  c.nv3 = a.spheres > 4 || a.linkers > 4;
  // 8 vertices, 8 edges, all degrees <= 2 and connected: one 8-cycle, and
  // bipartite, so it alternates S and L.
  c.target = a.spheres == 4 && a.linkers == 4 && a.edges == 8 && a.high_degree == 0;
  return c;
}

void BondGraph::tally(const Aggregate& a, int sign) {
  const Class c = classify(a);
  n_t_ += sign;
  n_tar_ += sign * c.target;
  n_viab_ += sign * c.viable();
  n_nv1_ += sign * c.nv1;
  n_nv2_ += sign * c.nv2;
  n_nv3_ += sign * c.nv3;
  if (a.spheres + a.linkers == 1) {
    n_mono_s_ += sign * a.spheres;
    n_mono_l_ += sign * a.linkers;
  }
}

int BondGraph::find(int v) {
  while (parent_[v] != v) {
    parent_[v] = parent_[parent_[v]];  // path halving
    v = parent_[v];
  }
  return v;
}

int BondGraph::component(int v) const {
  while (parent_[v] != v) v = parent_[v];
  return v;
}

int BondGraph::degree(int v) const { return degree_[v]; }

bool BondGraph::excluded(int i, int j, bool one_three) const {
  const bool si = is_sphere(i), sj = is_sphere(j);
  if (si != sj) {  // 1-2: the sphere bonded to one of the linker's ends
    const int s = si ? i : j, l = si ? j : i;
    return sphere_of(l, 0) == s || sphere_of(l, 1) == s;
  }
  if (!one_three) return false;
  if (si) {  // 1-3: two spheres on one linker
    for (const auto& [l, e] : linkers_of(i))
      if (sphere_of(l, 1 - e) == j) return true;
    return false;
  }
  for (int e = 0; e < 2; ++e) {  // 1-3: two linkers on one sphere
    const int s = sphere_of(i, e);
    if (s >= 0 && (sphere_of(j, 0) == s || sphere_of(j, 1) == s)) return true;
  }
  return false;
}

int BondGraph::sphere_of(int linker, int end) const { return linker_ends_[linker - n_s_][end]; }

int BondGraph::free_sphere_slots(int sphere_valency) const {
  int slots = 0;
  const int top = std::min<int>(sphere_valency, static_cast<int>(sphere_degree_count_.size()));
  for (int d = 0; d < top; ++d) slots += (sphere_valency - d) * sphere_degree_count_[d];
  return slots;
}

void BondGraph::raise_degree(int v, Aggregate& root_agg) {
  const int d = ++degree_[v];
  if (d == 3) ++root_agg.high_degree;
  if (is_sphere(v)) {
    if (static_cast<int>(sphere_degree_count_.size()) <= d) sphere_degree_count_.resize(d + 1, 0);
    --sphere_degree_count_[d - 1];
    ++sphere_degree_count_[d];
  }
}

int BondGraph::shortest_path(int sphere, int linker_vertex) {
  if (++stamp_ == 0) {  // wrapped: clear once every 2^32 searches
    std::fill(seen_.begin(), seen_.end(), 0u);
    stamp_ = 1;
  }
  queue_.clear();
  queue_.push_back(sphere);
  seen_[sphere] = stamp_;
  dist_[sphere] = 0;
  for (std::size_t head = 0; head < queue_.size(); ++head) {
    const int v = queue_[head];
    auto visit = [&](int w) {
      if (seen_[w] == stamp_) return false;
      seen_[w] = stamp_;
      dist_[w] = dist_[v] + 1;
      queue_.push_back(w);
      return w == linker_vertex;
    };
    if (is_sphere(v)) {
      for (const BondedEnd& e : sphere_adj_[v]) {
        if (visit(e.linker)) return dist_[e.linker];
      }
    } else {
      for (int s : linker_ends_[v - n_s_]) {
        if (s >= 0 && visit(s)) return dist_[s];
      }
    }
  }
  assert(false && "shortest_path: vertices of one component are not connected");
  return -1;
}

void BondGraph::add_bond(int sphere, int linker, int end, double t) {
  assert(0 <= sphere && sphere < n_s_);
  assert(n_s_ <= linker && linker < n_s_ + n_l_);
  assert(end == 0 || end == 1);
  assert(linker_ends_[linker - n_s_][end] < 0);

  int root = find(sphere);
  const int other = find(linker);
  int ring_m = 0;
  if (root == other) {
    // Closes a ring: length = shortest path before the bond + 1 (even).
    const int d = shortest_path(sphere, linker);
    ring_m = (d + 1) / 2;
    tally(agg_[root], -1);
  } else {
    tally(agg_[root], -1);
    tally(agg_[other], -1);
    int small = other;
    const auto size = [&](int r) { return agg_[r].spheres + agg_[r].linkers; };
    if (size(root) < size(other)) std::swap(root, small);
    parent_[small] = root;
    Aggregate& a = agg_[root];
    const Aggregate& b = agg_[small];
    a.spheres += b.spheres;
    a.linkers += b.linkers;
    a.edges += b.edges;
    a.high_degree += b.high_degree;
    a.bad_rings += b.bad_rings;
  }

  Aggregate& a = agg_[root];
  ++a.edges;
  raise_degree(sphere, a);
  raise_degree(linker, a);
  if (ring_m > 0) {
    ++rings_[ring_m];
    histogram_.add(ring_m);
    if (ring_m != 4) ++a.bad_rings;
  }
  sphere_adj_[sphere].push_back({linker, end});
  linker_ends_[linker - n_s_][end] = sphere;
  tally(a, +1);

  bonds_.push_back({sphere, linker, end, t});
  if (!tau_tar_ && n_tar_ >= 1) tau_tar_ = t;
}

Observables BondGraph::observables(double t_end) const {
  Observables o;
  o.N_t = n_t_;
  o.N_tar = n_tar_;
  o.N_viab = n_viab_;
  o.n_nv1 = n_nv1_;
  o.n_nv2 = n_nv2_;
  o.n_nv3 = n_nv3_;
  o.rings = rings_;
  o.histogram = histogram_;
  o.N_cyc = histogram_.cycles();
  o.Phi_obj = static_cast<double>(n_tar_) / n_t_;
  o.Phi_viab = static_cast<double>(n_viab_) / n_t_;
  if (o.N_cyc > 0) o.S4 = static_cast<double>(histogram_.count(4)) / o.N_cyc;
  const double n = n_s_ + n_l_;
  o.n_mono_S = n_mono_s_;
  o.n_mono_L = n_mono_l_;
  o.M_mono = (n_mono_s_ + n_mono_l_) / n;
  o.M_mono_S = n_mono_s_ / n;
  o.M_mono_L = n_mono_l_ / n;
  o.tau_tar_censored = !tau_tar_.has_value();
  o.tau_tar = tau_tar_.value_or(t_end);
  o.bonds = static_cast<int>(bonds_.size());
  return o;
}

std::vector<std::pair<int, int>> BondGraph::bonds() const {
  std::vector<std::pair<int, int>> out;
  out.reserve(bonds_.size());
  for (const Bond& b : bonds_) out.emplace_back(b.sphere, b.linker);
  return out;
}

// ---- Reference -----------------------------------------------------------------------

namespace {

// Distances from `from` by breadth-first search; -1 where unreachable.
std::vector<int> bfs_distances(const std::vector<std::vector<int>>& adj, int from) {
  std::vector<int> dist(adj.size(), -1);
  std::vector<int> queue{from};
  dist[from] = 0;
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const int v = queue[head];
    for (int w : adj[v]) {
      if (dist[w] < 0) {
        dist[w] = dist[v] + 1;
        queue.push_back(w);
      }
    }
  }
  return dist;
}

struct ComponentStats {
  int spheres = 0, linkers = 0;
  bool all_degree_two = true;
  bool degree_above_two = false;
  bool wrong_ring = false;
};

// Labels components by breadth-first search; returns one record per component.
std::vector<ComponentStats> scan_components(const std::vector<std::vector<int>>& adj, int n_spheres,
                                            std::vector<int>* label_out) {
  const int n = static_cast<int>(adj.size());
  std::vector<int> label(n, -1);
  std::vector<ComponentStats> comps;
  for (int v0 = 0; v0 < n; ++v0) {
    if (label[v0] >= 0) continue;
    const int c = static_cast<int>(comps.size());
    comps.emplace_back();
    std::vector<int> queue{v0};
    label[v0] = c;
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const int v = queue[head];
      ComponentStats& s = comps[c];
      (v < n_spheres ? s.spheres : s.linkers) += 1;
      const int deg = static_cast<int>(adj[v].size());
      if (deg != 2) s.all_degree_two = false;
      if (deg > 2) s.degree_above_two = true;
      for (int w : adj[v]) {
        if (label[w] < 0) {
          label[w] = c;
          queue.push_back(w);
        }
      }
    }
  }
  if (label_out) *label_out = std::move(label);
  return comps;
}

// Connected with every degree 2 is a simple cycle; bipartite, so it alternates.
bool is_target(const ComponentStats& s) { return s.all_degree_two && s.spheres == 4 && s.linkers == 4; }

}  // namespace

Observables observables_from_scratch(int n_spheres, int n_linkers, const std::vector<Bond>& bonds,
                                     double t_end) {
  const int n = n_spheres + n_linkers;
  std::vector<std::vector<int>> adj(n);
  std::vector<std::pair<int, int>> ring_sphere_m;  // (a sphere on the ring, m)
  std::optional<double> tau;
  for (const Bond& b : bonds) {
    const std::vector<int> dist = bfs_distances(adj, b.sphere);
    if (dist[b.linker] >= 0) ring_sphere_m.emplace_back(b.sphere, (dist[b.linker] + 1) / 2);
    adj[b.sphere].push_back(b.linker);
    adj[b.linker].push_back(b.sphere);
    if (!tau) {
      const auto comps = scan_components(adj, n_spheres, nullptr);
      if (std::any_of(comps.begin(), comps.end(), is_target)) tau = b.t;
    }
  }

  std::vector<int> label;
  std::vector<ComponentStats> comps = scan_components(adj, n_spheres, &label);
  Observables o;
  for (const auto& [s, m] : ring_sphere_m) {
    ++o.rings[m];
    o.histogram.add(m);
    if (m != 4) comps[label[s]].wrong_ring = true;
    if (m >= 3) ++o.N_cyc;
  }
  o.N_t = static_cast<int>(comps.size());
  for (const ComponentStats& c : comps) {
    const bool nv1 = c.degree_above_two;
    const bool nv2 = c.wrong_ring;
    const bool nv3 = c.spheres > 4 || c.linkers > 4;
    o.n_nv1 += nv1;
    o.n_nv2 += nv2;
    o.n_nv3 += nv3;
    o.N_viab += !nv1 && !nv2 && !nv3;
    o.N_tar += is_target(c);
  }
  for (int v = 0; v < n; ++v) {
    if (adj[v].empty()) ++(v < n_spheres ? o.n_mono_S : o.n_mono_L);
  }
  o.Phi_obj = static_cast<double>(o.N_tar) / o.N_t;
  o.Phi_viab = static_cast<double>(o.N_viab) / o.N_t;
  const auto four = o.rings.find(4);
  if (o.N_cyc > 0) o.S4 = static_cast<double>(four == o.rings.end() ? 0 : four->second) / o.N_cyc;
  const double total = n;
  o.M_mono = (o.n_mono_S + o.n_mono_L) / total;
  o.M_mono_S = o.n_mono_S / total;
  o.M_mono_L = o.n_mono_L / total;
  o.tau_tar_censored = !tau.has_value();
  o.tau_tar = tau.value_or(t_end);
  o.bonds = static_cast<int>(bonds.size());
  return o;
}

std::string diff_observables(const Observables& a, const Observables& b) {
  std::ostringstream out;
  out.precision(17);
  auto field = [&](const char* name, const auto& x, const auto& y) {
    if (out.tellp() == 0 && !(x == y)) out << name << ": " << x << " vs " << y;
  };
  field("N_t", a.N_t, b.N_t);
  field("N_tar", a.N_tar, b.N_tar);
  field("N_viab", a.N_viab, b.N_viab);
  field("N_cyc", a.N_cyc, b.N_cyc);
  field("n_nv1", a.n_nv1, b.n_nv1);
  field("n_nv2", a.n_nv2, b.n_nv2);
  field("n_nv3", a.n_nv3, b.n_nv3);
  if (out.tellp() == 0 && a.rings != b.rings) {
    out << "rings:";
    for (const auto& [m, c] : a.rings) out << ' ' << m << ':' << c;
    out << " vs";
    for (const auto& [m, c] : b.rings) out << ' ' << m << ':' << c;
  }
  for (int m = RingHistogram::kMinBinned; m <= RingHistogram::kMaxBinned; ++m) {
    field("histogram bin", a.histogram.count(m), b.histogram.count(m));
  }
  field("histogram.overflow", a.histogram.overflow, b.histogram.overflow);
  field("histogram.small", a.histogram.small, b.histogram.small);
  field("Phi_obj", a.Phi_obj, b.Phi_obj);
  field("Phi_viab", a.Phi_viab, b.Phi_viab);
  field("S4 defined", a.S4.has_value(), b.S4.has_value());
  if (a.S4 && b.S4) field("S4", *a.S4, *b.S4);
  field("M_mono", a.M_mono, b.M_mono);
  field("M_mono_S", a.M_mono_S, b.M_mono_S);
  field("M_mono_L", a.M_mono_L, b.M_mono_L);
  field("n_mono_S", a.n_mono_S, b.n_mono_S);
  field("n_mono_L", a.n_mono_L, b.n_mono_L);
  field("tau_tar", a.tau_tar, b.tau_tar);
  field("tau_tar_censored", a.tau_tar_censored, b.tau_tar_censored);
  field("bonds", a.bonds, b.bonds);
  return out.str();
}

std::string BondGraph::validate() const {
  // Observables against the reference (t_end chosen past every bond).
  const double t_end = bonds_.empty() ? 0.0 : bonds_.back().t + 1.0;
  std::string diff = diff_observables(observables(t_end), observables_from_scratch(n_s_, n_l_, bonds_, t_end));
  if (!diff.empty()) return "observables differ from the reference: " + diff;

  // Union-find against a fresh labelling, and the aggregates at each root.
  const int n = n_s_ + n_l_;
  std::vector<std::vector<int>> adj(n);
  for (const Bond& b : bonds_) {
    adj[b.sphere].push_back(b.linker);
    adj[b.linker].push_back(b.sphere);
  }
  std::vector<int> label;
  const std::vector<ComponentStats> comps = scan_components(adj, n_s_, &label);
  std::vector<int> root_of_label(comps.size(), -1);
  std::vector<int> label_of_root(n, -1);
  std::vector<Aggregate> expect(n);
  for (int v = 0; v < n; ++v) {
    const int r = component(v);
    if (root_of_label[label[v]] < 0) root_of_label[label[v]] = r;
    if (label_of_root[r] < 0) label_of_root[r] = label[v];
    if (root_of_label[label[v]] != r) return "union-find splits the component of vertex " + std::to_string(v);
    if (label_of_root[r] != label[v]) return "union-find joins vertex " + std::to_string(v) + " to a foreign component";
    if (static_cast<int>(adj[v].size()) != degree_[v]) return "degree of vertex " + std::to_string(v);
    (is_sphere(v) ? expect[r].spheres : expect[r].linkers) += 1;
    expect[r].edges += static_cast<int>(adj[v].size());  // halved below
    expect[r].high_degree += adj[v].size() > 2;
  }
  for (int v = 0; v < n; ++v) {
    if (parent_[v] != v) continue;
    const Aggregate& a = agg_[v];
    const Aggregate& e = expect[v];
    if (a.spheres != e.spheres || a.linkers != e.linkers || 2 * a.edges != e.edges ||
        a.high_degree != e.high_degree) {
      return "aggregates of the component rooted at " + std::to_string(v);
    }
  }
  return {};
}

}  // namespace ringsim
