#pragma once
// The process's memory allocator settings (docs/PERFORMANCE.md, "Allocator").

namespace ringsim {

// Freed memory stays in the process for the next allocation of its size:
// an articulated cluster's dense matrices (G, S, M^-1 G^T, the factors'
// work space: hundreds of KB once a cluster has tens of linkers) are made
// and freed many times per slice, and with glibc's adaptive defaults each
// free at the top of the heap went back to the system and each new block
// faulted its pages in again while it was zeroed. Called first thing by
// ringsim's main and the benchmarks that time such code. No effect off glibc.
void keep_freed_memory();

}  // namespace ringsim
