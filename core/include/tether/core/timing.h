#pragma once
// Wall time for the timings the summaries and reports carry: seconds on the steady clock
// (monotonic, so a clock adjustment during a solve cannot make a timing negative).
#include <chrono>

namespace tether {

/// Seconds elapsed on std::chrono::steady_clock since t0.
inline double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace tether
