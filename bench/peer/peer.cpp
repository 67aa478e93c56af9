// ringsim_peer: one replicate of the model on Bullet (docs/PEER.md).
#include "peer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_set>
#include <utility>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "analysis/mser.hpp"
#include "core/body.hpp"
#include "core/bond_graph.hpp"
#include "core/bond_rules.hpp"
#include "core/compliant.hpp"
#include "core/contact.hpp"
#include "core/joints.hpp"
#include "core/motion.hpp"
#include "core/prediction.hpp"
#include "core/scene.hpp"
#include "core/vec.hpp"
#include "ensemble/replicate_command.hpp"
#include "held_angle.hpp"
#include "held_dihedral.hpp"
#include "ringsim/version.hpp"

namespace ringsim::peer {

const char* to_string(JointReading j) { return j == JointReading::Welded ? "welded" : "articulated"; }

JointReading joint_reading_from_string(const std::string& s) {
  if (s == "welded") return JointReading::Welded;
  if (s == "articulated") return JointReading::Articulated;
  throw std::invalid_argument("bonding.joint must be welded or articulated, not '" + s + "'");
}

namespace {

btVector3 to_bt(const Vec3& v) { return btVector3(btScalar(v.x()), btScalar(v.y()), btScalar(v.z())); }
Vec3 to_vec(const btVector3& v) { return Vec3(double(v.x()), double(v.y()), double(v.z())); }

// Pair coefficients by the configured rules. Bullet asks a global callback
// for the combined restitution and friction of a new contact point; the rule
// is process-wide because the callback takes no context (one world at a time).
CombineRule g_restitution_rule = CombineRule::Min;
CombineRule g_friction_rule = CombineRule::Product;
btScalar combined_restitution(const btCollisionObject* a, const btCollisionObject* b) {
  return btScalar(combine(g_restitution_rule, a->getRestitution(), b->getRestitution()));
}
btScalar combined_friction(const btCollisionObject* a, const btCollisionObject* b) {
  return btScalar(combine(g_friction_rule, a->getFriction(), b->getFriction()));
}

// Which pairs never collide. Welded: members of one cluster (ringsim: their
// relative pose is frozen). Articulated: the bonding exclusions (MODEL.md,
// "Contacts"; BondGraph::excluded, as ringsim): a sphere and a linker
// bonded to each other, and with 1-3 also two linkers on one sphere and two
// spheres on one linker; every other pair collides, inside a cluster too.
// The broadphase keeps excluded pairs, so the near callback skips them and
// empties any manifold they still hold. Set while a world steps.
const BondGraph* g_graph = nullptr;
bool g_articulated = false;
bool g_one_two = false;  // bonding.exclusions = 1-2

void near_callback(btBroadphasePair& pair, btCollisionDispatcher& dispatcher, const btDispatcherInfo& info) {
  const auto* a = static_cast<const btCollisionObject*>(pair.m_pProxy0->m_clientObject);
  const auto* b = static_cast<const btCollisionObject*>(pair.m_pProxy1->m_clientObject);
  const int i = a->getUserIndex(), j = b->getUserIndex();
  if (g_graph && i >= 0 && j >= 0 &&
      (g_articulated ? g_graph->excluded(i, j, !g_one_two) : g_graph->same_component(i, j))) {
    if (pair.m_algorithm) {
      btManifoldArray manifolds;
      pair.m_algorithm->getAllContactManifolds(manifolds);
      for (int k = 0; k < manifolds.size(); ++k) manifolds[k]->clearManifold();
    }
    return;
  }
  btCollisionDispatcher::defaultNearCallback(pair, dispatcher, info);
}

// A failure mode of the stepped engine: how often and when first.
struct Failure {
  long count = 0;
  double first_t = -1.0;
  void note(double t) {
    if (count++ == 0) first_t = t;
  }
  nlohmann::json json() const {
    return {{"count", count}, {"first_t", first_t >= 0 ? nlohmann::json(first_t) : nlohmann::json(nullptr)}};
  }
};

// One bond held by a Bullet constraint, with the frames at capture (to
// measure how far the constraint lets the pose drift). Welded: a
// btFixedConstraint holding the whole relative pose (frame_a, frame_b).
// Articulated: a btPoint2PointConstraint, the ball joint at the sphere's
// centre (frame_a's origin 0 in the sphere, frame_b's origin the capture
// position of that centre in the linker's frame; their rotations unused).
struct HeldBond {
  int a = -1, b = -1;  // body ids (sphere, linker)
  btTransform frame_a, frame_b;
  std::unique_ptr<btTypedConstraint> constraint;
};

// A held bond angle (articulated, bonding.angle_filter on): one row between
// two linkers on one sphere (held_angle.hpp).
struct HeldAngleRow {
  int sphere = -1;
  std::unique_ptr<HeldAngleConstraint> constraint;
};

class Peer {
 public:
  Peer(const SimParams& p, std::uint64_t seed, std::uint64_t replicate, const PeerOptions& opt)
      : p_(p),
        opt_(opt),
        store_(build_scene(p, seed, replicate, &scene_)),
        box_{p.geometry.box_length, p.geometry.boundary == Boundary::Periodic},
        predictor_(store_, box_, p.run.contact_tolerance),
        n_(store_.size()),
        n_s_(count(Shape::Sphere)),
        graph_(n_s_, n_ - n_s_),
        monitor_(p.run.sample_interval, static_cast<std::size_t>(p.run.mser_min_samples),
                 static_cast<std::size_t>(p.run.mser_check_every), static_cast<std::size_t>(p.run.mser_batch)) {
    if (box_.periodic)
      throw std::invalid_argument("the Bullet peer has reflective walls only (geometry.boundary = reflective)");
    if (opt.dt <= 0 || !std::isfinite(opt.dt)) throw std::invalid_argument("--dt must be a positive number");
    if (p.compliant.enabled() && p.bonding.enabled)
      throw std::invalid_argument("the Bullet peer has rigid (welded or articulated) bonds only; compliant bonds are "
                                  "not modelled");
    if (opt.joint == JointReading::Welded && p.bonding.enabled && p.bonding.exclusions == Exclusions::OneTwo)
      throw std::invalid_argument("bonding.exclusions = 1-2 needs bonding.joint = articulated (welded clusters never "
                                  "collide inside); use 1-3");
    store_.free_all();  // every body free: the capture gap reads kin (mirror())
    predictor_.set_capture_site(p.bonding.capture_site);
    if (articulated())
      for (int i = 0; i < n_; ++i) topology_.bodies.push_back(compliant_body_from(store_.kin[i], store_.sp(i)));
    build_world();
  }

