#pragma once
// The bond graph G_t and the study's observables (MODEL.md, "Observables"),
// kept up to date bond by bond.
//
// Vertices are body ids: spheres 0..N_S-1, then linkers N_S..N_S+N_L-1.
// Every edge (bond) joins a sphere and one end of a linker (0 = a, 1 = b), so
// the graph is bipartite. A linker end carries at most one bond; a sphere
// any number (the caller enforces the valency v_S). Bonds are irreversible:
// they are only added, which is why union-find is enough.
//
// Definitions (MODEL.md, "Observables"):
//  - object: a connected component; N_t counts them, monomers included;
//  - target: a component that is one simple cycle alternating S and L with
//    exactly 4 S and 4 L. Tested as: 4 spheres, 4 linkers, 8 bonds and no
//    vertex of degree > 2 (8 vertices and 8 edges with every degree <= 2
//    force every degree to be 2, i.e. one 8-cycle);
//  - non-viable: NV1 a vertex of degree > 2; NV2 a closed ring whose number
//    of spheres m != 4 (see "rings"); NV3 more than 4 spheres or more than 4
//    linkers. A component may have several reasons; n_nv1..n_nv3 count each
//    separately. All other components (monomers and targets included) are
//    viable.
//  - rings: a bond whose two vertices are already in the same component
//    closes one ring. Its length is the shortest path between them before
//    the bond, plus one (even, as the graph is bipartite); it has m = length/2
//    spheres. m = 2 is two linkers bridging the same two spheres, m = 1 one
//    linker with both ends on one sphere (both need a capture distance far
//    above the default, and the filters off or their windows wide: seen at
//    r_c >= 2, m = 2 also with both filters at +-45 degrees and r_c = 3.9;
//    m = 1 passes the angle filter only if theta = 180 is in its window);
//    they are counted in their own bins and are NV2, but not in N_cyc.
//    Rings are never opened, so N_m "at the final time" is the running
//    count. N_cyc = sum_{m >= 3} N_m, S4 = N_4 / N_cyc, undefined
//    (std::nullopt, never 0) when N_cyc = 0.
//    Exactness: a component has exactly (edges - vertices + 1) recorded rings.
//    With the default valencies (v_S = 2, one bond per linker end) degrees
//    never exceed 2, every component is a path or a simple cycle, and the
//    rings are exactly the simple cycles. With raised valencies the rings are
//    a cycle basis chosen greedily by shortest path at closure time, which
//    depends on the bond order; a component with degree > 2 can contain
//    simple cycles that are not recorded. Example: two squares sharing a
//    sphere-linker-sphere path record rings m = 4 and m = 4, while the outer
//    12-cycle (m = 6) is not recorded; that component is NV1 and NV3 but not
//    counted in n_nv2. Recorded rings are always true simple cycles, and a
//    component without a vertex of degree > 2 has at most one cycle, which
//    is recorded exactly; so viability, N_viab and N_tar are exact for every
//    valency, and only n_nv2 on NV1 components can under-count.
//  - M_mono = (monomeric spheres + monomeric linkers) / (N_S + N_L).
//    Species parts share the same denominator, so they add up to M_mono:
//    M_mono_S = monomeric spheres / (N_S + N_L), M_mono_L = monomeric
//    linkers / (N_S + N_L). The raw counts n_mono_S, n_mono_L are reported
//    too, for per-species fractions (n_mono_S / N_S, n_mono_L / N_L).
//  - tau_tar: the time of the bond after which N_tar first became >= 1; if
//    none, t_end, flagged as right-censored.
//
// Invariants (after every add_bond):
//  - parent_ is a union-find forest (union by size); each root holds its
//    component's aggregates (spheres, linkers, bonds, vertices of degree > 2,
//    recorded rings with m != 4), exact;
//  - every running total (N_t, N_tar, N_viab, n_nv1..3, monomers, rings)
//    equals the sum over components of the classification of their
//    aggregates: a bond subtracts the classification of the component(s) it
//    touches and adds that of the result.
// Cost of add_bond: O(alpha(N)), except a bond closing a ring, which runs a
// breadth-first search inside its component (components are small).
// validate() recomputes everything with observables_from_scratch (heavy,
// for the validation mode and tests).

#include <array>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace ringsim {

// Counts of closed rings by number of spheres m.
struct RingHistogram {
  static constexpr int kMinBinned = 3;
  static constexpr int kMaxBinned = 12;
  std::array<int, kMaxBinned - kMinBinned + 1> by_size{};  // m = 3..12
  int overflow = 0;  // m > 12
  int small = 0;     // m < 3 (m = 1, 2); NV2, not in N_cyc

  void add(int m);
  int count(int m) const;  // N_m for m in 3..12; 0 otherwise (see overflow, small)
  int cycles() const;      // N_cyc = sum over m >= 3
};

struct Observables {
  int N_t = 0;     // objects (connected components, monomers included)
  int N_tar = 0;   // targets
  int N_viab = 0;  // viable objects
  int N_cyc = 0;   // rings with m >= 3
  int n_nv1 = 0, n_nv2 = 0, n_nv3 = 0;  // objects with each non-viability reason
  std::map<int, int> rings;  // m -> N_m, every m present (m < 3 too)
  RingHistogram histogram;   // the same rings in fixed bins (for tables)
  double Phi_obj = 0.0;   // N_tar / N_t (fraction, not percent)
  double Phi_viab = 0.0;  // N_viab / N_t
  std::optional<double> S4;  // N_4 / N_cyc; nullopt when N_cyc == 0
  double M_mono = 0.0;    // (n_mono_S + n_mono_L) / (N_S + N_L)
  double M_mono_S = 0.0;  // n_mono_S / (N_S + N_L)
  double M_mono_L = 0.0;  // n_mono_L / (N_S + N_L)
  int n_mono_S = 0, n_mono_L = 0;  // monomeric spheres, linkers
  double tau_tar = 0.0;   // first time N_tar >= 1, or t_end if censored
  bool tau_tar_censored = true;
  int bonds = 0;
};

