#include "core/allocator.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace ringsim {

void keep_freed_memory() {
#if defined(__GLIBC__)
  // Measured (Scenario 1, seed 1, t_max = 1000): 4.7 M page faults and
  // 134 s wall, 38 s of it in the kernel, against 4 thousand faults and
  // 51 s with these settings, the same trajectory to the last event. The
  // cost is memory that a process which once needed it keeps (a
  // replicate's peak, tens of MB).
  mallopt(M_MMAP_THRESHOLD, 32 << 20);   // blocks below 32 MB from the heap (glibc's largest setting)
  mallopt(M_TRIM_THRESHOLD, 512 << 20);  // the heap's free top returned only above 512 MB
#endif
}

}  // namespace ringsim
