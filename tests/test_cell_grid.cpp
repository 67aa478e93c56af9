// The neighbour grid's scans (core/cell_grid.hpp).

#include <gtest/gtest.h>

#include <map>
#include <random>
#include <set>
#include <vector>

#include "core/cell_grid.hpp"

using namespace ringsim;

TEST(CellGrid, NearFaceAndNearPairScansVisitEachNeighbourOnce) {
  // Grids up to 64 cells per side keep a bit mask of occupied cells per row
  // (65: none, the scans read every cell's list head). Every cell (sampled
  // on the big grid) against every cell (big grid: its 27 neighbours and
  // random ones).
  std::mt19937_64 rng(11);
  for (const bool periodic : {true, false}) {
    for (const int n : {1, 2, 3, 4, 5, 7, 64, 65}) {
      const int cells = n * n * n;
      const bool big = n > 7;
      const int bodies = big ? 40000 : 2 * cells;
      CellGrid g(static_cast<double>(n), 1.0, bodies, periodic);
      ASSERT_EQ(g.cells_per_side(), n);
      std::uniform_real_distribution<double> u(0.0, n);
      std::vector<int> cell_of(bodies);
      for (int i = 0; i < bodies; ++i) {
        g.insert(i, Vec3(u(rng), u(rng), u(rng)));
        cell_of[i] = g.cell_of_body(i);
      }
      // Move some bodies away and back, so that cells empty and fill again.
      for (int i = 0; i < bodies; i += 3) g.move(i, (cell_of[i] + 1) % cells);
      for (int i = 0; i < bodies; i += 3) g.move(i, cell_of[i]);
      auto apart = [&](int a, int b) {  // largest per-axis cell distance
        const auto ca = g.coords(a), cb = g.coords(b);
        int far = 0;
        for (int d = 0; d < 3; ++d) {
          int delta = std::abs(cb[d] - ca[d]);
          if (periodic) delta = std::min(delta, n - delta);
          far = std::max(far, delta);
        }
        return far;
      };
      // By brute force: the bodies whose cell is within one of c.
      std::map<int, std::set<int>> memo;
      auto near = [&](int c) -> const std::set<int>& {
        auto [it, fresh] = memo.try_emplace(c);
        if (fresh)
          for (int j = 0; j < bodies; ++j)
            if (apart(c, cell_of[j]) <= 1) it->second.insert(j);
        return it->second;
      };
      std::uniform_int_distribution<int> any(0, cells - 1);
      std::vector<int> firsts;
      for (int k = 0; k < (big ? 6 : cells); ++k) firsts.push_back(big ? any(rng) : k);
      if (big) firsts.push_back(cell_of[0]);  // body 0 heads a list: a "no body" test must not confuse it
      int merged = 0;
      for (const int a : firsts) {
        const std::set<int>& sa = near(a);
        std::set<int> seen_a;
        g.for_each_near(a, [&](int j) { EXPECT_TRUE(seen_a.insert(j).second) << "body " << j << " twice"; });
        ASSERT_EQ(seen_a, sa) << "n " << n << " cell " << a;
        // The face scans (9 cells entered across a face; distinct cells need
        // 3 per side in a periodic box).
        for (int dim = 0; dim < 3 && g.faces_distinct(); ++dim)
          for (const int dir : {-1, 1}) {
            const auto ca = g.coords(a);
            std::set<int> expected, seen_f;
            for (int j = 0; j < bodies; ++j) {
              const auto cj = g.coords(cell_of[j]);
              bool in = true;
              for (int d = 0; d < 3; ++d) {
                const int want = d == dim ? ca[d] + dir : ca[d];
                int delta = std::abs(cj[d] - (periodic ? (want + n) % n : want));
                if (periodic) delta = std::min(delta, n - delta);
                in = in && delta <= (d == dim ? 0 : 1);
              }
              if (in) expected.insert(j);
            }
            g.for_each_face(a, dim, dir, [&](int j) { EXPECT_TRUE(seen_f.insert(j).second) << "body " << j << " twice"; });
            ASSERT_EQ(seen_f, expected) << "n " << n << " cell " << a << " face " << dim << " " << dir;
          }
        std::vector<int> seconds;
        if (big) {
          const auto ca = g.coords(a);
          for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dz = -1; dz <= 1; ++dz) {
                auto w = [&](int q) { return periodic ? (q + n) % n : q; };
                const int x = w(ca[0] + dx), y = w(ca[1] + dy), z = w(ca[2] + dz);
                if (x >= 0 && y >= 0 && z >= 0 && x < n && y < n && z < n) seconds.push_back(g.index(x, y, z));
              }
          for (int k = 0; k < 4; ++k) seconds.push_back(any(rng));
        } else {
          for (int b = 0; b < cells; ++b) seconds.push_back(b);
        }
        for (const int b : seconds) {
          std::map<int, int> seen;  // body -> bit 0: near a, bit 1: near b
          const bool ok = g.for_each_near_pair(a, b, [&](int j, bool near_a, bool near_b) {
            EXPECT_TRUE(near_a || near_b);
            EXPECT_EQ(seen.count(j), 0u) << "body " << j << " visited twice";
            seen[j] = (near_a ? 1 : 0) | (near_b ? 2 : 0);
          });
          // Refused exactly for non-adjacent cells and periodic grids under 4 per side.
          ASSERT_EQ(ok, apart(a, b) <= 1 && (!periodic || n >= 4)) << "n " << n << " cells " << a << " " << b;
          if (!ok) {
            EXPECT_TRUE(seen.empty());
            continue;
          }
          ++merged;
          const std::set<int>& sb = near(b);
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

TEST(CellGrid, AnOuterFaceOfAClosedBoxIsNoExitOnceTheCentreIsOnIt) {
  // 5 cells of width 2: a centre on the box's face x = 0, moving out, has no
  // exit there (the wall turns it back), only the one ahead along y; inside
  // the box, or periodic, the face counts as before.
  const Vec3 v(-2.0, 1.0, 0.0);
  CellGrid closed(10.0, 2.0, 1000, false), periodic(10.0, 2.0, 1000, true);
  ASSERT_EQ(closed.cells_per_side(), 5);
  const CellGrid::Exit out = closed.exit_time(closed.locate(Vec3(0.0, 3.0, 5.0)), Vec3(0.0, 3.0, 5.0), v);
  EXPECT_EQ(out.dim, 1);
  EXPECT_DOUBLE_EQ(out.dt, 1.0);
  const CellGrid::Exit wrap = periodic.exit_time(periodic.locate(Vec3(0.0, 3.0, 5.0)), Vec3(0.0, 3.0, 5.0), v);
  EXPECT_EQ(wrap.dim, 0);
  EXPECT_EQ(wrap.dt, 0.0);
  const CellGrid::Exit before = closed.exit_time(closed.locate(Vec3(0.5, 3.0, 5.0)), Vec3(0.5, 3.0, 5.0), v);
  EXPECT_EQ(before.dim, 0);  // still ahead of the face: it bounds the searches
  EXPECT_DOUBLE_EQ(before.dt, 0.25);
  const CellGrid::Exit inner = closed.exit_time(closed.locate(Vec3(4.0, 3.0, 5.0)), Vec3(4.0, 3.0, 5.0), v);
  EXPECT_EQ(inner.dim, 0);  // x = 4 is an inner face: crossing it at once is an exit
  EXPECT_EQ(inner.dt, 0.0);
}
