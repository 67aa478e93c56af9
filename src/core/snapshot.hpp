#pragma once
// Configuration snapshots for visualisation: extended XYZ (OVITO 3, and our
// own reader), legacy VTK PolyData (ParaView). Format details, the property
// mapping and how to open the files: docs/OUTPUT.md, "Snapshots".
//
// Invariants of a Snapshot (checked by the writers and the reader):
//  - bodies[i] is body id i (spheres and linkers in any order, usually
//    spheres first, as in BodyStore);
//  - every number is finite; radius > 0; spheres have half_length == 0;
//    linkers have half_length > 0 and a unit axis (|axis| - 1 <= 1e-6);
//  - bonds are (sphere id, linker id) pairs of valid ids; a pair may repeat
//    (one linker with both ends on one sphere, at a large capture distance);
//  - bond_ends is empty (unknown) or holds one end per bond, 0 (a = x + h u)
//    or 1 (b = x - h u), and no (linker, end) twice;
//  - comment has no '"', '\\', '\n' or '\r' (it is written as a quoted
//    extended XYZ value, and OVITO's parser knows no escapes).
// Units are reduced (length = sphere radius), box = [0, box_length]^3.
#include <iosfwd>
#include <string>
#include <utility>
#include <vector>

#include "core/vec.hpp"

namespace ringsim {

struct SnapshotBody {
  bool sphere;          // true: sphere; false: linker (solid cylinder)
  Vec3 x;               // centre (inside the box)
  Vec3 axis;            // unit axis (linkers; spheres: any)
  double radius;
  double half_length;   // 0 for spheres
  int object;           // connected component id in the bond graph (for colouring)
};

struct Snapshot {
  double time = 0.0;
  double box_length = 0.0;
  bool periodic = false;
  std::vector<SnapshotBody> bodies;          // index = body id
  std::vector<std::pair<int, int>> bonds;    // (sphere id, linker id)
  // The bonded end of each bond's linker (0 = a, 1 = b), parallel to bonds;
  // empty when unknown (files without it), and then the end nearest the
  // sphere stands in for it (wrong only when both ends are within the
  // capture shell, a capture distance of about a linker length).
  std::vector<int> bond_ends;
  std::string comment;                       // free text (scenario, seed), no newlines
};

// (orientation_from_axis, core/vec.hpp, gives the Orientation column.)

// Extended XYZ, one frame. Throws std::invalid_argument when `s` breaks the
// invariants above (naming the body, bond or field).
void write_extended_xyz(std::ostream& out, const Snapshot& s);

// Reads one frame written by write_extended_xyz (columns are found by name in
// Properties, so reordered or extra columns are accepted). Throws
// std::runtime_error "extended XYZ line N: ..." on malformed input.
Snapshot read_extended_xyz(std::istream& in);

// Legacy VTK (version 3.0, ASCII) PolyData: one vertex per body and one line
// per bond, with point arrays for ParaView's Glyph filter. Throws
// std::invalid_argument like write_extended_xyz.
void write_vtk(std::ostream& out, const Snapshot& s);

}  // namespace ringsim
