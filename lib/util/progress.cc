#include "util/progress.h"

#include <unistd.h>

#include <cstdio>
#include <sstream>

namespace lunarnav::util {
namespace {
ProgressBar* g_active = nullptr;        // guarded by StderrMutex()
std::string g_line;                      // the bar as last drawn, guarded by StderrMutex()
}  // namespace

namespace internal {
std::mutex& StderrMutex() {
  static std::mutex mutex;
  return mutex;
}
void ClearProgressLineLocked() {
  if (g_active != nullptr && !g_line.empty()) std::fputs("\r\033[K", stderr);
}
void RedrawProgressLineLocked() {
  if (g_active != nullptr && !g_line.empty()) {
    std::fputs(g_line.c_str(), stderr);
    std::fflush(stderr);
  }
}
}  // namespace internal

ProgressBar::ProgressBar(std::size_t total, std::string label, bool enabled)
    : total_(total),
      label_(std::move(label)),
      active_(enabled && total > 1 && isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()) {
  if (!active_) return;
  std::lock_guard<std::mutex> lock(internal::StderrMutex());
  g_active = this;
  g_line = Render();
  internal::RedrawProgressLineLocked();
}

ProgressBar::~ProgressBar() {
  if (!active_) return;
  std::lock_guard<std::mutex> lock(internal::StderrMutex());
  internal::ClearProgressLineLocked();
  std::fflush(stderr);
  g_active = nullptr;
  g_line.clear();
}

void ProgressBar::Increment() {
  if (!active_) return;
  std::lock_guard<std::mutex> lock(internal::StderrMutex());
  ++done_;
  const auto now = std::chrono::steady_clock::now();
  if (done_ != total_ && now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  internal::ClearProgressLineLocked();
  g_line = Render();
  internal::RedrawProgressLineLocked();
}

std::string ProgressBar::Render() const {
  constexpr int kWidth = 30;
  const double fraction = total_ == 0 ? 1.0 : static_cast<double>(done_) / static_cast<double>(total_);
  const int filled = static_cast<int>(fraction * kWidth);
  const double elapsed_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::ostringstream s;
  s << label_ << " [" << std::string(filled, '#') << std::string(kWidth - filled, ' ') << "] "
    << done_ << "/" << total_;
  if (done_ > 0 && elapsed_s > 0) {
    const double rate = static_cast<double>(done_) / elapsed_s;
    s.precision(3);
    s << "  " << rate << "/s  ETA " << static_cast<long>((total_ - done_) / rate) << " s";
  }
  return s.str();
}

}  // namespace lunarnav::util
