#include "util/log.h"

#include <unistd.h>

#include <algorithm>
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

std::string BoundedMessage(const std::string& message, std::size_t max_bytes) {
  std::string out;
  out.reserve(std::min(message.size(), max_bytes) + 16);
  std::size_t used = 0;
  for (; used < message.size() && out.size() < max_bytes; ++used) {
    const auto c = static_cast<unsigned char>(message[used]);
    if (c < 0x20 || c == 0x7F) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02X", c);
      out += hex;
    } else {
      out += static_cast<char>(c);
    }
  }
  if (used < message.size()) out += " ... (" + std::to_string(message.size() - used) + " more bytes)";
  return out;
}

void LogLine(LogLevel level, const std::string& line) {
  if (level > g_level) return;
  std::string text;
  if (level == LogLevel::kError) text = "error: ";
  if (level == LogLevel::kWarning) text = "warning: ";
  text += BoundedMessage(line);
  text += '\n';
  std::lock_guard<std::mutex> lock(internal::StderrMutex());
  internal::ClearProgressLineLocked();
  std::fwrite(text.data(), 1, text.size(), stderr);
  std::fflush(stderr);
  internal::RedrawProgressLineLocked();
}

}  // namespace lunarnav::util
