#pragma once
// Wall time for the timings the summaries and reports carry: seconds on the steady clock
// (monotonic, so a clock adjustment during a solve cannot make a timing negative).
#include <chrono>
#include <ctime>

namespace tether {

/// Seconds elapsed on std::chrono::steady_clock since t0.
inline double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// CPU seconds the calling thread has used since it started (user and system). Called first
/// thing in main(), it is the process's start-up: exec, the dynamic loader mapping and
/// relocating the shared libraries, and their constructors, all of which run on the main
/// thread before main(); -1 where the clock is not available.
inline double ThreadCpuSeconds() {
  timespec t{};
  if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t) != 0) return -1;
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace tether