  ~Peer() {
    g_graph = nullptr;
    g_articulated = false;
    for (auto& hd : dihedrals_) world_->removeConstraint(hd.get());
    for (auto& ha : angles_) world_->removeConstraint(ha.constraint.get());
    for (auto& hb : held_) world_->removeConstraint(hb.constraint.get());
    for (auto& b : bodies_) world_->removeRigidBody(b.get());
    for (auto& w : walls_) world_->removeRigidBody(w.get());
  }

  nlohmann::json run();

 private:
  int count(Shape s) const {
    int c = 0;
    for (int i = 0; i < store_.size(); ++i) c += store_.shape[i] == s;
    return c;
  }
  void build_world();
  // Kinetic energy (translational, rotational) and momentum from the engine.
  std::tuple<double, double, Vec3> mechanics() const;
  // Copies the engine's poses at time t into store_ (for the capture gap).
  void mirror(double t);
  // Contacts of the step: collisions begun, largest penetration.
  void scan_contacts(double t);
  // Captures of the step (bonding on).
  void captures(double t);
  bool rules_pass(int s, int l, int end, double t);
  void form_bond(int s, int l, int end, double t, bool closure);
  // Articulated: the held angles and dihedrals a bond (s, l, end) creates.
  void hold_rows(int s, int l, int end);
  bool bond_possible() const;
  void check_state(double t);
  // The bonds' drift (welded: the frames' shift and turn; articulated: the
  // ball joints' separation and the held angles' error, degrees), and for
  // held dihedrals their largest |phi - phi0| (degrees) and |C|.
  double bond_drift(double* angle_deg, double* dihedral_deg, double* dihedral_c) const;
  bool articulated() const { return opt_.joint == JointReading::Articulated; }

  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();  // set-up included, as ringsim
  SimParams p_;
  PeerOptions opt_;
  SceneReport scene_;
  BodyStore store_;
  Box box_;
  Predictor predictor_;
  int n_, n_s_;
  BondGraph graph_;
  SteadyStateMonitor monitor_;

  std::unique_ptr<btDefaultCollisionConfiguration> config_;
  std::unique_ptr<btCollisionDispatcher> dispatcher_;
  std::unique_ptr<btBroadphaseInterface> broadphase_;
  std::unique_ptr<HeldDihedralSolver> solver_;  // Bullet's solver, plus the held dihedrals' rows
  std::unique_ptr<btDiscreteDynamicsWorld> world_;
  std::vector<std::unique_ptr<btCollisionShape>> shapes_;
  std::vector<std::unique_ptr<btRigidBody>> bodies_, walls_;
  std::vector<btVector3> inertia_;  // principal moments in the body frame
  std::vector<HeldBond> held_;       // one per bond
  std::vector<HeldAngleRow> angles_;  // articulated, angle filter on
  std::vector<std::unique_ptr<HeldDihedralConstraint>> dihedrals_;  // articulated, coplanarity filter on
  // Articulated: the bonds as ringsim's cluster topology, every body by its
  // id (add_articulated_bond decides which angles and dihedrals a bond
  // holds), with the held rows it made (joints_; their values at bonding).
  CompliantCluster topology_;
  JointSet joints_;

  // Contact episodes: a pair touching at this step and not at the last one
  // is one collision (keys: i * (n + 6) + j, walls as n .. n + 5).
  std::unordered_set<std::uint64_t> touching_, touching_next_;
  // Capture pairs inside the shell at the last step (key: (2 l + end) * n + s).
  std::unordered_set<std::uint64_t> inside_, inside_next_;
  std::vector<std::uint64_t> handled_;  // pairs the closure scan of this step already decided

