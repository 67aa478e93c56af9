#pragma once
// The default form of `ringsim run`'s progress (--progress auto): a live bar
// when a person is watching, plain timestamped lines otherwise.
//
// The rule (docs/ENSEMBLE.md, "Progress"): the bar when rank 0's stderr is a
// terminal; under an MPI launcher, whose ranks write into pipes, the bar when
// the launcher's own stderr is a terminal (an interactive `mpirun` in a
// shell); lines otherwise (a batch job, a redirect to a file or a pipe).

#include <string>

namespace ringsim {

enum class ProgressForm { Bar, Log, None };

// True when this process runs under an MPI launcher (Open MPI's
// OMPI_COMM_WORLD_SIZE, PMIx's PMIX_RANK or MPICH's PMI_SIZE is set) and the
// nearest ancestor process named mpirun, mpiexec, orterun, prterun or
// mpiexec.hydra has a terminal on its stderr. Linux (/proc) only; false when
// the launcher cannot be found or inspected (e.g. rank 0 on another node).
bool launcher_stderr_is_terminal();

// --progress bar, log, none as given; auto by the rule above.
ProgressForm resolve_progress(const std::string& mode);

}  // namespace ringsim
