#include "util/log.h"

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <mutex>

#include "util/progress.h"

namespace lunarnav::util {
namespace {
std::atomic<LogLevel> g_level{LogLevel::kInfo};
}  // namespace

void SetLogLevel(LogLevel level) { g_level = level; }
LogLevel GetLogLevel() { return g_level; }

void LogLine(LogLevel level, const std::string& line) {
  if (level > g_level) return;
  std::string text;
  if (level == LogLevel::kError) text = "error: ";
  if (level == LogLevel::kWarning) text = "warning: ";
  text += line;
  text += '\n';
  std::lock_guard<std::mutex> lock(internal::StderrMutex());
  internal::ClearProgressLineLocked();
  std::fwrite(text.data(), 1, text.size(), stderr);
  std::fflush(stderr);
  internal::RedrawProgressLineLocked();
}

}  // namespace lunarnav::util
