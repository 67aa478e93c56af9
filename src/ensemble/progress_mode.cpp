#include "ensemble/progress_mode.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <string>

namespace ringsim {

namespace {

bool under_mpi_launcher() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE"})
    if (std::getenv(v)) return true;
  return false;
}

// The parent's pid and the command name (comm) of process `pid`, from
// /proc/PID/stat: "pid (comm) state ppid ...". comm may hold spaces or ')'.
bool proc_stat(long pid, long* ppid, std::string* comm) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string s;
  if (!std::getline(in, s)) return false;
  const auto open = s.find('('), close = s.rfind(')');
  if (open == std::string::npos || close == std::string::npos || close + 4 > s.size()) return false;
  *comm = s.substr(open + 1, close - open - 1);
  // After ") " come the state (one character), a space, then the ppid.
  *ppid = std::strtol(s.c_str() + close + 4, nullptr, 10);
  return true;
}

bool is_launcher(const std::string& comm) {
  for (const char* name : {"mpirun", "mpiexec", "orterun", "prterun", "mpiexec.hydra"})
    if (comm == name) return true;
  return false;
}

}  // namespace

bool launcher_stderr_is_terminal() {
  if (!under_mpi_launcher()) return false;
  long pid = static_cast<long>(getppid());
  // The launcher is the parent (Open MPI, one node) or a few levels up (a
  // daemon or proxy in between); stop at init.
  for (int depth = 0; depth < 8 && pid > 1; ++depth) {
    long ppid = 0;
    std::string comm;
    if (!proc_stat(pid, &ppid, &comm)) return false;
    if (is_launcher(comm)) {
      // Open the launcher's stderr (the same open file) to ask isatty; no
      // controlling terminal is acquired, nothing is written.
      const int fd = ::open(("/proc/" + std::to_string(pid) + "/fd/2").c_str(), O_WRONLY | O_NOCTTY | O_NONBLOCK);
      if (fd < 0) return false;
      const bool tty = isatty(fd) == 1;
      ::close(fd);
      return tty;
    }
    pid = ppid;
  }
  return false;
}

ProgressForm resolve_progress(const std::string& mode) {
  if (mode == "bar") return ProgressForm::Bar;
  if (mode == "log") return ProgressForm::Log;
  if (mode == "none") return ProgressForm::None;
  return isatty(STDERR_FILENO) == 1 || launcher_stderr_is_terminal() ? ProgressForm::Bar : ProgressForm::Log;
}

}  // namespace ringsim