  long steps_ = 0, collisions_ = 0, wall_collisions_ = 0;
  long captures_ = 0, bonds_ = 0, closure_bonds_ = 0;
  long rejected_valency_ = 0, rejected_angle_ = 0, rejected_coplanarity_ = 0;
  double max_penetration_ = 0.0, max_penetration_t_ = 0.0, sum_step_penetration_ = 0.0;
  double e0_ = 0.0, e_min_ = 0.0, e_max_ = 0.0;
  double max_bond_drift_ = 0.0, max_bond_angle_deg_ = 0.0, max_dihedral_deg_ = 0.0, max_dihedral_c_ = 0.0;
  Failure non_finite_, escaped_, deep_penetration_, energy_blowup_, energy_drain_, joint_drift_, drift_capture_;
  std::string error_;
};

void Peer::build_world() {
  config_ = std::make_unique<btDefaultCollisionConfiguration>();
  dispatcher_ = std::make_unique<btCollisionDispatcher>(config_.get());
  broadphase_ = std::make_unique<btDbvtBroadphase>();
  solver_ = std::make_unique<HeldDihedralSolver>();
  world_ = std::make_unique<btDiscreteDynamicsWorld>(dispatcher_.get(), broadphase_.get(), solver_.get(),
                                                     config_.get());
  world_->setGravity(btVector3(0, 0, 0));
  dispatcher_->setNearCallback(near_callback);
  g_restitution_rule = p_.contact.restitution_rule;
  g_friction_rule = p_.contact.friction_rule;
  gCalculateCombinedRestitutionCallback = combined_restitution;
  gCalculateCombinedFrictionCallback = combined_friction;

  btContactSolverInfo& info = world_->getSolverInfo();
  info.m_numIterations = opt_.solver_iterations;
  const bool stock = opt_.bullet_defaults;
  if (!stock) {
    // Restitution at every approach speed: Bullet's default (0.2) makes
    // slower contacts perfectly inelastic, and most contacts of this gas are
    // slower than that.
    info.m_restitutionVelocityThreshold = 0;
    // Every penetration is pushed out by the split impulse, which moves
    // positions without touching velocities; within the default band
    // (0.04) Bullet feeds the penetration into the velocity (Baumgarte),
    // which puts energy in.
    info.m_splitImpulse = 1;
    info.m_splitImpulsePenetrationThreshold = 0;
  }
  // Shapes from the project's species (core/scene.hpp).
  const Species& ss = store_.species[static_cast<int>(Shape::Sphere)];
  const Species& sl = store_.species[static_cast<int>(Shape::Linker)];
  auto sphere = std::make_unique<btSphereShape>(btScalar(ss.radius));  // its margin is its radius: exact
  auto cyl = std::make_unique<btCylinderShapeZ>(btVector3(btScalar(sl.radius), btScalar(sl.radius), btScalar(sl.half_length)));
  // Margin 0: the cylinder is the solid itself (with a margin, Bullet rounds
  // its edges and detects contacts that far out).
  if (!stock) cyl->setMargin(0);
  btCollisionShape* shape_of[2] = {sphere.get(), cyl.get()};
  shapes_.push_back(std::move(sphere));
  shapes_.push_back(std::move(cyl));

  auto settle = [&](btRigidBody* b) {
    b->setActivationState(DISABLE_DEACTIVATION);  // no sleeping: a slow body is still moving
    // Speculative contacts off: Bullet solves contact points up to this gap
    // ahead, slowing an approaching pair to arrive exactly at contact, which
    // loses the energy its restitution should have returned.
    if (!stock) b->setContactProcessingThreshold(0);
  };
  for (int i = 0; i < n_; ++i) {
    const Species& s = store_.sp(i);
    const Kinematics& k = store_.kin[i];
    btTransform tr;
    tr.setIdentity();
    tr.setOrigin(to_bt(k.x));
    if (store_.shape[i] == Shape::Linker) {
      const Quat q = orientation_from_axis(k.axis);
      tr.setRotation(btQuaternion(btScalar(q.x()), btScalar(q.y()), btScalar(q.z()), btScalar(q.w())));
    }
    // Inertia from the project's species (cylinder axis = local z).
    const btVector3 inertia = store_.shape[i] == Shape::Linker
                                  ? btVector3(btScalar(s.i_perp), btScalar(s.i_perp), btScalar(s.i_axial))
                                  : btVector3(btScalar(s.i_axial), btScalar(s.i_axial), btScalar(s.i_axial));
    btRigidBody::btRigidBodyConstructionInfo ci(btScalar(s.mass), nullptr, shape_of[static_cast<int>(store_.shape[i])],
                                                inertia);
    ci.m_startWorldTransform = tr;
    ci.m_restitution = btScalar(s.restitution);
    // Bullet has one Coulomb coefficient; the dynamic one is the sliding law.
    ci.m_friction = btScalar(s.dynamic_friction);
    ci.m_linearDamping = 0;
    ci.m_angularDamping = 0;
    auto body = std::make_unique<btRigidBody>(ci);
    body->setUserIndex(i);
    body->setLinearVelocity(to_bt(k.v));
    body->setAngularVelocity(to_bt(omega_at(k, k.t)));
    // Torque-free precession of the linkers (the default since Bullet 2.83;
    // stated here because without it a tumbling linker keeps omega fixed).
    body->setFlags(BT_ENABLE_GYROSCOPIC_FORCE_IMPLICIT_BODY);
    settle(body.get());
    world_->addRigidBody(body.get());
    inertia_.push_back(inertia);
    bodies_.push_back(std::move(body));
  }
  // Reflective walls of [0, L]^3: six static slabs outside the box (not
  // infinite planes: a plane's bounding box holds every body, so the
  // broadphase would pair each plane with all of them at every step).
  const double L = p_.geometry.box_length;
  const double thick = 0.5 * L;  // far thicker than any step's travel
  for (int w = 0; w < 6; ++w) {
    const int axis = w / 2;
    const bool far = w % 2 == 1;
    btVector3 half(btScalar(0.5 * L + thick), btScalar(0.5 * L + thick), btScalar(0.5 * L + thick));
    half[axis] = btScalar(0.5 * thick);
    auto slab = std::make_unique<btBoxShape>(half);
    if (!stock) slab->setMargin(0);  // the slab's face is the wall itself
    btTransform tr;
    tr.setIdentity();
    btVector3 centre(btScalar(0.5 * L), btScalar(0.5 * L), btScalar(0.5 * L));
    centre[axis] = btScalar(far ? L + 0.5 * thick : -0.5 * thick);
    tr.setOrigin(centre);
    btRigidBody::btRigidBodyConstructionInfo ci(0, nullptr, slab.get());
    ci.m_startWorldTransform = tr;
    ci.m_restitution = btScalar(p_.contact.restitution_wall);
    ci.m_friction = btScalar(p_.contact.dynamic_friction_wall);
    auto wall = std::make_unique<btRigidBody>(ci);
    wall->setUserIndex(-1 - w);
    if (!stock) wall->setContactProcessingThreshold(0);
    world_->addRigidBody(wall.get());
    shapes_.push_back(std::move(slab));
    walls_.push_back(std::move(wall));
  }
}

std::tuple<double, double, Vec3> Peer::mechanics() const {
  double et = 0, er = 0;
  Vec3 mom = Vec3::Zero();
  for (int i = 0; i < n_; ++i) {
    const btRigidBody& b = *bodies_[i];
    const double m = store_.sp(i).mass;
    const Vec3 v = to_vec(b.getLinearVelocity());
    et += 0.5 * m * v.squaredNorm();
    mom += m * v;
    const btVector3 wl = b.getWorldTransform().getBasis().transpose() * b.getAngularVelocity();
    for (int k = 0; k < 3; ++k) er += 0.5 * double(inertia_[i][k]) * double(wl[k]) * double(wl[k]);
  }
  return {et, er, mom};
}

void Peer::mirror(double t) {
  for (int i = 0; i < n_; ++i) {
    const btTransform& tr = bodies_[i]->getWorldTransform();
    Kinematics& k = store_.kin[i];
    k.x = to_vec(tr.getOrigin());
    k.t = t;
    k.v = to_vec(bodies_[i]->getLinearVelocity());
    if (store_.shape[i] == Shape::Linker) k.axis = to_vec(tr.getBasis().getColumn(2)).normalized();
    k.precession = Vec3::Zero();
    k.spin = 0.0;
  }
}

void Peer::scan_contacts(double t) {
  touching_next_.clear();
  double step_max = 0.0;
  const int walls = 6;
  const int m = dispatcher_->getNumManifolds();
  for (int k = 0; k < m; ++k) {
    const btPersistentManifold* pm = dispatcher_->getManifoldByIndexInternal(k);
    double dmin = std::numeric_limits<double>::infinity();
    for (int c = 0; c < pm->getNumContacts(); ++c) dmin = std::min(dmin, double(pm->getContactPoint(c).getDistance()));
    if (!(dmin <= 0.0)) continue;
    step_max = std::max(step_max, -dmin);
    int i = pm->getBody0()->getUserIndex(), j = pm->getBody1()->getUserIndex();
    if (i < 0) i = n_ + (-1 - i);
    if (j < 0) j = n_ + (-1 - j);
    if (i > j) std::swap(i, j);
    const std::uint64_t key = static_cast<std::uint64_t>(i) * static_cast<std::uint64_t>(n_ + walls) + j;
    touching_next_.insert(key);
    if (!touching_.count(key)) {
      if (j >= n_) ++wall_collisions_;
      else ++collisions_;
    }
  }
  std::swap(touching_, touching_next_);
  sum_step_penetration_ += step_max;
  if (step_max > max_penetration_) {
    max_penetration_ = step_max;
    max_penetration_t_ = t;
  }
  // Deeper than the capture distance: the contact geometry the bond rules
  // read is then off by more than the shell the model resolves.
  if (step_max > p_.bonding.capture_distance) deep_penetration_.note(t);
}

bool Peer::rules_pass(int s, int l, int end, double t) {
  // The rules in ringsim's order (docs/MODEL_IMPLEMENTATION.md, "Bond
  // rules"), measured with core/bond_rules.hpp on this step's axes.
  const BondingParams& bp = p_.bonding;
  if (bp.end_valency < 1 || graph_.sphere_of(l, end) >= 0 || graph_.degree(s) >= bp.sphere_valency) {
    ++rejected_valency_;
    return false;
  }
  auto axis = [&](int body) { return store_.kin[body].axis; };
  const Vec3 u = axis(l);
  const Vec3 out = outward_axis(u, end);
  if (bp.angle_filter) {
    for (const BondedEnd& other : graph_.linkers_of(s)) {
      const double theta = bond_angle_deg(out, outward_axis(axis(other.linker), other.end));
      // Articulated: a held angle needs a measurable gradient (ringsim's
      // rule; core/joints.hpp, held_angle_defined).
      if (!angle_ok(theta, bp) || (articulated() && !held_angle_defined(theta * M_PI / 180.0))) {
        ++rejected_angle_;
        return false;
      }
    }
  }
  if (!bp.coplanarity_filter) return true;
  // The dihedral about a linker of axis uc, given its neighbours' outward
  // axes at its end 0 and at its end 1.
  // Articulated: a held dihedral needs a measurable phi0 (ringsim's rule;
  // core/joints.hpp, held_dihedral_defined).
  auto planar = [&](const Vec3& uc, const Vec3& at0, const Vec3& at1) {
    if (articulated() && !held_dihedral_defined(uc, at0, at1)) return false;
    return planarity_ok(dihedral_deg(uc, at0, at1), bp);
  };
  // The new linker, when its other end already sits on a sphere: every pair
  // of neighbours (one at s, one at that sphere).
  const int far_sphere = graph_.sphere_of(l, 1 - end);
  if (far_sphere >= 0) {
    for (const BondedEnd& here : graph_.linkers_of(s)) {
      const Vec3 n_here = outward_axis(axis(here.linker), here.end);
      for (const BondedEnd& there : graph_.linkers_of(far_sphere)) {
        if (there.linker == l) continue;
        const Vec3 n_there = outward_axis(axis(there.linker), there.end);
        const bool ok = end == 0 ? planar(u, n_here, n_there) : planar(u, n_there, n_here);
        if (!ok) {
          ++rejected_coplanarity_;
          return false;
        }
      }
    }
  }
  // Every linker already at s whose other end is bonded: the new linker
  // becomes its neighbour at s.
  for (const BondedEnd& c : graph_.linkers_of(s)) {
    const int s3 = graph_.sphere_of(c.linker, 1 - c.end);
    if (s3 < 0) continue;
    const Vec3 uc = axis(c.linker);
    for (const BondedEnd& nb : graph_.linkers_of(s3)) {
      if (nb.linker == c.linker) continue;
      const Vec3 n3 = outward_axis(axis(nb.linker), nb.end);
      const bool ok = c.end == 0 ? planar(uc, out, n3) : planar(uc, n3, out);
      if (!ok) {
        ++rejected_coplanarity_;
        return false;
      }
    }
  }
  (void)t;
  return true;
}

void Peer::form_bond(int s, int l, int end, double t, bool closure) {
  // Welded: the relative pose of this step, held by a fixed constraint whose
  // frame sits at the sphere's centre. Articulated: a ball joint at the
  // sphere's centre, and with the angle filter on the angle to every linker
  // already on the sphere held at its value of this step.
  const bool merge = !graph_.same_component(s, l);
  std::vector<int> side_s, side_l;
  if (merge && !closure) {
    const int cs = graph_.component(s), cl = graph_.component(l);
    for (int i = 0; i < n_; ++i) {
      const int c = graph_.component(i);
      if (c == cs) side_s.push_back(i);
      else if (c == cl) side_l.push_back(i);
    }
  }
  graph_.add_bond(s, l, end, t);
  ++bonds_;
  if (closure) ++closure_bonds_;
  btRigidBody& a = *bodies_[s];
  btRigidBody& b = *bodies_[l];
  btTransform at;
  at.setIdentity();
  at.setOrigin(a.getWorldTransform().getOrigin());
  HeldBond hb;
  hb.a = s;
  hb.b = l;
  hb.frame_a = a.getWorldTransform().inverse() * at;
  hb.frame_b = b.getWorldTransform().inverse() * at;
  if (articulated())
    hb.constraint = std::make_unique<btPoint2PointConstraint>(a, b, hb.frame_a.getOrigin(), hb.frame_b.getOrigin());
  else
    hb.constraint = std::make_unique<btFixedConstraint>(a, b, hb.frame_a, hb.frame_b);
  world_->addConstraint(hb.constraint.get(), true);  // no contacts between the two
  held_.push_back(std::move(hb));
  if (articulated()) hold_rows(s, l, end);
  monitor_.set(t, graph_.N_t());
  if (!merge || closure) return;
  // Ring closure (ringsim's rigid merge): every (sphere, free end) pair the
  // merge put inside one cluster, within the shell now, in (sphere, linker,
  // end) order.
  std::vector<std::tuple<int, int, int>> closures;
  const double rc = p_.bonding.capture_distance;
  auto scan = [&](const std::vector<int>& from, const std::vector<int>& to) {
    for (int x : from) {
      if (store_.shape[x] != Shape::Sphere) continue;
      for (int y : to) {
        if (store_.shape[y] != Shape::Linker) continue;
        for (int e = 0; e < 2; ++e)
          if (graph_.sphere_of(y, e) < 0 && predictor_.capture_gap(y, e, x, t, rc) <= p_.run.contact_tolerance)
            closures.emplace_back(x, y, e);
      }
    }
  };
  scan(side_s, side_l);
  scan(side_l, side_s);
  std::sort(closures.begin(), closures.end());
  for (const auto& [cs, cl, ce] : closures) {
    handled_.push_back((2 * static_cast<std::uint64_t>(cl) + ce) * n_ + cs);
    if (rules_pass(cs, cl, ce, t)) form_bond(cs, cl, ce, t, true);
  }
}

void Peer::hold_rows(int s, int l, int end) {
  // ringsim's add_articulated_bond on the bonds so far decides what the bond
  // holds (with the filters on: a held angle per linker already on s, a held
  // dihedral per pair of neighbours about every linker whose two ends are
  // now bonded to spheres with a second linker; rules_pass refused the
  // capture if one could not be held), measured on this step's poses.
  for (int i = n_s_; i < n_; ++i) {
    const btQuaternion q = bodies_[i]->getWorldTransform().getRotation();
    topology_.bodies[i].q = Quat(double(q.w()), double(q.x()), double(q.y()), double(q.z())).normalized();
  }
  const std::size_t na = joints_.angles.size(), nd = joints_.dihedrals.size();
  add_articulated_bond(topology_, joints_, s, l, end, p_.bonding);
  // Contacts between the linkers of a row are the exclusions' to decide (near_callback).
  for (std::size_t k = na; k < joints_.angles.size(); ++k) {
    // Its theta0 from the engine's axes (HeldAngleConstraint).
    const HeldAngle& a = joints_.angles[k];
    HeldAngleRow ha;
    ha.sphere = a.sphere;
    ha.constraint = std::make_unique<HeldAngleConstraint>(*bodies_[a.linker_a], a.end_a, *bodies_[a.linker_b], a.end_b);
    world_->addConstraint(ha.constraint.get(), false);
    angles_.push_back(std::move(ha));
  }
  for (std::size_t k = nd; k < joints_.dihedrals.size(); ++k) {
    const HeldDihedral& d = joints_.dihedrals[k];
    dihedrals_.push_back(std::make_unique<HeldDihedralConstraint>(*bodies_[d.linker], *bodies_[d.nb0], d.nb0_end,
                                                                  *bodies_[d.nb1], d.nb1_end, d.phi0));
    world_->addConstraint(dihedrals_.back().get(), false);
  }
}

void Peer::captures(double t) {
  // Pairs that could still bond (a free end, a sphere below its valency);
  // ringsim predicts captures for exactly these. A pair is a capture when
  // its gap is <= r_c at this step and was not at the last one.
  const BondingParams& bp = p_.bonding;
  const double rc = bp.capture_distance;
  const Species& sl = store_.species[static_cast<int>(Shape::Linker)];
  const double reach = Predictor::capture_arm(sl, bp.capture_site) + store_.species[0].radius + rc;
  const double L = p_.geometry.box_length;
  const int cells = std::max(1, std::min(64, static_cast<int>(L / reach)));
  const double w = L / cells;
  auto cell = [&](double x) { return std::clamp(static_cast<int>(std::floor(x / w)), 0, cells - 1); };
  // Spheres below their valency, binned.
  std::vector<std::vector<int>> bins(static_cast<std::size_t>(cells) * cells * cells);
  auto bin = [&](int cx, int cy, int cz) -> std::vector<int>& {
    return bins[(static_cast<std::size_t>(cx) * cells + cy) * cells + cz];
  };
  for (int s = 0; s < n_s_; ++s) {
    if (graph_.degree(s) >= bp.sphere_valency) continue;
    const Vec3& x = store_.kin[s].x;
    bin(cell(x.x()), cell(x.y()), cell(x.z())).push_back(s);
  }
  inside_next_.clear();
  std::vector<std::tuple<int, int, int>> entered;  // (sphere, linker, end)
  for (int l = n_s_; l < n_; ++l) {
    const bool free0 = graph_.sphere_of(l, 0) < 0, free1 = graph_.sphere_of(l, 1) < 0;
    if (!free0 && !free1) continue;
    const Vec3& x = store_.kin[l].x;
    const int cx = cell(x.x()), cy = cell(x.y()), cz = cell(x.z());
    for (int ix = std::max(0, cx - 1); ix <= std::min(cells - 1, cx + 1); ++ix)
      for (int iy = std::max(0, cy - 1); iy <= std::min(cells - 1, cy + 1); ++iy)
        for (int iz = std::max(0, cz - 1); iz <= std::min(cells - 1, cz + 1); ++iz)
          for (int s : bin(ix, iy, iz)) {
            if ((store_.kin[s].x - x).squaredNorm() > reach * reach) continue;
            for (int e = 0; e < 2; ++e) {
              if (!(e == 0 ? free0 : free1)) continue;
              if (predictor_.capture_gap(l, e, s, t, rc) > 0.0) continue;
              const std::uint64_t key = (2 * static_cast<std::uint64_t>(l) + e) * n_ + s;
              inside_next_.insert(key);
              if (!inside_.count(key)) entered.emplace_back(s, l, e);
            }
          }
  }
  std::swap(inside_, inside_next_);
  std::sort(entered.begin(), entered.end());
  handled_.clear();
  for (const auto& [s, l, e] : entered) {
    const std::uint64_t key = (2 * static_cast<std::uint64_t>(l) + e) * n_ + s;
    if (std::find(handled_.begin(), handled_.end(), key) != handled_.end()) continue;
    if (graph_.sphere_of(l, e) >= 0) continue;  // bonded earlier in this step
    if (!articulated() && graph_.same_component(s, l)) {
      // Welded: the rigid reading never captures inside a cluster; a gap
      // crossing r_c there is the constraints' drift. (Articulated clusters
      // flex: a capture inside one is a capture, the ring closure of a
      // chain.)
      drift_capture_.note(t);
      continue;
    }
    ++captures_;
    if (rules_pass(s, l, e, t)) form_bond(s, l, e, t, false);
  }
}

bool Peer::bond_possible() const {
  // Welded: a free end and a sphere below its valency in different clusters.
  // Articulated: anywhere (a cluster can close a ring inside itself; the peer
  // does not single out clusters without internal freedom, which ringsim
  // carries rigidly).
  const BondingParams& bp = p_.bonding;
  if (bp.end_valency < 1) return false;
  int first = -1;
  bool any_sphere = false, any_end = false, spread = false;
  auto note = [&](int b) {
    const int c = graph_.component(b);
    if (first < 0) first = c;
    else if (c != first) spread = true;
  };
  for (int s = 0; s < n_s_; ++s)
    if (graph_.degree(s) < bp.sphere_valency) {
      any_sphere = true;
      note(s);
    }
  for (int l = n_s_; l < n_; ++l)
    if (graph_.sphere_of(l, 0) < 0 || graph_.sphere_of(l, 1) < 0) {
      any_end = true;
      note(l);
    }
  return any_sphere && any_end && (spread || articulated());
}

double Peer::bond_drift(double* angle_deg, double* dihedral_deg, double* dihedral_c) const {
  double worst = 0.0, worst_angle = 0.0;
  *dihedral_deg = *dihedral_c = 0.0;
  if (articulated()) {
    // The ball joints' separation (the two pivots in the world) and the held
    // angles' error.
    for (const HeldBond& hb : held_) {
      const btVector3 pa = bodies_[hb.a]->getWorldTransform() * hb.frame_a.getOrigin();
      const btVector3 pb = bodies_[hb.b]->getWorldTransform() * hb.frame_b.getOrigin();
      worst = std::max(worst, double((pa - pb).length()));
    }
    for (const HeldAngleRow& ha : angles_)
      worst_angle = std::max(worst_angle, double(ha.constraint->angle_error()) * 180.0 / M_PI);
    for (const auto& hd : dihedrals_) {
      *dihedral_deg = std::max(*dihedral_deg, hd->dihedral_error() * 180.0 / M_PI);
      *dihedral_c = std::max(*dihedral_c, std::abs(hd->residual()));
    }
    *angle_deg = worst_angle;
    return worst;
  }
  for (const HeldBond& hb : held_) {
    const btTransform fa = bodies_[hb.a]->getWorldTransform() * hb.frame_a;
    const btTransform fb = bodies_[hb.b]->getWorldTransform() * hb.frame_b;
    worst = std::max(worst, double((fa.getOrigin() - fb.getOrigin()).length()));
    const btQuaternion rel = fa.getRotation().inverse() * fb.getRotation();
    worst_angle = std::max(worst_angle, double(rel.getAngleShortestPath()) * 180.0 / M_PI);
  }
  *angle_deg = worst_angle;
  return worst;
}

void Peer::check_state(double t) {
  const auto [et, er, mom] = mechanics();
  const double e = et + er;
  if (!std::isfinite(e) || !mom.allFinite()) {
    non_finite_.note(t);
    return;
  }
  e_min_ = std::min(e_min_, e);
  e_max_ = std::max(e_max_, e);
  if (e > 1.5 * e0_) energy_blowup_.note(t);
  if (!p_.bonding.enabled && e < 0.5 * e0_) energy_drain_.note(t);
  const double L = p_.geometry.box_length;
  for (int i = 0; i < n_; ++i) {
    const Vec3 x = to_vec(bodies_[i]->getWorldTransform().getOrigin());
    const double r = store_.sp(i).bounding_radius;
    if ((x.array() < -r).any() || (x.array() > L + r).any()) escaped_.note(t);  // through a wall
  }
  double angle = 0.0, dihedral = 0.0, dihedral_c = 0.0;
  const double drift = bond_drift(&angle, &dihedral, &dihedral_c);
  max_bond_drift_ = std::max(max_bond_drift_, drift);
  max_bond_angle_deg_ = std::max(max_bond_angle_deg_, angle);
  max_dihedral_deg_ = std::max(max_dihedral_deg_, dihedral);
  max_dihedral_c_ = std::max(max_dihedral_c_, dihedral_c);
  // A held bond that moved by more than the capture shell, or turned by
  // more than the angle window: the weld no longer holds the model's pose.
  // Articulated: a ball joint apart by more than the shell, a held angle
  // off by more than the angle window, or a held dihedral by more than the
  // coplanarity window.
  if (drift > p_.bonding.capture_distance || angle > p_.bonding.dtheta_deg || dihedral > p_.bonding.dphi_deg)
    joint_drift_.note(t);
}

nlohmann::json Peer::run() {
  const bool bonding = p_.bonding.enabled;
  {
    const auto [et, er, mom] = mechanics();
    e0_ = e_min_ = e_max_ = et + er;
    (void)mom;
  }
  std::string termination = "t_max";
  double t = 0.0;
  if (bonding) {
    g_graph = &graph_;
    g_articulated = articulated();
    g_one_two = p_.bonding.exclusions == Exclusions::OneTwo;
    // Pairs inside the shell at t = 0 (ringsim: rules checked at once, in
    // (sphere, linker, end) order); captures() sees them as entering.
    mirror(0.0);
    monitor_.set(0.0, graph_.N_t());
    captures(0.0);
    monitor_.advance(0.0);
    if (!bond_possible()) termination = "no_bond_possible";
  }
  const double t_max = p_.run.t_max;
  const double sample = p_.run.sample_interval;
  double next_check = sample;
  while (termination == "t_max") {
    // The last step ends at t_max exactly.
    const double h = std::min(opt_.dt, t_max - t);
    if (h <= 1e-12 * t_max) break;
    world_->stepSimulation(btScalar(h), 0, btScalar(h));
    ++steps_;
    t = std::abs(t + h - t_max) <= 1e-12 * t_max ? t_max : static_cast<double>(steps_) * opt_.dt;
    scan_contacts(t);
    if (bonding) {
      mirror(t);
      captures(t);
      if (!bond_possible()) termination = "no_bond_possible";
      if (monitor_.advance(t) && p_.run.steady_state && termination == "t_max") termination = "steady_state";
    }
    if (t >= next_check || t >= t_max) {
      next_check += sample;
      check_state(t);
      if (non_finite_.count > 0) {
        termination = "error";
        error_ = "the engine's state is no longer finite at t = " + std::to_string(t);
      }
    }
    if (p_.run.max_events > 0 && steps_ >= p_.run.max_events && termination == "t_max") termination = "event_budget";
  }
  check_state(t);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const auto [et, er, mom] = mechanics();
  const Observables o = graph_.observables(t);

  nlohmann::json j;
  j["version"] = kVersion;
  j["seed"] = nullptr;  // filled by the caller
  j["spheres"] = p_.init.spheres;
  j["linkers"] = p_.init.linkers;
  j["packing_fraction"] = scene_.packing_fraction;
  j["mixing"] = scene_.mixing;
  j["fallback_placements"] = scene_.fallback_placements;
  j["events"] = steps_;  // a step is the engine's unit of work
  j["collisions"] = collisions_;
  j["wall_collisions"] = wall_collisions_;
  j["t_end"] = t;
  j["termination"] = termination;
  if (termination == "error") j["error"] = error_;
  j["wall_seconds"] = wall;
  j["events_per_second"] = wall > 0 ? static_cast<double>(steps_) / wall : 0.0;
  j["energy"] = {{"translational", et}, {"rotational", er}};
  j["momentum"] = {mom.x(), mom.y(), mom.z()};
  j["energy_budget"] = {{"initial", e0_}, {"kinetic", et + er}};
  j["captures"] = captures_;
  j["bonds"] = bonds_;
  j["closure_bonds"] = closure_bonds_;
  j["rejected"] = {{"valency", rejected_valency_}, {"angle", rejected_angle_}, {"coplanarity", rejected_coplanarity_}};
  add_observables_json(j, o);  // the same fields as ringsim replicate --json
  if (termination == "steady_state") {
    const MserResult& m = monitor_.result();
    j["mser"] = {{"truncation", m.truncation}, {"batches", m.batches}, {"samples", monitor_.samples().size()}};
  }
  const double e_end = et + er;
  nlohmann::json peer;
  peer["engine"] = "bullet " + std::to_string(BT_BULLET_VERSION / 100) + "." + std::to_string(BT_BULLET_VERSION % 100);
  peer["precision"] = sizeof(btScalar) == sizeof(double) ? "double" : "single";
  peer["dt"] = opt_.dt;
  peer["steps"] = steps_;
  peer["joint"] = to_string(opt_.joint);
  if (articulated()) peer["exclusions"] = to_string(p_.bonding.exclusions);
  peer["contact_settings"] = opt_.bullet_defaults ? "bullet_defaults" : "elastic";
  peer["solver_iterations"] = opt_.solver_iterations;
  peer["energy_drift"] = e0_ > 0 ? e_end / e0_ - 1.0 : 0.0;
  peer["energy_min"] = e_min_;
  peer["energy_max"] = e_max_;
  peer["max_penetration"] = max_penetration_;
  peer["max_penetration_t"] = max_penetration_t_;
  peer["mean_step_penetration"] = steps_ > 0 ? sum_step_penetration_ / static_cast<double>(steps_) : 0.0;
  peer["bond_constraints"] = held_.size();
  // Constraints by kind: fixed (welded bonds), ball (articulated bonds),
  // held_angle (articulated, angle filter on), held_dihedral (articulated,
  // coplanarity filter on; of which held_dihedral_one_neighbour have one
  // linker as both neighbours, a ring of two spheres, and are identically
  // zero: held_dihedral.hpp).
  long one_neighbour = 0;
  for (const auto& hd : dihedrals_) one_neighbour += &hd->neighbour0() == &hd->neighbour1();
  peer["constraints"] = {{"fixed", articulated() ? 0 : held_.size()},
                         {"ball", articulated() ? held_.size() : 0},
                         {"held_angle", angles_.size()},
                         {"held_dihedral", dihedrals_.size()},
                         {"held_dihedral_one_neighbour", one_neighbour}};
  peer["max_bond_drift"] = max_bond_drift_;
  peer["max_bond_angle_drift_deg"] = max_bond_angle_deg_;
  // Held dihedrals: the largest |phi - phi0| (to the row's zero set, phi0 or
  // phi0 + pi; held_dihedral.hpp) and the largest |C|, at the checks.
  peer["max_dihedral_drift_deg"] = max_dihedral_deg_;
  peer["max_dihedral_residual"] = max_dihedral_c_;
  peer["skipped_dihedral_rows"] = solver_->skipped_rows();
  peer["failures"] = {{"non_finite", non_finite_.json()},
                      {"escaped", escaped_.json()},
                      {"deep_penetration", deep_penetration_.json()},
                      {"energy_blowup", energy_blowup_.json()},
                      {"energy_drain", energy_drain_.json()},
                      {"joint_drift", joint_drift_.json()},
                      {"drift_capture", drift_capture_.json()}};
  j["peer"] = peer;
  return j;
}

}  // namespace

nlohmann::json run_peer(const SimParams& params, std::uint64_t seed, std::uint64_t replicate, const PeerOptions& opt) {
  Peer peer(params, seed, replicate, opt);
  nlohmann::json j = peer.run();
  j["seed"] = seed;
  j["replicate"] = replicate;
  return j;
}

}  // namespace ringsim::peer
