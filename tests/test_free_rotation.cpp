// Exact torque-free rotation (core/free_rotation): against the independent
// reference integration in tests/data/free_rotation.json, against a
// Dormand-Prince integration of Euler's equations written here, against closed
// forms (symmetric top, spherical top, principal-axis rotation), conservation
// of L and E over 1e4 periods, the group property R(t2) = R_{t1}(t2 - t1), the
// theta-series path against the AGM/Carlson reference path, and the special
// functions against Boost.Math.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <boost/math/special_functions/ellint_1.hpp>
#include <boost/math/special_functions/ellint_3.hpp>
#include <boost/math/special_functions/ellint_rf.hpp>
#include <boost/math/special_functions/ellint_rj.hpp>
#include <nlohmann/json.hpp>

#include "core/cluster.hpp"
#include "core/free_rotation.hpp"

#ifndef RINGSIM_TESTDATA_DIR
#define RINGSIM_TESTDATA_DIR "tests/data"
#endif

namespace {

using ringsim::FreeRotation;
using ringsim::Mat3;
using ringsim::Quat;
using ringsim::Vec3;

template <class Derived>
double max_abs(const Eigen::MatrixBase<Derived>& M) {
  return M.cwiseAbs().maxCoeff();
}

Mat3 rot(double angle, const Vec3& axis) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

// Deterministic pseudo-random numbers (no clock seeding): a fixed LCG.
struct Lcg {
  unsigned long long s;
  double uniform() {  // in [0, 1)
    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(s >> 11) * (1.0 / 9007199254740992.0);
  }
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  Vec3 vec(double a, double b) { return Vec3(uniform(a, b), uniform(a, b), uniform(a, b)); }
  Mat3 rotation() { return Quat(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)).normalized().toRotationMatrix(); }
};

// Conservation of L (world) and E along the trajectory at time t.
void expect_conserves(const FreeRotation& fr, double t, double tol = 1e-12) {
  const Mat3 R = fr.orientation(t);
  const Vec3 w = fr.omega_body(t);
  const Vec3& I = fr.principal_moments();
  const Vec3 L = fr.angular_momentum();
  ASSERT_TRUE(R.allFinite() && w.allFinite()) << "t = " << t;
  EXPECT_LE(max_abs(R * I.cwiseProduct(w) - L), tol * L.norm() + 1e-300) << "t = " << t;
  const double E = 0.5 * w.dot(I.cwiseProduct(w));
  EXPECT_LE(std::abs(E - fr.energy()), tol * fr.energy() + 1e-300) << "t = " << t;
  EXPECT_LE(max_abs(R.transpose() * R - Mat3::Identity()), 1e-13) << "t = " << t;
  EXPECT_NEAR(R.determinant(), 1.0, 1e-13) << "t = " << t;
  EXPECT_LE(w.norm(), fr.max_rate()) << "t = " << t;
}

// ---- reference data ---------------------------------------------------------

struct RefState {
  double t;
  Mat3 R;
  Vec3 omega;
};
struct RefCase {
  Vec3 I, omega0;
  Mat3 R0;
  std::vector<RefState> states;
};

Quat quat_wxyz(const nlohmann::json& q) {
  return Quat(q[0].get<double>(), q[1].get<double>(), q[2].get<double>(), q[3].get<double>());
}
Vec3 vec3(const nlohmann::json& v) { return Vec3(v[0].get<double>(), v[1].get<double>(), v[2].get<double>()); }

std::vector<RefCase> reference_cases() {
  std::vector<std::string> dirs = {RINGSIM_TESTDATA_DIR};
  if (const char* env = std::getenv("RINGSIM_TESTDATA_DIR")) dirs.insert(dirs.begin(), env);
  std::ifstream in;
  for (const auto& d : dirs) {
    in.open(d + "/free_rotation.json");
    if (in) break;
    in.clear();
  }
  std::vector<RefCase> out;
  if (!in.is_open()) return out;
  const nlohmann::json j = nlohmann::json::parse(in);
  for (const auto& c : j.at("cases")) {
    RefCase rc;
    rc.I = vec3(c.at("inertia_principal"));
    rc.omega0 = vec3(c.at("omega_body_0"));
    rc.R0 = quat_wxyz(c.at("q0_wxyz")).normalized().toRotationMatrix();
    for (const auto& s : c.at("states"))
      rc.states.push_back({s.at("t").get<double>(), quat_wxyz(s.at("q_wxyz")).toRotationMatrix(), vec3(s.at("omega_body"))});
    out.push_back(rc);
  }
  return out;
}

