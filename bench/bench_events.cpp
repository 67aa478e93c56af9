// Event-loop throughput of whole replicates (set-up included, as for the
// reference codes' "whole process" figures). Prints a Markdown table; each row
// is the median of --repeat runs with different seeds. Usage:
//   bench_events [--repeat R] [--quick] [--only NAME]
// Figures and the machine are recorded in docs/PERFORMANCE.md.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "core/scene.hpp"
#include "core/simulation.hpp"

using namespace ringsim;

namespace {

struct Case {
  std::string name;
  SimParams params;
  std::int64_t events;  // event budget of the timed run
};

double box_for_packing(int spheres, int linkers, double packing) {
  const double volume = spheres * 4.0 / 3.0 * M_PI + linkers * 4.0 * M_PI;
  return std::cbrt(volume / packing);
}

SimParams hard_spheres(int n, double packing) {
  SimParams p;
  p.bonding.enabled = false;  // hard-body dynamics
  p.init.spheres = n;
  p.init.linkers = 0;
  p.init.velocity = VelocityInit::Thermal;
  p.geometry.boundary = Boundary::Periodic;
  p.geometry.box_length = box_for_packing(n, 0, packing);
  p.run.t_max = 1e12;
  return p;
}

struct Result {
  double wall, setup, events_per_s, collisions_per_s, ca_per_collision;
};

Result run_case(const Case& c, std::uint64_t seed) {
  SimParams p = c.params;
  p.run.max_events = c.events;
  const auto t0 = std::chrono::steady_clock::now();
  BodyStore b = build_scene(p, seed, 0, nullptr);
  Simulation sim(p, std::move(b));
  const auto t1 = std::chrono::steady_clock::now();
  sim.run();
  const auto t2 = std::chrono::steady_clock::now();
  const double setup = std::chrono::duration<double>(t1 - t0).count();
  const double wall = std::chrono::duration<double>(t2 - t0).count();
  const RunStats& s = sim.stats();
  return {wall, setup, s.events / wall, s.collisions / wall,
          s.collisions ? static_cast<double>(s.ca_steps) / s.collisions : 0.0};
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  int repeat = 3;
  bool quick = false;
  std::string only;
  for (int k = 1; k < argc; ++k) {
    if (!std::strcmp(argv[k], "--repeat") && k + 1 < argc) repeat = std::atoi(argv[++k]);
    else if (!std::strcmp(argv[k], "--quick")) quick = true;
    else if (!std::strcmp(argv[k], "--only") && k + 1 < argc) only = argv[++k];
    else {
      std::fprintf(stderr, "usage: bench_events [--repeat R] [--quick] [--only NAME-PREFIX]\n");
      return 2;
    }
  }
  const std::int64_t scale = quick ? 10 : 1;
  std::vector<Case> cases;
  for (double phi : {0.05, 0.1, 0.3}) {
    char name[64];
    std::snprintf(name, sizeof name, "hs-N1000-phi%.2f", phi);
    cases.push_back({name, hard_spheres(1000, phi), 2'000'000 / scale});
  }
  cases.push_back({"hs-N864-phi0.10 (Smallenburg 2.7e5 coll/s)", hard_spheres(864, 0.1), 2'000'000 / scale});
  cases.push_back({"hs-N4000-phi0.25 (Smallenburg 6.0e5 coll/s)", hard_spheres(4000, 0.25), 2'000'000 / scale});
  {
    SimParams p;  // the default scene: 300 + 300, 50 box, reflective, no bonding
    p.bonding.enabled = false;  // hard-body dynamics
    p.run.t_max = 1e12;
    cases.push_back({"default-300S+300L-reflective", p, 200'000 / scale});
    p.init.spheres = 0;
    p.init.linkers = 600;
    p.geometry.boundary = Boundary::Periodic;
    cases.push_back({"600L-periodic-50box (target 1e5 coll/s)", p, 200'000 / scale});
  }
  // Scaling at the default box's density (0.040), mixed 1:1.
  for (int n : {1000, 10000, 100000}) {
    SimParams p;
    p.bonding.enabled = false;  // hard-body dynamics
    p.init.spheres = n / 2;
    p.init.linkers = n / 2;
    p.geometry.boundary = Boundary::Periodic;
    p.geometry.box_length = box_for_packing(n / 2, n / 2, 0.0402);
    p.run.t_max = 1e12;
    char name[64];
    std::snprintf(name, sizeof name, "scaling-N%d-phi0.04", n);
    cases.push_back({name, p, 200'000 / scale});
  }

  std::printf("| case | events | median wall s | set-up s | events/s | collisions/s | CA distance evals / collision |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (const Case& c : cases) {
    if (!only.empty() && c.name.rfind(only, 0) != 0) continue;
    std::vector<double> wall, setup, eps, cps, ca;
    for (int r = 0; r < repeat; ++r) {
      const Result res = run_case(c, 1000 + r);
      wall.push_back(res.wall);
      setup.push_back(res.setup);
      eps.push_back(res.events_per_s);
      cps.push_back(res.collisions_per_s);
      ca.push_back(res.ca_per_collision);
    }
    std::printf("| %s | %lld | %.3f | %.3f | %.3g | %.3g | %.1f |\n", c.name.c_str(), static_cast<long long>(c.events),
                median(wall), median(setup), median(eps), median(cps), median(ca));
    std::fflush(stdout);
  }
  return 0;
}
