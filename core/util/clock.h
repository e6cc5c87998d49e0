// Host wall time for stats and limits: one steady clock and one way to read milliseconds.
#pragma once

#include <chrono>

namespace vismap {

using Clock = std::chrono::steady_clock;

inline double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace vismap
