// CPU seconds, the cost measure of runs and benchmarks (never the wall time of a shared machine).
#pragma once
#include <time.h>

namespace jamflow {

// CPU seconds of the calling thread (CLOCK_THREAD_CPUTIME_ID), or with `process` of the whole
// process (CLOCK_PROCESS_CPUTIME_ID: it counts an OpenMP team, and anything else the process
// does meanwhile). 0 if the clock is not available.
inline double cpu_clock(bool process = false) {
  timespec ts{};
  if (clock_gettime(process ? CLOCK_PROCESS_CPUTIME_ID : CLOCK_THREAD_CPUTIME_ID, &ts) != 0)
    return 0.0;
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

}  // namespace jamflow
