// The programs' malloc policy (boresight and boresightd call it first thing in main).
#pragma once

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace boresight::tools {

/// Buffers of 1 MB and more straight from the system and back to it when freed. glibc's default raises
/// this threshold to the size of every such buffer freed (up to 32 MB), after which the next ones come
/// from the heaps of the threads that asked and stay resident there. Measured: `calibrate --window`
/// with two windows at a time 448 -> 362 MB over three days; boresightd's worker with `method:
/// attitude` on a day 163 -> 147 MB. The real-time core allocates nothing after configuration, so its
/// thread never meets the system calls this adds.
inline void returnLargeBuffersToTheSystem() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 1 << 20);
#endif
}

}  // namespace boresight::tools