// One bond: sphere and linker are body ids, end 0 = a, 1 = b, t = time formed.
struct Bond {
  int sphere = -1;
  int linker = -1;
  int end = 0;
  double t = 0.0;
};

// A linker end bonded to a sphere (linker as a body id).
struct BondedEnd {
  int linker = -1;
  int end = 0;
};

class BondGraph {
 public:
  // Throws std::invalid_argument if a count is negative or both are 0.
  BondGraph(int n_spheres, int n_linkers);

  int n_spheres() const { return n_s_; }
  int n_linkers() const { return n_l_; }
  int n_bodies() const { return n_s_ + n_l_; }
  bool is_sphere(int v) const { return v < n_s_; }

  // Adds the bond sphere--(linker, end) at time t. Preconditions (asserted):
  // valid ids, end in {0, 1}, the end is free. The sphere's valency is the
  // caller's to enforce.
  void add_bond(int sphere, int linker, int end, double t);

  int degree(int v) const;
  bool end_bonded(int linker, int end) const { return sphere_of(linker, end) >= 0; }
  int sphere_of(int linker, int end) const;  // -1 if free
  const std::vector<BondedEnd>& linkers_of(int sphere) const { return sphere_adj_[sphere]; }
  // Contact exclusions (MODEL.md, "Contacts"): i and j (body ids, spheres
  // first) are bonded to each other (1-2), or, with one_three, bonded to a
  // common partner (1-3: two linkers on one sphere, two spheres on one
  // linker). ringsim (Simulation::contact_excluded) and the Bullet peer.
  bool excluded(int i, int j, bool one_three) const;

  int component(int v) const;  // representative (root); no path compression
  bool same_component(int a, int b) const { return component(a) == component(b); }
  int component_size(int v) const { return agg_[component(v)].spheres + agg_[component(v)].linkers; }

  // Totals for "no further bond possible": free bond slots on spheres given
  // the valency (spheres above it count 0), O(valency); free linker ends, O(1).
  int free_sphere_slots(int sphere_valency) const;
  int free_ends() const { return 2 * n_l_ - static_cast<int>(bonds_.size()); }

  int N_t() const { return n_t_; }
  int N_tar() const { return n_tar_; }
  int N_viab() const { return n_viab_; }
  int bond_count() const { return static_cast<int>(bonds_.size()); }
  // Time at which N_tar first became >= 1; nullopt if not yet.
  std::optional<double> first_target_time() const { return tau_tar_; }

  // All observables at the final time t_end. O(number of distinct ring sizes).
  Observables observables(double t_end) const;

  // (sphere, linker) in creation order, for snapshots; bond_log() adds ends and times.
  std::vector<std::pair<int, int>> bonds() const;
  const std::vector<Bond>& bond_log() const { return bonds_; }

  // Heavy check: compares every running total with observables_from_scratch
  // on the bond log and the union-find with a fresh labelling. Returns an
  // empty string when consistent, else a description of the first mismatch.
  std::string validate() const;

 private:
  // Per-component aggregates, valid at the root only.
  struct Aggregate {
    int spheres = 0;
    int linkers = 0;
    int edges = 0;
    int high_degree = 0;  // vertices with degree > 2
    int bad_rings = 0;    // recorded rings with m != 4
  };
  struct Class {
    bool target, nv1, nv2, nv3;
    bool viable() const { return !nv1 && !nv2 && !nv3; }
  };
  static Class classify(const Aggregate& a);
  void tally(const Aggregate& a, int sign);
  int find(int v);
  // Shortest path length from sphere to linker vertex inside their component
  // (before the new bond), by breadth-first search.
  int shortest_path(int sphere, int linker_vertex);
  void raise_degree(int v, Aggregate& root_agg);

  int n_s_ = 0, n_l_ = 0;
  // Adjacency: linkers of each sphere; the sphere at each linker end.
  std::vector<std::vector<BondedEnd>> sphere_adj_;
  std::vector<std::array<int, 2>> linker_ends_;  // index linker - N_S
  std::vector<int> degree_;
  std::vector<int> sphere_degree_count_;  // number of spheres with each degree
  // Union-find.
  std::vector<int> parent_;
  std::vector<Aggregate> agg_;
  // Running totals.
  int n_t_ = 0, n_tar_ = 0, n_viab_ = 0;
  int n_nv1_ = 0, n_nv2_ = 0, n_nv3_ = 0;
  int n_mono_s_ = 0, n_mono_l_ = 0;
  std::map<int, int> rings_;
  RingHistogram histogram_;
  std::optional<double> tau_tar_;
  std::vector<Bond> bonds_;
  // Breadth-first-search scratch, reused (stamped, never cleared).
  std::vector<unsigned> seen_;
  std::vector<int> dist_;
  std::vector<int> queue_;
  unsigned stamp_ = 0;
};

// Slow, obviously correct reference for tests and validate(): replays the
// bonds on plain adjacency lists, finds each ring by a breadth-first search of
// the graph so far, labels components by breadth-first search over the whole
// graph, and recomputes N_tar after every bond for tau_tar. Bonds must satisfy
// add_bond's preconditions.
Observables observables_from_scratch(int n_spheres, int n_linkers, const std::vector<Bond>& bonds,
                                     double t_end);

// Field-by-field comparison (exact, doubles included: both sides compute the
// fractions by the same expressions from the same integers). Empty string when
// equal, else the first differing field with both values.
std::string diff_observables(const Observables& a, const Observables& b);

}  // namespace ringsim
