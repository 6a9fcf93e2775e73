// Wall-clock timing of passes, frames and references (metrics.csv's ms_* columns): one clock for all of them.
#pragma once

#include <chrono>

namespace restir {

using Clock = std::chrono::steady_clock;

// Milliseconds from t0 to now.
inline double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace restir
