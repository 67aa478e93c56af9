#pragma once
// Dynamic work distribution over MPI ranks (docs/ARCHITECTURE.md "Ensemble").
//
// Every rank computes. On each rank a compute thread runs replicates (no MPI
// calls); the main thread does all MPI communication (MPI_THREAD_FUNNELED),
// polling with short sleeps so it costs no CPU while replicates run.
// Rank 0's main thread is also the coordinator: it hands out replicate ids
// one at a time to whichever rank asks (its own compute thread included),
// receives each result with the finished rank's next request, and passes it
// to `on_result` (which persists it). Run times vary a lot between
// replicates, so first come, first served balances the load.
//
// Stopping. SIGTERM, SIGUSR1 or SIGINT on any rank (Slurm's time limit,
// preemption, Ctrl-C) interrupts the running replicates (they are dropped,
// not recorded), results already finished are still delivered, and every
// rank leaves run_schedule with ScheduleEnd::Interrupted. The same happens
// when `on_result` throws (e.g. the disk fills up): ScheduleEnd::Failed.

#include <mpi.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "analysis/replicate_record.hpp"

namespace ringsim {

struct ReplicateOutput {
  ReplicateRecord record;
  std::vector<float> series;  // exactly series_length values (NaN-padded), or empty when series_length == 0
  bool interrupted = false;   // stopped before the end: not a result
};

// Runs replicate `id`; must return soon after `stop` turns true (with
// interrupted = true) and must not throw.
using ComputeFn = std::function<ReplicateOutput(std::uint64_t id, const std::atomic<bool>& stop)>;

struct CoordinatorHooks {
  std::function<void(const ReplicateOutput&)> on_result;  // rank 0, main thread; may throw
  std::function<void()> on_tick;                          // rank 0, main thread, every poll (~ms)
};

enum class ScheduleEnd { Complete, Interrupted, Failed };

// Installs handlers for SIGTERM, SIGUSR1 and SIGINT that only record the
// signal (a second SIGINT kills as usual). Returns the flag they set
// (0, or the signal number).
const std::atomic<int>& install_stop_signals();

// Collective over `comm`. `ids` (read on rank 0 only) are the replicates to
// run, handed out in this order. `failure` (rank 0) receives the message of a
// throwing `on_result`.
ScheduleEnd run_schedule(MPI_Comm comm, const std::vector<std::uint64_t>& ids, const ComputeFn& compute,
                         std::size_t series_length, const CoordinatorHooks& hooks, std::string* failure = nullptr);

// Waits for a non-blocking MPI request while sleeping between tests: a rank
// that waits does not take CPU from ranks still computing on the same node
// (Open MPI's blocking calls spin).
void wait_politely(MPI_Request* request);

}  // namespace ringsim
