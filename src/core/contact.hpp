#pragma once
// Impulsive hard contacts between two rigid bodies (or a body and a wall).
//
// Conventions: the normal n points from body A to body B; J is the impulse on
// B (A receives -J). The relative velocity at the contact point is
// u = (v_B + w_B x r_B) - (v_A + w_A x r_A), approaching when n.u < 0, and an
// impulse J changes it by K J with the collision matrix
//   K = (1/m_A + 1/m_B) 1 - [r_A]x I_A^-1 [r_A]x - [r_B]x I_B^-1 [r_B]x
// (Mirtich, "Impulse-based dynamic simulation", 1996, ch. 4).
//
// Normal law: Newton restitution, n.u' = -e n.u.
// Tangential law (impulsive Coulomb): the impulse that makes the tangential
// velocity vanish is used when it lies inside the static friction cone
// |J_t| <= mu_s J_n ("sticking"); otherwise the body slides and the tangential
// impulse is nu * J_n against the incoming tangential velocity.
// Friction 0 gives smooth contacts (J along n).

#include "core/params.hpp"
#include "core/vec.hpp"

namespace ringsim {

struct ContactSide {
  double inv_mass;   // 0 for a wall
  Mat3 inv_inertia;  // world frame; zero for a wall or where spin is irrelevant
  Vec3 arm;          // contact point - centre of mass
  Vec3 v;            // centre velocity
  Vec3 omega;        // angular velocity
  // A side whose velocities are constrained (a member of an articulated
  // cluster, core/joint_impulses.hpp): its share of the collision matrix is
  // k, given, instead of the rigid body's inv_mass 1 - [arm]x inv_inertia [arm]x.
  bool explicit_k = false;
  Mat3 k = Mat3::Zero();
};

struct ContactLaw {
  double restitution;
  double static_friction;
  double dynamic_friction;
  // Floor of the normal separation speed after an elastic (e = 1) impulse
  // (0 = none): a top-up along n when Newton's law leaves n.u' below it
  // (inelastic contacts keep their law; the TC model makes quick repeats
  // elastic, and so floored). Resting contacts
  // of two turning bodies otherwise bounce at ~1e-12 for ever, inside the
  // contact band (docs/ARCHITECTURE.md, "Contact response").
  double min_separation = 0.0;
};

enum class ContactMode { Smooth, Stick, Slide };

struct ContactResult {
  Vec3 impulse;      // on B
  ContactMode mode;
  bool floored = false;  // the separation-speed floor added to the impulse
  double energy_loss = 0.0;  // kinetic energy the impulse took out (impulse_energy_loss)
};

ContactResult solve_contact(const ContactSide& a, const ContactSide& b, const Vec3& n, const ContactLaw& law);

// A contact that fired while the pair does not approach along n: a pair left
// touching at zero normal speed (restitution 0) that rounding shows to the
// prediction as approaching and to the contact frame as separating. No
// restitution impulse, but the separation floor as for an elastic contact, so
// that the pair leaves instead of firing again at the same instant for ever
// (found by a sweep: contact.restitution_sphere = 0 froze time).
ContactResult separation_floor(const ContactSide& a, const ContactSide& b, const Vec3& n, const ContactLaw& law);

// The normal impulse the separation floor adds (law.min_separation, elastic
// contacts only) when an impulse leaves the contact separating at normal
// speed un_after; k_nn = n.K.n, the normal speed one unit of impulse along n
// makes. 0 when the floor does not apply.
double floor_impulse(double un_after, double k_nn, const ContactLaw& law);
// The same for a pair that fired without approaching (normal speed un >= 0,
// no restitution impulse): the floor applies whatever the restitution
// (separation_floor; the sphere gas's collisions use it directly).
double floor_impulse_at_rest(double un, double k_nn, const ContactLaw& law);
// Whether the response to a contact at normal speed un (B relative to A,
// positive: separating) acts on it, for a predictor deciding if the contact
// fires: it approaches, or the floor above (min_separation > 0) tops it up. A
// point separating at the floor up to a millionth of it counts as leaving:
// the top-up (the shortfall, ~1e-17 right after a floored impulse) could be
// too small to change any velocity, and the same contact would fire again at
// the same instant (Predictor::wall_contact).
inline bool response_acts(double un, double min_separation) { return un < (1.0 - 1e-6) * min_separation; }

// Kinetic energy an impulse J on B (-J on A) takes out of the pair: with u the
// relative velocity of the contact points (B minus A), before and after,
// -J . (u- + u+) / 2, exact for rigid bodies: a body's energy changes by
// dP . (v- + v+) / 2 + dL . (w- + w+) / 2 with dP = J, dL = arm x J, which sums
// to J . (its contact point's velocity before + after) / 2. Negative when the
// impulse adds energy.
double impulse_energy_loss(const ContactSide& a, const ContactSide& b, const Vec3& J);

// Velocity of B's contact point minus A's (v + omega x arm of each side).
Vec3 relative_point_velocity(const ContactSide& a, const ContactSide& b);

double combine(CombineRule rule, double a, double b);

}  // namespace ringsim