TEST(FreeRotation, MatchesReferenceData) {
  const auto cases = reference_cases();
  ASSERT_EQ(cases.size(), 16u) << "free_rotation.json not found or changed (RINGSIM_TESTDATA_DIR)";
  double worst_R = 0, worst_w = 0;
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const RefCase& c = cases[k];
    const FreeRotation fr(c.I, c.R0, c.R0 * c.I.cwiseProduct(c.omega0));
    for (const RefState& s : c.states) {
      const double eR = max_abs(fr.orientation(s.t) - s.R);
      const double ew = max_abs(fr.omega_body(s.t) - s.omega);
      EXPECT_LE(eR, 1e-9) << "case " << k << " t " << s.t;
      EXPECT_LE(ew, 1e-9) << "case " << k << " t " << s.t;
      worst_R = std::max(worst_R, eR);
      worst_w = std::max(worst_w, ew);
    }
  }
  std::printf("reference: max |R - R_ref| = %.2e, max |omega - omega_ref| = %.2e\n", worst_R, worst_w);
}

// The same bodies with the principal axes listed in every order (the body
// frame relabelled by a proper signed permutation Q: body_old <- body_new).
TEST(FreeRotation, MomentsInAnyOrder) {
  const auto cases = reference_cases();
  ASSERT_FALSE(cases.empty());
  const std::array<std::array<int, 3>, 6> perms = {{{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};
  const Mat3 R0 = rot(0.7, Vec3(1, -2, 0.5));
  double worst = 0;
  for (const RefCase& c : cases) {
    const FreeRotation ref(c.I, R0, R0 * c.I.cwiseProduct(c.omega0));
    for (const auto& p : perms) {
      Mat3 Q = Mat3::Zero();  // new axis i is old axis p[i]
      for (int i = 0; i < 3; ++i) Q(p[i], i) = 1.0;
      if (Q.determinant() < 0) Q.col(2) *= -1.0;
      const Vec3 I(c.I[p[0]], c.I[p[1]], c.I[p[2]]);
      const FreeRotation fr(I, R0 * Q, ref.angular_momentum());
      for (double t : {0.5, 5.0, 50.0}) {
        const double e = std::max(max_abs(fr.orientation(t) - ref.orientation(t) * Q),
                                  max_abs(fr.omega_body(t) - Q.transpose() * ref.omega_body(t)));
        EXPECT_LE(e, 1e-11) << "perm " << p[0] << p[1] << p[2] << " t " << t;
        worst = std::max(worst, e);
      }
    }
  }
  std::printf("any order: max difference %.2e\n", worst);
}

// ---- independent integration: Dormand-Prince 5(4) ----------------------------

using State = Eigen::Matrix<double, 7, 1>;  // quaternion w x y z (world <- body), omega_body

State rhs(const State& y, const Vec3& I) {
  const Quat q(y[0], y[1], y[2], y[3]);
  const Vec3 w = y.tail<3>();
  const Quat dq = q * Quat(0.0, w[0], w[1], w[2]);  // q' = q (0, omega_body) / 2
  State f;
  f << 0.5 * dq.w(), 0.5 * dq.x(), 0.5 * dq.y(), 0.5 * dq.z(),
      (I[1] - I[2]) * w[1] * w[2] / I[0], (I[2] - I[0]) * w[2] * w[0] / I[1],
      (I[0] - I[1]) * w[0] * w[1] / I[2];
  return f;
}

// Dormand & Prince, J. Comput. Appl. Math. 6, 19 (1980): RK5(4)7M, local
// extrapolation, error per step held below tol (mixed absolute/relative). The
// system is autonomous, so the nodes c_i are not needed.
State integrate(State y, const Vec3& I, double t_end, double tol) {
  static const double a[7][6] = {
      {0, 0, 0, 0, 0, 0},
      {1.0 / 5, 0, 0, 0, 0, 0},
      {3.0 / 40, 9.0 / 40, 0, 0, 0, 0},
      {44.0 / 45, -56.0 / 15, 32.0 / 9, 0, 0, 0},
      {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729, 0, 0},
      {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656, 0},
      {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84}};
  static const double b5[7] = {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84, 0};
  static const double b4[7] = {5179.0 / 57600, 0, 7571.0 / 16695, 393.0 / 640, -92097.0 / 339200, 187.0 / 2100, 1.0 / 40};
  double t = 0, h = 1e-3;
  while (t < t_end) {
    if (t + h > t_end) h = t_end - t;
    State k[7];
    for (int s = 0; s < 7; ++s) {
      State ys = y;
      for (int r = 0; r < s; ++r) ys += h * a[s][r] * k[r];
      k[s] = rhs(ys, I);
    }
    State y5 = y, y4 = y;
    for (int s = 0; s < 7; ++s) {
      y5 += h * b5[s] * k[s];
      y4 += h * b4[s] * k[s];
    }
    double err = 0;
    for (int i = 0; i < 7; ++i) err = std::max(err, std::abs(y5[i] - y4[i]) / (tol * (1.0 + std::abs(y[i]))));
    if (err <= 1.0) {
      t += h;
      y = y5;
      y.head<4>() /= y.head<4>().norm();
    }
    h *= std::min(4.0, std::max(0.2, 0.9 * std::pow(std::max(err, 1e-30), -0.2)));
  }
  return y;
}

TEST(FreeRotation, AgreesWithHighAccuracyIntegration) {
  Lcg rng{12345};
  double worst = 0, integrator_spread = 0;
  for (int k = 0; k < 8; ++k) {
    const Vec3 I = rng.vec(1.0, 10.0);
    const Vec3 w0 = rng.vec(-1.0, 1.0);
    const Quat q0 = Quat(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)).normalized();
    const Mat3 R0 = q0.toRotationMatrix();
    const FreeRotation fr(I, R0, R0 * I.cwiseProduct(w0));
    State y0;
    y0 << q0.w(), q0.x(), q0.y(), q0.z(), w0;
    const double t_end = 3.0 * (fr.body_period() > 0 ? fr.body_period() : 10.0);
    const State y = integrate(y0, I, t_end, 1e-14);
    const State y_loose = integrate(y0, I, t_end, 1e-13);
    integrator_spread = std::max(integrator_spread, (y - y_loose).cwiseAbs().maxCoeff());
    const Mat3 R_num = Quat(y[0], y[1], y[2], y[3]).toRotationMatrix();
    const double e = std::max(max_abs(fr.orientation(t_end) - R_num), max_abs(fr.omega_body(t_end) - Vec3(y.tail<3>())));
    EXPECT_LE(e, 1e-10) << "body " << k << " m " << fr.parameter_m();
    worst = std::max(worst, e);
  }
  std::printf("Dormand-Prince (tol 1e-14, 3 periods): max difference %.2e (integrator tol 1e-13 vs 1e-14: %.2e)\n",
              worst, integrator_spread);
}

// ---- conservation and long times ------------------------------------------------

std::vector<FreeRotation> test_bodies() {
  Lcg rng{777};
  std::vector<FreeRotation> out;
  for (int k = 0; k < 20; ++k) {
    const Vec3 I = rng.vec(0.5, 20.0);
    out.emplace_back(I, rng.rotation(), rng.vec(-5, 5));
  }
  // Both regimes of one body, and close to the separatrix on either side.
  const Vec3 I(2, 5, 9);
  for (double s : {0.3, 0.9, 0.999, 1.0001, 1.1, 3.0})
    out.emplace_back(I, rot(0.4, Vec3(1, 1, 0)), rot(0.4, Vec3(1, 1, 0)) * I.cwiseProduct(Vec3(0.1 * s, 1.0, 0.05)));
  return out;
}

TEST(FreeRotation, ConservesMomentumAndEnergyOver1e4Periods) {
  int n_elliptic = 0;
  for (const FreeRotation& fr : test_bodies()) {
    const double T = fr.body_period();
    ASSERT_GT(T, 0.0);
    ++n_elliptic;
    for (double t : {0.0, 0.1 * T, 0.37 * T, T, 13.3 * T, 101.7 * T, 999.9 * T, 5432.1 * T, 1e4 * T, -777.7 * T})
      expect_conserves(fr, t);
  }
  EXPECT_EQ(n_elliptic, 26);
}

// A rigid cluster restarts its FreeRotation at every impulse from the
// orientation reached (core/cluster.cpp, restart_cluster), and its members'
// axes are that orientation times fixed body-frame vectors: the geometry
// takes them as unit vectors. A plain chain of restarts drifts off
// orthogonal by ~5e-17 per restart for a nearly symmetric top (a
// sphere-linker pair: 5.2e-12 after 1e5 restarts, 2e-13 for an asymmetric
// body), without bound; cluster_impulse pulls it back past 1e-13.
TEST(FreeRotation, RestartChainStaysOrthonormal) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> N(0.0, 1.0);
  std::exponential_distribution<double> E(20.0);
  const ringsim::Box box{50.0, true};
  // An asymmetric body and a sphere-linker pair (nearly symmetric top).
  for (const Vec3& moments : {Vec3(3.1, 5.7, 7.9), Vec3(9.6342174710140505, 98.646009674372891, 98.646009674383379)}) {
    ringsim::Cluster c;
    c.moments = moments;
    c.mass = 4.0;
    c.x = Vec3(25, 25, 25);
    c.rot = FreeRotation(moments, Mat3::Identity(), Vec3(1.3, -0.4, 2.2));
    c.alive = true;
    double t = 0.0, worst = 0.0;
    for (int k = 0; k < 100000; ++k) {
      t += E(rng);
      ringsim::cluster_impulse(c, box, t, 0.01 * Vec3(N(rng), N(rng), N(rng)), Vec3(N(rng), N(rng), N(rng)));
      const Mat3& R = c.orientation_at(t);
      if (k % 100 == 0) worst = std::max(worst, (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff());
    }
    EXPECT_LT(worst, 2e-13) << moments.transpose();
    std::printf("moments %g %g %g: |R^T R - 1|_max <= %.2e over 1e5 impulses\n", moments[0], moments[1], moments[2], worst);
  }
}

// Period of the rotation about L: 2 pi / (omega . L/|L|) = 2 pi |L| / 2E.
double rotation_period(const FreeRotation& fr) {
  return 2 * M_PI * fr.angular_momentum().norm() / (2 * fr.energy());
}

// R(t2) = (the body restarted at t1 from R(t1), same L)(t2 - t1), up to 1e4
// rotation periods.
TEST(FreeRotation, GroupPropertyOver1e4Periods) {
  double worst = 0;
  for (const FreeRotation& fr : test_bodies()) {
    const double T = rotation_period(fr);
    for (const auto& [t1, t2] : std::vector<std::pair<double, double>>{
             {0.3 * T, 2.9 * T}, {17.7 * T, 4321.2 * T}, {5000.5 * T, 1e4 * T}, {9999.1 * T, 0.2 * T}, {1e4 * T, 1.3 * T}}) {
      const FreeRotation restarted(fr.principal_moments(), fr.orientation(t1), fr.angular_momentum());
      const double e = std::max(max_abs(restarted.orientation(t2 - t1) - fr.orientation(t2)),
                                max_abs(restarted.omega_body(t2 - t1) - fr.omega_body(t2)) / fr.max_rate());
      EXPECT_LE(e, 1e-10) << "m " << fr.parameter_m() << " t1/T " << t1 / T << " t2/T " << t2 / T;
      worst = std::max(worst, e);
    }
  }
  std::printf("group property up to 1e4 periods: max difference %.2e\n", worst);
}

// Orientation after ~1e4 rotation periods (R0 = identity) against 40-digit
// values: the closed form of free_rotation.cpp evaluated with mpmath 1.3
// (ellipfun, ellipk, ellipf, ellippi at mp.dps = 40) from the same double
// inputs; the symmetric top also equals the steady-precession formula there.
// The group property above is limited by the rounding of the restart state;
// this checks the evaluation itself, which keeps ~1e-14 at these times.
TEST(FreeRotation, LongTimeHighPrecisionReference) {
  struct Case {
    Vec3 I, L;
    double t;
    Mat3 R;
  };
  std::vector<Case> cases(3);
  cases[0] = {Vec3(5, 2, 9), Vec3(0.3, 1.1, -0.6), 122101.327, Mat3()};
  cases[0].R << -0.30980576951282979, -0.10339567779793524, 0.94516121322728275,  //
      -0.084183678692102082, 0.99314841518089114, 0.081051426055000778,           //
      -0.94706572814057011, -0.054456948467481218, -0.31638733752345682;
  cases[1] = {Vec3(2, 5, 9), Vec3(0.2, 5.0, 0.45), 62603.721, Mat3()};  // m = 0.99
  cases[1].R << 0.67464721804063776, -0.2107602686356288, -0.70741164844428861,  //
      0.26458559065049581, -0.82563739616991516, 0.49831451440419722,          //
      -0.68909041236267132, -0.523357429688736, -0.50124984227373415;
  cases[2] = {Vec3(1.5, 1.5, 4), Vec3(0.7, -0.2, 0.9), 130854.204, Mat3()};  // symmetric
  cases[2].R << 0.38219403444245637, -0.92269150149657642, 0.050676553775802963,  //
      0.91319612221363333, 0.38551610884935039, 0.13209909988958513,            //
      -0.14142334464500994, -0.0042098555378036516, 0.98994025814983888;
  double worst = 0;
  for (const Case& c : cases) {
    const FreeRotation fr(c.I, Mat3::Identity(), c.L);
    EXPECT_GT(c.t / rotation_period(fr), 9999.0);
    const double e = max_abs(fr.orientation(c.t) - c.R);
    EXPECT_LE(e, 1e-12) << "I " << c.I.transpose();
    worst = std::max(worst, e);
  }
  std::printf("1e4 rotation periods vs 40-digit reference: max difference %.2e\n", worst);
}

TEST(FreeRotation, MaxRateBoundsOmegaAndIsTight) {
  for (const FreeRotation& fr : test_bodies()) {
    const Vec3& I = fr.principal_moments();
    EXPECT_LE(fr.max_rate(), std::sqrt(2 * fr.energy() / I.minCoeff()) * (1 + 1e-12));
    const double T = fr.body_period();
    double seen = 0;
    for (int i = 0; i <= 4000; ++i) seen = std::max(seen, fr.omega_world(T * i / 4000.0).norm());
    EXPECT_LE(seen, fr.max_rate());
    EXPECT_GE(seen, fr.max_rate() * (1 - 1e-5));
  }
}

// ---- degenerate cases -------------------------------------------------------------

// Symmetric top: omega = L/I_perp + (1/I_s - 1/I_perp) L_s u, so
// R(t) = Rot(L, |L| t / I_perp) R0 Rot_body(e_s, (1/I_s - 1/I_perp) L_s t)
// (steady precession of the axis about L at |L|/I_perp; Landau & Lifshitz 33).
TEST(FreeRotation, SymmetricTopIsSteadyPrecession) {
  const Mat3 R0 = rot(1.1, Vec3(0.3, -1, 2));
  const Vec3 L = Vec3(0.4, -1.3, 0.9);
  double worst = 0;
  for (int s = 0; s < 3; ++s) {          // position of the symmetry axis
    for (double ratio : {0.3, 2.5}) {    // oblate and prolate
      Vec3 I = Vec3::Constant(4.0);
      I[s] = 4.0 * ratio;
      const double Ip = 4.0, Is = I[s];
      const Vec3 Lb = R0.transpose() * L;
      const FreeRotation fr(I, R0, L);
      const double Tp = 2 * M_PI * Ip / L.norm();
      for (double t : {0.0, 0.3, 7.0, 100.0 * Tp, 1e4 * Tp + 0.1}) {
        const Mat3 R_exact = rot(L.norm() * t / Ip, L) * R0 * rot((1 / Is - 1 / Ip) * Lb[s] * t, Vec3::Unit(s));
        const double e = max_abs(fr.orientation(t) - R_exact);
        EXPECT_LE(e, t < 10 ? 1e-13 : 1e-10) << "axis " << s << " ratio " << ratio << " t " << t;
        worst = std::max(worst, e);
        expect_conserves(fr, t);
      }
    }
  }
  std::printf("symmetric top vs steady precession: max difference %.2e\n", worst);
}

TEST(FreeRotation, SymmetricTopWithLInDegeneratePlaneIsUniform) {
  // I1 = I2 < I3 and L perpendicular to the symmetry axis: omega = L / I1.
  for (const Vec3& I : {Vec3(3, 3, 7), Vec3(7, 3, 3), Vec3(3, 7, 3), Vec3(2, 9, 9)}) {
    const int sym = (I[0] != I[1] && I[0] != I[2]) ? 0 : (I[1] != I[2] && I[1] != I[0]) ? 1 : 2;
    Vec3 Lb(0.6, -0.8, 0.5);
    Lb[sym] = 0.0;
    // With R0 = identity the body-frame L is exact and the uniform closed form is
    // selected; through a rotated R0 it carries ~1e-16 noise along the symmetry
    // axis and the elliptic solution (m = 0) is used, which must agree.
    EXPECT_EQ(FreeRotation(I, Mat3::Identity(), Lb).mode(), FreeRotation::Mode::Uniform);
    const Mat3 R0 = rot(0.3, Vec3(1, 2, 3));
    const FreeRotation fr(I, R0, R0 * Lb);
    const Vec3 w = R0 * Lb.cwiseQuotient(I);
    for (double t : {0.5, 3e3}) {
      EXPECT_LE(max_abs(fr.orientation(t) - rot(w.norm() * t, w) * R0), t < 1 ? 1e-14 : 1e-11);
      expect_conserves(fr, t);
    }
  }
}

TEST(FreeRotation, SphericalTopRotatesUniformly) {
  const Mat3 R0 = rot(2.0, Vec3(1, 0, 1));
  const Vec3 L(1.0, 2.0, -0.5);
  const FreeRotation fr(Vec3::Constant(2.5), R0, L);
  EXPECT_EQ(fr.mode(), FreeRotation::Mode::Uniform);
  for (double t : {0.1, 10.0, 1e5}) {
    EXPECT_LE(max_abs(fr.orientation(t) - rot(L.norm() / 2.5 * t, L) * R0), 1e-10);
    EXPECT_LE(max_abs(fr.omega_world(t) - L / 2.5), 1e-14);
    expect_conserves(fr, t);
  }
}

TEST(FreeRotation, ZeroAngularMomentumStaysAtRest) {
  const Mat3 R0 = rot(0.5, Vec3(0, 1, 1));
  const FreeRotation fr(Vec3(1, 2, 3), R0, Vec3::Zero());
  EXPECT_EQ(fr.mode(), FreeRotation::Mode::Rest);
  EXPECT_EQ(fr.orientation(123.0), R0);
  EXPECT_EQ(fr.omega_body(5.0), Vec3::Zero());
  EXPECT_EQ(fr.max_rate(), 0.0);
  const FreeRotation def;
  EXPECT_EQ(def.orientation(1.0), Mat3::Identity());
  EXPECT_EQ(def.omega_world(1.0), Vec3::Zero());
}

TEST(FreeRotation, PrincipalAxisRotationIsUniform) {
  const Vec3 I(5, 2, 9);  // unsorted: middle axis is body axis 0
  const Mat3 R0 = rot(0.9, Vec3(2, -1, 1));
  for (int a = 0; a < 3; ++a) {
    const Vec3 wb = 1.7 * Vec3::Unit(a);
    const FreeRotation fr(I, R0, R0 * I.cwiseProduct(wb));
    EXPECT_EQ(fr.mode(), FreeRotation::Mode::Uniform) << "axis " << a;
    for (double t : {0.3, 50.0, 1e4}) {
      EXPECT_LE(max_abs(fr.orientation(t) - R0 * rot(1.7 * t, Vec3::Unit(a))), 1e-11) << "axis " << a;
      EXPECT_LE(max_abs(fr.omega_body(t) - wb), 1e-15);
      expect_conserves(fr, t);
    }
    // Slightly off the axis: finite, conserving, and close to uniform at short times.
    const Vec3 wp = wb + Vec3(1e-9, -2e-9, 1.5e-9);
    const FreeRotation near(I, R0, R0 * I.cwiseProduct(wp));
    EXPECT_EQ(near.mode(), FreeRotation::Mode::Elliptic);
    EXPECT_LE(max_abs(near.orientation(0.3) - fr.orientation(0.3)), 1e-8) << "axis " << a;
    for (double t : {0.3, 50.0, 1e4}) expect_conserves(near, t);
  }
}

// Separatrix L^2 = 2 E I2: I = (1, 4, 16) gives 1/I1 - 1/I2 = 3/4 and
// 1/I2 - 1/I3 = 3/16 exactly, so L = (1, L2, 2) lies exactly on it.
TEST(FreeRotation, SeparatrixExactAndNear) {
  const Vec3 I(1, 4, 16);
  const Vec3 Lb(1.0, 0.7, 2.0);
  const FreeRotation sep(I, Mat3::Identity(), Lb);
  EXPECT_EQ(sep.mode(), FreeRotation::Mode::Separatrix);
  State y0;
  y0 << 1, 0, 0, 0, Lb.cwiseQuotient(I);
  double worst = 0;
  for (double t : {0.5, 2.0, 6.0}) {
    const State y = integrate(y0, I, t, 1e-14);
    const double e = std::max(max_abs(sep.orientation(t) - Quat(y[0], y[1], y[2], y[3]).toRotationMatrix()),
                              max_abs(sep.omega_body(t) - Vec3(y.tail<3>())));
    EXPECT_LE(e, 1e-10) << "t " << t;
    worst = std::max(worst, e);
  }
  std::printf("exact separatrix vs integration: %.2e\n", worst);
  // At long times L_body tends to the middle axis; everything stays finite.
  for (double t : {10.0, 1e3, 1e6, -1e6}) expect_conserves(sep, t);
  EXPECT_LE(max_abs(sep.angular_momentum_body(1e6).normalized().cwiseAbs() - Vec3::UnitY()), 1e-12);

  // Near the separatrix on either side (m -> 1 from below in both regimes):
  // continuous in the initial data over a short time, conserving over long times.
  for (double eps : {1e-4, 1e-8, 1e-12, 1e-15}) {
    for (double sgn : {-1.0, 1.0}) {
      const Vec3 Ln(1.0, 0.7, 2.0 * (1 + sgn * eps));
      const FreeRotation near(I, Mat3::Identity(), Ln);
      EXPECT_EQ(near.mode(), FreeRotation::Mode::Elliptic);
      EXPECT_LT(near.parameter_mc(), 10 * eps);
      for (double t : {0.5, 2.0}) {
        const double e = max_abs(near.orientation(t) - sep.orientation(t));
        EXPECT_LE(e, 10 * eps + 1e-12) << "eps " << eps << " sign " << sgn << " t " << t;
      }
      for (double t : {1.0, 1e2, 1e4, 1e6}) expect_conserves(near, t);
    }
  }
  // At rest on the unstable middle axis: uniform rotation.
  const FreeRotation middle(I, Mat3::Identity(), Vec3(0, 3.0, 0));
  EXPECT_EQ(middle.mode(), FreeRotation::Mode::Uniform);
}

// Nearly symmetric tops (1e-12 relative) stay close to the symmetric solution
// at moderate times, for either equal pair.
TEST(FreeRotation, NearlySymmetricTopIsContinuous) {
  const Mat3 R0 = rot(0.8, Vec3(1, -1, 2));
  const Vec3 L(0.5, 1.5, -0.7);
  for (const Vec3& I : {Vec3(3, 3, 7), Vec3(3, 7, 7), Vec3(7, 3, 7)}) {
    const FreeRotation sym(I, R0, L);
    for (int k = 0; k < 3; ++k) {
      Vec3 In = I;
      In[k] *= 1 + 1e-12;
      const FreeRotation near(In, R0, L);
      for (double t : {0.5, 5.0, 50.0}) {
        EXPECT_LE(max_abs(near.orientation(t) - sym.orientation(t)), 1e-9) << "t " << t;
        expect_conserves(near, t);
      }
      for (double t : {1e4, 1e7}) expect_conserves(near, t);
    }
    // L exactly in the degenerate plane, moments then split by 1e-12.
    Vec3 Lb = R0.transpose() * L;
    const int s = (I[0] == I[1]) ? 2 : (I[1] == I[2]) ? 0 : 1;
    Lb[s] = 0;
    for (int k = 0; k < 3; ++k) {
      Vec3 In = I;
      In[k] *= 1 - 1e-12;
      const FreeRotation a(I, R0, R0 * Lb), b(In, R0, R0 * Lb);
      EXPECT_LE(max_abs(a.orientation(5.0) - b.orientation(5.0)), 1e-9);
      for (double t : {5.0, 1e4, 1e8}) expect_conserves(b, t);
    }
  }
}

// ---- series path against the reference path --------------------------------------

// A body with a prescribed parameter m: moments I1 < I2 < I3 (random, in a
// random order in the body frame), L circling the largest (or smallest) axis,
// L_y (scaled by sqrt m) and L_z random and L_x solved from m = a^2 d_xy / (c^2 d_yz) (see
// free_rotation.cpp); resampled when that has no solution.
FreeRotation body_with_m(Lcg& rng, double m_target) {
  for (;;) {
    std::array<double, 3> Is = {rng.uniform(0.5, 10), rng.uniform(0.5, 10), rng.uniform(0.5, 10)};
    std::sort(Is.begin(), Is.end());
    const bool largest = rng.uniform() < 0.5;
    const double Ix = largest ? Is[0] : Is[2], Iy = Is[1], Iz = largest ? Is[2] : Is[0];
    const double dxz = 1 / Ix - 1 / Iz, dyz = 1 / Iy - 1 / Iz, dxy = 1 / Ix - 1 / Iy;
    const double rho = dyz / dxz, rho_c = dxy / dxz;
    const double Ly = rng.uniform(-1, 1) * std::min(1.0, std::sqrt(m_target)), Lz = rng.uniform(0.2, 1) * (rng.uniform() < 0.5 ? -1 : 1);
    const double Lx2 = m_target * (Lz * Lz + rho_c * Ly * Ly) * dyz / dxy - rho * Ly * Ly;
    if (!(Lx2 > 0) || dxy <= 0 || dyz <= 0) continue;
    const Vec3 L_xyz(std::sqrt(Lx2) * (rng.uniform() < 0.5 ? -1 : 1), Ly, Lz);
    // Principal axes in a random order: body axis perm[i] carries X axis i.
    std::array<int, 3> perm = {0, 1, 2};
    for (int i = 2; i > 0; --i) std::swap(perm[i], perm[static_cast<int>(rng.uniform() * (i + 1)) % (i + 1)]);
    Vec3 I, Lb;
    const double Ixyz[3] = {Ix, Iy, Iz};
    for (int i = 0; i < 3; ++i) {
      I[perm[i]] = Ixyz[i];
      Lb[perm[i]] = L_xyz[i];
    }
    const Mat3 R0 = rng.rotation();
    return FreeRotation(I, R0, R0 * Lb * rng.uniform(0.2, 5));
  }
}

// orientation() and omega_body() use theta series where q <= 0.25 and the
// AGM/Carlson reference path elsewhere; both share the reduction of the phase,
// so they must agree to rounding at any time. Bodies with m log-uniform down
// to 1e-16, uniform in (0, 1), and up to 1 - 1e-12 (where the fallback takes
// over), each at 40 times up to 1e4 body periods either way.
TEST(FreeRotation, SeriesPathMatchesReferencePath) {
  Lcg rng{2024};
  double worst_R = 0, worst_w = 0, worst_m = 0;
  int n_series = 0, n_reference = 0;
  double m_series_max = 0;
  for (int i = 0; i < 1200; ++i) {
    double m;
    switch (i % 4) {
      case 0: m = std::pow(10.0, rng.uniform(-16, -1)); break;
      case 3: m = 1 - std::pow(10.0, rng.uniform(-12, -1)); break;
      default: m = rng.uniform(); break;
    }
    const FreeRotation fr = body_with_m(rng, m);
    ASSERT_EQ(fr.mode(), FreeRotation::Mode::Elliptic) << "m " << m;
    if (fr.uses_series()) {
      ++n_series;
      m_series_max = std::max(m_series_max, fr.parameter_m());
    } else {
      ++n_reference;
    }
    const double T = fr.body_period();
    const double w_scale = fr.max_rate();
    for (int k = 0; k < 40; ++k) {
      const double t = (k < 10 ? rng.uniform(-2, 2) : rng.uniform(-1e4, 1e4)) * T;
      const double eR = max_abs(fr.orientation(t) - fr.orientation_reference(t));
      const double ew = max_abs(fr.omega_body(t) - fr.omega_body_reference(t)) / w_scale;
      if (eR > worst_R) worst_m = fr.parameter_m();
      worst_R = std::max(worst_R, eR);
      worst_w = std::max(worst_w, ew);
      ASSERT_LE(eR, 1e-13) << "m " << fr.parameter_m() << " t/T " << t / T;
      ASSERT_LE(ew, 1e-13) << "m " << fr.parameter_m() << " t/T " << t / T;
    }
  }
  EXPECT_GT(n_series, 800);
  EXPECT_GT(n_reference, 100);
  EXPECT_GT(m_series_max, 0.98);
  std::printf("series vs reference path (%d series, %d fallback bodies, series up to m = %.4f): "
              "max |dR| = %.2e (at m = %.3g), max |d omega| / max_rate = %.2e\n",
              n_series, n_reference, m_series_max, worst_R, worst_m, worst_w);
}

// The series path at the special values m = 0 (symmetric top about either
// end axis, characteristic n = 0 or n < 0) and tiny m, against the reference.
TEST(FreeRotation, SeriesPathAtSymmetricLimit) {
  Lcg rng{31};
  double worst = 0;
  for (const Vec3& I : {Vec3(2, 2, 7), Vec3(7, 2, 7), Vec3(2, 2 * (1 + 1e-15), 7), Vec3(3, 8, 8 * (1 + 1e-9))}) {
    for (int rep = 0; rep < 10; ++rep) {
      const Mat3 R0 = rng.rotation();
      const FreeRotation fr(I, R0, R0 * rng.vec(-2, 2));
      if (fr.mode() != FreeRotation::Mode::Elliptic) continue;
      EXPECT_TRUE(fr.uses_series()) << "m " << fr.parameter_m();
      const double T = fr.body_period();
      for (double u : {0.0, 0.3, -1.7, 12.9, 9999.3}) {
        const double e = max_abs(fr.orientation(u * T) - fr.orientation_reference(u * T));
        EXPECT_LE(e, 1e-13) << "I " << I.transpose() << " m " << fr.parameter_m() << " t/T " << u;
        worst = std::max(worst, e);
      }
    }
  }
  std::printf("series vs reference at m = 0 and tiny m: max |dR| = %.2e\n", worst);
}

// ---- special functions against Boost.Math --------------------------------------

TEST(FreeRotation, CarlsonIntegralsMatchBoost) {
  Lcg rng{99};
  double worst = 0;
  for (int i = 0; i < 2000; ++i) {
    const double x = std::pow(10.0, rng.uniform(-12, 1)), y = std::pow(10.0, rng.uniform(-12, 1));
    const double z = rng.uniform(0.1, 3), p = rng.uniform(0.2, 4);
    const double rf = ringsim::elliptic::carlson_rf(x, y, z), rf_b = boost::math::ellint_rf(x, y, z);
    const double rj = ringsim::elliptic::carlson_rj(x, y, z, p), rj_b = boost::math::ellint_rj(x, y, z, p);
    worst = std::max({worst, std::abs(rf / rf_b - 1), std::abs(rj / rj_b - 1)});
  }
  EXPECT_LE(worst, 1e-14);
  // The pieces of the precession angle: F(phi|m) = sin R_F(cos^2, 1 - m sin^2, 1),
  // Pi(n; phi|m) = F + (n/3) sin^3 R_J(cos^2, 1 - m sin^2, 1, 1 - n sin^2), with
  // Boost's sign convention (1 - n sin^2) for ellint_3(k, n, phi).
  for (double m : {0.0, 0.3, 0.9, 0.999999}) {
    for (double n : {-1.0, -0.4, 0.0}) {
      for (double phi : {0.1, 0.8, 1.5}) {
        const double s = std::sin(phi), c = std::cos(phi), d2 = 1 - m * s * s;
        const double F = s * ringsim::elliptic::carlson_rf(c * c, d2, 1.0);
        const double Pi = F + n / 3 * s * s * s * ringsim::elliptic::carlson_rj(c * c, d2, 1.0, 1 - n * s * s);
        EXPECT_NEAR(F, boost::math::ellint_1(std::sqrt(m), phi), 1e-14);
        EXPECT_NEAR(Pi, boost::math::ellint_3(std::sqrt(m), n, phi), 1e-14);
      }
    }
  }
}

}  // namespace
