// Narrow-phase timings over the reference poses of
// tests/data/cylinder_distance.json (cylinders near contact, random,
// parallel, perpendicular, coaxial and cap-to-side). Each iteration is one
// query; the pose cycles through the set.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/free_rotation.hpp"
#include "core/geometry.hpp"

#ifndef RINGSIM_TESTDATA_DIR
#define RINGSIM_TESTDATA_DIR "tests/data"
#endif

namespace {

using ringsim::Vec3;
using namespace ringsim::geom;

// The reference file: RINGSIM_TESTDATA_DIR (compile definition or environment
// variable), else tests/data of the repository this file is in
// (via __FILE__, so it works from any build directory), else relative to cwd.
std::ifstream open_testdata() {
  std::vector<std::string> dirs = {RINGSIM_TESTDATA_DIR};
  if (const char* env = std::getenv("RINGSIM_TESTDATA_DIR")) dirs.insert(dirs.begin(), env);
  const std::string src = __FILE__;
  const auto slash = src.rfind('/');
  if (slash != std::string::npos) dirs.push_back(src.substr(0, slash) + "/../tests/data");
  for (const std::string& d : dirs) {
    std::ifstream in(d + "/cylinder_distance.json");
    if (in) return in;
  }
  return std::ifstream();
}

struct Pose {
  Cylinder a, b;
};

const std::vector<Pose>& poses() {
  static const std::vector<Pose> out = [] {
    std::vector<Pose> v;
    std::ifstream in = open_testdata();
    if (!in.is_open()) return v;
    const nlohmann::json j = nlohmann::json::parse(in);
    const double r = j.at("radius"), h = 0.5 * j.at("length").get<double>();
    auto vec = [](const nlohmann::json& x) { return Vec3(x[0], x[1], x[2]); };
    for (const auto& c : j.at("cases"))
      v.push_back({{vec(c.at("center_a")), vec(c.at("axis_a")).normalized(), r, h},
                   {vec(c.at("center_b")), vec(c.at("axis_b")).normalized(), r, h}});
    return v;
  }();
  return out;
}

template <class F>
void run(benchmark::State& state, F query) {
  const auto& p = poses();
  if (p.empty()) {
    state.SkipWithError("cylinder_distance.json not found (set RINGSIM_TESTDATA_DIR)");
    return;
  }
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(query(p[i]));
    if (++i == p.size()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_SphereCylinder(benchmark::State& state) {
  // Sphere of radius 1 centred on b's centre, against cylinder a.
  run(state, [](const Pose& q) { return sphere_cylinder(q.b.center, 1.0, q.a).distance; });
}
BENCHMARK(BM_SphereCylinder);

void BM_CylinderCylinder(benchmark::State& state) {
  run(state, [](const Pose& q) { return cylinder_cylinder(q.a, q.b).distance; });
}
BENCHMARK(BM_CylinderCylinder);

void BM_CylinderCylinderFcl(benchmark::State& state) {
  const double tol = 1.0 / static_cast<double>(state.range(0));
  run(state, [tol](const Pose& q) { return cylinder_cylinder_fcl(q.a, q.b, tol).distance; });
}
BENCHMARK(BM_CylinderCylinderFcl)->Arg(1000000)->Arg(10000000000);  // tolerance 1e-6, 1e-10

void BM_FclCylindersOverlap(benchmark::State& state) {
  run(state, [](const Pose& q) { return fcl_cylinders_overlap(q.a, q.b, 0.0); });
}
BENCHMARK(BM_FclCylindersOverlap);

// Exact torque-free rotation, one evaluation per iteration at advancing
// times. Arg 0: an asymmetric body with m = 0.93; arg 1: a nearly symmetric
// one (m = 0.09), closer to the rigid clusters of a replicate (mostly m < 0.05).
ringsim::FreeRotation rotation_body(std::int64_t which) {
  const ringsim::Mat3 R0 = Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  if (which == 0) return ringsim::FreeRotation(Vec3(2, 5, 9), R0, R0 * Vec3(1.4, -2.0, 2.7));
  return ringsim::FreeRotation(Vec3(2, 2.2, 9), R0, R0 * Vec3(1.4, -2.0, 2.7));
}

template <class Eval>
void run_rotation(benchmark::State& state, Eval eval) {
  const ringsim::FreeRotation fr = rotation_body(state.range(0));
  state.counters["m"] = fr.parameter_m();
  double t = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(eval(fr, t));
    t += 0.37;
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_FreeRotationOrientation(benchmark::State& state) {
  run_rotation(state, [](const ringsim::FreeRotation& fr, double t) { return fr.orientation(t); });
}
BENCHMARK(BM_FreeRotationOrientation)->Arg(0)->Arg(1);

void BM_FreeRotationOmegaBody(benchmark::State& state) {
  run_rotation(state, [](const ringsim::FreeRotation& fr, double t) { return fr.omega_body(t); });
}
BENCHMARK(BM_FreeRotationOmegaBody)->Arg(0)->Arg(1);

// The reference path (AGM and Carlson R_J), which the series path replaces
// away from the separatrix.
void BM_FreeRotationOrientationReference(benchmark::State& state) {
  run_rotation(state, [](const ringsim::FreeRotation& fr, double t) { return fr.orientation_reference(t); });
}
BENCHMARK(BM_FreeRotationOrientationReference)->Arg(0)->Arg(1);

void BM_FreeRotationOmegaBodyReference(benchmark::State& state) {
  run_rotation(state, [](const ringsim::FreeRotation& fr, double t) { return fr.omega_body_reference(t); });
}
BENCHMARK(BM_FreeRotationOmegaBodyReference)->Arg(0)->Arg(1);

// Construction (long double constants, and the series coefficients).
void BM_FreeRotationConstruct(benchmark::State& state) {
  const ringsim::Mat3 R0 = Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const Vec3 I = state.range(0) == 0 ? Vec3(2, 5, 9) : Vec3(2, 2.2, 9);
  Vec3 L = R0 * Vec3(1.4, -2.0, 2.7);
  for (auto _ : state) {
    benchmark::DoNotOptimize(ringsim::FreeRotation(I, R0, L));
    L[0] += 1e-9;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_FreeRotationConstruct)->Arg(0)->Arg(1);

}  // namespace

BENCHMARK_MAIN();
