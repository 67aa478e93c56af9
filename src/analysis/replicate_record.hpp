#pragma once
// One replicate's result as a fixed-size row: the layout of the HDF5
// compound dataset `/replicates` (docs/OUTPUT.md), the payload ranks send to
// rank 0, and the input of the ensemble summary and the `aggregate` tables.
//
// Field names are those of `ringsim replicate --json`. The ring-size
// histogram is flattened into scalar columns (ring_2 counts the m < 3 rings,
// ring_3 ... ring_12, ring_over the m > 12 ones) so that
// `pandas.DataFrame(h5py.File(f)["replicates"][()])` works as is.
// Undefined values (S4 without rings) are NaN, never 0.

#include <array>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>

namespace ringsim {

enum class RecordStatus : std::int8_t {
  Pending = 0,  // not run yet (or lost in flight): `--resume` runs it
  Ok = 1,       // finished: steady_state, t_max or no_bond_possible
  Failed = 2,   // finished with an error or an exhausted event budget (see `termination`, `error`)
};

struct ReplicateRecord {
  std::uint64_t id = 0;    // replicate index r in 0 .. R-1
  std::uint64_t seed = 0;  // base seed S; the replicate is `ringsim replicate --seed S --replicate r`
  std::int8_t status = 0;  // RecordStatus
  char termination[24] = {};  // steady_state | t_max | no_bond_possible | event_budget | error
  char error[104] = {};       // message when status is Failed, else empty; at most 103 chars: longer ones are cut to 100 + "..."
  double t_end = 0.0;
  std::uint64_t events = 0;
  double wall_seconds = 0.0;  // measured: the only field that differs between identical runs

  // The study's observables at t_end (MODEL.md "Observables"; fractions, not percent).
  std::int32_t N_t = 0, N_tar = 0, N_viab = 0, N_nv1 = 0, N_nv2 = 0, N_nv3 = 0, N_cyc = 0;
  double Phi_obj = 0.0, Phi_viab = 0.0;
  double S4 = 0.0;  // NaN when N_cyc == 0
  double M_mono = 0.0, M_mono_S = 0.0, M_mono_L = 0.0;
  double tau_tar = 0.0;               // first time N_tar >= 1, or t_end when censored
  std::int8_t tau_tar_censored = 1;  // 1: no target formed before t_end

  static constexpr int kRingBins = 10;            // m = 3 .. 12
  std::int32_t ring_2 = 0;                        // rings with m < 3 (m = 1, 2)
  std::array<std::int32_t, kRingBins> ring{};     // ring[m - 3] = N_m; columns ring_3 .. ring_12
  std::int32_t ring_over = 0;                     // m > 12

  // Run statistics.
  std::uint64_t collisions = 0, captures = 0;
  std::int32_t bonds = 0, closure_bonds = 0;
  std::int64_t mser_truncation = -1;  // index into the N_t series when steady_state, else -1
  double packing_fraction = 0.0, mixing = 0.0;

  // Articulated bonds (bonding.joint = articulated; zero otherwise): how
  // closely the joints were held, as `replicate --json`'s "articulated"
  // block names them (docs/OUTPUT.md). Files written before these columns
  // read them as zero.
  std::int64_t failed_slices = 0, released_held_rows = 0, readmitted_held_rows = 0;
  double max_residual_after_projection = 0.0, max_cut_residual = 0.0, max_released_residual = 0.0;
  double max_projection = 0.0;
  std::int32_t end_rigid_bodies = 0, end_articulated_bodies = 0;  // bodies in rigid / integrated clusters at t_end
};

// A row with only its identity, status and termination set (observables
// zero, S4 NaN, padding zero): a pending row, or a replicate that failed
// before producing observables.
inline ReplicateRecord blank_record(std::uint64_t id, std::uint64_t seed, RecordStatus status,
                                    const char* termination, const std::string& error = "") {
  ReplicateRecord r{};
  r.id = id;
  r.seed = seed;
  r.status = static_cast<std::int8_t>(status);
  std::snprintf(r.termination, sizeof r.termination, "%s", termination);
  // A message longer than the fixed field keeps its first 100 characters
  // and ends in "..." so a reader sees it was cut (the full text is in
  // `ringsim replicate --seed S --replicate r`).
  if (error.size() < sizeof r.error) std::snprintf(r.error, sizeof r.error, "%s", error.c_str());
  else std::snprintf(r.error, sizeof r.error, "%.*s...", static_cast<int>(sizeof r.error) - 4, error.c_str());
  r.S4 = std::numeric_limits<double>::quiet_NaN();
  return r;
}

}  // namespace ringsim
