// The neighbour grid's scans (core/cell_grid.hpp).

#include <gtest/gtest.h>

#include <map>
#include <random>
#include <set>

#include "core/cell_grid.hpp"

using namespace ringsim;

namespace {

// A grid of n cells per side (unit cells) big enough for `bodies`.
CellGrid grid_of(int n, int bodies, bool periodic) {
  CellGrid g(static_cast<double>(n), 1.0, bodies, periodic);
  EXPECT_EQ(g.cells_per_side(), n);
  return g;
}

}  // namespace

TEST(CellGrid, NearPairVisitsTheUnionOfBothNeighbourhoodsOnce) {
  std::mt19937_64 rng(11);
  for (const bool periodic : {true, false}) {
    for (const int n : {1, 2, 3, 4, 5, 7}) {
      const int bodies = 2 * n * n * n;
      CellGrid g = grid_of(n, bodies, periodic);
      std::uniform_real_distribution<double> u(0.0, n);
      for (int i = 0; i < bodies; ++i) g.insert(i, Vec3(u(rng), u(rng), u(rng)));
      auto near = [&](int c) {
        std::set<int> s;
        g.for_each_near(c, [&](int j) { EXPECT_TRUE(s.insert(j).second); });
        return s;
      };
      int merged = 0;
      for (int a = 0; a < n * n * n; ++a) {
        const auto ca = g.coords(a);
        for (int b = 0; b < n * n * n; ++b) {
          const auto cb = g.coords(b);
          bool adjacent = true;  // at most one cell apart along every axis
          for (int d = 0; d < 3; ++d) {
            int delta = std::abs(cb[d] - ca[d]);
            if (periodic) delta = std::min(delta, n - delta);
            adjacent = adjacent && delta <= 1;
          }
          std::map<int, int> seen;  // body -> bit 0: near a, bit 1: near b
          const bool ok = g.for_each_near_pair(a, b, [&](int j, bool near_a, bool near_b) {
            EXPECT_TRUE(near_a || near_b);
            EXPECT_EQ(seen.count(j), 0u) << "body " << j << " visited twice";
            seen[j] = (near_a ? 1 : 0) | (near_b ? 2 : 0);
          });
          // Refused exactly for non-adjacent cells and periodic grids under 4 per side.
          ASSERT_EQ(ok, adjacent && (!periodic || n >= 4)) << "n " << n << " cells " << a << " " << b;
          if (!ok) {
            EXPECT_TRUE(seen.empty());
            continue;
          }
          ++merged;
          const std::set<int> sa = near(a), sb = near(b);
          std::set<int> both = sa;
          both.insert(sb.begin(), sb.end());
          ASSERT_EQ(seen.size(), both.size()) << "n " << n << " cells " << a << " " << b;
          for (const auto& [j, bits] : seen) {
            EXPECT_EQ((bits & 1) != 0, sa.count(j) == 1) << "body " << j;
            EXPECT_EQ((bits & 2) != 0, sb.count(j) == 1) << "body " << j;
          }
        }
      }
      if (!periodic || n >= 4) EXPECT_GT(merged, 0);
    }
  }
}
