// Wall-clock stopwatch for summaries.
#pragma once

#include <chrono>
#include <ctime>
#include <string>
#include <utility>
#include <vector>

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

/// The CPU time the calling thread has used, seconds (what a part of a parallel loop costs).
inline double ThreadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// Adds `more` to `total` stage by stage (by name), a stage `total` lacks appended in order.
inline void AddStages(const std::vector<std::pair<std::string, double>>& more,
                      std::vector<std::pair<std::string, double>>* total) {
  for (const auto& [name, seconds] : more) {
    auto at = total->begin();
    while (at != total->end() && at->first != name) ++at;
    if (at == total->end()) {
      total->emplace_back(name, seconds);
    } else {
      at->second += seconds;
    }
  }
}

/// Named stages' wall times, in the order they ran: Lap(name) ends the stage that began at the
/// last Lap (or at construction) and names it (docs/performance.md's per-stage profiles).
using StageTimes = std::vector<std::pair<std::string, double>>;
class StageClock {
 public:
  void Lap(std::string name) {
    stages_.emplace_back(std::move(name), timer_.ElapsedSeconds());
    timer_.Restart();
  }
  StageTimes Take() { return std::move(stages_); }

 private:
  Timer timer_;
  StageTimes stages_;
};

}  // namespace lunarnav::util
