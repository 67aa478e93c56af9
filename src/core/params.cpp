#include "core/params.hpp"

namespace ringsim {

// These names are the configuration values (docs/CONFIG.md); keep them
// lowercase and stable, they appear in scenario files and output provenance.

const char* to_string(Boundary b) {
  switch (b) {
    case Boundary::Reflective: return "reflective";
    case Boundary::Periodic: return "periodic";
  }
  return "?";
}

const char* to_string(CombineRule r) {
  switch (r) {
    case CombineRule::Min: return "min";
    case CombineRule::Max: return "max";
    case CombineRule::Product: return "product";
    case CombineRule::Mean: return "mean";
  }
  return "?";
}

const char* to_string(VelocityInit v) {
  switch (v) {
    case VelocityInit::Uniform: return "uniform";
    case VelocityInit::Thermal: return "thermal";
  }
  return "?";
}

const char* to_string(QueueKind q) {
  switch (q) {
    case QueueKind::Fast: return "fast";
    case QueueKind::Reference: return "reference";
  }
  return "?";
}

const char* to_string(CoplanarityMode m) {
  switch (m) {
    case CoplanarityMode::CisOrTrans: return "cis-or-trans";
    case CoplanarityMode::Cis: return "cis";
  }
  return "?";
}

const char* to_string(CaptureSite s) {
  switch (s) {
    case CaptureSite::EndFace: return "end_face";
    case CaptureSite::EndPoint: return "end_point";
  }
  return "?";
}

const char* to_string(BondJoint j) {
  switch (j) {
    case BondJoint::Articulated: return "articulated";
    case BondJoint::Welded: return "welded";
  }
  return "?";
}

const char* to_string(Exclusions e) {
  switch (e) {
    case Exclusions::OneThree: return "1-3";
    case Exclusions::OneTwo: return "1-2";
  }
  return "?";
}

const char* to_string(CompliantMethod m) {
  switch (m) {
    case CompliantMethod::Auto: return "auto";
    case CompliantMethod::Bdf: return "bdf";
    case CompliantMethod::Adams: return "adams";
    case CompliantMethod::Erk: return "erk";
  }
  return "?";
}

}  // namespace ringsim
