// A progress bar on stderr for long batch runs, drawn only when stderr is a terminal.
#pragma once

#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>

namespace lunarnav::util {

/// Shows "label [#####     ] done/total rate/s ETA" on one stderr line.
/// Thread-safe; log lines printed while it is active appear above it.
class ProgressBar {
 public:
  /// @param total  number of items.
  /// @param label  what is counted (e.g. "pairs").
  /// @param enabled  false for --quiet; the bar is also off when stderr is not a terminal.
  ProgressBar(std::size_t total, std::string label, bool enabled);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  /// Marks one more item as finished.
  void Increment();

 private:
  std::string Render() const;

  std::size_t total_;
  std::size_t done_ = 0;
  std::string label_;
  bool active_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

namespace internal {
std::mutex& StderrMutex();
/// Called by the logger with StderrMutex held.
void ClearProgressLineLocked();
void RedrawProgressLineLocked();
}  // namespace internal

}  // namespace lunarnav::util
