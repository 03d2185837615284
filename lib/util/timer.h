// Wall-clock stopwatch for summaries.
#pragma once

#include <chrono>

namespace lunarnav::util {

/// Measures elapsed wall time from construction or the last Restart().
class Timer {
 public:
  Timer() : start_(std::chrono::steady_clock::now()) {}
  void Restart() { start_ = std::chrono::steady_clock::now(); }
  double ElapsedSeconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  double ElapsedMs() const { return 1e3 * ElapsedSeconds(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace lunarnav::util
